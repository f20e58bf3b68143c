/* spherecull render: a scene in, a PNG out. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "common/sc_clock.h"
#include "common/sc_names.h"
#include "tracer.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_image.h"
#include "spherecull/sc_isa.h"
#include "spherecull/sc_render.h"
#include "spherecull/sc_scene.h"
#ifdef SC_HAVE_MPI
#include "mpi/sc_mpi.h"
#endif

#define CMD "render"

#define STR_(x) #x
#define STR(x) STR_(x)

enum { O_OUT, O_WIDTH, O_HEIGHT, O_EYE, O_TARGET, O_UP, O_FOV, O_INTEGRATOR, O_SPP, O_BOUNCES, O_EXPOSURE,
       O_TRACER, O_PREFILTER, O_LEAF, O_THREADS, O_ISA, O_TRIANGLE, O_AO, O_SEED, O_NO_SHADOWS, O_DEBUG,
       O_STATS, O_MAX_TRIS, O_QUIET };
static const sc_cli_opt opts[] = {
    [O_OUT] = { "output", 'o', "FILE", "PNG to write, atomically", "render.png" },
    [O_WIDTH] = { "width", 0, "W", "image width; one side given keeps the aspect", "the scene's" },
    [O_HEIGHT] = { "height", 0, "H", "image height", "the scene's" },
    [O_EYE] = { "eye", 0, "X,Y,Z", "camera position", "the scene's" },
    [O_TARGET] = { "target", 0, "X,Y,Z", "point the camera looks at", "the scene's" },
    [O_UP] = { "up", 0, "X,Y,Z", "camera up vector", "the scene's" },
    [O_FOV] = { "fov", 0, "DEG", "vertical field of view, degrees in (0, 180)", "the scene's" },
    [O_INTEGRATOR] = { "integrator", 0, "NAME", "direct (Lambert, shadows, AO)|path (path tracer)",
                       "path with --spp or --bounces, else direct" },
    [O_SPP] = { "spp", 0, "N", "path: samples per pixel, 1..65536", "16" },
    [O_BOUNCES] = { "bounces", 0, "B", "path: surface scatterings per path, 0..64 (1 = direct light)", "4" },
    [O_EXPOSURE] = { "exposure", 0, "EV", "path: radiance x 2^EV before the sRGB tone map", "0" },
    [O_TRACER] = { "tracer", 0, "NAME", "spherecull (this BVH, the options below) or a tracer of 'compare' "
                                        "(embree, embree-high, spherecull-exact, ...)", "spherecull" },
    [O_PREFILTER] = { "prefilter", 0, "MODE", "off|circum|minimal|auto|compact", "auto" },
    [O_LEAF] = { "leaf", 0, "N", "triangles per BVH leaf, 1.." STR(SC_BVH_MAX_LEAF), "8" },
    [O_THREADS] = { "threads", 0, "N", "render threads", "all" },
    [O_ISA] = { "isa", 0, "ISA", SC_CLI_ISA_VALUES, "auto" },
    [O_TRIANGLE] = { "triangle", 0, "TEST", "watertight|moller|exact", "watertight" },
    [O_AO] = { "ao", 0, "N", "direct: ambient-occlusion samples per pixel", "0" },
    [O_SEED] = { "seed", 0, "S", "seed for every random number (AO, paths)", "1" },
    [O_NO_SHADOWS] = { "no-shadows", 0, NULL, "direct: skip shadow rays", NULL },
    [O_DEBUG] = { "debug", 0, "VIEW", "direct: normals|depth|id|heat (sphere tests per pixel)", NULL },
    [O_STATS] = { "stats", 0, NULL, "count and print per-ray traversal statistics", NULL },
    [O_MAX_TRIS] = { "max-triangles", 0, "N", "refuse larger scenes", "50000000" },
    [O_QUIET] = { "quiet", 'q', NULL, "no progress line, no summary", NULL },
};

_Static_assert(SC_SCENE_DEFAULT_MAX_TRIANGLES == 50000000ull, "--max-triangles states the loader's default");

typedef struct args {
    const char *scene, *out, *tracer;
    long width, height, leaf, threads, ao, spp, bounces;
    double eye[3], target[3], up[3], fov, exposure;
    int has_eye, has_target, has_up, has_fov, has_integrator;
    unsigned long long seed, max_tris;
    int stats, quiet, shadows;
    sc_prefilter_mode prefilter;
    sc_tri_test tri;
    sc_render_debug debug;
    sc_render_integrator integrator;
} args;

static int on_option(void *ctx, int opt, const char *val)
{
    args *a = ctx;
    const char *name = opt >= 0 ? opts[opt].name : "";
    switch (opt) {
    case -1:
        if (a->scene) {
            sc_cli_error(CMD, "more than one scene given ('%s' and '%s')", a->scene, val);
            return 2;
        }
        a->scene = val;
        return 0;
    case O_OUT:
        if (!*val) {
            sc_cli_error(CMD, "--output needs a file name");
            return 2;
        }
        a->out = val;
        return 0;
    case O_WIDTH: return sc_cli_int(CMD, name, val, 1, SC_SCENE_MAX_IMAGE_SIDE, &a->width) ? 2 : 0;
    case O_HEIGHT: return sc_cli_int(CMD, name, val, 1, SC_SCENE_MAX_IMAGE_SIDE, &a->height) ? 2 : 0;
    case O_EYE: a->has_eye = 1; return sc_cli_vec3(CMD, name, val, 1e30, a->eye) ? 2 : 0;
    case O_TARGET: a->has_target = 1; return sc_cli_vec3(CMD, name, val, 1e30, a->target) ? 2 : 0;
    case O_UP: a->has_up = 1; return sc_cli_vec3(CMD, name, val, 1e30, a->up) ? 2 : 0;
    case O_FOV:
        a->has_fov = 1;
        if (sc_cli_double(CMD, name, val, 0, 180, &a->fov))
            return 2;
        if (a->fov > 0 && a->fov < 180)
            return 0;
        sc_cli_error(CMD, "--fov wants degrees strictly between 0 and 180, not '%s'", val);
        return 2;
    case O_SPP:
        if (!a->has_integrator)
            a->integrator = SC_RENDER_PATH;
        return sc_cli_int(CMD, name, val, 1, 65536, &a->spp) ? 2 : 0;
    case O_BOUNCES:
        if (!a->has_integrator)
            a->integrator = SC_RENDER_PATH;
        return sc_cli_int(CMD, name, val, 0, 64, &a->bounces) ? 2 : 0;
    case O_EXPOSURE: return sc_cli_double(CMD, name, val, -64, 64, &a->exposure) ? 2 : 0;
    case O_INTEGRATOR:
        if (sc_render_integrator_from_name(val, &a->integrator) == SC_OK) {
            a->has_integrator = 1;
            return 0;
        }
        break;
    case O_TRACER:
        if (strcmp(val, "spherecull") == 0 || sc_tracer_find(val)) {
            a->tracer = val;
            return 0;
        }
        sc_cli_error(CMD, "--tracer takes spherecull or a tracer 'spherecull compare --help' lists, not '%s'", val);
        return 2;
    case O_LEAF: return sc_cli_int(CMD, name, val, 1, SC_BVH_MAX_LEAF, &a->leaf) ? 2 : 0;
    case O_THREADS: return sc_cli_int(CMD, name, val, 1, 1024, &a->threads) ? 2 : 0;
    case O_AO: return sc_cli_int(CMD, name, val, 0, 4096, &a->ao) ? 2 : 0;
    case O_SEED: return sc_cli_u64(CMD, name, val, &a->seed) ? 2 : 0;
    case O_MAX_TRIS:
        if (sc_cli_u64(CMD, name, val, &a->max_tris) != 0)
            return 2;
        if (a->max_tris == 0) {
            sc_cli_error(CMD, "--max-triangles takes a positive integer");
            return 2;
        }
        return 0;
    case O_PREFILTER:
        if (sc_prefilter_mode_from_name(val, &a->prefilter) == SC_OK)
            return 0;
        break;
    case O_ISA:
        return sc_cli_isa(CMD, val);
    case O_TRIANGLE:
        if (sc_tri_test_from_name(val, &a->tri) == SC_OK)
            return 0;
        break;
    case O_DEBUG:
        if (sc_render_debug_from_name(val, &a->debug) == SC_OK && a->debug != SC_RENDER_SHADED)
            return 0;
        break;
    case O_NO_SHADOWS: a->shadows = 0; return 0;
    case O_STATS: a->stats = 1; return 0;
    case O_QUIET: a->quiet = 1; return 0;
    }
    sc_cli_error(CMD, "--%s takes %s, not '%s'", name, opts[opt].help, val);
    return 2;
}

static void on_warning(void *ctx, const char *msg)
{
    (void)ctx;
    fprintf(stderr, "spherecull: " CMD ": warning: %s\n", msg);
}

typedef struct progress {
    double t0, last;
} progress;

static void clock_text(double s, char *buf, size_t n)
{
    long v = (long)(s + 0.5);
    if (v >= 3600)
        snprintf(buf, n, "%ld:%02ld:%02ld", v / 3600, v / 60 % 60, v % 60);
    else
        snprintf(buf, n, "%ld:%02ld", v / 60, v % 60);
}

/* One line on a TTY, redrawn at most ten times a second: bar, elapsed time,
 * the time left at the rate so far, and the ray rate. */
