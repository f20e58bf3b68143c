/* x86 node and leaf kernels, included once per ISA by traverse_x86.c with
 *   KFN(name), KATTR (target attribute) and SC_X86_AVX512 (0 or 1).
 * 8-wide box tests in ymm registers; leaf blocks of 4 and 8 lanes in one ymm
 * pass, 16 lanes in two (AVX2) or one zmm pass (AVX-512). The arithmetic is
 * that of traverse_scalar.c, operation for operation. */

typedef struct {
    __m256 ordn[3], ordf[3], rd[3];
    size_t near_off[3], far_off[3];      /* byte offsets of rows in a node */
    __m256 okx, oky, okz, Sx, Sy, Sz, tmin;   /* broadcast once per ray, not per leaf */
    __m256 xK, xc0;                           /* exact test's edge bound */
    __m256 org[3], rdp[3];                    /* parallel rays' node test */
    float org_s[3], dir_s[3];
    int kx, ky, kz;
} KFN(ctx);
#define KCTX KFN(ctx)

static inline KATTR void KFN(ctx_init)(KCTX *c, const sc_ray_pre *p)
{
    for (int k = 0; k < 3; k++) {
        c->ordn[k] = _mm256_set1_ps(p->ord_near[k]);
        c->ordf[k] = _mm256_set1_ps(p->ord_far[k]);
        c->rd[k] = _mm256_set1_ps(p->rd[k]);
        c->near_off[k] = (size_t)p->near_row[k] * SC_BVH_N * sizeof(float);
        c->far_off[k] = (size_t)p->far_row[k] * SC_BVH_N * sizeof(float);
        c->org_s[k] = p->org[k];
        c->org[k] = _mm256_set1_ps(p->org[k]);
        c->rdp[k] = _mm256_set1_ps(p->rdp[k]);
        c->dir_s[k] = p->dir[k];
    }
    c->kx = p->kx, c->ky = p->ky, c->kz = p->kz;
    c->okx = _mm256_set1_ps(p->org[p->kx]);
    c->oky = _mm256_set1_ps(p->org[p->ky]);
    c->okz = _mm256_set1_ps(p->org[p->kz]);
    c->Sx = _mm256_set1_ps(p->Sx);
    c->Sy = _mm256_set1_ps(p->Sy);
    c->Sz = _mm256_set1_ps(p->Sz);
    c->tmin = _mm256_set1_ps(p->tmin);
    c->xK = _mm256_set1_ps(p->xK);
    c->xc0 = _mm256_set1_ps(p->xc0);
}

/* The set-up of a non-parallel ray (every kernel with a known octant):
 * sc_ray_precompute's arithmetic with the three axes in one xmm register,
 * one divide instead of three and no stores and reloads of the struct. The
 * per-ray set-up is a visible part of a primary ray, which visits only
 * about two nodes. Lane k computes exactly what the scalar code computes
 * for axis k (maxps(a, b) = a > b ? a : b = sc_fmax), so every ISA still
 * sees the same bits. Lane 3 holds tmin/tmax/root_hi[0] and is ignored. */
