/* One body for the batch-sphere kernels of every vector ISA and precision.
 *
 * Included by kernels_<isa>.c with
 *   VP        vector shape prefix (f32x8, f64x4, ...; see simd_vec.h)
 *   REAL      float | double
 *   REAL_U    unit roundoff;  REAL_MIN  smallest normal number
 *   ATTR      the ISA's target attribute
 *   FUNC      name of the kernel to define (sc_kernels.spheres_f / _d)
 *   SOURCE    sc_tri_source_f | sc_tri_source_d;  SOA  sc_spheres_soaf | _soad
 *   LOAD_INDEXED (optional) a full-vector indexed loader (row loads or gathers):
 *             uint32_t LOAD_INDEXED(const SOURCE *src, size_t first, VT P[3][3])
 *             returning the bit mask of lanes with an index out of range.
 *
 * The operation order mirrors src/sphere/circumsphere_template.h, the
 * specification, so that without FMA the result is bit-identical; with FMA
 * each a*b + c below is fused.
 *
 * Two paths. LOCAL(one) is the general one: the specification for every
 * kind and every input (prescaling, degenerate, non-finite, overflowing).
 * The conservative (prefilter) kinds first run LOCAL(fast), the same
 * arithmetic without prescaling on the common in-range triangles, with
 * the subexpressions the minimal-sphere test and the circumcentre share
 * computed once; only a vector with a lane outside that domain also runs
 * the general path, and only for those lanes (LOCAL(finish)).
 */
#include <string.h>

#define TCAT_(a, b) a##_##b
#define TCAT(a, b) TCAT_(a, b)
#define VT TCAT(VP, t)
#define VM TCAT(VP, m)
#define NL TCAT(VP, N)
#define vset1 TCAT(VP, set1)
#define vload TCAT(VP, load)
#define vstore TCAT(VP, store)
#define vstream TCAT(VP, stream)
#define vadd TCAT(VP, add)
#define vsub TCAT(VP, sub)
#define vmul TCAT(VP, mul)
#define vdiv TCAT(VP, div)
#define vfmadd TCAT(VP, fmadd)
#define vfmsub TCAT(VP, fmsub)
#define vmax TCAT(VP, max)
#define vabs TCAT(VP, abs)
#define vlt TCAT(VP, lt)
#define vle TCAT(VP, le)
#define vgt TCAT(VP, gt)
#define vge TCAT(VP, ge)
#define veq TCAT(VP, eq)
#define vfinite TCAT(VP, finite)
#define mand TCAT(VP, and)
#define mor TCAT(VP, or)
#define mandnot TCAT(VP, andnot)
#define vsel TCAT(VP, sel)
#define mbits TCAT(VP, bits)
#define vpow2pair TCAT(VP, pow2pair)
#define LOCAL(name) TCAT(FUNC, name)

/* Fast-path domain (see LOCAL(fast)); float: edges 2^-20..2^20 long, the
 * angle at C at least 2^-24 from 0 and pi; double: 2^-150..2^150, 2^-52. */
#define FAST_F32 (sizeof(REAL) == sizeof(float))
#define FAST_L_LO ((REAL)(FAST_F32 ? 0x1p-40 : 0x1p-300))
#define FAST_L_HI ((REAL)(FAST_F32 ? 0x1p40 : 0x1p300))
#define FAST_SIN2 ((REAL)(FAST_F32 ? 0x1p-48 : 0x1p-104))
#define FAST_NN_LO ((REAL)(FAST_F32 ? 0x1p-96 : 0x1p-800))
#define FAST_R2_HI ((REAL)(FAST_F32 ? FLT_MAX : DBL_MAX))

typedef struct { VT x, y, z; } LOCAL(v3);

static inline ATTR LOCAL(v3) LOCAL(sub3)(LOCAL(v3) p, LOCAL(v3) q)
{
    return (LOCAL(v3)){ vsub(p.x, q.x), vsub(p.y, q.y), vsub(p.z, q.z) };
}

static inline ATTR LOCAL(v3) LOCAL(add3)(LOCAL(v3) p, LOCAL(v3) q)
{
    return (LOCAL(v3)){ vadd(p.x, q.x), vadd(p.y, q.y), vadd(p.z, q.z) };
}

