/* The tracer table and the runs behind it (see tracer.h). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#if defined(__SSE__)
#include <xmmintrin.h>
#endif

#include "common/sc_clock.h"
#include "spherecull/sc_trace.h"
#include "tracer.h"
#ifdef SC_HAVE_EMBREE
#include "spherecull/sc_embree.h"
#endif

static const sc_tracer_def all_tracers[] = {
    { "spherecull-off", SC_TRACER_OURS, SC_PREFILTER_OFF, SC_TRI_WATERTIGHT, 0, 0, SC_BUILD_QUALITY_AUTO, 0 },
    { "spherecull-exact", SC_TRACER_OURS, SC_PREFILTER_OFF, SC_TRI_EXACT, 0, 0, SC_BUILD_QUALITY_AUTO, 0 },
    { "spherecull-medium", SC_TRACER_OURS, SC_PREFILTER_OFF, SC_TRI_WATERTIGHT, 0, 0, SC_BUILD_QUALITY_MEDIUM, 0 },
    { "spherecull-high", SC_TRACER_OURS, SC_PREFILTER_OFF, SC_TRI_WATERTIGHT, 0, 0, SC_BUILD_QUALITY_HIGH, 0 },
    { "spherecull-circum", SC_TRACER_OURS, SC_PREFILTER_CIRCUM, SC_TRI_WATERTIGHT, 0, 0, SC_BUILD_QUALITY_AUTO, 0 },
    { "spherecull-minimal", SC_TRACER_OURS, SC_PREFILTER_MINIMAL, SC_TRI_WATERTIGHT, 0, 0, SC_BUILD_QUALITY_AUTO, 0 },
    { "spherecull-auto", SC_TRACER_OURS, SC_PREFILTER_AUTO, SC_TRI_WATERTIGHT, 0, 0, SC_BUILD_QUALITY_AUTO, 0 },
    { "spherecull-compact", SC_TRACER_OURS, SC_PREFILTER_COMPACT, SC_TRI_WATERTIGHT, 0, 0, SC_BUILD_QUALITY_AUTO, 0 },
    { "spherecull-p8", SC_TRACER_OURS, SC_PREFILTER_OFF, SC_TRI_WATERTIGHT, 0, 8, SC_BUILD_QUALITY_AUTO, 0 },
    { "spherecull-p16", SC_TRACER_OURS, SC_PREFILTER_OFF, SC_TRI_WATERTIGHT, 0, 16, SC_BUILD_QUALITY_AUTO, 0 },
    { "spherecull-p16-circum", SC_TRACER_OURS, SC_PREFILTER_CIRCUM, SC_TRI_WATERTIGHT, 0, 16, SC_BUILD_QUALITY_AUTO, 0 },
    { "spherecull-p16-minimal", SC_TRACER_OURS, SC_PREFILTER_MINIMAL, SC_TRI_WATERTIGHT, 0, 16, SC_BUILD_QUALITY_AUTO, 0 },
    { "spherecull-p16-compact", SC_TRACER_OURS, SC_PREFILTER_COMPACT, SC_TRI_WATERTIGHT, 0, 16, SC_BUILD_QUALITY_AUTO, 0 },
    { "spherecull-stream", SC_TRACER_OURS, SC_PREFILTER_OFF, SC_TRI_WATERTIGHT, 0, SC_TRACER_STREAM, SC_BUILD_QUALITY_AUTO, 0 },
#ifdef SC_HAVE_EMBREE
    { "embree", SC_TRACER_EMBREE, SC_EMBREE_DEFAULT, SC_EMBREE_QUALITY_MEDIUM, 0, 0, 0, 0 },
    { "embree-robust", SC_TRACER_EMBREE, SC_EMBREE_ROBUST, SC_EMBREE_QUALITY_MEDIUM, 0, 0, 0, 0 },
    { "embree-high", SC_TRACER_EMBREE, SC_EMBREE_DEFAULT, SC_EMBREE_QUALITY_HIGH, 0, 0, 0, 0 },
    { "embree-robust-high", SC_TRACER_EMBREE, SC_EMBREE_ROBUST, SC_EMBREE_QUALITY_HIGH, 0, 0, 0, 0 },
    { "embree-compact", SC_TRACER_EMBREE, SC_EMBREE_COMPACT, SC_EMBREE_QUALITY_MEDIUM, 0, 0, 0, 0 },
    { "embree-p8", SC_TRACER_EMBREE, SC_EMBREE_DEFAULT, SC_EMBREE_QUALITY_MEDIUM, 0, 8, 0, 0 },
    { "embree-p16", SC_TRACER_EMBREE, SC_EMBREE_DEFAULT, SC_EMBREE_QUALITY_MEDIUM, 0, 16, 0, 0 },
    /* Embree's packets with one flag for every ray set: its faster flag is
     * not always the one its rays suggest (shadow packets on foliage run
     * faster incoherent); the best Embree packet is the faster of
     * embree-p8 / embree-p16 and the row of the other flag (compare.c) */
    { "embree-p8-coherent", SC_TRACER_EMBREE, SC_EMBREE_DEFAULT, SC_EMBREE_QUALITY_MEDIUM, 0, 8, 0, SC_TRACER_COHERENT },
    { "embree-p8-incoherent", SC_TRACER_EMBREE, SC_EMBREE_DEFAULT, SC_EMBREE_QUALITY_MEDIUM, 0, 8, 0, SC_TRACER_INCOHERENT },
    { "embree-p16-coherent", SC_TRACER_EMBREE, SC_EMBREE_DEFAULT, SC_EMBREE_QUALITY_MEDIUM, 0, 16, 0, SC_TRACER_COHERENT },
    { "embree-p16-incoherent", SC_TRACER_EMBREE, SC_EMBREE_DEFAULT, SC_EMBREE_QUALITY_MEDIUM, 0, 16, 0, SC_TRACER_INCOHERENT },
    { "embree-stream", SC_TRACER_EMBREE, SC_EMBREE_DEFAULT, SC_EMBREE_QUALITY_MEDIUM, 0, SC_TRACER_STREAM, 0, 0 },
    { "embree-user-prefilter", SC_TRACER_EMBREE, SC_EMBREE_USER_PREFILTER, SC_EMBREE_QUALITY_MEDIUM, 8, 0, 0, 0 },
    { "embree-user-prefilter16", SC_TRACER_EMBREE, SC_EMBREE_USER_PREFILTER, SC_EMBREE_QUALITY_MEDIUM, 16, 0, 0, 0 },
    { "embree-user-plain", SC_TRACER_EMBREE, SC_EMBREE_USER_PLAIN, SC_EMBREE_QUALITY_MEDIUM, 8, 0, 0, 0 },
    { "embree-user-plain16", SC_TRACER_EMBREE, SC_EMBREE_USER_PLAIN, SC_EMBREE_QUALITY_MEDIUM, 16, 0, 0, 0 },
