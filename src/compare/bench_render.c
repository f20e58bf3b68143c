/* 'bench-render': see bench_render.h. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/sc_median.h"
#include "bench_render.h"
#include "common/sc_clock.h"

void sc_bench_render_options_default(sc_bench_render_options *o)
{
    memset(o, 0, sizeof *o);
    o->spp = 16;
    o->bounces = 4;
    o->repeats = 5;
    o->seed = 1;
    o->threads[0] = 1;
    o->threads[1] = 2;
    o->nthreads = 2;
    o->tracers[o->ntracers++] = "spherecull";
#ifdef SC_HAVE_EMBREE
    o->tracers[o->ntracers++] = "embree";
    o->tracers[o->ntracers++] = "embree-high";
    o->tracers[o->ntracers++] = "embree-robust";
#endif
    sc_bvh_config_default(&o->bvh);
    o->bvh.threads = 0;
    o->tolerance = 1e-4;
}

static sc_status fail(char *err, size_t n, sc_status st, const char *fmt, ...)
{
    if (err && n) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, n, fmt, ap);
        va_end(ap);
    }
    return st;
}

typedef struct side {
    const char *name;
    int embree;
    sc_bvh *bvh;                  /* "spherecull" */
    sc_tracer tracer;             /* anything else */
    sc_tracer_backend backend;
    double build_s;
    double times[SC_BENCH_MAX_REPEATS];
    uint64_t rays;
    float *radiance;              /* of the first repeat */
    uint8_t *edge;
    sc_image image;
} side;

static void side_free(side *s)
{
    sc_bvh_free(s->bvh);
    if (s->tracer.handle)
        sc_tracer_free(&s->tracer);
    free(s->radiance);
    free(s->edge);
    sc_image_free(&s->image);
}

static sc_status build_side(side *s, const char *name, const sc_scene_view *v, const sc_checked_mesh *cm,
                            const sc_bench_render_options *o, char *err, size_t errlen)
{
    s->name = name;
    double t0 = sc_now_seconds();
    sc_status st;
    if (strcmp(name, "spherecull") == 0) {
        st = sc_bvh_build(&v->mesh, &o->bvh, &s->bvh);
    } else {
        const sc_tracer_def *def = sc_tracer_find(name);
        if (!def)
            return fail(err, errlen, SC_ERR_INVALID_ARGUMENT, "unknown tracer '%s'", name);
        st = sc_tracer_build(&s->tracer, def, cm);
        if (st == SC_OK) {
            s->embree = def->family == SC_TRACER_EMBREE;
            s->tracer.ftz = s->embree;
            /* backend points into s: s must not move from here on */
            sc_tracer_render_backend(&s->tracer, &s->backend);
        }
    }
    s->build_s = sc_now_seconds() - t0;
    if (st != SC_OK)
        return fail(err, errlen, st, "building %s failed: %s", name, sc_strerror(st));
    return SC_OK;
}

static sc_status render_side(side *s, const sc_scene_view *v, const sc_bench_render_options *o, int threads,
                             int keep, double *seconds)
{
    sc_render_options ro;
    sc_render_options_init(&ro);
    ro.integrator = SC_RENDER_PATH;
    ro.spp = o->spp;
    ro.bounces = o->bounces;
    ro.seed = o->seed;
    ro.exposure = o->exposure;
    ro.threads = threads;
    ro.backend = s->bvh ? NULL : &s->backend.backend;
    if (keep) {
        ro.radiance = s->radiance;
        ro.edge = s->edge;
    }
    sc_image img = { 0, 0, NULL };
    sc_render_stats rs;
    sc_status st = sc_render(v, s->bvh, &ro, &img, &rs);
    if (st != SC_OK)
        return st;
    *seconds = rs.seconds;
    if (!keep)
        s->rays = rs.primary_rays + rs.bounce_rays + rs.shadow_rays;
    if (keep) {
        sc_image_free(&s->image);
        s->image = img;
    } else {
        sc_image_free(&img);
    }
    return SC_OK;
}

static void compare_images(const side *ref, const side *s, size_t npx, double tol, sc_bench_render_row *r)
{
    for (size_t i = 0; i < npx; i++) {
        int edge = ref->edge[i] || s->edge[i];
        double worst = 0;
        for (int k = 0; k < 3; k++) {
            double a = ref->radiance[3 * i + k], b = s->radiance[3 * i + k];
            double scale = fmax(fmax(fabs(a), fabs(b)), 1e-3);
            worst = fmax(worst, fabs(a - b) / scale);
        }
        r->edge_pixels += (size_t)edge;
        if (worst > tol) {
            if (edge)
                r->differ_edge++;
            else
                r->differ_elsewhere++;
        }
        if (!edge)
            r->max_rel_diff_elsewhere = fmax(r->max_rel_diff_elsewhere, worst);
    }
}

