/* The tile loop and the direct integrator: primary rays through the back
 * end's closest query, shadow and AO rays through its occlusion query. The
 * path tracer's tiles are in path.c. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "common/sc_clock.h"
#include "common/sc_names.h"
#include "common/sc_rng.h"
#include "render_internal.h"

#define TILE SC_RENDER_TILE
#define PI 3.14159265358979323846

static const char *const debug_names[SC_RENDER_DEBUG_COUNT] = { "shaded", "normals", "depth", "id",
                                                                "heat" };
static const char *const integrator_names[SC_RENDER_INTEGRATOR_COUNT] = { "direct", "path" };

const char *sc_render_integrator_name(sc_render_integrator i)
{
    return sc_enum_name(integrator_names, SC_RENDER_INTEGRATOR_COUNT, (int)i, "?");
}

sc_status sc_render_integrator_from_name(const char *name, sc_render_integrator *out)
{
    int v;
    if (!out || sc_enum_lookup(integrator_names, SC_RENDER_INTEGRATOR_COUNT, name, &v) != 0)
        return SC_ERR_INVALID_ARGUMENT;
    *out = (sc_render_integrator)v;
    return SC_OK;
}

const char *sc_render_debug_name(sc_render_debug d)
{
    return sc_enum_name(debug_names, SC_RENDER_DEBUG_COUNT, (int)d, "?");
}

sc_status sc_render_debug_from_name(const char *name, sc_render_debug *out)
{
    int v;
    if (!out || sc_enum_lookup(debug_names, SC_RENDER_DEBUG_COUNT, name, &v) != 0)
        return SC_ERR_INVALID_ARGUMENT;
    *out = (sc_render_debug)v;
    return SC_OK;
}

void sc_render_options_init(sc_render_options *o)
{
    if (!o)
        return;
    memset(o, 0, sizeof *o);
    o->seed = 1;
    o->shadows = 1;
    o->integrator = SC_RENDER_DIRECT;
    o->spp = 16;
    o->bounces = 4;
    o->rr_depth = 3;
}

typedef struct ctx {
    sc_render_ctx r;
    float *accum;         /* 3 per pixel, linear */
    float *value;         /* depth or heat per pixel */
} ctx;

sc_status sc_render_closest(const sc_render_ctx *c, const sc_ray *rays, size_t n, sc_hitrec *hits,
                            int coherent, sc_trace_stats *stats)
{
    const sc_render_backend *b = c->o->backend;
    if (b)
        return b->closest(b->ctx, rays, n, hits, coherent);
    return sc_trace_closest_n(c->bvh, rays, sizeof *rays, hits, sizeof *hits, n, 0, stats);
}

sc_status sc_render_occluded_bytes(sc_render_any_n any_n, const void *scene, const sc_ray *rays, size_t n,
                                   uint8_t *occluded, sc_trace_stats *stats)
{
    enum { CHUNK = 256 };
    int32_t occ[CHUNK];
    sc_status st = SC_OK;
    for (size_t i = 0; i < n; i += CHUNK) {
        size_t m = n - i < CHUNK ? n - i : CHUNK;
        for (size_t k = 0; k < m; k++)
            occ[k] = occluded[i + k];   /* a refused ray keeps what the caller put */
        sc_status s = any_n(scene, rays + i, occ, m, stats);
        if (s != SC_OK)
            st = s;
        for (size_t k = 0; k < m; k++)
            occluded[i + k] = occ[k] != 0;
    }
    return st;
}

static sc_status bvh_any_n(const void *bvh, const sc_ray *rays, int32_t *occ, size_t n, sc_trace_stats *stats)
{
    return sc_trace_any_n(bvh, rays, sizeof *rays, occ, sizeof *occ, n, 0, stats);
}