#endif
};
enum { NDEFS = sizeof all_tracers / sizeof all_tracers[0] };

const char *const *sc_tracer_names(int *count)
{
    static const char *names[NDEFS + 1];
    for (int i = 0; i < NDEFS; i++)
        names[i] = all_tracers[i].name;
    names[NDEFS] = NULL;
    if (count)
        *count = NDEFS;
    return names;
}

const sc_tracer_def *sc_tracer_find(const char *name)
{
    for (int i = 0; name && i < NDEFS; i++)
        if (strcmp(all_tracers[i].name, name) == 0)
            return &all_tracers[i];
    return NULL;
}

/* What every build of ours records. */
static void ours_built(sc_tracer *t, void *handle, double seconds, size_t bytes, size_t triangles,
                       const sc_bvh_config *cfg)
{
    t->handle = handle;
    t->build_seconds = seconds;
    t->bytes_per_tri = triangles ? (double)bytes / (double)triangles : 0;
    t->prefilter = cfg->prefilter != SC_PREFILTER_OFF;
    t->counted = 1;
    /* auto mixes leaves with and without spheres: the counters cannot tell
     * which triangle tests followed a passed sphere */
    t->fp_exact = cfg->prefilter == SC_PREFILTER_CIRCUM || cfg->prefilter == SC_PREFILTER_MINIMAL ||
                  cfg->prefilter == SC_PREFILTER_COMPACT;
}