/* x0*y0 + x1*y1 + x2*y2, summed left to right as in the specification. */
static inline ATTR VT LOCAL(dot3)(LOCAL(v3) p, LOCAL(v3) q)
{
    return vfmadd(p.z, q.z, vfmadd(p.y, q.y, vmul(p.x, q.x)));
}

static inline ATTR LOCAL(v3) LOCAL(cross3)(LOCAL(v3) p, LOCAL(v3) q)
{
    return (LOCAL(v3)){ vfmsub(p.y, q.z, vmul(p.z, q.y)), vfmsub(p.z, q.x, vmul(p.x, q.z)),
                        vfmsub(p.x, q.y, vmul(p.y, q.x)) };
}

static inline ATTR LOCAL(v3) LOCAL(sel3)(VM m, LOCAL(v3) p, LOCAL(v3) q)
{
    return (LOCAL(v3)){ vsel(m, p.x, q.x), vsel(m, p.y, q.y), vsel(m, p.z, q.z) };
}

static inline ATTR VM LOCAL(finite3)(LOCAL(v3) p)
{
    return mand(mand(vfinite(p.x), vfinite(p.y)), vfinite(p.z));
}

/* Circumcentre offset from V2 and r^2 in the prescaled frame; *ok marks the
 * lanes that are not degenerate for this method. */
static inline ATTR void LOCAL(circum)(LOCAL(v3) a, LOCAL(v3) b, int method,
                                      LOCAL(v3) *off, VT *r2, VM *ok)
{
    const VT zero = vset1(0), half = vset1((REAL)0.5), one = vset1(1);
    LOCAL(v3) n = LOCAL(cross3)(a, b);
    VT aa = LOCAL(dot3)(a, a), bb = LOCAL(dot3)(b, b);
    switch (method) {
    case SC_METHOD_TEXTBOOK:
    default: {
        VT nn = LOCAL(dot3)(n, n);
        *ok = vgt(nn, zero);
        LOCAL(v3) u = { vfmsub(aa, b.x, vmul(bb, a.x)), vfmsub(aa, b.y, vmul(bb, a.y)),
                        vfmsub(aa, b.z, vmul(bb, a.z)) };
        LOCAL(v3) un = LOCAL(cross3)(u, n);
        VT inv = vdiv(one, vadd(nn, nn));
        *off = (LOCAL(v3)){ vmul(un.x, inv), vmul(un.y, inv), vmul(un.z, inv) };
        LOCAL(v3) amb = LOCAL(sub3)(a, b);
        *r2 = vdiv(vmul(vmul(aa, bb), LOCAL(dot3)(amb, amb)), vmul(nn, vset1(4)));
        break;
    }
    case SC_METHOD_CRAMER: {
        LOCAL(v3) bxn = LOCAL(cross3)(b, n), nxa = LOCAL(cross3)(n, a);
        VT det = LOCAL(dot3)(a, bxn);
        *ok = vgt(det, zero);
        VT ha = vmul(aa, half), hb = vmul(bb, half);
        *off = (LOCAL(v3)){ vdiv(vfmadd(ha, bxn.x, vmul(hb, nxa.x)), det),
                            vdiv(vfmadd(ha, bxn.y, vmul(hb, nxa.y)), det),
                            vdiv(vfmadd(ha, bxn.z, vmul(hb, nxa.z)), det) };
        *r2 = LOCAL(dot3)(*off, *off);
        break;
    }
    case SC_METHOD_PROJECTIVE_LITERAL: {
        /* The appendix's four 3x3 minors of [x1; x2; x3], x3_w = 0 included:
         * this method is measured as printed, zero products and all. */
        const VT x1[4] = { a.x, a.y, a.z, vmul(aa, vset1((REAL)-0.5)) };
        const VT x2[4] = { b.x, b.y, b.z, vmul(bb, vset1((REAL)-0.5)) };
        const VT x3[4] = { n.x, n.y, n.z, zero };
        static const int keep[4][3] = { { 1, 2, 3 }, { 0, 2, 3 }, { 0, 1, 3 }, { 0, 1, 2 } };
        VT q[4];
        for (int j = 0; j < 4; j++) {
            const int *k = keep[j];
            LOCAL(v3) p1 = { x1[k[0]], x1[k[1]], x1[k[2]] };
            LOCAL(v3) p2 = { x2[k[0]], x2[k[1]], x2[k[2]] };
            LOCAL(v3) p3 = { x3[k[0]], x3[k[1]], x3[k[2]] };
            VT minor = LOCAL(dot3)(p1, LOCAL(cross3)(p2, p3));
            q[j] = (j & 1) ? vmul(minor, vset1(-1)) : minor;   /* exact, -0 included */
        }
        *ok = vlt(q[3], zero);
        VT inv = vdiv(one, q[3]);
        *off = (LOCAL(v3)){ vmul(q[0], inv), vmul(q[1], inv), vmul(q[2], inv) };
        LOCAL(v3) qv = { q[0], q[1], q[2] };
        *r2 = vdiv(LOCAL(dot3)(qv, qv), vmul(q[3], q[3]));
        break;
    }
    case SC_METHOD_PROJECTIVE_REDUCED: {
        VT ha = vmul(aa, vset1((REAL)-0.5)), hb = vmul(bb, vset1((REAL)-0.5));
        LOCAL(v3) D = { vfmsub(a.x, hb, vmul(ha, b.x)), vfmsub(a.y, hb, vmul(ha, b.y)),
                        vfmsub(a.z, hb, vmul(ha, b.z)) };
        LOCAL(v3) q = LOCAL(cross3)(n, D);
        VT qw = vmul(LOCAL(dot3)(n, n), vset1(-1));
        *ok = vlt(qw, zero);
        VT inv = vdiv(one, qw);
        *off = (LOCAL(v3)){ vmul(q.x, inv), vmul(q.y, inv), vmul(q.z, inv) };
        *r2 = vdiv(LOCAL(dot3)(q, q), vmul(qw, qw));
        break;
    }
    }
}