sc_status sc_render_occluded(const sc_render_ctx *c, const sc_ray *rays, size_t n, uint8_t *occluded,
                             int coherent, sc_trace_stats *stats)
{
    const sc_render_backend *b = c->o->backend;
    if (b)
        return b->occluded(b->ctx, rays, n, occluded, coherent);
    return sc_render_occluded_bytes(bvh_any_n, c->bvh, rays, n, occluded, stats);
}

static void add_stats(sc_trace_stats *a, const sc_trace_stats *b)
{
    a->rays += b->rays;
    a->nodes += b->nodes;
    a->leaves += b->leaves;
    a->sphere_tests += b->sphere_tests;
    a->sphere_rejects += b->sphere_rejects;
    a->tri_tests += b->tri_tests;
    a->tri_hits += b->tri_hits;
}

static int occluded(const sc_render_ctx *c, const double o[3], const double d[3], float tmax,
                    sc_trace_stats *ts)
{
    sc_ray r = { { (float)o[0], (float)o[1], (float)o[2] }, 0.0f,
                 { (float)d[0], (float)d[1], (float)d[2] }, tmax };
    uint8_t blocked = 0;   /* a degenerate shadow ray (zero direction) lights the point */
    sc_render_occluded(c, &r, 1, &blocked, 0, c->collect ? ts : NULL);
    return blocked;
}