sc_status sc_tracer_build_bvh(sc_tracer *t, const char *name, const sc_bvh_config *cfg, const sc_checked_mesh *cm)
{
    if (!t || !cfg || !cm)
        return SC_ERR_INVALID_ARGUMENT;
    const sc_mesh_view *m = &cm->view;
    memset(t, 0, sizeof *t);
    t->def = (sc_tracer_def){ name, SC_TRACER_OURS, cfg->prefilter, cfg->tri_test, 0, 0, cfg->quality, 0 };
    sc_bvh *b;
    sc_status st = sc_bvh_build(m, cfg, &b);
    if (st != SC_OK)
        return st;
    sc_bvh_info info;
    sc_bvh_get_info(b, &info);
    ours_built(t, b, info.build_seconds, info.total_bytes, m->triangle_count, cfg);
    return SC_OK;
}

static sc_status tracer_build(sc_tracer *t, const sc_tracer_def *def, const sc_checked_mesh *cm);

sc_status sc_tracer_build_scene_bvh(sc_tracer *t, const char *name, const sc_bvh_config *cfg,
                                     const sc_scene_view *v)
{
    if (!t || !cfg || !v)
        return SC_ERR_INVALID_ARGUMENT;
    memset(t, 0, sizeof *t);
    t->def = (sc_tracer_def){ name, SC_TRACER_OURS, cfg->prefilter, cfg->tri_test, 0, 0, cfg->quality, 0 };
    t->instanced = 1;
    sc_scene_accel *a;
    sc_status st = sc_scene_accel_build(v, cfg, &a);
    if (st != SC_OK)
        return st;
    size_t bytes = 0;
    double secs = 0;
    sc_scene_accel_info(a, NULL, &bytes, &secs);
    ours_built(t, a, secs, bytes, v->mesh.triangle_count, cfg);
    return SC_OK;
}

static sc_status tracer_build_scene(sc_tracer *t, const sc_tracer_def *def, const sc_scene_view *v);

sc_status sc_tracer_build_scene(sc_tracer *t, const sc_tracer_def *def, const sc_scene_view *v)
{
    double t0 = sc_now_seconds();
    sc_status st = tracer_build_scene(t, def, v);
    if (st == SC_OK)
        t->build_seconds = sc_now_seconds() - t0;
    return st;
}

sc_status sc_tracer_build(sc_tracer *t, const sc_tracer_def *def, const sc_checked_mesh *cm)
{
    double t0 = sc_now_seconds();
    sc_status st = tracer_build(t, def, cm);
    if (st == SC_OK)
        t->build_seconds = sc_now_seconds() - t0;
    return st;
}

static sc_status tracer_build(sc_tracer *t, const sc_tracer_def *def, const sc_checked_mesh *cm)
{
    if (!t || !def || !cm)
        return SC_ERR_INVALID_ARGUMENT;
    const sc_mesh_view *m = &cm->view;
    if (def->family == SC_TRACER_OURS) {
        sc_bvh_config cfg;
        sc_bvh_config_default(&cfg);
        cfg.prefilter = (sc_prefilter_mode)def->mode;
        cfg.tri_test = (sc_tri_test)def->quality;
        cfg.quality = (sc_build_quality)def->build;
        cfg.threads = 0;      /* every CPU, as Embree's build (build_threads 0) */
        sc_status st = sc_tracer_build_bvh(t, def->name, &cfg, cm);
        t->def.packet = def->packet;
        /* packets test spheres only for one-origin packets (the cone): the
         * false positives of a sphere pass are not counted there */
        if (def->packet)
            t->fp_exact = 0;
        return st;
    }
    memset(t, 0, sizeof *t);
    t->def = *def;
#ifdef SC_HAVE_EMBREE
    sc_embree_config cfg;
    sc_embree_config_default(&cfg);
    cfg.mode = (sc_embree_mode)def->mode;
    cfg.quality = (sc_embree_quality)def->quality;
    if (def->cluster)
        cfg.cluster_size = def->cluster;
    sc_embree *e;
    sc_status st = sc_embree_create(cm, &cfg, &e);
    if (st != SC_OK)
        return st;
    sc_embree_info info;
    sc_embree_get_info(e, &info);
    t->handle = e;
    t->bytes_per_tri = (double)(info.embree_bytes + info.ours_bytes) / m->triangle_count;
    t->prefilter = def->mode == SC_EMBREE_USER_PREFILTER;
    t->counted = def->mode == SC_EMBREE_USER_PREFILTER || def->mode == SC_EMBREE_USER_PLAIN;
    t->fp_exact = t->prefilter;
    return SC_OK;
#else
    return SC_ERR_UNSUPPORTED;
#endif
}

