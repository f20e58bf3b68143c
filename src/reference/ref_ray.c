/* Exact ray-triangle decision. See sc_ref_ray.h for the contract. */
#include <float.h>
#include <limits.h>
#include <math.h>

#include "sc_ref_ray.h"

#define REF_T_MIN_PREC 256

/* Widens [lsb, msb] so every listed value is an integer multiple of 2^lsb
 * with |v| < 2^(msb+1); zeros are skipped. */
static void span(const double *v, int count, int *msb, int *lsb)
{
    for (int i = 0; i < count; i++) {
        if (v[i] == 0)
            continue;
        int e = ilogb(v[i]);
        int low = e - (DBL_MANT_DIG - 1);
        if (low < -1074)
            low = -1074;
        if (e > *msb) *msb = e;
        if (low < *lsb) *lsb = low;
    }
}

static int finite_all(const double *v, int count)
{
    for (int i = 0; i < count; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

/* The shared core: on a hit leaves num = a.n and den = D.n (exact) and returns 1. */
static int decide(const double O[3], const double D[3], double tmin, double tmax,
                  const double A[3], const double B[3], const double C[3], mpfr_t num, mpfr_t den)
{
    if (!O || !D || !A || !B || !C || isnan(tmin) || isnan(tmax) || tmin > tmax)
        return 0;
    double pts[12] = { O[0], O[1], O[2], A[0], A[1], A[2], B[0], B[1], B[2], C[0], C[1], C[2] };
    if (!finite_all(pts, 12) || !finite_all(D, 3))
        return 0;
    /* Differences of the points are integers times 2^lsb of at most P + 1
     * bits; D's components integers times 2^dlsb of PD bits. A triple
     * product D.(x x y) then has at most PD + 2(P+1) + 3 bits, a.n at most
     * 3(P+2) + 4, and tmin * D.n another 53: one precision covers all. */
    int msb = INT_MIN, lsb = INT_MAX, dmsb = INT_MIN, dlsb = INT_MAX;
    span(pts, 12, &msb, &lsb);
    span(D, 3, &dmsb, &dlsb);
    if (dmsb == INT_MIN)
        return 0;                                  /* D = 0: no ray */
    if (msb == INT_MIN)
        msb = lsb = 0;
    long P = (long)msb - lsb + 2, PD = (long)dmsb - dlsb + 1;
    mpfr_prec_t p = (mpfr_prec_t)(PD + 3 * P + DBL_MANT_DIG + 64);

    mpfr_t a[3], b[3], c[3], d[3], e1[3], e2[3], n[3], x[3], vol[3], t1, t2;
    for (int i = 0; i < 3; i++) {
        mpfr_inits2(p, a[i], b[i], c[i], d[i], e1[i], e2[i], n[i], x[i], vol[i], (mpfr_ptr)0);
        mpfr_set_d(a[i], A[i], MPFR_RNDN), mpfr_sub_d(a[i], a[i], O[i], MPFR_RNDN);
        mpfr_set_d(b[i], B[i], MPFR_RNDN), mpfr_sub_d(b[i], b[i], O[i], MPFR_RNDN);
        mpfr_set_d(c[i], C[i], MPFR_RNDN), mpfr_sub_d(c[i], c[i], O[i], MPFR_RNDN);
        mpfr_set_d(d[i], D[i], MPFR_RNDN);
        mpfr_set_d(e1[i], B[i], MPFR_RNDN), mpfr_sub_d(e1[i], e1[i], A[i], MPFR_RNDN);
        mpfr_set_d(e2[i], C[i], MPFR_RNDN), mpfr_sub_d(e2[i], e2[i], A[i], MPFR_RNDN);
    }
    mpfr_inits2(p, t1, t2, (mpfr_ptr)0);
    mpfr_set_prec(num, p);
    mpfr_set_prec(den, p);

    /* x = p x q, then out = d.x, all exact at precision p. */
#define CROSS(out, P_, Q_)                                                       \
    for (int i = 0; i < 3; i++) {                                                \
        int j = (i + 1) % 3, k = (i + 2) % 3;                                    \
        mpfr_mul(t1, P_[j], Q_[k], MPFR_RNDN);                                   \
        mpfr_mul(t2, P_[k], Q_[j], MPFR_RNDN);                                   \
        mpfr_sub(out[i], t1, t2, MPFR_RNDN);                                     \
    }
#define DOT(out, P_, Q_)                                                         \
    do {                                                                         \
        mpfr_mul(out, P_[0], Q_[0], MPFR_RNDN);                                  \
        mpfr_fma(out, P_[1], Q_[1], out, MPFR_RNDN);                             \
        mpfr_fma(out, P_[2], Q_[2], out, MPFR_RNDN);                             \
    } while (0)

    CROSS(x, b, c); DOT(vol[0], d, x);
    CROSS(x, c, a); DOT(vol[1], d, x);
    CROSS(x, a, b); DOT(vol[2], d, x);
    CROSS(n, e1, e2); DOT(den, d, n);
    int hit = 0;
    int sd = mpfr_sgn(den);
    if (sd != 0) {
        /* No volume of the opposite sign to D.n (their sum): the line
         * crosses the closed triangle. */
        hit = 1;
        for (int i = 0; i < 3; i++)
            if (mpfr_sgn(vol[i]) * sd < 0)
                hit = 0;
    }
    if (hit) {
        DOT(num, a, n);
        /* t = num / den in [tmin, tmax]  <=>  tmin*den <= num <= tmax*den
         * when den > 0; the inequalities flip when den < 0. */
        if (isfinite(tmin)) {
            mpfr_mul_d(t1, den, tmin, MPFR_RNDN);
            int cmp = mpfr_cmp(num, t1);
            if (cmp * sd < 0)
                hit = 0;
        } else if (tmin > 0) {
            hit = 0;                               /* tmin = +inf */
        }
        if (isfinite(tmax)) {
            mpfr_mul_d(t1, den, tmax, MPFR_RNDN);
            int cmp = mpfr_cmp(num, t1);
            if (cmp * sd > 0)
                hit = 0;
        } else if (tmax < 0) {
            hit = 0;                               /* tmax = -inf */
        }
    }
#undef CROSS
#undef DOT
    for (int i = 0; i < 3; i++)
        mpfr_clears(a[i], b[i], c[i], d[i], e1[i], e2[i], n[i], x[i], vol[i], (mpfr_ptr)0);
    mpfr_clears(t1, t2, (mpfr_ptr)0);
    return hit;
}

static int ref_ray(const double O[3], const double D[3], double tmin, double tmax,
                   const double A[3], const double B[3], const double C[3], mpfr_t t, mpfr_prec_t tprec,
                   int as_double)
{
    mpfr_t num, den;
    mpfr_inits2(64, num, den, (mpfr_ptr)0);        /* decide() sizes them */
    int hit = decide(O, D, tmin, tmax, A, B, C, num, den);
    if (hit) {
        mpfr_set_prec(t, tprec);
        if (as_double) {
            /* One correct rounding into the double format, subnormals included. */
            mpfr_exp_t emin = mpfr_get_emin(), emax = mpfr_get_emax();
            mpfr_set_emin(DBL_MIN_EXP - DBL_MANT_DIG + 1);
            mpfr_set_emax(DBL_MAX_EXP);
            int inex = mpfr_div(t, num, den, MPFR_RNDN);
            mpfr_subnormalize(t, inex, MPFR_RNDN);
            mpfr_set_emin(emin);
            mpfr_set_emax(emax);
        } else {
            mpfr_div(t, num, den, MPFR_RNDN);
        }
    }
    mpfr_clears(num, den, (mpfr_ptr)0);
    return hit;
}

int sc_ref_ray_triangle(const double O[3], const double D[3], double tmin, double tmax,
                        const double A[3], const double B[3], const double C[3], double *t_out)
{
    mpfr_t t;
    mpfr_init2(t, DBL_MANT_DIG);
    int hit = ref_ray(O, D, tmin, tmax, A, B, C, t, DBL_MANT_DIG, 1);
    if (hit && t_out)
        *t_out = mpfr_get_d(t, MPFR_RNDN);
    mpfr_clear(t);
    return hit;
}

int sc_ref_ray_triangle_mpfr(const double O[3], const double D[3], double tmin, double tmax,
                             const double A[3], const double B[3], const double C[3], mpfr_t t_exact)
{
    if (!t_exact)
        return 0;
    return ref_ray(O, D, tmin, tmax, A, B, C, t_exact, REF_T_MIN_PREC, 0);
}
