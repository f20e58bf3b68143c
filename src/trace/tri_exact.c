/* Exact-decision triangle test: the double filter, the exact fixed-point
 * fallback and the per-leaf resolution (see tri_exact.h).
 *
 * Why the float filter of the kernels is rigorous (u = 2^-24, first-order
 * terms with their second-order slack folded into the constants):
 *   translation  a = fl(P - O) = (P-O)(1+d);  shear Px = fl(a_x - fl(Sx a_z)),
 *   |Sx| <= 1 since kz is the largest |D| axis. Then
 *     |Px - Px*| <= 2.0001u|a_x| + 4.0002u|a_z| + 2^-149.99 (1 + |a_z|)
 *   (the last term for underflow in the product and in Sx), so with
 *   S >= |a|_1 (1 + 2^-10) for every vertex (the root box's farthest corner)
 *   both sheared coordinates of any vertex are within
 *   eps = 4.001u S + 2^-149.9 of the exactly sheared ones, and h = |Px|+|Py|
 *   <= 2S. An edge U = fl(fl(Cx By) - fl(Cy Bx)) then differs from the
 *   exact U* = D.(c x b)/|D_kz| by at most
 *     hC eps + hB eps + 2 eps^2 + 2.0001u hB hC + 2^-149
 *     <= (6.0012u S + 2^-149.9)(hB + hC) + 34u^2 S^2 + 2^-149,
 *   so K = 6.1u S + floor and c0 = 34u^2 S^2 + floor (1.6% slack for the
 *   two roundings of E = fl(K fl(hB + hC) + c0) and of h; floors below).
 *   |U| > E proves sign(U) = sign(U*). With three certain edges of one sign,
 *   t* = sum l_i* z_i* with l_i* = U_i* / sum U_j* >= 0 (convex). With
 *   l_i = U_i / sum U_j: sum |l_i - l_i*| <= 2E/|sum U| (E = sum of the edge
 *   bounds) and sum (l_i - l_i*) = 0, so sum (l_i - l_i*) z_i* moves t by at
 *   most 2 rho (R + 3u Z), rho = E/|det|, R = half the spread of the z_i.
 *   The roundings of T = sum U_i z_i (3u), of the z_i = Sz a_kz (3u), of
 *   det (2u) and of T fl(1/det) (2u) add 5u Z + 3u Z + 2u |t| and, for
 *   underflow, 2^-148/|det|:
 *     |t - t*| <= 2.0001 rho R + 14.02u Z + 2.001u|t| + 2^-147.9/|det|.
 *   The kernels use 2.02, 15u, 3u and 2^-146 for slack against the rounding
 *   of the bound itself (q fl(1/|det|) has two roundings: inside the 1%).
 * Underflow, with gradual underflow or with MXCSR FTZ|DAZ (a subnormal
 * result or operand becomes 0, an absolute error below MIN = 2^-126 per
 * operation, where gradual underflow leaves 2^-150): the floors are normal
 * numbers so DAZ cannot zero them. A coordinate read as 0, the translation,
 * Sx a_z, Sx itself (|err| < MIN |a_z|, inside the u terms) and the shear
 * subtraction add below 4 MIN (1 + |a_z|) to |Px - Px*|; the two products
 * and the difference of U below 3 MIN: K's floor 2^-123 = 8 MIN and c0's
 * 2^-121 = 32 MIN cover them, and E >= c0 keeps a certified U, and det,
 * normal. T's three products and two sums add below 5 MIN, times |1/det|:
 * SC_EXACT_FLOOR_N = 2^-123; z_i = Sz a_kz and T fl(1/det) below MIN each in t:
 * SC_EXACT_FLOOR_T = 2^-120. fl(1/det) itself is only u-accurate while normal:
 * a lane with |fl(1/det)| < 2^-126 (|det| > 2^126; FTZ makes it 0) is left
 * undecided and settled below.
 * The double filter below has the same structure with u = 2^-53 and no
 * underflow in either mode (products of at most three float-derived values
 * stay far above 2^-1022, so nothing is subnormal for DAZ or FTZ to zero),
 * and the exact path has no floating point at all (it reads the floats'
 * bits, so it decides for the caller's values even where DAZ reads a
 * subnormal coordinate as 0).
 */
