#include <float.h>
#include <math.h>

#include "sc_families.h"

static const char *const names[SC_FAM_COUNT] = {
    "random",
    "cap-1e-4", "cap-1e-5", "cap-1e-6", "cap-1e-7",
    "needle-1e-4", "needle-1e-5", "needle-1e-6", "needle-1e-7",
    "far-1e3", "far-1e4", "far-1e5",
    "scale-1e-20", "scale-1e-30", "scale-1e18",
    "right", "duplicate", "collinear", "nonfinite", "subnormal",
};

const char *sc_family_name(sc_family f)
{
    return (unsigned)f < SC_FAM_COUNT ? names[f] : "unknown";
}

int sc_family_expected(sc_family f)
{
    switch (f) {
    case SC_FAM_DUPLICATE:
    case SC_FAM_COLLINEAR: return 1;
    case SC_FAM_NONFINITE: return 2;
    default:               return 0;
    }
}

static void unit_vector(sc_rng *r, double v[3])
{
    for (;;) {
        double s = 0;
        for (int i = 0; i < 3; i++) {
            v[i] = sc_rng_range(r, -1, 1);
            s += v[i] * v[i];
        }
        if (s > 1e-4 && s <= 1) {
            s = sqrt(s);
            for (int i = 0; i < 3; i++)
                v[i] /= s;
            return;
        }
    }
}

/* A unit vector orthogonal to unit vector d. */
static void orthogonal_unit(sc_rng *r, const double d[3], double p[3])
{
    for (;;) {
        double v[3];
        unit_vector(r, v);
        double k = v[0] * d[0] + v[1] * d[1] + v[2] * d[2];
        double s = 0;
        for (int i = 0; i < 3; i++) {
            p[i] = v[i] - k * d[i];
            s += p[i] * p[i];
        }
        if (s > 1e-2) {
            s = sqrt(s);
            for (int i = 0; i < 3; i++)
                p[i] /= s;
            return;
        }
    }
}

static void random_in_cube(sc_rng *r, double half, double v[3])
{
    for (int i = 0; i < 3; i++)
        v[i] = sc_rng_range(r, -half, half);
}

static int small_int(sc_rng *r, int lo, int hi)
{
    return lo + (int)(sc_rng_next(r) % (uint64_t)(hi - lo + 1));
}