static void on_progress(void *ctx, double f, uint64_t rays)
{
    progress *p = ctx;
    double now = sc_now_seconds(), el = now - p->t0;
    if (f < 1 && now - p->last < 0.1)
        return;
    p->last = now;
    int pct = (int)(f * 100), bar = (int)(f * 30);
    char e[32], left[32];
    clock_text(el, e, sizeof e);
    clock_text(f > 0 ? el * (1 - f) / f : 0, left, sizeof left);
    fprintf(stderr, "\r\033[K[%.*s%*s] %3d%%  %s elapsed, %s left, %.1f Mrays/s", bar,
            "==============================", 30 - bar, "", pct, e, f > 0 ? left : "?",
            el > 0 ? (double)rays * 1e-6 / el : 0.0);
    fflush(stderr);
}

/* Ctrl-C: the render stops at its next tile and nothing is written. */
static volatile sig_atomic_t interrupted;
_Static_assert(sizeof(sig_atomic_t) == sizeof(int), "sc_render_options.cancel points at an int");

static void on_sigint(int sig)
{
    (void)sig;
    interrupted = 1;
}

static int apply_camera(const args *a, sc_scene *scene)
{
    sc_scene_view view;
    sc_scene_get_view(scene, &view);
    sc_camera cam = view.camera;
    long width = a->width, height = a->height;
    /* One side given: keep the scene's aspect ratio. */
    if (width && !height)
        height = (long)((double)width * cam.height / cam.width + 0.5);
    else if (height && !width)
        width = (long)((double)height * cam.width / cam.height + 0.5);
    if (width) {
        cam.width = (int)(width < 1 ? 1 : width);
        cam.height = (int)(height < 1 ? 1 : height);
    }
    for (int i = 0; i < 3; i++) {
        if (a->has_eye)
            cam.eye[i] = a->eye[i];
        if (a->has_target)
            cam.target[i] = a->target[i];
        if (a->has_up)
            cam.up[i] = a->up[i];
    }
    if (a->has_fov)
        cam.fov_y_deg = a->fov;
    sc_status st = sc_scene_set_camera(scene, &cam);
    if (st == SC_ERR_LIMIT) {
        sc_cli_error(CMD, "a %dx%d image is over the pixel cap", cam.width, cam.height);
        return 1;
    }
    if (st != SC_OK) {
        sc_cli_error(CMD, "that camera cannot see anything (eye = target, up along the view, or a %dx%d image)",
                     cam.width, cam.height);
        return 2;
    }
    return 0;
}

