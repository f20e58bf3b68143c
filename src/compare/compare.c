/* The comparison driver (see compare.h). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "common/sc_median.h"
#include "common/sc_clock.h"
#include "common/sc_csv.h"
#include "compare.h"
#include "crossing.h"
#include "oracle.h"
#include "tracer.h"
#ifdef SC_HAVE_EMBREE
#include "spherecull/sc_embree.h"
#endif

/* ---- rows ----------------------------------------------------------------- */

void sc_cmp_options_default(sc_cmp_options *o)
{
    memset(o, 0, sizeof *o);
    o->ray_kinds = (1u << SC_RAYS_KIND_COUNT) - 1;
    o->threads[0] = 1, o->threads[1] = 2;
    o->nthreads = 2;
    o->oracle_rays = 10000;
    o->repeats = 5;
    o->min_seconds = 0.2;
    o->ftz = 1;
    o->width = 512, o->height = 0;
    o->random_rays = 65536;
    o->adversarial_rays = 65536;
    o->seed = 1;
    o->oracle_threads = 2;
}

void sc_cmp_rows_free(sc_cmp_rows *r)
{
    if (!r)
        return;
    free(r->rows);
    memset(r, 0, sizeof *r);
}

static sc_cmp_row *row_add(sc_cmp_rows *r)
{
    if (r->count == r->cap) {
        size_t cap = r->cap ? 2 * r->cap : 64;
        sc_cmp_row *n = realloc(r->rows, cap * sizeof *n);
        if (!n)
            return NULL;
        r->rows = n, r->cap = cap;
    }
    sc_cmp_row *row = &r->rows[r->count++];
    memset(row, 0, sizeof *row);
    return row;
}

static int wanted(const sc_cmp_options *o, const char *name)
{
    if (o->ntracers == 0)
        return 1;
    for (int i = 0; i < o->ntracers; i++)
        if (strcmp(o->tracers[i], name) == 0)
            return 1;
    return 0;
}

typedef struct accuracy {
    size_t hit_miss, primid, holes, hole_rays, grazes_missed, graze_rays, oracle_rays;
    double t_med, t_max;
} accuracy;

static void score(const sc_rayset *set, const size_t *sample, const sc_oracle *orc, const sc_hitrec *hits,
                  const uint8_t *occ, int crossing, accuracy *a)
{
    memset(a, 0, sizeof *a);
    a->oracle_rays = orc->count;
    double *terr = malloc((orc->count ? orc->count : 1) * sizeof *terr);
    size_t nt = 0;
    for (size_t s = 0; s < orc->count; s++) {
        size_t i = sample[s];
        const sc_oracle_hit *o = &orc->hits[s];
        int hit = occ ? occ[i] != 0 : hits[i].prim != SC_HITREC_MISS;
        uint8_t tag = set->tag[i];
        int edgy = tag == SC_RAY_TAG_VERTEX || tag == SC_RAY_TAG_EDGE || tag == SC_RAY_TAG_EDGE_BACK;
        if (crossing && !occ) {
            /* A hole: a vertex/edge ray passes THROUGH the surface (exact
             * transversal crossing, crossing.h) and the tracer does not stop
             * there. A ray that only touches a silhouette vertex or edge is a
             * graze: reported apart, whatever its tag. */
            sc_oracle_verdict v = sc_oracle_judge(orc, s, hits[i].prim, hits[i].t);
            if (edgy && isfinite(o->cross_t)) {
                a->hole_rays++;
                a->holes += v == SC_VERDICT_HOLE;
            }
            if (o->hit && o->first_kind == SC_CROSS_TOUCH) {
                a->graze_rays++;
                a->grazes_missed += v == SC_VERDICT_GRAZE_MISSED;
            }
        }
        if (hit != o->hit) {
            a->hit_miss++;
            continue;
        }
        if (!hit || occ)
            continue;
        if (!sc_oracle_accepts(orc, s, hits[i].prim))
            a->primid++;
        double te = o->t != 0 ? fabs(((double)hits[i].t - o->t) / o->t) : fabs((double)hits[i].t);
        if (terr)
            terr[nt++] = te;
    }
    a->t_med = a->t_max = NAN;
    if (terr && nt) {
        qsort(terr, nt, sizeof *terr, sc_cmp_double);
        a->t_med = terr[nt / 2];
        a->t_max = terr[nt - 1];
    }
    free(terr);
}

/* One tracer's part of a set's timing: how many runs of the set make one
 * timed repeat, and each round's seconds for one run. */
typedef struct timed {
    int loops;
    double s[SC_CMP_MAX_REPEATS];
} timed;