/* Embree through instances: hit (inst, prim) back to view->mesh. */
typedef struct embree_map {
    const sc_scene_instance *instances;
    size_t num_instances;
    uint32_t *own_prim;     /* own triangle k is view->mesh triangle own_prim[k] */
    size_t num_own;
} embree_map;

static void embree_map_free(embree_map *m)
{
    if (m)
        free(m->own_prim);
    free(m);
}

static sc_status tracer_build_scene(sc_tracer *t, const sc_tracer_def *def, const sc_scene_view *v)
{
    if (!t || !def || !v || (v->num_instances && (!v->instances || !v->objects)))
        return SC_ERR_INVALID_ARGUMENT;
    memset(t, 0, sizeof *t);
    t->def = *def;
    t->instanced = 1;
    const size_t nt = v->mesh.triangle_count;
    if (def->family == SC_TRACER_OURS) {
        sc_bvh_config cfg;
        sc_bvh_config_default(&cfg);
        cfg.prefilter = (sc_prefilter_mode)def->mode;
        cfg.tri_test = (sc_tri_test)def->quality;
        cfg.quality = (sc_build_quality)def->build;
        cfg.threads = 0;
        sc_status st = sc_tracer_build_scene_bvh(t, def->name, &cfg, v);
        t->def.packet = def->packet;
        return st;
    }
#ifdef SC_HAVE_EMBREE
    /* Embree 3.13.5's rtcOccluded16 and rtcOccluded1M through instances do
     * not return on some ray sets (orchard.json's shadow rays, again in the
     * thirteenth session; the instance test under ASan: docs/scenes.md), so
     * its packets and streams are left out here; bench_scene times them
     * against ours on its own instanced scenes */
    if ((def->mode != SC_EMBREE_DEFAULT && def->mode != SC_EMBREE_ROBUST && def->mode != SC_EMBREE_COMPACT) ||
        def->packet == 8 || def->packet == 16 || def->packet == SC_TRACER_STREAM)
        return SC_ERR_UNSUPPORTED;
    sc_status st = SC_ERR_OUT_OF_MEMORY;
    embree_map *map = calloc(1, sizeof *map);
    uint32_t *own_idx = NULL;
    float *own_pos = NULL;
    sc_checked_mesh *objs = calloc(v->num_objects ? v->num_objects : 1, sizeof *objs);
    sc_embree_instance *inst = malloc((v->num_instances ? v->num_instances : 1) * sizeof *inst);
    sc_embree *e = NULL;
    if (!map || !objs || !inst ||
        (st = sc_scene_view_own_triangles(v, &own_idx, &map->own_prim, &map->num_own)) != SC_OK)
        goto done;
    map->instances = v->instances, map->num_instances = v->num_instances;
    for (size_t i = 0; i < v->num_instances; i++) {
        inst[i].object = v->instances[i].object;
        memcpy(inst[i].xfm, v->instances[i].xfm, sizeof inst[i].xfm);
    }
    for (size_t k = 0; k < v->num_objects; k++)
        if ((st = sc_mesh_check(&v->objects[k], &objs[k])) != SC_OK)
            goto done;
    /* the own triangles with only their vertices: Embree copies every
     * vertex of a geometry's buffer */
    sc_checked_mesh own;
    if (map->num_own) {
        uint32_t *remap = malloc((v->mesh.vertex_count ? v->mesh.vertex_count : 1) * sizeof *remap);
        own_pos = malloc(9 * sizeof(float) * map->num_own);
        st = SC_ERR_OUT_OF_MEMORY;
        if (!remap || !own_pos) {
            free(remap);
            goto done;
        }
        memset(remap, 0xff, v->mesh.vertex_count * sizeof *remap);
        uint32_t nv = 0;
        for (size_t k = 0; k < 3 * map->num_own; k++) {
            uint32_t *x = &own_idx[k];
            if (remap[*x] == UINT32_MAX) {
                memcpy(own_pos + 3 * (size_t)nv, sc_mesh_vertex(&v->mesh, *x), 3 * sizeof(float));
                remap[*x] = nv++;
            }
            *x = remap[*x];
        }
        free(remap);
        const sc_mesh_view own_view = { own_pos, nv, own_idx, map->num_own, 0, 0 };
        if ((st = sc_mesh_check(&own_view, &own)) != SC_OK)
            goto done;
    }
    sc_embree_config cfg;
    sc_embree_config_default(&cfg);
    cfg.mode = (sc_embree_mode)def->mode;
    cfg.quality = (sc_embree_quality)def->quality;
    if ((st = sc_embree_create_instanced(map->num_own ? &own : NULL, objs, v->num_objects, inst, v->num_instances, &cfg, &e)) != SC_OK)
        goto done;
    sc_embree_info info;
    sc_embree_get_info(e, &info);
    t->handle = e;
    t->aux = map;
    map = NULL;
    t->bytes_per_tri = nt ? (double)info.embree_bytes / nt : 0;
done:
    embree_map_free(map);
    free(own_idx), free(own_pos), free(objs), free(inst);
    return st;
#else
    (void)nt;
    return SC_ERR_UNSUPPORTED;
#endif
}