/* One vector of triangles (vertices P[k]) to spheres. bad: lanes to force
 * to the never-rejecting sphere (out-of-range index). */
static inline ATTR void LOCAL(one)(const LOCAL(v3) P[3], VM bad, int method, int kind,
                                   unsigned flags, LOCAL(v3) *centre, VT *radius2)
{
    const VT zero = vset1(0), inf = vset1((REAL)INFINITY);
    VM fin_in = mand(mand(LOCAL(finite3)(P[0]), LOCAL(finite3)(P[1])), LOCAL(finite3)(P[2]));
    fin_in = mandnot(bad, fin_in);

    /* C opposite the longest edge (same comparisons as the specification). */
    LOCAL(v3) eab = LOCAL(sub3)(P[0], P[1]), ebc = LOCAL(sub3)(P[1], P[2]), eca = LOCAL(sub3)(P[2], P[0]);
    VT ab = LOCAL(dot3)(eab, eab), bc = LOCAL(dot3)(ebc, ebc), ca = LOCAL(dot3)(eca, eca);
    VM rot1 = mand(vgt(bc, ab), vge(bc, ca));
    VM rot2 = mandnot(rot1, mand(vgt(ca, ab), vgt(ca, bc)));
    LOCAL(v3) V0 = LOCAL(sel3)(rot1, P[1], LOCAL(sel3)(rot2, P[2], P[0]));
    LOCAL(v3) V1 = LOCAL(sel3)(rot1, P[2], LOCAL(sel3)(rot2, P[0], P[1]));
    LOCAL(v3) V2 = LOCAL(sel3)(rot1, P[0], LOCAL(sel3)(rot2, P[1], P[2]));

    LOCAL(v3) a = LOCAL(sub3)(V0, V2), b = LOCAL(sub3)(V1, V2);
    VT m = vmax(vmax(vmax(vabs(a.x), vabs(a.y)), vmax(vabs(a.z), vabs(b.x))),
                vmax(vabs(b.y), vabs(b.z)));
    VM allsame = veq(m, zero);
    VT down = vset1(1), up = vset1(1);
    if (!(flags & SC_KFLAG_NO_PRESCALE)) {
        vpow2pair(m, &down, &up);
        a = (LOCAL(v3)){ vmul(a.x, down), vmul(a.y, down), vmul(a.z, down) };
        b = (LOCAL(v3)){ vmul(b.x, down), vmul(b.y, down), vmul(b.z, down) };
    }

    LOCAL(v3) off, c;
    VT r2s, r2;
    VM ok;
    LOCAL(circum)(a, b, method, &off, &r2s, &ok);
    ok = mand(ok, mand(LOCAL(finite3)(off), vfinite(r2s)));
    ok = mandnot(allsame, ok);
    LOCAL(v3) cc_ = { vfmadd(off.x, up, V2.x), vfmadd(off.y, up, V2.y), vfmadd(off.z, up, V2.z) };
    VT cr2 = vmul(vmul(r2s, up), up);
    VM circ_ok = mand(ok, mand(LOCAL(finite3)(cc_), vfinite(cr2)));

    if (kind == SC_BATCH_CIRCUM) {
        /* r2 underflowing to 0 is an error for the circumsphere itself. */
        VM keep = mand(fin_in, mandnot(mand(vgt(r2s, zero), veq(cr2, zero)), circ_ok));
        *centre = LOCAL(sel3)(keep, cc_, (LOCAL(v3)){ zero, zero, zero });
        *radius2 = vsel(keep, cr2, inf);
        return;
    }

    /* Minimal sphere, as the specification: right or obtuse at vertex X iff
     * (P - X).(R - X) <= 0, tested at every vertex on jointly prescaled
     * edges e[i] = P[i+1] - P[i]; then the opposite edge's midpoint. */
    LOCAL(v3) e[3] = { LOCAL(sub3)(P[1], P[0]), LOCAL(sub3)(P[2], P[1]), LOCAL(sub3)(P[0], P[2]) };
    VT em = zero;
    for (int i = 0; i < 3; i++)
        em = vmax(em, vmax(vmax(vabs(e[i].x), vabs(e[i].y)), vabs(e[i].z)));
    VT edown = vset1(1), eup = vset1(1);
    if (!(flags & SC_KFLAG_NO_PRESCALE)) {
        vpow2pair(em, &edown, &eup);
        for (int i = 0; i < 3; i++)
            e[i] = (LOCAL(v3)){ vmul(e[i].x, edown), vmul(e[i].y, edown), vmul(e[i].z, edown) };
    }
    const VT half = vset1((REAL)0.5), quarter = vset1((REAL)0.25);
    VM have = veq(zero, vset1(1));                     /* all false */
    VT lowest = zero;
    LOCAL(v3) e_opp = e[1], base = P[1];
    for (int i = 0; i < 3; i++) {
        VT d = vmul(LOCAL(dot3)(e[i], e[(i + 2) % 3]), vset1(-1));
        VM take = mand(vle(d, lowest), mor(mandnot(have, vle(d, lowest)), vlt(d, lowest)));
        e_opp = LOCAL(sel3)(take, e[(i + 1) % 3], e_opp);
        base = LOCAL(sel3)(take, P[(i + 1) % 3], base);
        lowest = vsel(take, d, lowest);
        have = mor(have, take);
    }
    LOCAL(v3) mc = { vfmadd(vmul(e_opp.x, half), eup, base.x), vfmadd(vmul(e_opp.y, half), eup, base.y),
                     vfmadd(vmul(e_opp.z, half), eup, base.z) };
    VT mr2s = vmul(LOCAL(dot3)(e_opp, e_opp), quarter);
    VT mr2 = vmul(vmul(mr2s, eup), eup);

    /* Acute to working precision but degenerate for the circumcentre: the
     * longest edge's midpoint sphere, widened to reach the third vertex. */
    VT len2[3];
    for (int i = 0; i < 3; i++)
        len2[i] = LOCAL(dot3)(e[i], e[i]);
    LOCAL(v3) el = e[0], eprev = e[2], lbase = P[0];
    VT llen = len2[0];
    for (int i = 1; i < 3; i++) {
        VM longer = vgt(len2[i], llen);
        el = LOCAL(sel3)(longer, e[i], el);
        eprev = LOCAL(sel3)(longer, e[(i + 2) % 3], eprev);
        lbase = LOCAL(sel3)(longer, P[i], lbase);
        llen = vsel(longer, len2[i], llen);
    }
    LOCAL(v3) loff = { vmul(el.x, half), vmul(el.y, half), vmul(el.z, half) };
    LOCAL(v3) dv = { vmul(vadd(eprev.x, loff.x), vset1(-1)), vmul(vadd(eprev.y, loff.y), vset1(-1)),
                     vmul(vadd(eprev.z, loff.z), vset1(-1)) };
    VT wr2s = LOCAL(dot3)(dv, dv);
    wr2s = vsel(vgt(vmul(llen, quarter), wr2s), vmul(llen, quarter), wr2s);
    LOCAL(v3) wc = { vfmadd(loff.x, eup, lbase.x), vfmadd(loff.y, eup, lbase.y), vfmadd(loff.z, eup, lbase.z) };
    VT wr2 = vmul(vmul(wr2s, eup), eup);

    /* All three vertices equal: the point itself. */
    VM allsame_e = veq(em, zero);
    VM use_mid = mor(allsame_e, have);
    mc = LOCAL(sel3)(allsame_e, P[2], mc);
    mr2 = vsel(allsame_e, zero, mr2);
    mr2s = vsel(allsame_e, zero, mr2s);
    VM use_wide = mandnot(use_mid, mandnot(ok, fin_in));
    LOCAL(v3) minc = LOCAL(sel3)(use_mid, mc, LOCAL(sel3)(use_wide, wc, cc_));
    VT minr2 = vsel(use_mid, mr2, vsel(use_wide, wr2, cr2));
    VT minr2s = vsel(use_mid, mr2s, vsel(use_wide, wr2s, r2s));
    /* Finite centre (what the prefilter needs) and, for the minimal kind
     * itself, a finite r2 that did not underflow to 0. */
    VM centre_ok = mand(fin_in, LOCAL(finite3)(minc));
    VM minimal_ok = mand(centre_ok, mandnot(mand(vgt(minr2s, zero), veq(minr2, zero)), vfinite(minr2)));

    if (kind == SC_BATCH_MINIMAL) {
        *centre = LOCAL(sel3)(minimal_ok, minc, (LOCAL(v3)){ zero, zero, zero });
        *radius2 = vsel(minimal_ok, minr2, inf);
        return;
    }

    /* Conservative kinds: the circumcentre where it exists (prefilter-circum),
     * else the minimal sphere's centre; then r2 from the stored centre. */
    VM use_circ = mand(fin_in, circ_ok);
    if (kind != SC_BATCH_PREFILTER_CIRCUM)
        use_circ = mandnot(use_circ, use_circ);
    c = LOCAL(sel3)(use_circ, cc_, minc);
    VM have_c = mor(use_circ, centre_ok);
    VT worst = zero;
    for (int k = 0; k < 3; k++) {
        LOCAL(v3) d = LOCAL(sub3)(P[k], c);
        VT dd = LOCAL(dot3)(d, d);
        worst = vsel(vle(dd, worst), worst, dd);     /* NaN poisons, as specified */
    }
    r2 = vadd(vmul(worst, vset1(1 + 8 * REAL_U)), vset1(16 * REAL_MIN));
    have_c = mand(have_c, mand(vfinite(r2), LOCAL(finite3)(c)));
    *centre = LOCAL(sel3)(have_c, c, (LOCAL(v3)){ zero, zero, zero });
    *radius2 = vsel(have_c, r2, inf);
}