/* One scene's comparison: the tracers, the ray sets, and the buffers every
 * set is traced into. */
typedef struct cmp_run {
    const char *scene;
    sc_checked_mesh mesh;        /* checked once, trusted from here on */
    const sc_cmp_options *opt;
    FILE *log;
    char *err;
    size_t errlen;
    int closed;
    sc_tracer tr[SC_CMP_MAX_TRACERS];
    int ntr;
    timed *timed;            /* one per tracer: the set being timed */
    /* Through instances (NULL: the flat mesh): the view, and what the
     * oracle needs: the own triangles, the objects checked, and a scene
     * accel whose object-space rays are the ones the hits are exact for. */
    const sc_scene_view *iv;
    sc_checked_mesh own, *objects;
    uint32_t *own_idx, *own_prim;
    size_t num_own;
    sc_scene_accel *oracle_accel;
    sc_rayset sets[SC_RAYS_KIND_COUNT];
    sc_hitrec *hits;
    uint8_t *occ;
    size_t *sample;          /* oracle sample: indices into the set */
    sc_ray *srays;           /* and its rays */
} cmp_run;

static void run_free(cmp_run *r)
{
    for (int k = 0; k < SC_RAYS_KIND_COUNT; k++)
        sc_rayset_free(&r->sets[k]);
    for (int i = 0; i < r->ntr; i++)
        sc_tracer_free(&r->tr[i]);
    free(r->hits), free(r->occ), free(r->sample), free(r->srays), free(r->timed);
    free(r->objects), free(r->own_idx), free(r->own_prim);
    sc_scene_accel_free(r->oracle_accel);
}

static sc_status object_ray(void *ctx, size_t inst, const sc_ray *world, sc_ray *obj)
{
    return sc_accel_instance_ray(sc_scene_accel_world(ctx), (uint32_t)inst, world, obj);
}

static sc_status oracle_run(cmp_run *r, const sc_ray *rays, size_t n, int flags, sc_oracle *orc)
{
    if (!r->iv)
        return sc_oracle_run(&r->mesh, rays, n, r->opt->oracle_threads, flags, orc);
    const sc_oracle_scene sc = { r->num_own ? &r->own : NULL, r->own_prim, r->objects, r->iv->num_objects,
                                 r->iv->instances, r->iv->num_instances, object_ray, r->oracle_accel };
    return sc_oracle_run_scene(&sc, rays, n, r->opt->oracle_threads, flags, orc);
}

/* The oracle's view of the instances (see cmp_run). */
static sc_status prepare_instances(cmp_run *r)
{
    const sc_scene_view *v = r->iv;
    sc_status st = sc_scene_view_own_triangles(v, &r->own_idx, &r->own_prim, &r->num_own);
    if (st != SC_OK)
        return st;
    if (r->num_own) {
        const sc_mesh_view own = { v->mesh.positions, v->mesh.vertex_count, r->own_idx, r->num_own,
                                   v->mesh.vertex_stride, 0 };
        if ((st = sc_mesh_check(&own, &r->own)) != SC_OK)
            return st;
    }
    if (!(r->objects = calloc(v->num_objects ? v->num_objects : 1, sizeof *r->objects)))
        return SC_ERR_OUT_OF_MEMORY;
    for (size_t k = 0; k < v->num_objects; k++)
        if ((st = sc_mesh_check(&v->objects[k], &r->objects[k])) != SC_OK)
            return st;
    return sc_scene_accel_build(v, NULL, &r->oracle_accel);
}

static sc_status fail(cmp_run *r, sc_status st, const char *what)
{
    if (r->err)
        snprintf(r->err, r->errlen, "%s: %s: %s", r->scene, what, sc_strerror(st));
    return st;
}

static sc_status build_tracers(cmp_run *r)
{
    int n;
    const char *const *names = sc_tracer_names(&n);
    for (int d = 0; d < n && r->ntr < SC_CMP_MAX_TRACERS; d++) {
        if (!wanted(r->opt, names[d]))
            continue;
        double t0 = sc_now_seconds();
        sc_status st = r->iv ? sc_tracer_build_scene(&r->tr[r->ntr], sc_tracer_find(names[d]), r->iv)
                             : sc_tracer_build(&r->tr[r->ntr], sc_tracer_find(names[d]), &r->mesh);
        if (st == SC_ERR_UNSUPPORTED && r->iv) {
            if (r->log) fprintf(r->log, "  %s: no path through instances (skipped)\n", names[d]);
            continue;
        }
        if (st != SC_OK) {
            if (r->log) fprintf(r->log, "  %s: build failed: %s (skipped)\n", names[d], sc_strerror(st));
            continue;
        }
        if (r->log) fprintf(r->log, "  built %-24s %6.2f s  %.0f B/tri\n", names[d], sc_now_seconds() - t0,
                            r->tr[r->ntr].bytes_per_tri);
        r->ntr++;
    }
    if (r->ntr == 0) {
        if (r->err) snprintf(r->err, r->errlen, "no tracer available (names: see --help)");
        return SC_ERR_UNSUPPORTED;
    }
    return SC_OK;
}

