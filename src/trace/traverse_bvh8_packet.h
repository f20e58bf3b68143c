/* The packet traversal of the 8-wide BVH: PK rays (8 or 16), one per vector
 * lane, walk the tree together; one body for every ISA and width. The
 * translation unit (traverse_bvh8_x86.h) defines before each inclusion
 *   SC_TARGET, SC_X86_INLINE   as for the single-ray template
 *   PK                         the packet width, 8 or 16
 *   VP                         the simd_vec.h shape with PK lanes
 * and gets closest_packet<PK>() and any_packet<PK>() for the watertight test.
 *
 * Exactness. Every lane is the single-ray query of traverse_bvh8_single.h
 * with the same triangle test: the per-ray constants are sc_ray_precompute's,
 * each box test of a lane is the single ray's (node_bvh8_slab.h), and the
 * triangle test is tri_watertight.h's operation sequence with the rays in the
 * lanes instead of the triangles (no FMA, same order), so a lane computes
 * the same t, U, V, W, det bits for a triangle as the single ray does. The
 * closest hit is the smallest (t, prim) of the triangles a lane tests, which
 * does not depend on the order they are visited in. A packet visits more
 * boxes than each of its rays would; a lane only ever tests triangles whose
 * boxes it passes itself (the lane masks go down the tree with the nodes).
 *
 * Spheres. A packet whose rays share their origin (camera rays) is bounded
 * by a cone around the mean direction; a leaf's circumspheres that lie
 * outside the cone remove their triangles for every ray of the packet at
 * once (pk_cone_cull), before the triangle tests: the job where one sphere
 * test replaces PK ray-triangle tests.
 */
#include <math.h>
#include <string.h>

#include "bvh/bvh_internal.h"
#include "traverse_stack.h"

/* Lanes at or below this count leave the packet for single rays. */
#ifndef SC_PACKET_THIN
#define SC_PACKET_THIN 2
#endif
/* A leaf reached by this many lanes or fewer is tested a lane at a time,
 * all its triangles at once (pk_leaf_lanes): 16-ray bounce packets 5 %
 * faster than with every leaf tested a triangle at a time, camera and
 * shadow packets level; 8 lanes as good as 5 (docs/compare.md,
 * twenty-ninth session). */
#ifndef SC_PACKET_LEAF_LANES
#define SC_PACKET_LEAF_LANES 5
#endif

#define PCAT_(a, b) a##_##b
#define PCAT(a, b) PCAT_(a, b)
#define PV(op) PCAT(VP, op)
#define PGLUE_(a, b) a##b
#define PGLUE(a, b) PGLUE_(a, b)
#define PFN(name) PGLUE(name, PK)
#define PKT PGLUE(sc_ray_packet, PK)
#define HITP PGLUE(sc_hit_packet, PK)

typedef PV(t) PFN(pvec);
#define pvec PFN(pvec)

typedef struct {
    float rd[3][PK] __attribute__((aligned(64)));
    float ordn[3][PK] __attribute__((aligned(64)));
    float ordf[3][PK] __attribute__((aligned(64)));
    float org[3][PK] __attribute__((aligned(64)));
    float Sx[PK] __attribute__((aligned(64)));
    float Sy[PK] __attribute__((aligned(64)));
    float Sz[PK] __attribute__((aligned(64)));
    float tmin[PK] __attribute__((aligned(64)));
    float tmax[PK] __attribute__((aligned(64)));
    uint32_t neg[3];              /* lanes whose direction is negative on axis k */
    uint32_t kx1, kx2, ky1, ky2, kz1, kz2;   /* lanes whose shear axis kx (ky, kz) is 1 or 2 */
    int uniform;                  /* every traced lane has the same octant and shear axes */
    int kx, ky, kz, oct;          /* those, when uniform */
    /* the frustum of a uniform packet, per axis: extreme reciprocals and
     * padded offsets over the traced lanes (pk_frustum_node) */
    float fr_rdmin[3], fr_rdmax[3], fr_onmax[3], fr_ofmin[3], fr_tmin;
    int cone;                     /* every traced lane has the same origin: the cone below */
    float apex[3], axis[3], cos_t, sin_t;
} PFN(pk_ctx);
#define pk_ctx PFN(pk_ctx)

/* The cone around the packet (lanes: the traced lanes, origins equal): unit
 * directions n_i, axis a their normalised sum; sin_t >= every |a x n_i|
 * with 2^-18 to spare for the float rounding of n_i, a and the products
 * (each below 2^-21), cos_t <= the matching cosine. Only for packets
 * narrower than 60 degrees (every a.n_i > 1/2), where a cone can cull. */
SC_X86_INLINE int PFN(pk_cone)(pk_ctx *c, pvec dx, pvec dy, pvec dz, uint32_t lanes, const PKT *r)
{
    const PV(m) lm = PV(mask_from_bits)(lanes);
    const pvec zero = PV(set1)(0);
    pvec l = PV(sqrt)(PV(add)(PV(add)(PV(mul)(dx, dx), PV(mul)(dy, dy)), PV(mul)(dz, dz)));
    pvec nx = PV(sel)(lm, PV(div)(dx, l), zero), ny = PV(sel)(lm, PV(div)(dy, l), zero),
         nz = PV(sel)(lm, PV(div)(dz, l), zero);
    /* the sum of the directions: sum the lanes through memory (PK <= 16) */
    float sx[PK], sy[PK], sz[PK];
    PV(store)(sx, nx), PV(store)(sy, ny), PV(store)(sz, nz);
    float tx = 0, ty = 0, tz = 0;
    for (unsigned i = 0; i < PK; i++)
        tx += sx[i], ty += sy[i], tz += sz[i];
    float al = sqrtf(tx * tx + ty * ty + tz * tz);
    if (!(al > 0))
        return 0;
    tx /= al, ty /= al, tz /= al;
    const pvec Ax = PV(set1)(tx), Ay = PV(set1)(ty), Az = PV(set1)(tz);
    pvec cx = PV(sub)(PV(mul)(Ay, nz), PV(mul)(Az, ny)), cy = PV(sub)(PV(mul)(Az, nx), PV(mul)(Ax, nz)),
         cz = PV(sub)(PV(mul)(Ax, ny), PV(mul)(Ay, nx));
    pvec co = PV(add)(PV(add)(PV(mul)(Ax, nx), PV(mul)(Ay, ny)), PV(mul)(Az, nz));
    if ((PV(bits)(PV(gt)(co, PV(set1)(0.5f))) & lanes) != lanes)
        return 0;
    pvec sn = PV(sel)(lm, PV(sqrt)(PV(add)(PV(add)(PV(mul)(cx, cx), PV(mul)(cy, cy)), PV(mul)(cz, cz))), zero);
    float s = -PV(hmin)(PV(sub)(zero, sn));
    s = s * (1 + 0x1p-10f) + 0x1p-18f;
    if (!(s < 0.86f))
        return 0;
    c->axis[0] = tx, c->axis[1] = ty, c->axis[2] = tz;
    c->sin_t = s;
    c->cos_t = sqrtf(1 - s * s) * (1 - 0x1p-18f);
    const unsigned f = (unsigned)__builtin_ctz(lanes);
    c->apex[0] = r->ox[f], c->apex[1] = r->oy[f], c->apex[2] = r->oz[f];
    return 1;
}

/* Lane l's axis from the lanes whose axis is 1 (m1) and 2 (m2). */
SC_X86_INLINE int PFN(pk_axis)(uint32_t m1, uint32_t m2, unsigned l)
{
    return (int)((m1 >> l & 1) | (m2 >> l & 1) << 1);
}

/* The smallest lane of each of v[0..16): out[i] = min of v[i] (no NaN
 * lanes), with simd_vec.h's transposing reductions: about 45 operations
 * for 16 lanes where 16 reductions of one vector each took about 130, and
 * the frustum's 13 were most of a camera packet's set-up time. */
SC_X86_INLINE void PFN(pk_hmin16)(const pvec v[16], float out[16])
{
#if PK == 16
    _mm512_store_ps(out, f32x16_hmin16(v));
#else
    _mm256_store_ps(out, f32x8_hmin8(v));
    _mm256_store_ps(out + 8, f32x8_hmin8(v + 8));
#endif
}

/* Per-lane set-up of the traced lanes in vectors: sc_ray_precompute's
 * operations (and sc_shear_axes' choice) lane by lane, so every lane has
 * the single ray's bits. Returns the lanes that are parallel rays (some
 * |d_k| < SC_MIN_RCP_INPUT): the caller traces those singly. Every other
 * lane (not asked for, or parallel) is loaded as a copy of a traced lane,
 * so no vector operation sees garbage, and reductions over all PK lanes
 * (the frustum, the octant, whether the packet is uniform) are reductions
 * over the traced lanes without a mask. cone: try the cone (the BVH has
 * spheres). */