/* Fast path of the conservative kinds for the common case, bit for bit the
 * computation of LOCAL(one) without its prescaling: every edge's squared
 * length L_i in [FAST_L_LO, FAST_L_HI] (so every input is finite, no
 * vertex repeats, and no product below can overflow), and, where the
 * circumcentre is used, |n|^2 >= FAST_SIN2 |a|^2 |b|^2 (the angle at C is
 * not within ~u of 0 or pi) and |n|^2 >= FAST_NN_LO (no product that
 * matters is subnormal). In that range the power-of-two scaling of the
 * specification is exact, so skipping it changes no bit except where a
 * negligible subnormal intermediate rounds differently. What is shared:
 * the three edges give the longest-edge rotation, a, b, |a|^2, |b|^2, the
 * obtuse test (the largest angle is the one opposite the longest edge) and
 * the midpoint; the circumcentre and the padded r2 reuse them.
 * Returns the lanes that need the general path (LOCAL(one)). */
static inline ATTR __attribute__((always_inline)) VM LOCAL(fast)(const LOCAL(v3) P[3], int method, int kind, LOCAL(v3) *centre, VT *radius2)
{
    const VT lo = vset1(FAST_L_LO), hi = vset1(FAST_L_HI);
    LOCAL(v3) e0 = LOCAL(sub3)(P[1], P[0]), e1 = LOCAL(sub3)(P[2], P[1]), e2 = LOCAL(sub3)(P[0], P[2]);
    VT L0 = LOCAL(dot3)(e0, e0), L1 = LOCAL(dot3)(e1, e1), L2 = LOCAL(dot3)(e2, e2);
    /* Ordered compares: NaN (non-finite input) fails them. */
    VM ok = mand(mand(mand(vge(L0, lo), vle(L0, hi)), mand(vge(L1, lo), vle(L1, hi))),
                 mand(vge(L2, lo), vle(L2, hi)));
    /* The specification's rotation: C opposite the longest edge e_k, ties as
     * there. With a = V0 - V2 = e_{k+2} and b = V1 - V2 = -e_{k+1}, the
     * textbook formula below is written with e' = e_{k+1} and the signs
     * folded in, which rounds exactly like the specification's a, b. */
    VM rot1 = mand(vgt(L1, L0), vge(L1, L2));
    VM rot2 = mandnot(rot1, mand(vgt(L2, L0), vgt(L2, L1)));
    LOCAL(v3) a = LOCAL(sel3)(rot1, e0, LOCAL(sel3)(rot2, e1, e2));
    LOCAL(v3) ep = LOCAL(sel3)(rot1, e2, LOCAL(sel3)(rot2, e0, e1));
    LOCAL(v3) V2 = LOCAL(sel3)(rot1, P[0], LOCAL(sel3)(rot2, P[1], P[2]));
    VT aa = vsel(rot1, L0, vsel(rot2, L1, L2)), bb = vsel(rot1, L2, vsel(rot2, L0, L1));

    LOCAL(v3) n = LOCAL(cross3)(a, ep);                         /* -(a x b) */
    VT nn = LOCAL(dot3)(n, n);
    LOCAL(v3) off;
    VM circ_ok;
    if (method == SC_METHOD_TEXTBOOK) {
        LOCAL(v3) u = { vfmadd(aa, ep.x, vmul(bb, a.x)), vfmadd(aa, ep.y, vmul(bb, a.y)),
                        vfmadd(aa, ep.z, vmul(bb, a.z)) };      /* -(aa b - bb a) */
        LOCAL(v3) un = LOCAL(cross3)(u, n);
        VT inv = vdiv(vset1(1), vadd(nn, nn));
        off = (LOCAL(v3)){ vmul(un.x, inv), vmul(un.y, inv), vmul(un.z, inv) };
        circ_ok = veq(lo, lo);
    } else {
        /* The other methods as the general path has them (b negated: only
         * the sign of a zero can differ). */
        const VT m1 = vset1(-1);
        LOCAL(v3) b = { vmul(ep.x, m1), vmul(ep.y, m1), vmul(ep.z, m1) };
        VT r2s;
        LOCAL(circum)(a, b, method, &off, &r2s, &circ_ok);
    }
    /* Rounded offset then sum, like the specification's V2 + off * up. */
    LOCAL(v3) c = LOCAL(add3)(V2, off);
    circ_ok = mand(circ_ok, mand(vge(nn, vset1(FAST_NN_LO)), vge(nn, vmul(vmul(aa, vset1(FAST_SIN2)), bb))));
    if (kind == SC_BATCH_PREFILTER_MINIMAL) {
        /* Right or obtuse at C iff a.b <= 0: the longest edge's midpoint,
         * V0 + e_k / 2 as in the specification. The specification tests
         * every vertex and takes the most obtuse; where the rounded tests
         * call another vertex right or obtuse too (needles whose two long
         * edges tie to working precision) the general path decides. */
        LOCAL(v3) eL = LOCAL(sel3)(rot1, e1, LOCAL(sel3)(rot2, e2, e0));
        LOCAL(v3) V0 = LOCAL(sel3)(rot1, P[1], LOCAL(sel3)(rot2, P[2], P[0]));
        const VT zero = vset1(0), half = vset1((REAL)0.5);
        VM obtuse = vge(LOCAL(dot3)(a, ep), zero);
        VM other = mor(vge(LOCAL(dot3)(eL, a), zero), vge(LOCAL(dot3)(ep, eL), zero));
        LOCAL(v3) mid = { vfmadd(eL.x, half, V0.x), vfmadd(eL.y, half, V0.y), vfmadd(eL.z, half, V0.z) };
        c = LOCAL(sel3)(obtuse, mid, c);
        ok = mand(ok, mandnot(other, mor(obtuse, circ_ok)));
    } else {
        ok = mand(ok, circ_ok);
    }
    VT worst = vset1(0);
    for (int k = 0; k < 3; k++) {
        LOCAL(v3) d = LOCAL(sub3)(P[k], c);
        worst = vmax(worst, LOCAL(dot3)(d, d));
    }
    VT r2 = vadd(vmul(worst, vset1(1 + 8 * REAL_U)), vset1(16 * REAL_MIN));
    *centre = c;
    *radius2 = r2;
    return mandnot(mand(ok, vle(r2, vset1(FAST_R2_HI))), veq(lo, lo));   /* lanes not ok */
}

