/* spherecull raster-check: the OSMesa ID buffer against primary-ray hits
 * of our tracer (and Embree when built in); src/compare/raster_check.c
 * traces and classifies, this file parses, prints and writes the CSVs,
 * maps and overlay. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "common/sc_csv.h"
#include "common/sc_names.h"
#include "raster_images.h"
#include "spherecull/sc_bvh.h"
#ifdef SC_HAVE_OSMESA
#include "compare/raster_check.h"
#endif

#define CMD "raster-check"

enum { O_CSV = 0, O_PIXELS, O_MAP, O_OVERLAY, O_PREFILTER, O_NO_EMBREE, NOWN };
static const sc_cli_opt opts[] = {
    { "csv", 0, "FILE", "one summary row per tracer", NULL },
    { "pixels", 0, "FILE", "CSV of every disagreement", NULL },
    { "map", 0, "MAP.png", "disagreements as dots over a dark preview", NULL },
    { "overlay", 0, "FILE.png", "our sphere tests per pixel, log colour scale over the preview", NULL },
    { "prefilter", 0, "MODE", "off|circum|minimal|auto: our BVH's prefilter", "minimal" },
    { "no-embree", 0, NULL, "check our tracer only", NULL },
    SC_RASTER_COMMON_OPTS,
};


typedef struct args {
    raster_args r;
    const char *csv, *pixels, *map, *overlay;
    sc_prefilter_mode prefilter;
    int no_embree;
} args;

static int on_option(void *ctx, int opt, const char *val)
{
    args *a = ctx;
    switch (opt) {
    case O_CSV: a->csv = val; return 0;
    case O_PIXELS: a->pixels = val; return 0;
    case O_MAP: a->map = val; return 0;
    case O_OVERLAY: a->overlay = val; return 0;
    case O_NO_EMBREE: a->no_embree = 1; return 0;
    case O_PREFILTER:
        if (sc_prefilter_mode_from_name(val, &a->prefilter) != SC_OK) {
            sc_cli_error(CMD, "--prefilter is off, circum, minimal or auto, not '%s'", val);
            return 2;
        }
        return 0;
    }
    return raster_common_option(CMD, opt < 0 ? -1 : opt - NOWN, val, &a->r);
}

#ifdef SC_HAVE_OSMESA
typedef struct report {
    const char *scene;
    const sc_raster_image *img;
    const sc_rcheck *check;
    const loaded *L;
} report;

static int write_summary_csv(void *ctx, FILE *f)
{
    const report *r = ctx;
    size_t n = (size_t)r->img->width * (size_t)r->img->height;
    fprintf(f, "scene,tracer,width,height,depth_mode,pixels,agree,agree_pct,at_edge,depth_tie,elsewhere,max_edge_px\n");
    for (int k = 0; k < r->check->ntr; k++) {
        const sc_rcheck_tracer *t = &r->check->tr[k];
        sc_csv_str(f, r->scene);
        fprintf(f, ",%s,%d,%d,%s,%zu,%zu,%.4f,%zu,%zu,%zu,%.4f\n", t->name, r->img->width, r->img->height,
                r->img->depth_mode == SC_RASTER_DEPTH_FIXED24 ? "fixed24" : "float", n, t->agree,
                100.0 * (double)t->agree / (double)n, t->kinds[SC_RASTER_DIFF_AT_EDGE],
                t->kinds[SC_RASTER_DIFF_DEPTH_TIE], t->kinds[SC_RASTER_DIFF_ELSEWHERE], t->max_edge_px);
    }
    return 0;
}

/* Every disagreement, one row each. */
static int write_pixels_csv(void *ctx, FILE *f)
{
    const report *r = ctx;
    const sc_raster_image *img = r->img;
    fprintf(f, "tracer,x,y,raster_prim,tracer_prim,class,edge_px\n");
    for (int k = 0; k < r->check->ntr; k++) {
        const sc_rcheck_tracer *t = &r->check->tr[k];
        for (int y = 0; y < img->height; y++)
            for (int x = 0; x < img->width; x++) {
                size_t p = (size_t)y * (size_t)img->width + (size_t)x;
                if (!t->cls[p])
                    continue;
                double dist = NAN;
                sc_raster_edge_distance(&r->L->mesh, &r->L->cam, img->near_dist, x, y, img->ids[p], t->ids[p],
                                        &dist);
                fprintf(f, "%s,%d,%d,%ld,%ld,%s,%.4f\n", t->name, x, y, (long)img->ids[p] - 1, (long)t->ids[p] - 1,
                        sc_raster_diff_name((sc_raster_diff)(t->cls[p] - 1)), dist);
            }
    }
    return 0;
}

static void print_summary(const args *a, const sc_raster_image *img, const sc_rcheck *c, size_t tris, double raster_s)
{
    size_t npix = (size_t)img->width * (size_t)img->height;
    printf("scene      %s: %zu triangles\n", a->r.scene, tris);
    printf("raster     %dx%d, %s depth (%d bits), near %.6g, %.3f s\n", img->width, img->height,
           raster_depth_mode_name(img->depth_mode), img->depth_bits, img->near_dist, raster_s);
    printf("ours       BVH (prefilter %s) built in %.3f s, %zu rays traced in %.3f s\n",
           sc_prefilter_mode_name(a->prefilter), c->build_seconds, c->rays, c->tr[0].seconds);
    printf("%-8s %10s %10s %9s %9s %9s %9s %12s\n", "tracer", "pixels", "agree", "agree%", "at-edge", "depth-tie",
           "elsewhere", "max-edge-px");
    for (int k = 0; k < c->ntr; k++) {
        const sc_rcheck_tracer *t = &c->tr[k];
        printf("%-8s %10zu %10zu %8.4f%% %9zu %9zu %9zu %12.4f\n", t->name, npix, t->agree,
               100.0 * (double)t->agree / (double)npix, t->kinds[SC_RASTER_DIFF_AT_EDGE],
               t->kinds[SC_RASTER_DIFF_DEPTH_TIE], t->kinds[SC_RASTER_DIFF_ELSEWHERE], t->max_edge_px);
    }
    /* The first few "elsewhere" pixels, to start debugging from. */
    for (int k = 0; k < c->ntr; k++) {
        const sc_rcheck_tracer *t = &c->tr[k];
        int shown = 0;
        for (size_t p = 0; p < npix && shown < 5; p++)
            if (t->cls[p] == 1 + SC_RASTER_DIFF_ELSEWHERE) {
                printf("  %s elsewhere: pixel %zu,%zu raster prim %ld, %s prim %ld\n", t->name,
                       p % (size_t)img->width, p / (size_t)img->width, (long)img->ids[p] - 1, t->name,
                       (long)t->ids[p] - 1);
                shown++;
            }
    }
}

