/* Scenes of instances and refits, spherecull (sc_accel.h) against Embree
 * with the same instances and the same rays (docs/scenes.md has the
 * figures):
 *   instancing  N instances of one mesh (rotated, scaled, on a grid): build
 *               seconds, bytes, and Mrays/s of primary, shadow and diffuse
 *               rays, one thread, paired repeats, medians; single rays
 *               (rtcIntersect1) and 16-ray packets of 4x4 pixel tiles and
 *               the rays they spawn (rtcIntersect16), the "16" rows;
 *   refit       the mesh deformed by a smooth wave K times: refit seconds
 *               against a fresh build and against Embree's refit build
 *               quality, then the speed of the refitted trees against
 *               fresh ones.
 * Both tracers run with flush-to-zero / denormals-are-zero, as Embree
 * asks; both build (and refit) on --threads threads (default 1). A
 * ratio above 1 means spherecull is faster (or smaller).
 *
 *   bench_scene [--mesh SPEC] [--instances N] [--size WxH] [--repeats R]
 *               [--refits K] [--threads T] [--min-time S] [--rows LIST]
 *               [--identity] [--plain] [--shuffle]
 * Each timed row runs its ray set until the faster tracer has run S
 * seconds (default 0.2), the same number of passes for both. --rows
 * (comma-separated row names, e.g. primary16) times only those rows of
 * the instancing table: a profile of one path. --identity makes every
 * instance's transform a translation to its grid point (no rotation or
 * scale); --plain traces the mesh itself in both tracers' world scenes
 * instead of instances, with the rays of one instance. What the instance
 * level costs each tracer is then --instances 1 --identity against
 * --plain: the same geometry and the same rays, with and without it.
 * --shuffle puts each ray set in a seeded random order (the packets then
 * take 16 rays from anywhere in the image): the control for what depends
 * on neighbouring rays being alike, such as the occluder tried first. */
#define _GNU_SOURCE
#include <embree3/rtcore.h>
#include <getopt.h>
#include <math.h>
#include <pmmintrin.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <xmmintrin.h>

#include "common/sc_clock.h"
#include "common/sc_median.h"
#include "common/sc_names.h"
#include "common/sc_rng.h"
#include "spherecull/sc_accel.h"
#include "spherecull/sc_embree.h"
#include "spherecull/sc_scene.h"

static atomic_llong embree_bytes;
/* Each timed run repeats its ray set until it has run this long (--min-time). */
static double min_time = 0.2;
/* The instancing table's rows, and those --rows asks for (bit i: row_names[i]) */
static const char *const row_names[] = { "primary", "shadow", "diffuse", "primary16", "shadow16", "diffuse16" };
enum { ROW_COUNT = sizeof row_names / sizeof row_names[0] };
static unsigned rows_wanted = (1u << ROW_COUNT) - 1;
static int identity_xfm, plain_mesh, shuffle_rays;   /* --identity, --plain, --shuffle */
/* Our builds and refits: the default configuration on --threads threads. */
static sc_bvh_config build_cfg;
static bool monitor(void *ptr, ssize_t bytes, bool post)
{
    (void)ptr, (void)post;
    atomic_fetch_add(&embree_bytes, (long long)bytes);
    return true;
}

static void die(const char *what)
{
    fprintf(stderr, "bench_scene: %s\n", what);
    exit(1);
}

/* ---- rays ------------------------------------------------------------------ */

typedef struct ray_sets {
    sc_ray *primary, *shadow, *diffuse;
    size_t n, nshadow, ndiffuse;
} ray_sets;

/* A seeded random order (Fisher-Yates), for --shuffle. */
static void shuffle(sc_ray *r, size_t n, uint64_t seed)
{
    sc_rng rng;
    sc_rng_seed(&rng, seed);
    for (size_t i = n; i > 1; i--) {
        size_t j = (size_t)sc_rng_range(&rng, 0, (double)i);
        j = j < i ? j : i - 1;   /* a product that rounds up to i */
        const sc_ray t = r[i - 1];
        r[i - 1] = r[j];
        r[j] = t;
    }
}

/* Camera rays from outside the box at (1, 0.7, 1.3) times its size, then
 * shadow and cosine-weighted diffuse rays from the hits `trace` reports. */
