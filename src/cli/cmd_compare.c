/* spherecull compare: every tracer on the same scenes and rays, judged by
 * the exact oracle (src/compare/compare.c does the work). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#ifdef SC_HAVE_MPI
#include "mpi/sc_mpi.h"
#endif
#include "common/sc_names.h"
#include "compare/compare.h"
#include "compare/tracer.h"
#include "spherecull/sc_scene.h"
#ifdef SC_HAVE_EMBREE
#include "spherecull/sc_embree.h"
#endif

#define CMD "compare"

enum { O_RAYS, O_TRACERS, O_THREADS, O_ORACLE, O_REPEATS, O_MIN_TIME, O_MXCSR, O_WIDTH, O_COUNT, O_SEED, O_CSV,
       O_JSON, O_PLOT, O_INSTANCES };
static const sc_cli_opt opts[] = {
    [O_RAYS] = { "rays", 0, "LIST", "comma list of primary,shadow,diffuse,random,adversarial", "all" },
    [O_TRACERS] = { "tracers", 0, "LIST", "comma list of tracer names (below)", "all of this build" },
    [O_THREADS] = { "threads", 0, "LIST", "thread counts to time, e.g. 1,2", "1,2" },
    [O_ORACLE] = { "oracle-rays", 0, "N", "rays per set checked by the oracle (0 = none)", "10000" },
    [O_REPEATS] = { "repeats", 0, "N",
                    "timed rounds, each timing every tracer once (backwards on odd rounds); medians are reported",
                    "5" },
    [O_MIN_TIME] = { "min-time", 0, "SECONDS", "each timed run repeats its ray set until this long", "0.2" },
    [O_MXCSR] = { "mxcsr", 0, "MODE", "ftz (flush-to-zero + denormals-are-zero, as Embree asks) or default, "
                                      "in every timed thread of every tracer", "ftz" },
    [O_WIDTH] = { "width", 0, "W", "primary image width; height keeps the camera's aspect", "512" },
    [O_COUNT] = { "count", 0, "N", "random and adversarial rays per set", "65536" },
    [O_SEED] = { "seed", 0, "S", "ray seed", "1" },
    [O_CSV] = { "csv", 0, "FILE", "write all rows as CSV", NULL },
    [O_JSON] = { "json", 0, "FILE", "write all rows as JSON", NULL },
    [O_PLOT] = { "plot", 0, "DIR", "write gnuplot PNGs (and their data) there", NULL },
    [O_INSTANCES] = { "instances", 0, "MODE", "a scene with instances: 'trace' through them (the tracers "
                                              "without that path are skipped) or 'flat' (its flattened mesh)",
                      "trace" },
};

typedef struct args {
    sc_cmp_options opt;
    const char *csv, *json, *plot;
    const char *scenes[256];
    int nscenes;
    char lists[3][1024];     /* copies the tracer names point into */
} args;

