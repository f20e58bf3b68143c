/* spherecull bench — our BVH against Embree on the same rays, in the same run.
 *
 *   spherecull bench SCENE... [--csv FILE] [--rays primary,shadow] [--threads 1,2]
 *                    [--leaf 4,8,16] [--prefilter off,circum,minimal,auto]
 *                    [--size WxH] [--repeats R] [--isa ISA] [--embree default|robust]
 *
 * Per scene: the primary rays of the scene's camera (4x4 pixel tiles) and
 * shadow rays from their hits towards the scene's first light. Before any
 * timing, every configuration's hits are checked against Embree (all rays)
 * and against brute force over all triangles (a sample of rays); a brute
 * force disagreement is an error. Timings are paired: each repeat times
 * Embree and us back to back on the same rays (alternating who goes first),
 * and the ratio reported is the median of the per-repeat ratios, so load from
 * other processes hits both sides alike. With 1 thread the user-mode cycle
 * counts of both sides are read as well (perf_event_open, when the kernel
 * allows it): the cycle ratio does not move when the machine is shared.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <linux/perf_event.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/syscall.h>
#include <unistd.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "common/sc_clock.h"
#include "commands.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_rays.h"
#include "spherecull/sc_scene.h"
#include "spherecull/sc_trace.h"
#ifdef SC_HAVE_EMBREE
#include <embree3/rtcore_config.h>
#include "spherecull/sc_embree.h"
#endif

#define CMD "bench"
#define MAX_LIST 16
#define MAX_REPEATS 64
#define BRUTE_SAMPLE 64

static void usage(FILE *f)
{
    fprintf(f,
            "usage: spherecull bench SCENE... [options]\n"
            "  Mrays/s of closest-hit (primary) and any-hit (shadow) rays per scene x prefilter\n"
            "  mode x leaf size x thread count, with per-ray work counters, bytes per\n"
            "  triangle, and Embree's rtcIntersect1/rtcOccluded1 on the same rays as the ratio.\n"
            "  SCENE: a mesh file assimp reads, a scenes/*.json file, or proc:KIND:N.\n"
            "options:\n"
            "  --csv FILE            also write one row per measurement\n"
            "  --rays LIST           primary,shadow (default both)\n"
            "  --threads LIST        OpenMP threads, e.g. 1,2 (default 1,2)\n"
            "  --leaf LIST           leaf sizes 1..16 (default 4,8,16)\n"
            "  --prefilter LIST      off,circum,minimal,auto (default all)\n"
            "  --size WxH            image size of the primary rays (default 512x384)\n"
            "  --repeats R           paired repeats per measurement, median (default 5)\n"
            "  --isa ISA             auto|scalar|avx2|avx512 (default auto)\n"
            "  --embree MODE         default|robust: Embree scene flags (default default)\n"
            "  --triangle TEST       watertight|moller|exact: our triangle test (default watertight)\n"
            "  --trav-cost C         SAH cost of a node visit relative to a leaf block test\n"
            "                        (default: the builder's, sc_bvh_config_default)\n");
}

/* ---- small helpers -------------------------------------------------------- */

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* User-mode cycles of the calling thread; -1 when perf events are not allowed. */
static int cycles_open(void)
{
    struct perf_event_attr a;
    memset(&a, 0, sizeof a);
    a.size = sizeof a;
    a.type = PERF_TYPE_HARDWARE;
    a.config = PERF_COUNT_HW_CPU_CYCLES;
    a.exclude_kernel = 1;
    a.exclude_hv = 1;
    return (int)syscall(SYS_perf_event_open, &a, 0, -1, -1, 0);
}

static uint64_t cycles_read(int fd)
{
    uint64_t v = 0;
    if (fd < 0 || read(fd, &v, sizeof v) != (ssize_t)sizeof v)
        return 0;
    return v;
}

