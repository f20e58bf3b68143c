/* Embree 3 back end: native triangles and the user-geometry prefilter
 * drop-in (see sc_embree.h). */
/* dladdr (which shared object the Embree symbols came from) is a GNU extension. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <embree3/rtcore.h>

#include "spherecull/sc_embree.h"
#include "trace/tri_watertight.h"

enum { MAX_CLUSTER = 16 };

struct sc_embree {
    RTCDevice device;
    RTCScene scene;
    sc_embree_config cfg;
    sc_embree_info info;
    /* memory monitor: bytes currently held and the peak */
    _Atomic long long mem_now, mem_peak;
    int device_error;
    /* user modes */
    uint32_t nclusters;
    int width;                  /* 8 or 16: the sphere block used */
    sc_sphere_block8 *b8;
    sc_sphere_block16 *b16;
    float (*tri)[9];            /* nclusters * width triangles */
    uint32_t *prim;             /* nclusters * width original ids */
    uint8_t *count;             /* triangles per cluster */
    float (*box)[6];            /* per cluster lo, hi */
    /* sc_embree_create_instanced: instances are geometries 0..n-1 of the
     * top scene, its own mesh geometry n (reported as geom 0) */
    int instanced;
    uint32_t num_instances;
};

/* The context passed through Embree to our callbacks: Embree hands the
 * caller's RTCIntersectContext pointer back unchanged, so it can carry
 * per-thread counters. */
typedef struct ctx_ext {
    struct RTCIntersectContext rtc;
    sc_embree_counters *ctr;
} ctx_ext;

void sc_embree_config_default(sc_embree_config *cfg)
{
    if (!cfg)
        return;
    memset(cfg, 0, sizeof *cfg);
    cfg->mode = SC_EMBREE_DEFAULT;
    cfg->quality = SC_EMBREE_QUALITY_MEDIUM;
    cfg->cluster_size = 8;
    cfg->sphere = SC_SPHERE_MINIMAL;
    cfg->build_threads = 0;
}

sc_status sc_embree_version(char *buf, size_t n)
{
    if (!buf || n == 0)
        return SC_ERR_INVALID_ARGUMENT;
    buf[0] = 0;
    RTCDevice d = rtcNewDevice("verbose=0");
    if (!d)
        return SC_ERR_UNSUPPORTED;
    long major = (long)rtcGetDeviceProperty(d, RTC_DEVICE_PROPERTY_VERSION_MAJOR);
    long minor = (long)rtcGetDeviceProperty(d, RTC_DEVICE_PROPERTY_VERSION_MINOR);
    long patch = (long)rtcGetDeviceProperty(d, RTC_DEVICE_PROPERTY_VERSION_PATCH);
    rtcReleaseDevice(d);
    Dl_info info;
    const char *path = "?";
    /* An object pointer to a function: the one cast POSIX dladdr needs. */
    if (dladdr((void *)(uintptr_t)&rtcNewDevice, &info) && info.dli_fname)
        path = info.dli_fname;
    snprintf(buf, n, "%ld.%ld.%ld %s", major, minor, patch, path);
    return SC_OK;
}

static bool memory_monitor(void *ptr, ssize_t bytes, bool post)
{
    (void)post;
    sc_embree *e = ptr;
    long long now = atomic_fetch_add(&e->mem_now, (long long)bytes) + (long long)bytes;
    long long peak = atomic_load(&e->mem_peak);
    while (now > peak && !atomic_compare_exchange_weak(&e->mem_peak, &peak, now))
        ;
    return true;                       /* never refuse an allocation */
}

static void error_function(void *ptr, enum RTCError code, const char *str)
{
    (void)str;
    sc_embree *e = ptr;
    if (!e->device_error)
        e->device_error = (int)code;
}

/* ---- clusters ------------------------------------------------------------ */

typedef struct centroid_key {
    float c;
    uint32_t tri;
} centroid_key;

static int cmp_key(const void *pa, const void *pb)
{
    const centroid_key *a = pa, *b = pb;
    if (a->c != b->c)
        return a->c < b->c ? -1 : 1;
    return (a->tri > b->tri) - (a->tri < b->tri);
}

/* Median split on the longest centroid axis, splitting at a multiple of k so
 * every cluster but the last of a run is full. Iterative: an explicit stack
 * of ranges. */