#include <math.h>
#include <string.h>

#include "common/sc_round.h"
#include "tri_exact.h"

/* ---- exact fixed point ---------------------------------------------------- */

/* A float is (-1)^neg m 2^e with m < 2^24 and e >= -149, so a product of
 * three floats is an integer below 2^72 times 2^e, e >= -447. Every
 * predicate here is a sum of such products (or a product of two such sums,
 * or one times a float): a two's complement integer of XL limbs in units of
 * 2^-XBASE holds them all exactly (floats are below 2^128: the largest value,
 * a product of two sums of 48 terms each, stays under 2^1700). */
enum { XL = 32, XBASE = 447 };

typedef struct xint {
    uint64_t w[XL];
} xint;

typedef struct xf {
    uint32_t m;
    int e;
    int neg;
} xf;

static xf fdec(float f)
{
    uint32_t b;
    memcpy(&b, &f, sizeof b);
    xf x;
    int ex = (int)((b >> 23) & 0xff);
    x.m = b & 0x7fffff;
    if (ex) {
        x.m |= 0x800000;
        x.e = ex - 150;
    } else {
        x.e = -149;
    }
    x.neg = (int)(b >> 31);
    return x;
}

/* x += (-1)^neg (hi:lo) 2^off */
static void xi_addmag(xint *x, uint64_t lo, uint64_t hi, int neg, unsigned off)
{
    unsigned q = off >> 6, r = off & 63;
    uint64_t p[3];
    p[0] = lo << r;
    p[1] = r ? (lo >> (64 - r)) | (hi << r) : hi;
    p[2] = r ? hi >> (64 - r) : 0;
    if (!neg) {
        uint64_t carry = 0;
        for (unsigned i = q; i < XL; i++) {
            unsigned k = i - q;
            uint64_t a = k < 3 ? p[k] : 0;
            unsigned __int128 s = (unsigned __int128)x->w[i] + a + carry;
            x->w[i] = (uint64_t)s;
            carry = (uint64_t)(s >> 64);
            if (k >= 2 && !carry)
                break;
        }
    } else {
        uint64_t borrow = 0;
        for (unsigned i = q; i < XL; i++) {
            unsigned k = i - q;
            uint64_t a = k < 3 ? p[k] : 0, w = x->w[i];
            uint64_t d1 = w - a;
            uint64_t b1 = w < a;
            uint64_t d = d1 - borrow;
            borrow = b1 | (d1 < borrow);
            x->w[i] = d;
            if (k >= 2 && !borrow)
                break;
        }
    }
}

/* x += (-1)^flip a b c */
static void xi_tp(xint *x, xf a, xf b, xf c, int flip)
{
    if (!a.m || !b.m || !c.m)
        return;
    unsigned __int128 m = (unsigned __int128)((uint64_t)a.m * b.m) * c.m;
    xi_addmag(x, (uint64_t)m, (uint64_t)(m >> 64), a.neg ^ b.neg ^ c.neg ^ flip,
              (unsigned)(a.e + b.e + c.e + XBASE));
}

/* x += (-1)^flip X.(Y x Z) */
static void xi_det3(xint *x, const xf *X, const xf *Y, const xf *Z, int flip)
{
    for (int i = 0; i < 3; i++) {
        int j = (i + 1) % 3, k = (i + 2) % 3;
        xi_tp(x, X[i], Y[j], Z[k], flip);
        xi_tp(x, X[i], Y[k], Z[j], !flip);
    }
}

static int xi_sign(const xint *x)
{
    if ((int64_t)x->w[XL - 1] < 0)
        return -1;
    for (int i = XL - 1; i >= 0; i--)
        if (x->w[i])
            return 1;
    return 0;
}

static void xi_negate(xint *x)
{
    uint64_t carry = 1;
    for (int i = 0; i < XL; i++) {
        uint64_t v = ~x->w[i] + carry;
        carry = carry && v == 0;
        x->w[i] = v;
    }
}