static void cpu_name(char *buf, size_t len)
{
    snprintf(buf, len, "unknown");
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (!f)
        return;
    char line[512];
    while (fgets(line, sizeof line, f)) {
        if (strncmp(line, "model name", 10) == 0) {
            char *c = strchr(line, ':');
            if (c) {
                c++;
                while (*c == ' ' || *c == '\t')
                    c++;
                c[strcspn(c, "\n")] = 0;
                snprintf(buf, len, "%s", c);
            }
            break;
        }
    }
    fclose(f);
}

static int parse_int_list(const char *s, int *out, int lo, int hi)
{
    int n = 0;
    const char *p = s;
    while (*p) {
        char *end;
        long v = strtol(p, &end, 10);
        if (end == p || v < lo || v > hi || n >= MAX_LIST || (*end && *end != ','))
            return -1;
        out[n++] = (int)v;
        p = *end ? end + 1 : end;
    }
    return n;
}

static int parse_mode_list(const char *s, int *out)
{
    char buf[256];
    if (strlen(s) >= sizeof buf)
        return -1;
    snprintf(buf, sizeof buf, "%s", s);
    int n = 0;
    char *save = NULL;
    for (char *tok = strtok_r(buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
        sc_prefilter_mode m;
        if (n >= MAX_LIST || sc_prefilter_mode_from_name(tok, &m) != SC_OK)
            return -1;
        out[n++] = (int)m;
    }
    return n;
}

/* ---- the two tracers over a ray range ------------------------------------- */

enum { KIND_PRIMARY = 0, KIND_SHADOW = 1 };
static const char *const kind_names[2] = { "primary", "shadow" };

typedef struct bench_out {
    sc_hitrec *hits;     /* primary */
    uint8_t *occ;        /* shadow */
} bench_out;

static void ours_range(const sc_bvh *b, int kind, const sc_ray *rays, size_t lo, size_t hi, bench_out *o,
                       sc_trace_stats *st)
{
    if (kind == KIND_PRIMARY) {
        for (size_t i = lo; i < hi; i++)
            sc_trace_closest(b, &rays[i], &o->hits[i], st);
    } else {
        for (size_t i = lo; i < hi; i++) {
            int occ = 0;
            sc_trace_any(b, &rays[i], &occ, st);
            o->occ[i] = (uint8_t)occ;
        }
    }
}

#define CHUNK 1024

static void ours_run(const sc_bvh *b, int kind, const sc_ray *rays, size_t n, bench_out *o, int threads)
{
    if (threads <= 1) {
        ours_range(b, kind, rays, 0, n, o, NULL);
        return;
    }
#ifdef _OPENMP
    long chunks = (long)((n + CHUNK - 1) / CHUNK);
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (long c = 0; c < chunks; c++) {
        size_t lo = (size_t)c * CHUNK, hi = lo + CHUNK < n ? lo + CHUNK : n;
        ours_range(b, kind, rays, lo, hi, o, NULL);
    }
#else
    ours_range(b, kind, rays, 0, n, o, NULL);
#endif
}

#ifdef SC_HAVE_EMBREE
static void embree_range(sc_embree *e, int kind, const sc_ray *rays, size_t lo, size_t hi, bench_out *o)
{
    if (kind == KIND_PRIMARY)
        sc_embree_intersect1(e, rays + lo, hi - lo, o->hits + lo, NULL);
    else
        sc_embree_occluded1(e, rays + lo, hi - lo, o->occ + lo, NULL);
}

static void embree_run(sc_embree *e, int kind, const sc_ray *rays, size_t n, bench_out *o, int threads)
{
    if (threads <= 1) {
        embree_range(e, kind, rays, 0, n, o);
        return;
    }
#ifdef _OPENMP
    long chunks = (long)((n + CHUNK - 1) / CHUNK);
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (long c = 0; c < chunks; c++) {
        size_t lo = (size_t)c * CHUNK, hi = lo + CHUNK < n ? lo + CHUNK : n;
        embree_range(e, kind, rays, lo, hi, o);
    }
#else
    embree_range(e, kind, rays, 0, n, o);
#endif
}
#endif

/* ---- checks ------------------------------------------------------------------ */

/* Same primitive, or (an edge or a tie) the same distance. */
static int same_hit(const sc_hitrec *a, const sc_hitrec *b, float rel)
{
    if (a->prim == b->prim)
        return a->prim == SC_HITREC_MISS || fabsf(a->t - b->t) <= rel * fabsf(b->t);
    if (a->prim == SC_HITREC_MISS || b->prim == SC_HITREC_MISS)
        return 0;
    return fabsf(a->t - b->t) <= rel * fabsf(b->t);
}

/* ---- CSV ----------------------------------------------------------------------- */

typedef struct csvbuf {
    char *s;
    size_t len, cap;
} csvbuf;

static __attribute__((format(printf, 2, 3))) void csv_add(csvbuf *c, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    char line[1024];
    int n = vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    if (n < 0)
        return;
    size_t need = c->len + (size_t)n + 1;
    if (need > c->cap) {
        size_t cap = c->cap ? c->cap : 4096;
        while (cap < need)
            cap *= 2;
        char *s = realloc(c->s, cap);
        if (!s)
            return;
        c->s = s, c->cap = cap;
    }
    memcpy(c->s + c->len, line, (size_t)n + 1);
    c->len += (size_t)n;
}

static int csv_write(void *ctx, FILE *f)
{
    const csvbuf *c = ctx;
    return c->len && fwrite(c->s, 1, c->len, f) != c->len ? -1 : 0;
}

/* ---- one scene ------------------------------------------------------------------ */

typedef struct bench_opts {
    int kinds[2], nkinds;
    int threads[MAX_LIST], nthreads;
    int leaves[MAX_LIST], nleaves;
    int modes[MAX_LIST], nmodes;
    int width, height, repeats;
    sc_trace_isa isa;
    int embree_robust;
    float trav_cost;     /* < 0: the builder's default */
    sc_tri_test tri;
    int cycles_fd;
} bench_opts;

static void light_point(const sc_scene_view *v, const float lo[3], const float hi[3], float out[3])
{
    double c[3], diag = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * ((double)lo[k] + hi[k]);
        diag += ((double)hi[k] - lo[k]) * ((double)hi[k] - lo[k]);
    }
    diag = sqrt(diag);
    if (v->num_lights && v->lights[0].type == SC_LIGHT_POINT) {
        memcpy(out, v->lights[0].vec, 3 * sizeof(float));
        return;
    }
    double d[3] = { 0.5, -1.0, -0.3 }, len = 0;
    if (v->num_lights)
        for (int k = 0; k < 3; k++)
            d[k] = v->lights[0].vec[k];
    for (int k = 0; k < 3; k++)
        len += d[k] * d[k];
    len = sqrt(len);
    /* A directional light becomes a point two diagonals away against its direction. */
    for (int k = 0; k < 3; k++)
        out[k] = (float)(c[k] - 2 * diag * d[k] / len);
}