/* Where this process stands: one process (rank 0 of 1, mpi NULL), or a
 * rank of an MPI job started by mpirun. */
typedef struct dist {
    int rank, size;
    struct sc_mpi *mpi;
} dist;

static int render_scene(const args *a, dist *d);

/* Under an MPI launcher every rank loads and builds the scene, rank 0 hands
 * out tiles and writes the PNG (sc_mpi.h); otherwise one process renders. */
static int distributed(const args *a, int argc, char **argv)
{
    dist d;
    int rc = sc_cli_mpi_start(CMD, &argc, &argv, &d.mpi, &d.rank, &d.size);
    if (rc)
        return rc;
    rc = render_scene(a, &d);
#ifdef SC_HAVE_MPI
    sc_mpi_finalize(d.mpi);
#endif
    return rc;
}

static int run(int argc, char **argv)
{
    /* ranks other than 0 keep quiet about what every rank finds alike */
    if (sc_cli_mpi_rank() > 0)
        sc_cli_quiet_errors(1);
    args a = { .out = "render.png", .tracer = "spherecull", .leaf = 8, .seed = 1, .shadows = 1, .spp = 16,
               .bounces = 4, .prefilter = SC_PREFILTER_AUTO, .tri = SC_TRI_WATERTIGHT,
               .debug = SC_RENDER_SHADED, .integrator = SC_RENDER_DIRECT };
    int rc = sc_cli_parse(&sc_cli_render, argc, argv, on_option, &a);
    if (rc)
        return rc < 0 ? 0 : rc;
    if (!a.scene) {
        sc_cli_error(CMD, "no scene given (try --help)");
        return 2;
    }
    const int ours = strcmp(a.tracer, "spherecull") == 0;
    if (a.integrator == SC_RENDER_PATH && a.debug != SC_RENDER_SHADED) {
        sc_cli_error(CMD, "--debug views belong to --integrator direct");
        return 2;
    }
    if (!ours && (a.debug == SC_RENDER_HEAT || a.stats)) {
        sc_cli_error(CMD, "--debug heat and --stats count inside this BVH: they need --tracer spherecull");
        return 2;
    }
    if (sc_cli_check_output(CMD, "output", a.out) != 0)
        return 1;
    return distributed(&a, argc, argv);
}