static inline __attribute__((always_inline)) KATTR void KFN(ctx_fast)(KCTX *c, const sc_ray *r, const sc_bvh *bvh)
{
    const __m128 sgn = _mm_set1_ps(-0.0f);
    const __m128 o = _mm_loadu_ps(r->org), d = _mm_loadu_ps(r->dir);
    const __m128 rd = _mm_div_ps(_mm_set1_ps(1.0f), d);
    const __m128 ord = _mm_mul_ps(o, rd);
    const __m128 m = _mm_max_ps(_mm_andnot_ps(sgn, _mm_sub_ps(_mm_loadu_ps(bvh->root_lo), o)),
                                _mm_andnot_ps(sgn, _mm_sub_ps(_mm_loadu_ps(bvh->root_hi), o)));
    const __m128 g = _mm_fmadd_ps(_mm_andnot_ps(sgn, o), _mm_set1_ps(0x1.0cp-23f),
                                  _mm_fmadd_ps(m, _mm_set1_ps(0x1.0cp-23f), _mm_set1_ps(0x1p-123f)));
    const __m128 pad = _mm_fmadd_ps(_mm_andnot_ps(sgn, rd), g,
                                    _mm_fmadd_ps(m, _mm_set1_ps(0x1p-124f), _mm_set1_ps(0x1p-122f)));
    const __m128 ordn = _mm_add_ps(ord, pad), ordf = _mm_sub_ps(ord, pad);
#define BC(v, k) _mm256_broadcastss_ps(_mm_permute_ps((v), (k) * 0x55))
    c->rd[0] = BC(rd, 0), c->rd[1] = BC(rd, 1), c->rd[2] = BC(rd, 2);
    c->ordn[0] = BC(ordn, 0), c->ordn[1] = BC(ordn, 1), c->ordn[2] = BC(ordn, 2);
    c->ordf[0] = BC(ordf, 0), c->ordf[1] = BC(ordf, 1), c->ordf[2] = BC(ordf, 2);
#undef BC
    float mk[3] = { m[0], m[1], m[2] }, rdk[3] = { rd[0], rd[1], rd[2] };
    float xK, xc0;
    sc_exact_consts(mk, &xK, &xc0);
    c->xK = _mm256_set1_ps(xK);
    c->xc0 = _mm256_set1_ps(xc0);
    /* the shear of the watertight test, as in sc_ray_precompute */
    const float *dd = r->dir;
    int kx, ky, kz;
    sc_shear_axes(dd, &kx, &ky, &kz);
    c->kx = kx, c->ky = ky, c->kz = kz;
    c->okx = _mm256_set1_ps(r->org[kx]);
    c->oky = _mm256_set1_ps(r->org[ky]);
    c->okz = _mm256_set1_ps(r->org[kz]);
    c->Sx = _mm256_set1_ps(dd[kx] / dd[kz]);
    c->Sy = _mm256_set1_ps(dd[ky] / dd[kz]);
    c->Sz = _mm256_set1_ps(rdk[kz]);
    c->tmin = _mm256_set1_ps(r->tmin);
    for (int k = 0; k < 3; k++)
        c->org_s[k] = r->org[k], c->dir_s[k] = dd[k];
}

static inline __attribute__((always_inline)) KATTR unsigned
KFN(node_test)(const KCTX *c, const sc_bvh_node8 *node, float tmin, float tmax, float *dist,
               const int OCT, const int WANT_DIST)
{
    const char *nb = (const char *)node;
    /* With the ray octant known at compile time (OCT >= 0) the near and far
     * rows are fixed offsets: no per-ray offsets held in registers. */
#define NEAR(k) (OCT >= 0 ? (size_t)(2 * (k) + ((OCT >> (k)) & 1)) * SC_BVH_N * sizeof(float) : c->near_off[k])
#define FAR(k) (OCT >= 0 ? (size_t)(2 * (k) + 1 - ((OCT >> (k)) & 1)) * SC_BVH_N * sizeof(float) : c->far_off[k])
#define ROW(off) _mm256_load_ps((const float *)(const void *)(nb + (off)))
    __m256 tnx = _mm256_fmsub_ps(ROW(NEAR(0)), c->rd[0], c->ordn[0]);
    __m256 tny = _mm256_fmsub_ps(ROW(NEAR(1)), c->rd[1], c->ordn[1]);
    __m256 tnz = _mm256_fmsub_ps(ROW(NEAR(2)), c->rd[2], c->ordn[2]);
    __m256 tfx = _mm256_fmsub_ps(ROW(FAR(0)), c->rd[0], c->ordf[0]);
    __m256 tfy = _mm256_fmsub_ps(ROW(FAR(1)), c->rd[1], c->ordf[1]);
    __m256 tfz = _mm256_fmsub_ps(ROW(FAR(2)), c->rd[2], c->ordf[2]);
#undef ROW
#undef NEAR
#undef FAR
    (void)tmin;
    __m256 tn = _mm256_max_ps(_mm256_max_ps(tnx, tny), _mm256_max_ps(tnz, c->tmin));
    __m256 tf = _mm256_min_ps(_mm256_min_ps(tfx, tfy), _mm256_min_ps(tfz, _mm256_set1_ps(tmax)));
    if (WANT_DIST)
        _mm256_store_ps(dist, tn);
#if SC_X86_AVX512
    return (unsigned)_mm256_cmp_ps_mask(tn, tf, _CMP_LE_OQ);
#else
    return (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(tn, tf, _CMP_LE_OQ));
#endif
}