static int bench_scene(const char *spec, const bench_opts *o, csvbuf *csv)
{
    sc_scene_options so;
    sc_scene_options_init(&so);
    sc_scene *scene = NULL;
    char err[512];
    sc_status st = sc_scene_load(spec, &so, &scene, err, sizeof err);
    if (st != SC_OK) {
        sc_cli_error(CMD, "%s", err);
        return 1;
    }
    sc_scene_view v;
    sc_scene_get_view(scene, &v);
    if (v.num_triangles == 0 || v.num_triangles > UINT32_MAX || v.num_vertices > UINT32_MAX) {
        sc_cli_error(CMD, "%s: no triangles to trace", spec);
        sc_scene_free(scene);
        return 1;
    }
    sc_mesh_view mesh = { v.positions, (uint32_t)v.num_vertices, v.indices, (uint32_t)v.num_triangles };
    const size_t ntri = v.num_triangles;
    float lo[3], hi[3];
    sc_mesh_bounds(&mesh, lo, hi);
    sc_camera cam = v.camera;
    cam.width = o->width, cam.height = o->height;
    float light[3];
    light_point(&v, lo, hi, light);

    int rc = 1;
    sc_rayset prim = { 0 }, shad = { 0 };
    sc_bvh *ref = NULL;
    sc_hitrec *ref_hits = NULL, *emb_hits = NULL;
    uint8_t *ref_occ = NULL, *emb_occ = NULL;
    bench_out out = { 0 };
#ifdef SC_HAVE_EMBREE
    sc_embree *emb = NULL;
#endif
    double emb_bpt = NAN, emb_bvh_bpt = NAN;

    if ((st = sc_rayset_primary(&cam, &prim)) != SC_OK) {
        sc_cli_error(CMD, "%s: primary rays: %s", spec, sc_strerror(st));
        goto done;
    }
    /* Shadow rays come from our own hits (the default configuration), so the
     * ray set does not depend on whether Embree is built in. */
    sc_bvh_config rc_cfg;
    sc_bvh_config_default(&rc_cfg);
    rc_cfg.isa = o->isa;
    if ((st = sc_bvh_build(v.positions, v.num_vertices, v.indices, ntri, &rc_cfg, &ref)) != SC_OK) {
        sc_cli_error(CMD, "%s: BVH build: %s", spec, sc_strerror(st));
        goto done;
    }
    ref_hits = malloc(prim.count * sizeof *ref_hits);
    out.hits = malloc(prim.count * sizeof *out.hits);
    out.occ = malloc(prim.count + 1);
    ref_occ = malloc(prim.count + 1);
    emb_hits = malloc(prim.count * sizeof *emb_hits);
    emb_occ = malloc(prim.count + 1);
    if (!ref_hits || !out.hits || !out.occ || !ref_occ || !emb_hits || !emb_occ) {
        sc_cli_error(CMD, "%s: out of memory", spec);
        goto done;
    }
    ours_range(ref, KIND_PRIMARY, prim.rays, 0, prim.count, &(bench_out){ ref_hits, NULL }, NULL);
    if ((st = sc_rayset_shadow(&mesh, &prim, ref_hits, light, &shad)) != SC_OK) {
        sc_cli_error(CMD, "%s: shadow rays: %s", spec, sc_strerror(st));
        goto done;
    }
    ours_range(ref, KIND_SHADOW, shad.rays, 0, shad.count, &(bench_out){ NULL, ref_occ }, NULL);
    size_t nhit = 0, nblocked = 0;
    for (size_t i = 0; i < prim.count; i++)
        nhit += ref_hits[i].prim != SC_HITREC_MISS;
    for (size_t i = 0; i < shad.count; i++)
        nblocked += ref_occ[i];

#ifdef SC_HAVE_EMBREE
    {
        sc_embree_config ec;
        sc_embree_config_default(&ec);
        ec.mode = o->embree_robust ? SC_EMBREE_ROBUST : SC_EMBREE_DEFAULT;
        if ((st = sc_embree_create(&mesh, &ec, &emb)) != SC_OK) {
            sc_cli_error(CMD, "%s: Embree: %s", spec, sc_strerror(st));
            goto done;
        }
        sc_embree_info ei;
        sc_embree_get_info(emb, &ei);
        /* Embree holds its own copy of the vertex and index buffers (12 B
         * per vertex and per triangle); our leaves need no mesh at all, so
         * the comparable figure is Embree's BVH alone. Both are printed. */
        emb_bpt = (double)ei.embree_bytes / (double)ntri;
        emb_bvh_bpt = ((double)ei.embree_bytes - 12.0 * (double)v.num_vertices - 12.0 * (double)ntri) / (double)ntri;
        sc_embree_intersect1(emb, prim.rays, prim.count, emb_hits, NULL);
        sc_embree_occluded1(emb, shad.rays, shad.count, emb_occ, NULL);
    }
#endif
    printf("\n## %s: %zu triangles, bounds (%.4g %.4g %.4g)..(%.4g %.4g %.4g)\n", spec, ntri, lo[0], lo[1], lo[2],
           hi[0], hi[1], hi[2]);
    printf("#  eye (%.4g %.4g %.4g) target (%.4g %.4g %.4g) fov %.1f, light (%.4g %.4g %.4g)\n", cam.eye[0],
           cam.eye[1], cam.eye[2], cam.target[0], cam.target[1], cam.target[2], cam.fov_y_deg, light[0], light[1],
           light[2]);
    printf("#  %zu primary rays (%zu hit), %zu shadow rays (%zu blocked); embree BVH %.1f B/tri (+%.1f for\n"
           "#  its copy of the mesh)\n", prim.count, nhit, shad.count, nblocked, emb_bvh_bpt, emb_bpt - emb_bvh_bpt);
    printf("%-7s %3s %4s %-8s %6s %5s %8s %8s %6s %6s | %6s %6s %6s %6s %6s %5s %8s %6s\n", "rays", "thr", "leaf",
           "prefilt", "B/tri", "sph%", "Mrays/s", "embree", "ratio", "cyc-r", "nodes", "leaves", "sph", "rej%",
           "tris", "hits", "build-ms", "diff");
    fflush(stdout);

    for (int li = 0; li < o->nleaves; li++)
        for (int mi = 0; mi < o->nmodes; mi++) {
            sc_bvh_config cfg;
            sc_bvh_config_default(&cfg);
            cfg.leaf_size = o->leaves[li];
            cfg.prefilter = (sc_prefilter_mode)o->modes[mi];
            cfg.isa = o->isa;
            cfg.tri_test = o->tri;
            if (o->trav_cost >= 0)
                cfg.traversal_cost = o->trav_cost;
            sc_bvh *b = NULL;
            if ((st = sc_bvh_build(v.positions, v.num_vertices, v.indices, ntri, &cfg, &b)) != SC_OK) {
                sc_cli_error(CMD, "%s: BVH build: %s", spec, sc_strerror(st));
                goto done;
            }
            sc_bvh_info info;
            sc_bvh_get_info(b, &info);
            const double bpt = (double)info.total_bytes / (double)ntri;
            const double sph_pct = info.leaves ? 100.0 * (double)info.leaves_with_spheres / (double)info.leaves : 0;
            for (int ki = 0; ki < o->nkinds; ki++) {
                const int kind = o->kinds[ki];
                const sc_rayset *rs = kind == KIND_PRIMARY ? &prim : &shad;
                const size_t n = rs->count;
                /* Check first: brute force on a sample (same arithmetic, so
                 * only exact ties may differ), Embree on every ray. */
                sc_trace_stats stt = { 0 };
                ours_range(b, kind, rs->rays, 0, n, &out, &stt);
                size_t diff_brute = 0, diff_emb = 0;
                size_t step = n > BRUTE_SAMPLE ? n / BRUTE_SAMPLE : 1;
                for (size_t i = 0; i < n; i += step) {
                    sc_hitrec h;
                    sc_trace_closest_brute(b, &rs->rays[i], &h);
                    if (kind == KIND_PRIMARY ? !same_hit(&out.hits[i], &h, 0.0f)
                                             : out.occ[i] != (h.prim != SC_HITREC_MISS))
                        diff_brute++;
                }
#ifdef SC_HAVE_EMBREE
                for (size_t i = 0; i < n; i++)
                    diff_emb += kind == KIND_PRIMARY ? !same_hit(&out.hits[i], &emb_hits[i], 1e-4f)
                                                     : out.occ[i] != emb_occ[i];
#endif
                if (diff_brute) {
                    sc_cli_error(CMD, "%s: leaf %d %s: %zu of %zu sampled %s rays differ from brute force", spec,
                                 cfg.leaf_size, sc_prefilter_mode_name(cfg.prefilter), diff_brute,
                                 (n + step - 1) / step, kind_names[kind]);
                    sc_bvh_free(b);
                    goto done;
                }
                const double rays_d = stt.rays ? (double)stt.rays : 1;
                for (int ti = 0; ti < o->nthreads; ti++) {
                    const int thr = o->threads[ti];
                    double t_o[MAX_REPEATS], t_e[MAX_REPEATS], ratio[MAX_REPEATS], cratio[MAX_REPEATS];
                    int have_cyc = thr == 1 && o->cycles_fd >= 0;
                    ours_run(b, kind, rs->rays, n, &out, thr); /* warm-up */
#ifdef SC_HAVE_EMBREE
                    embree_run(emb, kind, rs->rays, n, &out, thr);
#endif
                    for (int r = 0; r < o->repeats; r++) {
                        double te = NAN, to;
                        uint64_t ce = 0, co, c0, c1;
#ifdef SC_HAVE_EMBREE
                        if (r % 2 == 0) {
                            c0 = cycles_read(o->cycles_fd);
                            double t0 = sc_now_seconds();
                            embree_run(emb, kind, rs->rays, n, &out, thr);
                            te = sc_now_seconds() - t0;
                            ce = cycles_read(o->cycles_fd) - c0;
                        }
#endif
                        c0 = cycles_read(o->cycles_fd);
                        double t0 = sc_now_seconds();
                        ours_run(b, kind, rs->rays, n, &out, thr);
                        to = sc_now_seconds() - t0;
                        c1 = cycles_read(o->cycles_fd);
                        co = c1 - c0;
#ifdef SC_HAVE_EMBREE
                        if (r % 2 == 1) {
                            c0 = cycles_read(o->cycles_fd);
                            double t1 = sc_now_seconds();
                            embree_run(emb, kind, rs->rays, n, &out, thr);
                            te = sc_now_seconds() - t1;
                            ce = cycles_read(o->cycles_fd) - c0;
                        }
#endif
                        t_o[r] = to, t_e[r] = te;
                        ratio[r] = te / to;
                        cratio[r] = co ? (double)ce / (double)co : NAN;
                    }
                    const double mo = (double)n / median(t_o, o->repeats) * 1e-6;
                    const double me = (double)n / median(t_e, o->repeats) * 1e-6;
                    const double rr = median(ratio, o->repeats);
                    const double cr = have_cyc ? median(cratio, o->repeats) : NAN;
                    printf("%-7s %3d %4d %-8s %6.1f %5.1f %8.2f %8.2f %6.3f %6.3f | %6.2f %6.3f %6.2f %6.1f %6.2f "
                           "%5.3f %8.1f %6zu\n",
                           kind_names[kind], thr, cfg.leaf_size, sc_prefilter_mode_name(cfg.prefilter), bpt,
                           sph_pct, mo, me, rr, cr, (double)stt.nodes / rays_d, (double)stt.leaves / rays_d,
                           (double)stt.sphere_tests / rays_d,
                           stt.sphere_tests ? 100.0 * (double)stt.sphere_rejects / (double)stt.sphere_tests : 0.0,
                           (double)stt.tri_tests / rays_d, (double)stt.tri_hits / rays_d,
                           info.build_seconds * 1e3, diff_emb);
                    fflush(stdout);
                    csv_add(csv,
                            "%s,%zu,%s,%zu,%d,%d,%s,%s,%.3f,%.3f,%.3f,%.2f,%.4f,%.4f,%.4f,%.4f,%.4f,%.5f,%.4f,%.4f,%.5f,"
                            "%.4f,%.4f,%zu,%zu,%.2f,%zu,%zu\n",
                            spec, ntri, kind_names[kind], n, thr, cfg.leaf_size, sc_prefilter_mode_name(cfg.prefilter),
                            sc_trace_isa_name(info.isa), bpt, emb_bvh_bpt, emb_bpt, sph_pct, mo, me, rr, cr,
                            (double)stt.nodes / rays_d, (double)stt.leaves / rays_d,
                            (double)stt.sphere_tests / rays_d, (double)stt.sphere_rejects / rays_d,
                            (double)stt.tri_tests / rays_d, (double)stt.tri_hits / rays_d,
                            stt.sphere_tests ? (double)stt.sphere_rejects / (double)stt.sphere_tests : 0.0,
                            info.leaves, info.leaves_with_spheres, info.build_seconds * 1e3, diff_emb, diff_brute);
                }
            }
            sc_bvh_free(b);
        }
    printf("# ratio: our Mrays/s over Embree's, median of %d paired repeats; cyc-r: the same from user-mode\n"
           "# cycles (1 thread); nodes..hits: per ray; sph%%: leaves with spheres; diff: rays whose hit\n"
           "# differs from Embree's (another primitive at another t, or occlusion)\n",
           o->repeats);
    rc = 0;
done:
#ifdef SC_HAVE_EMBREE
    sc_embree_destroy(emb);
#endif
    sc_bvh_free(ref);
    free(ref_hits), free(ref_occ), free(emb_hits), free(emb_occ), free(out.hits), free(out.occ);
    sc_rayset_free(&prim);
    sc_rayset_free(&shad);
    sc_scene_free(scene);
    return rc;
}