SC_X86_INLINE uint32_t PFN(pk_init)(pk_ctx *c, const sc_bvh *bvh, const PKT *r, uint32_t lanes, int cone)
{
    const uint32_t full = PK == 16 ? 0xffffu : 0xffu;
    pvec o[3], d[3], tmin, tmax, ad[3];
    const pvec tiny = PV(set1)(SC_MIN_RCP_INPUT), one = PV(set1)(1.0f), zero = PV(set1)(0);
    uint32_t par = 0, tl = lanes;
    for (int pass = 0; pass < 2; pass++) {
        if (tl == full) {
            o[0] = PV(load)(r->ox), o[1] = PV(load)(r->oy), o[2] = PV(load)(r->oz);
            d[0] = PV(load)(r->dx), d[1] = PV(load)(r->dy), d[2] = PV(load)(r->dz);
            tmin = PV(load)(r->tmin), tmax = PV(load)(r->tmax);
        } else {
            const unsigned f = (unsigned)__builtin_ctz(tl);
            const PV(m) lm = PV(mask_from_bits)(tl);
#define LD(row) PV(sel)(lm, PV(load)(r->row), PV(set1)(r->row[f]))
            o[0] = LD(ox), o[1] = LD(oy), o[2] = LD(oz);
            d[0] = LD(dx), d[1] = LD(dy), d[2] = LD(dz);
            tmin = LD(tmin), tmax = LD(tmax);
#undef LD
        }
        for (int k = 0; k < 3; k++)
            ad[k] = PV(abs)(d[k]);
        if (pass)
            break;
        for (int k = 0; k < 3; k++)
            par |= PV(bits)(PV(lt)(ad[k], tiny));
        par &= lanes;
        if (!par)
            break;
        /* parallel lanes: load the others again, now as copies of a
         * lane that is traced here (rare) */
        tl = lanes & ~par;
        if (!tl) {
            c->uniform = 1;
            c->cone = 0;
            return par;
        }
    }
    c->cone = 0;
    uint32_t neg[3];
    for (int k = 0; k < 3; k++) {
        const pvec rd = PV(div)(one, d[k]);
        const pvec m = PV(max)(PV(abs)(PV(sub)(PV(set1)(bvh->root_lo[k]), o[k])),
                               PV(abs)(PV(sub)(PV(set1)(bvh->root_hi[k]), o[k])));
        const pvec g = PV(fmadd)(PV(abs)(o[k]), PV(set1)(0x1.0cp-23f),
                                 PV(fmadd)(m, PV(set1)(0x1.0cp-23f), PV(set1)(0x1p-123f)));
        const pvec pad = PV(fmadd)(PV(abs)(rd), g, PV(fmadd)(m, PV(set1)(0x1p-124f), PV(set1)(0x1p-122f)));
        const pvec ord = PV(mul)(o[k], rd);
        PV(store)(c->rd[k], rd);
        PV(store)(c->ordn[k], PV(add)(ord, pad));
        PV(store)(c->ordf[k], PV(sub)(ord, pad));
        PV(store)(c->org[k], o[k]);
        neg[k] = PV(bits)(PV(lt)(d[k], zero));
        c->neg[k] = neg[k] & tl;
    }
    /* sc_shear_axes: kz = 0; |d1| > |d0| -> 1; |d2| > |d_kz| -> 2; then
     * kx = kz + 1, ky = kx + 1 (mod 3), swapped where d[kz] < 0 */
    const PV(m) z1 = PV(gt)(ad[1], ad[0]);
    const PV(m) z2 = PV(gt)(ad[2], PV(sel)(z1, ad[1], ad[0]));
#define BYKZ(a0, a1, a2) PV(sel)(z2, (a2), PV(sel)(z1, (a1), (a0)))   /* kz 0 -> a0, 1 -> a1, 2 -> a2 */
    const pvec dkz = BYKZ(d[0], d[1], d[2]);
    const PV(m) sw = PV(lt)(dkz, zero);
    /* unswapped: kz 0 -> (1, 2), 1 -> (2, 0), 2 -> (0, 1) */
    const pvec dkx0 = BYKZ(d[1], d[2], d[0]), dky0 = BYKZ(d[2], d[0], d[1]);
    PV(store)(c->Sx, PV(div)(PV(sel)(sw, dky0, dkx0), dkz));
    PV(store)(c->Sy, PV(div)(PV(sel)(sw, dkx0, dky0), dkz));
    /* Sz = 1 / d[kz]: the lane's rd on axis kz, the same division */
    PV(store)(c->Sz, BYKZ(PV(load)(c->rd[0]), PV(load)(c->rd[1]), PV(load)(c->rd[2])));
#undef BYKZ
    PV(store)(c->tmin, tmin);
    PV(store)(c->tmax, tmax);
    const uint32_t b1 = PV(bits)(z1), b2 = PV(bits)(z2), bs = PV(bits)(sw);
    const uint32_t kz1 = b1 & ~b2, kz2 = b2, kz0 = ~(kz1 | kz2) & full;
    const uint32_t kx1 = (kz0 & ~bs) | (kz2 & bs), kx2 = (kz1 & ~bs) | (kz0 & bs);
    const uint32_t ky1 = (kz2 & ~bs) | (kz0 & bs), ky2 = (kz0 & ~bs) | (kz1 & bs);
    c->kx1 = kx1 & tl, c->kx2 = kx2 & tl, c->ky1 = ky1 & tl, c->ky2 = ky2 & tl;
    c->kz1 = kz1 & tl, c->kz2 = kz2 & tl;
    /* uniform: the octant and the shear axes (kz and the swap) the same
     * in every lane; lane 0 holds a traced lane's ray */
    uint32_t mixed = 0;
    const uint32_t all[6] = { neg[0], neg[1], neg[2], kz1, kz2, bs };
    for (int i = 0; i < 6; i++)
        mixed |= all[i] ^ ((0u - (all[i] & 1)) & full);
    c->uniform = mixed == 0;
    c->oct = (int)((neg[0] & 1) | (neg[1] & 1) << 1 | (neg[2] & 1) << 2);
    c->kx = PFN(pk_axis)(kx1, kx2, 0), c->ky = PFN(pk_axis)(ky1, ky2, 0), c->kz = PFN(pk_axis)(kz1, kz2, 0);
    if (c->uniform) {
        /* the frustum (pk_frustum_node): 13 minima, maxima as minima of
         * the negations */
        pvec v[16];
        for (int k = 0; k < 3; k++) {
            const pvec rd = PV(load)(c->rd[k]);
            v[k] = rd, v[3 + k] = PV(neg)(rd);
            v[6 + k] = PV(neg)(PV(load)(c->ordn[k])), v[9 + k] = PV(load)(c->ordf[k]);
        }
        v[12] = tmin;
        for (int i = 13; i < 16; i++)
            v[i] = PV(set1)(INFINITY);
        float mins[16] __attribute__((aligned(64)));
        PFN(pk_hmin16)(v, mins);
        for (int k = 0; k < 3; k++) {
            c->fr_rdmin[k] = mins[k], c->fr_rdmax[k] = -mins[3 + k];
            c->fr_onmax[k] = -mins[6 + k], c->fr_ofmin[k] = mins[9 + k];
        }
        c->fr_tmin = mins[12];
    }
    if (cone && __builtin_popcount(tl) > 1) {
        /* one origin: every lane's bits equal lane 0's */
        uint32_t same = full;
        for (int k = 0; k < 3; k++)
            same &= PV(bits)(PV(eq)(o[k], PV(set1)(c->org[k][0])));
        if (same == full)
            c->cone = PFN(pk_cone)(c, d[0], d[1], d[2], tl, r);
    }
    return par;
}

/* Spheres of lanes [0, W) of a leaf's sphere block that lie outside the
 * packet's cone: a bit set means no ray of the packet meets the sphere.
 * With v = c - apex, d = v.a and e = |v x a| (the cross product, not
 * sqrt(v.v - d^2), which cancels near the axis), the sphere is outside the
 * cone when e cos - max(d, 0) sin > r (the distance from the centre to the
 * cone's surface; d <= 0 only ever loosens the test, so the cone's sin and
 * cos may both err outward). The rounding of v, d and e is below 2^-21 |v|;
 * r grows by 2^-16 (|vx| + |vy| + |vz|) and by 2^-10 r, and cos shrinks by
 * 2^-10: the square roots of r^2 and e^2 come from the approximate
 * reciprocal square root (error below 2^-11), two multiplies instead of two
 * divisions' worth of latency. Centres with v.v
 * outside [2^-100, 2^100] (subnormal or flushed products, overflow) and
 * empty lanes are never culled here. */
