/* The tracer benchmark (see bench.h). */
#define _GNU_SOURCE
#include <linux/perf_event.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/syscall.h>
#include <unistd.h>

#include "common/sc_median.h"
#include "bench.h"
#include "common/sc_clock.h"
#include "spherecull/sc_trace.h"
#include "tri_filter.h"

enum { BRUTE_SAMPLE = 64 };

void sc_bench_options_default(sc_bench_options *o)
{
    memset(o, 0, sizeof *o);
    o->kinds[0] = SC_RAYS_PRIMARY, o->kinds[1] = SC_RAYS_SHADOW, o->nkinds = 2;
    o->threads[0] = 1, o->threads[1] = 2, o->nthreads = 2;
    o->leaves[0] = 4, o->leaves[1] = 8, o->leaves[2] = 16, o->nleaves = 3;
    for (int m = 0; m < SC_PREFILTER_MODE_COUNT; m++)
        o->modes[m] = m;
    o->nmodes = SC_PREFILTER_MODE_COUNT;
    o->width = 512, o->height = 384, o->repeats = 5;
    o->count = 65536;
    o->trav_cost = -1;
    o->tri = SC_TRI_WATERTIGHT;
}

int sc_bench_cycles_open(void)
{
    struct perf_event_attr a;
    memset(&a, 0, sizeof a);
    a.size = sizeof a;
    a.type = PERF_TYPE_HARDWARE;
    a.config = PERF_COUNT_HW_CPU_CYCLES;
    a.exclude_kernel = 1;
    a.exclude_hv = 1;
    return (int)syscall(SYS_perf_event_open, &a, 0, -1, -1, 0);
}

static uint64_t cycles_read(int fd)
{
    uint64_t v = 0;
    if (fd < 0 || read(fd, &v, sizeof v) != (ssize_t)sizeof v)
        return 0;
    return v;
}

/* Everything one scene's measurements share. */
typedef struct bench_ctx {
    sc_checked_mesh mesh;        /* checked once at entry */
    const sc_bench_options *o;
    int cycles_fd;
    sc_rayset sets[SC_BENCH_KINDS];
    sc_tracer emb;                 /* handle NULL without Embree */
    sc_hitrec *hits;               /* the tracer under test's, one per ray of the largest set */
    uint8_t *occ;
    sc_hitrec *emb_hits[SC_BENCH_KINDS];   /* Embree's answers per closest-hit set */
    uint8_t *emb_occ;                      /* and for the shadow rays */
    char *err;
    size_t errlen;
    /* Through instances (NULL: the flat mesh): the view, the object-space
     * rays (accel), and for the brute-force check one tree per object and
     * one over the rest, built with the benchmark's triangle test */
    const sc_scene_view *iv;
    sc_scene_accel *accel;
    sc_bvh **obj_bvh, *own_bvh;
    double (*obj_box)[6];
    uint32_t *own_idx, *own_prim;
    size_t num_own;
} bench_ctx;

static sc_status run(const sc_tracer *t, sc_rayset_kind kind, const sc_rayset *rs, bench_ctx *c, int threads,
                     double *seconds)
{
    return sc_tracer_run_threads(t, rs->rays, rs->count, kind != SC_RAYS_SHADOW ? c->hits : NULL,
                                 kind == SC_RAYS_SHADOW ? c->occ : NULL, threads, seconds);
}

static int wanted(const sc_bench_options *o, sc_rayset_kind kind)
{
    for (int i = 0; i < o->nkinds; i++)
        if (o->kinds[i] == kind)
            return 1;
    return 0;
}

static size_t count_hits(const sc_hitrec *h, size_t n)
{
    size_t k = 0;
    for (size_t i = 0; i < n; i++)
        k += h[i].prim != SC_HITREC_MISS;
    return k;
}

/* The shadow and diffuse rays come from our own hits in the default
 * configuration, so the ray sets do not depend on whether Embree is built
 * in. Every set is made (they are cheap); only the asked ones are timed. */