int sc_cmd_bench(int argc, char **argv)
{
    bench_opts o;
    memset(&o, 0, sizeof o);
    o.kinds[0] = KIND_PRIMARY, o.kinds[1] = KIND_SHADOW, o.nkinds = 2;
    o.threads[0] = 1, o.threads[1] = 2, o.nthreads = 2;
    o.leaves[0] = 4, o.leaves[1] = 8, o.leaves[2] = 16, o.nleaves = 3;
    for (int m = 0; m < SC_PREFILTER_MODE_COUNT; m++)
        o.modes[m] = m;
    o.nmodes = SC_PREFILTER_MODE_COUNT;
    o.width = 512, o.height = 384, o.repeats = 5;
    o.isa = SC_TRACE_ISA_AUTO;
    o.trav_cost = -1;
    o.tri = SC_TRI_WATERTIGHT;
    const char *csv_path = NULL;
    const char *scenes[64];
    int nscenes = 0;

    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            return 0;
        }
        if (a[0] != '-' || strncmp(a, "proc:", 5) == 0) {
            if (nscenes == 64) {
                sc_cli_error(CMD, "too many scenes (at most 64)");
                return 2;
            }
            scenes[nscenes++] = a;
            continue;
        }
        if (i + 1 >= argc) {
            sc_cli_error(CMD, "%s needs a value", a);
            return 2;
        }
        const char *val = argv[++i];
        int bad = 0;
        if (strcmp(a, "--csv") == 0) {
            csv_path = val;
        } else if (strcmp(a, "--rays") == 0) {
            o.nkinds = 0;
            int seen[2] = { 0, 0 };
            char buf[64];
            snprintf(buf, sizeof buf, "%s", val);
            char *save = NULL;
            for (char *tok = strtok_r(buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
                int k = strcmp(tok, "primary") == 0 ? 0 : strcmp(tok, "shadow") == 0 ? 1 : -1;
                if (k < 0 || seen[k]) {
                    bad = 1;
                    break;
                }
                seen[k] = 1;
                o.kinds[o.nkinds++] = k;
            }
            bad |= o.nkinds == 0;
        } else if (strcmp(a, "--threads") == 0) {
            bad = (o.nthreads = parse_int_list(val, o.threads, 1, 256)) <= 0;
        } else if (strcmp(a, "--leaf") == 0) {
            bad = (o.nleaves = parse_int_list(val, o.leaves, 1, SC_BVH_MAX_LEAF)) <= 0;
        } else if (strcmp(a, "--prefilter") == 0) {
            bad = (o.nmodes = parse_mode_list(val, o.modes)) <= 0;
        } else if (strcmp(a, "--size") == 0) {
            char x;
            bad = sscanf(val, "%d%c%d", &o.width, &x, &o.height) != 3 || x != 'x' || o.width < 1 ||
                  o.height < 1 || o.width > 8192 || o.height > 8192;
        } else if (strcmp(a, "--repeats") == 0) {
            char *end;
            long r = strtol(val, &end, 10);
            bad = *end || r < 1 || r > MAX_REPEATS;
            o.repeats = (int)r;
        } else if (strcmp(a, "--isa") == 0) {
            bad = sc_trace_isa_from_name(val, &o.isa) != SC_OK;
            if (!bad && !sc_trace_isa_supported(o.isa)) {
                sc_cli_error(CMD, "ISA '%s' is not supported by this CPU", val);
                return 2;
            }
        } else if (strcmp(a, "--triangle") == 0) {
            bad = sc_tri_test_from_name(val, &o.tri) != SC_OK;
        } else if (strcmp(a, "--trav-cost") == 0) {
            char *end;
            double c = strtod(val, &end);
            bad = *end || !(c >= 0 && c <= 100);
            o.trav_cost = (float)c;
        } else if (strcmp(a, "--embree") == 0) {
            bad = strcmp(val, "default") != 0 && strcmp(val, "robust") != 0;
            o.embree_robust = strcmp(val, "robust") == 0;
        } else {
            sc_cli_error(CMD, "unknown option '%s' (try --help)", a);
            return 2;
        }
        if (bad) {
            sc_cli_error(CMD, "bad value '%s' for %s (try --help)", val, a);
            return 2;
        }
    }
    if (nscenes == 0) {
        sc_cli_error(CMD, "no SCENE given (try --help)");
        return 2;
    }
