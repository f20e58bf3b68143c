/* spherecull raster: the scene rasterized offscreen by OSMesa with the
 * scene's camera: a lit preview, optionally the triangle-ID buffer and a
 * depth picture. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "common/sc_names.h"
#include "raster_images.h"

#define CMD "raster"

enum { O_OUT = 0, O_IDS, O_DEPTH };
static const sc_cli_opt opts[] = {
    { "output", 'o', "PREVIEW.png", "flat-shaded preview, one directional light (required)", NULL },
    { "ids", 0, "IDS.png", "triangle index + 1 as 24-bit RGB (R low byte), black = background", NULL },
    { "depth", 0, "DEPTH.png", "1/t between the nearest and farthest visible pixel, near bright", NULL },
    SC_RASTER_COMMON_OPTS,
};


typedef struct args {
    raster_args r;
    const char *out, *ids, *depth;
} args;

static int on_option(void *ctx, int opt, const char *val)
{
    args *a = ctx;
    if (opt == O_OUT || opt == O_IDS || opt == O_DEPTH) {
        *(opt == O_OUT ? &a->out : opt == O_IDS ? &a->ids : &a->depth) = val;
        return 0;
    }
    return raster_common_option(CMD, opt < 0 ? -1 : opt - 3, val, &a->r);
}

#ifdef SC_HAVE_OSMESA
static int rasterize(const args *a)
{
    int rc = 1;
    loaded L;
    sc_raster_image img = { 0 };
    double secs = 0, tmin = 0, tmax = 0;
    if (!raster_load(CMD, &a->r, &L) || !raster_render(CMD, &L, &img, &secs))
        goto done;
    sc_image prev = { img.width, img.height, img.rgb };
    if (!raster_write_png(CMD, a->out, &prev) ||
        (a->ids && !raster_write_ids(CMD, a->ids, &img, L.mesh.triangle_count)) ||
        (a->depth && !raster_write_depth(CMD, a->depth, &img, &tmin, &tmax)))
        goto done;
    size_t covered = 0;
    for (size_t p = 0; p < (size_t)img.width * (size_t)img.height; p++)
        covered += img.ids[p] != 0;
    printf("scene      %s: %zu triangles, %zu vertices\n", a->r.scene, L.mesh.triangle_count, L.mesh.vertex_count);
    printf("image      %dx%d, %.2f%% covered, raster %.3f s\n", img.width, img.height,
           100.0 * (double)covered / ((double)img.width * img.height), secs);
    printf("depth      %s (%d bits), near %.6g, far %.6g\n", raster_depth_mode_name(img.depth_mode), img.depth_bits,
           img.near_dist, img.far_dist);
    printf("wrote      %s", a->out);
    if (a->ids)
        printf(", %s", a->ids);
    if (a->depth)
        printf(", %s (t from %.6g bright to %.6g dark)", a->depth, tmin, tmax);
    printf("\n");
    rc = 0;
done:
    sc_raster_image_free(&img);
    raster_unload(&L);
    return rc;
}
#else
static int rasterize(const args *a)
{
    (void)a;
    return raster_unavailable(CMD);
}
#endif

static int run(int argc, char **argv)
{
    args a;
    memset(&a, 0, sizeof a);
    int rc = sc_cli_parse(&sc_cli_raster, argc, argv, on_option, &a);
    if (rc)
        return rc < 0 ? 0 : rc;
    if (!a.r.scene || !a.out) {
        sc_cli_error(CMD, "needs SCENE and -o PREVIEW.png (try --help)");
        return 2;
    }
    if (sc_cli_check_output(CMD, "-o", a.out) != 0 || sc_cli_check_output(CMD, "--ids", a.ids) != 0 ||
        sc_cli_check_output(CMD, "--depth", a.depth) != 0)
        return 1;
    return rasterize(&a);
}

const sc_cli_cmd sc_cli_raster = {
    .name = "raster",
    .operands = "SCENE -o PREVIEW.png",
    .summary = "rasterize a scene offscreen (OSMesa): preview, triangle IDs, depth",
    .details = "SCENE: see 'spherecull --help' for scene specs; the scene's camera unless overridden.\n",
    .opts = opts,
    .nopts = SC_NAMES_COUNT(opts),
    .run = run,
};
