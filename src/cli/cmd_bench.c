/* spherecull bench: our BVH against Embree on the same rays, in the same
 * run (the measuring is src/compare/bench.c); this file parses, prints the
 * machine, the table and the CSV. */
#define _GNU_SOURCE
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#ifdef SC_HAVE_MPI
#include "mpi/sc_mpi.h"
#endif
#include "common/sc_atomic_file.h"
#include "common/sc_csv.h"
#include "common/sc_names.h"
#include "compare/bench.h"
#include "spherecull/sc_scene.h"
#include "spherecull/sc_trace.h"
#include "x86/cpu_features.h"
#ifdef SC_HAVE_EMBREE
#include <embree3/rtcore_config.h>

#include "spherecull/sc_embree.h"
#endif

#define CMD "bench"

/* The Embree this process loaded ("3.13.5 /path", sc_embree_version): the
 * yardstick, printed and written in every CSV row. */
static char embree_build[128];

static const sc_name embree_modes[] = { { "default", 0 }, { "robust", 1 } };

enum { O_CSV, O_RAYS, O_THREADS, O_LEAF, O_PREFILTER, O_SIZE, O_REPEATS, O_ISA, O_EMBREE, O_TRIANGLE, O_TRAV,
       O_PACKET, O_COUNT, O_INSTANCES };
static const sc_cli_opt opts[] = {
    [O_CSV] = { "csv", 0, "FILE", "also write one row per measurement", NULL },
    [O_RAYS] = { "rays", 0, "LIST", "primary,shadow,diffuse,random", "primary,shadow" },
    [O_THREADS] = { "threads", 0, "LIST", "thread counts, e.g. 1,2", "1,2" },
    [O_LEAF] = { "leaf", 0, "LIST", "leaf sizes 1..16", "4,8,16" },
    [O_PREFILTER] = { "prefilter", 0, "LIST", "off,circum,minimal,auto,compact", "all" },
    [O_SIZE] = { "size", 0, "WxH", "image size of the primary rays", "512x384" },
    [O_REPEATS] = { "repeats", 0, "R", "paired repeats per measurement, median", "5" },
    [O_ISA] = { "isa", 0, "ISA", SC_CLI_ISA_VALUES, "auto" },
    [O_EMBREE] = { "embree", 0, "MODE", "default|robust: Embree scene flags", "default" },
    [O_TRIANGLE] = { "triangle", 0, "TEST", "watertight|moller|exact: our triangle test", "watertight" },
    [O_TRAV] = { "trav-cost", 0, "C", "SAH cost of a node visit relative to a leaf block test",
                 "the builder's, sc_bvh_config_default" },
    [O_PACKET] = { "packet", 0, "W", "0: single rays; 8 or 16: packets of consecutive rays (4x4 pixel tiles), "
                   "against Embree's packets of the same width", "0" },
    [O_COUNT] = { "count", 0, "N", "random rays per scene", "65536" },
    [O_INSTANCES] = { "instances", 0, "MODE", "a scene with instances: 'trace' through them (both tracers; "
                                              "single rays only) or 'flat' (its flattened mesh)", "trace" },
};

typedef struct args {
    sc_bench_options o;
    const char *csv;
    const char *scenes[64];
    int nscenes;
} args;