static sc_status make_rays(bench_ctx *c, const sc_camera *camera, const sc_light *lights, size_t nlights,
                           sc_bench_scene *sc)
{
    const sc_bench_options *o = c->o;
    sc_rayset *const prim = &c->sets[SC_RAYS_PRIMARY];
    sc->triangles = c->mesh.view.triangle_count;
    for (int k = 0; k < 3; k++)
        sc->lo[k] = c->mesh.lo[k], sc->hi[k] = c->mesh.hi[k];
    sc->camera = *camera;
    sc->camera.width = o->width, sc->camera.height = o->height;
    sc_light_point(lights, nlights, sc->lo, sc->hi, sc->light);
    sc_status st = sc_rayset_primary(&sc->camera, prim);
    if (st == SC_OK)
        st = sc_rayset_random(sc->lo, sc->hi, (size_t)o->count, 1, &c->sets[SC_RAYS_RANDOM]);
    if (st != SC_OK) {
        snprintf(c->err, c->errlen, "rays: %s", sc_strerror(st));
        return st;
    }
    size_t n = prim->count > c->sets[SC_RAYS_RANDOM].count ? prim->count : c->sets[SC_RAYS_RANDOM].count;
    c->hits = malloc((n + 1) * sizeof *c->hits);
    c->occ = malloc(n + 1);
    if (!c->hits || !c->occ) {
        snprintf(c->err, c->errlen, "out of memory");
        return SC_ERR_OUT_OF_MEMORY;
    }
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    sc_tracer ref;
    if ((st = c->iv ? sc_tracer_build_scene_bvh(&ref, "reference", &cfg, c->iv)
                    : sc_tracer_build_bvh(&ref, "reference", &cfg, &c->mesh)) != SC_OK) {
        snprintf(c->err, c->errlen, "BVH build: %s", sc_strerror(st));
        return st;
    }
    sc_tracer_run(&ref, prim->rays, prim->count, c->hits, NULL, NULL);
    sc->primary = prim->count, sc->primary_hits = count_hits(c->hits, prim->count);
    st = sc_rayset_shadow(&c->mesh, prim, c->hits, sc->light, &c->sets[SC_RAYS_SHADOW]);
    if (st == SC_OK)
        st = sc_rayset_diffuse(&c->mesh, prim, c->hits, 1, &c->sets[SC_RAYS_DIFFUSE]);
    if (st == SC_OK) {
        const sc_rayset *sh = &c->sets[SC_RAYS_SHADOW], *df = &c->sets[SC_RAYS_DIFFUSE],
                        *rn = &c->sets[SC_RAYS_RANDOM];
        sc_tracer_run(&ref, sh->rays, sh->count, NULL, c->occ, NULL);
        sc->shadow = sh->count, sc->shadow_blocked = 0;
        for (size_t i = 0; i < sh->count; i++)
            sc->shadow_blocked += c->occ[i];
        sc_tracer_run(&ref, df->rays, df->count, c->hits, NULL, NULL);
        sc->diffuse = df->count, sc->diffuse_hits = count_hits(c->hits, df->count);
        sc_tracer_run(&ref, rn->rays, rn->count, c->hits, NULL, NULL);
        sc->random = rn->count, sc->random_hits = count_hits(c->hits, rn->count);
    }
    sc_tracer_free(&ref);
    if (st != SC_OK)
        snprintf(c->err, c->errlen, "shadow/diffuse rays: %s", sc_strerror(st));
    return st;
}

static sc_status make_embree(bench_ctx *c, sc_bench_scene *sc)
{
    sc->embree_bpt = sc->embree_bvh_bpt = NAN;
    const sc_tracer_def *def = sc_tracer_find(c->o->embree_robust ? "embree-robust" : "embree");
    if (!def)
        return SC_OK;
    sc_tracer_def pdef;
    if (c->o->packet) {
        /* Embree's packets of the same width (robust flag as asked) */
        pdef = *def;
        pdef.packet = c->o->packet;
        def = &pdef;
    }
    sc_status st = c->iv ? sc_tracer_build_scene(&c->emb, def, c->iv) : sc_tracer_build(&c->emb, def, &c->mesh);
    if (st != SC_OK) {
        snprintf(c->err, c->errlen, "Embree: %s", sc_strerror(st));
        return st;
    }
    /* Embree holds its own copy of the vertex and index buffers (12 B per
     * vertex and per triangle); our leaves need no mesh at all, so the
     * comparable figure is Embree's BVH alone. Both are reported. */
    double ntri = (double)c->mesh.view.triangle_count;
    sc->embree_bpt = c->emb.bytes_per_tri;
    /* through instances Embree holds each object once: no flat copy to take off */
    sc->embree_bvh_bpt = c->iv ? NAN : sc->embree_bpt - 12.0 * (double)c->mesh.view.vertex_count / ntri - 12.0;
    for (int k = 0; k < SC_BENCH_KINDS; k++) {
        const sc_rayset *rs = &c->sets[k];
        if (!wanted(c->o, (sc_rayset_kind)k))
            continue;
        c->emb.incoherent = sc_tracer_set_incoherent((sc_rayset_kind)k);
        if (k == SC_RAYS_SHADOW) {
            if (!(c->emb_occ = malloc(rs->count + 1)))
                return SC_ERR_OUT_OF_MEMORY;
            sc_tracer_run(&c->emb, rs->rays, rs->count, NULL, c->emb_occ, NULL);
        } else {
            if (!(c->emb_hits[k] = malloc((rs->count + 1) * sizeof *c->emb_hits[k])))
                return SC_ERR_OUT_OF_MEMORY;
            sc_tracer_run(&c->emb, rs->rays, rs->count, c->emb_hits[k], NULL, NULL);
        }
    }
    return SC_OK;
}