/* sc_slab_par on 8 children: (v)maxps/(v)minps return the second operand
 * when the first is NaN, as sc_fmax/sc_fmin do. */
static inline __attribute__((always_inline)) KATTR unsigned
KFN(node_test_par)(const KCTX *c, const sc_bvh_node8 *node, float tmin, float tmax, float *dist)
{
    const char *nb = (const char *)node;
    __m256 a = c->tmin, b = _mm256_set1_ps(tmax);
    (void)tmin;
    for (int k = 0; k < 3; k++) {
        __m256 n = _mm256_load_ps((const float *)(const void *)(nb + c->near_off[k]));
        __m256 f = _mm256_load_ps((const float *)(const void *)(nb + c->far_off[k]));
        a = _mm256_max_ps(_mm256_mul_ps(_mm256_sub_ps(n, c->org[k]), c->rdp[k]), a);
        b = _mm256_min_ps(_mm256_mul_ps(_mm256_sub_ps(f, c->org[k]), c->rdp[k]), b);
    }
    a = _mm256_fmsub_ps(a, _mm256_set1_ps(SC_SLAB_DOWN), _mm256_set1_ps(SC_SLAB_PAR_EPS));
    b = _mm256_fmadd_ps(b, _mm256_set1_ps(SC_SLAB_UP), _mm256_set1_ps(SC_SLAB_PAR_EPS));
    _mm256_store_ps(dist, a);
#if SC_X86_AVX512
    return (unsigned)_mm256_cmp_ps_mask(a, b, _CMP_LE_OQ);
#else
    return (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(a, b, _CMP_LE_OQ));
#endif
}

/* Lanes [h, h+8) of a block of width W. For W = 4 the upper lanes are
 * undefined: every result is masked by `live` (< 16), and float garbage
 * cannot trap (exceptions are masked), so the zero-extension is not paid. */
static inline __attribute__((always_inline)) KATTR __m256 KFN(row8)(const float *row, unsigned W, unsigned h)
{
    if (W == 4)
        return _mm256_castps128_ps256(_mm_load_ps(row));
    return _mm256_load_ps(row + h);
}

static inline __attribute__((always_inline)) KATTR unsigned
KFN(mask8)(__m256 m)
{
    return (unsigned)_mm256_movemask_ps(m);
}

/* Lanes h..h+7 of a leaf block in the ray's sheared frame and their edge
 * functions: the common first half of the watertight and the exact test,
 * which must compute the same bits (the operations of lane_shear). */
typedef struct KFN(sheared8) {
    __m256 Ax, Ay, Bx, By, Cx, Cy, Akz, Bkz, Ckz, U, V, W;
} KFN(sheared8);

static inline __attribute__((always_inline)) KATTR void
KFN(shear8)(const KCTX *c, const float *rows, unsigned W, unsigned h, KFN(sheared8) *s)
{
    const int kx = c->kx, ky = c->ky, kz = c->kz;
    const __m256 okx = c->okx, oky = c->oky, okz = c->okz;
    const __m256 Sx = c->Sx, Sy = c->Sy;
#define LD(j, k) KFN(row8)(rows + (3 * (j) + (k)) * W, W, h)
    __m256 Akz = _mm256_sub_ps(LD(0, kz), okz);
    __m256 Bkz = _mm256_sub_ps(LD(1, kz), okz);
    __m256 Ckz = _mm256_sub_ps(LD(2, kz), okz);
    __m256 Ax = _mm256_sub_ps(_mm256_sub_ps(LD(0, kx), okx), _mm256_mul_ps(Sx, Akz));
    __m256 Ay = _mm256_sub_ps(_mm256_sub_ps(LD(0, ky), oky), _mm256_mul_ps(Sy, Akz));
    __m256 Bx = _mm256_sub_ps(_mm256_sub_ps(LD(1, kx), okx), _mm256_mul_ps(Sx, Bkz));
    __m256 By = _mm256_sub_ps(_mm256_sub_ps(LD(1, ky), oky), _mm256_mul_ps(Sy, Bkz));
    __m256 Cx = _mm256_sub_ps(_mm256_sub_ps(LD(2, kx), okx), _mm256_mul_ps(Sx, Ckz));
    __m256 Cy = _mm256_sub_ps(_mm256_sub_ps(LD(2, ky), oky), _mm256_mul_ps(Sy, Ckz));
#undef LD
    s->Ax = Ax, s->Ay = Ay, s->Bx = Bx, s->By = By, s->Cx = Cx, s->Cy = Cy;
    s->Akz = Akz, s->Bkz = Bkz, s->Ckz = Ckz;
    s->U = _mm256_sub_ps(_mm256_mul_ps(Cx, By), _mm256_mul_ps(Cy, Bx));
    s->V = _mm256_sub_ps(_mm256_mul_ps(Ax, Cy), _mm256_mul_ps(Ay, Cx));
    s->W = _mm256_sub_ps(_mm256_mul_ps(Bx, Ay), _mm256_mul_ps(By, Ax));
}