static void shade_pixel(const sc_render_ctx *c, int px, int py, float rgb[3], float *value,
                        sc_render_stats *st)
{
    const sc_scene_view *v = c->v;
    const sc_camera *cam = &v->camera;
    double dir[3];
    sc_camera_ray_dir(cam, &c->frame, px + 0.5, py + 0.5, dir);
    sc_ray ray = { { (float)cam->eye[0], (float)cam->eye[1], (float)cam->eye[2] }, 0.0f,
                   { (float)dir[0], (float)dir[1], (float)dir[2] }, INFINITY };
    sc_hitrec hit;
    sc_trace_stats before = st->trace;
    st->primary_rays++;
    hit.prim = SC_HITREC_MISS;
    sc_status s = sc_render_closest(c, &ray, 1, &hit, 1, c->collect ? &st->trace : NULL);
    if (c->o->debug == SC_RENDER_HEAT) {
        /* Sphere tests; a BVH without spheres shows its triangle tests. */
        uint64_t n = st->trace.sphere_tests - before.sphere_tests;
        *value = (float)(n ? n : st->trace.tri_tests - before.tri_tests);
        return;
    }
    if (s != SC_OK || hit.prim == SC_HITREC_MISS || hit.prim >= v->mesh.triangle_count) {
        for (int i = 0; i < 3; i++)
            rgb[i] = c->o->debug == SC_RENDER_SHADED ? v->background[i] : 0.0f;
        return;
    }
    const uint32_t *ix = sc_mesh_triangle(&v->mesh, hit.prim);
    const float *a = sc_mesh_vertex(&v->mesh, ix[0]), *b = sc_mesh_vertex(&v->mesh, ix[1]),
                *cc = sc_mesh_vertex(&v->mesh, ix[2]);
    double e0[3], e1[3], n[3], p[3];
    for (int i = 0; i < 3; i++) {
        e0[i] = (double)b[i] - a[i];
        e1[i] = (double)cc[i] - a[i];
        p[i] = (double)ray.org[i] + (double)hit.t * (double)ray.dir[i];
    }
    n[0] = e0[1] * e1[2] - e0[2] * e1[1];
    n[1] = e0[2] * e1[0] - e0[0] * e1[2];
    n[2] = e0[0] * e1[1] - e0[1] * e1[0];
    double nl = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(nl > 0)) {   /* degenerate triangle: face the viewer */
        for (int i = 0; i < 3; i++)
            n[i] = -dir[i];
        nl = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    }
    for (int i = 0; i < 3; i++)
        n[i] /= nl;
    if (n[0] * dir[0] + n[1] * dir[1] + n[2] * dir[2] > 0)
        for (int i = 0; i < 3; i++)
            n[i] = -n[i];
    if (c->o->debug == SC_RENDER_NORMALS) {
        for (int i = 0; i < 3; i++)
            rgb[i] = (float)(0.5 * n[i] + 0.5);
        return;
    }
    if (c->o->debug == SC_RENDER_DEPTH) {
        *value = (float)(hit.t * sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]));
        return;
    }
    if (c->o->debug == SC_RENDER_ID) {
        uint64_t h = hit.prim + 1;
        uint64_t z = sc_rng_splitmix(&h);
        for (int i = 0; i < 3; i++)
            rgb[i] = (float)(0.2 + 0.8 * (double)((z >> (16 * i)) & 0xffff) / 65535.0);
        return;
    }

    double o[3];
    for (int i = 0; i < 3; i++)
        o[i] = p[i] + c->eps * n[i];
    const float *albedo = v->mesh_colors + 3 * (size_t)v->mesh_ids[hit.prim];
    double light[3] = { 0, 0, 0 };
    for (size_t l = 0; l < v->num_lights; l++) {
        const sc_light *L = &v->lights[l];
        double to[3], dist2 = 1, tmax_scale;
        if (L->type == SC_LIGHT_DIRECTIONAL) {
            for (int i = 0; i < 3; i++)
                to[i] = -(double)L->vec[i];
            tmax_scale = INFINITY;
        } else {
            for (int i = 0; i < 3; i++)
                to[i] = (double)L->vec[i] - o[i];
            dist2 = to[0] * to[0] + to[1] * to[1] + to[2] * to[2];
            if (!(dist2 > 0))
                continue;
            tmax_scale = 1.0;   /* unnormalised direction: t = 1 at the light */
        }
        double len = sqrt(to[0] * to[0] + to[1] * to[1] + to[2] * to[2]);
        double cosine = (n[0] * to[0] + n[1] * to[1] + n[2] * to[2]) / len;
        if (!(cosine > 0))
            continue;
        if (c->o->shadows) {
            st->shadow_rays++;
            float tmax = isinf(tmax_scale) ? INFINITY : (float)(1.0 - 1e-6);
            if (occluded(c, o, to, tmax, &st->trace))
                continue;
        }
        double k = cosine / (L->type == SC_LIGHT_POINT ? dist2 : 1.0);
        for (int i = 0; i < 3; i++)
            light[i] += k * L->color[i];
    }
    double ambient = v->ambient;
    if (c->o->ao_samples > 0) {
        sc_rng r;
        sc_rng_seed(&r, c->o->seed ^ ((uint64_t)py * 0x9e3779b97f4a7c15ull + (uint64_t)px));
        double t1[3], t2[3];
        double ax = fabs(n[0]) < 0.9 ? 1 : 0, ay = 1 - ax;
        t1[0] = ay * n[2];   /* (ax, ay, 0) x n */
        t1[1] = -ax * n[2];
        t1[2] = ax * n[1] - ay * n[0];
        double tl = sqrt(t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2]);
        for (int i = 0; i < 3; i++)
            t1[i] /= tl;
        t2[0] = n[1] * t1[2] - n[2] * t1[1];
        t2[1] = n[2] * t1[0] - n[0] * t1[2];
        t2[2] = n[0] * t1[1] - n[1] * t1[0];
        int open = 0;
        for (int s2 = 0; s2 < c->o->ao_samples; s2++) {
            /* Cosine-weighted: the unoccluded fraction is the ambient
             * visibility seen by a Lambert surface. */
            double u1 = sc_rng_uniform(&r), u2 = sc_rng_uniform(&r);
            double rr = sqrt(u1), ph = 2 * PI * u2, z = sqrt(1 - u1);
            double d[3];
            for (int i = 0; i < 3; i++)
                d[i] = c->ao_len * (rr * cos(ph) * t1[i] + rr * sin(ph) * t2[i] + z * n[i]);
            st->ao_rays++;
            open += !occluded(c, o, d, 1.0f, &st->trace);
        }
        ambient *= (double)open / c->o->ao_samples;
    }
    for (int i = 0; i < 3; i++)
        rgb[i] = (float)(albedo[i] * (ambient + light[i]));
}

