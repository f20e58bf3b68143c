/* spherecull render: a scene in, a PNG out. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "common/sc_names.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_image.h"
#include "spherecull/sc_isa.h"
#include "spherecull/sc_render.h"
#include "spherecull/sc_scene.h"

#define CMD "render"

#define STR_(x) #x
#define STR(x) STR_(x)

enum { O_OUT, O_WIDTH, O_HEIGHT, O_PREFILTER, O_LEAF, O_THREADS, O_ISA, O_TRIANGLE, O_AO, O_SEED, O_NO_SHADOWS,
       O_DEBUG, O_STATS, O_MAX_TRIS, O_QUIET };
static const sc_cli_opt opts[] = {
    [O_OUT] = { "output", 'o', "FILE", "PNG to write, atomically", "render.png" },
    [O_WIDTH] = { "width", 0, "W", "image width; one side given keeps the aspect", "the scene's" },
    [O_HEIGHT] = { "height", 0, "H", "image height", "the scene's" },
    [O_PREFILTER] = { "prefilter", 0, "MODE", "off|circum|minimal|auto", "auto" },
    [O_LEAF] = { "leaf", 0, "N", "triangles per BVH leaf, 1.." STR(SC_BVH_MAX_LEAF), "8" },
    [O_THREADS] = { "threads", 0, "N", "render threads", "all" },
    [O_ISA] = { "isa", 0, "ISA", SC_CLI_ISA_VALUES, "auto" },
    [O_TRIANGLE] = { "triangle", 0, "TEST", "watertight|moller|exact", "watertight" },
    [O_AO] = { "ao", 0, "N", "ambient-occlusion samples per pixel", "0" },
    [O_SEED] = { "seed", 0, "S", "seed for AO directions", "1" },
    [O_NO_SHADOWS] = { "no-shadows", 0, NULL, "skip shadow rays", NULL },
    [O_DEBUG] = { "debug", 0, "VIEW", "normals|depth|id|heat (sphere tests per pixel)", NULL },
    [O_STATS] = { "stats", 0, NULL, "count and print per-ray traversal statistics", NULL },
    [O_MAX_TRIS] = { "max-triangles", 0, "N", "refuse larger scenes", "50000000" },
    [O_QUIET] = { "quiet", 'q', NULL, "no progress bar, no summary", NULL },
};

_Static_assert(SC_SCENE_DEFAULT_MAX_TRIANGLES == 50000000ull, "--max-triangles states the loader's default");

typedef struct args {
    const char *scene, *out;
    long width, height, leaf, threads, ao;
    unsigned long long seed, max_tris;
    int stats, quiet, shadows;
    sc_prefilter_mode prefilter;
    sc_tri_test tri;
    sc_render_debug debug;
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

static void on_progress(void *ctx, double f)
{
    int *last = ctx;
    int pct = (int)(f * 100);
    if (pct == *last)
        return;
    *last = pct;
    int bar = pct * 40 / 100;
    fprintf(stderr, "\r[%.*s%*s] %3d%%", bar, "========================================", 40 - bar, "", pct);
    fflush(stderr);
}

static int run(int argc, char **argv)
{
    args a = { .out = "render.png", .leaf = 8, .seed = 1, .shadows = 1, .prefilter = SC_PREFILTER_AUTO,
               .tri = SC_TRI_WATERTIGHT, .debug = SC_RENDER_SHADED };
    int rc = sc_cli_parse(&sc_cli_render, argc, argv, on_option, &a);
    if (rc)
        return rc < 0 ? 0 : rc;
    if (!a.scene) {
        sc_cli_error(CMD, "no scene given (try --help)");
        return 2;
    }
    const char *scene_path = a.scene, *out_path = a.out;
    long width = a.width, height = a.height, leaf = a.leaf, threads = a.threads, ao = a.ao;
    unsigned long long seed = a.seed, max_tris = a.max_tris;
    int stats_on = a.stats, quiet = a.quiet, shadows = a.shadows;
    sc_prefilter_mode prefilter = a.prefilter;
    sc_tri_test tri = a.tri;
    sc_render_debug debug = a.debug;

    sc_scene_options so;
    sc_scene_options_init(&so);
    so.max_triangles = max_tris;
    so.warn = on_warning;
    char err[1024];
    sc_scene *scene = NULL;
    sc_status st = sc_scene_load(scene_path, &so, &scene, err, sizeof err);
    if (st != SC_OK) {
        sc_cli_error(CMD, "%s", err);
        return 1;
    }
    sc_scene_view view;
    sc_scene_get_view(scene, &view);
    if (width || height) {
        sc_camera cam = view.camera;
        /* One side given: keep the scene's aspect ratio. */
        if (width && !height)
            height = (long)((double)width * cam.height / cam.width + 0.5);
        else if (height && !width)
            width = (long)((double)height * cam.width / cam.height + 0.5);
        cam.width = (int)(width < 1 ? 1 : width);
        cam.height = (int)(height < 1 ? 1 : height);
        st = sc_scene_set_camera(scene, &cam);
        if (st != SC_OK) {
            sc_cli_error(CMD, "a %dx%d image is %s", cam.width, cam.height,
                         st == SC_ERR_LIMIT ? "over the pixel cap" : "not possible");
            sc_scene_free(scene);
            return st == SC_ERR_LIMIT ? 1 : 2;
        }
        sc_scene_get_view(scene, &view);
    }

    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    cfg.leaf_size = (int)leaf;
    cfg.prefilter = prefilter;
    cfg.tri_test = tri;
    cfg.threads = (int)threads;          /* 0 (the default): every CPU, as the render */
    sc_bvh *bvh = NULL;
    st = sc_bvh_build(&view.mesh, &cfg, &bvh);
    if (st != SC_OK) {
        sc_cli_error(CMD, "building the BVH failed: %s", sc_strerror(st));
        sc_scene_free(scene);
        return 1;
    }
    sc_bvh_info info;
    sc_bvh_get_info(bvh, &info);

    sc_render_options ro;
    sc_render_options_init(&ro);
    ro.debug = debug;
    ro.ao_samples = (int)ao;
    ro.seed = seed;
    ro.threads = (int)threads;
    ro.shadows = shadows;
    ro.trace_stats = stats_on;
    int last = -1;
    if (!quiet && isatty(STDERR_FILENO)) {
        ro.progress = on_progress;
        ro.progress_ctx = &last;
    }
    sc_image img = { 0, 0, NULL };
    sc_render_stats rs;
    st = sc_render(&view, bvh, &ro, &img, &rs);
    if (ro.progress)
        fputs("\r\033[K", stderr);
    if (st != SC_OK) {
        sc_cli_error(CMD, "rendering failed: %s", sc_strerror(st));
        sc_bvh_free(bvh);
        sc_scene_free(scene);
        return 1;
    }
    st = sc_png_write(out_path, &img, err, sizeof err);
    if (st != SC_OK) {
        sc_cli_error(CMD, "%s", err);
        sc_image_free(&img);
        sc_bvh_free(bvh);
        sc_scene_free(scene);
        return 1;
    }
    if (!quiet) {
        sc_scene_stats ss;
        sc_scene_get_stats(scene, &ss);
        printf("%s: %zu triangles (scene %.1f B/tri), BVH %.3f s (leaf %d, prefilter %s, %s, %.1f B/tri)",
               scene_path, ss.triangles, ss.bytes_per_triangle, info.build_seconds, info.leaf_size,
               sc_prefilter_mode_name(info.prefilter), sc_isa_name(sc_isa_active()),
               info.triangles ? (double)info.total_bytes / (double)info.triangles : 0.0);
        uint64_t rays = rs.primary_rays + rs.shadow_rays + rs.ao_rays;
        printf(", %.2f M rays in %.3f s = %.2f Mrays/s%s", (double)rays * 1e-6, rs.seconds,
               rs.seconds > 0 ? (double)rays * 1e-6 / rs.seconds : 0.0,
               stats_on ? " (with counters)" : "");
        printf(" -> %s (%dx%d)\n", out_path, img.width, img.height);
        if (stats_on && rs.trace.rays) {
            double n = (double)rs.trace.rays;
            printf("per ray: %.2f nodes, %.2f leaves, %.2f sphere tests (%.1f%% rejected), %.2f triangle tests, %.3f hits"
                   " [%llu primary, %llu shadow, %llu AO rays]\n",
                   (double)rs.trace.nodes / n, (double)rs.trace.leaves / n, (double)rs.trace.sphere_tests / n,
                   rs.trace.sphere_tests ? 100.0 * (double)rs.trace.sphere_rejects / (double)rs.trace.sphere_tests : 0.0,
                   (double)rs.trace.tri_tests / n, (double)rs.trace.tri_hits / n,
                   (unsigned long long)rs.primary_rays, (unsigned long long)rs.shadow_rays,
                   (unsigned long long)rs.ao_rays);
        }
    }
    sc_image_free(&img);
    sc_bvh_free(bvh);
    sc_scene_free(scene);
    return 0;
}

const sc_cli_cmd sc_cli_render = {
    .name = "render",
    .operands = "SCENE",
    .summary = "trace a scene to a PNG: Lambert, shadows, AO, debug views",
    .details = "Traces SCENE with the sphere-prefiltered BVH and writes an RGB PNG.\n"
               "SCENE is a scenes/*.json file, a mesh file assimp reads (the camera frames it),\n"
               "proc:sphere|soup|slivers|terrain:N, proc:grid:MESH:N or cache:NAME\n"
               "(scripts/fetch-meshes.sh fills the mesh cache).\n",
    .opts = opts,
    .nopts = SC_NAMES_COUNT(opts),
    .run = run,
};