static void split_clusters(const float *cent, uint32_t *order, size_t n, int k, uint32_t *starts,
                           uint32_t *nclusters, centroid_key *keys)
{
    size_t stack[128][2];
    int sp = 0;
    stack[sp][0] = 0, stack[sp][1] = n, sp++;
    uint32_t nc = 0;
    while (sp) {
        sp--;
        size_t lo = stack[sp][0], hi = stack[sp][1];
        if (hi - lo <= (size_t)k) {
            starts[nc++] = (uint32_t)lo;
            continue;
        }
        float mn[3] = { INFINITY, INFINITY, INFINITY }, mx[3] = { -INFINITY, -INFINITY, -INFINITY };
        for (size_t i = lo; i < hi; i++)
            for (int a = 0; a < 3; a++) {
                float c = cent[3 * (size_t)order[i] + a];
                if (c < mn[a]) mn[a] = c;
                if (c > mx[a]) mx[a] = c;
            }
        int axis = 0;
        for (int a = 1; a < 3; a++)
            if (mx[a] - mn[a] > mx[axis] - mn[axis])
                axis = a;
        for (size_t i = lo; i < hi; i++) {
            keys[i - lo].c = cent[3 * (size_t)order[i] + axis];
            keys[i - lo].tri = order[i];
        }
        qsort(keys, hi - lo, sizeof *keys, cmp_key);
        for (size_t i = lo; i < hi; i++)
            order[i] = keys[i - lo].tri;
        size_t groups = (hi - lo + (size_t)k - 1) / (size_t)k;
        size_t mid = lo + (groups / 2) * (size_t)k;
        /* push right then left so clusters come out in spatial order */
        stack[sp][0] = mid, stack[sp][1] = hi, sp++;
        stack[sp][0] = lo, stack[sp][1] = mid, sp++;
    }
    *nclusters = nc;
}

static int cmp_u32(const void *pa, const void *pb)
{
    uint32_t a = *(const uint32_t *)pa, b = *(const uint32_t *)pb;
    return (a > b) - (a < b);
}

static sc_status build_clusters(sc_embree *e, const sc_checked_mesh *checked)
{
    const sc_mesh_view *m = &checked->view;
    const size_t nt = m->triangle_count;
    const int k = e->cfg.cluster_size;
    float *cent = malloc(3 * nt * sizeof *cent);
    uint32_t *order = malloc(nt * sizeof *order);
    uint32_t *starts = malloc((nt + 1) * sizeof *starts);
    centroid_key *keys = malloc(nt * sizeof *keys);
    if (!cent || !order || !starts || !keys) {
        free(cent), free(order), free(starts), free(keys);
        return SC_ERR_OUT_OF_MEMORY;
    }
    for (size_t t = 0; t < nt; t++) {
        order[t] = (uint32_t)t;
        for (int a = 0; a < 3; a++) {
            double s = 0;
            for (int c = 0; c < 3; c++)
                s += sc_mesh_vertex(m, sc_mesh_triangle(m, t)[c])[a];
            cent[3 * t + a] = (float)(s / 3);
        }
    }
    uint32_t nc = 0;
    split_clusters(cent, order, nt, k, starts, &nc, keys);
    /* the stack pops ranges in spatial order already; sort to be safe */
    qsort(starts, nc, sizeof *starts, cmp_u32);
    starts[nc] = (uint32_t)nt;
    free(cent), free(keys);

    e->nclusters = nc;
    e->width = k <= 8 ? 8 : 16;
    size_t w = (size_t)e->width;
    if (e->width == 8)
        e->b8 = aligned_alloc(64, nc * sizeof *e->b8);
    else
        e->b16 = aligned_alloc(64, nc * sizeof *e->b16);
    e->tri = aligned_alloc(64, ((nc * w * sizeof *e->tri + 63) / 64) * 64);
    e->prim = malloc(nc * w * sizeof *e->prim);
    e->count = malloc(nc);
    e->box = malloc(nc * sizeof *e->box);
    if ((!e->b8 && !e->b16) || !e->tri || !e->prim || !e->count || !e->box) {
        free(order), free(starts);
        return SC_ERR_OUT_OF_MEMORY;
    }
    double diag_sum = 0;
    const float *slo = checked->lo, *shi = checked->hi;
    double sdiag = sqrt(((double)shi[0] - slo[0]) * ((double)shi[0] - slo[0]) +
                        ((double)shi[1] - slo[1]) * ((double)shi[1] - slo[1]) +
                        ((double)shi[2] - slo[2]) * ((double)shi[2] - slo[2]));
    for (uint32_t c = 0; c < nc; c++) {
        uint32_t n = starts[c + 1] - starts[c];
        e->count[c] = (uint8_t)n;
        if (e->width == 8)
            sc_sphere_block8_init(&e->b8[c]);
        else
            sc_sphere_block16_init(&e->b16[c]);
        float *bx = e->box[c];
        bx[0] = bx[1] = bx[2] = INFINITY;
        bx[3] = bx[4] = bx[5] = -INFINITY;
        for (uint32_t i = 0; i < w; i++) {
            float *v = e->tri[c * w + i];
            if (i >= n) {
                memset(v, 0, sizeof e->tri[0]);
                e->prim[c * w + i] = SC_HITREC_MISS;
                continue;
            }
            uint32_t t = order[starts[c] + i];
            e->prim[c * w + i] = t;
            for (int j = 0; j < 3; j++)
                for (int a = 0; a < 3; a++) {
                    float x = sc_mesh_vertex(m, sc_mesh_triangle(m, t)[j])[a];
                    v[3 * j + a] = x;
                    if (x < bx[a]) bx[a] = x;
                    if (x > bx[3 + a]) bx[3 + a] = x;
                }
            sc_spheref s;
            sc_prefilter_sphere_f(v, v + 3, v + 6, e->cfg.sphere, SC_METHOD_TEXTBOOK, &s);
            if (e->width == 8)
                sc_sphere_block8_set(&e->b8[c], (int)i, &s);
            else
                sc_sphere_block16_set(&e->b16[c], (int)i, &s);
        }
        double d = sqrt(((double)bx[3] - bx[0]) * ((double)bx[3] - bx[0]) +
                        ((double)bx[4] - bx[1]) * ((double)bx[4] - bx[1]) +
                        ((double)bx[5] - bx[2]) * ((double)bx[5] - bx[2]));
        diag_sum += sdiag > 0 ? d / sdiag : 0;
    }
    free(order), free(starts);
    e->info.clusters = nc;
    e->info.mean_cluster_size = nc ? (double)nt / nc : 0;
    e->info.mean_cluster_diag = nc ? diag_sum / nc : 0;
    e->info.ours_bytes = nc * (w * (sizeof *e->tri + sizeof *e->prim) + 1 + sizeof *e->box +
                               (e->width == 8 ? sizeof *e->b8 : sizeof *e->b16));
    return SC_OK;
}