void sc_tracer_free(sc_tracer *t)
{
    if (!t || !t->handle)
        return;
    if (t->def.family == SC_TRACER_OURS && t->instanced)
        sc_scene_accel_free(t->handle);
    else if (t->def.family == SC_TRACER_OURS)
        sc_bvh_free(t->handle);
#ifdef SC_HAVE_EMBREE
    else
        sc_embree_destroy(t->handle);
#endif
    embree_map_free(t->aux);
    t->handle = NULL;
    t->aux = NULL;
}

const sc_bvh *sc_tracer_bvh(const sc_tracer *t)
{
    return t && t->def.family == SC_TRACER_OURS && !t->instanced ? t->handle : NULL;
}

void sc_tracer_counters_add(sc_tracer_counters *to, const sc_tracer_counters *c)
{
    to->rays += c->rays, to->nodes += c->nodes, to->leaves += c->leaves;
    to->sphere_tests += c->sphere_tests, to->sphere_rejects += c->sphere_rejects;
    to->tri_tests += c->tri_tests, to->tri_hits += c->tri_hits, to->false_positives += c->false_positives;
}

/* Rays [base, base + W) as a packet (the tail padded with invalid lanes). */
static void fill_packet(const sc_ray *rays, size_t n, size_t base, unsigned W, float *soa, int32_t *valid)
{
    if (base + W <= n) {
        /* a full packet: a transpose of W rays of 8 floats, 4x4 blocks */
        const float *src = (const float *)(const void *)(rays + base);
#if defined(__SSE__)
        for (unsigned i = 0; i < W; i += 4) {
            for (unsigned h = 0; h < 8; h += 4) {
                __m128 r0 = _mm_loadu_ps(src + 8 * i + h), r1 = _mm_loadu_ps(src + 8 * (i + 1) + h);
                __m128 r2 = _mm_loadu_ps(src + 8 * (i + 2) + h), r3 = _mm_loadu_ps(src + 8 * (i + 3) + h);
                _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
                _mm_storeu_ps(soa + (h + 0) * W + i, r0);
                _mm_storeu_ps(soa + (h + 1) * W + i, r1);
                _mm_storeu_ps(soa + (h + 2) * W + i, r2);
                _mm_storeu_ps(soa + (h + 3) * W + i, r3);
            }
        }
#else
        for (unsigned f = 0; f < 8; f++)
            for (unsigned i = 0; i < W; i++)
                soa[f * W + i] = src[8 * i + f];
#endif
        for (unsigned i = 0; i < W; i++)
            valid[i] = 1;
        return;
    }
    for (unsigned i = 0; i < W; i++) {
        size_t k = base + i;
        const sc_ray *r = &rays[k < n ? k : n - 1];
        valid[i] = k < n;
        soa[0 * W + i] = r->org[0], soa[1 * W + i] = r->org[1], soa[2 * W + i] = r->org[2];
        soa[3 * W + i] = r->tmin;
        soa[4 * W + i] = r->dir[0], soa[5 * W + i] = r->dir[1], soa[6 * W + i] = r->dir[2];
        soa[7 * W + i] = r->tmax;
    }
}