/* Shadow and diffuse rays start at primary hits. They come from one fixed
 * tracer (the first single-ray one of the table: ours) so the sets do not
 * depend on which tracers were asked for. */
static sc_status secondary_rays(cmp_run *r, const float light[3])
{
    const sc_rayset *prim = &r->sets[SC_RAYS_PRIMARY];
    const sc_tracer_def *rd = NULL;
    int n;
    const char *const *names = sc_tracer_names(&n);
    for (int d = 0; d < n && !rd; d++)
        if (!sc_tracer_find(names[d])->packet)
            rd = sc_tracer_find(names[d]);
    sc_hitrec *ref_hits = malloc((prim->count ? prim->count : 1) * sizeof *ref_hits);
    sc_tracer reft;
    if (!rd || !ref_hits ||
        (r->iv ? sc_tracer_build_scene(&reft, rd, r->iv) : sc_tracer_build(&reft, rd, &r->mesh)) != SC_OK) {
        free(ref_hits);
        if (r->err) snprintf(r->err, r->errlen, "%s: no reference tracer for shadow rays", r->scene);
        return SC_ERR_OUT_OF_MEMORY;
    }
    sc_status st = sc_tracer_run(&reft, prim->rays, prim->count, ref_hits, NULL, NULL);
    sc_tracer_free(&reft);
    if (st == SC_OK)
        st = sc_rayset_shadow(&r->mesh, prim, ref_hits, light, &r->sets[SC_RAYS_SHADOW]);
    if (st == SC_OK)
        st = sc_rayset_diffuse(&r->mesh, prim, ref_hits, r->opt->seed, &r->sets[SC_RAYS_DIFFUSE]);
    free(ref_hits);
    if (st != SC_OK)
        return fail(r, st, "shadow/diffuse rays");
    if (r->log) fprintf(r->log, "  shadow/diffuse origins from %s's primary hits\n", rd->name);
    return SC_OK;
}

static sc_status make_rays(cmp_run *r, const sc_camera *camera, const float light[3])
{
    const sc_cmp_options *opt = r->opt;
    /* Primary rays at the requested width, the camera's aspect kept. */
    sc_camera cam = *camera;
    cam.width = opt->width;
    cam.height = opt->height > 0 ? opt->height
                                 : (int)lround((double)opt->width * camera->height / camera->width);
    if (cam.height < 1) cam.height = 1;
    sc_status st = sc_rayset_primary(&cam, &r->sets[SC_RAYS_PRIMARY]);
    if (st != SC_OK)
        return fail(r, st, "primary rays");
    if (opt->ray_kinds & ((1u << SC_RAYS_SHADOW) | (1u << SC_RAYS_DIFFUSE)))
        if ((st = secondary_rays(r, light)) != SC_OK)
            return st;
    if ((st = sc_rayset_random(r->mesh.lo, r->mesh.hi, opt->random_rays ? opt->random_rays : 1, opt->seed,
                               &r->sets[SC_RAYS_RANDOM])) != SC_OK ||
        (st = sc_rayset_adversarial(&r->mesh, opt->adversarial_rays ? opt->adversarial_rays : 1, opt->seed,
                                    &r->sets[SC_RAYS_ADVERSARIAL])) != SC_OK)
        return fail(r, st, "random/adversarial rays");
    size_t maxn = 1;
    for (int k = 0; k < SC_RAYS_KIND_COUNT; k++)
        if (r->sets[k].count > maxn)
            maxn = r->sets[k].count;
    r->hits = malloc(maxn * sizeof *r->hits);
    r->occ = malloc(maxn);
    r->sample = malloc(maxn * sizeof *r->sample);
    r->srays = malloc(maxn * sizeof *r->srays);
    r->timed = malloc(SC_CMP_MAX_TRACERS * sizeof *r->timed);
    return r->hits && r->occ && r->sample && r->srays && r->timed ? SC_OK : SC_ERR_OUT_OF_MEMORY;
}