static uint8_t encode(float linear)
{
    if (!(linear > 0))
        return 0;
    if (linear >= 1)
        return 255;
    return (uint8_t)lrint(255.0 * pow(linear, 1 / 2.2));
}

/* Blue - cyan - green - yellow - red. */
static void heat_color(double x, uint8_t out[3])
{
    static const double stops[5][3] = { { 0, 0, 0.5 }, { 0, 0.8, 1 }, { 0.2, 0.9, 0.2 },
                                        { 1, 0.9, 0 }, { 0.9, 0.1, 0 } };
    x = x < 0 ? 0 : x > 1 ? 1 : x;
    double f = x * 4;
    int i = f >= 4 ? 3 : (int)f;
    double t = f - i;
    for (int k = 0; k < 3; k++)
        out[k] = (uint8_t)lrint(255 * (stops[i][k] * (1 - t) + stops[i + 1][k] * t));
}

/* sRGB transfer curve (IEC 61966-2-1) of a linear value clamped to [0, 1]. */
static uint8_t encode_srgb(double linear)
{
    if (!(linear > 0))
        return 0;
    if (linear >= 1)
        return 255;
    double e = linear <= 0.0031308 ? 12.92 * linear : 1.055 * pow(linear, 1 / 2.4) - 0.055;
    return (uint8_t)lrint(255.0 * e);
}

/* A failure before the tile loop: the other processes of a distributed
 * render still wait in combine, so this one reports there (no buffers). */
static sc_status tiles_failed(const sc_render_options *opt, sc_status st)
{
    if (opt->tiles)
        opt->tiles->combine(opt->tiles->ctx, st, NULL, NULL, 0, NULL);
    return st;
}

static int options_ok(const sc_render_options *o, const sc_bvh *bvh)
{
    if ((unsigned)o->debug >= SC_RENDER_DEBUG_COUNT || o->ao_samples < 0 || o->ao_samples > 4096 ||
        o->threads < 0 || (unsigned)o->integrator >= SC_RENDER_INTEGRATOR_COUNT)
        return 0;
    if (!bvh && (!o->backend || o->debug == SC_RENDER_HEAT || o->trace_stats))
        return 0;
    if (o->backend && (!o->backend->closest || !o->backend->occluded || o->debug == SC_RENDER_HEAT))
        return 0;
    if (o->tiles && (!o->tiles->next || !o->tiles->combine))
        return 0;
    if (o->integrator == SC_RENDER_PATH &&
        (o->spp < 1 || o->spp > 65536 || o->bounces < 0 || o->bounces > 64 || o->rr_depth < 1 ||
         !(fabs(o->exposure) <= 64) || o->debug != SC_RENDER_SHADED))
        return 0;
    return 1;
}