/* out = a * b (signed); the caller keeps |a b| < 2^(64 XL - 1) */
static void xi_mul(const xint *a, const xint *b, xint *out)
{
    xint ma = *a, mb = *b;
    int sa = xi_sign(a), sb = xi_sign(b);
    if (sa < 0)
        xi_negate(&ma);
    if (sb < 0)
        xi_negate(&mb);
    int na = XL, nb = XL;
    while (na > 0 && !ma.w[na - 1])
        na--;
    while (nb > 0 && !mb.w[nb - 1])
        nb--;
    memset(out, 0, sizeof *out);
    for (int i = 0; i < na; i++) {
        uint64_t carry = 0;
        for (int j = 0; j < nb && i + j < XL; j++) {
            unsigned __int128 s = (unsigned __int128)ma.w[i] * mb.w[j] + out->w[i + j] + carry;
            out->w[i + j] = (uint64_t)s;
            carry = (uint64_t)(s >> 64);
        }
        if (i + nb < XL)
            out->w[i + nb] = carry;
    }
    if (sa * sb < 0)
        xi_negate(out);
}

static void xi_shl(xint *x, unsigned s)
{
    int q = (int)(s >> 6);
    unsigned r = s & 63;
    for (int i = XL - 1; i >= 0; i--) {
        uint64_t hi = i - q >= 0 ? x->w[i - q] : 0;
        uint64_t lo = i - q - 1 >= 0 ? x->w[i - q - 1] : 0;
        x->w[i] = r ? (hi << r) | (lo >> (64 - r)) : hi;
    }
}

/* sign(a - b) */
static int xi_cmp(const xint *a, const xint *b)
{
    xint d;
    uint64_t borrow = 0;
    for (int i = 0; i < XL; i++) {
        uint64_t d1 = a->w[i] - b->w[i];
        uint64_t b1 = a->w[i] < b->w[i];
        d.w[i] = d1 - borrow;
        borrow = b1 | (d1 < borrow);
    }
    return xi_sign(&d);
}

/* an approximation (a few ulps) of x 2^-XBASE 2^scale, for reporting only */
static double xi_approx(const xint *x, int scale)
{
    xint m = *x;
    int s = xi_sign(x);
    if (!s)
        return 0;
    if (s < 0)
        xi_negate(&m);
    int k = XL - 1;
    while (!m.w[k])
        k--;
    double v = (double)m.w[k];
    if (k > 0)
        v += ldexp((double)m.w[k - 1], -64);
    return s * ldexp(v, 64 * k - XBASE + scale);
}

typedef struct xin {
    xf o[3], d[3], v[3][3];
} xin;

static void xin_init(xin *in, const sc_ray *r, const float v[9])
{
    for (int k = 0; k < 3; k++) {
        in->o[k] = fdec(r->org[k]);
        in->d[k] = fdec(r->dir[k]);
        for (int j = 0; j < 3; j++)
            in->v[j][k] = fdec(v[3 * j + k]);
    }
}

/* D.((P-O) x (Q-O)) = D.(P x Q) + D.(O x P) + D.(Q x O) */
static int vol_sign(const xin *in, int p, int q)
{
    xint x;
    memset(&x, 0, sizeof x);
    xi_det3(&x, in->d, in->v[p], in->v[q], 0);
    xi_det3(&x, in->d, in->o, in->v[p], 0);
    xi_det3(&x, in->d, in->v[q], in->o, 0);
    return xi_sign(&x);
}

/* num = (A-O).n = A.(B x C) - O.(A x B) - O.(B x C) - O.(C x A),
 * den = D.n = D.(A x B) + D.(B x C) + D.(C x A), n = (B-A) x (C-A) */
static void num_den(const xin *in, xint *num, xint *den)
{
    const xf *A = in->v[0], *B = in->v[1], *C = in->v[2];
    memset(num, 0, sizeof *num);
    memset(den, 0, sizeof *den);
    xi_det3(num, A, B, C, 0);
    xi_det3(num, in->o, A, B, 1);
    xi_det3(num, in->o, B, C, 1);
    xi_det3(num, in->o, C, A, 1);
    xi_det3(den, in->d, A, B, 0);
    xi_det3(den, in->d, B, C, 0);
    xi_det3(den, in->d, C, A, 0);
}

/* sign(num - f den) for a finite float f */
static int cmp_num_fden(const xint *num, const xint *den, float f)
{
    if (f == 0)
        return xi_sign(num);
    xf x = fdec(f);
    xint m, p, n = *num;
    memset(&m, 0, sizeof m);
    m.w[0] = x.m;
    xi_mul(den, &m, &p);                        /* in units of 2^(e - XBASE) */
    if (x.neg)
        xi_negate(&p);
    if (x.e >= 0)
        xi_shl(&p, (unsigned)x.e);
    else
        xi_shl(&n, (unsigned)-x.e);
    return xi_cmp(&n, &p);
}