/* Times every tracer on one set at one thread count in rounds: a round runs
 * each tracer once, forwards on even rounds and backwards on odd ones, so a
 * burst of load from the VM's neighbours falls on every tracer of a round
 * alike and the ratios of one round are paired in time (timing them one
 * tracer after another put two runs of one Embree configuration 25 % apart).
 * A repeat runs the set `loops` times, enough for min_seconds, so a small
 * set is not timed over a few milliseconds; the first run of each tracer
 * (untimed for the result) measures how many that is. */
static sc_status time_rounds(cmp_run *r, int k, int nthreads, timed *tm)
{
    const sc_cmp_options *opt = r->opt;
    const sc_rayset *set = &r->sets[k];
    uint8_t *occ = k == SC_RAYS_SHADOW ? r->occ : NULL;
    const int reps = opt->repeats;
    sc_status st = SC_OK;
    if (opt->timing)
        opt->timing(opt->timing_ctx, 1);
    for (int ti = 0; ti < r->ntr && st == SC_OK; ti++) {
        double first;
        st = sc_tracer_run_threads(&r->tr[ti], set->rays, set->count, r->hits, occ, nthreads, &first);
        int loops = 1;
        if (opt->min_seconds > 0 && first < opt->min_seconds)
            loops = first > 0 ? (int)ceil(opt->min_seconds / first) : 1000;
        tm[ti].loops = loops > 1000 ? 1000 : loops;
    }
    for (int i = 0; i < reps && st == SC_OK; i++)
        for (int j = 0; j < r->ntr && st == SC_OK; j++) {
            const int ti = i % 2 ? r->ntr - 1 - j : j;
            double sum = 0;
            for (int l = 0; l < tm[ti].loops && st == SC_OK; l++) {
                double s;
                st = sc_tracer_run_threads(&r->tr[ti], set->rays, set->count, r->hits, occ, nthreads, &s);
                sum += s;
            }
            tm[ti].s[i] = sum / tm[ti].loops;
        }
    if (opt->timing)
        opt->timing(opt->timing_ctx, 0);
    return st;
}

/* One row: the median of the tracer's timed rounds beside the accuracy
 * and the work counters of the checking run. */
static sc_status add_row(cmp_run *r, int k, const sc_tracer *t, const accuracy *acc, const sc_tracer_counters *ctr,
                         int nthreads, const timed *tm, sc_cmp_rows *out)
{
    const sc_cmp_options *opt = r->opt;
    const sc_rayset *set = &r->sets[k];
    const int reps = opt->repeats;
    double sorted[SC_CMP_MAX_REPEATS];
    memcpy(sorted, tm->s, (size_t)reps * sizeof sorted[0]);
    qsort(sorted, (size_t)reps, sizeof sorted[0], sc_cmp_double);
    sc_cmp_row *row = row_add(out);
    if (!row)
        return SC_ERR_OUT_OF_MEMORY;
    snprintf(row->scene, sizeof row->scene, "%s", r->scene);
    row->triangles = r->mesh.view.triangle_count;
    row->instances = r->iv ? r->iv->num_instances : 0;
    row->closed = r->closed;
    row->rays = (sc_rayset_kind)k;
    row->nrays = set->count;
    snprintf(row->tracer, sizeof row->tracer, "%s", t->def.name);
    row->threads = nthreads;
    row->mrays_per_s = (double)set->count / sorted[reps / 2] / 1e6;
    row->speed_vs_embree = NAN;
    row->best_embree = NAN;
    row->best_embree_tracer[0] = 0;
    snprintf(row->embree_build, sizeof row->embree_build, "%s", opt->embree_build ? opt->embree_build : "");
    row->ftz = opt->ftz;
    row->loops = tm->loops;
    row->rounds = reps;
    memcpy(row->round_s, tm->s, (size_t)reps * sizeof row->round_s[0]);
    row->oracle_rays = acc->oracle_rays;
    row->hit_miss_disagree = acc->hit_miss;
    row->primid_disagree = acc->primid;
    row->holes = acc->holes;
    row->hole_rays = acc->hole_rays;
    row->grazes_missed = acc->grazes_missed;
    row->graze_rays = acc->graze_rays;
    row->t_err_median = acc->t_med;
    row->t_err_max = acc->t_max;
    row->bytes_per_tri = t->bytes_per_tri;
    row->build_s = t->build_seconds;
    row->has_prefilter_stats = t->prefilter;
    double nr = ctr->rays ? (double)ctr->rays : 1;
    row->sphere_tests_per_ray = t->prefilter ? (double)ctr->sphere_tests / nr : NAN;
    row->sphere_reject_rate = t->prefilter && ctr->sphere_tests
                                  ? (double)ctr->sphere_rejects / (double)ctr->sphere_tests : NAN;
    uint64_t passed = ctr->sphere_tests - ctr->sphere_rejects;
    row->false_positive_rate = t->fp_exact && passed ? (double)ctr->false_positives / (double)passed : NAN;
    row->tri_tests_per_ray = t->counted ? (double)ctr->tri_tests / nr : NAN;
    return SC_OK;
}