/* A status every rank reaches: 0 if all succeeded; else 1, and the lowest
 * failing rank prints fmt (NULL: it has said so already). One process: the
 * local status. */
static int agreed(dist *d, sc_status st, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static int agreed(dist *d, sc_status st, const char *fmt, ...)
{
    char line[1200] = "";
    if (st != SC_OK && fmt) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(line, sizeof line, fmt, ap);
        va_end(ap);
    }
    return sc_cli_mpi_failed(CMD, d->mpi, st, fmt ? line : NULL);
}

static int render_scene(const args *ap, dist *d)
{
    args a = *ap;
    int rc;
    const int ours = strcmp(a.tracer, "spherecull") == 0;
    sc_scene_options so;
    sc_scene_options_init(&so);
    so.max_triangles = a.max_tris;
    so.warn = on_warning;
    char err[1024];
    sc_scene *scene = NULL;
    sc_status st = sc_scene_load(a.scene, &so, &scene, err, sizeof err);
    if (agreed(d, st, "%s", err))
        return 1;
    /* the same on every rank: only rank 0 speaks */
    rc = apply_camera(&a, scene);
    if (agreed(d, rc ? SC_ERR_INVALID_ARGUMENT : SC_OK, NULL)) {
        sc_scene_free(scene);
        return rc ? rc : 1;
    }
    sc_scene_view view;
    sc_scene_get_view(scene, &view);

    sc_bvh *bvh = NULL;
    sc_bvh_info info;
    memset(&info, 0, sizeof info);
    sc_tracer tracer;
    memset(&tracer, 0, sizeof tracer);
    sc_tracer_backend backend;
    double build_seconds = 0;
    /* A scene with instances traces through them (one tree per object),
     * unless a view needs the flattened mesh's own BVH (heat, counters). */
    sc_scene_accel *sacc = NULL;
    sc_render_backend sa_backend;
    const int use_instances = ours && view.num_instances && a.debug != SC_RENDER_HEAT && !a.stats;
    if (use_instances) {
        sc_bvh_config cfg;
        sc_bvh_config_default(&cfg);
        cfg.leaf_size = (int)a.leaf;
        cfg.prefilter = a.prefilter;
        cfg.tri_test = a.tri;
        st = sc_scene_accel_build(&view, &cfg, &sacc);
        if (agreed(d, st, "building the scene's trees failed: %s", sc_strerror(st))) {
            sc_scene_free(scene);
            return 1;
        }
        sc_scene_accel_backend(sacc, &sa_backend);
        sc_scene_accel_info(sacc, NULL, &info.total_bytes, &build_seconds);
        info.triangles = view.mesh.triangle_count;
        info.leaf_size = cfg.leaf_size;
        info.prefilter = cfg.prefilter;
    } else if (ours) {
        sc_bvh_config cfg;
        sc_bvh_config_default(&cfg);
        cfg.leaf_size = (int)a.leaf;
        cfg.prefilter = a.prefilter;
        cfg.tri_test = a.tri;
        cfg.threads = (int)a.threads;   /* 0 (the default): every CPU, as the render */
        st = sc_bvh_build(&view.mesh, &cfg, &bvh);
        if (agreed(d, st, "building the BVH failed: %s", sc_strerror(st))) {
            sc_bvh_free(bvh);
            sc_scene_free(scene);
            return 1;
        }
        sc_bvh_get_info(bvh, &info);
        build_seconds = info.build_seconds;
    } else {
        sc_checked_mesh cm;
        double t0 = sc_now_seconds();
        st = sc_mesh_check(&view.mesh, &cm);
        if (st == SC_OK)
            st = sc_tracer_build(&tracer, sc_tracer_find(a.tracer), &cm);
        if (agreed(d, st, "building tracer %s failed: %s", a.tracer, sc_strerror(st))) {
            if (st == SC_OK)
                sc_tracer_free(&tracer);
            sc_scene_free(scene);
            return 1;
        }
        build_seconds = sc_now_seconds() - t0;
        tracer.ftz = tracer.def.family == SC_TRACER_EMBREE;   /* Embree asks for FTZ|DAZ */
        sc_tracer_render_backend(&tracer, &backend);
    }

    sc_render_options ro;
    sc_render_options_init(&ro);
    ro.integrator = a.integrator;
    ro.spp = (int)a.spp;
    ro.bounces = (int)a.bounces;
    ro.exposure = a.exposure;
    ro.debug = a.debug;
    ro.ao_samples = (int)a.ao;
    ro.seed = a.seed;
    ro.threads = (int)a.threads;
    ro.shadows = a.shadows;
    ro.trace_stats = a.stats;
    ro.backend = use_instances ? &sa_backend : ours ? NULL : &backend.backend;
    ro.cancel = (const volatile int *)&interrupted;
    progress prog = { sc_now_seconds(), 0 };
#ifdef SC_HAVE_MPI
    sc_render_tiles hook;
    sc_mpi_tiles *tiles = NULL;
    if (d->mpi) {
        if (agreed(d, sc_mpi_tiles_new(d->mpi, &tiles, &hook), "setting up the tile counter failed")) {
            sc_bvh_free(bvh);
            sc_scene_accel_free(sacc);
            if (!ours)
                sc_tracer_free(&tracer);
            sc_scene_free(scene);
            return 1;
        }
        ro.tiles = &hook;
    }
#endif
    if (!a.quiet && d->rank == 0 && isatty(STDERR_FILENO)) {
        ro.progress = on_progress;
        ro.progress_ctx = &prog;
    }
    struct sigaction sa, old;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_sigint;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, &old);
    sc_image img = { 0, 0, NULL };
    sc_render_stats rs;
    st = sc_render(&view, bvh, &ro, &img, &rs);
    sigaction(SIGINT, &old, NULL);
    char shares[256] = "";
