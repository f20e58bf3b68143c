/* spherecull bench-render: one path-traced frame per scene on our tracer
 * and on Embree (the measuring is src/compare/bench_render.c); this file
 * parses, prints the table, writes the CSV and the frames. */
#define _GNU_SOURCE
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "common/sc_atomic_file.h"
#include "common/sc_csv.h"
#include "common/sc_names.h"
#include "compare/bench_render.h"
#include "spherecull/sc_isa.h"
#include "spherecull/sc_scene.h"
#include "x86/cpu_features.h"
#ifdef SC_HAVE_EMBREE
#include "spherecull/sc_embree.h"
#endif

#define CMD "bench-render"

enum { O_CSV, O_IMAGES, O_SPP, O_BOUNCES, O_REPEATS, O_THREADS, O_TRACERS, O_WIDTH, O_HEIGHT, O_SEED,
       O_TRIANGLE, O_EXPOSURE };
static const sc_cli_opt opts[] = {
    [O_CSV] = { "csv", 0, "FILE", "also write one row per scene x threads x tracer", NULL },
    [O_IMAGES] = { "images", 0, "DIR", "write each tracer's frame (first thread count) as DIR/SCENE-TRACER.png",
                   NULL },
    [O_SPP] = { "spp", 0, "N", "samples per pixel", "16" },
    [O_BOUNCES] = { "bounces", 0, "B", "surface scatterings per path", "4" },
    [O_REPEATS] = { "repeats", 0, "R", "paired repeats per measurement, median", "5" },
    [O_THREADS] = { "threads", 0, "LIST", "render thread counts, e.g. 1,2", "1,2" },
    [O_TRACERS] = { "tracers", 0, "LIST", "first is the reference: spherecull or any tracer of 'compare'",
                    "spherecull,embree,embree-high,embree-robust" },
    [O_WIDTH] = { "width", 0, "W", "frame width; the height keeps the scene's aspect", "the scene's" },
    [O_HEIGHT] = { "height", 0, "H", "frame height", "from the width" },
    [O_SEED] = { "seed", 0, "S", "seed of the per-pixel streams", "1" },
    [O_TRIANGLE] = { "triangle", 0, "TEST", "watertight|moller|exact: spherecull's triangle test", "watertight" },
    [O_EXPOSURE] = { "exposure", 0, "EV", "tone map of the written frames", "0" },
};

typedef struct args {
    sc_bench_render_options o;
    const char *csv, *images;
    const char *scenes[64];
    int nscenes;
    long width, height;
    char tracer_buf[256];
} args;

static int parse_tracers(args *a, const char *val)
{
    if (strlen(val) >= sizeof a->tracer_buf)
        return -1;
    snprintf(a->tracer_buf, sizeof a->tracer_buf, "%s", val);
    a->o.ntracers = 0;
    char *save = NULL;
    for (char *tok = strtok_r(a->tracer_buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
        if (a->o.ntracers == SC_BENCH_RENDER_MAX_TRACERS || (strcmp(tok, "spherecull") && !sc_tracer_find(tok)))
            return -1;
        a->o.tracers[a->o.ntracers++] = tok;
    }
    return a->o.ntracers > 0 ? 0 : -1;
}

static int on_option(void *ctx, int opt, const char *val)
{
    args *a = ctx;
    sc_bench_render_options *o = &a->o;
    const char *name = opt >= 0 ? opts[opt].name : "";
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
    case O_IMAGES: a->images = val; return 0;
    case O_SPP: if (sc_cli_int(CMD, name, val, 1, 65536, &v)) return 2; o->spp = (int)v; return 0;
    case O_BOUNCES: if (sc_cli_int(CMD, name, val, 0, 64, &v)) return 2; o->bounces = (int)v; return 0;
    case O_REPEATS:
        if (sc_cli_int(CMD, name, val, 1, SC_BENCH_MAX_REPEATS, &v))
            return 2;
        o->repeats = (int)v;
        return 0;
    case O_THREADS:
        return (o->nthreads = sc_cli_int_list(CMD, name, val, 1, 1024, o->threads, SC_BENCH_MAX_LIST)) < 0 ? 2 : 0;
    case O_TRACERS:
        if (parse_tracers(a, val) == 0)
            return 0;
        sc_cli_error(CMD, "--tracers takes 1..%d of spherecull and the tracers 'compare --help' lists, not '%s'",
                     SC_BENCH_RENDER_MAX_TRACERS, val);
        return 2;
    case O_WIDTH: return sc_cli_int(CMD, name, val, 1, SC_SCENE_MAX_IMAGE_SIDE, &a->width) ? 2 : 0;
    case O_HEIGHT: return sc_cli_int(CMD, name, val, 1, SC_SCENE_MAX_IMAGE_SIDE, &a->height) ? 2 : 0;
    case O_SEED: {
        unsigned long long s;
        if (sc_cli_u64(CMD, name, val, &s))
            return 2;
        o->seed = s;
        return 0;
    }
    case O_TRIANGLE:
        if (sc_tri_test_from_name(val, &o->bvh.tri_test) == SC_OK)
            return 0;
        break;
    case O_EXPOSURE: return sc_cli_double(CMD, name, val, -64, 64, &o->exposure) ? 2 : 0;
    }
    sc_cli_error(CMD, "--%s takes %s, not '%s'", name, opts[opt].help, val);
    return 2;
}

