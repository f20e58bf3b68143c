/* Transversal crossing or tangential touch (see crossing.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <mpfr.h>

#include "crossing.h"
#include "tri_filter.h"

/* Every input is a float: an integer multiple of 2^-149 below 2^128 in
 * magnitude. A difference of two is a multiple of 2^-149 below 2^129 (278
 * bits); a cross product of differences a multiple of 2^-298 below 2^259;
 * a volume or a.n or D.n a multiple of 2^-447 below 2^389 (836 bits), and
 * tmin * D.n at most 1113 bits. PREC holds all of these exactly. Comparing
 * two t = num/den exactly takes num1 * den2, at most 1672 bits: PREC2. */
#define PREC 1152
#define PREC2 1792

static const char *const kind_names[] = { "none", "cross", "touch", "ambiguous" };

const char *sc_cross_kind_name(sc_cross_kind k)
{
    return (unsigned)k <= SC_CROSS_AMBIG ? kind_names[k] : "unknown";
}

/* ---- the conservative double filter -------------------------------------- */

int sc_cross_may_hit(const sc_ray *r, const float tri[9])
{
    /* The oracle's own filter on the same widened inputs, so both skip
     * exactly the same triangles. */
    double v[9], O[3], D[3], t_lo;
    for (int k = 0; k < 9; k++)
        v[k] = tri[k];
    for (int k = 0; k < 3; k++)
        O[k] = r->org[k], D[k] = r->dir[k];
    return sc_tri_filter(v, O, D, r->tmin, r->tmax, &t_lo);
}

/* ---- exact classification ----------------------------------------------- */

typedef struct xhit {
    uint32_t tri;
    uint8_t pert;
    int8_t facing;
    mpfr_t num, den;          /* t = num / den, den > 0 */
} xhit;

typedef struct xwork {
    mpfr_t O[3], D[3], a[3], b[3], c[3], e[3][3], n[3], x[3], vol[3], dx[3], t1, t2;
    mpfr_t p1, p2;            /* PREC2 */
} xwork;

static void work_init(xwork *w)
{
    for (int i = 0; i < 3; i++) {
        mpfr_inits2(PREC, w->O[i], w->D[i], w->a[i], w->b[i], w->c[i], w->n[i], w->x[i], w->vol[i], w->dx[i],
                    (mpfr_ptr)0);
        mpfr_inits2(PREC, w->e[i][0], w->e[i][1], w->e[i][2], (mpfr_ptr)0);
    }
    mpfr_inits2(PREC, w->t1, w->t2, (mpfr_ptr)0);
    mpfr_inits2(PREC2, w->p1, w->p2, (mpfr_ptr)0);
}

static void work_clear(xwork *w)
{
    for (int i = 0; i < 3; i++) {
        mpfr_clears(w->O[i], w->D[i], w->a[i], w->b[i], w->c[i], w->n[i], w->x[i], w->vol[i], w->dx[i],
                    (mpfr_ptr)0);
        mpfr_clears(w->e[i][0], w->e[i][1], w->e[i][2], (mpfr_ptr)0);
    }
    mpfr_clears(w->t1, w->t2, w->p1, w->p2, (mpfr_ptr)0);
}

/* out = p x q, exact. */
static void xcross(xwork *w, mpfr_t out[3], mpfr_t p[3], mpfr_t q[3])
{
    for (int i = 0; i < 3; i++) {
        int j = (i + 1) % 3, k = (i + 2) % 3;
        mpfr_mul(w->t1, p[j], q[k], MPFR_RNDN);
        mpfr_mul(w->t2, p[k], q[j], MPFR_RNDN);
        mpfr_sub(out[i], w->t1, w->t2, MPFR_RNDN);
    }
}

static void xdot(xwork *w, mpfr_t out, mpfr_t p[3], mpfr_t q[3])
{
    mpfr_mul(out, p[0], q[0], MPFR_RNDN);
    mpfr_mul(w->t1, p[1], q[1], MPFR_RNDN);
    mpfr_add(out, out, w->t1, MPFR_RNDN);
    mpfr_mul(w->t1, p[2], q[2], MPFR_RNDN);
    mpfr_add(out, out, w->t1, MPFR_RNDN);
}

/* The four offsets: (primary axis, its sign, secondary axis). */
static void offsets(const float D[3], int prim[4], int sgn[4], int sec[4])
{
    int kz = 0;
    if (fabsf(D[1]) > fabsf(D[kz])) kz = 1;
    if (fabsf(D[2]) > fabsf(D[kz])) kz = 2;
    int a = (kz + 1) % 3, b = (kz + 2) % 3;    /* {D, e_a, e_b} is a basis: D[kz] != 0 */
    prim[0] = a, sgn[0] = 1, sec[0] = b;
    prim[1] = a, sgn[1] = -1, sec[1] = b;
    prim[2] = b, sgn[2] = 1, sec[2] = a;
    prim[3] = b, sgn[3] = -1, sec[3] = a;
}