/* Lanes [first, first + NL) with lanes >= count padded by zeros; returns
 * the out-of-range-index lanes. Scalar loads: for tails and ISAs without
 * gathers. */
static inline ATTR uint32_t LOCAL(load_lanes)(const SOURCE *src, size_t first, size_t count,
                                              LOCAL(v3) P[3])
{
    REAL buf[3][3][NL];
    uint32_t bad = 0;
    for (int l = 0; l < NL; l++) {
        size_t t = first + (size_t)l;
        for (int k = 0; k < 3; k++) {
            REAL xyz[3] = { 0, 0, 0 };
            if (t < count) {
                if (src->indices) {
                    uint32_t v = src->indices[3 * t + (size_t)k];
                    if (v < src->vertex_count) {
                        const REAL *p = src->vertices + 3 * (size_t)v;
                        xyz[0] = p[0], xyz[1] = p[1], xyz[2] = p[2];
                    } else {
                        bad |= 1u << l;
                    }
                } else {
                    xyz[0] = src->soa[k][0][t], xyz[1] = src->soa[k][1][t], xyz[2] = src->soa[k][2][t];
                }
            }
            buf[k][0][l] = xyz[0], buf[k][1][l] = xyz[1], buf[k][2][l] = xyz[2];
        }
    }
    for (int k = 0; k < 3; k++)
        P[k] = (LOCAL(v3)){ vload(buf[k][0]), vload(buf[k][1]), vload(buf[k][2]) };
    return bad;
}