#ifndef _OPENMP
    for (int i = 0; i < o.nthreads; i++)
        if (o.threads[i] > 1) {
            sc_cli_error(CMD, "built without OpenMP: only --threads 1");
            return 2;
        }
#endif

    char cpu[256];
    cpu_name(cpu, sizeof cpu);
    sc_trace_isa isa = o.isa;
    if (isa == SC_TRACE_ISA_AUTO) {
        /* What a build with AUTO will pick (SPHERECULL_ISA, then the CPU). */
        sc_bvh *probe = NULL;
        sc_bvh_config pc;
        sc_bvh_config_default(&pc);
        if (sc_bvh_build(NULL, 0, NULL, 0, &pc, &probe) == SC_OK) {
            sc_bvh_info pi;
            sc_bvh_get_info(probe, &pi);
            isa = pi.isa;
            sc_bvh_free(probe);
        }
    }
#if defined(__clang__)
    printf("# compiler: clang %s\n", __clang_version__);
#elif defined(__GNUC__)
    printf("# compiler: gcc %s\n", __VERSION__);
#else
    printf("# compiler: unknown\n");
#endif
    printf("# cpu: %s (%ld online)\n", cpu, sysconf(_SC_NPROCESSORS_ONLN));
    printf("# isa: %s (tracer kernels)\n", sc_trace_isa_name(isa));
    printf("# threads:");
    for (int i = 0; i < o.nthreads; i++)
        printf("%s%d", i ? "," : " ", o.threads[i]);