/* exact tmin <= num/den <= tmax, den != 0 (the oracle's inequalities) */
static int range_exact(const sc_ray *r, const xint *num, const xint *den)
{
    int sd = xi_sign(den);
    if (!isfinite(r->tmin))
        return 0;
    if (cmp_num_fden(num, den, r->tmin) * sd < 0)
        return 0;
    if (isfinite(r->tmax)) {
        if (cmp_num_fden(num, den, r->tmax) * sd > 0)
            return 0;
    } else if (r->tmax < 0) {
        return 0;
    }
    return 1;
}

int sc_exact_vol_sign(const sc_ray *r, const float P[3], const float Q[3])
{
    float v[9] = { P[0], P[1], P[2], Q[0], Q[1], Q[2], 0, 0, 0 };
    xin in;
    xin_init(&in, r, v);
    return vol_sign(&in, 0, 1);
}

int sc_exact_hit_test(const sc_ray *r, const float v[9])
{
    xin in;
    xin_init(&in, r, v);
    int s0 = vol_sign(&in, 1, 2), s1 = vol_sign(&in, 2, 0), s2 = vol_sign(&in, 0, 1);
    if ((s0 < 0 || s1 < 0 || s2 < 0) && (s0 > 0 || s1 > 0 || s2 > 0))
        return 0;
    if (!s0 && !s1 && !s2)
        return 0;                              /* D.n = s0 + s1 + s2 = 0: parallel */
    xint num, den;
    num_den(&in, &num, &den);
    return range_exact(r, &num, &den);
}

int sc_exact_cmp_t(const sc_ray *r, const float a[9], const float b[9])
{
    xin ia, ib;
    xin_init(&ia, r, a);
    xin_init(&ib, r, b);
    xint na, da, nb, db, p, q;
    num_den(&ia, &na, &da);
    num_den(&ib, &nb, &db);
    xi_mul(&na, &db, &p);
    xi_mul(&nb, &da, &q);
    return xi_cmp(&p, &q) * xi_sign(&da) * xi_sign(&db);
}

/* ---- the double filter ---------------------------------------------------- */

typedef struct dvol {
    double a[3][3];          /* vertices - origin */
    double vol[3], ev[3];    /* edge volumes D.(b x c), D.(c x a), D.(a x b) and bounds */
} dvol;

/* The vertices of edge e's volume: edge e is opposite vertex e. A table,
 * not (e + 1) % 3, which compiled to two integer divisions an edge. */
static const unsigned char dvol_p[3] = { 1, 2, 0 }, dvol_q[3] = { 2, 0, 1 };

/* The formulas shared by the double filter and sc_exact_report (which must
 * compute the same bits): the vertices relative to the origin, the edge
 * volume D.(P x Q), and a vertex's tau = a.D / D.D. */
static inline void dvol_rel(const sc_ray *r, const float *v, double a[3][3])
{
    for (int j = 0; j < 3; j++)
        for (int k = 0; k < 3; k++)
            a[j][k] = (double)v[3 * j + k] - (double)r->org[k];
}
static inline double dvol_edge(const double *d, const double *P, const double *Q)
{
    const double x0 = P[1] * Q[2] - P[2] * Q[1];
    const double x1 = P[2] * Q[0] - P[0] * Q[2];
    const double x2 = P[0] * Q[1] - P[1] * Q[0];
    return (d[0] * x0 + d[1] * x1) + d[2] * x2;
}
static inline double dvol_dd(const double *d)
{
    return (d[0] * d[0] + d[1] * d[1]) + d[2] * d[2];
}
static inline double dvol_tau(const double *a, const double *d, double dd)
{
    return ((a[0] * d[0] + a[1] * d[1]) + a[2] * d[2]) / dd;
}
/* t = sum vol_j tau_j / sum vol_j; *den: the sum */
static inline double dvol_t(const double *vol, const double *tau, double *den)
{
    *den = (vol[0] + vol[1]) + vol[2];
    return ((vol[0] * tau[0] + vol[1] * tau[1]) + vol[2] * tau[2]) / *den;
}