SC_X86_INLINE uint32_t PFN(pk_cone_cull)(const pk_ctx *c, const float *blk, unsigned W)
{
    const pvec ax = PV(set1)(c->axis[0]), ay = PV(set1)(c->axis[1]), az = PV(set1)(c->axis[2]);
    /* cos lowered by 2^-10 for the approximate sqrt of e^2 */
    const pvec cs = PV(set1)(c->cos_t * (1 - 0x1p-10f)), sn = PV(set1)(c->sin_t), zero = PV(set1)(0);
    const pvec grow = PV(set1)(1 + 0x1p-10f), slack = PV(set1)(0x1p-16f);
    uint32_t cull = 0;
    for (unsigned h = 0; h < W; h += PK) {
        pvec vx = PV(sub)(PV(load)(blk + h), PV(set1)(c->apex[0]));
        pvec vy = PV(sub)(PV(load)(blk + W + h), PV(set1)(c->apex[1]));
        pvec vz = PV(sub)(PV(load)(blk + 2 * W + h), PV(set1)(c->apex[2]));
        pvec r2 = PV(load)(blk + 3 * W + h);
        pvec vv = PV(add)(PV(add)(PV(mul)(vx, vx), PV(mul)(vy, vy)), PV(mul)(vz, vz));
        pvec d = PV(add)(PV(add)(PV(mul)(vx, ax), PV(mul)(vy, ay)), PV(mul)(vz, az));
        pvec ex = PV(sub)(PV(mul)(vy, az), PV(mul)(vz, ay));
        pvec ey = PV(sub)(PV(mul)(vz, ax), PV(mul)(vx, az));
        pvec ez = PV(sub)(PV(mul)(vx, ay), PV(mul)(vy, ax));
        pvec ee = PV(add)(PV(add)(PV(mul)(ex, ex), PV(mul)(ey, ey)), PV(mul)(ez, ez));
        pvec l1 = PV(add)(PV(add)(PV(abs)(vx), PV(abs)(vy)), PV(abs)(vz));
        /* square roots from the approximate reciprocal (error below
         * 2^-11): r rounded up, e down; x * rsqrt(x) is NaN for x = 0,
         * which culls nothing */
        pvec r = PV(add)(PV(mul)(PV(mul)(r2, PV(rsqrt)(r2)), grow), PV(mul)(l1, slack));
        pvec rhs = PV(add)(r, PV(mul)(PV(max)(d, zero), sn));
        pvec lhs = PV(mul)(PV(mul)(ee, PV(rsqrt)(ee)), cs);
        PV(m) out = PV(gt)(lhs, rhs);
        PV(m) trusted = PV(and)(PV(and)(PV(ge)(vv, PV(set1)(0x1p-100f)), PV(le)(vv, PV(set1)(0x1p100f))),
                                PV(ge)(r2, zero));
        cull |= PV(bits)(PV(and)(out, trusted)) << h;
    }
    return cull;
}

typedef struct {
    uint64_t ref;
    uint32_t mask;
    float dist;
} PFN(pk_entry);

/* The node test of a uniform packet (every lane in one octant): one 8-wide
 * test of the node's children against the packet's frustum instead of one
 * per child against every lane. For a plane x, min_i fl(x rd_i - b_i) >=
 * fl(x r - b_max) with r = the smallest rd_i for x >= 0 and the largest for
 * x < 0 (the sign bit picks, as blendv does), since rounding is monotone:
 * the frustum's near distance is never above any lane's, its far distance
 * never below (b_min, the other r). A child that any lane's own test
 * (node_bvh8_slab.h) passes therefore passes here; dist gets the near
 * bound, a lower bound of every lane's entry distance. The lanes' offsets
 * b_i differ with their origins, so this holds for any uniform packet; one
 * origin (camera rays) only makes the bounds tight. On AVX-512 the same r
 * as the smaller of the two products (the larger for the far plane): x r
 * is smallest for that r, and rounding is monotone. GCC lowers blendv
 * there to an integer compare of the row, which it moves through the
 * stack (about 60 instructions a node, against 30). */
SC_X86_INLINE unsigned PFN(pk_frustum_node)(const pk_ctx *c, const sc_bvh_node8 *node, int nr0, int nr1,
                                            int nr2, int fr0, int fr1, int fr2, float tmax_hi, float *dist)
{
#if SC_X86_AVX512
#define FNEAR(row, k)                                                                              \
    _mm256_min_ps(_mm256_fmsub_ps(_mm256_load_ps(node->b[row]), _mm256_set1_ps(c->fr_rdmin[k]),    \
                                  _mm256_set1_ps(c->fr_onmax[k])),                                 \
                  _mm256_fmsub_ps(_mm256_load_ps(node->b[row]), _mm256_set1_ps(c->fr_rdmax[k]),    \
                                  _mm256_set1_ps(c->fr_onmax[k])))
#define FFAR(row, k)                                                                               \
    _mm256_max_ps(_mm256_fmsub_ps(_mm256_load_ps(node->b[row]), _mm256_set1_ps(c->fr_rdmax[k]),    \
                                  _mm256_set1_ps(c->fr_ofmin[k])),                                 \
                  _mm256_fmsub_ps(_mm256_load_ps(node->b[row]), _mm256_set1_ps(c->fr_rdmin[k]),    \
                                  _mm256_set1_ps(c->fr_ofmin[k])))
#else
#define FNEAR(row, k)                                                                              \
    _mm256_fmsub_ps(_mm256_load_ps(node->b[row]),                                               \
                    _mm256_blendv_ps(_mm256_set1_ps(c->fr_rdmin[k]), _mm256_set1_ps(c->fr_rdmax[k]), \
                                     _mm256_load_ps(node->b[row])),                             \
                    _mm256_set1_ps(c->fr_onmax[k]))
#define FFAR(row, k)                                                                               \
    _mm256_fmsub_ps(_mm256_load_ps(node->b[row]),                                               \
                    _mm256_blendv_ps(_mm256_set1_ps(c->fr_rdmax[k]), _mm256_set1_ps(c->fr_rdmin[k]), \
                                     _mm256_load_ps(node->b[row])),                             \
                    _mm256_set1_ps(c->fr_ofmin[k]))
#endif
    __m256 tn = _mm256_max_ps(_mm256_max_ps(FNEAR(nr0, 0), FNEAR(nr1, 1)),
                              _mm256_max_ps(FNEAR(nr2, 2), _mm256_set1_ps(c->fr_tmin)));
    __m256 tf = _mm256_min_ps(_mm256_min_ps(FFAR(fr0, 0), FFAR(fr1, 1)),
                              _mm256_min_ps(FFAR(fr2, 2), _mm256_set1_ps(tmax_hi)));
#undef FNEAR
#undef FFAR
    _mm256_store_ps(dist, tn);
    return (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(tn, tf, _CMP_LE_OQ));
}

/* A packet's best hit so far per lane (closest): t (the lanes' tmax), the
 * unnormalised barycentrics un / den and vn / den, the primitive id (its
 * bit pattern in a float lane) and the geometric normal (sc_leaf_normal);
 * got: the lanes that have one. A lane without a hit keeps its start
 * values, which are the miss record (t = its tmax, u = v = 0, ng = 0,
 * prim = SC_HITREC_MISS). */
typedef struct {
    pvec t, un, vn, den, prim, ng[3];
    uint32_t got;
} PFN(pk_best);

/* The same, lane by lane: for the rare paths that update single lanes
 * (pk_best_spill, pk_best_offer, then pk_best_fill). */
typedef struct {
    float t[PK], un[PK], vn[PK], den[PK], ng[3][PK];
    uint32_t prim[PK];
} PFN(pk_best_lanes);

SC_X86_INLINE void PFN(pk_best_spill)(const PFN(pk_best) *b, PFN(pk_best_lanes) *a)
{
    PV(store)(a->t, b->t), PV(store)(a->un, b->un), PV(store)(a->vn, b->vn), PV(store)(a->den, b->den);
    PV(store)((float *)(void *)a->prim, b->prim);
    for (int k = 0; k < 3; k++)
        PV(store)(a->ng[k], b->ng[k]);
}

SC_X86_INLINE void PFN(pk_best_fill)(PFN(pk_best) *b, const PFN(pk_best_lanes) *a)
{
    b->t = PV(load)(a->t), b->un = PV(load)(a->un), b->vn = PV(load)(a->vn), b->den = PV(load)(a->den);
    b->prim = PV(load)((const float *)(const void *)a->prim);
    for (int k = 0; k < 3; k++)
        b->ng[k] = PV(load)(a->ng[k]);
}

/* A hit (t, u, v already divided out, prim, normal) for lane l: kept if it
 * is nearer, or as near with a smaller primitive id (the tie rule). */