/* Exact decision for one triangle. Returns 1 on a hit of the closed
 * triangle at t in [tmin, tmax] (h filled, num/den initialised), 0 on a
 * miss, 2 when the line lies in the triangle's plane. */
static int decide(xwork *w, const sc_ray *r, const float v[9], xhit *h)
{
    for (int k = 0; k < 3; k++) {
        mpfr_set_d(w->a[k], v[k], MPFR_RNDN), mpfr_sub(w->a[k], w->a[k], w->O[k], MPFR_RNDN);
        mpfr_set_d(w->b[k], v[3 + k], MPFR_RNDN), mpfr_sub(w->b[k], w->b[k], w->O[k], MPFR_RNDN);
        mpfr_set_d(w->c[k], v[6 + k], MPFR_RNDN), mpfr_sub(w->c[k], w->c[k], w->O[k], MPFR_RNDN);
        /* edge vectors opposite each volume: C-B, A-C, B-A */
        mpfr_set_d(w->e[0][k], v[6 + k], MPFR_RNDN), mpfr_sub_d(w->e[0][k], w->e[0][k], v[3 + k], MPFR_RNDN);
        mpfr_set_d(w->e[1][k], v[k], MPFR_RNDN), mpfr_sub_d(w->e[1][k], w->e[1][k], v[6 + k], MPFR_RNDN);
        mpfr_set_d(w->e[2][k], v[3 + k], MPFR_RNDN), mpfr_sub_d(w->e[2][k], w->e[2][k], v[k], MPFR_RNDN);
    }
    xcross(w, w->x, w->b, w->c), xdot(w, w->vol[0], w->D, w->x);
    xcross(w, w->x, w->c, w->a), xdot(w, w->vol[1], w->D, w->x);
    xcross(w, w->x, w->a, w->b), xdot(w, w->vol[2], w->D, w->x);
    int s[3], pos = 0, neg = 0;
    for (int i = 0; i < 3; i++) {
        s[i] = mpfr_sgn(w->vol[i]);
        pos |= s[i] > 0, neg |= s[i] < 0;
    }
    if (pos && neg)
        return 0;
    /* n = (B-A) x (C-A) = e2 x (-e1) */
    xcross(w, w->n, w->e[1], w->e[2]);          /* (A-C) x (B-A) = (B-A) x (C-A) */
    mpfr_t den;
    mpfr_init2(den, PREC);
    xdot(w, den, w->D, w->n);
    int sd = mpfr_sgn(den);
    if (sd == 0) {
        mpfr_clear(den);
        return !pos && !neg ? 2 : 0;
    }
    if ((sd > 0 && neg) || (sd < 0 && pos)) {
        mpfr_clear(den);
        return 0;
    }
    mpfr_t num;
    mpfr_init2(num, PREC);
    xdot(w, num, w->a, w->n);
    int ok = 1;
    if (isfinite(r->tmin)) {
        mpfr_mul_d(w->t1, den, r->tmin, MPFR_RNDN);
        if (mpfr_cmp(num, w->t1) * sd < 0) ok = 0;
    }
    if (isfinite(r->tmax)) {
        mpfr_mul_d(w->t1, den, r->tmax, MPFR_RNDN);
        if (mpfr_cmp(num, w->t1) * sd > 0) ok = 0;
    } else if (r->tmax < 0) {
        ok = 0;
    }
    if (!ok) {
        mpfr_clears(num, den, (mpfr_ptr)0);
        return 0;
    }
    if (sd < 0) {
        mpfr_neg(num, num, MPFR_RNDN);
        mpfr_neg(den, den, MPFR_RNDN);
    }
    h->facing = (int8_t)sd;
    /* The offsets: a zero volume takes the sign of delta . (D x E). */
    int prim[4], sgn[4], sec[4];
    offsets(r->dir, prim, sgn, sec);
    int dsgn[3][3] = { { 0 } };                            /* [volume][axis] sign of (D x E)_axis */
    for (int i = 0; i < 3; i++) {
        if (s[i] != 0)
            continue;
        xcross(w, w->dx, w->D, w->e[i]);
        for (int k = 0; k < 3; k++)
            dsgn[i][k] = mpfr_sgn(w->dx[k]);
    }
    h->pert = 0;
    for (int p = 0; p < SC_CROSS_PERTURBATIONS; p++) {
        int hit = 1;
        for (int i = 0; i < 3 && hit; i++) {
            int si = s[i];
            if (si == 0) si = sgn[p] * dsgn[i][prim[p]];
            if (si == 0) si = dsgn[i][sec[p]];
            if (si != sd)                        /* 0 here: E parallel to D, so D.n = 0, excluded */
                hit = 0;
        }
        if (hit)
            h->pert |= (uint8_t)(1u << p);
    }
    mpfr_init2(h->num, PREC), mpfr_init2(h->den, PREC);
    mpfr_set(h->num, num, MPFR_RNDN), mpfr_set(h->den, den, MPFR_RNDN);
    mpfr_clears(num, den, (mpfr_ptr)0);
    return 1;
}

