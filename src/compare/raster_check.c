/* raster-check's tracing and classification (see raster_check.h). */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/sc_clock.h"
#include "raster_check.h"

static sc_status fail(char *err, size_t errlen, sc_status st, const char *what)
{
    if (err && errlen)
        snprintf(err, errlen, "%s: %s", what, sc_strerror(st));
    return st;
}

/* Hits of t for every pixel; per-pixel sphere tests when tests != NULL
 * (one ray at a time, so they can be told apart). */
static sc_status trace(const sc_tracer *t, const sc_rayset *rays, sc_rcheck_tracer *out, uint32_t *tests,
                       sc_tracer_counters *work)
{
    sc_hitrec *hits = malloc((rays->count ? rays->count : 1) * sizeof *hits);
    if (!hits)
        return SC_ERR_OUT_OF_MEMORY;
    sc_status st = SC_OK;
    double t0 = sc_now_seconds();
    if (tests) {
        for (size_t i = 0; i < rays->count && st == SC_OK; i++) {
            sc_tracer_counters c;
            memset(&c, 0, sizeof c);
            st = sc_tracer_run(t, &rays->rays[i], 1, &hits[i], NULL, &c);
            tests[rays->target[i]] = (uint32_t)c.sphere_tests;
            sc_tracer_counters_add(work, &c);
        }
    } else {
        st = sc_tracer_run(t, rays->rays, rays->count, hits, NULL, NULL);
    }
    out->seconds = sc_now_seconds() - t0;
    for (size_t i = 0; st == SC_OK && i < rays->count; i++)
        out->ids[rays->target[i]] = hits[i].prim == SC_HITREC_MISS ? 0 : hits[i].prim + 1;
    free(hits);
    return st;
}

static sc_status classify(const sc_mesh_view *mesh, const sc_camera *cam, const sc_raster_image *img,
                          sc_rcheck_tracer *t, char *err, size_t errlen)
{
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++) {
            size_t p = (size_t)y * (size_t)img->width + (size_t)x;
            if (t->ids[p] == img->ids[p]) {
                t->agree++;
                continue;
            }
            sc_raster_diff kind;
            double dist;
            sc_status st = sc_raster_classify(mesh, cam, img, x, y, t->ids[p], &kind, &dist);
            if (st != SC_OK) {
                if (err && errlen)
                    snprintf(err, errlen, "classify pixel %d,%d: %s", x, y, sc_strerror(st));
                return st;
            }
            t->kinds[kind]++;
            t->cls[p] = (uint8_t)(1 + kind);
            if (kind == SC_RASTER_DIFF_AT_EDGE && dist > t->max_edge_px)
                t->max_edge_px = dist;
        }
    return SC_OK;
}

static sc_status add_tracer(sc_rcheck *c, const char *name, size_t npix)
{
    sc_rcheck_tracer *t = &c->tr[c->ntr++];
    t->name = name;
    t->ids = calloc(npix, sizeof *t->ids);
    t->cls = calloc(npix, 1);
    return t->ids && t->cls ? SC_OK : SC_ERR_OUT_OF_MEMORY;
}

sc_status sc_rcheck_run(const sc_mesh_view *mesh, const sc_camera *cam, const sc_raster_image *img,
                        sc_prefilter_mode prefilter, int with_embree, int want_tests, sc_rcheck *out, char *err,
                        size_t errlen)
{
    memset(out, 0, sizeof *out);
    if (mesh->triangle_count > UINT32_MAX - 1 || mesh->vertex_count > UINT32_MAX) {
        if (err && errlen)
            snprintf(err, errlen, "too many triangles for 32-bit primitive IDs");
        return SC_ERR_LIMIT;
    }
    size_t npix = (size_t)img->width * (size_t)img->height;
    sc_checked_mesh cm;
    sc_status cst = sc_mesh_check(mesh, &cm);
    if (cst != SC_OK) {
        fail(err, errlen, cst, "mesh");
        return cst;
    }
    sc_rayset rays = { 0 };
    sc_tracer t = { 0 };
    sc_status st = sc_rayset_primary(cam, &rays);
    if (st != SC_OK) {
        fail(err, errlen, st, "primary rays");
        goto done;
    }
    out->rays = rays.count;
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    cfg.prefilter = prefilter;
    double t0 = sc_now_seconds();
    if ((st = sc_tracer_build_bvh(&t, "ours", &cfg, &cm)) != SC_OK) {
        fail(err, errlen, st, "BVH build");
        goto done;
    }
    out->build_seconds = sc_now_seconds() - t0;
    if ((st = add_tracer(out, "ours", npix)) != SC_OK ||
        (want_tests && !(out->tests = calloc(npix, sizeof *out->tests)))) {
        fail(err, errlen, st = SC_ERR_OUT_OF_MEMORY, "pixels");
        goto done;
    }
    if ((st = trace(&t, &rays, &out->tr[0], out->tests, &out->work)) != SC_OK) {
        fail(err, errlen, st, "trace");
        goto done;
    }
    sc_tracer_free(&t);
    const sc_tracer_def *emb = with_embree ? sc_tracer_find("embree") : NULL;
    if (emb) {
        if ((st = add_tracer(out, "embree", npix)) != SC_OK) {
            fail(err, errlen, st, "pixels");
            goto done;
        }
        if ((st = sc_tracer_build(&t, emb, &cm)) != SC_OK ||
            (st = trace(&t, &rays, &out->tr[1], NULL, NULL)) != SC_OK) {
            fail(err, errlen, st, "Embree");
            goto done;
        }
        sc_tracer_free(&t);
    }
    for (int k = 0; k < out->ntr && st == SC_OK; k++)
        st = classify(mesh, cam, img, &out->tr[k], err, errlen);
done:
    sc_tracer_free(&t);
    sc_rayset_free(&rays);
    if (st != SC_OK)
        sc_rcheck_free(out);
    return st;
}

void sc_rcheck_free(sc_rcheck *c)
{
    for (int k = 0; k < 2; k++) {
        free(c->tr[k].ids);
        free(c->tr[k].cls);
    }
    free(c->tests);
    memset(c, 0, sizeof *c);
}

int sc_rcheck_target_met(const sc_rcheck *c, size_t pixels)
{
    return c->ntr > 0 && c->tr[0].agree * 1000 >= pixels * 995 && c->tr[0].kinds[SC_RASTER_DIFF_ELSEWHERE] == 0;
}