SC_X86_INLINE void PFN(pk_best_offer)(PFN(pk_best) *b, PFN(pk_best_lanes) *a, unsigned l, float t, float u,
                                      float v, uint32_t prim, const float ng[3])
{
    if (!(t < a->t[l] || prim < a->prim[l]))
        return;
    a->t[l] = t, a->un[l] = u, a->vn[l] = v, a->den[l] = 1, a->prim[l] = prim;
    a->ng[0][l] = ng[0], a->ng[1][l] = ng[1], a->ng[2][l] = ng[2];
    b->got |= 1u << l;
}

/* Lanes m finish the subtree ref as single rays (traverse_bvh8_single.h,
 * the same kernel as sc_trace_closest / sc_trace_any) with tmax = the
 * lane's best t so far. */
SC_X86_INLINE void PFN(pk_single)(const sc_bvh *bvh, const PKT *r, uint64_t ref, uint32_t m, PFN(pk_best) *best,
                                  uint32_t *alive, sc_trace_stats *st, const int ANY, const int STATS)
{
    PFN(pk_best_lanes) a;
    if (ANY)
        PV(store)(a.t, best->t);
    else
        PFN(pk_best_spill)(best, &a);
    for (; m; m &= m - 1) {
        const unsigned l = (unsigned)__builtin_ctz(m);
        const sc_ray ray = { { r->ox[l], r->oy[l], r->oz[l] }, r->tmin[l], { r->dx[l], r->dy[l], r->dz[l] }, a.t[l] };
        sc_hitrec h;
        int hit;
        if (STATS) {
            hit = subtree_stats_watertight(bvh, &ray, &h, st, ref, ANY);
            st->rays--;                       /* counted once, by the packet */
        } else if (ANY) {
            hit = any_subtree_watertight(bvh, &ray, ref);
        } else {
            closest_subtree_watertight(bvh, &ray, &h, ref);
            hit = 0;
        }
        if (ANY) {
            if (hit)
                *alive &= ~(1u << l);
        } else if (h.prim != SC_HITREC_MISS) {
            PFN(pk_best_offer)(best, &a, l, h.t, h.u, h.v, h.prim, h.ng);
        }
    }
    if (!ANY)
        PFN(pk_best_fill)(best, &a);
}

/* Lanes m test a leaf's triangles `live` one lane at a time, eight
 * triangles a pass: the single ray's leaf test (leaf_test) with the lane's
 * shear constants, so each lane gets the bits it gets in the packet loop
 * below (and as a single ray). A packet loop pass costs the same for one
 * lane as for all, so a leaf that few lanes reach is cheaper this way.
 * Returns the lanes an any-hit test found occluded; closest: the lanes'
 * best hits updated as the single ray's leaf_visit does. */
SC_X86_INLINE uint32_t PFN(pk_leaf_lanes)(const pk_ctx *c, const float *rows, unsigned W, unsigned live, uint32_t m,
                                          const uint32_t *prims, PFN(pk_best) *best, sc_trace_stats *st,
                                          const int ANY, const int STATS, const int UNI)
{
    PFN(pk_best_lanes) a;
    if (ANY)
        PV(store)(a.t, best->t);
    else
        PFN(pk_best_spill)(best, &a);
    uint32_t occ = 0;
    for (; m; m &= m - 1) {
        const unsigned l = (unsigned)__builtin_ctz(m);
        trace_ctx tc;
        tc.kx = UNI ? c->kx : PFN(pk_axis)(c->kx1, c->kx2, l);
        tc.ky = UNI ? c->ky : PFN(pk_axis)(c->ky1, c->ky2, l);
        tc.kz = UNI ? c->kz : PFN(pk_axis)(c->kz1, c->kz2, l);
        tc.okx = _mm256_set1_ps(c->org[tc.kx][l]);
        tc.oky = _mm256_set1_ps(c->org[tc.ky][l]);
        tc.okz = _mm256_set1_ps(c->org[tc.kz][l]);
        tc.Sx = _mm256_set1_ps(c->Sx[l]), tc.Sy = _mm256_set1_ps(c->Sy[l]), tc.Sz = _mm256_set1_ps(c->Sz[l]);
        tc.tmin = _mm256_set1_ps(c->tmin[l]);
        float t[16] __attribute__((aligned(64))), te[16] __attribute__((aligned(64)));
        float un[16] __attribute__((aligned(64))), vn[16] __attribute__((aligned(64)));
        float den[16] __attribute__((aligned(64)));
        if (STATS)
            st->tri_tests += (uint64_t)__builtin_popcount(live);
        const unsigned hm = leaf_test(&tc, rows, W, live, c->tmin[l], a.t[l], SC_TRI_WATERTIGHT, t, te, un, vn, den);
        if (!hm)
            continue;
        if (STATS)
            st->tri_hits += (uint64_t)__builtin_popcount(hm);
        if (ANY) {
            occ |= 1u << l;
            continue;
        }
        const unsigned bi = sc_nearest_lane(hm, t, prims);
        float ng[3];
        sc_leaf_normal(rows, W, bi, ng);
        PFN(pk_best_offer)(best, &a, l, t[bi], un[bi] / den[bi], vn[bi] / den[bi], prims[bi], ng);
    }
    if (!ANY)
        PFN(pk_best_fill)(best, &a);
    return occ;
}

/* A leaf for lanes *mp of one packet: the cone cull (one origin), then its
 * triangles, lane by lane when few lanes reach it (pk_leaf_lanes), else one
 * triangle at a time over the lanes. Any: the lanes found occluded leave
 * *mp and *alivep; closest: best holds each lane's nearest hit. Shared by
 * the packet traversal and the stream groups (traverse_group_any). */