typedef struct printer {
    const char *spec;
    const args *a;
    FILE *csv;
    size_t triangles;
    int failed;
    char embree_build[128];
} printer;

/* DIR/SCENE-TRACER.png with the scene spec's base name, '.' and ':' kept
 * out of the way. */
static void image_path(const printer *p, const char *tracer, char *buf, size_t n)
{
    const char *base = strrchr(p->spec, '/');
    base = base ? base + 1 : p->spec;
    char name[128];
    size_t k = 0;
    for (const char *c = base; *c && k + 1 < sizeof name; c++)
        name[k++] = (*c == ':' || *c == '.' || *c == ' ') ? '_' : *c;
    name[k] = 0;
    snprintf(buf, n, "%s/%s-%s.png", p->a->images, name, tracer);
}

static void print_row(void *ctx, const sc_bench_render_row *r)
{
    printer *p = ctx;
    char ratio[48] = "";
    if (!isnan(r->x_best_embree))
        snprintf(ratio, sizeof ratio, "%.3fx %s", r->x_best_embree, r->best_embree);
    char diff[64] = "reference";
    if (r->differ_edge || r->differ_elsewhere || strcmp(r->tracer, p->a->o.tracers[0]))
        snprintf(diff, sizeof diff, "%zu / %zu", r->differ_elsewhere, r->differ_edge);
    /* The table shows the file name; the CSV has the whole spec. */
    const char *shown = strrchr(p->spec, '/') ? strrchr(p->spec, '/') + 1 : p->spec;
    printf("%-26.26s %3d  %-14s %8.3f %9.3f %8.2f  %-22s %-14s %6.2f%%\n", shown, r->threads, r->tracer,
           r->build_s, r->frame_s, r->mrays, ratio, diff, 100.0 * (double)r->edge_pixels / (double)r->pixels);
    fflush(stdout);
    sc_csv_str(p->csv, p->spec);
    fprintf(p->csv, ",%zu,%d,%d,%d,%d,%d,", p->triangles, r->image->width, r->image->height, p->a->o.spp,
            p->a->o.bounces, r->threads);
    sc_csv_str(p->csv, r->tracer);
    fprintf(p->csv, ",%.4f,%.5f,%llu,%.4f,%.4f,", r->build_s, r->frame_s, (unsigned long long)r->rays, r->mrays,
            r->x_best_embree);
    sc_csv_str(p->csv, r->best_embree ? r->best_embree : "");
    fprintf(p->csv, ",%zu,%zu,%zu,%zu,%.3g,", r->pixels, r->edge_pixels, r->differ_edge, r->differ_elsewhere,
            r->max_rel_diff_elsewhere);
    sc_csv_str(p->csv, p->embree_build);
    fputc('\n', p->csv);
    if (p->a->images && r->threads == p->a->o.threads[0]) {
        char path[1024], err[512];
        image_path(p, r->tracer, path, sizeof path);
        if (sc_png_write(path, r->image, err, sizeof err) != SC_OK) {
            sc_cli_error(CMD, "%s", err);
            p->failed = 1;
        }
    }
}

static int bench_scene(printer *p, const char *spec)
{
    sc_scene_options so;
    sc_scene_options_init(&so);
    char err[1024] = "";
    sc_scene *scene = NULL;
    if (sc_scene_load(spec, &so, &scene, err, sizeof err) != SC_OK) {
        sc_cli_error(CMD, "%s", err);
        return 1;
    }
    sc_scene_view v;
    sc_scene_get_view(scene, &v);
    if (p->a->width || p->a->height) {
        sc_camera cam = v.camera;
        long w = p->a->width, h = p->a->height;
        if (w && !h)
            h = (long)((double)w * cam.height / cam.width + 0.5);
        else if (h && !w)
            w = (long)((double)h * cam.width / cam.height + 0.5);
        cam.width = (int)(w < 1 ? 1 : w);
        cam.height = (int)(h < 1 ? 1 : h);
        if (sc_scene_set_camera(scene, &cam) != SC_OK) {
            sc_cli_error(CMD, "%s: a %dx%d frame is not possible", spec, cam.width, cam.height);
            sc_scene_free(scene);
            return 1;
        }
        sc_scene_get_view(scene, &v);
    }
    p->spec = spec;
    p->triangles = v.mesh.triangle_count;
    sc_bench_render_sink sink = { print_row, p };
    sc_status st = sc_bench_render_run(&v, &p->a->o, &sink, err, sizeof err);
    sc_scene_free(scene);
    if (st != SC_OK) {
        sc_cli_error(CMD, "%s: %s", spec, err[0] ? err : sc_strerror(st));
        return 1;
    }
    return p->failed;
}