static void make_rays(const float lo[3], const float hi[3], int w, int h, const sc_accel *a, ray_sets *rs)
{
    double c[3], ext = 0;
    for (int k = 0; k < 3; k++)
        c[k] = 0.5 * (lo[k] + hi[k]), ext = fmax(ext, hi[k] - lo[k]);
    const double eye[3] = { c[0] + 1.0 * ext, c[1] + 0.7 * ext, c[2] + 1.3 * ext };
    double f[3], len = 0;
    for (int k = 0; k < 3; k++)
        f[k] = c[k] - eye[k], len += f[k] * f[k];
    len = sqrt(len);
    for (int k = 0; k < 3; k++)
        f[k] /= len;
    double r[3] = { f[2], 0, -f[0] }, rl = sqrt(r[0] * r[0] + r[2] * r[2]);
    r[0] /= rl, r[2] /= rl;
    const double u[3] = { r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0] };
    rs->n = (size_t)w * h;
    rs->primary = malloc(rs->n * sizeof(sc_ray));
    rs->shadow = malloc(rs->n * sizeof(sc_ray));
    rs->diffuse = malloc(rs->n * sizeof(sc_ray));
    const double fov = 0.45;
    /* in 4x4 pixel tiles, as a renderer hands rays to packets (w and h are
     * multiples of 4); the shadow and diffuse rays follow in that order */
    size_t next = 0;
    for (int ty = 0; ty < h; ty += 4)
        for (int tx = 0; tx < w; tx += 4)
            for (int j = 0; j < 16; j++) {
                const int x = tx + j % 4, y = ty + j / 4;
                double sx = (2 * (x + 0.5) / w - 1) * fov, sy = (1 - 2 * (y + 0.5) / h) * fov;
                sc_ray *ray = &rs->primary[next++];
                for (int k = 0; k < 3; k++) {
                    ray->org[k] = (float)eye[k];
                    ray->dir[k] = (float)(f[k] + sx * r[k] + sy * u[k]);
                }
                ray->tmin = 0;
                ray->tmax = INFINITY;
            }
    const double light[3] = { c[0] - 0.3 * ext, c[1] + 2 * ext, c[2] + 0.2 * ext };
    sc_rng rng;
    sc_rng_seed(&rng, 42);
    rs->nshadow = rs->ndiffuse = 0;
    for (size_t i = 0; i < rs->n; i++) {
        sc_hitrec hit;
        sc_accel_closest(a, &rs->primary[i], &hit, NULL);
        if (hit.prim == SC_HITREC_MISS)
            continue;
        const sc_ray *p = &rs->primary[i];
        double n[3] = { hit.ng[0], hit.ng[1], hit.ng[2] }, nl = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (!(nl > 0))
            continue;
        double dn = 0;
        for (int k = 0; k < 3; k++)
            n[k] /= nl, dn += n[k] * p->dir[k];
        if (dn > 0)
            for (int k = 0; k < 3; k++)
                n[k] = -n[k];
        float o[3];
        for (int k = 0; k < 3; k++)
            o[k] = (float)(p->org[k] + (double)hit.t * p->dir[k] + 1e-4 * ext * n[k]);
        sc_ray s = { { o[0], o[1], o[2] }, 0, { 0, 0, 0 }, 1 };
        for (int k = 0; k < 3; k++)
            s.dir[k] = (float)(light[k] - o[k]);
        rs->shadow[rs->nshadow++] = s;
        /* cosine-weighted around n */
        double a1 = sc_rng_range(&rng, 0, 6.283185307179586), r2 = sc_rng_range(&rng, 0, 1), sr = sqrt(r2);
        double t1[3] = { fabs(n[0]) < 0.6 ? 1.0 : 0.0, fabs(n[0]) < 0.6 ? 0.0 : 1.0, 0 }, b1[3], b2[3];
        b1[0] = n[1] * t1[2] - n[2] * t1[1], b1[1] = n[2] * t1[0] - n[0] * t1[2], b1[2] = n[0] * t1[1] - n[1] * t1[0];
        double bl = sqrt(b1[0] * b1[0] + b1[1] * b1[1] + b1[2] * b1[2]);
        for (int k = 0; k < 3; k++)
            b1[k] /= bl;
        b2[0] = n[1] * b1[2] - n[2] * b1[1], b2[1] = n[2] * b1[0] - n[0] * b1[2], b2[2] = n[0] * b1[1] - n[1] * b1[0];
        sc_ray d = { { o[0], o[1], o[2] }, 0, { 0, 0, 0 }, INFINITY };
        for (int k = 0; k < 3; k++)
            d.dir[k] = (float)(sr * cos(a1) * b1[k] + sr * sin(a1) * b2[k] + sqrt(1 - r2) * n[k]);
        rs->diffuse[rs->ndiffuse++] = d;
    }
    if (shuffle_rays) {
        shuffle(rs->primary, rs->n, 1);
        shuffle(rs->shadow, rs->nshadow, 2);
        shuffle(rs->diffuse, rs->ndiffuse, 3);
    }
}

static void free_rays(ray_sets *rs)
{
    free(rs->primary), free(rs->shadow), free(rs->diffuse);
}

/* ---- the two tracers over one ray set ------------------------------------- */

typedef struct result {
    uint32_t prim, inst;
} result;