/* Stores of one vector of results: streaming (non-temporal) for outputs
 * far larger than the caches, which then skip the read-for-ownership of
 * lines that are only written, like a large memcpy does. */
static inline ATTR void LOCAL(put)(const SOA *out, size_t i, LOCAL(v3) c, VT r2, int nt)
{
    if (nt) {
        vstream(out->cx + i, c.x);
        vstream(out->cy + i, c.y);
        vstream(out->cz + i, c.z);
        vstream(out->r2 + i, r2);
    } else {
        vstore(out->cx + i, c.x);
        vstore(out->cy + i, c.y);
        vstore(out->cz + i, c.z);
        vstore(out->r2 + i, r2);
    }
}

/* The vectors the fast path cannot finish: the general path for the lanes
 * in `need`, blended with the fast lanes (so a lane's result never
 * depends on its neighbours). Out of line so that the fast loop keeps its
 * values in registers; plain stores. */
static ATTR __attribute__((noinline)) void LOCAL(finish)(const LOCAL(v3) P[3], VM bad, VM need,
                                                         const LOCAL(v3) *cf, const VT *r2f, int method,
                                                         int kind, unsigned flags, const SOA *out, size_t i)
{
    LOCAL(v3) c;
    VT r2;
    LOCAL(one)(P, bad, method, kind, flags, &c, &r2);
    LOCAL(put)(out, i, LOCAL(sel3)(need, c, *cf), vsel(need, r2, *r2f), 0);
}