/* Brute force through instances: every triangle of every instance whose
 * box the object ray may hit, with the same rounded object ray and the same
 * triangle test as the tracer; the first hit over them, as a view->mesh
 * index. */
static void brute_scene(const bench_ctx *c, const sc_ray *r, sc_hitrec *best)
{
    best->prim = SC_HITREC_MISS;
    best->t = INFINITY;
    sc_hitrec h;
    if (c->own_bvh) {
        sc_trace_closest_brute(c->own_bvh, r, &h);
        if (h.prim != SC_HITREC_MISS)
            *best = h, best->prim = c->own_prim[h.prim];
    }
    const sc_accel *world = sc_scene_accel_world(c->accel);
    for (size_t i = 0; i < c->iv->num_instances; i++) {
        const sc_scene_instance *in = &c->iv->instances[i];
        sc_ray o;
        if (sc_accel_instance_ray(world, (uint32_t)i, r, &o) != SC_OK)
            continue;
        const double O[3] = { o.org[0], o.org[1], o.org[2] }, D[3] = { o.dir[0], o.dir[1], o.dir[2] };
        if (!sc_tf_box_may_hit(c->obj_box[in->object], O, D, o.tmin, o.tmax))
            continue;
        sc_trace_closest_brute(c->obj_bvh[in->object], &o, &h);
        if (h.prim != SC_HITREC_MISS && (best->prim == SC_HITREC_MISS || h.t < best->t))
            *best = h, best->prim = (uint32_t)(in->first_triangle + h.prim);
    }
}

/* What brute_scene needs, built once: the tests' answers do not depend on
 * the leaf size or the prefilter, only on the triangle test. */
static sc_status prepare_instances(bench_ctx *c)
{
    const sc_scene_view *v = c->iv;
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    cfg.tri_test = c->o->tri;
    cfg.prefilter = SC_PREFILTER_OFF;
    sc_status st;
    if ((st = sc_scene_accel_build(v, &cfg, &c->accel)) != SC_OK ||
        (st = sc_scene_view_own_triangles(v, &c->own_idx, &c->own_prim, &c->num_own)) != SC_OK)
        return st;
    if (c->num_own) {
        const sc_mesh_view own = { v->mesh.positions, v->mesh.vertex_count, c->own_idx, c->num_own,
                                   v->mesh.vertex_stride, 0 };
        if ((st = sc_bvh_build(&own, &cfg, &c->own_bvh)) != SC_OK)
            return st;
    }
    c->obj_bvh = calloc(v->num_objects ? v->num_objects : 1, sizeof *c->obj_bvh);
    c->obj_box = calloc(v->num_objects ? v->num_objects : 1, sizeof *c->obj_box);
    if (!c->obj_bvh || !c->obj_box)
        return SC_ERR_OUT_OF_MEMORY;
    for (size_t k = 0; k < v->num_objects; k++) {
        float lo[3], hi[3];
        if ((st = sc_bvh_build(&v->objects[k], &cfg, &c->obj_bvh[k])) != SC_OK ||
            (st = sc_mesh_bounds(&v->objects[k], lo, hi)) != SC_OK)
            return st;
        for (int a = 0; a < 3; a++)
            c->obj_box[k][a] = lo[a], c->obj_box[k][3 + a] = hi[a];
        sc_tf_box_pad(c->obj_box[k]);
    }
    return SC_OK;
}

static void release_instances(bench_ctx *c)
{
    sc_scene_accel_free(c->accel);
    sc_bvh_free(c->own_bvh);
    for (size_t k = 0; c->obj_bvh && k < c->iv->num_objects; k++)
        sc_bvh_free(c->obj_bvh[k]);
    free(c->obj_bvh), free(c->obj_box), free(c->own_idx), free(c->own_prim);
}

/* Hits of one configuration against brute force (a sample; same
 * arithmetic, so only exact ties may differ) and against Embree (all). */