static int run(int argc, char **argv)
{
    args a;
    memset(&a, 0, sizeof a);
    sc_bench_render_options_default(&a.o);
    int rc = sc_cli_parse(&sc_cli_bench_render, argc, argv, on_option, &a);
    if (rc)
        return rc < 0 ? 0 : rc;
    if (a.nscenes == 0) {
        sc_cli_error(CMD, "no SCENE given (try --help)");
        return 2;
    }
    if (sc_cli_check_output(CMD, "--csv", a.csv) != 0)
        return 1;
    printer p = { .a = &a };
    snprintf(p.embree_build, sizeof p.embree_build, "none");
#ifdef SC_HAVE_EMBREE
    if (sc_embree_version(p.embree_build, sizeof p.embree_build) != SC_OK)
        snprintf(p.embree_build, sizeof p.embree_build, "no device");
#endif
    char cpu[64];
    sc_x86_brand(cpu);
    printf("# cpu: %s (%ld online), isa %s\n", cpu, sysconf(_SC_NPROCESSORS_ONLN), sc_isa_name(sc_isa_active()));
    printf("# embree: %s (traced with FTZ|DAZ)\n", p.embree_build);
    printf("# path tracer: %d spp, %d bounces, seed %llu; frame time = median of %d paired repeats (rendering "
           "only);\n# ratio = best Embree frame time / ours (> 1: ours faster); differ = pixels whose radiance "
           "differs by\n# > %g relative from the first tracer's, away from / near triangle edges; edge%% = pixels "
           "with a path\n# vertex within %g (barycentric) of an edge. Differences far from edges against Embree's default\n"
           "# builds are rays slipping through shared edges there (not watertight): embree-robust must show none\n",
           a.o.spp, a.o.bounces, (unsigned long long)a.o.seed, a.o.repeats, a.o.tolerance, SC_RENDER_EDGE_BARY);
    printf("%-26s %3s  %-14s %8s %9s %8s  %-22s %-14s %7s\n", "scene", "thr", "tracer", "build_s", "frame_s",
           "Mrays/s", "ratio (best Embree)", "differ far/edge", "edge%");
    char *text = NULL;
    size_t len = 0;
    FILE *csv = open_memstream(&text, &len);
    if (!csv) {
        sc_cli_error(CMD, "out of memory");
        return 1;
    }
    p.csv = csv;
    fprintf(csv, "scene,triangles,width,height,spp,bounces,threads,tracer,build_s,frame_s,rays,mrays,"
                 "x_best_embree,best_embree,pixels,edge_pixels,differ_edge,differ_elsewhere,"
                 "max_rel_diff_elsewhere,embree_build\n");
    for (int s = 0; s < a.nscenes && rc == 0; s++)
        rc = bench_scene(&p, a.scenes[s]);
    if (fclose(csv) != 0 && rc == 0) {
        sc_cli_error(CMD, "out of memory for the CSV");
        rc = 1;
    }
    if (rc == 0 && a.csv && sc_write_atomic_bytes(a.csv, text, len) != 0) {
        sc_cli_error(CMD, "cannot write %s: %s", a.csv, strerror(errno));
        rc = 1;
    }
    free(text);
    return rc;
}

const sc_cli_cmd sc_cli_bench_render = {
    .name = "bench-render",
    .operands = "SCENE...",
    .summary = "path-traced frame time on our tracer against Embree, and the images compared",
    .details = "Renders one path-traced frame per SCENE with each tracer (same rays, same seeds, same\n"
               "options), prints the median frame time, Mrays/s and the ratio against the best Embree\n"
               "build, and compares every frame with the first tracer's pixel by pixel.\n"
               "SCENE: a scenes/*.json file, a mesh file assimp reads, proc:KIND:N or cache:NAME.\n",
    .opts = opts,
    .nopts = SC_NAMES_COUNT(opts),
    .run = run,
};