static sc_status ours_packets(const sc_tracer *t, const sc_ray *rays, size_t n, sc_hitrec *hits, uint8_t *occ,
                              sc_trace_stats *tsp)
{
    const unsigned W = (unsigned)t->def.packet;
    sc_ray_packet16 p __attribute__((aligned(64)));
    sc_hit_packet16 h __attribute__((aligned(64)));
    int32_t valid[16], o[16];
    const sc_accel *w = t->instanced ? sc_scene_accel_world(t->handle) : NULL;
    const sc_ray_packet8 *p8 = (const sc_ray_packet8 *)(const void *)&p;
    sc_hit_packet8 *h8 = (sc_hit_packet8 *)(void *)&h;
    for (size_t base = 0; base < n; base += W) {
        fill_packet(rays, n, base, W, p.ox, valid);
        sc_status st;
        if (w && W == 16)
            st = occ ? sc_accel_any16(w, valid, &p, o, tsp) : sc_accel_closest16(w, valid, &p, &h, tsp);
        else if (w)
            st = occ ? sc_accel_any8(w, valid, p8, o, tsp) : sc_accel_closest8(w, valid, p8, h8, tsp);
        else if (W == 16)
            st = occ ? sc_trace_any16(t->handle, valid, &p, o, tsp) : sc_trace_closest16(t->handle, valid, &p, &h, tsp);
        else
            st = occ ? sc_trace_any8(t->handle, valid, p8, o, tsp) : sc_trace_closest8(t->handle, valid, p8, h8, tsp);
        if (st != SC_OK)
            return st;
        for (unsigned i = 0; i < W && base + i < n; i++) {
            if (occ) {
                occ[base + i] = (uint8_t)o[i];
                continue;
            }
            /* an 8-wide hit packet has the same rows at stride 8 */
            sc_hitrec *hr = &hits[base + i];
            const float *hf = h.t;
            hr->t = hf[0 * W + i], hr->u = hf[1 * W + i], hr->v = hf[2 * W + i];
            hr->prim = ((const uint32_t *)(const void *)hf)[3 * W + i];
            if (w) {
                hr->geom = ((const uint32_t *)(const void *)hf)[7 * W + i];
                hr->inst = ((const uint32_t *)(const void *)hf)[8 * W + i];
                sc_scene_accel_flat_hit(t->handle, hr);
            }
        }
    }
    return SC_OK;
}