static double run_ours(const sc_accel *a, const sc_ray *rays, size_t n, int shadow, result *out)
{
    double t0 = sc_now_seconds();
    for (size_t i = 0; i < n; i++) {
        if (shadow) {
            int occ;
            sc_accel_any(a, &rays[i], &occ, NULL);
            out[i].prim = (uint32_t)occ, out[i].inst = 0;
        } else {
            sc_hitrec h;
            sc_accel_closest(a, &rays[i], &h, NULL);
            out[i].prim = h.prim, out[i].inst = h.inst;
        }
    }
    return sc_now_seconds() - t0;
}

static double run_embree(RTCScene scene, const sc_ray *rays, size_t n, int shadow, result *out)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    double t0 = sc_now_seconds();
    for (size_t i = 0; i < n; i++) {
        const sc_ray *r = &rays[i];
        struct RTCRayHit rh;
        rh.ray.org_x = r->org[0], rh.ray.org_y = r->org[1], rh.ray.org_z = r->org[2];
        rh.ray.dir_x = r->dir[0], rh.ray.dir_y = r->dir[1], rh.ray.dir_z = r->dir[2];
        rh.ray.tnear = r->tmin, rh.ray.tfar = r->tmax;
        rh.ray.mask = UINT32_MAX, rh.ray.flags = 0, rh.ray.time = 0, rh.ray.id = 0;
        if (shadow) {
            rtcOccluded1(scene, &ctx, &rh.ray);
            out[i].prim = rh.ray.tfar < 0, out[i].inst = 0;
        } else {
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(scene, &ctx, &rh);
            out[i].prim = rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? SC_HITREC_MISS : rh.hit.primID;
            out[i].inst = rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? SC_INVALID_ID : rh.hit.instID[0];
        }
    }
    return sc_now_seconds() - t0;
}

/* The same through 16-ray packets (sc_accel_closest16 / sc_accel_any16
 * against rtcIntersect16 / rtcOccluded16): runs of 16 consecutive rays,
 * the last one padded with invalid lanes. Both loops fill their packet
 * from the ray array, so both pay the transpose. */
static double run_ours16(const sc_accel *a, const sc_ray *rays, size_t n, int shadow, result *out)
{
    double t0 = sc_now_seconds();
    for (size_t b = 0; b < n; b += 16) {
        sc_ray_packet16 p;
        int32_t valid[16];
        for (unsigned i = 0; i < 16; i++) {
            const sc_ray *r = &rays[b + i < n ? b + i : n - 1];
            valid[i] = b + i < n ? -1 : 0;
            p.ox[i] = r->org[0], p.oy[i] = r->org[1], p.oz[i] = r->org[2], p.tmin[i] = r->tmin;
            p.dx[i] = r->dir[0], p.dy[i] = r->dir[1], p.dz[i] = r->dir[2], p.tmax[i] = r->tmax;
        }
        if (shadow) {
            int32_t occ[16];
            sc_accel_any16(a, valid, &p, occ, NULL);
            for (unsigned i = 0; i < 16 && b + i < n; i++)
                out[b + i].prim = (uint32_t)occ[i], out[b + i].inst = 0;
        } else {
            sc_hit_packet16 hp;
            sc_accel_closest16(a, valid, &p, &hp, NULL);
            for (unsigned i = 0; i < 16 && b + i < n; i++)
                out[b + i].prim = hp.prim[i], out[b + i].inst = hp.inst[i];
        }
    }
    return sc_now_seconds() - t0;
}

/* Embree's default context (incoherent) for every row, its faster choice
 * through instances: with RTC_INTERSECT_CONTEXT_FLAG_COHERENT its camera
 * packets through 1,000 instances ran at half the speed, and rtcOccluded16
 * did not return on their shadow rays (Embree 3.13.5, as on orchard.json's
 * in compare; docs/compare.md, thirty-seventh session). */