/* Embree's box tests for user geometry are not conservative even with
 * RTC_SCENE_FLAG_ROBUST: a ray through a vertex that lies on a cluster box's
 * face was culled before the callback ran (tests/test_embree.c, vertex rays
 * through a closed sphere). So the boxes handed to Embree are padded by
 * 2^-16 of their size and of their distance from the origin — far above the
 * float rounding of a slab test for origins within a few scene sizes, and
 * negligible for culling. */
static void bounds_cb(const struct RTCBoundsFunctionArguments *args)
{
    const sc_embree *e = args->geometryUserPtr;
    const float *bx = e->box[args->primID];
    float pad[3];
    for (int a = 0; a < 3; a++)
        pad[a] = 0x1p-16f * ((bx[3 + a] - bx[a]) + fmaxf(fabsf(bx[a]), fabsf(bx[3 + a]))) + 0x1p-100f;
    args->bounds_o->lower_x = bx[0] - pad[0], args->bounds_o->lower_y = bx[1] - pad[1];
    args->bounds_o->lower_z = bx[2] - pad[2];
    args->bounds_o->upper_x = bx[3] + pad[0], args->bounds_o->upper_y = bx[4] + pad[1];
    args->bounds_o->upper_z = bx[5] + pad[2];
}

/* Candidate lanes of cluster c for ray r: all filled lanes, minus the
 * sphere rejects in prefilter mode. */
static uint32_t live_lanes(const sc_embree *e, uint32_t c, const sc_ray *r, sc_embree_counters *ctr)
{
    uint32_t n = e->count[c];
    uint32_t filled = n >= 32 ? ~0u : (1u << n) - 1;
    if (e->cfg.mode != SC_EMBREE_USER_PREFILTER)
        return filled;
    uint32_t rej = e->width == 8 ? sc_reject8(r, &e->b8[c]) : sc_reject16(r, &e->b16[c]);
    uint32_t live = ~rej & filled;
    if (ctr) {
        ctr->sphere_tests += n;
        ctr->sphere_rejects += (uint64_t)__builtin_popcount(rej & filled);
    }
    return live;
}

/* Ray i of an SoA packet of N: Embree's RTCRayN layout is org_x[N], org_y[N],
 * org_z[N], tnear[N], dir_x[N], dir_y[N], dir_z[N], time[N], tfar[N], ...;
 * the hit follows at float offset 12 N: Ng_x, Ng_y, Ng_z, u, v, primID, geomID, instID. */
#define RAYN(p, k) (((float *)(p))[(k) * N + i])
#define RAYN_U(p, k) (((unsigned *)(p))[(k) * N + i])

/* The cluster loop of both callbacks. Always inlined with a constant
 * `occluded`, so each callback compiles to its own branch-free loop. With
 * occluded, hit is unused and the first hit marks the ray and stops. */