SC_X86_INLINE void PFN(pk_leaf)(const sc_bvh *bvh, const pk_ctx *c, uint64_t ref, uint32_t *mp, uint32_t *alivep,
                                PFN(pk_best) *bestp, sc_trace_stats *st, const int ANY, const int STATS, const int UNI)
{
    uint32_t m = *mp, alive = *alivep;
    PFN(pk_best) *const best = bestp;
    const pvec tminv = PV(load)(c->tmin), zero = PV(set1)(0);
    const unsigned n = sc_ref_count(ref), W = sc_leaf_width(n);
    const float *block = sc_leaf_block(bvh->leaves, ref);
    const float *rows = sc_leaf_rows(block, W, ref);
    const uint32_t *prims = sc_leaf_prims(rows, W);
    uint32_t live = (1u << n) - 1;
    if (STATS)
        st->leaves++;
    if (c->cone && (ref & (SC_REF_SPHERES | SC_REF_SUMMARY))) {
        _Alignas(64) float dec[4 * 16];
        if (sc_ref_has_summary(ref)) {
            if (W < PK)   /* the cull reads PK lanes a row: no uninitialised ones */
                __builtin_memset(dec, 0, sizeof dec);
            summary_decode(block, W, dec);
        }
        uint32_t cull = PFN(pk_cone_cull)(c, sc_ref_has_summary(ref) ? dec : block, W) & live;
        if (STATS) {
            /* per ray, as the single-ray counters */
            const uint64_t rays = (uint64_t)__builtin_popcount(m);
            st->sphere_tests += n * rays;
            st->sphere_rejects += (uint64_t)__builtin_popcount(cull) * rays;
        }
        live &= ~cull;
    }
    if (live && __builtin_popcount(m) <= SC_PACKET_LEAF_LANES) {
        const uint32_t occ = PFN(pk_leaf_lanes)(c, rows, W, live, m, prims, best, st, ANY, STATS, UNI);
        if (ANY)
            alive &= ~occ, m &= ~occ;
        live = 0;   /* the triangles are done */
    }
    /* v - o as (-o) + v: IEEE subtraction is the addition of
     * the negation, and addition commutes, so the bits are the
     * single ray's (-o by its sign bit, so a subnormal origin
     * reads the same under DAZ and flushes the same under FTZ);
     * with the vertex as the second operand, AVX-512 folds its
     * broadcast into the addition */
    const pvec o0 = PV(neg)(PV(load)(c->org[0])), o1 = PV(neg)(PV(load)(c->org[1])),
               o2 = PV(neg)(PV(load)(c->org[2]));
    const pvec Sx = PV(load)(c->Sx), Sy = PV(load)(c->Sy), Sz = PV(load)(c->Sz);
    /* a uniform packet's rows kx, ky, kz of vertex A; B and C
     * follow at 3W and 6W (sc_leaf_at) */
    const float *rx = rows + (size_t)(UNI ? c->kx : 0) * W, *ry = rows + (size_t)(UNI ? c->ky : 0) * W,
                *rz = rows + (size_t)(UNI ? c->kz : 0) * W;
    const pvec okx = UNI ? (c->kx == 0 ? o0 : c->kx == 1 ? o1 : o2) : o0;
    const pvec oky = UNI ? (c->ky == 0 ? o0 : c->ky == 1 ? o1 : o2) : o0;
    const pvec okz = UNI ? (c->kz == 0 ? o0 : c->kz == 1 ? o1 : o2) : o0;
    /* lanes of other shear axes: each lane's axes, picked once a leaf */
    const PV(m) mx1 = PV(mask_from_bits)(UNI ? 0 : c->kx1), mx2 = PV(mask_from_bits)(UNI ? 0 : c->kx2);
    const PV(m) my1 = PV(mask_from_bits)(UNI ? 0 : c->ky1), my2 = PV(mask_from_bits)(UNI ? 0 : c->ky2);
    const PV(m) mz1 = PV(mask_from_bits)(UNI ? 0 : c->kz1), mz2 = PV(mask_from_bits)(UNI ? 0 : c->kz2);
    for (; live && m; live &= live - 1) {
        const unsigned i = (unsigned)__builtin_ctz(live);
        if (STATS)
            st->tri_tests += (uint64_t)__builtin_popcount(m);
#define VTX(j, k) PV(set1)(rows[sc_leaf_at(W, (j), (k), i)])
        pvec Akz, Bkz, Ckz, Ax, Ay, Bx, By, Cx, Cy;
        if (UNI) {
            const size_t ia = i, ib = i + 3 * (size_t)W, ic = i + 6 * (size_t)W;
            Akz = PV(add)(okz, PV(set1)(rz[ia]));
            Bkz = PV(add)(okz, PV(set1)(rz[ib]));
            Ckz = PV(add)(okz, PV(set1)(rz[ic]));
            Ax = PV(sub)(PV(add)(okx, PV(set1)(rx[ia])), PV(mul)(Sx, Akz));
            Ay = PV(sub)(PV(add)(oky, PV(set1)(ry[ia])), PV(mul)(Sy, Akz));
            Bx = PV(sub)(PV(add)(okx, PV(set1)(rx[ib])), PV(mul)(Sx, Bkz));
            By = PV(sub)(PV(add)(oky, PV(set1)(ry[ib])), PV(mul)(Sy, Bkz));
            Cx = PV(sub)(PV(add)(okx, PV(set1)(rx[ic])), PV(mul)(Sx, Ckz));
            Cy = PV(sub)(PV(add)(oky, PV(set1)(ry[ic])), PV(mul)(Sy, Ckz));
        } else {
            /* A[k] = v - o for every axis, then the lane's axes */
            pvec A0 = PV(add)(o0, VTX(0, 0)), A1 = PV(add)(o1, VTX(0, 1)), A2 = PV(add)(o2, VTX(0, 2));
            pvec B0 = PV(add)(o0, VTX(1, 0)), B1 = PV(add)(o1, VTX(1, 1)), B2 = PV(add)(o2, VTX(1, 2));
            pvec C0 = PV(add)(o0, VTX(2, 0)), C1 = PV(add)(o1, VTX(2, 1)), C2 = PV(add)(o2, VTX(2, 2));
#define SEL3(k, a0, a1, a2) PV(sel)(m##k##2, (a2), PV(sel)(m##k##1, (a1), (a0)))
            Akz = SEL3(z, A0, A1, A2);
            Bkz = SEL3(z, B0, B1, B2);
            Ckz = SEL3(z, C0, C1, C2);
            Ax = PV(sub)(SEL3(x, A0, A1, A2), PV(mul)(Sx, Akz));
            Ay = PV(sub)(SEL3(y, A0, A1, A2), PV(mul)(Sy, Akz));
            Bx = PV(sub)(SEL3(x, B0, B1, B2), PV(mul)(Sx, Bkz));
            By = PV(sub)(SEL3(y, B0, B1, B2), PV(mul)(Sy, Bkz));
            Cx = PV(sub)(SEL3(x, C0, C1, C2), PV(mul)(Sx, Ckz));
            Cy = PV(sub)(SEL3(y, C0, C1, C2), PV(mul)(Sy, Ckz));
#undef SEL3
        }
#undef VTX
        const pvec U = PV(sub)(PV(mul)(Cx, By), PV(mul)(Cy, Bx));
        const pvec V = PV(sub)(PV(mul)(Ax, Cy), PV(mul)(Ay, Cx));
        const pvec Wv = PV(sub)(PV(mul)(Bx, Ay), PV(mul)(By, Ax));
        /* edge functions of both signs: a miss. As the smallest
         * below zero and the largest above, which differs from
         * the three-way sign test only in lanes with a NaN edge
         * function, whose det and t are NaN, so never a hit. */
        const pvec emin = PV(min)(PV(min)(U, V), Wv), emax = PV(max)(PV(max)(U, V), Wv);
        const PV(m) zm = PV(or)(PV(or)(PV(eq)(U, zero), PV(eq)(V, zero)), PV(eq)(Wv, zero));
        const pvec det = PV(add)(PV(add)(U, V), Wv);
        /* not candidates: both signs, det = 0, or an edge function
         * exactly 0 (those lanes: zr, the double test below) */
        const PV(m) out = PV(or)(PV(or)(PV(and)(PV(lt)(emin, zero), PV(gt)(emax, zero)), PV(eq)(det, zero)), zm);
        uint32_t zr = PV(bits)(zm) & m;
        const uint32_t cand = ~PV(bits)(out) & m;
        uint32_t h = 0;
        pvec tt = zero;
        if (cand) {
            const pvec Az = PV(mul)(Sz, Akz), Bz = PV(mul)(Sz, Bkz), Cz = PV(mul)(Sz, Ckz);
            pvec T = PV(add)(PV(add)(PV(mul)(U, Az), PV(mul)(V, Bz)), PV(mul)(Wv, Cz));
            tt = PV(div)(T, det);
            h = PV(bits)(PV(and)(PV(ge)(tt, tminv), PV(le)(tt, best->t))) & cand;
        }
        if (h) {
            if (STATS)
                st->tri_hits += (uint64_t)__builtin_popcount(h);
            if (ANY) {
                alive &= ~h;
                m &= ~h;
            } else {
                /* of equal t the smaller primitive id */
                uint32_t upd = h & PV(bits)(PV(lt)(tt, best->t));
                if (h & ~upd) {
                    uint32_t bprim[PK];
                    PV(store)((float *)(void *)bprim, best->prim);
                    for (uint32_t e = h & ~upd; e; e &= e - 1) {
                        unsigned l = (unsigned)__builtin_ctz(e);
                        if (prims[i] < bprim[l])
                            upd |= 1u << l;
                    }
                }
                if (upd) {
                    const PV(m) um = PV(mask_from_bits)(upd);
                    float ng[3];
                    sc_leaf_normal(rows, W, i, ng);
                    best->t = PV(sel)(um, tt, best->t);
                    best->un = PV(sel)(um, V, best->un);
                    best->vn = PV(sel)(um, Wv, best->vn);
                    best->den = PV(sel)(um, det, best->den);
                    best->prim = PV(sel)(um, PV(set1_bits)(prims[i]), best->prim);
                    for (int k = 0; k < 3; k++)
                        best->ng[k] = PV(sel)(um, PV(set1)(ng[k]), best->ng[k]);
                    best->got |= upd;
                }
            }
        }
        if (__builtin_expect(zr != 0, 0)) {
            /* Two equal sheared vertices (a triangle with a repeated
             * vertex, or an edge seen end-on) make one edge function
             * zero and the other two exact negatives, in float and
             * in sc_watertight_double alike, so det is exactly 0
             * there and the double test rejects: skip those lanes.
             * CAD meshes have such triangles, and every ray that
             * reaches one would take the double path. */
            const PV(m) dab = PV(and)(PV(eq)(Ax, Bx), PV(eq)(Ay, By));
            const PV(m) dbc = PV(and)(PV(eq)(Bx, Cx), PV(eq)(By, Cy));
            const PV(m) dac = PV(and)(PV(eq)(Ax, Cx), PV(eq)(Ay, Cy));
            zr &= ~PV(bits)(PV(or)(PV(or)(dab, dbc), dac));
        }
        if (__builtin_expect(zr != 0, 0)) {
            /* an exactly zero edge function: sc_watertight_double
             * per lane, as the single ray does */
            float ax[PK], ay[PK], bx[PK], by[PK], cx[PK], cy[PK], az[PK], bz[PK], cz[PK];
            PFN(pk_best_lanes) a;
            PV(store)(ax, Ax), PV(store)(ay, Ay), PV(store)(bx, Bx), PV(store)(by, By);
            PV(store)(cx, Cx), PV(store)(cy, Cy), PV(store)(az, PV(mul)(Sz, Akz));
            PV(store)(bz, PV(mul)(Sz, Bkz)), PV(store)(cz, PV(mul)(Sz, Ckz));
            PFN(pk_best_spill)(best, &a);
            for (uint32_t e = zr; e; e &= e - 1) {
                unsigned l = (unsigned)__builtin_ctz(e);
                float t, u, v;
                if (!sc_watertight_double(ax[l], ay[l], bx[l], by[l], cx[l], cy[l], az[l], bz[l],
                                          cz[l], c->tmin[l], a.t[l], &t, &u, &v))
                    continue;
                if (STATS)
                    st->tri_hits++;
                if (ANY) {
                    alive &= ~(1u << l);
                    m &= ~(1u << l);
                } else {
                    float ng[3];
                    sc_leaf_normal(rows, W, i, ng);
                    PFN(pk_best_offer)(best, &a, l, t, u, v, prims[i], ng);
                }
            }
            if (!ANY)
                PFN(pk_best_fill)(best, &a);
        }
    }
    *mp = m, *alivep = alive;
}