static double run_embree16(RTCScene scene, const sc_ray *rays, size_t n, int shadow, result *out)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    double t0 = sc_now_seconds();
    for (size_t b = 0; b < n; b += 16) {
        RTC_ALIGN(64) struct RTCRayHit16 rh;
        RTC_ALIGN(64) int valid[16];
        for (unsigned i = 0; i < 16; i++) {
            const sc_ray *r = &rays[b + i < n ? b + i : n - 1];
            valid[i] = b + i < n ? -1 : 0;
            rh.ray.org_x[i] = r->org[0], rh.ray.org_y[i] = r->org[1], rh.ray.org_z[i] = r->org[2];
            rh.ray.dir_x[i] = r->dir[0], rh.ray.dir_y[i] = r->dir[1], rh.ray.dir_z[i] = r->dir[2];
            rh.ray.tnear[i] = r->tmin, rh.ray.tfar[i] = r->tmax;
            rh.ray.mask[i] = UINT32_MAX, rh.ray.flags[i] = 0, rh.ray.time[i] = 0, rh.ray.id[i] = i;
            rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
        }
        if (shadow) {
            rtcOccluded16(valid, scene, &ctx, &rh.ray);
            for (unsigned i = 0; i < 16 && b + i < n; i++)
                out[b + i].prim = rh.ray.tfar[i] < 0, out[b + i].inst = 0;
        } else {
            rtcIntersect16(valid, scene, &ctx, &rh);
            for (unsigned i = 0; i < 16 && b + i < n; i++) {
                const int miss = rh.hit.geomID[i] == RTC_INVALID_GEOMETRY_ID;
                out[b + i].prim = miss ? SC_HITREC_MISS : rh.hit.primID[i];
                out[b + i].inst = miss ? SC_INVALID_ID : rh.hit.instID[0][i];
            }
        }
    }
    return sc_now_seconds() - t0;
}

/* Whether --rows asks for row `name`. */
static int row_wanted(const char *name)
{
    int v;
    return sc_enum_lookup(row_names, ROW_COUNT, name, &v) == 0 && (rows_wanted >> v & 1);
}

/* Paired repeats of one ray set; prints one row. packet: 16-ray packets
 * on both sides instead of single rays. */
static void time_set_as(const char *name, const sc_accel *a, RTCScene e, const sc_ray *rays, size_t n, int shadow,
                        int repeats, int packet)
{
    if (!n || !row_wanted(name))
        return;
    result *ro = malloc(n * sizeof *ro), *re = malloc(n * sizeof *re);
    double *to = malloc(sizeof(double) * (size_t)repeats), *te = malloc(sizeof(double) * (size_t)repeats),
           *ratio = malloc(sizeof(double) * (size_t)repeats);
#define OURS() (packet ? run_ours16(a, rays, n, shadow, ro) : run_ours(a, rays, n, shadow, ro))
#define EMBREE() (packet ? run_embree16(e, rays, n, shadow, re) : run_embree(e, rays, n, shadow, re))
    /* passes of the set per timed run, the same for both tracers: enough
     * for the faster one to run min_time (a set of 40k shadow rays takes
     * 20 ms, and runs that short moved by +-10 %) */
    const double t1 = fmin(OURS(), EMBREE());
    const int passes = t1 >= min_time ? 1 : (int)fmin(ceil(min_time / fmax(t1, 1e-6)), 1000);
    for (int r = 0; r < repeats; r++) {
        to[r] = te[r] = 0;
        for (int p = 0; p < passes; p++)
            to[r] += OURS();
        for (int p = 0; p < passes; p++)
            te[r] += EMBREE();
        to[r] /= passes, te[r] /= passes;
        ratio[r] = te[r] / to[r];
    }
#undef OURS
#undef EMBREE
    size_t same = 0;
    for (size_t i = 0; i < n; i++)
        same += ro[i].prim == re[i].prim && ro[i].inst == re[i].inst;
    const double mo = sc_median(to, repeats), me = sc_median(te, repeats);
    printf("%-9s %9zu %10.2f %10.2f %8.3fx %9.3f%%\n", name, n, n / mo * 1e-6, n / me * 1e-6,
           sc_median(ratio, repeats), 100.0 * same / n);
    free(ro), free(re), free(to), free(te), free(ratio);
}

static void time_set(const char *name, const sc_accel *a, RTCScene e, const sc_ray *rays, size_t n, int shadow,
                     int repeats)
{
    time_set_as(name, a, e, rays, n, shadow, repeats, 0);
}

/* ---- Embree scenes -------------------------------------------------------- */

static RTCScene embree_mesh_scene(RTCDevice dev, const sc_mesh_view *m, enum RTCBuildQuality q, RTCGeometry *geom)
{
    RTCScene s = rtcNewScene(dev);
    /* Embree honours a geometry's REFIT quality only in a scene of LOW
     * quality (its two-level structure; rtcSetGeometryBuildQuality(3)). */
    if (q == RTC_BUILD_QUALITY_REFIT || q == RTC_BUILD_QUALITY_LOW)
        rtcSetSceneBuildQuality(s, RTC_BUILD_QUALITY_LOW);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, m->positions, 0, 12,
                               m->vertex_count);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, m->indices, 0, 12, m->triangle_count);
    rtcSetGeometryBuildQuality(g, q);
    rtcCommitGeometry(g);
    rtcAttachGeometry(s, g);
    if (geom)
        *geom = g;
    else
        rtcReleaseGeometry(g);
    return s;
}

/* ---- instancing ------------------------------------------------------------ */