/* One vector of triangles to its stored spheres. P and every result stay
 * in registers on the fast path: only LOCAL(finish) and LOCAL(one), out of
 * line, see copies in memory. */
static inline ATTR __attribute__((always_inline)) void LOCAL(step)(LOCAL(v3) P0, LOCAL(v3) P1, LOCAL(v3) P2, uint32_t bad, int fast,
                                    int method, int kind, unsigned flags, const SOA *out, size_t i, int nt)
{
    const LOCAL(v3) P[3] = { P0, P1, P2 };
    VM badm = TCAT(VP, mask_from_bits)(bad);
    if (fast) {
        LOCAL(v3) c;
        VT r2;
        VM need = mor(LOCAL(fast)(P, method, kind, &c, &r2), badm);
        if (__builtin_expect(mbits(need) == 0, 1)) {
            LOCAL(put)(out, i, c, r2, nt);
        } else {
            LOCAL(v3) Q[3] = { P0, P1, P2 }, cf = c;
            VT r2f = r2;
            LOCAL(finish)(Q, badm, need, &cf, &r2f, method, kind, flags, out, i);
        }
    } else {
        LOCAL(v3) Q[3] = { P0, P1, P2 }, c;
        VT r2;
        LOCAL(one)(Q, badm, method, kind, flags, &c, &r2);
        LOCAL(put)(out, i, c, r2, nt);
    }
}