sc_status sc_bench_render_run(const sc_scene_view *v, const sc_bench_render_options *o,
                              const sc_bench_render_sink *sink, char *err, size_t errlen)
{
    if (!v || !o || !sink || !sink->row || o->ntracers < 1 || o->ntracers > SC_BENCH_RENDER_MAX_TRACERS ||
        o->repeats < 1 || o->repeats > SC_BENCH_MAX_REPEATS || o->nthreads < 1 ||
        o->nthreads > SC_BENCH_MAX_LIST)
        return fail(err, errlen, SC_ERR_INVALID_ARGUMENT, "bad benchmark options");
    sc_checked_mesh cm;
    sc_status st = sc_mesh_check(&v->mesh, &cm);
    if (st != SC_OK)
        return fail(err, errlen, st, "the scene's mesh is not traceable: %s", sc_strerror(st));
    const size_t npx = (size_t)v->camera.width * (size_t)v->camera.height;
    side *sides = calloc((size_t)o->ntracers, sizeof *sides);
    if (!sides)
        return fail(err, errlen, SC_ERR_OUT_OF_MEMORY, "out of memory");
    for (int t = 0; t < o->ntracers && st == SC_OK; t++) {
        sides[t].radiance = malloc(npx * 3 * sizeof(float));
        sides[t].edge = malloc(npx);
        if (!sides[t].radiance || !sides[t].edge)
            st = fail(err, errlen, SC_ERR_OUT_OF_MEMORY, "out of memory");
        else
            st = build_side(&sides[t], o->tracers[t], v, &cm, o, err, errlen);
    }
    for (int ti = 0; ti < o->nthreads && st == SC_OK; ti++) {
        const int threads = o->threads[ti];
        /* Repeat r renders the back ends starting at r mod n: none is always
         * first (cold caches, turbo) or always last. */
        for (int r = -1; r < o->repeats && st == SC_OK; r++)
            for (int k = 0; k < o->ntracers && st == SC_OK; k++) {
                /* r = -1: the untimed frame with the edge mask (slower:
                 * its shadow rays are closest-hit queries), kept for the
                 * comparison; then the timed repeats. */
                side *s = &sides[(r + 1 + k) % o->ntracers];
                double untimed;
                st = render_side(s, v, o, threads, r < 0, r < 0 ? &untimed : &s->times[r]);
                if (st != SC_OK)
                    fail(err, errlen, st, "rendering with %s failed: %s", s->name, sc_strerror(st));
            }
        if (st != SC_OK)
            break;
        /* The best Embree: the lower median frame time. */
        int best = -1;
        double best_median = INFINITY, tmp[SC_BENCH_MAX_REPEATS];
        for (int t = 1; t < o->ntracers; t++) {
            if (!sides[t].embree)
                continue;
            memcpy(tmp, sides[t].times, (size_t)o->repeats * sizeof *tmp);
            double m = sc_median(tmp, o->repeats);
            if (m < best_median)
                best_median = m, best = t;
        }
        for (int t = 0; t < o->ntracers; t++) {
            side *s = &sides[t];
            sc_bench_render_row row;
            memset(&row, 0, sizeof row);
            row.tracer = s->name;
            row.threads = threads;
            row.build_s = s->build_s;
            memcpy(tmp, s->times, (size_t)o->repeats * sizeof *tmp);
            row.frame_s = sc_median(tmp, o->repeats);
            row.rays = s->rays;
            row.mrays = row.frame_s > 0 ? (double)s->rays * 1e-6 / row.frame_s : NAN;
            row.x_best_embree = NAN;
            if (t == 0 && best > 0) {
                for (int r = 0; r < o->repeats; r++)
                    tmp[r] = sides[best].times[r] / s->times[r];
                row.x_best_embree = sc_median(tmp, o->repeats);
                row.best_embree = sides[best].name;
            }
            row.pixels = npx;
            if (t > 0)
                compare_images(&sides[0], s, npx, o->tolerance, &row);
            else
                for (size_t i = 0; i < npx; i++)
                    row.edge_pixels += sides[0].edge[i];
            row.image = &s->image;
            sink->row(sink->ctx, &row);
        }
    }
    for (int t = 0; t < o->ntracers; t++)
        side_free(&sides[t]);
    free(sides);
    return st;
}