/* One ray set: the oracle on an even sample, then every tracer checked
 * against it and timed. */
static sc_status run_set(cmp_run *r, int k, sc_cmp_rows *out)
{
    const sc_cmp_options *opt = r->opt;
    const sc_rayset *set = &r->sets[k];
    /* An even stride through the set: every region of the image or kind of
     * adversarial ray is represented. */
    size_t ns = opt->oracle_rays < set->count ? opt->oracle_rays : set->count;
    for (size_t s = 0; s < ns; s++) {
        r->sample[s] = (size_t)((double)s * set->count / ns);
        r->srays[s] = set->rays[r->sample[s]];
    }
    sc_oracle orc;
    double t0 = sc_now_seconds();
    sc_status st = oracle_run(r, r->srays, ns, k == SC_RAYS_ADVERSARIAL ? SC_ORACLE_CROSSING : 0, &orc);
    if (st != SC_OK)
        return fail(r, st, "oracle");
    size_t ohits = 0;
    for (size_t s = 0; s < ns; s++)
        ohits += (size_t)orc.hits[s].hit;
    if (r->log)
        fprintf(r->log, "  %-11s %7zu rays; oracle %zu rays (%zu hit) %.1f s, %.1f exact calls/ray\n",
                sc_rayset_kind_name((sc_rayset_kind)k), set->count, ns, ohits, sc_now_seconds() - t0,
                ns ? (double)orc.exact_calls / (double)ns : 0);
    int shadow = k == SC_RAYS_SHADOW;
    accuracy acc[SC_CMP_MAX_TRACERS];
    sc_tracer_counters ctr[SC_CMP_MAX_TRACERS];
    for (int ti = 0; ti < r->ntr && st == SC_OK; ti++) {
        const sc_tracer *t = &r->tr[ti];
        memset(&ctr[ti], 0, sizeof ctr[ti]);
        /* Embree's streams and packets get their coherence flag from the ray set */
        r->tr[ti].incoherent = sc_tracer_set_incoherent((sc_rayset_kind)k);
        r->tr[ti].ftz = opt->ftz;
        st = sc_tracer_run(t, set->rays, set->count, r->hits, shadow ? r->occ : NULL, &ctr[ti]);
        if (st != SC_OK) {
            if (r->err)
                snprintf(r->err, r->errlen, "%s: %s failed: %s", r->scene, t->def.name, sc_strerror(st));
            break;
        }
        score(set, r->sample, &orc, r->hits, shadow ? r->occ : NULL, k == SC_RAYS_ADVERSARIAL, &acc[ti]);
    }
    timed *tm = r->timed;
    for (int th = 0; th < opt->nthreads && st == SC_OK; th++) {
        if ((st = time_rounds(r, k, opt->threads[th], tm)) != SC_OK) {
            if (r->err)
                snprintf(r->err, r->errlen, "%s: timing failed: %s", r->scene, sc_strerror(st));
            break;
        }
        for (int ti = 0; ti < r->ntr && st == SC_OK; ti++)
            st = add_row(r, k, &r->tr[ti], &acc[ti], &ctr[ti], opt->threads[th], &tm[ti], out);
    }
    sc_oracle_free(&orc);
    return st;
}

/* Speed against native Embree of the same kind, same set and threads.
 * speed_vs_embree: single rays against rtcIntersect1 / rtcOccluded1
 * ("embree"), packets of 8 and 16 against "embree-p8" and "embree-p16"
 * (the flag of the ray set), streams against rtcIntersect1M /
 * rtcOccluded1M ("embree-stream").
 * Both are medians of the rounds' paired ratios (time_rounds).
 * best_embree: against the fastest Embree row (by median) of its default scene flags
 * and the same width in the run: for single rays "embree" and
 * "embree-high", for packets also the row of the other fixed flag
 * ("embree-p16-incoherent" for camera and shadow rays, "-coherent" for
 * bounce and random rays), as a user would pick Embree's faster build
 * and flag. */
