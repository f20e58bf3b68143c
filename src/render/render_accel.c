/* A scene view with instances traced through sc_accel.h (sc_render.h,
 * sc_scene_accel): each object of view->objects becomes a scene of its
 * own, each instance an instance of it, and the triangles no instance owns
 * one mesh of the top scene; hits are mapped back to view->mesh indices so
 * that the renderer shades them like the flattened mesh's. */
#include <stdlib.h>
#include <string.h>

#include "common/sc_clock.h"
#include "spherecull/sc_render.h"

struct sc_scene_accel {
    sc_accel **objects;
    size_t num_objects;
    sc_accel *world;
    uint32_t *own_idx;           /* the triangles no instance owns, 3 indices each */
    uint32_t *own_prim;          /* their index in view->mesh */
    const sc_scene_instance *instances;
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

sc_status sc_scene_accel_build(const sc_scene_view *v, const sc_bvh_config *cfg, sc_scene_accel **out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    *out = NULL;
    if (!v || (v->num_instances && (!v->instances || !v->objects)))
        return SC_ERR_INVALID_ARGUMENT;
    const size_t nt = v->mesh.triangle_count;
    for (size_t i = 0; i < v->num_instances; i++)
        if (v->instances[i].object >= v->num_objects ||
            v->instances[i].first_triangle > nt ||
            v->objects[v->instances[i].object].triangle_count > nt - v->instances[i].first_triangle)
            return SC_ERR_INVALID_ARGUMENT;
    const double t0 = sc_now_seconds();
    sc_scene_accel *a = calloc(1, sizeof *a);
    unsigned char *owned = calloc(nt ? nt : 1, 1);
    sc_status st = SC_ERR_OUT_OF_MEMORY;
    if (!a || !owned)
        goto fail;
    a->instances = v->instances;
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
    for (size_t i = 0; i < v->num_instances; i++)
        memset(owned + v->instances[i].first_triangle, 1, v->objects[v->instances[i].object].triangle_count);
    size_t n_own = 0;
    for (size_t t = 0; t < nt; t++)
        n_own += !owned[t];
    a->own_idx = malloc(12 * (n_own ? n_own : 1));
    a->own_prim = malloc(4 * (n_own ? n_own : 1));
    st = SC_ERR_OUT_OF_MEMORY;
    if (!a->own_idx || !a->own_prim)
        goto fail;
    for (size_t t = 0, k = 0; t < nt; t++)
        if (!owned[t]) {
            memcpy(a->own_idx + 3 * k, sc_mesh_triangle(&v->mesh, t), 12);
            a->own_prim[k++] = (uint32_t)t;
        }
    if ((st = sc_accel_new(cfg, &a->world)) != SC_OK)
        goto fail;
    if (n_own) {
        const sc_mesh_view own = { v->mesh.positions, v->mesh.vertex_count, a->own_idx, n_own, v->mesh.vertex_stride, 0 };
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
    free(owned);
    *out = a;
    return SC_OK;
fail:
    free(owned);
    sc_scene_accel_free(a);
    return st;
}

static sc_status closest(void *ctx, const sc_ray *rays, size_t n, sc_hitrec *hits, int coherent)
{
    (void)coherent;
    const sc_scene_accel *a = ctx;
    sc_status st = sc_accel_closest_n(a->world, rays, sizeof *rays, hits, sizeof *hits, n, 0, NULL);
    for (size_t i = 0; i < n; i++) {
        sc_hitrec *h = &hits[i];
        if (h->prim == SC_HITREC_MISS)
            continue;
        h->prim = h->inst != SC_INVALID_ID ? (uint32_t)(a->instances[h->inst].first_triangle + h->prim)
                                           : a->own_prim[h->prim];
        h->geom = 0;
        h->inst = SC_INVALID_ID;
    }
    return st;
}

static sc_status occluded(void *ctx, const sc_ray *rays, size_t n, uint8_t *occ, int coherent)
{
    (void)coherent;
    const sc_scene_accel *a = ctx;
    int32_t buf[256];
    sc_status st = SC_OK;
    for (size_t i = 0; i < n; i += 256) {
        const size_t m = n - i < 256 ? n - i : 256;
        for (size_t j = 0; j < m; j++)
            buf[j] = occ[i + j];   /* a refused ray keeps what the caller put, as render.c's own */
        sc_status s = sc_accel_any_n(a->world, rays + i, sizeof *rays, buf, sizeof *buf, m, 0, NULL);
        if (s != SC_OK)
            st = s;
        for (size_t j = 0; j < m; j++)
            occ[i + j] = buf[j] != 0;
    }
    return st;
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