/* sign(t_i - t_j), exact. */
static int tcmp(xwork *w, const xhit *i, const xhit *j)
{
    mpfr_mul(w->p1, i->num, j->den, MPFR_RNDN);
    mpfr_mul(w->p2, j->num, i->den, MPFR_RNDN);
    return mpfr_cmp(w->p1, w->p2);
}

void sc_cross_result_free(sc_cross_result *x)
{
    if (!x)
        return;
    free(x->groups);
    memset(x, 0, sizeof *x);
}

size_t sc_cross_result_first(const sc_cross_result *x)
{
    size_t g = 0;
    while (g < x->ngroups && x->groups[g].kind != SC_CROSS_CROSS)
        g++;
    return g;
}

sc_status sc_cross_classify(const sc_ray *r, const float (*tris)[9], const uint32_t *ids, size_t n,
                        sc_cross_result *out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    memset(out, 0, sizeof *out);
    if (!r || (n && (!tris || !ids)))
        return SC_ERR_INVALID_ARGUMENT;
    for (int k = 0; k < 3; k++)
        if (!isfinite(r->org[k]) || !isfinite(r->dir[k]))
            return SC_ERR_INVALID_ARGUMENT;
    if (r->dir[0] == 0 && r->dir[1] == 0 && r->dir[2] == 0)
        return SC_ERR_INVALID_ARGUMENT;
    xwork w;
    work_init(&w);
    for (int k = 0; k < 3; k++) {
        mpfr_set_d(w.O[k], r->org[k], MPFR_RNDN);
        mpfr_set_d(w.D[k], r->dir[k], MPFR_RNDN);
    }
    size_t nh = 0, cap = 8;
    xhit *h = malloc(cap * sizeof *h);
    sc_status st = h ? SC_OK : SC_ERR_OUT_OF_MEMORY;
    for (size_t k = 0; k < n && st == SC_OK; k++) {
        if (nh == cap) {
            xhit *nhp = realloc(h, 2 * cap * sizeof *h);
            if (!nhp) {
                st = SC_ERR_OUT_OF_MEMORY;
                break;
            }
            h = nhp, cap *= 2;
        }
        int d = decide(&w, r, tris[k], &h[nh]);
        if (d == 2)
            out->coplanar++;
        if (d == 1) {
            h[nh].tri = ids[k];
            nh++;
        }
    }
    /* Insertion sort by exact t, stable (few hits per ray). */
    for (size_t i = 1; i < nh && st == SC_OK; i++) {
        xhit tmp = h[i];
        size_t j = i;
        while (j > 0 && tcmp(&w, &h[j - 1], &tmp) > 0) {
            h[j] = h[j - 1];
            j--;
        }
        h[j] = tmp;
    }
    if (st == SC_OK && nh) {
        out->groups = calloc(nh, sizeof *out->groups);
        if (!out->groups)
            st = SC_ERR_OUT_OF_MEMORY;
    }
    for (size_t i = 0; i < nh && st == SC_OK;) {
        size_t j = i + 1;
        while (j < nh && tcmp(&w, &h[i], &h[j]) == 0)
            j++;
        sc_cross_group *g = &out->groups[out->ngroups++];
        mpfr_div(w.t1, h[i].num, h[i].den, MPFR_RNDN);
        g->t = mpfr_get_d(w.t1, MPFR_RNDN);
        g->count = (uint32_t)(j - i);
        int parity[SC_CROSS_PERTURBATIONS] = { 0 };
        for (size_t q = i; q < j; q++) {
            for (int p = 0; p < SC_CROSS_PERTURBATIONS; p++)
                parity[p] ^= (h[q].pert >> p) & 1;
            if (q - i < SC_CROSS_MAX_GROUP) {
                g->tri[q - i] = h[q].tri;
                g->pert[q - i] = h[q].pert;
                g->facing[q - i] = h[q].facing;
            }
        }
        int odd = 0;
        for (int p = 0; p < SC_CROSS_PERTURBATIONS; p++)
            odd += parity[p];
        g->kind = odd == SC_CROSS_PERTURBATIONS ? SC_CROSS_CROSS : odd == 0 ? SC_CROSS_TOUCH : SC_CROSS_AMBIG;
        i = j;
    }
    for (size_t i = 0; i < nh; i++)
        mpfr_clears(h[i].num, h[i].den, (mpfr_ptr)0);
    free(h);
    work_clear(&w);
    if (st != SC_OK)
        sc_cross_result_free(out);
    return st;
}