static void instancing(const sc_mesh_view *mesh, int ninst, int w, int h, int repeats, RTCDevice dev)
{
    float lo[3], hi[3];
    sc_mesh_bounds(mesh, lo, hi);
    double ext = 0, c[3];
    for (int k = 0; k < 3; k++)
        ext = fmax(ext, hi[k] - lo[k]), c[k] = 0.5 * (lo[k] + hi[k]);
    int side = (int)ceil(cbrt((double)ninst));
    float (*xfm)[12] = malloc(sizeof(float[12]) * (size_t)ninst);
    sc_rng rng;
    sc_rng_seed(&rng, 7);
    for (int i = 0; i < ninst; i++) {
        double ax[3] = { sc_rng_range(&rng, -1, 1), sc_rng_range(&rng, -1, 1), sc_rng_range(&rng, -1, 1) };
        double al = sqrt(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]) + 1e-9;
        for (int k = 0; k < 3; k++)
            ax[k] /= al;
        double ang = sc_rng_range(&rng, 0, 6.283185307179586), cs = cos(ang), sn = sin(ang), C = 1 - cs;
        double sc = sc_rng_range(&rng, 0.6, 0.8);
        if (identity_xfm)
            sc = 1, ang = 0, cs = 1, sn = 0, C = 0;
        double R[3][3] = { { cs + ax[0] * ax[0] * C, ax[0] * ax[1] * C - ax[2] * sn, ax[0] * ax[2] * C + ax[1] * sn },
                           { ax[1] * ax[0] * C + ax[2] * sn, cs + ax[1] * ax[1] * C, ax[1] * ax[2] * C - ax[0] * sn },
                           { ax[2] * ax[0] * C - ax[1] * sn, ax[2] * ax[1] * C + ax[0] * sn, cs + ax[2] * ax[2] * C } };
        const int g[3] = { i % side, (i / side) % side, i / (side * side) };
        for (int r = 0; r < 3; r++) {
            for (int k = 0; k < 3; k++)
                xfm[i][4 * r + k] = (float)(sc * R[r][k]);
            /* the mesh's centre goes to the grid point */
            double t = g[r] * ext - sc * (R[r][0] * c[0] + R[r][1] * c[1] + R[r][2] * c[2]);
            xfm[i][4 * r + 3] = (float)t;
        }
    }
    /* ours */
    double t0 = sc_now_seconds();
    sc_accel *obj, *world;
    if (sc_accel_new(&build_cfg, &obj) != SC_OK || sc_accel_attach_mesh(obj, mesh, SC_ACCEL_SHARED, NULL) != SC_OK ||
        sc_accel_commit(obj) != SC_OK || sc_accel_new(&build_cfg, &world) != SC_OK)
        die("spherecull scene failed");
    const double ours_obj = sc_now_seconds() - t0;
    if (plain_mesh && sc_accel_attach_mesh(world, mesh, SC_ACCEL_SHARED, NULL) != SC_OK)
        die("mesh refused");
    for (int i = 0; i < ninst && !plain_mesh; i++)
        if (sc_accel_attach_instance(world, obj, xfm[i], NULL) != SC_OK)
            die("instance refused");
    if (sc_accel_commit(world) != SC_OK)
        die("commit failed");
    double ours_build = sc_now_seconds() - t0;
    sc_accel_info io, iw;
    sc_accel_get_info(obj, &io);
    sc_accel_get_info(world, &iw);
    /* Embree */
    atomic_store(&embree_bytes, 0);
    t0 = sc_now_seconds();
    RTCScene eobj = embree_mesh_scene(dev, mesh, RTC_BUILD_QUALITY_MEDIUM, NULL);
    rtcCommitScene(eobj);
    const double embree_obj = sc_now_seconds() - t0;
    RTCScene eworld = plain_mesh ? embree_mesh_scene(dev, mesh, RTC_BUILD_QUALITY_MEDIUM, NULL) : rtcNewScene(dev);
    for (int i = 0; i < ninst && !plain_mesh; i++) {
        RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_INSTANCE);
        rtcSetGeometryInstancedScene(g, eobj);
        rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, xfm[i]);
        rtcCommitGeometry(g);
        rtcAttachGeometry(eworld, g);
        rtcReleaseGeometry(g);
    }
    rtcCommitScene(eworld);
    double embree_build = sc_now_seconds() - t0;
    long long eb = atomic_load(&embree_bytes);
    const double tris = (double)ninst * mesh->triangle_count;
    if (plain_mesh)
        printf("\ninstancing: none (--plain), the mesh of %zu triangles itself, the rays of one instance\n",
               mesh->triangle_count);
    else
        printf("\ninstancing: %d instances of %zu triangles (%.3g triangles), one shared tree%s\n", ninst,
               mesh->triangle_count, tris, identity_xfm ? ", translations only (--identity)" : "");
    printf("%-22s %12s %12s %9s\n", "", "spherecull", "embree", "ratio");
    printf("%-22s %12.4f %12.4f %8.3fx\n", "build seconds", ours_build, embree_build, embree_build / ours_build);
    printf("%-22s %12.4f %12.4f %8.3fx\n", "  of which the mesh", ours_obj, embree_obj, embree_obj / ours_obj);
    printf("%-22s %12.4f %12.4f %8.3fx\n", "  of which instances", ours_build - ours_obj, embree_build - embree_obj,
           (embree_build - embree_obj) / (ours_build - ours_obj));
    printf("%-22s %12.1f %12.1f %8.3fx\n", "MB", (io.bytes + iw.bytes) / 1e6, eb / 1e6,
           (double)eb / (double)(io.bytes + iw.bytes));
    ray_sets rs;
    float wlo[3] = { INFINITY, INFINITY, INFINITY }, whi[3] = { -INFINITY, -INFINITY, -INFINITY };
    for (int k = 0; k < 3; k++)
        wlo[k] = (float)(-0.5 * ext), whi[k] = (float)((side - 0.5) * ext);
    /* the plain mesh is where it is, an instance's centre at the origin */
    if (plain_mesh)
        for (int k = 0; k < 3; k++)
            wlo[k] = (float)(c[k] - 0.5 * ext), whi[k] = (float)(c[k] + 0.5 * ext);
    make_rays(wlo, whi, w, h, world, &rs);
    printf("%-9s %9s %10s %10s %9s %10s\n", "rays", "count", "ours Mr/s", "embree", "ratio", "same hit");
    time_set("primary", world, eworld, rs.primary, rs.n, 0, repeats);
    time_set("shadow", world, eworld, rs.shadow, rs.nshadow, 1, repeats);
    time_set("diffuse", world, eworld, rs.diffuse, rs.ndiffuse, 0, repeats);
    time_set_as("primary16", world, eworld, rs.primary, rs.n, 0, repeats, 1);
    time_set_as("shadow16", world, eworld, rs.shadow, rs.nshadow, 1, repeats, 1);
    time_set_as("diffuse16", world, eworld, rs.diffuse, rs.ndiffuse, 0, repeats, 1);
    free_rays(&rs);
    rtcReleaseScene(eworld);
    rtcReleaseScene(eobj);
    sc_accel_release(world);
    sc_accel_release(obj);
    free(xfm);
}