/* Watertight test of 8 lanes; returns the hit mask (bit 0 = lane h). */
static inline __attribute__((always_inline)) KATTR unsigned
KFN(watertight8)(const KCTX *c, const float *rows, unsigned W, unsigned h, unsigned live,
                 float tmin, float tmax, float *t, float *un, float *vn, float *den)
{
    const __m256 Sz = c->Sz;
    KFN(sheared8) sh;
    KFN(shear8)(c, rows, W, h, &sh);
    const __m256 Ax = sh.Ax, Ay = sh.Ay, Bx = sh.Bx, By = sh.By, Cx = sh.Cx, Cy = sh.Cy;
    const __m256 Akz = sh.Akz, Bkz = sh.Bkz, Ckz = sh.Ckz;
    const __m256 U = sh.U, V = sh.V, Wv = sh.W;
    const __m256 zero = _mm256_setzero_ps();
    __m256 neg = _mm256_or_ps(_mm256_or_ps(_mm256_cmp_ps(U, zero, _CMP_LT_OQ), _mm256_cmp_ps(V, zero, _CMP_LT_OQ)),
                              _mm256_cmp_ps(Wv, zero, _CMP_LT_OQ));
    __m256 pos = _mm256_or_ps(_mm256_or_ps(_mm256_cmp_ps(U, zero, _CMP_GT_OQ), _mm256_cmp_ps(V, zero, _CMP_GT_OQ)),
                              _mm256_cmp_ps(Wv, zero, _CMP_GT_OQ));
    __m256 det = _mm256_add_ps(_mm256_add_ps(U, V), Wv);
    __m256 ok = _mm256_andnot_ps(_mm256_and_ps(neg, pos), _mm256_cmp_ps(det, zero, _CMP_NEQ_UQ));
    __m256 zr = _mm256_or_ps(_mm256_or_ps(_mm256_cmp_ps(U, zero, _CMP_EQ_OQ), _mm256_cmp_ps(V, zero, _CMP_EQ_OQ)),
                             _mm256_cmp_ps(Wv, zero, _CMP_EQ_OQ));
    unsigned zmask = KFN(mask8)(zr) & live;
    unsigned cand = KFN(mask8)(ok) & live & ~zmask;
    unsigned hm = 0;
    __m256 Az = _mm256_mul_ps(Sz, Akz), Bz = _mm256_mul_ps(Sz, Bkz), Cz = _mm256_mul_ps(Sz, Ckz);
    if (cand) {
        __m256 T = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(U, Az), _mm256_mul_ps(V, Bz)), _mm256_mul_ps(Wv, Cz));
        __m256 tt = _mm256_div_ps(T, det);
        (void)tmin;
        __m256 in = _mm256_and_ps(_mm256_cmp_ps(tt, c->tmin, _CMP_GE_OQ),
                                  _mm256_cmp_ps(tt, _mm256_set1_ps(tmax), _CMP_LE_OQ));
        hm = KFN(mask8)(in) & cand;
        if (hm) {
            _mm256_storeu_ps(t + h, tt);
            _mm256_storeu_ps(un + h, V);
            _mm256_storeu_ps(vn + h, Wv);
            _mm256_storeu_ps(den + h, det);
        }
    }
    if (__builtin_expect(zmask != 0, 0)) {
        float ax[8], ay[8], bx[8], by[8], cx[8], cy[8], az[8], bz[8], cz[8];
        _mm256_storeu_ps(ax, Ax), _mm256_storeu_ps(ay, Ay), _mm256_storeu_ps(bx, Bx);
        _mm256_storeu_ps(by, By), _mm256_storeu_ps(cx, Cx), _mm256_storeu_ps(cy, Cy);
        _mm256_storeu_ps(az, Az), _mm256_storeu_ps(bz, Bz), _mm256_storeu_ps(cz, Cz);
        for (unsigned m = zmask; m; m &= m - 1) {
            unsigned i = (unsigned)__builtin_ctz(m);
            float u, v;
            if (sc_watertight_double(ax[i], ay[i], bx[i], by[i], cx[i], cy[i], az[i], bz[i], cz[i],
                                     tmin, tmax, &t[h + i], &u, &v)) {
                un[h + i] = u, vn[h + i] = v, den[h + i] = 1;
                hm |= 1u << i;
            }
        }
    }
    return hm;
}