static inline __attribute__((always_inline)) void
cluster_n(const sc_embree *e, sc_embree_counters *ctr, const int *valid, unsigned N, float *ray, float *hit,
          uint32_t c, unsigned geomID, unsigned instID, const int occluded)
{
    const size_t w = (size_t)e->width;
    for (unsigned i = 0; i < N; i++) {
        if (!valid[i])
            continue;
        sc_ray r = { { RAYN(ray, 0), RAYN(ray, 1), RAYN(ray, 2) }, RAYN(ray, 3),
                     { RAYN(ray, 4), RAYN(ray, 5), RAYN(ray, 6) }, RAYN(ray, 8) };
        if (ctr)
            ctr->cluster_calls++;
        uint32_t live = live_lanes(e, c, &r, ctr);
        if (!live)
            continue;
        sc_ray_pre pre;
        sc_ray_precompute_shear(&r, &pre);
        while (live) {
            int j = __builtin_ctz(live);
            live &= live - 1;
            /* A cluster triangle (9 floats) is a leaf block of width 1. The
             * hit interval is [tmin, tmax): of equal t the first found stays. */
            float t, un, vn, den;
            int h = sc_tri_watertight(&pre, e->tri[c * w + (size_t)j], 1, 0, r.tmin, r.tmax, &t, &un, &vn, &den) &&
                    t < r.tmax;
            if (ctr) {
                ctr->tri_tests++;
                ctr->tri_hits += (uint64_t)h;
                if (!h && e->cfg.mode == SC_EMBREE_USER_PREFILTER)
                    ctr->false_positives++;
            }
            if (!h)
                continue;
            if (occluded) {
                RAYN(ray, 8) = -INFINITY;    /* Embree's "occluded" mark */
                break;
            }
            const float *tv = e->tri[c * w + (size_t)j];
            float e1[3], e2[3];
            for (int a = 0; a < 3; a++)
                e1[a] = tv[3 + a] - tv[a], e2[a] = tv[6 + a] - tv[a];
            r.tmax = t;
            RAYN(ray, 8) = t;
            RAYN(hit, 0) = e1[1] * e2[2] - e1[2] * e2[1];
            RAYN(hit, 1) = e1[2] * e2[0] - e1[0] * e2[2];
            RAYN(hit, 2) = e1[0] * e2[1] - e1[1] * e2[0];
            RAYN(hit, 3) = un / den;
            RAYN(hit, 4) = vn / den;
            RAYN_U(hit, 5) = e->prim[c * w + (size_t)j];
            RAYN_U(hit, 6) = geomID;
            RAYN_U(hit, 7) = instID;
        }
    }
}

static void intersect_cb(const struct RTCIntersectFunctionNArguments *args)
{
    float *ray = (float *)args->rayhit;
    cluster_n(args->geometryUserPtr, ((ctx_ext *)args->context)->ctr, args->valid, args->N, ray,
              ray + 12 * args->N, args->primID, args->geomID, args->context->instID[0], 0);
}

static void occluded_cb(const struct RTCOccludedFunctionNArguments *args)
{
    cluster_n(args->geometryUserPtr, ((ctx_ext *)args->context)->ctr, args->valid, args->N,
              (float *)args->ray, NULL, args->primID, args->geomID, 0, 1);
}
#undef RAYN
#undef RAYN_U

/* ---- create / destroy ---------------------------------------------------- */

static sc_status check_config(const sc_embree_config *cfg)
{
    if ((unsigned)cfg->mode >= SC_EMBREE_MODE_COUNT || (unsigned)cfg->quality >= SC_EMBREE_QUALITY_COUNT ||
        (unsigned)cfg->sphere >= SC_SPHERE_KIND_COUNT || cfg->build_threads < 0 || cfg->build_threads > 1024)
        return SC_ERR_INVALID_ARGUMENT;
    if ((cfg->mode == SC_EMBREE_USER_PREFILTER || cfg->mode == SC_EMBREE_USER_PLAIN) &&
        (cfg->cluster_size < 2 || cfg->cluster_size > MAX_CLUSTER))
        return SC_ERR_INVALID_ARGUMENT;
    return SC_OK;
}

/* A native triangle geometry holding Embree's own copies of the mesh, so
 * the memory monitor counts what a user of Embree pays; NULL when out of
 * memory. Not committed. */
static RTCGeometry triangle_geometry(RTCDevice dev, const sc_mesh_view *mesh)
{
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (!g)
        return NULL;
    float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                        mesh->vertex_count);
    unsigned *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                           mesh->triangle_count);
    if (!vb || !ib) {
        rtcReleaseGeometry(g);
        return NULL;
    }
    for (size_t i = 0; i < mesh->vertex_count; i++)
        memcpy(vb + 3 * i, sc_mesh_vertex(mesh, i), 3 * sizeof(float));
    for (size_t t = 0; t < mesh->triangle_count; t++)
        memcpy(ib + 3 * t, sc_mesh_triangle(mesh, t), 3 * sizeof(unsigned));
    return g;
}

static enum RTCSceneFlags scene_flags(sc_embree_mode mode)
{
    /* The drop-in needs Embree's conservative box tests too: a ray through
     * a vertex on a cluster box's face is otherwise culled before our
     * watertight test runs (measured: vertex rays through closed meshes). */
    return mode == SC_EMBREE_DEFAULT ? RTC_SCENE_FLAG_NONE
           : mode == SC_EMBREE_COMPACT ? RTC_SCENE_FLAG_COMPACT
                                       : RTC_SCENE_FLAG_ROBUST;
}

static enum RTCBuildQuality build_quality(sc_embree_quality q)
{
    return q == SC_EMBREE_QUALITY_HIGH ? RTC_BUILD_QUALITY_HIGH : RTC_BUILD_QUALITY_MEDIUM;
}

