/* bench_trace — our BVH against Embree 3 on the same triangles and rays.
 *
 *   bench_trace [--size N] [--repeats R] [--leaf L,...] [--mode M,...] MESH...
 *
 * MESH is any file assimp reads (node transforms flattened), or
 * "sphere:LEVEL" / "soup:N" for procedural meshes. Per mesh: primary rays of
 * an N x N pinhole camera framing the model, and shadow rays from the primary
 * hits (Embree's) towards a point light. Before timing, our hits are checked
 * against Embree's (same primitive, or t within 1e-4 relative). Timings: 1
 * thread, the median of R repeats, Mrays/s and the ratio to Embree's
 * rtcIntersect1 / rtcOccluded1 measured in the same run. Memory: bytes per
 * triangle of our BVH + spheres, and Embree's BVH from its memory monitor
 * (geometry buffers are shared, so they are not counted on either side).
 */
#define _POSIX_C_SOURCE 200809L
#define SC_PI 3.14159265358979323846
#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <embree3/rtcore.h>
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "common/sc_rng.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_trace.h"

typedef struct mesh {
    float *pos;
    uint32_t *idx;
    size_t nv, nt;
} mesh;

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void mat_apply(const struct aiMatrix4x4 *m, const struct aiVector3D *v, float out[3])
{
    out[0] = m->a1 * v->x + m->a2 * v->y + m->a3 * v->z + m->a4;
    out[1] = m->b1 * v->x + m->b2 * v->y + m->b3 * v->z + m->b4;
    out[2] = m->c1 * v->x + m->c2 * v->y + m->c3 * v->z + m->c4;
}

static void mat_mul(const struct aiMatrix4x4 *a, const struct aiMatrix4x4 *b, struct aiMatrix4x4 *r)
{
    const float *A = &a->a1, *B = &b->a1;
    float *R = &r->a1;
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            float s = 0;
            for (int k = 0; k < 4; k++)
                s += A[4 * i + k] * B[4 * k + j];
            R[4 * i + j] = s;
        }
}

static void add_node(const struct aiScene *sc, const struct aiNode *node, const struct aiMatrix4x4 *parent, mesh *m)
{
    struct aiMatrix4x4 x;
    mat_mul(parent, &node->mTransformation, &x);
    for (unsigned i = 0; i < node->mNumMeshes; i++) {
        const struct aiMesh *am = sc->mMeshes[node->mMeshes[i]];
        size_t base = m->nv;
        m->pos = realloc(m->pos, (m->nv + am->mNumVertices) * 3 * sizeof(float));
        for (unsigned v = 0; v < am->mNumVertices; v++)
            mat_apply(&x, &am->mVertices[v], m->pos + 3 * (m->nv + v));
        m->nv += am->mNumVertices;
        m->idx = realloc(m->idx, (m->nt + am->mNumFaces) * 3 * sizeof(uint32_t));
        for (unsigned f = 0; f < am->mNumFaces; f++) {
            if (am->mFaces[f].mNumIndices != 3)
                continue;
            for (int k = 0; k < 3; k++)
                m->idx[3 * m->nt + k] = (uint32_t)(base + am->mFaces[f].mIndices[k]);
            m->nt++;
        }
    }
    for (unsigned c = 0; c < node->mNumChildren; c++)
        add_node(sc, node->mChildren[c], &x, m);
}

static int load_mesh(const char *spec, mesh *m)
{
    memset(m, 0, sizeof *m);
    if (strncmp(spec, "soup:", 5) == 0) {
        size_t n = (size_t)atol(spec + 5);
        sc_rng r;
        sc_rng_seed(&r, 1);
        m->pos = malloc(9 * n * sizeof(float));
        m->idx = malloc(3 * n * sizeof(uint32_t));
        for (size_t i = 0; i < n; i++) {
            double c[3], s = 0.02 * sc_rng_uniform(&r);
            for (int k = 0; k < 3; k++)
                c[k] = sc_rng_range(&r, -1, 1);
            for (int j = 0; j < 3; j++) {
                for (int k = 0; k < 3; k++)
                    m->pos[9 * i + 3 * j + k] = (float)(c[k] + s * sc_rng_range(&r, -1, 1));
                m->idx[3 * i + j] = (uint32_t)(3 * i + j);
            }
        }
        m->nv = 3 * n, m->nt = n;
        return 0;
    }
    const struct aiScene *sc =
        aiImportFile(spec, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_SortByPType);
    if (!sc || !sc->mRootNode) {
        fprintf(stderr, "bench_trace: cannot load %s: %s\n", spec, aiGetErrorString());
        return -1;
    }
    struct aiMatrix4x4 id = { 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1 };
    add_node(sc, sc->mRootNode, &id, m);
    aiReleaseImport(sc);
    return m->nt ? 0 : -1;
}