/* The traversal. UNI = 1: every lane has the packet's octant and shear axes
 * (the near planes and the sheared axes are the same rows for all lanes). */
SC_X86_INLINE void PFN(traverse_packet)(const sc_bvh *bvh, const PKT *r, uint32_t lanes, HITP *hit,
                                        int32_t *occluded, const pk_ctx *c, sc_trace_stats *st,
                                        const int ANY, const int STATS, const int UNI)
{
    const pvec rd0 = PV(load)(c->rd[0]), rd1 = PV(load)(c->rd[1]), rd2 = PV(load)(c->rd[2]);
    const pvec on0 = PV(load)(c->ordn[0]), on1 = PV(load)(c->ordn[1]), on2 = PV(load)(c->ordn[2]);
    const pvec of0 = PV(load)(c->ordf[0]), of1 = PV(load)(c->ordf[1]), of2 = PV(load)(c->ordf[2]);
    const pvec tminv = PV(load)(c->tmin);
    const pvec inf = PV(set1)(INFINITY);
    const pvec zero = PV(set1)(0);
    PFN(pk_best) best = { PV(load)(c->tmax), zero, zero, PV(set1)(1), PV(set1_bits)(SC_HITREC_MISS),
                          { zero, zero, zero }, 0 };
    /* the largest tmax of the traced lanes: the frustum's far bound */
    float tmax_hi = -PV(hmin)(PV(sel)(PV(mask_from_bits)(lanes), PV(sub)(zero, best.t), inf));
    uint32_t alive = lanes;       /* any: lanes not yet occluded */
    PFN(pk_entry) stack[SC_TRACE_STACK];
    int sp = 0;
    /* near/far rows of a uniform packet */
    const int oct = c->oct;
    const int nr0 = (oct & 1), nr1 = 2 + ((oct >> 1) & 1), nr2 = 4 + ((oct >> 2) & 1);
    const int fr0 = 1 - (oct & 1), fr1 = 3 - ((oct >> 1) & 1), fr2 = 5 - ((oct >> 2) & 1);
    PV(m) ng0 = PV(mask_from_bits)(c->neg[0]), ng1 = PV(mask_from_bits)(c->neg[1]),
          ng2 = PV(mask_from_bits)(c->neg[2]);
    if (STATS)
        st->rays += (uint64_t)__builtin_popcount(lanes);
    if (!bvh->has_root || !lanes)
        goto done;

    uint64_t ref = 0;
    uint32_t m = lanes;
    for (;;) {
        while (!sc_ref_is_leaf(ref)) {
            if (__builtin_popcount(m) <= SC_PACKET_THIN) {
                /* a thin packet: its lanes finish this subtree as single
                 * rays, each bounded by its own best hit so far */
                PFN(pk_single)(bvh, r, ref, m, &best, &alive, st, ANY, STATS);
                goto pop;
            }
            const sc_bvh_node8 *node = (const sc_bvh_node8 *)(const void *)((const char *)bvh->nodes + ref);
            if (STATS)
                st->nodes++;
            /* children to test lane by lane: in a uniform packet, those
             * the packet's frustum keeps (one 8-wide test culls the rest) */
            unsigned cand = 0xff;
            float fdist[SC_BVH_N] __attribute__((aligned(32)));
            if (UNI) {
                cand = PFN(pk_frustum_node)(c, node, nr0, nr1, nr2, fr0, fr1, fr2, tmax_hi, fdist);
                if (!cand)
                    goto pop;
            }
            uint64_t hr[SC_BVH_N];
            uint32_t hmk[SC_BVH_N];
            float hd[SC_BVH_N];
            pvec htn[SC_BVH_N];
            int cnt = 0;
            for (; cand; cand &= cand - 1) {
                const int k = __builtin_ctz(cand);
                if (!node->child[k])
                    continue;
                pvec nx, ny, nz, fx, fy, fz;
                if (UNI) {
                    nx = PV(set1)(node->b[nr0][k]), fx = PV(set1)(node->b[fr0][k]);
                    ny = PV(set1)(node->b[nr1][k]), fy = PV(set1)(node->b[fr1][k]);
                    nz = PV(set1)(node->b[nr2][k]), fz = PV(set1)(node->b[fr2][k]);
                } else {
                    /* lanes of every octant: near and far planes per lane */
                    pvec lx = PV(set1)(node->b[0][k]), hx = PV(set1)(node->b[1][k]);
                    pvec ly = PV(set1)(node->b[2][k]), hy = PV(set1)(node->b[3][k]);
                    pvec lz = PV(set1)(node->b[4][k]), hz = PV(set1)(node->b[5][k]);
                    nx = PV(sel)(ng0, hx, lx), fx = PV(sel)(ng0, lx, hx);
                    ny = PV(sel)(ng1, hy, ly), fy = PV(sel)(ng1, ly, hy);
                    nz = PV(sel)(ng2, hz, lz), fz = PV(sel)(ng2, lz, hz);
                }
                pvec tn = PV(max)(PV(max)(PV(fmsub)(nx, rd0, on0), PV(fmsub)(ny, rd1, on1)),
                                  PV(max)(PV(fmsub)(nz, rd2, on2), tminv));
                pvec tf = PV(min)(PV(min)(PV(fmsub)(fx, rd0, of0), PV(fmsub)(fy, rd1, of1)),
                                  PV(min)(PV(fmsub)(fz, rd2, of2), best.t));
                uint32_t mk = PV(bits)(PV(le)(tn, tf)) & m;
                if (!mk)
                    continue;
                hr[cnt] = node->child[k];
                hmk[cnt] = mk;
                /* the order key: the frustum's near bound (below every
                 * lane's own entry, pk_frustum_node) where there is one,
                 * else the nearest entry of the child's lanes (below) */
                if (UNI)
                    hd[cnt] = fdist[k];
                else
                    htn[cnt] = tn;
                cnt++;
            }
            if (cnt == 0)
                goto pop;
            if (cnt == 1) {
                ref = hr[0];
                m = hmk[0];
                continue;
            }
            if (!ANY) {
                if (!UNI)
                    for (int i = 0; i < cnt; i++)
                        hd[i] = PV(hmin)(PV(sel)(PV(mask_from_bits)(hmk[i]), htn[i], inf));
                /* near first: insertion sort of the few hit children */
                for (int i = 1; i < cnt; i++) {
                    uint64_t rr = hr[i];
                    uint32_t mm = hmk[i];
                    float dd = hd[i];
                    int j = i;
                    while (j > 0 && hd[j - 1] > dd) {
                        hr[j] = hr[j - 1], hmk[j] = hmk[j - 1], hd[j] = hd[j - 1];
                        j--;
                    }
                    hr[j] = rr, hmk[j] = mm, hd[j] = dd;
                }
            }
            for (int i = cnt - 1; i > 0; i--) {
                if (bvh->prefetch == SC_PREFETCH_ALL)   /* a large tree (bvh_internal.h) */
                    sc_prefetch_ref(bvh, hr[i]);
                stack[sp].ref = hr[i];
                stack[sp].mask = hmk[i];
                stack[sp].dist = ANY ? 0.0f : hd[i];
                sp++;
            }
            ref = hr[0];
            m = hmk[0];
        }
        PFN(pk_leaf)(bvh, c, ref, &m, &alive, &best, st, ANY, STATS, UNI);
        if (UNI && !ANY)
            tmax_hi = -PV(hmin)(PV(sel)(PV(mask_from_bits)(lanes), PV(sub)(zero, best.t), inf));
    pop:
        do {
            if (sp == 0)
                goto done;
            sp--;
            m = stack[sp].mask & alive;
            if (!ANY && m)
                m &= PV(bits)(PV(ge)(best.t, PV(set1)(stack[sp].dist)));
        } while (!m);
        ref = stack[sp].ref;
    }
done:
    if (ANY) {
        for (uint32_t e = lanes; e; e &= e - 1) {
            unsigned l = (unsigned)__builtin_ctz(e);
            occluded[l] = !((alive >> l) & 1);
        }
        return;
    }
    {
        /* the hit rows, stored to the traced lanes only (the caller's
         * other lanes stay as they were); a lane without a hit writes the
         * miss record it started with (pk_best) */
        const pvec invalid = PV(set1_bits)(SC_INVALID_ID);
#define OUT(row, v) PV(store_lanes)((float *)(void *)hit->row, lanes, (v))
        OUT(t, best.t);
        OUT(u, PV(div)(best.un, best.den));
        OUT(v, PV(div)(best.vn, best.den));
        OUT(prim, best.prim);
        OUT(ng_x, best.ng[0]);
        OUT(ng_y, best.ng[1]);
        OUT(ng_z, best.ng[2]);
        OUT(geom, PV(sel)(PV(mask_from_bits)(best.got), zero, invalid));
        OUT(inst, invalid);
#undef OUT
    }
}

