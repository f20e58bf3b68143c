/* A scene view with instances traced through sc_accel.h (sc_render.h,
 * sc_scene_accel): each object of view->objects becomes a scene of its
 * own, each instance an instance of it, and the triangles no instance owns
 * one mesh of the top scene; hits are mapped back to view->mesh indices so
 * that the renderer shades them like the flattened mesh's. */
#include <stdlib.h>
#include <string.h>

#include "common/sc_clock.h"
#include "render_internal.h"
#include "spherecull/sc_render.h"

struct sc_scene_accel {
    sc_accel **objects;
    size_t num_objects;
    sc_accel *world;
    uint32_t *own_idx;           /* the triangles no instance owns, 3 indices each */
    uint32_t *own_prim;          /* their index in view->mesh */
    size_t num_own;
    const sc_scene_instance *instances;
    size_t num_instances;
    double build_seconds;
};

void sc_scene_accel_free(sc_scene_accel *a)
{
    if (!a)
        return;
    for (size_t i = 0; i < a->num_objects; i++)
        sc_accel_release(a->objects[i]);
    free(a->objects);
    sc_accel_release(a->world);
    free(a->own_idx);
    free(a->own_prim);
    free(a);
}

static int instances_fit(const sc_scene_view *v)
{
    const size_t nt = v->mesh.triangle_count;
    for (size_t i = 0; i < v->num_instances; i++)
        if (v->instances[i].object >= v->num_objects || v->instances[i].first_triangle > nt ||
            v->objects[v->instances[i].object].triangle_count > nt - v->instances[i].first_triangle)
            return 0;
    return 1;
}

sc_status sc_scene_view_own_triangles(const sc_scene_view *v, uint32_t **indices, uint32_t **prims, size_t *count)
{
    if (!indices || !prims || !count)
        return SC_ERR_INVALID_ARGUMENT;
    *indices = *prims = NULL;
    *count = 0;
    if (!v || (v->num_instances && (!v->instances || !v->objects)) || !instances_fit(v))
        return SC_ERR_INVALID_ARGUMENT;
    const size_t nt = v->mesh.triangle_count;
    unsigned char *owned = calloc(nt ? nt : 1, 1);
    if (!owned)
        return SC_ERR_OUT_OF_MEMORY;
    for (size_t i = 0; i < v->num_instances; i++)
        memset(owned + v->instances[i].first_triangle, 1, v->objects[v->instances[i].object].triangle_count);
    size_t n = 0;
    for (size_t t = 0; t < nt; t++)
        n += !owned[t];
    uint32_t *idx = malloc(12 * (n ? n : 1)), *prim = malloc(4 * (n ? n : 1));
    if (!idx || !prim) {
        free(owned), free(idx), free(prim);
        return SC_ERR_OUT_OF_MEMORY;
    }
    for (size_t t = 0, k = 0; t < nt; t++)
        if (!owned[t]) {
            memcpy(idx + 3 * k, sc_mesh_triangle(&v->mesh, t), 12);
            prim[k++] = (uint32_t)t;
        }
    free(owned);
    *indices = idx, *prims = prim, *count = n;
    return SC_OK;
}

sc_status sc_scene_accel_build(const sc_scene_view *v, const sc_bvh_config *cfg, sc_scene_accel **out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    *out = NULL;
    if (!v || (v->num_instances && (!v->instances || !v->objects)) || !instances_fit(v))
        return SC_ERR_INVALID_ARGUMENT;
    const double t0 = sc_now_seconds();
    sc_scene_accel *a = calloc(1, sizeof *a);
    sc_status st = SC_ERR_OUT_OF_MEMORY;
    if (!a)
        goto fail;
    a->instances = v->instances;
    a->num_instances = v->num_instances;
    a->objects = calloc(v->num_objects ? v->num_objects : 1, sizeof *a->objects);
    if (!a->objects)
        goto fail;
    for (size_t i = 0; i < v->num_objects; i++) {
        if ((st = sc_accel_new(cfg, &a->objects[i])) != SC_OK)
            goto fail;
        a->num_objects = i + 1;
        if ((st = sc_accel_attach_mesh(a->objects[i], &v->objects[i], SC_ACCEL_SHARED, NULL)) != SC_OK ||
            (st = sc_accel_commit(a->objects[i])) != SC_OK)
            goto fail;
    }
    if ((st = sc_scene_view_own_triangles(v, &a->own_idx, &a->own_prim, &a->num_own)) != SC_OK ||
        (st = sc_accel_new(cfg, &a->world)) != SC_OK)
        goto fail;
    if (a->num_own) {
        const sc_mesh_view own = { v->mesh.positions, v->mesh.vertex_count, a->own_idx, a->num_own,
                                   v->mesh.vertex_stride, 0 };
        if ((st = sc_accel_attach_mesh(a->world, &own, SC_ACCEL_SHARED, NULL)) != SC_OK)
            goto fail;
    }
    for (size_t i = 0; i < v->num_instances; i++)
        if ((st = sc_accel_attach_instance(a->world, a->objects[v->instances[i].object], v->instances[i].xfm, NULL)) !=
            SC_OK)
            goto fail;
    if ((st = sc_accel_commit(a->world)) != SC_OK)
        goto fail;
    a->build_seconds = sc_now_seconds() - t0;
    *out = a;
    return SC_OK;
fail:
    sc_scene_accel_free(a);
    return st;
}