/* ---- rays ------------------------------------------------------------------ */

static void make_primary(const mesh *m, int N, sc_ray *rays, float light[3], float *diag_out)
{
    float lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
    for (size_t i = 0; i < m->nv; i++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fminf(lo[k], m->pos[3 * i + k]);
            hi[k] = fmaxf(hi[k], m->pos[3 * i + k]);
        }
    double c[3], diag = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * ((double)lo[k] + hi[k]);
        diag += ((double)hi[k] - lo[k]) * ((double)hi[k] - lo[k]);
    }
    diag = sqrt(diag);
    *diag_out = (float)diag;
    /* Eye on the +z/+y diagonal, 45 degree field of view, framing the box. */
    double dist = 0.5 * diag / tan(0.5 * 45 * SC_PI / 180) * 1.1;
    double eye[3] = { c[0] + 0.3 * dist, c[1] + 0.4 * dist, c[2] + 0.866 * dist };
    double f[3], r[3], u[3], up[3] = { 0, 1, 0 };
    double fl = 0;
    for (int k = 0; k < 3; k++) {
        f[k] = c[k] - eye[k];
        fl += f[k] * f[k];
    }
    fl = sqrt(fl);
    for (int k = 0; k < 3; k++)
        f[k] /= fl;
    r[0] = f[1] * up[2] - f[2] * up[1], r[1] = f[2] * up[0] - f[0] * up[2], r[2] = f[0] * up[1] - f[1] * up[0];
    double rl = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    for (int k = 0; k < 3; k++)
        r[k] /= rl;
    u[0] = r[1] * f[2] - r[2] * f[1], u[1] = r[2] * f[0] - r[0] * f[2], u[2] = r[0] * f[1] - r[1] * f[0];
    double h = tan(0.5 * 45 * SC_PI / 180);
    /* 4x4 pixel tiles, as a tile renderer would issue them. */
    size_t k = 0;
    for (int ty = 0; ty < N; ty += 4)
        for (int tx = 0; tx < N; tx += 4)
            for (int y = ty; y < ty + 4 && y < N; y++)
                for (int x = tx; x < tx + 4 && x < N; x++) {
                    double px = (2 * (x + 0.5) / N - 1) * h, py = (1 - 2 * (y + 0.5) / N) * h;
                    sc_ray *ray = &rays[k++];
                    for (int a = 0; a < 3; a++) {
                        ray->org[a] = (float)eye[a];
                        ray->dir[a] = (float)(f[a] + px * r[a] + py * u[a]);
                    }
                    ray->tmin = 0;
                    ray->tmax = INFINITY;
                }
    for (int a = 0; a < 3; a++)
        light[a] = (float)(c[a] + diag * (a == 1 ? 1.0 : a == 0 ? -0.5 : 0.3));
}

/* ---- Embree ------------------------------------------------------------------ */

static _Atomic long long embree_bytes;
static bool mem_monitor(void *ptr, ssize_t bytes, bool post)
{
    (void)ptr, (void)post;
    atomic_fetch_add(&embree_bytes, (long long)bytes);
    return true;
}

static RTCScene embree_scene(RTCDevice dev, const mesh *m, int robust, double *build_s, long long *bytes)
{
    long long before = atomic_load(&embree_bytes);
    double t0 = now();
    RTCScene s = rtcNewScene(dev);
    if (robust)
        rtcSetSceneFlags(s, RTC_SCENE_FLAG_ROBUST);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, m->pos, 0, 3 * sizeof(float), m->nv);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, m->idx, 0, 3 * sizeof(uint32_t), m->nt);
    rtcCommitGeometry(g);
    rtcAttachGeometry(s, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(s);
    *build_s = now() - t0;
    *bytes = atomic_load(&embree_bytes) - before;
    return s;
}

static void embree_closest(RTCScene s, const sc_ray *rays, size_t n, sc_hitrec *out)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (size_t i = 0; i < n; i++) {
        struct RTCRayHit rh __attribute__((aligned(16)));
        const sc_ray *r = &rays[i];
        rh.ray.org_x = r->org[0], rh.ray.org_y = r->org[1], rh.ray.org_z = r->org[2];
        rh.ray.dir_x = r->dir[0], rh.ray.dir_y = r->dir[1], rh.ray.dir_z = r->dir[2];
        rh.ray.tnear = r->tmin, rh.ray.tfar = r->tmax;
        rh.ray.mask = UINT32_MAX, rh.ray.flags = 0, rh.ray.time = 0;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(s, &ctx, &rh);
        if (out) {
            out[i].prim = rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? SC_HITREC_MISS : rh.hit.primID;
            out[i].t = rh.ray.tfar, out[i].u = rh.hit.u, out[i].v = rh.hit.v;
        }
    }
}