/* ---- refit ------------------------------------------------------------------- */

/* The rest pose moved by a smooth wave of amplitude 4 % of the mesh's size. */
static void deform(const float *rest, float *out, size_t nv, const float lo[3], double ext, double phase)
{
    const double a = 0.04 * ext, k = 6.283185307179586 / ext;
    for (size_t i = 0; i < nv; i++) {
        const float *p = rest + 3 * i;
        out[3 * i + 0] = (float)(p[0] + a * sin(k * (p[1] - lo[1]) + phase));
        out[3 * i + 1] = (float)(p[1] + a * sin(k * (p[2] - lo[2]) + 1.3 * phase));
        out[3 * i + 2] = (float)(p[2] + a * cos(k * (p[0] - lo[0]) + 0.7 * phase));
    }
}

static void refit(const sc_mesh_view *mesh, int refits, int w, int h, int repeats, RTCDevice dev)
{
    const size_t nv = mesh->vertex_count;
    float lo[3], hi[3];
    sc_mesh_bounds(mesh, lo, hi);
    double ext = 0;
    for (int k = 0; k < 3; k++)
        ext = fmax(ext, hi[k] - lo[k]);
    float *rest = malloc(12 * nv), *pos = malloc(12 * nv + 4), *epos = malloc(12 * nv + 4);
    for (size_t i = 0; i < nv; i++)
        memcpy(rest + 3 * i, sc_mesh_vertex(mesh, i), 12);
    memcpy(pos, rest, 12 * nv);
    memcpy(epos, rest, 12 * nv);
    const sc_mesh_view mv = { pos, nv, mesh->indices, mesh->triangle_count, 0, mesh->index_stride };
    const sc_mesh_view ev = { epos, nv, mesh->indices, mesh->triangle_count, 0, mesh->index_stride };
    sc_accel *a;
    if (sc_accel_new(&build_cfg, &a) != SC_OK || sc_accel_attach_mesh(a, &mv, SC_ACCEL_SHARED, NULL) != SC_OK ||
        sc_accel_commit(a) != SC_OK)
        die("spherecull scene failed");
    RTCGeometry eg, lg;
    RTCScene es = embree_mesh_scene(dev, &ev, RTC_BUILD_QUALITY_REFIT, &eg);
    rtcCommitScene(es);
    /* Embree's cheapest update of a moving mesh: a low-quality rebuild */
    RTCScene ls = embree_mesh_scene(dev, &ev, RTC_BUILD_QUALITY_LOW, &lg);
    rtcCommitScene(ls);
    double *tr = malloc(sizeof(double) * (size_t)refits), *te = malloc(sizeof(double) * (size_t)refits),
           *tl = malloc(sizeof(double) * (size_t)refits);
    for (int s = 0; s < refits; s++) {
        const double phase = 0.05 * (s + 1);
        deform(rest, pos, nv, lo, ext, phase);
        memcpy(epos, pos, 12 * nv);
        double t0 = sc_now_seconds();
        if (sc_accel_refit(a) != SC_OK)
            die("refit failed");
        tr[s] = sc_now_seconds() - t0;
        t0 = sc_now_seconds();
        rtcUpdateGeometryBuffer(eg, RTC_BUFFER_TYPE_VERTEX, 0);
        rtcCommitGeometry(eg);
        rtcCommitScene(es);
        te[s] = sc_now_seconds() - t0;
        t0 = sc_now_seconds();
        rtcUpdateGeometryBuffer(lg, RTC_BUFFER_TYPE_VERTEX, 0);
        rtcCommitGeometry(lg);
        rtcCommitScene(ls);
        tl[s] = sc_now_seconds() - t0;
    }
    sc_accel_info info;
    sc_accel_get_info(a, &info);
    /* fresh builds of the final pose */
    double t0 = sc_now_seconds();
    sc_accel *fresh;
    if (sc_accel_new(&build_cfg, &fresh) != SC_OK || sc_accel_attach_mesh(fresh, &mv, SC_ACCEL_SHARED, NULL) != SC_OK ||
        sc_accel_commit(fresh) != SC_OK)
        die("spherecull scene failed");
    double ours_fresh = sc_now_seconds() - t0;
    t0 = sc_now_seconds();
    RTCScene efresh = embree_mesh_scene(dev, &ev, RTC_BUILD_QUALITY_MEDIUM, NULL);
    rtcCommitScene(efresh);
    double embree_fresh = sc_now_seconds() - t0;
    const double mr = sc_median(tr, refits), me = sc_median(te, refits), ml = sc_median(tl, refits);
    printf("\nrefit: %zu triangles, %d steps of a smooth wave (amplitude 4 %% of the size); median seconds\n",
           mesh->triangle_count, refits);
    printf("%-34s %12s %12s %9s\n", "", "spherecull", "embree", "ratio");
    printf("%-34s %12.5f %12.5f %8.3fx\n", "refit (Embree: scene low, mesh refit)", mr, me, me / mr);
    printf("%-34s %12.5f %12.5f %8.3fx\n", "refit (Embree: low-quality rebuild)", mr, ml, ml / mr);
    printf("%-34s %12.5f %12.5f %8.3fx\n", "fresh build (medium)", ours_fresh, embree_fresh, embree_fresh / ours_fresh);
    printf("%-34s %12.3f\n", "refit / own fresh build", mr / ours_fresh);
    printf("refits %u, rebuilds %u (past SAH growth %.2f); SAH growth now %.3f\n", info.refits, info.builds - 1,
           SC_ACCEL_REBUILD_GROWTH, info.sah_growth);
    ray_sets rs;
    make_rays(lo, hi, w, h, fresh, &rs);
    printf("after %d refits: ours refitted / ours fresh, Embree refitted / Embree fresh\n", refits);
    printf("%-9s %9s %10s %10s %9s %10s\n", "rays", "count", "refit Mr/s", "fresh", "ratio", "");
    const sc_ray *sets[3] = { rs.primary, rs.shadow, rs.diffuse };
    const size_t ns[3] = { rs.n, rs.nshadow, rs.ndiffuse };
    const char *names[3] = { "primary", "shadow", "diffuse" };
    for (int k = 0; k < 3; k++) {
        size_t n = ns[k];
        if (!n)
            continue;
        result *res = malloc(n * sizeof *res);
        double *x = malloc(sizeof(double) * (size_t)repeats), *y = malloc(sizeof(double) * (size_t)repeats),
               *u = malloc(sizeof(double) * (size_t)repeats), *v = malloc(sizeof(double) * (size_t)repeats);
        for (int r = 0; r < repeats; r++) {
            x[r] = run_ours(a, sets[k], n, k == 1, res);
            y[r] = run_ours(fresh, sets[k], n, k == 1, res);
            u[r] = run_embree(es, sets[k], n, k == 1, res);
            v[r] = run_embree(efresh, sets[k], n, k == 1, res);
        }
        double ox = sc_median(x, repeats), oy = sc_median(y, repeats),
               eu = sc_median(u, repeats), evv = sc_median(v, repeats);
        printf("%-9s %9zu %10.2f %10.2f %8.3fx   embree %.2f / %.2f = %.3fx\n", names[k], n, n / ox * 1e-6,
               n / oy * 1e-6, oy / ox, n / eu * 1e-6, n / evv * 1e-6, evv / eu);
        free(res), free(x), free(y), free(u), free(v);
    }
    free_rays(&rs);
    rtcReleaseScene(efresh);
    rtcReleaseGeometry(eg);
    rtcReleaseScene(es);
    rtcReleaseGeometry(lg);
    rtcReleaseScene(ls);
    sc_accel_release(fresh);
    sc_accel_release(a);
    free(tr), free(te), free(tl), free(rest), free(pos), free(epos);
}