static int best_candidate(const char *tracer, int width, sc_rayset_kind rays)
{
#ifdef SC_HAVE_EMBREE
    const sc_tracer_def *d = sc_tracer_find(tracer);
    if (!d || d->family != SC_TRACER_EMBREE || d->mode != SC_EMBREE_DEFAULT || d->packet != width)
        return 0;
    /* a fixed-flag row with the ray set's own flag repeats embree-pW: the
     * faster of two runs of one configuration would only pick the noise */
    return !d->coherence || (d->coherence == SC_TRACER_INCOHERENT) != sc_tracer_set_incoherent(rays);
#else
    (void)tracer, (void)width, (void)rays;
    return 0;
#endif
}

/* row's speed over ref's: the median over their shared rounds of ref's
 * time over row's, each ratio paired in time. */
static double paired_ratio(const sc_cmp_row *row, const sc_cmp_row *ref)
{
    double q[SC_CMP_MAX_REPEATS];
    const int n = row->rounds < ref->rounds ? row->rounds : ref->rounds;
    for (int i = 0; i < n; i++)
        q[i] = ref->round_s[i] / row->round_s[i];
    return n ? sc_median(q, n) : NAN;
}

static void embree_ratios(sc_cmp_rows *out, size_t first_row)
{
    for (size_t i = first_row; i < out->count; i++) {
        sc_cmp_row *row = &out->rows[i];
        const sc_tracer_def *d = sc_tracer_find(row->tracer);
        const int w = d ? d->packet : 0;
        const char *ref = w == 8 ? "embree-p8" : w == 16 ? "embree-p16" : w == SC_TRACER_STREAM ? "embree-stream"
                                                                                                  : "embree";
        const sc_cmp_row *best = NULL;
        for (size_t j = first_row; j < out->count; j++) {
            const sc_cmp_row *o = &out->rows[j];
            if (o->rays != row->rays || o->threads != row->threads)
                continue;
            if (strcmp(o->tracer, ref) == 0)
                row->speed_vs_embree = paired_ratio(row, o);
            if (best_candidate(o->tracer, w, row->rays) && (!best || o->mrays_per_s > best->mrays_per_s))
                best = o;
        }
        if (best) {
            row->best_embree = paired_ratio(row, best);
            snprintf(row->best_embree_tracer, sizeof row->best_embree_tracer, "%s", best->tracer);
        }
    }
}

sc_status sc_cmp_scene(const char *scene_name, const sc_mesh_view *mesh, const sc_scene_view *instances,
                       const sc_camera *camera, const sc_light *lights, size_t nlights, const sc_cmp_options *opt,
                       sc_cmp_rows *out, FILE *log, char *err, size_t errlen)
{
    if (err && errlen)
        err[0] = 0;
    if (!scene_name || !camera || (nlights && !lights) || !opt || !out || opt->nthreads < 1 ||
        opt->nthreads > SC_CMP_MAX_THREADS || opt->repeats < 1 || opt->repeats > SC_CMP_MAX_REPEATS ||
        !(opt->min_seconds >= 0) || opt->min_seconds > 60)
        return SC_ERR_INVALID_ARGUMENT;
    for (int k = 0; k < opt->nthreads; k++)
        if (opt->threads[k] < 1 || opt->threads[k] > SC_CMP_MAX_THREADS)
            return SC_ERR_INVALID_ARGUMENT;
    cmp_run r;
    memset(&r, 0, sizeof r);
    r.scene = scene_name, r.opt = opt, r.log = log, r.err = err, r.errlen = errlen;
    sc_status st = sc_mesh_check(mesh, &r.mesh);
    if (st != SC_OK) {
        if (err) snprintf(err, errlen, "%s: bad mesh: %s", scene_name, sc_strerror(st));
        return st;
    }
    sc_mesh_is_closed(&r.mesh, &r.closed);
    if (instances && instances->num_instances && !opt->flatten) {
        r.iv = instances;
        if ((st = prepare_instances(&r)) != SC_OK) {
            if (err) snprintf(err, errlen, "%s: instances: %s", scene_name, sc_strerror(st));
            run_free(&r);
            return st;
        }
        if (log) fprintf(log, "  traced through %zu instances of %zu objects\n", instances->num_instances,
                         instances->num_objects);
    }
    float light[3];
    sc_light_point(lights, nlights, r.mesh.lo, r.mesh.hi, light);
    size_t first_row = out->count;
    if ((st = build_tracers(&r)) == SC_OK && (st = make_rays(&r, camera, light)) == SC_OK)
        for (int k = 0; k < SC_RAYS_KIND_COUNT && st == SC_OK; k++)
            if ((opt->ray_kinds & (1u << k)) && r.sets[k].count)
                st = run_set(&r, k, out);
    if (st == SC_OK)
        embree_ratios(out, first_row);
    run_free(&r);
    return st;
}

/* ---- output --------------------------------------------------------------- */

