/* Per-tile render times of one frame, for the scale-out model
 * (docs/scale-out.md): how long a 16 x 16 tile takes, and how much tiles
 * differ, which bounds what a dynamic hand-out of tiles to N ranks loses
 * at the end of a frame. One render thread, so the time between two
 * requests for a tile is one tile's time.
 *
 *   bench_tiles SCENE [SPP] [BOUNCES]      (path tracer; default 16 spp, 4 bounces) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/sc_clock.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_render.h"
#include "spherecull/sc_scene.h"

typedef struct {
    int next;
    double last;
    double *times;
    int n, cap;
} tile_clock;

static int next_tile(void *ctx)
{
    tile_clock *c = ctx;
    double now = sc_now_seconds();
    if (c->next > 0 && c->n < c->cap)
        c->times[c->n++] = now - c->last;
    c->last = now;
    return c->next++;
}

static sc_status combine(void *ctx, sc_status local, float *color, float *value, size_t pixels,
                         sc_render_stats *stats)
{
    (void)ctx, (void)color, (void)value, (void)pixels, (void)stats;
    return local;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: bench_tiles SCENE [SPP] [BOUNCES]\n");
        return 2;
    }
    char err[512];
    sc_scene *scene = NULL;
    double t0 = sc_now_seconds();
    if (sc_scene_load(argv[1], NULL, &scene, err, sizeof err) != SC_OK) {
        fprintf(stderr, "bench_tiles: %s\n", err);
        return 1;
    }
    double t_load = sc_now_seconds() - t0;
    sc_scene_view v;
    sc_scene_get_view(scene, &v);
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    cfg.threads = 1;
    sc_bvh *bvh = NULL;
    t0 = sc_now_seconds();
    if (sc_bvh_build(&v.mesh, &cfg, &bvh) != SC_OK) {
        fprintf(stderr, "bench_tiles: BVH build failed\n");
        return 1;
    }
    double t_build = sc_now_seconds() - t0;
    const int ntiles = ((v.camera.width + 15) / 16) * ((v.camera.height + 15) / 16);
    tile_clock c = { 0, 0, calloc((size_t)ntiles + 1, sizeof(double)), 0, ntiles + 1 };
    if (!c.times)
        return 1;
    sc_render_tiles hook = { next_tile, combine, &c };
    sc_render_options o;
    sc_render_options_init(&o);
    o.integrator = SC_RENDER_PATH;
    o.spp = argc > 2 ? atoi(argv[2]) : 16;
    o.bounces = argc > 3 ? atoi(argv[3]) : 4;
    o.threads = 1;
    o.tiles = &hook;
    sc_image img = { 0, 0, NULL };
    sc_render_stats rs;
    if (sc_render(&v, bvh, &o, &img, &rs) != SC_OK) {
        fprintf(stderr, "bench_tiles: render failed\n");
        return 1;
    }
    qsort(c.times, (size_t)c.n, sizeof(double), cmp_double);
    double sum = 0, sq = 0;
    for (int i = 0; i < c.n; i++)
        sum += c.times[i], sq += c.times[i] * c.times[i];
    double mean = sum / c.n, sd = sqrt(fmax(0, sq / c.n - mean * mean));
    printf("%s: %zu triangles, %dx%d, %d spp, %d bounces; load %.3f s, build %.3f s (1 thread); "
           "frame %.3f s (1 thread)\n",
           argv[1], v.mesh.triangle_count, v.camera.width, v.camera.height, o.spp, o.bounces, t_load, t_build,
           rs.seconds);
    printf("tiles %d: mean %.2f ms, sd %.2f ms (cv %.2f), min %.2f, median %.2f, p95 %.2f, max %.2f ms\n", c.n,
           1e3 * mean, 1e3 * sd, sd / mean, 1e3 * c.times[0], 1e3 * c.times[c.n / 2],
           1e3 * c.times[(int)(0.95 * (c.n - 1))], 1e3 * c.times[c.n - 1]);
    sc_image_free(&img);
    sc_bvh_free(bvh);
    sc_scene_free(scene);
    free(c.times);
    return 0;
}