/* A device as the config asks, with our error and memory callbacks. */
static sc_status new_device(sc_embree *e)
{
    char config[64] = "verbose=0";
    if (e->cfg.build_threads > 0)
        snprintf(config, sizeof config, "verbose=0,threads=%d", e->cfg.build_threads);
    e->device = rtcNewDevice(config);
    if (!e->device)
        return rtcGetDeviceError(NULL) == RTC_ERROR_UNSUPPORTED_CPU ? SC_ERR_UNSUPPORTED : SC_ERR_OUT_OF_MEMORY;
    rtcSetDeviceErrorFunction(e->device, error_function, e);
    rtcSetDeviceMemoryMonitorFunction(e->device, memory_monitor, e);
    return SC_OK;
}

/* After the commit: Embree's errors, and what it holds. */
static sc_status finish_create(sc_embree *e, sc_embree **out)
{
    if (e->device_error || rtcGetDeviceError(e->device) != RTC_ERROR_NONE) {
        int code = e->device_error;
        sc_embree_destroy(e);
        return code == RTC_ERROR_OUT_OF_MEMORY ? SC_ERR_OUT_OF_MEMORY : SC_ERR_UNSUPPORTED;
    }
    e->info.embree_bytes = (size_t)(atomic_load(&e->mem_now) > 0 ? atomic_load(&e->mem_now) : 0);
    e->info.embree_peak_bytes = (size_t)(atomic_load(&e->mem_peak) > 0 ? atomic_load(&e->mem_peak) : 0);
    *out = e;
    return SC_OK;
}

sc_status sc_embree_create(const sc_checked_mesh *checked, const sc_embree_config *cfg,
                           sc_embree **out)
{
    if (!out || !cfg)
        return SC_ERR_INVALID_ARGUMENT;
    *out = NULL;
    if (!checked)
        return SC_ERR_INVALID_ARGUMENT;
    const sc_mesh_view *mesh = &checked->view;
    sc_status st = check_config(cfg);
    if (st != SC_OK)
        return st;
    sc_embree *e = calloc(1, sizeof *e);
    if (!e)
        return SC_ERR_OUT_OF_MEMORY;
    e->cfg = *cfg;
    e->info.triangles = mesh->triangle_count;
    if ((st = new_device(e)) != SC_OK) {
        sc_embree_destroy(e);
        return st;
    }
    e->scene = rtcNewScene(e->device);
    rtcSetSceneBuildQuality(e->scene, build_quality(cfg->quality));
    rtcSetSceneFlags(e->scene, scene_flags(cfg->mode));

    RTCGeometry g;
    if (cfg->mode == SC_EMBREE_DEFAULT || cfg->mode == SC_EMBREE_ROBUST || cfg->mode == SC_EMBREE_COMPACT) {
        if (!(g = triangle_geometry(e->device, mesh))) {
            sc_embree_destroy(e);
            return SC_ERR_OUT_OF_MEMORY;
        }
    } else {
        if ((st = build_clusters(e, checked)) != SC_OK) {
            sc_embree_destroy(e);
            return st;
        }
        g = rtcNewGeometry(e->device, RTC_GEOMETRY_TYPE_USER);
        rtcSetGeometryUserPrimitiveCount(g, e->nclusters);
        rtcSetGeometryUserData(g, e);
        rtcSetGeometryBoundsFunction(g, bounds_cb, e);
        rtcSetGeometryIntersectFunction(g, intersect_cb);
        /* the Debian build aborts on rtcOccluded1 without one */
        rtcSetGeometryOccludedFunction(g, occluded_cb);
    }
    rtcSetGeometryBuildQuality(g, build_quality(cfg->quality));
    rtcCommitGeometry(g);
    rtcAttachGeometry(e->scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(e->scene);
    return finish_create(e, out);
}

sc_status sc_embree_create_instanced(const sc_checked_mesh *own, const sc_checked_mesh *objects, size_t num_objects,
                                     const sc_embree_instance *instances, size_t num_instances,
                                     const sc_embree_config *cfg, sc_embree **out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    *out = NULL;
    if (!cfg || (num_objects && !objects) || (num_instances && !instances) || num_instances >= RTC_INVALID_GEOMETRY_ID)
        return SC_ERR_INVALID_ARGUMENT;
    sc_status st = check_config(cfg);
    if (st != SC_OK)
        return st;
    if (cfg->mode != SC_EMBREE_DEFAULT && cfg->mode != SC_EMBREE_ROBUST && cfg->mode != SC_EMBREE_COMPACT)
        return SC_ERR_UNSUPPORTED;
    for (size_t i = 0; i < num_instances; i++)
        if (instances[i].object >= num_objects)
            return SC_ERR_INVALID_ARGUMENT;
    sc_embree *e = calloc(1, sizeof *e);
    if (!e)
        return SC_ERR_OUT_OF_MEMORY;
    e->cfg = *cfg;
    e->instanced = 1;
    e->num_instances = (uint32_t)num_instances;
    size_t tris = own ? own->view.triangle_count : 0;
    for (size_t i = 0; i < num_instances; i++)
        tris += objects[instances[i].object].view.triangle_count;
    e->info.triangles = tris > UINT32_MAX ? UINT32_MAX : (uint32_t)tris;
    RTCScene *obj = calloc(num_objects ? num_objects : 1, sizeof *obj);
    if (!obj || (st = new_device(e)) != SC_OK) {
        free(obj);
        sc_embree_destroy(e);
        return obj ? st : SC_ERR_OUT_OF_MEMORY;
    }
    st = SC_OK;
    /* One scene per object, as an Embree user builds them; the instances
     * take ids 0..n-1 in the top scene, so Embree's instID is our inst. */
    for (size_t k = 0; k < num_objects && st == SC_OK; k++) {
        obj[k] = rtcNewScene(e->device);
        rtcSetSceneBuildQuality(obj[k], build_quality(cfg->quality));
        rtcSetSceneFlags(obj[k], scene_flags(cfg->mode));
        RTCGeometry g = triangle_geometry(e->device, &objects[k].view);
        if (!g) {
            st = SC_ERR_OUT_OF_MEMORY;
            break;
        }
        rtcSetGeometryBuildQuality(g, build_quality(cfg->quality));
        rtcCommitGeometry(g);
        rtcAttachGeometry(obj[k], g);
        rtcReleaseGeometry(g);
        rtcCommitScene(obj[k]);
    }
    if (st == SC_OK) {
        e->scene = rtcNewScene(e->device);
        rtcSetSceneBuildQuality(e->scene, build_quality(cfg->quality));
        rtcSetSceneFlags(e->scene, scene_flags(cfg->mode));
        for (size_t i = 0; i < num_instances; i++) {
            RTCGeometry g = rtcNewGeometry(e->device, RTC_GEOMETRY_TYPE_INSTANCE);
            rtcSetGeometryInstancedScene(g, obj[instances[i].object]);
            rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, instances[i].xfm);
            rtcCommitGeometry(g);
            rtcAttachGeometryByID(e->scene, g, (unsigned)i);
            rtcReleaseGeometry(g);
        }
        if (own && own->view.triangle_count) {
            RTCGeometry g = triangle_geometry(e->device, &own->view);
            if (!g) {
                st = SC_ERR_OUT_OF_MEMORY;
            } else {
                rtcSetGeometryBuildQuality(g, build_quality(cfg->quality));
                rtcCommitGeometry(g);
                rtcAttachGeometryByID(e->scene, g, (unsigned)num_instances);
                rtcReleaseGeometry(g);
            }
        }
        if (st == SC_OK)
            rtcCommitScene(e->scene);
    }
    /* the top scene holds its own references to the object scenes */
    for (size_t k = 0; k < num_objects; k++)
        if (obj[k])
            rtcReleaseScene(obj[k]);
    free(obj);
    if (st != SC_OK) {
        sc_embree_destroy(e);
        return st;
    }
    return finish_create(e, out);
}