/* v with fmt, or mark where v is NaN ("not applicable"). */
static void fmt_or(char *buf, size_t n, const char *fmt, double v, const char *mark)
{
    if (isnan(v))
        snprintf(buf, n, "%s", mark);
    else
        snprintf(buf, n, fmt, v);
}

static void fmt_num(char *buf, size_t n, const char *fmt, double v) { fmt_or(buf, n, fmt, v, "-"); }

/* an empty CSV cell for "not applicable" */
static void csv_num(char *buf, size_t n, const char *fmt, double v) { fmt_or(buf, n, fmt, v, ""); }

int sc_cmp_write_csv(const sc_cmp_rows *rows, FILE *f)
{
    fprintf(f, "scene,triangles,rays,tracer,threads,mrays_per_s,oracle_rays,hit_miss_disagree,"
               "primid_disagree,t_err_max,holes,sphere_tests_per_ray,sphere_reject_rate,"
               "false_positive_rate,tri_tests_per_ray,bytes_per_tri,"
               "nrays,closed,t_err_median,hole_rays,speed_vs_embree,grazes_missed,graze_rays,"
               "best_embree,best_embree_tracer,embree_build,mxcsr,loops,build_s,instances\n");
    for (size_t i = 0; i < rows->count; i++) {
        const sc_cmp_row *r = &rows->rows[i];
        char a[32], b[32], c[32], d[32], e[32], g[32], h[32], be[32];
        csv_num(a, sizeof a, "%.3e", r->t_err_max);
        csv_num(b, sizeof b, "%.3f", r->sphere_tests_per_ray);
        csv_num(c, sizeof c, "%.4f", r->sphere_reject_rate);
        csv_num(d, sizeof d, "%.4f", r->false_positive_rate);
        csv_num(e, sizeof e, "%.3f", r->tri_tests_per_ray);
        csv_num(g, sizeof g, "%.3e", r->t_err_median);
        csv_num(h, sizeof h, "%.3f", r->speed_vs_embree);
        csv_num(be, sizeof be, "%.4g", r->best_embree);
        sc_csv_str(f, r->scene);
        fprintf(f, ",%u,%s,", r->triangles, sc_rayset_kind_name(r->rays));
        sc_csv_str(f, r->tracer);
        fprintf(f, ",%d,%.3f,%zu,%zu,%zu,%s,%zu,%s,%s,%s,%s,%.1f,%zu,%d,%s,%zu,%s,%zu,%zu,",
                r->threads, r->mrays_per_s,
                r->oracle_rays, r->hit_miss_disagree, r->primid_disagree, a, r->holes, b, c, d, e,
                r->bytes_per_tri, r->nrays, r->closed, g, r->hole_rays, h, r->grazes_missed, r->graze_rays);
        fprintf(f, "%s,", be);
        sc_csv_str(f, r->best_embree_tracer);
        fputc(',', f);
        sc_csv_str(f, r->embree_build);
        fprintf(f, ",%s,%d,%.6g,%zu\n", r->ftz ? "ftz" : "default", r->loops, r->build_s, r->instances);
    }
    return ferror(f) ? -1 : 0;
}

static void json_num(cJSON *o, const char *k, double v)
{
    if (isnan(v))
        cJSON_AddNullToObject(o, k);
    else
        cJSON_AddNumberToObject(o, k, v);
}