/* CSVs, maps (Embree's gets '-embree' before the extension) and overlay. */
static int write_outputs(const args *a, const sc_raster_image *img, const sc_rcheck *c, const loaded *L)
{
    report rep = { a->r.scene, img, c, L };
    if ((a->csv && sc_cli_write(CMD, a->csv, write_summary_csv, &rep) != 0) ||
        (a->pixels && sc_cli_write(CMD, a->pixels, write_pixels_csv, &rep) != 0))
        return 0;
    for (int k = 0; a->map && k < c->ntr; k++) {
        char *path = k == 0 ? (char *)a->map : raster_suffixed(a->map, c->tr[k].name);
        int ok = path && raster_write_map(CMD, path, img, c->tr[k].cls);
        if (ok)
            printf("map        %s: %s\n", c->tr[k].name, path);
        if (k > 0)
            free(path);
        if (!ok)
            return 0;
    }
    if (a->overlay) {
        uint32_t mx = 0;
        if (!raster_write_overlay(CMD, a->overlay, img, c->tests, &mx))
            return 0;
        const sc_tracer_counters *w = &c->work;
        double npix = (double)img->width * (double)img->height;
        printf("overlay    %s: sphere tests per pixel, log scale, max %u; mean %.2f tests, "
               "%.2f passed, %.2f triangle tests, %.3f hits per ray\n",
               a->overlay, (unsigned)mx, (double)w->sphere_tests / npix,
               (double)(w->sphere_tests - w->sphere_rejects) / npix, (double)w->tri_tests / npix,
               (double)w->tri_hits / npix);
    }
    return 1;
}

static int check(const args *a)
{
    int rc = 1;
    loaded L;
    sc_raster_image img = { 0 };
    sc_rcheck c;
    memset(&c, 0, sizeof c);
    double raster_s = 0;
    char err[256] = "";
    if (!raster_load(CMD, &a->r, &L) || !raster_render(CMD, &L, &img, &raster_s))
        goto done;
    if (sc_rcheck_run(&L.mesh, &L.cam, &img, a->prefilter, !a->no_embree, a->overlay != NULL, &c, err, sizeof err) !=
        SC_OK) {
        sc_cli_error(CMD, "%s", err);
        goto done;
    }
    print_summary(a, &img, &c, L.mesh.triangle_count, raster_s);
    if (!write_outputs(a, &img, &c, &L))
        goto done;
    size_t npix = (size_t)img.width * (size_t)img.height;
    if (!sc_rcheck_target_met(&c, npix)) {
        sc_cli_error(CMD, "ours misses the target: %.4f%% agreement (>= 99.5%%), %zu elsewhere (0)",
                     100.0 * (double)c.tr[0].agree / (double)npix, c.tr[0].kinds[SC_RASTER_DIFF_ELSEWHERE]);
        goto done;
    }
    rc = 0;
done:
    sc_rcheck_free(&c);
    sc_raster_image_free(&img);
    raster_unload(&L);
    return rc;
}
#else
static int check(const args *a)
{
    (void)a;
    return raster_unavailable(CMD);
}
#endif

static int run(int argc, char **argv)
{
    args a;
    memset(&a, 0, sizeof a);
    a.prefilter = SC_PREFILTER_MINIMAL;
    int rc = sc_cli_parse(&sc_cli_raster_check, argc, argv, on_option, &a);
    if (rc)
        return rc < 0 ? 0 : rc;
    if (!a.r.scene) {
        sc_cli_error(CMD, "needs a SCENE (try --help)");
        return 2;
    }
    if (sc_cli_check_output(CMD, "--csv", a.csv) != 0 || sc_cli_check_output(CMD, "--pixels", a.pixels) != 0 ||
        sc_cli_check_output(CMD, "--map", a.map) != 0 || sc_cli_check_output(CMD, "--overlay", a.overlay) != 0)
        return 1;
    return check(&a);
}

const sc_cli_cmd sc_cli_raster_check = {
    .name = "raster-check",
    .operands = "SCENE",
    .summary = "raster ID buffer vs tracer primary hits: agreement, map, overlay",
    .details = "Compares the OSMesa triangle-ID buffer with the primary-ray hits of our tracer\n"
               "(and of Embree, when built in). Each disagreement is at-edge (pixel centre within\n"
               "half a pixel of a projected edge of either triangle), depth-tie (both triangles\n"
               "cover the centre at depths the raster cannot order) or elsewhere (a bug).\n"
               "MAP: 3x3 dots, at-edge amber, depth-tie blue, elsewhere red.\n"
               "Exit status 1 if ours misses the target (>= 99.5% agreement, 0 elsewhere).\n",
    .opts = opts,
    .nopts = SC_NAMES_COUNT(opts),
    .run = run,
};