int main(int argc, char **argv)
{
    const char *spec = "proc:sphere:100k";
    int ninst = 1000, w = 384, h = 256, repeats = 5, refits = 100, threads = 1;
    static const struct option opts[] = { { "mesh", required_argument, 0, 'm' },
                                          { "instances", required_argument, 0, 'n' },
                                          { "size", required_argument, 0, 's' },
                                          { "repeats", required_argument, 0, 'r' },
                                          { "refits", required_argument, 0, 'k' },
                                          { "threads", required_argument, 0, 't' },
                                          { "min-time", required_argument, 0, 'T' },
                                          { "rows", required_argument, 0, 'R' },
                                          { "identity", no_argument, 0, 'I' },
                                          { "plain", no_argument, 0, 'P' },
                                          { "shuffle", no_argument, 0, 'S' },
                                          { 0, 0, 0, 0 } };
    int o;
    while ((o = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        switch (o) {
        case 'm': spec = optarg; break;
        case 'n': ninst = atoi(optarg); break;
        case 's':
            if (sscanf(optarg, "%dx%d", &w, &h) != 2)
                die("--size WxH");
            break;
        case 'r': repeats = atoi(optarg); break;
        case 'k': refits = atoi(optarg); break;
        case 't': threads = atoi(optarg); break;
        case 'T': min_time = atof(optarg); break;
        case 'I': identity_xfm = 1; break;
        case 'P': plain_mesh = 1; break;
        case 'S': shuffle_rays = 1; break;
        case 'R': {
            /* a copy for strtok_r, as the CLI's comma lists */
            char buf[256];
            if (snprintf(buf, sizeof buf, "%s", optarg) >= (int)sizeof buf)
                die("--rows: list too long");
            char *save = NULL;
            rows_wanted = 0;
            for (char *tok = strtok_r(buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
                int v;
                if (sc_enum_lookup(row_names, ROW_COUNT, tok, &v) != 0)
                    die("--rows: names among primary, shadow, diffuse, primary16, shadow16, diffuse16");
                rows_wanted |= 1u << v;
            }
            if (!rows_wanted)
                die("--rows: an empty list");
            break;
        }
        default: die("usage: bench_scene [--mesh SPEC] [--instances N] [--size WxH] [--repeats R] [--refits K] [--threads T] [--min-time S] [--rows LIST] [--identity] [--plain] [--shuffle]");
        }
    }
    if (plain_mesh && ninst != 1)
        die("--plain traces one mesh: give --instances 1");
    if (ninst < 0 || w < 4 || h < 4 || w % 4 || h % 4 || repeats < 1 || refits < 0 || threads < 1 ||
        !(min_time >= 0 && min_time <= 60))
        die("bad option value (the image size in multiples of 4)");
    sc_bvh_config_default(&build_cfg);
    build_cfg.threads = threads;
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
    sc_scene *scene;
    char err[256];
    if (sc_scene_load(spec, NULL, &scene, err, sizeof err) != SC_OK) {
        fprintf(stderr, "bench_scene: %s\n", err);
        return 1;
    }
    sc_scene_view view;
    sc_scene_get_view(scene, &view);
    char ver[512];
    sc_embree_version(ver, sizeof ver);
    char cfg[64];
    snprintf(cfg, sizeof cfg, "verbose=0,threads=%d", threads);
    RTCDevice dev = rtcNewDevice(cfg);
    if (!dev)
        die("no Embree device");
    rtcSetDeviceMemoryMonitorFunction(dev, monitor, NULL);
    printf("mesh %s (%zu triangles); embree: %s (FTZ|DAZ); both build on %d thread%s, trace on 1; %d repeats of "
           ">= %.2g s, medians\n",
           spec, view.mesh.triangle_count, ver, threads, threads == 1 ? "" : "s", repeats, min_time);
    if (ninst > 0)
        instancing(&view.mesh, ninst, w, h, repeats, dev);
    if (refits > 0)
        refit(&view.mesh, refits, w, h, repeats, dev);
    rtcReleaseDevice(dev);
    sc_scene_free(scene);
    return 0;
}