/* The exact test's float filter on 8 lanes, the operations of lane_exact:
 * returns the lanes left to sc_xresolve; te = -1 where the edges are not
 * all certain. */
static inline __attribute__((always_inline)) KATTR unsigned
KFN(exact8)(const KCTX *c, const float *rows, unsigned W, unsigned h, unsigned live,
            float tmin, float tmax, float *t, float *te, float *un, float *vn, float *den)
{
    const __m256 Sz = c->Sz;
    KFN(sheared8) sh;
    KFN(shear8)(c, rows, W, h, &sh);
    const __m256 Ax = sh.Ax, Ay = sh.Ay, Bx = sh.Bx, By = sh.By, Cx = sh.Cx, Cy = sh.Cy;
    const __m256 Akz = sh.Akz, Bkz = sh.Bkz, Ckz = sh.Ckz;
    const __m256 U = sh.U, V = sh.V, Wv = sh.W;
    const __m256 sgn = _mm256_set1_ps(-0.0f);
#define ABS(x) _mm256_andnot_ps(sgn, (x))
    __m256 hA = _mm256_add_ps(ABS(Ax), ABS(Ay));
    __m256 hB = _mm256_add_ps(ABS(Bx), ABS(By));
    __m256 hC = _mm256_add_ps(ABS(Cx), ABS(Cy));
    __m256 E1 = _mm256_fmadd_ps(c->xK, _mm256_add_ps(_mm256_add_ps(hA, hB), hC), c->xc0);
    __m256 nE1 = _mm256_xor_ps(E1, sgn);
#if SC_X86_AVX512
    __mmask8 pU = _mm256_cmp_ps_mask(U, E1, _CMP_GT_OQ), nU = _mm256_cmp_ps_mask(U, nE1, _CMP_LT_OQ);
    __mmask8 pV = _mm256_cmp_ps_mask(V, E1, _CMP_GT_OQ), nV = _mm256_cmp_ps_mask(V, nE1, _CMP_LT_OQ);
    __mmask8 pW = _mm256_cmp_ps_mask(Wv, E1, _CMP_GT_OQ), nW = _mm256_cmp_ps_mask(Wv, nE1, _CMP_LT_OQ);
    unsigned miss = (unsigned)((pU | pV | pW) & (nU | nV | nW));
    unsigned inside = (unsigned)((pU & pV & pW) | (nU & nV & nW));
#else
    __m256 pU = _mm256_cmp_ps(U, E1, _CMP_GT_OQ), nU = _mm256_cmp_ps(U, nE1, _CMP_LT_OQ);
    __m256 pV = _mm256_cmp_ps(V, E1, _CMP_GT_OQ), nV = _mm256_cmp_ps(V, nE1, _CMP_LT_OQ);
    __m256 pW = _mm256_cmp_ps(Wv, E1, _CMP_GT_OQ), nW = _mm256_cmp_ps(Wv, nE1, _CMP_LT_OQ);
    unsigned miss = KFN(mask8)(_mm256_and_ps(_mm256_or_ps(_mm256_or_ps(pU, pV), pW),
                                             _mm256_or_ps(_mm256_or_ps(nU, nV), nW)));
    unsigned inside = KFN(mask8)(_mm256_or_ps(_mm256_and_ps(_mm256_and_ps(pU, pV), pW),
                                              _mm256_and_ps(_mm256_and_ps(nU, nV), nW)));
#endif
    live &= ~miss;
    unsigned open = live & ~inside;
    unsigned in = live & inside;
    unsigned sure = 0;
    if (in) {
        __m256 Az = _mm256_mul_ps(Sz, Akz), Bz = _mm256_mul_ps(Sz, Bkz), Cz = _mm256_mul_ps(Sz, Ckz);
        __m256 det = _mm256_add_ps(_mm256_add_ps(U, V), Wv);
        __m256 T = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(U, Az), _mm256_mul_ps(V, Bz)), _mm256_mul_ps(Wv, Cz));
        /* one division: tt and the bound both use 1/det */
        __m256 inv = _mm256_div_ps(_mm256_set1_ps(1.0f), det);
        __m256 tt = _mm256_mul_ps(T, inv);
        __m256 zmax = _mm256_max_ps(_mm256_max_ps(Az, Bz), Cz), zmin = _mm256_min_ps(_mm256_min_ps(Az, Bz), Cz);
        __m256 Z = _mm256_max_ps(zmax, _mm256_xor_ps(zmin, sgn));
        __m256 R = _mm256_mul_ps(_mm256_sub_ps(zmax, zmin), _mm256_set1_ps(0.5f));
        __m256 q = _mm256_fmadd_ps(R, _mm256_mul_ps(E1, _mm256_set1_ps(SC_X_K606)), _mm256_set1_ps(SC_X_FLOOR_N));
        __m256 e = _mm256_fmadd_ps(q, ABS(inv),
                                   _mm256_fmadd_ps(Z, _mm256_set1_ps(SC_X_K15U),
                                                   _mm256_fmadd_ps(ABS(tt), _mm256_set1_ps(SC_X_K3U),
                                                                   _mm256_set1_ps(SC_X_FLOOR_T))));
        unsigned fin = KFN(mask8)(_mm256_and_ps(_mm256_cmp_ps(e, _mm256_set1_ps(INFINITY), _CMP_LT_OQ),
                                                _mm256_cmp_ps(ABS(inv), _mm256_set1_ps(0x1p-126f), _CMP_GE_OQ)));
        unsigned out = KFN(mask8)(_mm256_or_ps(_mm256_cmp_ps(_mm256_sub_ps(tt, e), _mm256_set1_ps(tmax), _CMP_GT_OQ),
                                               _mm256_cmp_ps(_mm256_add_ps(tt, e), _mm256_set1_ps(tmin), _CMP_LT_OQ)));
        open |= in & ~fin;
        sure = in & fin & ~out;
        if (sure) {
            _mm256_storeu_ps(t + h, tt);
            _mm256_storeu_ps(te + h, e);
            _mm256_storeu_ps(un + h, V);
            _mm256_storeu_ps(vn + h, Wv);
            _mm256_storeu_ps(den + h, inv);
        }
    }