static sc_status ours_run(const sc_tracer *t, const sc_ray *rays, size_t n, sc_hitrec *hits, uint8_t *occ,
                          sc_tracer_counters *ctr)
{
    sc_trace_stats ts, *tsp = NULL;
    if (ctr) {
        memset(&ts, 0, sizeof ts);
        tsp = &ts;
    }
    if (t->instanced) {
        /* single rays, packets and streams through the instances, as for a flat mesh */
        const sc_accel *w = sc_scene_accel_world(t->handle);
        sc_status st = SC_OK;
        if (t->def.packet == SC_TRACER_STREAM) {
            st = occ ? sc_scene_accel_any(t->handle, rays, n, occ, tsp)
                     : sc_scene_accel_closest(t->handle, rays, n, hits, tsp);
        } else if (t->def.packet == 8 || t->def.packet == 16) {
            st = ours_packets(t, rays, n, hits, occ, tsp);
        } else {
            for (size_t i = 0; i < n && st == SC_OK; i++) {
                if (occ) {
                    int o = 0;
                    st = sc_accel_any(w, &rays[i], &o, tsp);
                    occ[i] = (uint8_t)o;
                } else {
                    st = sc_accel_closest(w, &rays[i], &hits[i], tsp);
                    sc_scene_accel_flat_hit(t->handle, &hits[i]);
                }
            }
        }
        if (st == SC_OK && ctr) {
            sc_tracer_counters c = { n, ts.nodes, ts.leaves, ts.sphere_tests, ts.sphere_rejects, ts.tri_tests,
                                     ts.tri_hits, t->fp_exact ? ts.tri_tests - ts.tri_hits : 0 };
            sc_tracer_counters_add(ctr, &c);
        }
        return st;
    }
    if (t->def.packet == SC_TRACER_STREAM || t->def.packet == 8 || t->def.packet == 16) {
        sc_status st;
        if (t->def.packet != SC_TRACER_STREAM) {
            st = ours_packets(t, rays, n, hits, occ, tsp);
        } else if (occ) {
            st = SC_OK;
            int32_t o[256];
            for (size_t b = 0; b < n && st == SC_OK; b += 256) {
                size_t k = n - b < 256 ? n - b : 256;
                st = sc_trace_any_n(t->handle, rays + b, sizeof(sc_ray), o, sizeof(int32_t), k, 0, tsp);
                for (size_t i = 0; i < k; i++)
                    occ[b + i] = (uint8_t)o[i];
            }
        } else {
            st = sc_trace_closest_n(t->handle, rays, sizeof(sc_ray), hits, sizeof(sc_hitrec), n, 0, tsp);
        }
        if (st == SC_OK && ctr) {
            sc_tracer_counters c = { n, ts.nodes, ts.leaves, ts.sphere_tests, ts.sphere_rejects, ts.tri_tests,
                                     ts.tri_hits, 0 };
            sc_tracer_counters_add(ctr, &c);
        }
        return st;
    }
    for (size_t i = 0; i < n; i++) {
        sc_status st;
        if (occ) {
            int o = 0;
            st = sc_trace_any(t->handle, &rays[i], &o, tsp);
            occ[i] = (uint8_t)o;
        } else {
            st = sc_trace_closest(t->handle, &rays[i], &hits[i], tsp);
        }
        if (st != SC_OK)
            return st;
    }
    if (ctr) {
        /* every exact test in a sphere leaf follows a passed sphere; exact
         * only when all leaves carry spheres */
        sc_tracer_counters c = { n, ts.nodes, ts.leaves, ts.sphere_tests, ts.sphere_rejects, ts.tri_tests,
                                 ts.tri_hits, t->fp_exact ? ts.tri_tests - ts.tri_hits : 0 };
        sc_tracer_counters_add(ctr, &c);
    }
    return SC_OK;
}

#ifdef SC_HAVE_EMBREE
static sc_status embree_run(const sc_tracer *t, const sc_ray *rays, size_t n, sc_hitrec *hits, uint8_t *occ,
                            sc_tracer_counters *ctr)
{
    sc_embree_counters ec, *ecp = NULL;
    if (ctr) {
        memset(&ec, 0, sizeof ec);
        ecp = &ec;
    }
    const int coherent = t->def.coherence ? t->def.coherence == SC_TRACER_COHERENT : !t->incoherent;
    sc_status st;
    if (t->def.packet == SC_TRACER_STREAM && occ)
        st = sc_embree_occluded_stream(t->handle, rays, n, occ, coherent, ecp);
    else if (t->def.packet == SC_TRACER_STREAM)
        st = sc_embree_intersect_stream(t->handle, rays, n, hits, coherent, ecp);
    else if (occ && t->def.packet)
        st = sc_embree_occluded_packets(t->handle, t->def.packet, rays, n, occ, coherent, ecp);
    else if (occ)
        st = sc_embree_occluded1(t->handle, rays, n, occ, ecp);
    else if (t->def.packet)
        st = sc_embree_intersect_packets(t->handle, t->def.packet, rays, n, hits, coherent, ecp);
    else
        st = sc_embree_intersect1(t->handle, rays, n, hits, ecp);
    const embree_map *map = t->aux;
    if (map && !occ)
        for (size_t i = 0; i < n; i++) {
            sc_hitrec *h = &hits[i];
            if (h->prim == SC_HITREC_MISS)
                continue;
            h->prim = h->inst != SC_INVALID_ID ? (uint32_t)(map->instances[h->inst].first_triangle + h->prim)
                                               : map->own_prim[h->prim];
            h->geom = 0;
            h->inst = SC_INVALID_ID;
        }
    if (st == SC_OK && ctr) {
        sc_tracer_counters c = { n, 0, 0, ec.sphere_tests, ec.sphere_rejects, ec.tri_tests, ec.tri_hits,
                                 ec.false_positives };
        sc_tracer_counters_add(ctr, &c);
    }
    return st;
}
#endif