sc_status sc_render(const sc_scene_view *v, const sc_bvh *bvh, const sc_render_options *opt,
                    sc_image *out, sc_render_stats *stats)
{
    if (!v || !out || !sc_mesh_layout_ok(&v->mesh) ||
        (v->mesh.triangle_count && (!v->mesh.positions || !v->mesh.indices || !v->mesh_ids)) ||
        (v->num_meshes && !v->mesh_colors) || (v->num_lights && !v->lights))
        return SC_ERR_INVALID_ARGUMENT;
    sc_render_options defaults;
    if (!opt) {
        sc_render_options_init(&defaults);
        opt = &defaults;
    }
    if (!options_ok(opt, bvh))
        return SC_ERR_INVALID_ARGUMENT;
    ctx c = { .r = { .v = v, .bvh = bvh, .o = opt } };
    sc_render_ctx *rc = &c.r;
    if (sc_camera_frame_make(&v->camera, &rc->frame) != SC_OK)
        return SC_ERR_INVALID_ARGUMENT;
    for (size_t t = 0; t < v->mesh.triangle_count; t++)
        if (v->mesh_ids[t] >= v->num_meshes)
            return SC_ERR_INVALID_ARGUMENT;
    const int w = v->camera.width, h = v->camera.height;
    const int path = opt->integrator == SC_RENDER_PATH;

    /* Offsets scale with the scene: 1e-4 of the diagonal, as the shared ray
     * sets do (sc_rays.h), and never below float resolution at the hit. */
    double lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
    for (size_t k = 0; k < 3 * v->mesh.triangle_count; k++) {
        const float *p = sc_mesh_vertex(&v->mesh, sc_mesh_triangle(&v->mesh, k / 3)[k % 3]);
        for (int i = 0; i < 3; i++) {
            lo[i] = fmin(lo[i], p[i]);
            hi[i] = fmax(hi[i], p[i]);
        }
    }
    double diag = 0, mag = 0;
    for (int i = 0; i < 3; i++) {
        if (lo[i] <= hi[i]) {
            diag += (hi[i] - lo[i]) * (hi[i] - lo[i]);
            mag = fmax(mag, fmax(fabs(lo[i]), fabs(hi[i])));
        }
    }
    diag = sqrt(diag);
    rc->eps = fmax(1e-4 * diag, 4e-7 * mag);
    if (!(rc->eps > 0))
        rc->eps = 1e-6;
    rc->ao_len = 0.2 * diag;
    rc->collect = !opt->backend && (opt->trace_stats || opt->debug == SC_RENDER_HEAT);

    sc_status st = path ? sc_path_prepare(rc) : SC_OK;
    if (st != SC_OK)
        return tiles_failed(opt, st);
    st = sc_image_alloc(out, w, h);
    if (st != SC_OK) {
        sc_path_release(rc);
        return tiles_failed(opt, st);
    }
    size_t npx = (size_t)w * (size_t)h;
    /* zeroed: the pixels of tiles another process renders stay 0 (sc_render_tiles) */
    c.accum = calloc(npx * 3, sizeof(float));
    c.value = calloc(npx, sizeof(float));
    if (!c.accum || !c.value) {
        free(c.accum);
        free(c.value);
        sc_path_release(rc);
        sc_image_free(out);
        return tiles_failed(opt, SC_ERR_OUT_OF_MEMORY);
    }
    const int tx = (w + TILE - 1) / TILE, ty = (h + TILE - 1) / TILE, ntiles = tx * ty;
    sc_render_stats total;
    memset(&total, 0, sizeof total);
    int done = 0, failed = 0, cancelled = 0, next_tile = 0;
    uint64_t rays_done = 0;
    double t0 = sc_now_seconds();
#ifdef _OPENMP
    int nthreads = opt->threads > 0 ? opt->threads : omp_get_max_threads();
#pragma omp parallel num_threads(nthreads)
#endif
    {
        sc_render_stats local;
        memset(&local, 0, sizeof local);
        sc_path_work *work = path ? sc_path_work_new() : NULL;
        if (path && !work) {
#ifdef _OPENMP
#pragma omp atomic write
#endif
            failed = 1;
        }
        for (;;) {
            int tile, stop;
            if (opt->tiles) {
                tile = opt->tiles->next(opt->tiles->ctx);
            } else {
#ifdef _OPENMP
#pragma omp atomic capture
#endif
                tile = next_tile++;
            }
            if (tile < 0 || tile >= ntiles)
                break;
#ifdef _OPENMP
#pragma omp atomic read
#endif
            stop = failed;
            if (opt->cancel && *opt->cancel) {
                stop = 1;
#ifdef _OPENMP
#pragma omp atomic write
#endif
                cancelled = 1;
            }
            if (stop)
                break;
            uint64_t before = local.primary_rays + local.shadow_rays + local.ao_rays + local.bounce_rays;
            int x0 = (tile % tx) * TILE, y0 = (tile / tx) * TILE;
            int x1 = x0 + TILE < w ? x0 + TILE : w, y1 = y0 + TILE < h ? y0 + TILE : h;
            if (path) {
                sc_path_tile(rc, work, x0, y0, x1, y1, c.accum, opt->edge, &local);
            } else {
                for (int y = y0; y < y1; y++)
                    for (int x = x0; x < x1; x++) {
                        size_t i = (size_t)y * (size_t)w + (size_t)x;
                        c.value[i] = -1;
                        shade_pixel(rc, x, y, c.accum + 3 * i, c.value + i, &local);
                    }
            }
            uint64_t traced = local.primary_rays + local.shadow_rays + local.ao_rays + local.bounce_rays - before;
            uint64_t r;
            int d;
#ifdef _OPENMP
#pragma omp atomic capture
#endif
            r = rays_done += traced;
#ifdef _OPENMP
#pragma omp atomic capture
#endif
            d = ++done;
#ifdef _OPENMP
            if (omp_get_thread_num() == 0 && opt->progress)
#else
            if (opt->progress)
#endif
                /* handed out elsewhere too: the share of all tiles handed out */
                opt->progress(opt->progress_ctx, (double)(opt->tiles ? tile + 1 : d) / ntiles, r);
        }
        sc_path_work_free(work);
#ifdef _OPENMP
#pragma omp critical(sc_render_stats)
#endif
        {
            total.primary_rays += local.primary_rays;
            total.shadow_rays += local.shadow_rays;
            total.ao_rays += local.ao_rays;
            total.bounce_rays += local.bounce_rays;
            add_stats(&total.trace, &local.trace);
        }
    }
    sc_path_release(rc);
    st = failed ? SC_ERR_OUT_OF_MEMORY : cancelled ? SC_ERR_CANCELLED : SC_OK;
    if (opt->tiles)
        st = opt->tiles->combine(opt->tiles->ctx, st, c.accum, c.value, npx, &total);
    total.seconds = sc_now_seconds() - t0;
    if (st != SC_OK) {
        free(c.accum);
        free(c.value);
        sc_image_free(out);
        return st;
    }

    if (path) {
        double scale = exp2(opt->exposure);
        for (size_t i = 0; i < 3 * npx; i++)
            out->rgb[i] = encode_srgb(scale * c.accum[i]);
        if (opt->radiance)
            memcpy(opt->radiance, c.accum, npx * 3 * sizeof(float));
    } else if (opt->debug == SC_RENDER_DEPTH || opt->debug == SC_RENDER_HEAT) {
        double vmin = INFINITY, vmax = -INFINITY;
        for (size_t i = 0; i < npx; i++)
            if (c.value[i] >= 0) {
                vmin = fmin(vmin, c.value[i]);
                vmax = fmax(vmax, c.value[i]);
            }
        for (size_t i = 0; i < npx; i++) {
            uint8_t *px = out->rgb + 3 * i;
            if (opt->debug == SC_RENDER_HEAT) {
                heat_color(vmax > 0 ? c.value[i] / vmax : 0, px);
            } else if (c.value[i] >= 0) {
                double x = vmax > vmin ? (c.value[i] - vmin) / (vmax - vmin) : 0;
                px[0] = px[1] = px[2] = (uint8_t)lrint(255 * (1 - 0.85 * x));
            }
        }
    } else {
        int gamma = opt->debug == SC_RENDER_SHADED;
        for (size_t i = 0; i < 3 * npx; i++)
            out->rgb[i] = gamma ? encode(c.accum[i])
                                : (uint8_t)lrint(255 * fmin(1, fmax(0, c.accum[i])));
    }
    free(c.accum);
    free(c.value);
    if (stats)
        *stats = total;
    return SC_OK;
}