/* Each volume term d_i p_j q_k passes through at most 7 roundings (two
 * translations, product, difference, product, two sums): the error is below
 * 7.001u times the permanent, computed within 7u itself, so 8u covers. */
static void dvols(const sc_ray *r, const float *v, dvol *o)
{
    const double d[3] = { r->dir[0], r->dir[1], r->dir[2] };
    dvol_rel(r, v, o->a);
    for (int e = 0; e < 3; e++) {
        const double *P = o->a[dvol_p[e]], *Q = o->a[dvol_q[e]];
        o->vol[e] = dvol_edge(d, P, Q);
        double p0 = fabs(P[1] * Q[2]) + fabs(P[2] * Q[1]);
        double p1 = fabs(P[2] * Q[0]) + fabs(P[0] * Q[2]);
        double p2 = fabs(P[0] * Q[1]) + fabs(P[1] * Q[0]);
        o->ev[e] = 0x1p-50 * ((fabs(d[0]) * p0 + fabs(d[1]) * p1) + fabs(d[2]) * p2);
    }
}

/* t bounds from the barycentric form t = sum vol_j tau_j / sum vol_j,
 * tau_j = a_j.D / D.D, valid when the exact volumes have no two opposite
 * signs and a non-zero sum (checked by the caller). With E the summed
 * volume bounds, rho = E/|den|, T = max |tau_j|, R half their spread and
 * eta the tau bound (the computed volumes may have a wrong sign here, so
 * sum |l_j| <= 1 + 2 rho):
 *   |t - t*| <= 2 rho (R + eta) + eta (1 + 2 rho) + 6u T (1 + 2 rho) + u |t|.
 * Returns 0 when den is within rounding of 0 (then nothing is set). */
static int dt_bounds(const sc_ray *r, const dvol *o, double *lo, double *hi, double *tc, double *u, double *v)
{
    const double d[3] = { r->dir[0], r->dir[1], r->dir[2] };
    const double dd = dvol_dd(d);
    double tau[3], T = 0, eta = 0, tlo = INFINITY, thi = -INFINITY;
    for (int j = 0; j < 3; j++) {
        const double *a = o->a[j];
        tau[j] = dvol_tau(a, d, dd);
        double m = (fabs(a[0] * d[0]) + fabs(a[1] * d[1])) + fabs(a[2] * d[2]);
        double ej = 0x1p-50 * m / dd;
        if (fabs(tau[j]) > T) T = fabs(tau[j]);
        if (ej > eta) eta = ej;
        if (tau[j] < tlo) tlo = tau[j];
        if (tau[j] > thi) thi = tau[j];
    }
    double R = 0.5 * (thi - tlo);
    double den;
    const double t = dvol_t(o->vol, tau, &den);
    double E = (o->ev[0] + o->ev[1]) + o->ev[2];
    double rho = E / fabs(den);
    double te = (2 * rho * (R + eta) + eta * (1 + 2 * rho) + 0x1p-50 * T * (1 + 2 * rho) + 0x1p-52 * fabs(t)) *
                (1 + 0x1p-30);
    if (!(den != 0 && isfinite(t) && isfinite(te)))
        return 0;
    *lo = t - te * (1 + 0x1p-40);     /* te >= 2^-52 |t|: covers the rounding */
    *hi = t + te * (1 + 0x1p-40);
    *tc = t;
    *u = o->vol[1] / den;
    *v = o->vol[2] / den;
    return 1;
}


/* a hit's exact t is in [tmin, tmax]: keep the rounded one there too */
static void clamp_t(const sc_ray *r, sc_exact_hit *c)
{
    if (!(c->t >= r->tmin)) c->t = r->tmin;
    if (!(c->t <= r->tmax)) c->t = r->tmax;
}

static void load_tri(const float *rows, unsigned W, unsigned i, float v[9])
{
    for (unsigned j = 0; j < 3; j++)
        for (unsigned k = 0; k < 3; k++)
            v[3 * j + k] = rows[sc_leaf_at(W, j, k, i)];
}

/* Double bounds for c (whose edges are settled: no two opposite exact
 * signs, non-zero sum); intersected with the ones it has. The reported t,
 * u, v become the double ones (more accurate than the float filter's); with
 * report != 0 they are set even when the double den is ~0 (from the exact
 * values). */