/* Splits a comma list in place into at most max items; -1 if more. */
static int split(char *s, const char **items, int max)
{
    int n = 0;
    char *save = NULL;
    for (char *tok = strtok_r(s, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
        if (n == max)
            return -1;
        items[n++] = tok;
    }
    return n;
}

static int on_rays(args *a, const char *val)
{
    const char *items[SC_RAYS_KIND_COUNT + 1];
    snprintf(a->lists[0], sizeof a->lists[0], "%s", val);
    int n = split(a->lists[0], items, SC_RAYS_KIND_COUNT);
    a->opt.ray_kinds = 0;
    for (int k = 0; k < n; k++) {
        sc_rayset_kind kind;
        if (sc_rayset_kind_from_name(items[k], &kind) != SC_OK) {
            sc_cli_error(CMD, "unknown ray set '%s' (primary, shadow, diffuse, random, adversarial)", items[k]);
            return 2;
        }
        a->opt.ray_kinds |= 1u << kind;
    }
    if (n <= 0) {
        sc_cli_error(CMD, "--rays needs a comma list of ray sets");
        return 2;
    }
    return 0;
}

static int on_tracers(args *a, const char *val)
{
    snprintf(a->lists[1], sizeof a->lists[1], "%s", val);
    int n = split(a->lists[1], a->opt.tracers, SC_CMP_MAX_TRACERS);
    for (int k = 0; k < n; k++)
        if (!sc_tracer_find(a->opt.tracers[k])) {
            sc_cli_error(CMD, "tracer '%s' is not in this build (see 'spherecull compare --help')",
                         a->opt.tracers[k]);
            return 2;
        }
    if (n <= 0) {
        sc_cli_error(CMD, "--tracers needs a comma list of tracer names");
        return 2;
    }
    a->opt.ntracers = n;
    return 0;
}

static int on_option(void *ctx, int opt, const char *val)
{
    args *a = ctx;
    long v;
    unsigned long long u;
    switch (opt) {
    case -1:
        if (a->nscenes == 256) {
            sc_cli_error(CMD, "at most 256 scenes per run");
            return 2;
        }
        a->scenes[a->nscenes++] = val;
        return 0;
    case O_RAYS: return on_rays(a, val);
    case O_TRACERS: return on_tracers(a, val);
    case O_THREADS:
        a->opt.nthreads = sc_cli_int_list(CMD, opts[opt].name, val, 1, SC_CMP_MAX_THREADS, a->opt.threads,
                                          SC_CMP_MAX_THREADS);
        return a->opt.nthreads < 0 ? 2 : 0;
    case O_ORACLE:
        if (sc_cli_u64(CMD, opts[opt].name, val, &u) != 0)
            return 2;
        a->opt.oracle_rays = (size_t)u;
        return 0;
    case O_REPEATS:
        if (sc_cli_int(CMD, opts[opt].name, val, 1, 64, &v) != 0)
            return 2;
        a->opt.repeats = (int)v;
        return 0;
    case O_MIN_TIME: {
        char *end;
        errno = 0;
        double d = strtod(val, &end);
        if (errno || end == val || *end || !(d >= 0) || d > 60) {
            sc_cli_error(CMD, "--min-time: '%s' is not a number of seconds in [0, 60]", val);
            return 2;
        }
        a->opt.min_seconds = d;
        return 0;
    }
    case O_MXCSR:
        return sc_cli_choice(CMD, opts[opt].name, val, "default", "ftz", &a->opt.ftz) ? 2 : 0;
    case O_WIDTH:
        if (sc_cli_int(CMD, opts[opt].name, val, 1, 8192, &v) != 0)
            return 2;
        a->opt.width = (int)v;
        return 0;
    case O_COUNT:
        if (sc_cli_int(CMD, opts[opt].name, val, 1, 100000000, &v) != 0)
            return 2;
        a->opt.random_rays = a->opt.adversarial_rays = (size_t)v;
        return 0;
    case O_SEED:
        if (sc_cli_u64(CMD, opts[opt].name, val, &u) != 0)
            return 2;
        a->opt.seed = u;
        return 0;
    case O_CSV: a->csv = val; return 0;
    case O_JSON: a->json = val; return 0;
    case O_PLOT: a->plot = val; return 0;
    case O_INSTANCES:
        return sc_cli_choice(CMD, opts[opt].name, val, "trace", "flat", &a->opt.flatten) ? 2 : 0;
    }
    return 0;
}

static int write_csv_cb(void *ctx, FILE *f)
{
    return sc_cmp_write_csv(ctx, f);
}

static int write_json_cb(void *ctx, FILE *f)
{
    return sc_cmp_write_json(ctx, f);
}

static int compare_scene(const char *spec, const sc_cmp_options *opt, sc_cmp_rows *rows)
{
    sc_scene *scene;
    sc_scene_view v;
    sc_mesh_view mesh;
    if (sc_cli_load_mesh(CMD, spec, &scene, &v, &mesh) != 0)
        return 1;
    char err[512] = "";
    const char *base = strrchr(spec, '/');
    base = base ? base + 1 : spec;
    fprintf(stderr, "%s: %zu triangles\n", base, v.mesh.triangle_count);
    sc_status st = sc_cmp_scene(base, &mesh, &v, &v.camera, v.lights, v.num_lights, opt, rows, stderr, err, sizeof err);
    sc_scene_free(scene);
    if (st != SC_OK) {
        sc_cli_error(CMD, "%s", err[0] ? err : sc_strerror(st));
        return 1;
    }
    return 0;
}

#ifdef SC_HAVE_MPI
/* Under mpirun: the work items (scene x ray set, in the single process's
 * order) dealt round-robin to the ranks; each rank loads the scenes of its
 * items and times them under the node lock (sc_mpi.h); rank 0 gathers the
 * rows in the single process's order. Returns 0 or the exit status; on
 * rank 0 *rows holds every row. */
static int compare_distributed(sc_mpi *mpi, const args *a, sc_cmp_rows *rows)
{
    const int rank = sc_mpi_rank(mpi), size = sc_mpi_size(mpi);
    sc_mpi_node_lock *lock = NULL;
    if (sc_cli_mpi_failed(CMD, mpi, sc_mpi_node_lock_new(mpi, &lock),
                          rank == 0 ? "cannot set up the node's timing lock (/dev/shm or /tmp)" : NULL))
        return 1;
    sc_cmp_options opt = a->opt;
    opt.timing = sc_mpi_node_lock_timing;
    opt.timing_ctx = lock;
    sc_cmp_rows mine = { 0 };
    int *items = NULL;
    size_t items_cap = 0;
    char err[512] = "", loaded_err[600] = "";
    sc_status st = SC_OK;
    int item = 0, loaded = -1;
    sc_scene *scene = NULL;
    sc_scene_view v;
    sc_mesh_view mesh;
    for (int s = 0; s < a->nscenes && st == SC_OK; s++) {
        const char *base = strrchr(a->scenes[s], '/');
        base = base ? base + 1 : a->scenes[s];
        for (int k = 0; k < SC_RAYS_KIND_COUNT && st == SC_OK; k++) {
            if (!(a->opt.ray_kinds & (1u << k)))
                continue;
            if (item++ % size != rank)
                continue;
            if (loaded != s) {
                sc_scene_free(scene);
                scene = NULL;
                /* the line is printed once, after the ranks agree */
                if (sc_cli_load_mesh_msg(a->scenes[s], &scene, &v, &mesh, loaded_err, sizeof loaded_err) != 0) {
                    st = SC_ERR_IO;
                    break;
                }
                loaded = s;
                if (rank == 0)
                    fprintf(stderr, "%s: %zu triangles\n", base, v.mesh.triangle_count);
            }
            opt.ray_kinds = 1u << k;
            size_t before = mine.count;
            st = sc_cmp_scene(base, &mesh, &v, &v.camera, v.lights, v.num_lights, &opt, &mine, rank == 0 ? stderr : NULL,
                              err, sizeof err);
            if (st != SC_OK) {
                snprintf(loaded_err, sizeof loaded_err, "%s", err[0] ? err : sc_strerror(st));
                break;
            }
            if (mine.count > items_cap) {
                size_t cap = mine.cap > 16 ? mine.cap : 16;
                int *p = realloc(items, cap * sizeof *items);
                if (!p) {
                    st = SC_ERR_OUT_OF_MEMORY;
                    snprintf(loaded_err, sizeof loaded_err, "out of memory");
                    break;
                }
                items = p, items_cap = cap;
            }
            for (size_t i = before; i < mine.count; i++)
                items[i] = item - 1;
        }
    }
    sc_scene_free(scene);
    sc_mpi_node_lock_free(lock);
    if (sc_cli_mpi_failed(CMD, mpi, st, loaded_err)) {
        free(items);
        sc_cmp_rows_free(&mine);
        return 1;
    }
    st = sc_mpi_gather_rows(mpi, &mine, items, rows);
    free(items);
    sc_cmp_rows_free(&mine);
    if (st != SC_OK) {
        if (rank == 0)
            sc_cli_error(CMD, "gathering the rows failed: %s", sc_strerror(st));
        return 1;
    }
    return 0;
}
#endif

static int run(int argc, char **argv)
{
    /* ranks other than 0 keep quiet about what every rank finds alike */
    if (sc_cli_mpi_rank() > 0)
        sc_cli_quiet_errors(1);
    args a;
    memset(&a, 0, sizeof a);
    sc_cmp_options_default(&a.opt);
    int rc = sc_cli_parse(&sc_cli_compare, argc, argv, on_option, &a);
    if (rc)
        return rc < 0 ? 0 : rc;
    if (a.nscenes == 0) {
        sc_cli_error(CMD, "no scene given (try --help)");
        return 2;
    }
    if (sc_cli_check_output(CMD, "--csv", a.csv) != 0 || sc_cli_check_output(CMD, "--json", a.json) != 0)
        return 1;
    int rank, size;
    struct sc_mpi *mpi;
    if ((rc = sc_cli_mpi_start(CMD, &argc, &argv, &mpi, &rank, &size)) != 0)
        return rc;
    /* The yardstick, named in the output and in every row. */
    char embree_build[128] = "";
#ifdef SC_HAVE_EMBREE
    if (sc_embree_version(embree_build, sizeof embree_build) == SC_OK && rank == 0)
        printf("embree: %s\n", embree_build);
#endif
    a.opt.embree_build = embree_build;
    if (rank == 0) {
        printf("timing: MXCSR %s in every timed thread, each timed run >= %.2f s\n",
               a.opt.ftz ? "flush-to-zero + denormals-are-zero" : "default", a.opt.min_seconds);
        if (size > 1)
            printf("mpi: %d ranks; work items (scene x ray set) dealt round-robin; one timed block at a time per node\n",
                   size);
    }
    fflush(stdout);
    sc_cmp_rows rows = { 0 };
#ifdef SC_HAVE_MPI
    if (mpi) {
        rc = compare_distributed(mpi, &a, &rows);
        sc_mpi_finalize(mpi);
        if (rank != 0) {
            sc_cmp_rows_free(&rows);
            return rc;
        }
    } else
#endif
    for (int s = 0; s < a.nscenes && rc == 0; s++)
        rc = compare_scene(a.scenes[s], &a.opt, &rows);
    if (rc == 0) {
        sc_cmp_print_table(&rows, stdout);
        printf("\nh/m = hit/miss disagreements with the exact oracle, prim = primID outside the tie set,\n"
               "holes = vertex/edge-aimed rays that pass through the surface (exact transversal crossing) where the tracer\n"
               "does not stop, grazes = rays whose first exact hit only touches the surface (tangent) and that the tracer\n"
               "does not report (adversarial rows), xEmbree = speed / "
               "embree (rtcIntersect1/rtcOccluded1) at the same threads, packet rows (-p8, -p16) / embree-p8, "
               "embree-p16 (the ray set's coherence flag), stream rows / embree-stream; xBest = speed / the fastest Embree\n"
               "row of the same width in the run (single rays: embree, embree-high; packets: also embree-p8/p16-coherent or\n"
               "-incoherent, the flag the ray set does not get), named in the CSV's best_embree_tracer; both are medians of\n"
               "ratios paired in time (a round times every tracer once; Mrays/s is the median round);\n"
               "sph/ray, rej%%, fp%% (sphere passed, triangle missed, of the passes) and tri/ray are "
               "counted by the prefilter tracers\n(packet rows count ray-triangle and ray-sphere pairs, as single rays do).\n");
    }
    if (rc == 0 && a.csv && sc_cli_write(CMD, a.csv, write_csv_cb, &rows) != 0)
        rc = 1;
    if (rc == 0 && a.json && sc_cli_write(CMD, a.json, write_json_cb, &rows) != 0)
        rc = 1;
    if (rc == 0 && a.plot && sc_cmp_write_plots(&rows, a.plot) != 0) {
        sc_cli_error(CMD, "cannot write the plots into %s (is gnuplot installed?)", a.plot);
        rc = 1;
    }
    sc_cmp_rows_free(&rows);
    return rc;
}

/* This build's tracers, for the help. */
static const char *tracer_list(void)
{
    static char buf[1024];
    int n;
    const char *const *names = sc_tracer_names(&n);
    size_t at = (size_t)snprintf(buf, sizeof buf, "\ntracers in this build:");
    for (int i = 0; i < n && at < sizeof buf; i++)
        at += (size_t)snprintf(buf + at, sizeof buf - at, " %s", names[i]);
    if (at < sizeof buf - 1)
        snprintf(buf + at, sizeof buf - at, "\n");
    return buf;
}

const sc_cli_cmd sc_cli_compare = {
    .name = "compare",
    .operands = "SCENE...",
    .summary = "every tracer vs an exact oracle: speed, disagreements, prefilter work",
    .details = "Traces the same seeded ray sets with every tracer, checks a sample of each set\n"
               "against an exact (MPFR) oracle and prints speed, disagreements and prefilter work.\n"
               "SCENE: a mesh file, scene .json, proc:KIND:N or cache:NAME (see sc_scene.h).\n",
    .more = tracer_list,
    .opts = opts,
    .nopts = SC_NAMES_COUNT(opts),
    .run = run,
    .mpi = 1,
};
