/* MPFR references. See sc_reference.h for the contract. */
#include <float.h>
#include <math.h>
#include <stdlib.h>

#include "sc_reference.h"

/* Bits needed to hold any difference of the given doubles exactly: from the
 * highest set bit of the largest to the lowest possible bit of the smallest. */
static mpfr_prec_t diff_bits(const double *v, int count)
{
    int emax = INT_MIN, emin = INT_MAX;
    for (int i = 0; i < count; i++) {
        if (v[i] == 0 || !isfinite(v[i]))
            continue;
        int e = ilogb(v[i]);
        if (e > emax) emax = e;
        int lsb = e - (DBL_MANT_DIG - 1);
        if (lsb < -1074) lsb = -1074;
        if (lsb < emin) emin = lsb;
    }
    if (emax == INT_MIN)
        return 64;
    return (mpfr_prec_t)(emax - emin + 2);
}

static int all_finite(const double *v, int count)
{
    for (int i = 0; i < count; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

void sc_ref_sphere_init(sc_ref_sphere *s)
{
    for (int i = 0; i < 3; i++)
        mpfr_init2(s->c[i], SC_REF_MIN_PREC);
    mpfr_init2(s->r2, SC_REF_MIN_PREC);
}

void sc_ref_sphere_clear(sc_ref_sphere *s)
{
    for (int i = 0; i < 3; i++)
        mpfr_clear(s->c[i]);
    mpfr_clear(s->r2);
}

typedef struct vec3m { mpfr_t x[3]; } vec3m;

static void v_init(vec3m *v, mpfr_prec_t p)
{
    for (int i = 0; i < 3; i++)
        mpfr_init2(v->x[i], p);
}

static void v_clear(vec3m *v)
{
    for (int i = 0; i < 3; i++)
        mpfr_clear(v->x[i]);
}

static void v_set_diff(vec3m *r, const double *p, const double *q)
{
    for (int i = 0; i < 3; i++) {
        mpfr_set_d(r->x[i], p[i], MPFR_RNDN);
        mpfr_sub_d(r->x[i], r->x[i], q[i], MPFR_RNDN);
    }
}

static void v_dot(mpfr_t out, const vec3m *a, const vec3m *b, mpfr_t tmp)
{
    mpfr_mul(out, a->x[0], b->x[0], MPFR_RNDN);
    mpfr_mul(tmp, a->x[1], b->x[1], MPFR_RNDN);
    mpfr_add(out, out, tmp, MPFR_RNDN);
    mpfr_mul(tmp, a->x[2], b->x[2], MPFR_RNDN);
    mpfr_add(out, out, tmp, MPFR_RNDN);
}

static void v_cross(vec3m *out, const vec3m *a, const vec3m *b, mpfr_t tmp)
{
    for (int i = 0; i < 3; i++) {
        int j = (i + 1) % 3, k = (i + 2) % 3;
        mpfr_mul(out->x[i], a->x[j], b->x[k], MPFR_RNDN);
        mpfr_mul(tmp, a->x[k], b->x[j], MPFR_RNDN);
        mpfr_sub(out->x[i], out->x[i], tmp, MPFR_RNDN);
    }
}

int sc_ref_circumsphere(const double A[3], const double B[3], const double C[3], sc_ref_sphere *out)
{
    double all[9] = { A[0], A[1], A[2], B[0], B[1], B[2], C[0], C[1], C[2] };
    if (!all_finite(all, 9))
        return 0;
    /* n = a x b and |n|^2 are of degree 2 and 4; u x n of degree 5. */
    mpfr_prec_t p = 6 * diff_bits(all, 9) + 16;
    mpfr_prec_t po = p > SC_REF_MIN_PREC ? p : SC_REF_MIN_PREC;
    vec3m a, b, n, u, un;
    mpfr_t aa, bb, nn, tmp;
    v_init(&a, p), v_init(&b, p), v_init(&n, p), v_init(&u, p), v_init(&un, p);
    mpfr_inits2(p, aa, bb, nn, tmp, (mpfr_ptr)0);

    v_set_diff(&a, A, C);
    v_set_diff(&b, B, C);
    v_cross(&n, &a, &b, tmp);
    v_dot(aa, &a, &a, tmp);
    v_dot(bb, &b, &b, tmp);
    v_dot(nn, &n, &n, tmp);
    int ok = mpfr_sgn(nn) != 0;
    if (ok) {
        for (int i = 0; i < 3; i++) {       /* u = |a|^2 b - |b|^2 a */
            mpfr_mul(u.x[i], aa, b.x[i], MPFR_RNDN);
            mpfr_mul(tmp, bb, a.x[i], MPFR_RNDN);
            mpfr_sub(u.x[i], u.x[i], tmp, MPFR_RNDN);
        }
        v_cross(&un, &u, &n, tmp);
        mpfr_mul_2ui(nn, nn, 1, MPFR_RNDN);
        for (int i = 0; i < 3; i++)
            mpfr_set_prec(out->c[i], po);
        mpfr_set_prec(out->r2, po);
        mpfr_t off;
        mpfr_init2(off, po);
        mpfr_set_ui(out->r2, 0, MPFR_RNDN);
        for (int i = 0; i < 3; i++) {
            mpfr_div(off, un.x[i], nn, MPFR_RNDN);
            mpfr_fma(out->r2, off, off, out->r2, MPFR_RNDN);
            mpfr_add_d(out->c[i], off, C[i], MPFR_RNDN);
        }
        mpfr_clear(off);
    }
    v_clear(&a), v_clear(&b), v_clear(&n), v_clear(&u), v_clear(&un);
    mpfr_clears(aa, bb, nn, tmp, (mpfr_ptr)0);
    return ok;
}

int sc_ref_minimal_sphere(const double A[3], const double B[3], const double C[3], sc_ref_sphere *out)
{
    double all[9] = { A[0], A[1], A[2], B[0], B[1], B[2], C[0], C[1], C[2] };
    if (!all_finite(all, 9))
        return 0;
    mpfr_prec_t p = 2 * diff_bits(all, 9) + 16;
    const double *V[3] = { A, B, C };
    vec3m e[3];
    mpfr_t len2[3], tmp, sum;
    for (int i = 0; i < 3; i++) {
        v_init(&e[i], p);
        mpfr_init2(len2[i], p);
        v_set_diff(&e[i], V[(i + 1) % 3], V[(i + 2) % 3]);   /* edge opposite V[i] */
    }
    mpfr_inits2(p + 2, tmp, sum, (mpfr_ptr)0);
    for (int i = 0; i < 3; i++)
        v_dot(len2[i], &e[i], &e[i], tmp);
    int longest = 0;
    for (int i = 1; i < 3; i++)
        if (mpfr_cmp(len2[i], len2[longest]) > 0)
            longest = i;
    mpfr_add(sum, len2[(longest + 1) % 3], len2[(longest + 2) % 3], MPFR_RNDN);
    int obtuse = mpfr_cmp(sum, len2[longest]) <= 0;
    int ok = 1;
    if (obtuse) {
        const double *P = V[(longest + 1) % 3], *R = V[(longest + 2) % 3];
        mpfr_prec_t po = p > SC_REF_MIN_PREC ? p : SC_REF_MIN_PREC;
        for (int i = 0; i < 3; i++) {
            mpfr_set_prec(out->c[i], po);
            mpfr_set_d(out->c[i], P[i], MPFR_RNDN);
            mpfr_add_d(out->c[i], out->c[i], R[i], MPFR_RNDN);
            mpfr_div_2ui(out->c[i], out->c[i], 1, MPFR_RNDN);
        }
        mpfr_set_prec(out->r2, po);
        mpfr_div_2ui(out->r2, len2[longest], 2, MPFR_RNDN);
    } else {
        ok = sc_ref_circumsphere(A, B, C, out);
    }
    for (int i = 0; i < 3; i++) {
        v_clear(&e[i]);
        mpfr_clear(len2[i]);
    }
    mpfr_clears(tmp, sum, (mpfr_ptr)0);
    return ok;
}

double sc_ref_centre_error(const sc_ref_sphere *ref, const double c[3])
{
    if (!all_finite(c, 3))
        return INFINITY;
    mpfr_t d, s, t;
    mpfr_inits2(mpfr_get_prec(ref->c[0]) + 64, d, s, t, (mpfr_ptr)0);
    mpfr_set_ui(s, 0, MPFR_RNDN);
    for (int i = 0; i < 3; i++) {
        mpfr_set_d(d, c[i], MPFR_RNDN);
        mpfr_sub(d, d, ref->c[i], MPFR_RNDN);
        mpfr_fma(s, d, d, s, MPFR_RNDN);
    }
    if (mpfr_sgn(ref->r2) > 0)
        mpfr_div(s, s, ref->r2, MPFR_RNDN);
    mpfr_sqrt(s, s, MPFR_RNDN);
    double e = mpfr_get_d(s, MPFR_RNDU);
    mpfr_clears(d, s, t, (mpfr_ptr)0);
    return e;
}

double sc_ref_r2_error(const sc_ref_sphere *ref, double r2)
{
    if (!isfinite(r2))
        return INFINITY;
    mpfr_t d;
    mpfr_init2(d, mpfr_get_prec(ref->r2) + 64);
    mpfr_set_d(d, r2, MPFR_RNDN);
    mpfr_sub(d, d, ref->r2, MPFR_RNDN);
    mpfr_abs(d, d, MPFR_RNDN);
    if (mpfr_sgn(ref->r2) > 0)
        mpfr_div(d, d, ref->r2, MPFR_RNDN);
    double e = mpfr_get_d(d, MPFR_RNDU);
    mpfr_clear(d);
    return e;
}

int sc_ref_contains(const double V[3], const double c[3], double r2)
{
    if (isnan(r2) || !all_finite(V, 3) || !all_finite(c, 3))
        return 0;
    if (isinf(r2))
        return r2 > 0;
    double all[7] = { V[0], V[1], V[2], c[0], c[1], c[2], r2 };
    mpfr_prec_t p = 2 * diff_bits(all, 7) + 8;
    mpfr_t d, s;
    mpfr_inits2(p, d, s, (mpfr_ptr)0);
    mpfr_set_ui(s, 0, MPFR_RNDN);
    for (int i = 0; i < 3; i++) {
        mpfr_set_d(d, V[i], MPFR_RNDN);
        mpfr_sub_d(d, d, c[i], MPFR_RNDN);
        mpfr_fma(s, d, d, s, MPFR_RNDN);
    }
    int inside = mpfr_cmp_d(s, r2) <= 0;
    mpfr_clears(d, s, (mpfr_ptr)0);
    return inside;
}

double sc_ref_condition(const double A[3], const double B[3], const double C[3])
{
    double all[9] = { A[0], A[1], A[2], B[0], B[1], B[2], C[0], C[1], C[2] };
    if (!all_finite(all, 9))
        return INFINITY;
    mpfr_prec_t p = 4 * diff_bits(all, 9) + 16;
    vec3m a, b, c, n;
    mpfr_t la, lb, lc, nn, tmp;
    v_init(&a, p), v_init(&b, p), v_init(&c, p), v_init(&n, p);
    mpfr_inits2(p, la, lb, lc, nn, tmp, (mpfr_ptr)0);
    v_set_diff(&a, A, C);
    v_set_diff(&b, B, C);
    v_set_diff(&c, A, B);
    v_cross(&n, &a, &b, tmp);
    v_dot(la, &a, &a, tmp);
    v_dot(lb, &b, &b, tmp);
    v_dot(lc, &c, &c, tmp);
    v_dot(nn, &n, &n, tmp);
    mpfr_max(la, la, lb, MPFR_RNDN);
    mpfr_max(la, la, lc, MPFR_RNDN);
    double k = INFINITY;
    if (mpfr_sgn(nn) > 0) {
        mpfr_sqrt(nn, nn, MPFR_RNDN);
        mpfr_div(la, la, nn, MPFR_RNDN);
        k = mpfr_get_d(la, MPFR_RNDU);
    }
    v_clear(&a), v_clear(&b), v_clear(&c), v_clear(&n);
    mpfr_clears(la, lb, lc, nn, tmp, (mpfr_ptr)0);
    return k;
}

int sc_ref_simplex_sphere(int n, int k, const double *vertices, mpfr_t *centre, mpfr_t r2)
{
    if (n < 1 || k < 1 || k > n || !all_finite(vertices, (k + 1) * n))
        return 0;
    /* Gram entries exact, then elimination at a generous fixed precision:
     * even a condition number of 1e60 leaves > 300 correct bits. */
    mpfr_prec_t p = 2 * diff_bits(vertices, (k + 1) * n) + 16;
    mpfr_prec_t pe = p + 1024;
    mpfr_t *e = malloc(sizeof(mpfr_t) * (size_t)(k * n));
    mpfr_t *g = malloc(sizeof(mpfr_t) * (size_t)(k * (k + 1)));   /* [G | h] */
    mpfr_t tmp, f;
    mpfr_inits2(pe, tmp, f, (mpfr_ptr)0);
    for (int i = 0; i < k; i++)
        for (int j = 0; j < n; j++) {
            mpfr_init2(e[i * n + j], p);
            mpfr_set_d(e[i * n + j], vertices[(i + 1) * n + j], MPFR_RNDN);
            mpfr_sub_d(e[i * n + j], e[i * n + j], vertices[j], MPFR_RNDN);
        }
    for (int i = 0; i < k; i++)
        for (int j = 0; j <= k; j++) {
            mpfr_ptr gij = g[i * (k + 1) + j];
            mpfr_init2(gij, pe);
            mpfr_set_ui(gij, 0, MPFR_RNDN);
            int jj = j < k ? j : i;                 /* last column: |e_i|^2 / 2 */
            for (int t = 0; t < n; t++)
                mpfr_fma(gij, e[i * n + t], e[jj * n + t], gij, MPFR_RNDN);
            if (j == k)
                mpfr_div_2ui(gij, gij, 1, MPFR_RNDN);
        }
    int ok = 1;
    for (int col = 0; col < k && ok; col++) {
        int piv = col;
        for (int r = col + 1; r < k; r++)
            if (mpfr_cmpabs(g[r * (k + 1) + col], g[piv * (k + 1) + col]) > 0)
                piv = r;
        if (mpfr_zero_p(g[piv * (k + 1) + col])) {
            ok = 0;
            break;
        }
        if (piv != col)
            for (int c = 0; c <= k; c++)
                mpfr_swap(g[piv * (k + 1) + c], g[col * (k + 1) + c]);
        for (int r = col + 1; r < k; r++) {
            mpfr_div(f, g[r * (k + 1) + col], g[col * (k + 1) + col], MPFR_RNDN);
            for (int c = col; c <= k; c++) {
                mpfr_mul(tmp, f, g[col * (k + 1) + c], MPFR_RNDN);
                mpfr_sub(g[r * (k + 1) + c], g[r * (k + 1) + c], tmp, MPFR_RNDN);
            }
        }
    }
    if (ok) {
        mpfr_t *lambda = malloc(sizeof(mpfr_t) * (size_t)k);
        for (int r = k - 1; r >= 0; r--) {
            mpfr_init2(lambda[r], pe);
            mpfr_set(lambda[r], g[r * (k + 1) + k], MPFR_RNDN);
            for (int c = r + 1; c < k; c++) {
                mpfr_mul(tmp, g[r * (k + 1) + c], lambda[c], MPFR_RNDN);
                mpfr_sub(lambda[r], lambda[r], tmp, MPFR_RNDN);
            }
            mpfr_div(lambda[r], lambda[r], g[r * (k + 1) + r], MPFR_RNDN);
        }
        mpfr_set_prec(r2, pe);
        mpfr_set_ui(r2, 0, MPFR_RNDN);
        for (int j = 0; j < n; j++) {             /* x = E^T lambda */
            mpfr_set_ui(f, 0, MPFR_RNDN);
            for (int i = 0; i < k; i++)
                mpfr_fma(f, e[i * n + j], lambda[i], f, MPFR_RNDN);
            mpfr_fma(r2, f, f, r2, MPFR_RNDN);
            mpfr_set_prec(centre[j], pe);
            mpfr_add_d(centre[j], f, vertices[j], MPFR_RNDN);
        }
        for (int r = 0; r < k; r++)
            mpfr_clear(lambda[r]);
        free(lambda);
    }
    for (int i = 0; i < k * n; i++)
        mpfr_clear(e[i]);
    for (int i = 0; i < k * (k + 1); i++)
        mpfr_clear(g[i]);
    free(e);
    free(g);
    mpfr_clears(tmp, f, (mpfr_ptr)0);
    return ok;
}

double sc_ref_simplex_centre_error(int n, const mpfr_t *centre_ref, const mpfr_t r2_ref, const double *c)
{
    if (!all_finite(c, n))
        return INFINITY;
    mpfr_t d, s;
    mpfr_inits2(mpfr_get_prec(centre_ref[0]) + 64, d, s, (mpfr_ptr)0);
    mpfr_set_ui(s, 0, MPFR_RNDN);
    for (int i = 0; i < n; i++) {
        mpfr_set_d(d, c[i], MPFR_RNDN);
        mpfr_sub(d, d, centre_ref[i], MPFR_RNDN);
        mpfr_fma(s, d, d, s, MPFR_RNDN);
    }
    if (mpfr_sgn(r2_ref) > 0)
        mpfr_div(s, s, r2_ref, MPFR_RNDN);
    mpfr_sqrt(s, s, MPFR_RNDN);
    double err = mpfr_get_d(s, MPFR_RNDU);
    mpfr_clears(d, s, (mpfr_ptr)0);
    return err;
}
