/* One body for the reject-mask kernels: one ray against a block of W
 * spheres, and one sphere against a packet of W rays, processed NL lanes at
 * a time. Included by kernels_<isa>.c with
 *   VP      float vector shape (f32x4, f32x8, f32x16)
 *   W       block / packet width (4, 8, 16), a multiple of the shape's lanes
 *   ATTR    the ISA's target attribute
 *   RFUNC   name of the ray-vs-block kernel;  PFUNC  of the sphere-vs-packet
 *           kernel (optional, W = 8 or 16 only)
 *   RQUAL   optional: the ray-vs-block kernel's qualifiers and attributes
 *           (default static ATTR); the traversal (src/trace) compiles it
 *           always-inline so that no call sits in its leaf loop
 *
 * The arithmetic is sc_ray_sphere_reject's, operation for operation and
 * without FMA, so every lane agrees with the scalar specification bit for
 * bit; see src/sphere/prefilter.c for why each term is there.
 */

#define RCAT_(a, b) a##_##b
#define RCAT(a, b) RCAT_(a, b)
#define RV(op) RCAT(VP, op)
#define RGLUE_(a, b) a##b
#define RGLUE(a, b) RGLUE_(a, b)
#ifdef RQUAL
#define RQ_ RQUAL
#else
#define RQ_ static ATTR
#endif

/* Lanes of one chunk; O, D, tmin, tmax and c, r2 may each be per lane or
 * broadcast. dd, tmin*dd, |tmin|*dd, tmax*dd, |tmax|*dd come in precomputed
 * because in the ray-block case they are uniform. */
static inline ATTR uint32_t RCAT(RFUNC, lanes)(RV(t) ox, RV(t) oy, RV(t) oz, RV(t) dx, RV(t) dy, RV(t) dz,
                                               RV(t) dd, RV(t) tmin_dd, RV(t) atmin_dd, RV(t) tmax_dd,
                                               RV(t) atmax_dd, RV(t) cx, RV(t) cy, RV(t) cz, RV(t) r2)
{
    const RV(t) zero = RV(set1)(0), eight_u = RV(set1)(8 * (FLT_EPSILON / 2));
    RV(m) empty = RV(lt)(r2, zero);
    RV(t) ocx = RV(sub)(ox, cx), ocy = RV(sub)(oy, cy), ocz = RV(sub)(oz, cz);
    RV(t) ococ = RV(add)(RV(add)(RV(mul)(ocx, ocx), RV(mul)(ocy, ocy)), RV(mul)(ocz, ocz));
    RV(t) xx = RV(sub)(RV(mul)(ocy, dz), RV(mul)(ocz, dy));
    RV(t) xy = RV(sub)(RV(mul)(ocz, dx), RV(mul)(ocx, dz));
    RV(t) xz = RV(sub)(RV(mul)(ocx, dy), RV(mul)(ocy, dx));
    RV(t) cross2 = RV(add)(RV(add)(RV(mul)(xx, xx), RV(mul)(xy, xy)), RV(mul)(xz, xz));
    RV(t) allowance = RV(add)(RV(mul)(r2, RV(set1)(1 + 0x1p-10f)),
                              RV(mul)(RV(set1)(1025 * (8 * (FLT_EPSILON / 2)) * (8 * (FLT_EPSILON / 2))), ococ));
    RV(t) reach = RV(mul)(allowance, dd);
    /* Below 2^-100 the products may be subnormal or flushed: keep
     * (prefilter.c, also for MXCSR FTZ|DAZ). */
    RV(m) trusted = RV(and)(RV(and)(RV(ge)(dd, RV(set1)(0x1p-100f)), RV(ge)(allowance, RV(set1)(0x1p-100f))),
                            RV(ge)(reach, RV(set1)(0x1p-100f)));
    RV(m) rej = RV(gt)(cross2, reach);

    RV(t) px = RV(mul)(ocx, dx), py = RV(mul)(ocy, dy), pz = RV(mul)(ocz, dz);
    RV(t) b = RV(add)(RV(add)(px, py), pz);
    RV(t) babs = RV(add)(RV(add)(RV(abs)(px), RV(abs)(py)), RV(abs)(pz));
    RV(t) before = RV(add)(b, tmin_dd);
    RV(t) m = RV(sub)(before, RV(mul)(eight_u, RV(add)(babs, atmin_dd)));
    rej = RV(or)(rej, RV(and)(RV(gt)(m, zero), RV(gt)(RV(mul)(m, m), reach)));
    RV(t) beyond = RV(sub)(RV(mul)(b, RV(set1)(-1)), tmax_dd);   /* -b, exactly */
    RV(t) p = RV(sub)(beyond, RV(mul)(eight_u, RV(add)(babs, atmax_dd)));
    rej = RV(or)(rej, RV(and)(RV(gt)(p, zero), RV(gt)(RV(mul)(p, p), reach)));
    return RV(bits)(RV(or)(empty, RV(and)(trusted, rej)));
}

RQ_ uint32_t RFUNC(const sc_ray *ray, const RGLUE(sc_sphere_block, W) *blk)
{
    const float *O = ray->org, *D = ray->dir;
    float dd = D[0] * D[0] + D[1] * D[1] + D[2] * D[2];
    float tmin_dd = ray->tmin * dd, tmax_dd = ray->tmax * dd;
    float atmin_dd = fabsf(ray->tmin) * dd, atmax_dd = fabsf(ray->tmax) * dd;
    uint32_t mask = 0;
    for (int i = 0; i < W; i += RV(N))
        mask |= RCAT(RFUNC, lanes)(RV(set1)(O[0]), RV(set1)(O[1]), RV(set1)(O[2]), RV(set1)(D[0]),
                                   RV(set1)(D[1]), RV(set1)(D[2]), RV(set1)(dd), RV(set1)(tmin_dd),
                                   RV(set1)(atmin_dd), RV(set1)(tmax_dd), RV(set1)(atmax_dd),
                                   RV(load)(blk->cx + i), RV(load)(blk->cy + i), RV(load)(blk->cz + i),
                                   RV(load)(blk->r2 + i))
                << i;
    return mask;
}

#ifdef PFUNC
static ATTR uint32_t PFUNC(const RGLUE(sc_ray_packet, W) *rays, const float c[3], float r2)
{
    uint32_t mask = 0;
    for (int i = 0; i < W; i += RV(N)) {
        RV(t) dx = RV(load)(rays->dx + i), dy = RV(load)(rays->dy + i), dz = RV(load)(rays->dz + i);
        RV(t) dd = RV(add)(RV(add)(RV(mul)(dx, dx), RV(mul)(dy, dy)), RV(mul)(dz, dz));
        RV(t) tmin = RV(load)(rays->tmin + i), tmax = RV(load)(rays->tmax + i);
        mask |= RCAT(RFUNC, lanes)(RV(load)(rays->ox + i), RV(load)(rays->oy + i), RV(load)(rays->oz + i),
                                   dx, dy, dz, dd, RV(mul)(tmin, dd), RV(mul)(RV(abs)(tmin), dd),
                                   RV(mul)(tmax, dd), RV(mul)(RV(abs)(tmax), dd),
                                   RV(set1)(c[0]), RV(set1)(c[1]), RV(set1)(c[2]), RV(set1)(r2))
                << i;
    }
    return mask;
}
#endif

#undef RCAT_
#undef RCAT
#undef RV
#undef RGLUE_
#undef RGLUE
#undef RQ_