static void check(bench_ctx *c, const sc_tracer *t, sc_rayset_kind kind, const sc_rayset *rs, sc_bench_row *r)
{
    const size_t n = rs->count;
    memset(&r->work, 0, sizeof r->work);
    const int any = kind == SC_RAYS_SHADOW;
    sc_tracer_run(t, rs->rays, n, any ? NULL : c->hits, any ? c->occ : NULL, &r->work);
    size_t step = n > BRUTE_SAMPLE ? n / BRUTE_SAMPLE : 1;
    r->diff_brute = r->diff_embree = 0;
    for (size_t i = 0; i < n; i += step) {
        sc_hitrec h;
        if (c->iv)
            brute_scene(c, &rs->rays[i], &h);
        else
            sc_trace_closest_brute(sc_tracer_bvh(t), &rs->rays[i], &h);
        if (!any ? !sc_same_hit(&c->hits[i], &h, 0.0f) : c->occ[i] != (h.prim != SC_HITREC_MISS))
            r->diff_brute++;
    }
    if (c->emb.handle)
        for (size_t i = 0; i < n; i++)
            r->diff_embree += !any ? !sc_same_hit(&c->hits[i], &c->emb_hits[kind][i], 1e-4f)
                                   : c->occ[i] != c->emb_occ[i];
}

/* Paired repeats at one thread count: Embree first on even repeats,
 * second on odd ones. */
static void time_pairs(bench_ctx *c, const sc_tracer *t, sc_rayset_kind kind, const sc_rayset *rs, int thr, sc_bench_row *r)
{
    const int reps = c->o->repeats;
    double t_o[SC_BENCH_MAX_REPEATS], t_e[SC_BENCH_MAX_REPEATS], ratio[SC_BENCH_MAX_REPEATS],
        cratio[SC_BENCH_MAX_REPEATS];
    const int emb = c->emb.handle != NULL, fd = c->cycles_fd;
    if (c->o->timing)
        c->o->timing(c->o->timing_ctx, 1);
    run(t, kind, rs, c, thr, NULL);          /* warm-up */
    if (emb)
        run(&c->emb, kind, rs, c, thr, NULL);
    for (int i = 0; i < reps; i++) {
        double te = NAN, to;
        uint64_t ce = 0, co, c0;
        if (emb && i % 2 == 0) {
            c0 = cycles_read(fd);
            run(&c->emb, kind, rs, c, thr, &te);
            ce = cycles_read(fd) - c0;
        }
        c0 = cycles_read(fd);
        run(t, kind, rs, c, thr, &to);
        co = cycles_read(fd) - c0;
        if (emb && i % 2 == 1) {
            c0 = cycles_read(fd);
            run(&c->emb, kind, rs, c, thr, &te);
            ce = cycles_read(fd) - c0;
        }
        t_o[i] = to, t_e[i] = te;
        ratio[i] = te / to;
        cratio[i] = co ? (double)ce / (double)co : NAN;
    }
    if (c->o->timing)
        c->o->timing(c->o->timing_ctx, 0);
    r->threads = thr;
    r->mrays = (double)rs->count / sc_median(t_o, reps) * 1e-6;
    r->embree_mrays = (double)rs->count / sc_median(t_e, reps) * 1e-6;
    r->ratio = sc_median(ratio, reps);
    r->cycle_ratio = thr == 1 && fd >= 0 ? sc_median(cratio, reps) : NAN;
}