/* Lanes pl of a set-up packet (pk_init) walk the tree as a packet: the
 * body for a uniform packet where c says it is one, with or without
 * statistics. */
SC_X86_INLINE void PFN(pk_walk)(const sc_bvh *bvh, const PKT *r, uint32_t pl, HITP *hit, int32_t *occluded,
                                const pk_ctx *c, sc_trace_stats *st, const int ANY)
{
    if (st)
        c->uniform ? PFN(traverse_packet)(bvh, r, pl, hit, occluded, c, st, ANY, 1, 1)
                   : PFN(traverse_packet)(bvh, r, pl, hit, occluded, c, st, ANY, 1, 0);
    else
        c->uniform ? PFN(traverse_packet)(bvh, r, pl, hit, occluded, c, NULL, ANY, 0, 1)
                   : PFN(traverse_packet)(bvh, r, pl, hit, occluded, c, NULL, ANY, 0, 0);
}

/* Lanes par (parallel rays, which pk_init leaves out) as single rays. */
SC_X86_INLINE void PFN(pk_parallel)(const sc_bvh *bvh, const PKT *r, uint32_t par, HITP *hit, int32_t *occluded,
                                    sc_trace_stats *st, const int ANY)
{
    for (uint32_t e = par; e; e &= e - 1) {
        const unsigned l = (unsigned)__builtin_ctz(e);
        const sc_ray ray = { { r->ox[l], r->oy[l], r->oz[l] }, r->tmin[l], { r->dx[l], r->dy[l], r->dz[l] }, r->tmax[l] };
        if (ANY) {
            occluded[l] = st ? any_stats_watertight(bvh, &ray, st) : any_watertight(bvh, &ray);
            continue;
        }
        sc_hitrec h;
        if (st)
            closest_stats_watertight(bvh, &ray, &h, st);
        else
            closest_watertight(bvh, &ray, &h);
        hit->t[l] = h.t, hit->u[l] = h.u, hit->v[l] = h.v, hit->prim[l] = h.prim;
        hit->ng_x[l] = h.ng[0], hit->ng_y[l] = h.ng[1], hit->ng_z[l] = h.ng[2];
        hit->geom[l] = h.geom, hit->inst[l] = h.inst;
    }
}

/* ---- a stream's group of packets, any hit ----------------------------------
 * SC_GROUP packets (64 rays) of one octant walk the tree together, as
 * Embree's coherent stream traverser does: a node is fetched, tested
 * against the group's frustum and pushed once per 64 rays instead of once
 * per packet. The children the frustum keeps get every traced lane's own
 * box test (the single ray's, node_bvh8_slab.h), so a lane only enters the
 * boxes it passes itself and tests the triangles of those leaves, as in
 * the packet traversal. (Embree's way, children the group's first ray
 * enters taking the whole lane mask without a test per lane, measured the
 * same on shadow streams here, and worse when leaves took it too:
 * docs/compare.md, thirty-second session.)
 *
 * Exactness: a lane is occluded when one of the triangles it tests hits it
 * within [tmin, tmax], with the packet's triangle test, which computes the
 * single ray's bits; it tests every triangle its own single-ray walk would
 * reach, so its answer is the single ray's. */
#define SC_GROUP (64 / PK)
#if SC_GROUP * PK != 64
#error "a stream group holds 64 rays"
#endif

typedef struct {
    uint64_t ref;
    uint64_t mask;
} PFN(group_entry);

/* Packet g's lanes in a group's 64-bit lane mask (bit g * PK + l: lane l
 * of packet g). */
SC_X86_INLINE uint32_t PFN(group_lanes)(uint64_t m, unsigned g)
{
    return (uint32_t)(m >> (g * PK)) & (PK == 16 ? 0xffffu : 0xffu);
}

/* Lanes m (bit g * PK + l: lane l of packet g) of the group against child k
 * of node: each packet's lanes with the single ray's box test (rows nr*,
 * fr*: the group's near and far planes). */
SC_X86_INLINE uint64_t PFN(group_child_lanes)(const pk_ctx *c, const sc_bvh_node8 *node, int k, uint64_t m,
                                              int nr0, int nr1, int nr2, int fr0, int fr1, int fr2)
{
    const pvec nx = PV(set1)(node->b[nr0][k]), fx = PV(set1)(node->b[fr0][k]);
    const pvec ny = PV(set1)(node->b[nr1][k]), fy = PV(set1)(node->b[fr1][k]);
    const pvec nz = PV(set1)(node->b[nr2][k]), fz = PV(set1)(node->b[fr2][k]);
    uint64_t out = 0;
    for (unsigned g = 0; g < SC_GROUP; g++) {
        const uint32_t mg = PFN(group_lanes)(m, g);
        if (!mg)
            continue;
        const pk_ctx *cg = &c[g];
        const pvec tn = PV(max)(PV(max)(PV(fmsub)(nx, PV(load)(cg->rd[0]), PV(load)(cg->ordn[0])),
                                        PV(fmsub)(ny, PV(load)(cg->rd[1]), PV(load)(cg->ordn[1]))),
                                PV(max)(PV(fmsub)(nz, PV(load)(cg->rd[2]), PV(load)(cg->ordn[2])),
                                        PV(load)(cg->tmin)));
        const pvec tf = PV(min)(PV(min)(PV(fmsub)(fx, PV(load)(cg->rd[0]), PV(load)(cg->ordf[0])),
                                        PV(fmsub)(fy, PV(load)(cg->rd[1]), PV(load)(cg->ordf[1]))),
                                PV(min)(PV(fmsub)(fz, PV(load)(cg->rd[2]), PV(load)(cg->ordf[2])),
                                        PV(load)(cg->tmax)));
        out |= (uint64_t)(PV(bits)(PV(le)(tn, tf)) & mg) << (g * PK);
    }
    return out;
}

/* The walk of a group whose packets (lanes[g]: the traced lanes of packet
 * g, parallel lanes removed) are uniform (pk_init) and in octant oct; their
 * shear axes may differ from packet to packet (each leaf test reads its
 * packet's own).
 * occluded: SC_GROUP * PK entries, lane g * PK + l for lane l of packet g. */