void sc_embree_destroy(sc_embree *e)
{
    if (!e)
        return;
    if (e->scene)
        rtcReleaseScene(e->scene);
    if (e->device)
        rtcReleaseDevice(e->device);
    free(e->b8), free(e->b16), free(e->tri), free(e->prim), free(e->count), free(e->box);
    free(e);
}

sc_status sc_embree_get_info(const sc_embree *e, sc_embree_info *info)
{
    if (!e || !info)
        return SC_ERR_INVALID_ARGUMENT;
    *info = e->info;
    return SC_OK;
}

/* ---- queries ------------------------------------------------------------- */

static void ctx_init(ctx_ext *c, sc_embree_counters *ctr, int coherent)
{
    rtcInitIntersectContext(&c->rtc);
    if (coherent)
        c->rtc.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    c->ctr = ctr;
}

static void to_rtc(struct RTCRay *o, const sc_ray *r)
{
    o->org_x = r->org[0], o->org_y = r->org[1], o->org_z = r->org[2];
    o->dir_x = r->dir[0], o->dir_y = r->dir[1], o->dir_z = r->dir[2];
    o->tnear = r->tmin, o->tfar = r->tmax;
    o->time = 0, o->mask = 0xffffffffu, o->id = 0, o->flags = 0;
}

/* A miss as the Embree tracers report it (t = +inf, unlike our tracer's tmax). */
static void hit_miss(sc_hitrec *h)
{
    h->t = INFINITY, h->u = h->v = 0, h->prim = SC_HITREC_MISS;
    h->ng[0] = h->ng[1] = h->ng[2] = 0;
    h->geom = h->inst = SC_INVALID_ID;
}

/* Embree's ids as sc_embree.h reports them: an instanced scene's own mesh
 * is geometry n of the top scene, reported as geom 0. */