static void refine(const sc_ray *r, sc_exact_hit *c, const dvol *o, int report)
{
    double lo, hi, t, u, v;
    if (dt_bounds(r, o, &lo, &hi, &t, &u, &v)) {
        float fl = sc_f32_down(lo), fh = sc_f32_up(hi);
        if (fl > c->lo) c->lo = fl;
        if (fh < c->hi) c->hi = fh;
        c->t = (float)t, c->u = (float)u, c->v = (float)v;
        clamp_t(r, c);
    } else {
        if (report) {
            float tri[9];
            xin in;
            xint num, den;
            load_tri(c->rows, c->W, c->lane, tri);
            xin_init(&in, r, tri);
            num_den(&in, &num, &den);
            c->t = (float)(xi_approx(&num, 0) / xi_approx(&den, 0));
            c->u = c->v = 0;
            clamp_t(r, c);
        }
    }
    c->refined = 1;
}

static void refine_certified(const sc_ray *r, sc_exact_hit *c)
{
    float tri[9];
    dvol o;
    load_tri(c->rows, c->W, c->lane, tri);
    dvols(r, tri, &o);
    refine(r, c, &o, 0);
}

/* A lane the float filter left open: 1 iff the line crosses the closed
 * triangle (exact); then c holds bounds and the reported values. */
static int settle(const sc_ray *r, sc_exact_hit *c)
{
    float tri[9];
    dvol o;
    load_tri(c->rows, c->W, c->lane, tri);
    dvols(r, tri, &o);
    int s[3], open = 0, pos = 0, neg = 0;
    for (int e = 0; e < 3; e++) {
        s[e] = o.vol[e] > o.ev[e] ? 1 : o.vol[e] < -o.ev[e] ? -1 : 2;
        pos |= s[e] == 1;
        neg |= s[e] == -1;
        open |= (s[e] == 2) << e;
    }
    if (pos && neg)
        return 0;
    if (open) {
        xin in;
        xin_init(&in, r, tri);
        for (int e = 0; e < 3; e++)
            if (open >> e & 1) {
                s[e] = vol_sign(&in, (e + 1) % 3, (e + 2) % 3);
                pos |= s[e] == 1;
                neg |= s[e] == -1;
            }
        if ((pos && neg) || (!pos && !neg))
            return 0;
    }
    c->lo = -INFINITY, c->hi = INFINITY;
    refine(r, c, &o, 1);
    return 1;
}

static int in_range(const sc_ray *r, sc_exact_hit *c)
{
    for (;;) {
        if (c->hi < r->tmin || c->lo > r->tmax)
            return 0;
        if (c->lo >= r->tmin && c->hi <= r->tmax)
            return 1;
        if (!c->refined) {
            refine_certified(r, c);
            continue;
        }
        float tri[9];
        xin in;
        xint num, den;
        load_tri(c->rows, c->W, c->lane, tri);
        xin_init(&in, r, tri);
        num_den(&in, &num, &den);
        return range_exact(r, &num, &den);
    }
}

/* refine_certified for a comparison: tighter lo and hi, the reported
 * values left as the hit was accepted with (sc_exact_hit) */
static void refine_bounds(const sc_ray *r, sc_exact_hit *c)
{
    const float t = c->t, u = c->u, v = c->v;
    refine_certified(r, c);
    c->t = t, c->u = u, c->v = v;
}

/* Whether two triangles have the same three vertices, in any order: one
 * plane, so a ray that hits both meets them at exactly the same t. Both
 * were hit, so neither is degenerate and three matches make the sets
 * equal. A face stored twice (once a side, or a copy) is common in
 * architectural models: on Sponza nearly every exact comparison of two
 * hits' t is such a pair (docs/compare.md, thirty-seventh session), each
 * a tie that the integer arithmetic would take ~20,000 instructions to find. */
static int same_face(const float a[9], const float b[9])
{
    for (int i = 0; i < 3; i++) {
        int found = 0;
        for (int j = 0; j < 3; j++)
            found |= (a[3 * i] == b[3 * j]) & (a[3 * i + 1] == b[3 * j + 1]) & (a[3 * i + 2] == b[3 * j + 2]);
        if (!found)
            return 0;
    }
    return 1;
}