#ifdef SC_HAVE_MPI
    if (tiles && d->rank == 0 && st == SC_OK) {
        /* how the tiles were shared, and what assembling the image cost */
        const uint64_t *rr = sc_mpi_tiles_rank_rays(tiles);
        uint64_t all = 0;
        for (int i = 0; i < d->size; i++)
            all += rr[i];
        size_t n = (size_t)snprintf(shares, sizeof shares, " (rays per rank");
        for (int i = 0; i < d->size && i < 16 && n < sizeof shares; i++)
            n += (size_t)snprintf(shares + n, sizeof shares - n, "%s%.0f%%", i ? " / " : " ",
                                  all ? 100.0 * (double)rr[i] / (double)all : 0.0);
        if (n < sizeof shares)
            snprintf(shares + n, sizeof shares - n, "; gather %.1f ms)", 1e3 * sc_mpi_tiles_combine_seconds(tiles));
    }
    sc_mpi_tiles_free(tiles);
#endif
    if (ro.progress)
        fputs("\r\033[K", stderr);
    if (d->rank != 0) {
        /* the image is complete on rank 0 only, which writes and reports */
    } else if (st == SC_OK) {
        st = sc_png_write(a.out, &img, err, sizeof err);
        if (st != SC_OK)
            sc_cli_error(CMD, "%s", err);
    } else if (st == SC_ERR_CANCELLED) {
        sc_cli_error(CMD, "interrupted; %s left as it was", a.out);
    } else {
        sc_cli_error(CMD, "rendering failed: %s", sc_strerror(st));
    }
    if (st == SC_OK && !a.quiet && d->rank == 0) {
        sc_scene_stats ss;
        sc_scene_get_stats(scene, &ss);
        printf("%s: %zu triangles (scene %.1f B/tri), ", a.scene, ss.triangles, ss.bytes_per_triangle);
        if (use_instances)
            printf("%zu instances of %zu objects, trees %.3f s (leaf %d, prefilter %s, %s, %.1f B/tri)",
                   view.num_instances, view.num_objects, build_seconds, info.leaf_size,
                   sc_prefilter_mode_name(info.prefilter), sc_isa_name(sc_isa_active()),
                   info.triangles ? (double)info.total_bytes / (double)info.triangles : 0.0);
        else if (ours)
            printf("BVH %.3f s (leaf %d, prefilter %s, %s, %.1f B/tri)", build_seconds, info.leaf_size,
                   sc_prefilter_mode_name(info.prefilter), sc_isa_name(sc_isa_active()),
                   info.triangles ? (double)info.total_bytes / (double)info.triangles : 0.0);
        else
            printf("tracer %s built in %.3f s (%.1f B/tri)", a.tracer, build_seconds, tracer.bytes_per_tri);
        uint64_t rays = rs.primary_rays + rs.shadow_rays + rs.ao_rays + rs.bounce_rays;
        printf(", %s, %.2f M rays in %.3f s = %.2f Mrays/s%s", sc_render_integrator_name(a.integrator),
               (double)rays * 1e-6, rs.seconds, rs.seconds > 0 ? (double)rays * 1e-6 / rs.seconds : 0.0,
               a.stats ? " (with counters)" : "");
        printf(" -> %s (%dx%d)", a.out, img.width, img.height);
        if (d->size > 1)
            printf(", %d MPI ranks%s", d->size, shares);
        printf("\n");
        if (a.stats && rs.trace.rays) {
            double n = (double)rs.trace.rays;
            printf("per ray: %.2f nodes, %.2f leaves, %.2f sphere tests (%.1f%% rejected), %.2f triangle tests, %.3f hits"
                   " [%llu primary, %llu bounce, %llu shadow, %llu AO rays]\n",
                   (double)rs.trace.nodes / n, (double)rs.trace.leaves / n, (double)rs.trace.sphere_tests / n,
                   rs.trace.sphere_tests ? 100.0 * (double)rs.trace.sphere_rejects / (double)rs.trace.sphere_tests : 0.0,
                   (double)rs.trace.tri_tests / n, (double)rs.trace.tri_hits / n,
                   (unsigned long long)rs.primary_rays, (unsigned long long)rs.bounce_rays,
                   (unsigned long long)rs.shadow_rays, (unsigned long long)rs.ao_rays);
        }
    }
    sc_image_free(&img);
    sc_bvh_free(bvh);
    sc_scene_accel_free(sacc);
    if (!ours)
        sc_tracer_free(&tracer);
    sc_scene_free(scene);
    return st == SC_OK ? 0 : st == SC_ERR_CANCELLED ? 130 : 1;
}

const sc_cli_cmd sc_cli_render = {
    .name = "render",
    .operands = "SCENE",
    .summary = "trace a scene to a PNG: path tracing, or Lambert, shadows, AO, debug views",
    .details = "Traces SCENE with the sphere-prefiltered BVH (or --tracer embree) and writes an RGB PNG.\n"
               "--integrator path (implied by --spp/--bounces) path-traces it: diffuse bounces, lights\n"
               "and emissive meshes, the background as sky; the image is the same for any thread\n"
               "count. Ctrl-C stops and leaves an existing output file as it was.\n"
               "SCENE is a scenes/*.json file, a mesh file assimp reads (the camera frames it),\n"
               "proc:sphere|soup|slivers|terrain:N, proc:grid:MESH:N or cache:NAME\n"
               "(scripts/fetch-meshes.sh fills the mesh cache).\n",
    .opts = opts,
    .nopts = SC_NAMES_COUNT(opts),
    .run = run,
    .mpi = 1,
};