static inline void set_ids(const sc_embree *e, sc_hitrec *h, unsigned geom, unsigned inst)
{
    h->inst = inst;
    h->geom = e->instanced && inst == RTC_INVALID_GEOMETRY_ID ? geom - e->num_instances : geom;
}

sc_status sc_embree_intersect1(sc_embree *e, const sc_ray *rays, size_t n, sc_hitrec *hits,
                               sc_embree_counters *ctr)
{
    if (!e || (n && (!rays || !hits)))
        return SC_ERR_INVALID_ARGUMENT;
    ctx_ext c;
    ctx_init(&c, ctr, 0);
    for (size_t i = 0; i < n; i++) {
        struct RTCRayHit rh;
        to_rtc(&rh.ray, &rays[i]);
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(e->scene, &c.rtc, &rh);
        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
            hit_miss(&hits[i]);
        } else {
            hits[i].t = rh.ray.tfar, hits[i].u = rh.hit.u, hits[i].v = rh.hit.v;
            hits[i].prim = rh.hit.primID;
            hits[i].ng[0] = rh.hit.Ng_x, hits[i].ng[1] = rh.hit.Ng_y, hits[i].ng[2] = rh.hit.Ng_z;
            set_ids(e, &hits[i], rh.hit.geomID, rh.hit.instID[0]);
        }
    }
    if (ctr)
        ctr->rays += n;
    return SC_OK;
}

sc_status sc_embree_occluded1(sc_embree *e, const sc_ray *rays, size_t n, uint8_t *occluded,
                              sc_embree_counters *ctr)
{
    if (!e || (n && (!rays || !occluded)))
        return SC_ERR_INVALID_ARGUMENT;
    ctx_ext c;
    ctx_init(&c, ctr, 0);
    for (size_t i = 0; i < n; i++) {
        struct RTCRay r;
        to_rtc(&r, &rays[i]);
        rtcOccluded1(e->scene, &c.rtc, &r);
        occluded[i] = r.tfar == -INFINITY;
    }
    if (ctr)
        ctr->rays += n;
    return SC_OK;
}

#define PACKET_LOOP(W)                                                                   \
    for (size_t base = 0; base < n; base += W) {                                        \
        struct RTCRayHit##W rh __attribute__((aligned(64)));                            \
        int valid[W] __attribute__((aligned(64)));                                      \
        for (int i = 0; i < W; i++) {                                                    \
            size_t k = base + (size_t)i;                                                 \
            const sc_ray *r = &rays[k < n ? k : n - 1];                                  \
            valid[i] = k < n ? -1 : 0;                                                   \
            rh.ray.org_x[i] = r->org[0], rh.ray.org_y[i] = r->org[1], rh.ray.org_z[i] = r->org[2]; \
            rh.ray.dir_x[i] = r->dir[0], rh.ray.dir_y[i] = r->dir[1], rh.ray.dir_z[i] = r->dir[2]; \
            rh.ray.tnear[i] = r->tmin, rh.ray.tfar[i] = r->tmax;                         \
            rh.ray.time[i] = 0, rh.ray.mask[i] = 0xffffffffu;                            \
            rh.ray.id[i] = 0, rh.ray.flags[i] = 0;                                       \
            rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;                                  \
            rh.hit.primID[i] = RTC_INVALID_GEOMETRY_ID;                                  \
            rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;                               \
        }                                                                                \
        rtcIntersect##W(valid, e->scene, &c.rtc, &rh);                                   \
        for (int i = 0; i < W && base + (size_t)i < n; i++) {                            \
            sc_hitrec *h = &hits[base + (size_t)i];                                      \
            if (rh.hit.geomID[i] == RTC_INVALID_GEOMETRY_ID) {                           \
                hit_miss(h);                                                             \
            } else {                                                                     \
                h->t = rh.ray.tfar[i], h->u = rh.hit.u[i], h->v = rh.hit.v[i];           \
                h->prim = rh.hit.primID[i];                                              \
                h->ng[0] = rh.hit.Ng_x[i], h->ng[1] = rh.hit.Ng_y[i];                    \
                h->ng[2] = rh.hit.Ng_z[i];                                               \
                set_ids(e, h, rh.hit.geomID[i], rh.hit.instID[0][i]);                   \
            }                                                                            \
        }                                                                                \
    }

sc_status sc_embree_intersect_packets(sc_embree *e, int width, const sc_ray *rays, size_t n,
                                      sc_hitrec *hits, int coherent, sc_embree_counters *ctr)
{
    if (!e || (width != 8 && width != 16) || (n && (!rays || !hits)))
        return SC_ERR_INVALID_ARGUMENT;
    ctx_ext c;
    ctx_init(&c, ctr, coherent);
    if (width == 8) {
        PACKET_LOOP(8)
    } else {
        PACKET_LOOP(16)
    }
    if (ctr)
        ctr->rays += n;
    return SC_OK;
}