static int parse_modes(const char *s, int *out)
{
    char buf[256];
    int n = 0;
    if (strlen(s) < sizeof buf) {
        snprintf(buf, sizeof buf, "%s", s);
        char *save = NULL;
        for (char *tok = strtok_r(buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
            sc_prefilter_mode m;
            if (n >= SC_BENCH_MAX_LIST || sc_prefilter_mode_from_name(tok, &m) != SC_OK)
                return -1;
            out[n++] = (int)m;
        }
    }
    return n > 0 ? n : -1;
}

static int parse_kinds(const char *s, sc_bench_options *o)
{
    char buf[64];
    int seen[SC_BENCH_KINDS] = { 0 };
    o->nkinds = 0;
    if (strlen(s) >= sizeof buf)
        return -1;
    snprintf(buf, sizeof buf, "%s", s);
    char *save = NULL;
    for (char *tok = strtok_r(buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
        sc_rayset_kind k;
        if (sc_rayset_kind_from_name(tok, &k) != SC_OK || k == SC_RAYS_ADVERSARIAL || seen[k])
            return -1;
        seen[k] = 1;
        o->kinds[o->nkinds++] = k;
    }
    return o->nkinds > 0 ? 0 : -1;
}

static int on_option(void *ctx, int opt, const char *val)
{
    args *a = ctx;
    sc_bench_options *o = &a->o;
    int bad = 0;
    long v;
    switch (opt) {
    case -1:
        if (a->nscenes == 64) {
            sc_cli_error(CMD, "too many scenes (at most 64)");
            return 2;
        }
        a->scenes[a->nscenes++] = val;
        return 0;
    case O_CSV: a->csv = val; return 0;
    case O_RAYS: bad = parse_kinds(val, o) != 0; break;
    case O_THREADS:
        return (o->nthreads = sc_cli_int_list(CMD, opts[opt].name, val, 1, SC_TRACER_MAX_THREADS, o->threads,
                                              SC_BENCH_MAX_LIST)) < 0 ? 2 : 0;
    case O_LEAF:
        return (o->nleaves = sc_cli_int_list(CMD, opts[opt].name, val, 1, SC_BVH_MAX_LEAF, o->leaves,
                                             SC_BENCH_MAX_LIST)) < 0 ? 2 : 0;
    case O_PREFILTER: bad = (o->nmodes = parse_modes(val, o->modes)) < 0; break;
    case O_SIZE: {
        char x;
        bad = sscanf(val, "%d%c%d", &o->width, &x, &o->height) != 3 || x != 'x' || o->width < 1 ||
              o->height < 1 || o->width > 8192 || o->height > 8192;
        break;
    }
    case O_REPEATS:
        if (sc_cli_int(CMD, opts[opt].name, val, 1, SC_BENCH_MAX_REPEATS, &v) != 0)
            return 2;
        o->repeats = (int)v;
        return 0;
    case O_ISA:
        return sc_cli_isa(CMD, val);
    case O_EMBREE:
        bad = sc_name_lookup(embree_modes, SC_NAMES_COUNT(embree_modes), val, &o->embree_robust) != 0;
        break;
    case O_TRIANGLE: bad = sc_tri_test_from_name(val, &o->tri) != SC_OK; break;
    case O_COUNT:
        if (sc_cli_int(CMD, opts[opt].name, val, 1, 1 << 26, &v) != 0)
            return 2;
        o->count = (int)v;
        return 0;
    case O_PACKET:
        if (sc_cli_int(CMD, opts[opt].name, val, 0, 16, &v) != 0)
            return 2;
        bad = v != 0 && v != 8 && v != 16;
        o->packet = (int)v;
        break;
    case O_INSTANCES:
        return sc_cli_choice(CMD, opts[opt].name, val, "trace", "flat", &o->flatten) ? 2 : 0;
    case O_TRAV: {
        char *end;
        double c = strtod(val, &end);
        bad = end == val || *end || !(c >= 0 && c <= 100);
        o->trav_cost = (float)c;
        break;
    }
    }
    if (bad) {
        sc_cli_error(CMD, "bad value '%s' for --%s (try --help)", val, opts[opt].name);
        return 2;
    }
    return 0;
}

/* ---- printing ---------------------------------------------------------- */

typedef struct printer {
    const char *spec;
    const sc_bench_options *o;
    FILE *csv;               /* an in-memory CSV, written at the end */
    sc_bench_scene scene;
} printer;

static void print_scene(void *ctx, const sc_bench_scene *s)
{
    printer *p = ctx;
    p->scene = *s;
    const sc_camera *cam = &s->camera;
    if (s->instances)
        printf("\n## %s: traced through %zu instances (both tracers)", p->spec, s->instances);
    printf("\n## %s: %zu triangles, bounds (%.4g %.4g %.4g)..(%.4g %.4g %.4g)\n", p->spec, s->triangles, s->lo[0],
           s->lo[1], s->lo[2], s->hi[0], s->hi[1], s->hi[2]);
    printf("#  eye (%.4g %.4g %.4g) target (%.4g %.4g %.4g) fov %.1f, light (%.4g %.4g %.4g)\n", cam->eye[0],
           cam->eye[1], cam->eye[2], cam->target[0], cam->target[1], cam->target[2], cam->fov_y_deg, s->light[0],
           s->light[1], s->light[2]);
    printf("#  %zu primary rays (%zu hit), %zu shadow rays (%zu blocked), %zu diffuse rays (%zu hit),\n"
           "#  %zu random rays (%zu hit); ", s->primary, s->primary_hits, s->shadow, s->shadow_blocked, s->diffuse,
           s->diffuse_hits, s->random, s->random_hits);
    if (s->instances)   /* Embree holds each object once, its copies included */
        printf("embree %.2f B per flattened triangle in all\n", s->embree_bpt);
    else
        printf("embree BVH %.1f B/tri (+%.1f for its copy of the mesh)\n", s->embree_bvh_bpt,
               s->embree_bpt - s->embree_bvh_bpt);
    printf("%-7s %3s %4s %-8s %6s %5s %8s %8s %6s %6s | %6s %6s %6s %6s %6s %5s %8s %6s\n", "rays", "thr", "leaf",
           "prefilt", "B/tri", "sph%", "Mrays/s", "embree", "ratio", "cyc-r", "nodes", "leaves", "sph", "rej%",
           "tris", "hits", "build-ms", "diff");
    fflush(stdout);
}

static void print_row(void *ctx, const sc_bench_row *r)
{
    const printer *p = ctx;
    const sc_tracer_counters *w = &r->work;
    const double n = w->rays ? (double)w->rays : 1;
    const double rej = w->sphere_tests ? (double)w->sphere_rejects / (double)w->sphere_tests : 0.0;
    const char *kind = sc_rayset_kind_name(r->kind), *mode = sc_prefilter_mode_name(r->prefilter);
    printf("%-7s %3d %4d %-8s %6.2f %5.1f %8.2f %8.2f %6.3f %6.3f | %6.2f %6.3f %6.2f %6.1f %6.2f %5.3f %8.1f %6zu\n",
           kind, r->threads, r->leaf, mode, r->bytes_per_tri, r->sphere_leaf_pct, r->mrays, r->embree_mrays, r->ratio,
           r->cycle_ratio, (double)w->nodes / n, (double)w->leaves / n, (double)w->sphere_tests / n, 100.0 * rej,
           (double)w->tri_tests / n, (double)w->tri_hits / n, r->build_ms, r->diff_embree);
    fflush(stdout);
    sc_csv_str(p->csv, p->spec);
    fprintf(p->csv,
            ",%zu,%s,%zu,%d,%d,%s,%s,%.3f,%.3f,%.3f,%.2f,%.4f,%.4f,%.4f,%.4f,%.4f,%.5f,%.4f,%.4f,%.5f,"
            "%.4f,%.4f,%zu,%zu,%.2f,%zu,%zu,",
            p->scene.triangles, kind, r->rays, r->threads, r->leaf, mode, sc_isa_name(r->isa),
            r->bytes_per_tri, p->scene.embree_bvh_bpt, p->scene.embree_bpt, r->sphere_leaf_pct, r->mrays, r->embree_mrays, r->ratio, r->cycle_ratio, (double)w->nodes / n,
            (double)w->leaves / n, (double)w->sphere_tests / n, (double)w->sphere_rejects / n,
            (double)w->tri_tests / n, (double)w->tri_hits / n, rej, r->leaf_count, r->leaves_with_spheres,
            r->build_ms, r->diff_embree, r->diff_brute);
    sc_csv_str(p->csv, embree_build);
    fputc('\n', p->csv);
}

static void print_footer(const sc_bench_options *o)
{
    printf("# ratio: our Mrays/s over Embree's, median of %d paired repeats; cyc-r: the same from user-mode\n"
           "# cycles (1 thread); nodes..hits: per ray; sph%%: leaves with spheres; diff: rays whose hit\n"
           "# differs from Embree's (another primitive at another t, or occlusion)\n",
           o->repeats);
}

static int bench_scene(const char *spec, const sc_bench_options *o, int cycles_fd, FILE *csv)
{
    sc_scene *scene;
    sc_scene_view v;
    sc_mesh_view mesh;
    if (sc_cli_load_mesh(CMD, spec, &scene, &v, &mesh) != 0)
        return 1;
    char err[512] = "";
    printer p = { spec, o, csv, { 0 } };
    sc_bench_sink sink = { print_scene, print_row, &p };
    sc_status st = sc_bench_run(&mesh, &v, &v.camera, v.lights, v.num_lights, o, cycles_fd, &sink, err, sizeof err);
    sc_scene_free(scene);
    if (st != SC_OK) {
        sc_cli_error(CMD, "%s: %s", spec, err[0] ? err : sc_strerror(st));
        return 1;
    }
    print_footer(o);
    return 0;
}

#ifdef SC_HAVE_MPI
/* What one rank measured: the scene summary and the rows of each of its
 * work items, tagged with the item. */
typedef struct collect {
    int item;
    sc_bench_scene *scenes;
    int *scene_items;
    size_t nscenes;
    sc_bench_row *rows;
    int *row_items;
    size_t nrows;
    int oom;
} collect;

static int grow(void **p, size_t n, size_t size)
{
    /* doubling at powers of two */
    if (n & (n - 1))
        return 0;
    void *q = realloc(*p, (n ? 2 * n : 1) * size);
    if (!q)
        return -1;
    *p = q;
    return 0;
}

static void collect_scene(void *ctx, const sc_bench_scene *sc)
{
    collect *c = ctx;
    if (grow((void **)&c->scenes, c->nscenes, sizeof *c->scenes) ||
        grow((void **)&c->scene_items, c->nscenes, sizeof *c->scene_items)) {
        c->oom = 1;
        return;
    }
    c->scenes[c->nscenes] = *sc;
    c->scene_items[c->nscenes++] = c->item;
}

static void collect_row(void *ctx, const sc_bench_row *r)
{
    collect *c = ctx;
    if (grow((void **)&c->rows, c->nrows, sizeof *c->rows) ||
        grow((void **)&c->row_items, c->nrows, sizeof *c->row_items)) {
        c->oom = 1;
        return;
    }
    c->rows[c->nrows] = *r;
    c->row_items[c->nrows++] = c->item;
}

/* Under mpirun: the work items (scene x leaf size x prefilter mode, in the
 * single process's order) dealt round-robin; each rank times its items
 * under the node lock (sc_mpi.h); rank 0 prints and writes everything in
 * the single process's order. */
static int bench_distributed(sc_mpi *mpi, const args *a, int cycles_fd, FILE *csv)
{
    const int rank = sc_mpi_rank(mpi), size = sc_mpi_size(mpi);
    sc_mpi_node_lock *lock = NULL;
    if (sc_cli_mpi_failed(CMD, mpi, sc_mpi_node_lock_new(mpi, &lock),
                          rank == 0 ? "cannot set up the node's timing lock (/dev/shm or /tmp)" : NULL))
        return 1;
    sc_bench_options o = a->o;
    o.timing = sc_mpi_node_lock_timing;
    o.timing_ctx = lock;
    o.nleaves = o.nmodes = 1;
    const int per = a->o.nleaves * a->o.nmodes;
    collect c;
    memset(&c, 0, sizeof c);
    sc_bench_sink sink = { collect_scene, collect_row, &c };
    char err[512] = "", line[700] = "";
    sc_status st = SC_OK;
    int loaded = -1;
    sc_scene *scene = NULL;
    sc_scene_view v;
    sc_mesh_view mesh;
    for (int item = 0; item < a->nscenes * per && st == SC_OK; item++) {
        if (item % size != rank)
            continue;
        const int s = item / per, li = item % per / a->o.nmodes, mi = item % a->o.nmodes;
        if (loaded != s) {
            sc_scene_free(scene);
            scene = NULL;
            if (sc_cli_load_mesh_msg(a->scenes[s], &scene, &v, &mesh, line, sizeof line) != 0) {
                st = SC_ERR_IO;
                break;
            }
            loaded = s;
        }
        o.leaves[0] = a->o.leaves[li];
        o.modes[0] = a->o.modes[mi];
        c.item = item;
        st = sc_bench_run(&mesh, &v, &v.camera, v.lights, v.num_lights, &o, cycles_fd, &sink, err, sizeof err);
        if (st == SC_OK && c.oom)
            st = SC_ERR_OUT_OF_MEMORY;
        if (st != SC_OK)
            snprintf(line, sizeof line, "%s: %s", a->scenes[s], err[0] ? err : sc_strerror(st));
    }
    sc_scene_free(scene);
    sc_mpi_node_lock_free(lock);
    int rc = 0;
    void *scenes = NULL, *rows = NULL;
    size_t nscenes = 0, nrows = 0;
    if (sc_cli_mpi_failed(CMD, mpi, st, line)) {
        rc = 1;
    } else if (sc_mpi_gather_items(mpi, c.scenes, c.nscenes, sizeof *c.scenes, c.scene_items, &scenes, &nscenes) !=
                   SC_OK ||
               sc_mpi_gather_items(mpi, c.rows, c.nrows, sizeof *c.rows, c.row_items, &rows, &nrows) != SC_OK) {
        if (rank == 0)
            sc_cli_error(CMD, "gathering the results failed");
        rc = 1;
    } else if (rank == 0) {
        /* every item reports its scene once and nkinds x nthreads rows, so
         * the records of scene s start at s * per items */
        const sc_bench_scene *sc = scenes;
        const sc_bench_row *row = rows;
        const size_t items = (size_t)a->nscenes * (size_t)per, rows_per = (size_t)a->o.nkinds * (size_t)a->o.nthreads;
        if (nscenes != items || nrows != items * rows_per) {
            sc_cli_error(CMD, "the ranks returned %zu scenes and %zu rows, not %zu and %zu", nscenes, nrows, items,
                         items * rows_per);
            rc = 1;
        }
        for (int s = 0; s < a->nscenes && rc == 0; s++) {
            printer p = { a->scenes[s], &a->o, csv, { 0 } };
            print_scene(&p, &sc[(size_t)s * (size_t)per]);
            for (size_t r = (size_t)s * per * rows_per; r < (size_t)(s + 1) * per * rows_per; r++)
                print_row(&p, &row[r]);
            print_footer(&a->o);
        }
    }
    free(scenes);
    free(rows);
    free(c.scenes);
    free(c.scene_items);
    free(c.rows);
    free(c.row_items);
    return rc;
}
#endif

/* What the benchmark runs on, before any number. */
static void print_machine(const sc_bench_options *o, int cycles_fd)
{
    char cpu[64];
    sc_x86_brand(cpu);
#if defined(__clang__)
    printf("# compiler: clang %s\n", __clang_version__);
#elif defined(__GNUC__)
    printf("# compiler: gcc %s\n", __VERSION__);
#endif
    printf("# cpu: %s (%ld online)\n", cpu, sysconf(_SC_NPROCESSORS_ONLN));
    printf("# isa: %s (every kernel)\n", sc_isa_name(sc_isa_active()));
    printf("# threads:");
    for (int i = 0; i < o->nthreads; i++)
        printf("%s%d", i ? "," : " ", o->threads[i]);
    printf(" (worker threads, rays handed out in chunks of 1024)\n");
#ifdef SC_HAVE_EMBREE
    if (o->packet)
        printf("# embree: %s, %s scene, rtcIntersect%d / rtcOccluded%d on the same rays; ours: sc_trace_closest%d / "
               "sc_trace_any%d\n", embree_build, o->embree_robust ? "robust" : "default", o->packet, o->packet,
               o->packet, o->packet);
    else
        printf("# embree: %s, %s scene, rtcIntersect1 / rtcOccluded1 on the same rays\n", embree_build,
               o->embree_robust ? "robust" : "default");
#else
    printf("# embree: not built in; ratios are n/a\n");
#endif
    printf("# %dx%d primary rays per scene, %d paired repeats, cycle counter %s\n", o->width, o->height,
           o->repeats, cycles_fd >= 0 ? "on" : "unavailable");
    fflush(stdout);
}

static int run(int argc, char **argv)
{
    /* ranks other than 0 keep quiet about what every rank finds alike */
    if (sc_cli_mpi_rank() > 0)
        sc_cli_quiet_errors(1);
    args a;
    memset(&a, 0, sizeof a);
    sc_bench_options_default(&a.o);
    int rc = sc_cli_parse(&sc_cli_bench, argc, argv, on_option, &a);
    if (rc)
        return rc < 0 ? 0 : rc;
    if (a.nscenes == 0) {
        sc_cli_error(CMD, "no SCENE given (try --help)");
        return 2;
    }
    if (sc_cli_check_output(CMD, "--csv", a.csv) != 0)
        return 1;
    int rank, size;
    struct sc_mpi *mpi;
    if ((rc = sc_cli_mpi_start(CMD, &argc, &argv, &mpi, &rank, &size)) != 0)
        return rc;
    int cycles_fd = sc_bench_cycles_open();
#ifdef SC_HAVE_EMBREE
    if (sc_embree_version(embree_build, sizeof embree_build) != SC_OK)
        snprintf(embree_build, sizeof embree_build, "%s (headers; no device)", RTC_VERSION_STRING);
#endif
    if (rank == 0)
        print_machine(&a.o, cycles_fd);
    if (rank == 0 && size > 1)
        printf("# mpi: %d ranks; work items (scene x leaf x prefilter mode) dealt round-robin; one timed block at "
               "a time per node\n", size);
    char *text = NULL;
    size_t len = 0;
    FILE *csv = open_memstream(&text, &len);
    if (!csv) {
        sc_cli_error(CMD, "out of memory");
        rc = 1;
    } else {
        fprintf(csv, "scene,triangles,rays,count,threads,leaf,prefilter,isa,bytes_per_tri,embree_bvh_bytes_per_tri,"
                     "embree_total_bytes_per_tri,sphere_leaf_pct,mrays,embree_mrays,ratio,cycle_ratio,nodes,leaves,"
                     "sphere_tests,sphere_rejects,tri_tests,tri_hits,reject_rate,leaf_count,leaves_with_spheres,"
                     "build_ms,diff_embree,diff_brute,embree_build\n");
#ifdef SC_HAVE_MPI
        if (mpi)
            rc = bench_distributed(mpi, &a, cycles_fd, csv);
        else
#endif
        for (int s = 0; s < a.nscenes && rc == 0; s++)
            rc = bench_scene(a.scenes[s], &a.o, cycles_fd, csv);
        if (fclose(csv) != 0 && rc == 0) {
            sc_cli_error(CMD, "out of memory for the CSV");
            rc = 1;
        }
    }
    if (cycles_fd >= 0)
        close(cycles_fd);
#ifdef SC_HAVE_MPI
    sc_mpi_finalize(mpi);
#endif
    if (rc == 0 && a.csv && rank == 0 && sc_write_atomic_bytes(a.csv, text, len) != 0) {
        sc_cli_error(CMD, "cannot write %s: %s", a.csv, strerror(errno));
        rc = 1;
    }
    free(text);
    return rc;
}

const sc_cli_cmd sc_cli_bench = {
    .name = "bench",
    .operands = "SCENE...",
    .summary = "tracer Mrays/s per prefilter mode and leaf size, against Embree on the same rays",
    .details = "Closest-hit (primary, diffuse bounce, random) and any-hit (shadow) rays per scene x\n"
               "prefilter mode x leaf size x thread count, with per-ray work counters, bytes per\n"
               "triangle, and Embree's\n"
               "rtcIntersect1/rtcOccluded1 on the same rays as the ratio. Every configuration is first\n"
               "checked against brute force on a sample of rays (a difference is an error).\n"
               "SCENE: a mesh file assimp reads, a scenes/*.json file, proc:KIND:N or cache:NAME.\n",
    .opts = opts,
    .nopts = SC_NAMES_COUNT(opts),
    .run = run,
    .mpi = 1,
};