static ATTR size_t FUNC(const SOURCE *src, size_t count, int method, int kind, unsigned flags,
                        const SOA *out)
{
    size_t nbad = 0, i = 0;
    const int fast = kind >= SC_BATCH_PREFILTER_CIRCUM && !(flags & SC_KFLAG_GENERAL);
    const uintptr_t align = (uintptr_t)out->cx | (uintptr_t)out->cy | (uintptr_t)out->cz | (uintptr_t)out->r2;
    const int nt = count >= SC_STREAM_MIN_COUNT && align % (NL * sizeof(REAL)) == 0 && !(flags & SC_KFLAG_NO_STREAM);
    const SOA o = *out;
    if (!src->indices) {
        const REAL *soa[3][3];
        memcpy(soa, src->soa, sizeof soa);
        for (; i + NL <= count; i += NL) {
            LOCAL(v3) P[3];
            for (int k = 0; k < 3; k++)
                P[k] = (LOCAL(v3)){ vload(soa[k][0] + i), vload(soa[k][1] + i), vload(soa[k][2] + i) };
            LOCAL(step)(P[0], P[1], P[2], 0, fast, method, kind, flags, &o, i, nt);
        }
    }
    else {
        /* Shuffled index buffers miss the caches on every vertex: touch the
         * vertices of the triangles a few vectors ahead so that their
         * misses overlap (large batches only; indices are read in order). */
        const size_t pf = count >= SC_STREAM_MIN_COUNT ? SC_PREFETCH_AHEAD : 0;
        for (; i + NL <= count; i += NL) {
            LOCAL(v3) P[3];
            if (pf && i + pf + NL <= count)
                for (size_t t = 3 * (i + pf); t < 3 * (i + pf + NL); t++)
                    __builtin_prefetch((const void *)((uintptr_t)src->vertices +
                                                      (uintptr_t)src->indices[t] * (3 * sizeof(REAL))));
#ifdef LOAD_INDEXED
            uint32_t bad = LOAD_INDEXED(src, i, P);
#else
            uint32_t bad = LOCAL(load_lanes)(src, i, count, P);
#endif
            nbad += (size_t)__builtin_popcount(bad);
            LOCAL(step)(P[0], P[1], P[2], bad, fast, method, kind, flags, &o, i, nt);
        }
    }
    for (; i < count; i += NL) {
        LOCAL(v3) P[3];
        uint32_t bad = LOCAL(load_lanes)(src, i, count, P);
        nbad += (size_t)__builtin_popcount(bad);
        LOCAL(step)(P[0], P[1], P[2], bad, fast, method, kind, flags, &o, i, nt);
    }
    if (nt)
        sc_store_fence();
    /* Padding lanes (and what the last vector wrote past count): empty. */
    size_t padded = (count + 15) & ~(size_t)15;
    for (size_t t = count; t < padded; t++)
        o.cx[t] = o.cy[t] = o.cz[t] = 0, o.r2[t] = -1;
    return nbad;
}

#undef TCAT_
#undef TCAT
#undef VT
#undef VM
#undef NL
#undef vset1
#undef vload
#undef vstore
#undef vstream
#undef vadd
#undef vsub
#undef vmul
#undef vdiv
#undef vfmadd
#undef vfmsub
#undef vmax
#undef vabs
#undef vlt
#undef vle
#undef vgt
#undef vge
#undef veq
#undef vfinite
#undef mand
#undef mor
#undef mandnot
#undef vsel
#undef mbits
#undef vpow2pair
#undef LOCAL
#undef FAST_F32
#undef FAST_L_LO
#undef FAST_L_HI
#undef FAST_SIN2
#undef FAST_NN_LO
#undef FAST_R2_HI
