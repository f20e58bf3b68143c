/* spherecull render: a scene in, a PNG out. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "commands.h"
#include "spherecull/sc_isa.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_image.h"
#include "spherecull/sc_render.h"
#include "spherecull/sc_scene.h"

#define CMD "render"

static void help(FILE *f)
{
    fprintf(f,
            "usage: spherecull render SCENE [-o out.png] [options]\n"
            "\n"
            "Traces SCENE with the sphere-prefiltered BVH and writes an RGB PNG.\n"
            "SCENE is a scenes/*.json file, a mesh file assimp reads (the camera frames it),\n"
            "proc:sphere|soup|slivers|terrain:N, proc:grid:MESH:N or cache:NAME\n"
            "(scripts/fetch-meshes.sh fills the mesh cache).\n"
            "\n"
            "  -o, --output FILE     PNG to write (default render.png); written atomically\n"
            "  --width W, --height H image size (default: the scene's)\n"
            "  --prefilter MODE      off | circum | minimal | auto (default auto)\n"
            "  --leaf N              triangles per BVH leaf, 1..%d (default 8)\n"
            "  --threads N           render threads (default: all)\n"
            "  --isa ISA             auto | scalar | sse4 | avx2 | avx512: every kernel (default auto)\n"
            "  --triangle TEST       watertight | moller | exact (default watertight)\n"
            "  --ao N                ambient-occlusion samples per pixel (default 0)\n"
            "  --seed S              seed for AO directions (default 1)\n"
            "  --no-shadows          skip shadow rays\n"
            "  --debug VIEW          normals | depth | id | heat (sphere tests per pixel)\n"
            "  --stats               count and print per-ray traversal statistics\n"
            "  --max-triangles N     refuse larger scenes (default %llu)\n"
            "  -q, --quiet           no progress bar, no summary\n"
            "  -h, --help            this text\n",
            SC_BVH_MAX_LEAF, (unsigned long long)SC_SCENE_DEFAULT_MAX_TRIANGLES);
}

static int parse_int(const char *s, long lo, long hi, long *out)
{
    if (!s || !*s)
        return 0;
    errno = 0;
    char *end;
    long v = strtol(s, &end, 10);
    if (errno || *end || v < lo || v > hi)
        return 0;
    *out = v;
    return 1;
}

static int parse_u64(const char *s, unsigned long long *out)
{
    if (!s || !*s || *s == '-')
        return 0;
    errno = 0;
    char *end;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || *end)
        return 0;
    *out = v;
    return 1;
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

int sc_cmd_render(int argc, char **argv)
{
    const char *scene_path = NULL, *out_path = "render.png";
    long width = 0, height = 0, leaf = 8, threads = 0, ao = 0;
    unsigned long long seed = 1, max_tris = 0;
    int stats_on = 0, quiet = 0, shadows = 1;
    sc_prefilter_mode prefilter = SC_PREFILTER_AUTO;
    int isa = -1;   /* auto: SPHERECULL_ISA or the widest level */
    sc_tri_test tri = SC_TRI_WATERTIGHT;
    sc_render_debug debug = SC_RENDER_SHADED;

    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *val = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            help(stdout);
            return 0;
        } else if (!strcmp(a, "-o") || !strcmp(a, "--output")) {
            if (!val || !*val) {
                sc_cli_error(CMD, "%s needs a file name", a);
                return 2;
            }
            out_path = val, i++;
        } else if (!strcmp(a, "--width") || !strcmp(a, "--height")) {
            long v;
            if (!parse_int(val, 1, SC_SCENE_MAX_IMAGE_SIDE, &v)) {
                sc_cli_error(CMD, "%s needs a whole number of pixels in 1..%d", a, SC_SCENE_MAX_IMAGE_SIDE);
                return 2;
            }
            *(a[2] == 'w' ? &width : &height) = v, i++;
        } else if (!strcmp(a, "--prefilter")) {
            if (!val || sc_prefilter_mode_from_name(val, &prefilter) != SC_OK) {
                sc_cli_error(CMD, "--prefilter takes off, circum, minimal or auto");
                return 2;
            }
            i++;
        } else if (!strcmp(a, "--leaf")) {
            if (!parse_int(val, 1, SC_BVH_MAX_LEAF, &leaf)) {
                sc_cli_error(CMD, "--leaf takes a number in 1..%d", SC_BVH_MAX_LEAF);
                return 2;
            }
            i++;
        } else if (!strcmp(a, "--threads")) {
            if (!parse_int(val, 1, 1024, &threads)) {
                sc_cli_error(CMD, "--threads takes a number in 1..1024");
                return 2;
            }
            i++;
        } else if (!strcmp(a, "--isa")) {
            if (!val || sc_cli_parse_isa(val, &isa) != 0) {
                sc_cli_error(CMD, "--isa takes auto, scalar, sse4, avx2 or avx512");
                return 2;
            }
            i++;
        } else if (!strcmp(a, "--triangle")) {
            if (!val || sc_tri_test_from_name(val, &tri) != SC_OK) {
                sc_cli_error(CMD, "--triangle takes watertight, moller or exact");
                return 2;
            }
            i++;
        } else if (!strcmp(a, "--ao")) {
            if (!parse_int(val, 0, 4096, &ao)) {
                sc_cli_error(CMD, "--ao takes a number of samples in 0..4096");
                return 2;
            }
            i++;
        } else if (!strcmp(a, "--seed")) {
            if (!parse_u64(val, &seed)) {
                sc_cli_error(CMD, "--seed takes a non-negative integer");
                return 2;
            }
            i++;
        } else if (!strcmp(a, "--max-triangles")) {
            if (!parse_u64(val, &max_tris) || max_tris == 0) {
                sc_cli_error(CMD, "--max-triangles takes a positive integer");
                return 2;
            }
            i++;
        } else if (!strcmp(a, "--debug")) {
            if (!val || sc_render_debug_from_name(val, &debug) != SC_OK || debug == SC_RENDER_SHADED) {
                sc_cli_error(CMD, "--debug takes normals, depth, id or heat");
                return 2;
            }
            i++;
        } else if (!strcmp(a, "--stats")) {
            stats_on = 1;
        } else if (!strcmp(a, "--no-shadows")) {
            shadows = 0;
        } else if (!strcmp(a, "-q") || !strcmp(a, "--quiet")) {
            quiet = 1;
        } else if (a[0] == '-' && a[1]) {
            sc_cli_error(CMD, "unknown option '%s' (try --help)", a);
            return 2;
        } else if (!scene_path) {
            scene_path = a;
        } else {
            sc_cli_error(CMD, "more than one scene given ('%s' and '%s')", scene_path, a);
            return 2;
        }
    }
    if (!scene_path) {
        sc_cli_error(CMD, "no scene given (try --help)");
        return 2;
    }
    if (isa >= 0 && sc_isa_force((sc_isa)isa) != SC_OK) {
        sc_cli_error(CMD, "this CPU cannot run the %s kernels", sc_isa_name((sc_isa)isa));
        return 1;
    }

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
    sc_bvh *bvh = NULL;
    st = sc_bvh_build(view.positions, view.num_vertices, view.indices, view.num_triangles, &cfg, &bvh);
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