#ifdef _OPENMP
    printf(" (OpenMP, %d available)\n", omp_get_max_threads());
#else
    printf(" (no OpenMP)\n");
#endif
#ifdef SC_HAVE_EMBREE
    printf("# embree: %s, %s scene, rtcIntersect1 / rtcOccluded1 on the same rays\n", RTC_VERSION_STRING,
           o.embree_robust ? "robust" : "default");
#else
    printf("# embree: not built in; ratios are n/a\n");
#endif
    o.cycles_fd = cycles_open();
    printf("# %dx%d primary rays per scene, %d paired repeats, cycle counter %s\n", o.width, o.height, o.repeats,
           o.cycles_fd >= 0 ? "on" : "unavailable");
    fflush(stdout);

    csvbuf csv = { 0 };
    csv_add(&csv, "scene,triangles,rays,count,threads,leaf,prefilter,isa,bytes_per_tri,embree_bvh_bytes_per_tri,"
                  "embree_total_bytes_per_tri,"
                  "sphere_leaf_pct,mrays,embree_mrays,ratio,cycle_ratio,nodes,leaves,sphere_tests,sphere_rejects,"
                  "tri_tests,tri_hits,reject_rate,leaf_count,leaves_with_spheres,build_ms,diff_embree,"
                  "diff_brute\n");
    int rc = 0;
    for (int s = 0; s < nscenes && rc == 0; s++)
        rc = bench_scene(scenes[s], &o, &csv);
    if (o.cycles_fd >= 0)
        close(o.cycles_fd);
    if (rc == 0 && csv_path && sc_cli_write_atomic(csv_path, csv_write, &csv) != 0) {
        sc_cli_error(CMD, "cannot write %s: %s", csv_path, strerror(errno));
        rc = 1;
    }
    free(csv.s);
    return rc;
}