void sc_family_triangle(sc_family f, sc_rng *r, int as_float, double V[3][3])
{
    double d[3], p[3], base[3];
    switch (f) {
    case SC_FAM_CAP_1E4: case SC_FAM_CAP_1E5: case SC_FAM_CAP_1E6: case SC_FAM_CAP_1E7: {
        /* Base of length 1, apex over an interior point at height h. */
        double h = pow(10.0, -4.0 - (f - SC_FAM_CAP_1E4));
        random_in_cube(r, 1, base);
        unit_vector(r, d);
        orthogonal_unit(r, d, p);
        double t = sc_rng_range(r, 0.1, 0.9);
        for (int i = 0; i < 3; i++) {
            V[0][i] = base[i];
            V[1][i] = base[i] + d[i];
            V[2][i] = base[i] + t * d[i] + h * p[i];
        }
        break;
    }
    case SC_FAM_NEEDLE_1E4: case SC_FAM_NEEDLE_1E5: case SC_FAM_NEEDLE_1E6: case SC_FAM_NEEDLE_1E7: {
        /* Two long edges of length ~1 and one short edge of length w. */
        double w = pow(10.0, -4.0 - (f - SC_FAM_NEEDLE_1E4));
        random_in_cube(r, 1, base);
        unit_vector(r, d);
        unit_vector(r, p);
        for (int i = 0; i < 3; i++) {
            V[0][i] = base[i];
            V[1][i] = base[i] + d[i];
            V[2][i] = base[i] + d[i] + w * p[i];
        }
        break;
    }
    case SC_FAM_FAR_1E3: case SC_FAM_FAR_1E4: case SC_FAM_FAR_1E5: {
        double dist = pow(10.0, 3.0 + (f - SC_FAM_FAR_1E3));
        unit_vector(r, d);
        for (int k = 0; k < 3; k++) {
            random_in_cube(r, 0.5e-3, p);
            for (int i = 0; i < 3; i++)
                V[k][i] = dist * d[i] + p[i];
        }
        break;
    }
    case SC_FAM_SCALE_1EM20: case SC_FAM_SCALE_1EM30: case SC_FAM_SCALE_1E18: {
        double s = f == SC_FAM_SCALE_1EM20 ? 1e-20 : f == SC_FAM_SCALE_1EM30 ? 1e-30 : 1e18;
        for (int k = 0; k < 3; k++) {
            random_in_cube(r, 1, p);
            for (int i = 0; i < 3; i++)
                V[k][i] = s * p[i];
        }
        break;
    }
    case SC_FAM_RIGHT: {
        /* legs (p, q, 0) and (-q t, p t, s) are orthogonal in exact integers */
        int P = small_int(r, -50, 50), Q = small_int(r, -50, 50);
        int T = small_int(r, 1, 9), S = small_int(r, -50, 50);
        if (P == 0 && Q == 0) P = 1;
        int o[3] = { small_int(r, -1000, 1000), small_int(r, -1000, 1000), small_int(r, -1000, 1000) };
        double a[3] = { P, Q, 0 }, b[3] = { -Q * T, P * T, S };
        for (int i = 0; i < 3; i++) {
            V[0][i] = o[i] + a[i];
            V[1][i] = o[i] + b[i];
            V[2][i] = o[i];
        }
        break;
    }
    case SC_FAM_DUPLICATE: {
        double W[3][3];
        random_in_cube(r, 1, W[0]);
        random_in_cube(r, 1, W[1]);
        int src = small_int(r, 0, 1), rot = small_int(r, 0, 2);
        for (int i = 0; i < 3; i++)
            W[2][i] = W[src][i];
        for (int k = 0; k < 3; k++)
            for (int i = 0; i < 3; i++)
                V[k][i] = W[(k + rot) % 3][i];
        break;
    }
    case SC_FAM_COLLINEAR: {
        /* Small integers: exactly collinear also after rounding to float. */
        int a[3], s[3], t = small_int(r, -5, 5), u = small_int(r, -5, 5);
        for (int i = 0; i < 3; i++) {
            a[i] = small_int(r, -1000, 1000);
            s[i] = small_int(r, -100, 100);
        }
        for (int i = 0; i < 3; i++) {
            V[0][i] = a[i];
            V[1][i] = a[i] + t * s[i];
            V[2][i] = a[i] + u * s[i];
        }
        break;
    }
    case SC_FAM_NONFINITE: {
        for (int k = 0; k < 3; k++)
            random_in_cube(r, 1, V[k]);
        static const double bad[3] = { NAN, INFINITY, -INFINITY };
        V[small_int(r, 0, 2)][small_int(r, 0, 2)] = bad[small_int(r, 0, 2)];
        break;
    }
    case SC_FAM_SUBNORMAL: {
        /* Deep in the subnormal range of the working precision. */
        double s = as_float ? 1e-41 : 1e-312;
        for (int k = 0; k < 3; k++) {
            random_in_cube(r, 1, p);
            for (int i = 0; i < 3; i++)
                V[k][i] = s * p[i];
        }
        break;
    }
    case SC_FAM_RANDOM:
    default:
        for (int k = 0; k < 3; k++)
            random_in_cube(r, 1, V[k]);
        break;
    }
    /* A random vertex order, so "origin as given" meets every configuration
     * (for a needle: C at the far tip, or at one end of the short edge). */
    int rot = small_int(r, 0, 2);
    double W[3][3];
    for (int k = 0; k < 3; k++)
        for (int i = 0; i < 3; i++)
            W[k][i] = V[(k + rot) % 3][i];
    for (int k = 0; k < 3; k++)
        for (int i = 0; i < 3; i++)
            V[k][i] = W[k][i];
    if (as_float)
        for (int k = 0; k < 3; k++)
            for (int i = 0; i < 3; i++) {
                /* volatile: the rounding must happen (docs/numerics.md) */
                volatile float x = (float)V[k][i];
                V[k][i] = x;
            }
}