#undef ABS
    /* te = -1 marks the lanes whose edges sc_xresolve must settle */
    for (unsigned m = open; m; m &= m - 1)
        te[h + (unsigned)__builtin_ctz(m)] = -1;
    return sure | open;
}

/* Moller-Trumbore on 8 lanes, the operations of lane_moller. */
static inline __attribute__((always_inline)) KATTR unsigned
KFN(moller8)(const KCTX *c, const float *rows, unsigned W, unsigned h, unsigned live,
             float tmin, float tmax, float *t, float *un, float *vn, float *den)
{
#define LD(j, k) KFN(row8)(rows + (3 * (j) + (k)) * W, W, h)
    __m256 v0[3], e1[3], e2[3], s[3], d[3];
    for (int k = 0; k < 3; k++) {
        v0[k] = LD(0, k);
        e1[k] = _mm256_sub_ps(LD(1, k), v0[k]);
        e2[k] = _mm256_sub_ps(LD(2, k), v0[k]);
        s[k] = _mm256_sub_ps(_mm256_set1_ps(c->org_s[k]), v0[k]);
        d[k] = _mm256_set1_ps(c->dir_s[k]);
    }
#undef LD
#define MUL _mm256_mul_ps
#define SUB _mm256_sub_ps
#define ADD _mm256_add_ps
    __m256 px = SUB(MUL(d[1], e2[2]), MUL(d[2], e2[1]));
    __m256 py = SUB(MUL(d[2], e2[0]), MUL(d[0], e2[2]));
    __m256 pz = SUB(MUL(d[0], e2[1]), MUL(d[1], e2[0]));
    __m256 det = ADD(ADD(MUL(e1[0], px), MUL(e1[1], py)), MUL(e1[2], pz));
    __m256 inv = _mm256_div_ps(_mm256_set1_ps(1.0f), det);
    __m256 u = MUL(ADD(ADD(MUL(s[0], px), MUL(s[1], py)), MUL(s[2], pz)), inv);
    __m256 qx = SUB(MUL(s[1], e1[2]), MUL(s[2], e1[1]));
    __m256 qy = SUB(MUL(s[2], e1[0]), MUL(s[0], e1[2]));
    __m256 qz = SUB(MUL(s[0], e1[1]), MUL(s[1], e1[0]));
    __m256 v = MUL(ADD(ADD(MUL(d[0], qx), MUL(d[1], qy)), MUL(d[2], qz)), inv);
    __m256 tt = MUL(ADD(ADD(MUL(e2[0], qx), MUL(e2[1], qy)), MUL(e2[2], qz)), inv);
    const __m256 zero = _mm256_setzero_ps();
    __m256 ok = _mm256_and_ps(_mm256_cmp_ps(det, zero, _CMP_NEQ_UQ), _mm256_cmp_ps(u, zero, _CMP_GE_OQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(v, zero, _CMP_GE_OQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(ADD(u, v), _mm256_set1_ps(1.0f), _CMP_LE_OQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(tt, _mm256_set1_ps(tmin), _CMP_GE_OQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(tt, _mm256_set1_ps(tmax), _CMP_LE_OQ));
#undef MUL
#undef SUB
#undef ADD
    unsigned hm = KFN(mask8)(ok) & live;
    if (hm) {
        _mm256_storeu_ps(t + h, tt);
        _mm256_storeu_ps(un + h, u);
        _mm256_storeu_ps(vn + h, v);
        _mm256_storeu_ps(den + h, _mm256_set1_ps(1.0f));
    }
    return hm;
}

static inline __attribute__((always_inline)) KATTR unsigned
KFN(leaf_test)(const KCTX *c, const float *rows, unsigned W, unsigned live, float tmin, float tmax,
               int test, float *t, float *te, float *un, float *vn, float *den)
{
    unsigned hm;
    if (test == SC_TRI_EXACT) {
        hm = KFN(exact8)(c, rows, W, 0, live & 0xff, tmin, tmax, t, te, un, vn, den);
        if (W == 16 && (live >> 8))
            hm |= KFN(exact8)(c, rows, W, 8, live >> 8, tmin, tmax, t, te, un, vn, den) << 8;
    } else if (test == SC_TRI_MOLLER) {
        hm = KFN(moller8)(c, rows, W, 0, live & 0xff, tmin, tmax, t, un, vn, den);
        if (W == 16 && (live >> 8))
            hm |= KFN(moller8)(c, rows, W, 8, live >> 8, tmin, tmax, t, un, vn, den) << 8;
    } else {
        hm = KFN(watertight8)(c, rows, W, 0, live & 0xff, tmin, tmax, t, un, vn, den);
        if (W == 16 && (live >> 8))
            hm |= KFN(watertight8)(c, rows, W, 8, live >> 8, tmin, tmax, t, un, vn, den) << 8;
    }
    return hm;
}

#include "traverse_core_template.h"
#undef KCTX