static size_t embree_occluded(RTCScene s, const sc_ray *rays, size_t n)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    size_t blocked = 0;
    for (size_t i = 0; i < n; i++) {
        struct RTCRay ry __attribute__((aligned(16)));
        const sc_ray *r = &rays[i];
        ry.org_x = r->org[0], ry.org_y = r->org[1], ry.org_z = r->org[2];
        ry.dir_x = r->dir[0], ry.dir_y = r->dir[1], ry.dir_z = r->dir[2];
        ry.tnear = r->tmin, ry.tfar = r->tmax;
        ry.mask = UINT32_MAX, ry.flags = 0, ry.time = 0;
        rtcOccluded1(s, &ctx, &ry);
        blocked += ry.tfar < 0;
    }
    return blocked;
}

static void ours_closest(const sc_bvh *b, const sc_ray *rays, size_t n, sc_hitrec *out, sc_trace_stats *st)
{
    sc_hitrec h;
    for (size_t i = 0; i < n; i++)
        sc_trace_closest(b, &rays[i], out ? &out[i] : &h, st);
}

static size_t ours_any(const sc_bvh *b, const sc_ray *rays, size_t n, sc_trace_stats *st)
{
    size_t blocked = 0;
    for (size_t i = 0; i < n; i++) {
        int occ = 0;
        sc_trace_any(b, &rays[i], &occ, st);
        blocked += (size_t)occ;
    }
    return blocked;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

#define MAX_REP 64
#define TIME_MEDIAN(reps, stmt, out)                                  \
    do {                                                              \
        double ts_[MAX_REP];                                          \
        for (int r_ = 0; r_ < (reps); r_++) {                         \
            double t0_ = now();                                       \
            stmt;                                                     \
            ts_[r_] = now() - t0_;                                    \
        }                                                             \
        qsort(ts_, (size_t)(reps), sizeof(double), cmp_double);       \
        (out) = ts_[(reps) / 2];                                      \
    } while (0)

static int parse_list(const char *s, int *out, int max, int is_mode)
{
    int n = 0;
    char buf[256];
    snprintf(buf, sizeof buf, "%s", s);
    for (char *tok = strtok(buf, ","); tok && n < max; tok = strtok(NULL, ",")) {
        if (is_mode) {
            sc_prefilter_mode m;
            if (sc_prefilter_mode_from_name(tok, &m) != SC_OK)
                return -1;
            out[n++] = (int)m;
        } else {
            int v = atoi(tok);
            if (v < 1 || v > SC_BVH_MAX_LEAF)
                return -1;
            out[n++] = v;
        }
    }
    return n;
}

int main(int argc, char **argv)
{
    int N = 512, reps = 5;
    int leaves[16] = { 4, 8, 16 }, nleaves = 3;
    int modes[8] = { 0, 1, 2, 3 }, nmodes = 4;
    sc_trace_isa isa = SC_TRACE_ISA_AUTO;
    float trav_cost = -1;
    int first = 1;
    for (; first < argc && argv[first][0] == '-'; first++) {
        const char *a = argv[first];
        const char *v = first + 1 < argc ? argv[first + 1] : NULL;
        if (!v) {
            fprintf(stderr, "bench_trace: %s needs a value\n", a);
            return 2;
        }
        if (strcmp(a, "--size") == 0)
            N = atoi(v);
        else if (strcmp(a, "--trav-cost") == 0)
            trav_cost = (float)atof(v);
        else if (strcmp(a, "--repeats") == 0)
            reps = atoi(v);
        else if (strcmp(a, "--leaf") == 0)
            nleaves = parse_list(v, leaves, 16, 0);
        else if (strcmp(a, "--mode") == 0)
            nmodes = parse_list(v, modes, 8, 1);
        else if (strcmp(a, "--isa") == 0) {
            if (sc_trace_isa_from_name(v, &isa) != SC_OK) {
                fprintf(stderr, "bench_trace: unknown ISA '%s'\n", v);
                return 2;
            }
        } else {
            fprintf(stderr, "bench_trace: unknown option '%s'\n", a);
            return 2;
        }
        first++;
    }
    if (N < 4 || N > 8192 || reps < 1 || reps > MAX_REP || nleaves < 1 || nmodes < 1 || first >= argc) {
        fprintf(stderr, "usage: bench_trace [--size N] [--repeats R] [--leaf 1,4,..] [--mode off,circum,minimal,auto]"
                        " [--isa scalar|avx2|avx512] [--trav-cost C] MESH...\n");
        return 2;
    }
    RTCDevice dev = rtcNewDevice("threads=1,set_affinity=0");
    if (!dev) {
        fprintf(stderr, "bench_trace: Embree device failed\n");
        return 1;
    }
    rtcSetDeviceMemoryMonitorFunction(dev, mem_monitor, NULL);
    printf("# compiler %s, embree %s, 1 thread, %dx%d primary rays, median of %d\n", __VERSION__,
           RTC_VERSION_STRING, N, N, reps);

    for (int mi = first; mi < argc; mi++) {
        mesh m;
        if (load_mesh(argv[mi], &m) != 0) {
            fprintf(stderr, "bench_trace: %s: no triangles\n", argv[mi]);
            return 1;
        }
        size_t np = (size_t)N * (size_t)N;
        sc_ray *prim = aligned_alloc(64, np * sizeof(sc_ray));
        sc_ray *shad = aligned_alloc(64, np * sizeof(sc_ray));
        sc_hitrec *eh = malloc(np * sizeof *eh), *oh = malloc(np * sizeof *oh);
        float light[3], diag;
        make_primary(&m, N, prim, light, &diag);

        double eb_s, ebr_s;
        long long e_bytes, er_bytes;
        RTCScene es = embree_scene(dev, &m, 0, &eb_s, &e_bytes);
        RTCScene esr = embree_scene(dev, &m, 1, &ebr_s, &er_bytes);
        embree_closest(es, prim, np, eh);
        /* Shadow rays from Embree's primary hits, offset towards the eye. */
        size_t ns = 0, nhit = 0;
        for (size_t i = 0; i < np; i++) {
            if (eh[i].prim == SC_HITREC_MISS)
                continue;
            nhit++;
            sc_ray *s = &shad[ns++];
            float dl = sqrtf(prim[i].dir[0] * prim[i].dir[0] + prim[i].dir[1] * prim[i].dir[1] +
                             prim[i].dir[2] * prim[i].dir[2]);
            for (int a = 0; a < 3; a++) {
                float p = prim[i].org[a] + eh[i].t * prim[i].dir[a] - 1e-4f * diag * prim[i].dir[a] / dl;
                s->org[a] = p;
                s->dir[a] = light[a] - p;
            }
            s->tmin = 0;
            s->tmax = 1;
        }
        double e_prim, e_shadow, er_prim, er_shadow;
        size_t e_blocked = embree_occluded(es, shad, ns);
        TIME_MEDIAN(reps, embree_closest(es, prim, np, NULL), e_prim);
        TIME_MEDIAN(reps, embree_occluded(es, shad, ns), e_shadow);
        TIME_MEDIAN(reps, embree_closest(esr, prim, np, NULL), er_prim);
        TIME_MEDIAN(reps, embree_occluded(esr, shad, ns), er_shadow);
        double E_p = (double)np / e_prim * 1e-6, E_s = (double)ns / e_shadow * 1e-6;
        printf("\n## %s: %zu triangles, %zu primary rays (%zu hit), %zu shadow rays (%zu blocked)\n", argv[mi], m.nt,
               np, nhit, ns, e_blocked);
        printf("embree          build %7.1f ms  %6.1f B/tri  primary %7.2f Mrays/s  shadow %7.2f Mrays/s\n",
               eb_s * 1e3, (double)e_bytes / (double)m.nt, E_p, E_s);
        printf("embree robust   build %7.1f ms  %6.1f B/tri  primary %7.2f Mrays/s  shadow %7.2f Mrays/s\n",
               ebr_s * 1e3, (double)er_bytes / (double)m.nt, (double)np / er_prim * 1e-6,
               (double)ns / er_shadow * 1e-6);
        printf("%-6s %-8s %8s %7s %8s %8s %6s %6s  %6s %6s %6s %6s %6s | %8s %6s %6s %6s %6s\n", "leaf", "mode",
               "build ms", "B/tri", "prim Mr/s", "x embree", "x rob", "diff", "nodes", "leaves", "sph", "rej%", "tris",
               "shad Mr/s", "x emb", "x rob", "nodes", "tris");
        for (int li = 0; li < nleaves; li++)
            for (int mo = 0; mo < nmodes; mo++) {
                sc_bvh_config cfg;
                sc_bvh_config_default(&cfg);
                cfg.leaf_size = leaves[li];
                cfg.prefilter = (sc_prefilter_mode)modes[mo];
                cfg.isa = isa;
                if (trav_cost >= 0)
                    cfg.traversal_cost = trav_cost;
                sc_bvh *b;
                sc_status st = sc_bvh_build(m.pos, m.nv, m.idx, m.nt, &cfg, &b);
                if (st != SC_OK) {
                    fprintf(stderr, "bench_trace: build failed: %s\n", sc_strerror(st));
                    return 1;
                }
                sc_bvh_info info;
                sc_bvh_get_info(b, &info);
                /* Check before timing: same primitive, or the same t (ties at edges). */
                ours_closest(b, prim, np, oh, NULL);
                size_t diff = 0;
                for (size_t i = 0; i < np; i++)
                    if (oh[i].prim != eh[i].prim &&
                        !(oh[i].prim != SC_HITREC_MISS && eh[i].prim != SC_HITREC_MISS &&
                          fabsf(oh[i].t - eh[i].t) <= 1e-4f * eh[i].t))
                        diff++;
                size_t blocked = ours_any(b, shad, ns, NULL);
                sc_trace_stats sp = { 0 }, ss = { 0 };
                ours_closest(b, prim, np, NULL, &sp);
                ours_any(b, shad, ns, &ss);
                /* Interleaved with Embree, repeat by repeat, so that load from
                 * other processes hits both sides alike; ratios are medians of
                 * the per-repeat ratios. */
                double tp[MAX_REP], ts[MAX_REP], rp[MAX_REP], rs[MAX_REP], rrp[MAX_REP], rrs[MAX_REP];
                for (int r = 0; r < reps; r++) {
                    double t0 = now();
                    embree_closest(es, prim, np, NULL);
                    double t1 = now();
                    ours_closest(b, prim, np, NULL, NULL);
                    double t2 = now();
                    embree_closest(esr, prim, np, NULL);
                    double t3 = now();
                    embree_occluded(es, shad, ns);
                    double t4 = now();
                    ours_any(b, shad, ns, NULL);
                    double t5 = now();
                    embree_occluded(esr, shad, ns);
                    double t6 = now();
                    tp[r] = t2 - t1, ts[r] = t5 - t4;
                    rp[r] = (t1 - t0) / (t2 - t1), rrp[r] = (t3 - t2) / (t2 - t1);
                    rs[r] = (t4 - t3) / (t5 - t4), rrs[r] = (t6 - t5) / (t5 - t4);
                }
                qsort(tp, (size_t)reps, sizeof(double), cmp_double);
                qsort(ts, (size_t)reps, sizeof(double), cmp_double);
                qsort(rp, (size_t)reps, sizeof(double), cmp_double);
                qsort(rs, (size_t)reps, sizeof(double), cmp_double);
                qsort(rrp, (size_t)reps, sizeof(double), cmp_double);
                qsort(rrs, (size_t)reps, sizeof(double), cmp_double);
                double O_p = (double)np / tp[reps / 2] * 1e-6, O_s = (double)ns / ts[reps / 2] * 1e-6;
                double rays_p = (double)sp.rays, rays_s = (double)(ss.rays ? ss.rays : 1);
                printf("%-6d %-8s %8.1f %7.1f %8.2f %8.3f %6.3f %6zu  %6.2f %6.2f %6.2f %6.1f %6.2f | %8.2f %6.3f %6.3f %6.2f %6.2f%s\n",
                       leaves[li], sc_prefilter_mode_name(cfg.prefilter), info.build_seconds * 1e3,
                       (double)info.total_bytes / (double)m.nt, O_p, rp[reps / 2], rrp[reps / 2],
                       diff, sp.nodes / rays_p, sp.leaves / rays_p, sp.sphere_tests / rays_p,
                       sp.sphere_tests ? 100.0 * (double)sp.sphere_rejects / (double)sp.sphere_tests : 0.0,
                       sp.tri_tests / rays_p, O_s, rs[reps / 2], rrs[reps / 2], ss.nodes / rays_s,
                       ss.tri_tests / rays_s, blocked == e_blocked ? "" : "  (shadow blocked count differs)");
                fflush(stdout);
                sc_bvh_free(b);
            }
        printf("# x embree / x rob: our Mrays/s over Embree's default / robust scene; diff: primary hits\n"
               "# that differ from Embree's (other primitive at another t); nodes..tris: per ray\n");
        rtcReleaseScene(es);
        rtcReleaseScene(esr);
        free(prim), free(shad), free(eh), free(oh), free(m.pos), free(m.idx);
    }
    rtcReleaseDevice(dev);
    return 0;
}