/* 1 iff c's exact t is smaller than b's, or equal and c's primitive id the
 * smaller: the tie rule of every kernel, so that the answer does not depend
 * on the order in which the leaves are visited */
static int closer(const sc_ray *r, sc_exact_hit *c, sc_exact_hit *b)
{
    if (c->hi < b->lo)
        return 1;
    if (c->lo > b->hi)
        return 0;
    float ta[9], tb[9];
    load_tri(c->rows, c->W, c->lane, ta);
    load_tri(b->rows, b->W, b->lane, tb);
    if (same_face(ta, tb))
        return c->prim < b->prim;
    for (;;) {
        if (c->hi < b->lo)
            return 1;
        if (c->lo > b->hi)
            return 0;
        if (!c->refined) {
            refine_bounds(r, c);
            continue;
        }
        if (!b->refined) {
            refine_bounds(r, b);
            continue;
        }
        const int cmp = sc_exact_cmp_t(r, ta, tb);
        return cmp < 0 || (cmp == 0 && c->prim < b->prim);
    }
}

unsigned sc_exact_resolve(const sc_ray *r, const float *rows, unsigned W, unsigned cand, const float *t,
                     const float *te, const float *un, const float *vn, const float *den, int any,
                     sc_exact_hit *best)
{
    if (!(r->tmin <= r->tmax) || isinf(r->tmin))
        return 0;
    const uint32_t *ids = sc_leaf_prims(rows, W);
    unsigned nh = 0;
    for (unsigned m = cand; m; m &= m - 1) {
        unsigned i = (unsigned)__builtin_ctz(m);
        sc_exact_hit c;
        c.have = 1;
        c.refined = 0;
        c.prim = ids[i];
        c.rows = rows, c.W = W, c.lane = i;
        if (te[i] >= 0) {
            c.lo = t[i] - 2 * te[i];       /* as in sc_exact_fast */
            c.hi = t[i] + 2 * te[i];
            c.t = t[i];
            c.u = un[i] * den[i];
            c.v = vn[i] * den[i];
        } else if (!settle(r, &c)) {
            continue;
        }
        if (!in_range(r, &c))
            continue;
        nh++;
        if (any)
            return 1;
        /* the exact t is in [tmin, tmax]: so are the bounds and the report */
        if (c.lo < r->tmin) c.lo = r->tmin;
        if (c.hi > r->tmax) c.hi = r->tmax;
        c.rlo = c.lo, c.rhi = c.hi;
        clamp_t(r, &c);
        if (!best->have || closer(r, &c, best))
            *best = c;
    }
    return nh;
}

/* The decisions are made: only the reported values are recomputed, with
 * dvols' and dt_bounds' formulas for vol, tau and t (the same helpers, so
 * the same bits) but
 * without their error bounds (two thirds of the work: random rays that hit
 * large triangles near their origin call this for one hit in six). The
 * bounds the hit was accepted with, [rlo, rhi], hold the exact t, so the
 * double t is clamped to them: where the double is unreliable (den near 0)
 * the report is still inside the bound. Not to [lo, hi], which comparisons
 * with other hits may have tightened: the report would then depend on
 * which hits this one met (sc_exact_hit). */
void sc_exact_report(const sc_ray *r, sc_exact_hit *best)
{
    float tri[9];
    load_tri(best->rows, best->W, best->lane, tri);
    const double d[3] = { r->dir[0], r->dir[1], r->dir[2] };
    double a[3][3];
    dvol_rel(r, tri, a);
    const double dd = dvol_dd(d);
    double vol[3], tau[3];
    for (int e = 0; e < 3; e++) {
        vol[e] = dvol_edge(d, a[dvol_p[e]], a[dvol_q[e]]);
        tau[e] = dvol_tau(a[e], d, dd);
    }
    double den;
    const double t = dvol_t(vol, tau, &den);
    if (!(den != 0 && isfinite(t)))
        return;
    float tf = (float)t;
    tf = tf < best->rlo ? best->rlo : tf > best->rhi ? best->rhi : tf;
    best->t = tf;
    best->u = (float)(vol[1] / den);
    best->v = (float)(vol[2] / den);
    clamp_t(r, best);
}