sc_status sc_tracer_run(const sc_tracer *t, const sc_ray *rays, size_t n, sc_hitrec *hits, uint8_t *occ,
                        sc_tracer_counters *ctr)
{
    if (!t || !t->handle || (n && (!rays || (!hits && !occ))))
        return SC_ERR_INVALID_ARGUMENT;
    if (t->def.family == SC_TRACER_OURS)
        return ours_run(t, rays, n, hits, occ, ctr);
#ifdef SC_HAVE_EMBREE
    return embree_run(t, rays, n, hits, occ, ctr);
#else
    return SC_ERR_UNSUPPORTED;
#endif
}

/* ---- threads -------------------------------------------------------------- */

enum { CHUNK = 1024 };   /* a multiple of every packet width */

typedef struct pool_job {
    const sc_tracer *t;
    const sc_ray *rays;
    size_t n;
    sc_hitrec *hits;
    uint8_t *occ;
    atomic_size_t next;
    atomic_int failed;
} pool_job;

static void *pool_worker(void *arg)
{
    pool_job *j = arg;
#if defined(__SSE__)
    const unsigned csr = _mm_getcsr();
    if (j->t->ftz)
        _mm_setcsr(csr | 0x8040);            /* FTZ (bit 15) | DAZ (bit 6) */
#endif
    for (;;) {
        size_t b = atomic_fetch_add(&j->next, CHUNK);
        if (b >= j->n)
            break;
        size_t e = b + CHUNK < j->n ? b + CHUNK : j->n;
        if (sc_tracer_run(j->t, j->rays + b, e - b, j->occ ? NULL : j->hits + b, j->occ ? j->occ + b : NULL,
                          NULL) != SC_OK)
            atomic_store(&j->failed, 1);
    }
#if defined(__SSE__)
    _mm_setcsr(csr);
#endif
    return NULL;
}

sc_status sc_tracer_run_threads(const sc_tracer *t, const sc_ray *rays, size_t n, sc_hitrec *hits,
                                uint8_t *occ, int threads, double *seconds)
{
    if (threads < 1 || threads > SC_TRACER_MAX_THREADS)
        return SC_ERR_INVALID_ARGUMENT;
    pool_job j;
    j.t = t, j.rays = rays, j.n = n, j.hits = hits, j.occ = occ;
    atomic_init(&j.next, 0);
    atomic_init(&j.failed, 0);
    pthread_t tid[SC_TRACER_MAX_THREADS];
    int started[SC_TRACER_MAX_THREADS] = { 0 };
    double t0 = sc_now_seconds();
    for (int k = 1; k < threads; k++)
        started[k] = pthread_create(&tid[k], NULL, pool_worker, &j) == 0;
    pool_worker(&j);
    for (int k = 1; k < threads; k++)
        if (started[k])
            pthread_join(tid[k], NULL);
    if (seconds)
        *seconds = sc_now_seconds() - t0;
    return atomic_load(&j.failed) ? SC_ERR_INVALID_ARGUMENT : SC_OK;
}

/* ---- judging and lighting -------------------------------------------------- */

int sc_same_hit(const sc_hitrec *a, const sc_hitrec *b, float rel)
{
    if (a->prim == SC_HITREC_MISS || b->prim == SC_HITREC_MISS)
        return a->prim == b->prim;
    return fabsf(a->t - b->t) <= rel * fabsf(b->t);
}

void sc_light_point(const sc_light *lights, size_t nlights, const float lo[3], const float hi[3], float out[3])
{
    double c[3], diag = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * ((double)lo[k] + hi[k]);
        diag += ((double)hi[k] - lo[k]) * ((double)hi[k] - lo[k]);
    }
    diag = sqrt(diag);
    for (size_t i = 0; i < nlights; i++)
        if (lights[i].type == SC_LIGHT_POINT) {
            memcpy(out, lights[i].vec, 3 * sizeof(float));
            return;
        }
    for (size_t i = 0; i < nlights; i++)
        if (lights[i].type == SC_LIGHT_DIRECTIONAL) {
            for (int k = 0; k < 3; k++)
                out[k] = (float)(c[k] - 2 * diag * lights[i].vec[k]);
            return;
        }
    const double d[3] = { 0.3, 1.0, 0.2 };
    for (int k = 0; k < 3; k++)
        out[k] = (float)(c[k] + 2 * diag * d[k]);
}