/* One BVH configuration: checked, then timed per ray kind and thread count. */
static sc_status run_config(bench_ctx *c, int leaf, int mode, const sc_bench_sink *sink)
{
    const sc_bench_options *o = c->o;
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    cfg.leaf_size = leaf;
    cfg.prefilter = (sc_prefilter_mode)mode;
    cfg.tri_test = o->tri;
    cfg.threads = 0;          /* every CPU, as Embree's build */
    if (o->trav_cost >= 0)
        cfg.traversal_cost = o->trav_cost;
    sc_tracer t;
    sc_status st = c->iv ? sc_tracer_build_scene_bvh(&t, sc_prefilter_mode_name(cfg.prefilter), &cfg, c->iv)
                         : sc_tracer_build_bvh(&t, sc_prefilter_mode_name(cfg.prefilter), &cfg, &c->mesh);
    if (st != SC_OK) {
        snprintf(c->err, c->errlen, "BVH build: %s", sc_strerror(st));
        return st;
    }
    t.def.packet = o->packet;
    sc_bvh_info info;
    memset(&info, 0, sizeof info);
    if (c->iv)
        info.build_seconds = t.build_seconds;     /* objects, rest and top level; no leaf census */
    else
        sc_bvh_get_info(sc_tracer_bvh(&t), &info);
    sc_bench_row r;
    memset(&r, 0, sizeof r);
    r.leaf = cfg.leaf_size, r.prefilter = cfg.prefilter, r.isa = sc_isa_active();
    r.bytes_per_tri = t.bytes_per_tri;
    r.sphere_leaf_pct = info.leaves ? 100.0 * (double)info.leaves_with_spheres / (double)info.leaves : 0;
    r.leaf_count = info.leaves, r.leaves_with_spheres = info.leaves_with_spheres;
    r.build_ms = info.build_seconds * 1e3;
    for (int ki = 0; ki < o->nkinds && st == SC_OK; ki++) {
        r.kind = o->kinds[ki];
        const sc_rayset *rs = &c->sets[r.kind];
        r.rays = rs->count;
        /* Embree's packets get their coherence flag from the ray set */
        c->emb.incoherent = sc_tracer_set_incoherent(r.kind);
        check(c, &t, r.kind, rs, &r);
        if (r.diff_brute) {
            size_t step = rs->count > BRUTE_SAMPLE ? rs->count / BRUTE_SAMPLE : 1;
            snprintf(c->err, c->errlen, "leaf %d %s: %zu of %zu sampled %s rays differ from brute force",
                     cfg.leaf_size, sc_prefilter_mode_name(cfg.prefilter), r.diff_brute,
                     (rs->count + step - 1) / step, sc_rayset_kind_name(r.kind));
            st = SC_ERR_INVALID_ARGUMENT;
            break;
        }
        for (int ti = 0; ti < o->nthreads; ti++) {
            time_pairs(c, &t, r.kind, rs, o->threads[ti], &r);
            if (sink && sink->row)
                sink->row(sink->ctx, &r);
        }
    }
    sc_tracer_free(&t);
    return st;
}

sc_status sc_bench_run(const sc_mesh_view *mesh, const sc_scene_view *instances, const sc_camera *camera,
                       const sc_light *lights, size_t nlights, const sc_bench_options *o, int cycles_fd,
                       const sc_bench_sink *sink, char *err, size_t errlen)
{
    char dummy[8];
    if (!err || !errlen)
        err = dummy, errlen = sizeof dummy;
    err[0] = 0;
    if (!mesh || !camera || !o || o->repeats < 1 || o->repeats > SC_BENCH_MAX_REPEATS ||
        o->count < 1)
        return SC_ERR_INVALID_ARGUMENT;
    for (int i = 0; i < o->nthreads; i++)
        if (o->threads[i] < 1 || o->threads[i] > SC_TRACER_MAX_THREADS)
            return SC_ERR_INVALID_ARGUMENT;
    bench_ctx c;
    memset(&c, 0, sizeof c);
    if (sc_mesh_check(mesh, &c.mesh) != SC_OK) {
        snprintf(err, errlen, "bad mesh");
        return SC_ERR_INVALID_ARGUMENT;
    }
    c.o = o, c.cycles_fd = cycles_fd, c.err = err, c.errlen = errlen;
    sc_bench_scene sc;
    memset(&sc, 0, sizeof sc);
    sc_status st = SC_OK;
    if (instances && instances->num_instances && !o->flatten) {
        if (o->packet) {
            snprintf(err, errlen, "Embree's packets are not timed through instances here, their yardstick (its "
                                  "rtcOccluded16 can hang there; bench/bench_scene times both): --instances flat, "
                                  "or --packet 0");
            return SC_ERR_UNSUPPORTED;
        }
        c.iv = instances;
        sc.instances = instances->num_instances;
        if ((st = prepare_instances(&c)) != SC_OK) {
            snprintf(err, errlen, "instances: %s", sc_strerror(st));
            release_instances(&c);
            return st;
        }
    }
    if (st == SC_OK)
        st = make_rays(&c, camera, lights, nlights, &sc);
    if (st == SC_OK)
        st = make_embree(&c, &sc);
    if (st == SC_OK && sink && sink->scene)
        sink->scene(sink->ctx, &sc);
    for (int li = 0; li < o->nleaves && st == SC_OK; li++)
        for (int mi = 0; mi < o->nmodes && st == SC_OK; mi++)
            st = run_config(&c, o->leaves[li], o->modes[mi], sink);
    sc_tracer_free(&c.emb);
    if (c.iv)
        release_instances(&c);
    free(c.hits), free(c.occ), free(c.emb_occ);
    for (int k = 0; k < SC_BENCH_KINDS; k++) {
        free(c.emb_hits[k]);
        sc_rayset_free(&c.sets[k]);
    }
    return st;
}