int sc_cmp_write_json(const sc_cmp_rows *rows, FILE *f)
{
    cJSON *root = cJSON_CreateObject(), *arr = cJSON_AddArrayToObject(root, "rows");
    if (!root || !arr) {
        cJSON_Delete(root);
        return -1;
    }
    for (size_t i = 0; i < rows->count; i++) {
        const sc_cmp_row *r = &rows->rows[i];
        cJSON *o = cJSON_CreateObject();
        if (!o)
            break;
        cJSON_AddStringToObject(o, "scene", r->scene);
        cJSON_AddNumberToObject(o, "triangles", r->triangles);
        cJSON_AddNumberToObject(o, "instances", (double)r->instances);
        cJSON_AddBoolToObject(o, "closed", r->closed);
        cJSON_AddStringToObject(o, "rays", sc_rayset_kind_name(r->rays));
        cJSON_AddNumberToObject(o, "nrays", (double)r->nrays);
        cJSON_AddStringToObject(o, "tracer", r->tracer);
        cJSON_AddNumberToObject(o, "threads", r->threads);
        cJSON_AddNumberToObject(o, "mrays_per_s", r->mrays_per_s);
        json_num(o, "speed_vs_embree", r->speed_vs_embree);
        json_num(o, "best_embree", r->best_embree);
        cJSON_AddStringToObject(o, "best_embree_tracer", r->best_embree_tracer);
        cJSON_AddStringToObject(o, "embree_build", r->embree_build);
        cJSON_AddStringToObject(o, "mxcsr", r->ftz ? "ftz" : "default");
        cJSON_AddNumberToObject(o, "loops", r->loops);
        cJSON_AddNumberToObject(o, "oracle_rays", (double)r->oracle_rays);
        cJSON_AddNumberToObject(o, "hit_miss_disagree", (double)r->hit_miss_disagree);
        cJSON_AddNumberToObject(o, "primid_disagree", (double)r->primid_disagree);
        json_num(o, "t_err_median", r->t_err_median);
        json_num(o, "t_err_max", r->t_err_max);
        cJSON_AddNumberToObject(o, "holes", (double)r->holes);
        cJSON_AddNumberToObject(o, "hole_rays", (double)r->hole_rays);
        cJSON_AddNumberToObject(o, "grazes_missed", (double)r->grazes_missed);
        cJSON_AddNumberToObject(o, "graze_rays", (double)r->graze_rays);
        json_num(o, "sphere_tests_per_ray", r->sphere_tests_per_ray);
        json_num(o, "sphere_reject_rate", r->sphere_reject_rate);
        json_num(o, "false_positive_rate", r->false_positive_rate);
        json_num(o, "tri_tests_per_ray", r->tri_tests_per_ray);
        cJSON_AddNumberToObject(o, "bytes_per_tri", r->bytes_per_tri);
        cJSON_AddNumberToObject(o, "build_s", r->build_s);
        cJSON_AddItemToArray(arr, o);
    }
    char *s = cJSON_Print(root);
    cJSON_Delete(root);
    if (!s)
        return -1;
    fputs(s, f);
    fputc('\n', f);
    free(s);
    return ferror(f) ? -1 : 0;
}

void sc_cmp_print_table(const sc_cmp_rows *rows, FILE *f)
{
    const char *last_scene = "";
    for (size_t i = 0; i < rows->count; i++) {
        const sc_cmp_row *r = &rows->rows[i];
        if (strcmp(r->scene, last_scene) != 0) {
            fprintf(f, "\n%s: %u triangles, %s", r->scene, r->triangles, r->closed ? "closed" : "open");
            if (r->instances)
                fprintf(f, ", traced through %zu instances", r->instances);
            fputc('\n', f);
            fprintf(f, "%-11s %-24s %3s %8s %7s %6s %6s %5s %5s %9s %9s %5s %6s %7s %6s %6s %7s %6s\n", "rays",
                    "tracer", "thr", "Mrays/s", "xEmbree", "xBest", "oracle", "h/m", "prim", "t_err_med", "t_err_max",
                    "holes", "grazes", "sph/ray", "rej%", "fp%", "tri/ray", "B/tri");
            last_scene = r->scene;
        }
        char x[16], xb[16], tm[16], tx[16], sp[16], rj[16], fp[16], tt[16], ho[24], gz[24];
        fmt_num(x, sizeof x, "%.2f", r->speed_vs_embree);
        fmt_num(xb, sizeof xb, "%.2f", r->best_embree);
        fmt_num(tm, sizeof tm, "%.1e", r->t_err_median);
        fmt_num(tx, sizeof tx, "%.1e", r->t_err_max);
        fmt_num(sp, sizeof sp, "%.2f", r->sphere_tests_per_ray);
        fmt_num(rj, sizeof rj, "%.1f", 100 * r->sphere_reject_rate);
        fmt_num(fp, sizeof fp, "%.1f", 100 * r->false_positive_rate);
        fmt_num(tt, sizeof tt, "%.2f", r->tri_tests_per_ray);
        if (r->rays == SC_RAYS_ADVERSARIAL) {
            snprintf(ho, sizeof ho, "%zu", r->holes);
            snprintf(gz, sizeof gz, "%zu", r->grazes_missed);
        } else {
            snprintf(ho, sizeof ho, "-");
            snprintf(gz, sizeof gz, "-");
        }
        fprintf(f, "%-11s %-24s %3d %8.2f %7s %6s %6zu %5zu %5zu %9s %9s %5s %6s %7s %6s %6s %7s %6.0f\n",
                sc_rayset_kind_name(r->rays), r->tracer, r->threads, r->mrays_per_s, x, xb, r->oracle_rays,
                r->hit_miss_disagree, r->primid_disagree, tm, tx, ho, gz, sp, rj, fp, tt, r->bytes_per_tri);
    }
}