#define OCCLUDED_LOOP(W)                                                                 \
    for (size_t base = 0; base < n; base += W) {                                        \
        struct RTCRay##W r __attribute__((aligned(64)));                                \
        int valid[W] __attribute__((aligned(64)));                                      \
        for (int i = 0; i < W; i++) {                                                    \
            size_t k = base + (size_t)i;                                                 \
            const sc_ray *s = &rays[k < n ? k : n - 1];                                  \
            valid[i] = k < n ? -1 : 0;                                                   \
            r.org_x[i] = s->org[0], r.org_y[i] = s->org[1], r.org_z[i] = s->org[2];      \
            r.dir_x[i] = s->dir[0], r.dir_y[i] = s->dir[1], r.dir_z[i] = s->dir[2];      \
            r.tnear[i] = s->tmin, r.tfar[i] = s->tmax;                                   \
            r.time[i] = 0, r.mask[i] = 0xffffffffu, r.id[i] = 0, r.flags[i] = 0;         \
        }                                                                                \
        rtcOccluded##W(valid, e->scene, &c.rtc, &r);                                     \
        for (int i = 0; i < W && base + (size_t)i < n; i++)                              \
            occluded[base + (size_t)i] = r.tfar[i] == -INFINITY;                         \
    }

sc_status sc_embree_occluded_packets(sc_embree *e, int width, const sc_ray *rays, size_t n, uint8_t *occluded,
                                     int coherent, sc_embree_counters *ctr)
{
    if (!e || (width != 8 && width != 16) || (n && (!rays || !occluded)))
        return SC_ERR_INVALID_ARGUMENT;
    ctx_ext c;
    ctx_init(&c, ctr, coherent);
    if (width == 8) {
        OCCLUDED_LOOP(8)
    } else {
        OCCLUDED_LOOP(16)
    }
    if (ctr)
        ctr->rays += n;
    return SC_OK;
}

/* rtcIntersect1M / rtcOccluded1M over chunks of AoS rays (Embree's stream
 * API), with the coherent or incoherent context flag. */
enum { STREAM_CHUNK = 256 };

sc_status sc_embree_intersect_stream(sc_embree *e, const sc_ray *rays, size_t n, sc_hitrec *hits, int coherent,
                                     sc_embree_counters *ctr)
{
    if (!e || (n && (!rays || !hits)))
        return SC_ERR_INVALID_ARGUMENT;
    ctx_ext c;
    ctx_init(&c, ctr, coherent);
    c.rtc.flags = coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    struct RTCRayHit *rh = aligned_alloc(64, STREAM_CHUNK * sizeof *rh);
    if (!rh)
        return SC_ERR_OUT_OF_MEMORY;
    for (size_t base = 0; base < n; base += STREAM_CHUNK) {
        const unsigned m = n - base < STREAM_CHUNK ? (unsigned)(n - base) : STREAM_CHUNK;
        for (unsigned i = 0; i < m; i++) {
            to_rtc(&rh[i].ray, &rays[base + i]);
            rh[i].hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh[i].hit.primID = RTC_INVALID_GEOMETRY_ID;
            rh[i].hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        }
        rtcIntersect1M(e->scene, &c.rtc, rh, m, sizeof *rh);
        for (unsigned i = 0; i < m; i++) {
            sc_hitrec *h = &hits[base + i];
            if (rh[i].hit.geomID == RTC_INVALID_GEOMETRY_ID) {
                hit_miss(h);
            } else {
                h->t = rh[i].ray.tfar, h->u = rh[i].hit.u, h->v = rh[i].hit.v, h->prim = rh[i].hit.primID;
                h->ng[0] = rh[i].hit.Ng_x, h->ng[1] = rh[i].hit.Ng_y, h->ng[2] = rh[i].hit.Ng_z;
                set_ids(e, h, rh[i].hit.geomID, rh[i].hit.instID[0]);
            }
        }
    }
    free(rh);
    if (ctr)
        ctr->rays += n;
    return SC_OK;
}

sc_status sc_embree_occluded_stream(sc_embree *e, const sc_ray *rays, size_t n, uint8_t *occluded, int coherent,
                                    sc_embree_counters *ctr)
{
    if (!e || (n && (!rays || !occluded)))
        return SC_ERR_INVALID_ARGUMENT;
    ctx_ext c;
    ctx_init(&c, ctr, coherent);
    c.rtc.flags = coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    struct RTCRay *r = aligned_alloc(64, STREAM_CHUNK * sizeof *r);
    if (!r)
        return SC_ERR_OUT_OF_MEMORY;
    for (size_t base = 0; base < n; base += STREAM_CHUNK) {
        const unsigned m = n - base < STREAM_CHUNK ? (unsigned)(n - base) : STREAM_CHUNK;
        for (unsigned i = 0; i < m; i++)
            to_rtc(&r[i], &rays[base + i]);
        rtcOccluded1M(e->scene, &c.rtc, r, m, sizeof *r);
        for (unsigned i = 0; i < m; i++)
            occluded[base + i] = r[i].tfar == -INFINITY;
    }
    free(r);
    if (ctr)
        ctr->rays += n;
    return SC_OK;
}