sc_status sc_scene_accel_closest(const sc_scene_accel *a, const sc_ray *rays, size_t n, sc_hitrec *hits,
                                 sc_trace_stats *stats)
{
    if (!a || (n && (!rays || !hits)))
        return SC_ERR_INVALID_ARGUMENT;
    sc_status st = sc_accel_closest_n(a->world, rays, sizeof *rays, hits, sizeof *hits, n, 0, stats);
    for (size_t i = 0; i < n; i++)
        sc_scene_accel_flat_hit(a, &hits[i]);
    return st;
}

void sc_scene_accel_flat_hit(const sc_scene_accel *a, sc_hitrec *h)
{
    /* a refused ray's entry is the caller's: mapped only if it can be */
    if (!a || !h || h->prim == SC_HITREC_MISS ||
        (h->inst != SC_INVALID_ID ? h->inst >= a->num_instances : h->prim >= a->num_own))
        return;
    h->prim = h->inst != SC_INVALID_ID ? (uint32_t)(a->instances[h->inst].first_triangle + h->prim)
                                       : a->own_prim[h->prim];
    h->geom = 0;
    h->inst = SC_INVALID_ID;
}

static sc_status world_any_n(const void *world, const sc_ray *rays, int32_t *occ, size_t n, sc_trace_stats *stats)
{
    return sc_accel_any_n(world, rays, sizeof *rays, occ, sizeof *occ, n, 0, stats);
}

sc_status sc_scene_accel_any(const sc_scene_accel *a, const sc_ray *rays, size_t n, uint8_t *occ,
                             sc_trace_stats *stats)
{
    if (!a || (n && (!rays || !occ)))
        return SC_ERR_INVALID_ARGUMENT;
    return sc_render_occluded_bytes(world_any_n, a->world, rays, n, occ, stats);
}

const sc_accel *sc_scene_accel_world(const sc_scene_accel *a)
{
    return a ? a->world : NULL;
}

static sc_status closest(void *ctx, const sc_ray *rays, size_t n, sc_hitrec *hits, int coherent)
{
    (void)coherent;
    return sc_scene_accel_closest(ctx, rays, n, hits, NULL);
}

static sc_status occluded(void *ctx, const sc_ray *rays, size_t n, uint8_t *occ, int coherent)
{
    (void)coherent;
    return sc_scene_accel_any(ctx, rays, n, occ, NULL);
}

void sc_scene_accel_backend(sc_scene_accel *a, sc_render_backend *out)
{
    if (!out)
        return;
    out->closest = closest;
    out->occluded = occluded;
    out->ctx = a;
}

sc_status sc_scene_accel_info(const sc_scene_accel *a, sc_accel_info *world, size_t *total_bytes, double *build_seconds)
{
    if (!a)
        return SC_ERR_INVALID_ARGUMENT;
    sc_accel_info wi;
    sc_accel_get_info(a->world, &wi);
    if (world)
        *world = wi;
    if (total_bytes) {
        size_t b = wi.bytes;
        for (size_t i = 0; i < a->num_objects; i++) {
            sc_accel_info oi;
            sc_accel_get_info(a->objects[i], &oi);
            b += oi.bytes;
        }
        *total_bytes = b;
    }
    if (build_seconds)
        *build_seconds = a->build_seconds;
    return SC_OK;
}