SC_X86_INLINE void PFN(traverse_group_any)(const sc_bvh *bvh, const PKT *r, const uint32_t *lanes,
                                           int32_t *occluded, const pk_ctx *c, int oct, sc_trace_stats *st,
                                           const int STATS)
{
    /* the group's frustum: the union of the packets' (pk_frustum_node
     * reads only these fields) */
    pk_ctx fc;
    uint64_t all = 0;
    float tmax_hi = -INFINITY;
    PFN(pk_best) best[SC_GROUP];
    for (int k = 0; k < 3; k++)
        fc.fr_rdmin[k] = fc.fr_ofmin[k] = INFINITY, fc.fr_rdmax[k] = fc.fr_onmax[k] = -INFINITY;
    fc.fr_tmin = INFINITY;
    for (unsigned g = 0; g < SC_GROUP; g++) {
        if (!lanes[g])
            continue;
        best[g].t = PV(load)(c[g].tmax);
        all |= (uint64_t)lanes[g] << (g * PK);
        const pvec inf = PV(set1)(INFINITY);
        tmax_hi = sc_fmax(tmax_hi, -PV(hmin)(PV(sel)(PV(mask_from_bits)(lanes[g]), PV(neg)(best[g].t), inf)));
        for (int k = 0; k < 3; k++) {
            fc.fr_rdmin[k] = sc_fmin(fc.fr_rdmin[k], c[g].fr_rdmin[k]);
            fc.fr_rdmax[k] = sc_fmax(fc.fr_rdmax[k], c[g].fr_rdmax[k]);
            fc.fr_onmax[k] = sc_fmax(fc.fr_onmax[k], c[g].fr_onmax[k]);
            fc.fr_ofmin[k] = sc_fmin(fc.fr_ofmin[k], c[g].fr_ofmin[k]);
        }
        fc.fr_tmin = sc_fmin(fc.fr_tmin, c[g].fr_tmin);
    }
    if (STATS)
        st->rays += (uint64_t)__builtin_popcountll(all);
    uint64_t alive = all;
    if (!bvh->has_root || !all)
        goto done;
    const int nr0 = (oct & 1), nr1 = 2 + ((oct >> 1) & 1), nr2 = 4 + ((oct >> 2) & 1);
    const int fr0 = 1 - (oct & 1), fr1 = 3 - ((oct >> 1) & 1), fr2 = 5 - ((oct >> 2) & 1);
    PFN(group_entry) stack[SC_TRACE_STACK];
    int sp = 0;
    uint64_t ref = 0, m = all;
    for (;;) {
        while (!sc_ref_is_leaf(ref)) {
            if (__builtin_popcountll(m) <= SC_PACKET_THIN) {
                /* a thin group: its lanes finish this subtree as single rays */
                for (unsigned g = 0; g < SC_GROUP; g++) {
                    uint32_t mg = PFN(group_lanes)(m, g), ag = mg;
                    if (!mg)
                        continue;
                    PFN(pk_single)(bvh, &r[g], ref, mg, &best[g], &ag, st, 1, STATS);
                    alive &= ~((uint64_t)(mg & ~ag) << (g * PK));
                }
                goto pop;
            }
            const sc_bvh_node8 *node = (const sc_bvh_node8 *)(const void *)((const char *)bvh->nodes + ref);
            if (STATS)
                st->nodes++;
            float fdist[SC_BVH_N] __attribute__((aligned(32)));
            unsigned cand = PFN(pk_frustum_node)(&fc, node, nr0, nr1, nr2, fr0, fr1, fr2, tmax_hi, fdist);
            if (!cand)
                goto pop;
            uint64_t hr[SC_BVH_N], hmk[SC_BVH_N];
            int cnt = 0;
            for (; cand; cand &= cand - 1) {
                const int k = __builtin_ctz(cand);
                const uint64_t child = node->child[k];
                if (!child)
                    continue;
                const uint64_t mk = PFN(group_child_lanes)(c, node, k, m, nr0, nr1, nr2, fr0, fr1, fr2);
                if (!mk)
                    continue;
                hr[cnt] = child;
                hmk[cnt] = mk;
                cnt++;
            }
            if (cnt == 0)
                goto pop;
            /* the first slot first, as the packets' any-hit walk goes */
            for (int i = cnt - 1; i > 0; i--) {
                if (bvh->prefetch == SC_PREFETCH_ALL)
                    sc_prefetch_ref(bvh, hr[i]);
                stack[sp].ref = hr[i];
                stack[sp].mask = hmk[i];
                sp++;
            }
            ref = hr[0];
            m = hmk[0];
        }
        for (unsigned g = 0; g < SC_GROUP; g++) {
            uint32_t mg = PFN(group_lanes)(m, g), ag = mg;
            if (!mg)
                continue;
            PFN(pk_leaf)(bvh, &c[g], ref, &mg, &ag, &best[g], st, 1, STATS, 1);
            alive &= ~((uint64_t)(PFN(group_lanes)(m, g) & ~ag) << (g * PK));
        }
    pop:
        do {
            if (sp == 0)
                goto done;
            sp--;
            m = stack[sp].mask & alive;
        } while (!m);
        ref = stack[sp].ref;
    }
done:
    for (unsigned g = 0; g < SC_GROUP; g++)
        for (uint32_t e = lanes[g]; e; e &= e - 1) {
            const unsigned l = (unsigned)__builtin_ctz(e);
            occluded[g * PK + l] = !((alive >> (g * PK + l)) & 1);
        }
}

/* Any hit for a stream's group: packets r[0..SC_GROUP) with their valid
 * lanes (checked rays), answers to occluded[g * PK + l]. Packets that are
 * not uniform, or not in the first uniform packet's octant, walk
 * alone (traverse_packet), and parallel lanes go as single rays, as in
 * packet_entry. */
SC_X86_INLINE void PFN(group_entry_any)(const sc_bvh *bvh, const PKT *r, const uint32_t *lanes, int32_t *occluded,
                                        sc_trace_stats *st)
{
    pk_ctx c[SC_GROUP];
    uint32_t par[SC_GROUP], together[SC_GROUP], n_together = 0;
    int lead = -1;
    for (unsigned g = 0; g < SC_GROUP; g++) {
        par[g] = lanes[g] ? PFN(pk_init)(&c[g], bvh, &r[g], lanes[g], bvh->cfg.prefilter != SC_PREFILTER_OFF) : 0;
        together[g] = 0;
        const uint32_t pl = lanes[g] & ~par[g];
        if (!pl)
            continue;
        if (c[g].uniform && (lead < 0 || c[g].oct == c[lead].oct)) {
            if (lead < 0)
                lead = (int)g;
            together[g] = pl;
            n_together++;
        } else {
            PFN(pk_walk)(bvh, &r[g], pl, NULL, occluded + g * PK, &c[g], st, 1);
        }
    }
    if (n_together == 1) {
        /* one packet: its own walk, with its own (tighter) frustum */
        const unsigned g = (unsigned)lead;
        PFN(pk_walk)(bvh, &r[g], together[g], NULL, occluded + g * PK, &c[g], st, 1);
    } else if (n_together > 1) {
        if (st)
            PFN(traverse_group_any)(bvh, r, together, occluded, c, c[lead].oct, st, 1);
        else
            PFN(traverse_group_any)(bvh, r, together, occluded, c, c[lead].oct, NULL, 0);
    }
    for (unsigned g = 0; g < SC_GROUP; g++)
        PFN(pk_parallel)(bvh, &r[g], par[g], NULL, occluded + g * PK, st, 1);
}

/* The packet entry points: lanes = the caller's valid lanes (rays already
 * checked). Parallel rays leave the packet for the single-ray kernel. */
SC_X86_INLINE void PFN(packet_entry)(const sc_bvh *bvh, const PKT *r, uint32_t lanes, HITP *hit,
                                     int32_t *occluded, sc_trace_stats *st, const int ANY)
{
    pk_ctx c;
    const uint32_t par = PFN(pk_init)(&c, bvh, r, lanes, bvh->cfg.prefilter != SC_PREFILTER_OFF);
    const uint32_t pl = lanes & ~par;
    if (pl)
        PFN(pk_walk)(bvh, r, pl, hit, occluded, &c, st, ANY);
    PFN(pk_parallel)(bvh, r, par, hit, occluded, st, ANY);
}

static SC_TARGET void PFN(closest_packet)(const sc_bvh *bvh, const PKT *r, uint32_t lanes, HITP *hit,
                                          sc_trace_stats *st)
{
    PFN(packet_entry)(bvh, r, lanes, hit, NULL, st, 0);
}

static SC_TARGET void PFN(any_packet)(const sc_bvh *bvh, const PKT *r, uint32_t lanes, int32_t *occluded,
                                      sc_trace_stats *st)
{
    PFN(packet_entry)(bvh, r, lanes, NULL, occluded, st, 1);
}

#if PK == 16 || !SC_X86_AVX512   /* the level's table takes its widest */
/* A stream's group as four 16-ray packets (the stream gathers runs of 16);
 * occluded[g * 16 + l] for lane l of packet g. With 8 lanes a vector, each
 * packet is two of 8 (the rows copied half by half). */
static SC_TARGET void PFN(any_stream64_p)(const sc_bvh *bvh, const sc_ray_packet16 *r16, const uint32_t *lanes16,
                                          int32_t *occluded, sc_trace_stats *st)
{
#if PK == 16
    PFN(group_entry_any)(bvh, r16, lanes16, occluded, st);
#else
    sc_ray_packet8 r[8];
    uint32_t lanes[8];
    for (unsigned g = 0; g < 4; g++)
        for (unsigned h = 0; h < 2; h++) {
            const float *src = r16[g].ox;
            float *dst = r[2 * g + h].ox;
            for (unsigned k = 0; k < 8; k++)
                _mm256_store_ps(dst + 8 * k, _mm256_load_ps(src + 16 * k + 8 * h));
            lanes[2 * g + h] = (lanes16[g] >> (8 * h)) & 0xffu;
        }
    PFN(group_entry_any)(bvh, r, lanes, occluded, st);
#endif
}
#endif

#undef pvec
#undef pk_ctx
#undef SC_GROUP
#undef PCAT_
#undef PCAT
#undef PV
#undef PGLUE_
#undef PGLUE
#undef PFN
#undef PKT
#undef HITP
