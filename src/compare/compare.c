/* The comparison driver (see compare.h). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "common/sc_clock.h"
#include "common/sc_csv.h"
#include "compare.h"
#include "crossing.h"
#include "oracle.h"

#ifdef SC_HAVE_TRACE
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_trace.h"
#endif
#ifdef SC_HAVE_EMBREE
#include "spherecull/sc_embree.h"
#endif

/* ---- the tracer table ----------------------------------------------------- */

typedef enum family { FAM_SPHERECULL, FAM_EMBREE } family;

typedef struct tracer_def {
    const char *name;
    family fam;
    int mode;          /* sc_prefilter_mode or sc_embree_mode */
    int quality;       /* embree: build quality; spherecull: sc_tri_test */
    int cluster;       /* embree user modes */
    int packet;        /* 0, 8 or 16 */
} tracer_def;

static const tracer_def all_tracers[] = {
#ifdef SC_HAVE_TRACE
    { "spherecull-off", FAM_SPHERECULL, SC_PREFILTER_OFF, 0, 0, 0 },
    { "spherecull-exact", FAM_SPHERECULL, SC_PREFILTER_OFF, SC_TRI_EXACT, 0, 0 },
    { "spherecull-circum", FAM_SPHERECULL, SC_PREFILTER_CIRCUM, 0, 0, 0 },
    { "spherecull-minimal", FAM_SPHERECULL, SC_PREFILTER_MINIMAL, 0, 0, 0 },
    { "spherecull-auto", FAM_SPHERECULL, SC_PREFILTER_AUTO, 0, 0, 0 },
#endif
#ifdef SC_HAVE_EMBREE
    { "embree", FAM_EMBREE, SC_EMBREE_DEFAULT, SC_EMBREE_QUALITY_MEDIUM, 0, 0 },
    { "embree-robust", FAM_EMBREE, SC_EMBREE_ROBUST, SC_EMBREE_QUALITY_MEDIUM, 0, 0 },
    { "embree-high", FAM_EMBREE, SC_EMBREE_DEFAULT, SC_EMBREE_QUALITY_HIGH, 0, 0 },
    { "embree-robust-high", FAM_EMBREE, SC_EMBREE_ROBUST, SC_EMBREE_QUALITY_HIGH, 0, 0 },
    { "embree-p8", FAM_EMBREE, SC_EMBREE_DEFAULT, SC_EMBREE_QUALITY_MEDIUM, 0, 8 },
    { "embree-p16", FAM_EMBREE, SC_EMBREE_DEFAULT, SC_EMBREE_QUALITY_MEDIUM, 0, 16 },
    { "embree-user-prefilter", FAM_EMBREE, SC_EMBREE_USER_PREFILTER, SC_EMBREE_QUALITY_MEDIUM, 8, 0 },
    { "embree-user-prefilter16", FAM_EMBREE, SC_EMBREE_USER_PREFILTER, SC_EMBREE_QUALITY_MEDIUM, 16, 0 },
    { "embree-user-plain", FAM_EMBREE, SC_EMBREE_USER_PLAIN, SC_EMBREE_QUALITY_MEDIUM, 8, 0 },
    { "embree-user-plain16", FAM_EMBREE, SC_EMBREE_USER_PLAIN, SC_EMBREE_QUALITY_MEDIUM, 16, 0 },
#endif
    { NULL, FAM_SPHERECULL, 0, 0, 0, 0 }
};
enum { NDEFS = sizeof all_tracers / sizeof all_tracers[0] - 1 };

const char *const *sc_cmp_tracer_names(int *count)
{
    static const char *names[NDEFS + 1];
    for (int i = 0; i < NDEFS; i++)
        names[i] = all_tracers[i].name;
    names[NDEFS] = NULL;
    if (count)
        *count = NDEFS;
    return names;
}

typedef struct tracer {
    const tracer_def *def;
    void *handle;
    double bytes_per_tri;
    int prefilter;        /* has sphere statistics */
    int counted;          /* counts triangle tests */
    int fp_exact;         /* false positives are counted exactly */
} tracer;

static sc_status tracer_build(tracer *t, const tracer_def *def, const sc_mesh_view *m)
{
    memset(t, 0, sizeof *t);
    t->def = def;
    if (def->fam == FAM_SPHERECULL) {
#ifdef SC_HAVE_TRACE
        sc_bvh_config cfg;
        sc_bvh_config_default(&cfg);
        cfg.prefilter = (sc_prefilter_mode)def->mode;
        cfg.tri_test = (sc_tri_test)def->quality;
        sc_bvh *b;
        sc_status st = sc_bvh_build(m->positions, m->vertex_count, m->indices, m->triangle_count, &cfg, &b);
        if (st != SC_OK)
            return st;
        sc_bvh_info info;
        sc_bvh_get_info(b, &info);
        t->handle = b;
        t->bytes_per_tri = (double)info.total_bytes / m->triangle_count;
        t->prefilter = def->mode != SC_PREFILTER_OFF;
        t->counted = 1;
        /* auto mixes leaves with and without spheres: the counters cannot
         * tell which triangle tests followed a passed sphere */
        t->fp_exact = def->mode == SC_PREFILTER_CIRCUM || def->mode == SC_PREFILTER_MINIMAL;
        return SC_OK;
#else
        return SC_ERR_UNSUPPORTED;
#endif
    }
#ifdef SC_HAVE_EMBREE
    sc_embree_config cfg;
    sc_embree_config_default(&cfg);
    cfg.mode = (sc_embree_mode)def->mode;
    cfg.quality = (sc_embree_quality)def->quality;
    if (def->cluster)
        cfg.cluster_size = def->cluster;
    sc_embree *e;
    sc_status st = sc_embree_create(m, &cfg, &e);
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
    (void)m;
    return SC_ERR_UNSUPPORTED;
#endif
}

static void tracer_free(tracer *t)
{
    if (!t->handle)
        return;
#ifdef SC_HAVE_TRACE
    if (t->def->fam == FAM_SPHERECULL)
        sc_bvh_free(t->handle);
#endif
#ifdef SC_HAVE_EMBREE
    if (t->def->fam == FAM_EMBREE)
        sc_embree_destroy(t->handle);
#endif
    t->handle = NULL;
}

/* Closest hits (occ == NULL) or occlusion (occ != NULL) for rays[0..n). */
static sc_status tracer_run(const tracer *t, const sc_ray *rays, size_t n, sc_hitrec *hits, uint8_t *occ,
                            sc_cmp_counters *ctr)
{
#ifdef SC_HAVE_TRACE
    if (t->def->fam == FAM_SPHERECULL) {
        sc_trace_stats ts, *tsp = NULL;
        if (ctr) {
            memset(&ts, 0, sizeof ts);
            tsp = &ts;
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
            ctr->rays += n;
            ctr->sphere_tests += ts.sphere_tests;
            ctr->sphere_rejects += ts.sphere_rejects;
            ctr->tri_tests += ts.tri_tests;
            ctr->tri_hits += ts.tri_hits;
            /* every exact test in a sphere leaf follows a passed sphere;
             * exact only when all leaves carry spheres (circum, minimal) */
            if (t->def->mode == SC_PREFILTER_CIRCUM || t->def->mode == SC_PREFILTER_MINIMAL)
                ctr->false_positives += ts.tri_tests - ts.tri_hits;
        }
        return SC_OK;
    }
#endif
#ifdef SC_HAVE_EMBREE
    if (t->def->fam == FAM_EMBREE) {
        sc_embree_counters ec, *ecp = NULL;
        if (ctr) {
            memset(&ec, 0, sizeof ec);
            ecp = &ec;
        }
        sc_status st;
        if (occ)
            st = sc_embree_occluded1(t->handle, rays, n, occ, ecp);
        else if (t->def->packet)
            st = sc_embree_intersect_packets(t->handle, t->def->packet, rays, n, hits, ecp);
        else
            st = sc_embree_intersect1(t->handle, rays, n, hits, ecp);
        if (st == SC_OK && ctr) {
            ctr->rays += n;
            ctr->sphere_tests += ec.sphere_tests;
            ctr->sphere_rejects += ec.sphere_rejects;
            ctr->tri_tests += ec.tri_tests;
            ctr->tri_hits += ec.tri_hits;
            ctr->false_positives += ec.false_positives;
        }
        return st;
    }
#endif
    (void)rays, (void)n, (void)hits, (void)occ, (void)ctr;
    return SC_ERR_UNSUPPORTED;
}

/* ---- threaded timing ------------------------------------------------------ */

enum { CHUNK = 1024 };   /* a multiple of every packet width */

typedef struct pool_job {
    const tracer *t;
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
    for (;;) {
        size_t b = atomic_fetch_add(&j->next, CHUNK);
        if (b >= j->n)
            break;
        size_t e = b + CHUNK < j->n ? b + CHUNK : j->n;
        if (tracer_run(j->t, j->rays + b, e - b, j->occ ? NULL : j->hits + b, j->occ ? j->occ + b : NULL,
                       NULL) != SC_OK)
            atomic_store(&j->failed, 1);
    }
    return NULL;
}

static sc_status timed_run(const tracer *t, const sc_ray *rays, size_t n, sc_hitrec *hits, uint8_t *occ,
                           int threads, double *seconds)
{
    pool_job j;
    j.t = t, j.rays = rays, j.n = n, j.hits = hits, j.occ = occ;
    atomic_init(&j.next, 0);
    atomic_init(&j.failed, 0);
    pthread_t tid[SC_CMP_MAX_THREADS];
    int started[SC_CMP_MAX_THREADS] = { 0 };
    double t0 = sc_now_seconds();
    for (int k = 1; k < threads; k++)
        started[k] = pthread_create(&tid[k], NULL, pool_worker, &j) == 0;
    pool_worker(&j);
    for (int k = 1; k < threads; k++)
        if (started[k])
            pthread_join(tid[k], NULL);
    *seconds = sc_now_seconds() - t0;
    return atomic_load(&j.failed) ? SC_ERR_INVALID_ARGUMENT : SC_OK;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* ---- rows ----------------------------------------------------------------- */

void sc_cmp_options_default(sc_cmp_options *o)
{
    memset(o, 0, sizeof *o);
    o->ray_kinds = (1u << SC_RAYS_KIND_COUNT) - 1;
    o->threads[0] = 1, o->threads[1] = 2;
    o->nthreads = 2;
    o->oracle_rays = 10000;
    o->repeats = 5;
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
            if (o->hit && o->first_kind == SC_XK_TOUCH) {
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
        qsort(terr, nt, sizeof *terr, cmp_double);
        a->t_med = terr[nt / 2];
        a->t_max = terr[nt - 1];
    }
    free(terr);
}

sc_status sc_cmp_scene(const char *scene_name, const sc_mesh_view *mesh, const sc_camera *camera,
                       const float light[3], const sc_cmp_options *opt, sc_cmp_rows *out, FILE *log,
                       char *err, size_t errlen)
{
    if (err && errlen)
        err[0] = 0;
    if (!scene_name || !camera || !light || !opt || !out || opt->nthreads < 1 ||
        opt->nthreads > SC_CMP_MAX_THREADS || opt->repeats < 1)
        return SC_ERR_INVALID_ARGUMENT;
    for (int k = 0; k < opt->nthreads; k++)
        if (opt->threads[k] < 1 || opt->threads[k] > SC_CMP_MAX_THREADS)
            return SC_ERR_INVALID_ARGUMENT;
    sc_status st = sc_mesh_view_check(mesh);
    if (st != SC_OK) {
        if (err) snprintf(err, errlen, "%s: bad mesh: %s", scene_name, sc_strerror(st));
        return st;
    }
    int closed = 0;
    sc_mesh_is_closed(mesh, &closed);

    tracer tr[NDEFS > 0 ? NDEFS : 1];
    int ntr = 0;
    for (int d = 0; d < NDEFS; d++) {
        if (!wanted(opt, all_tracers[d].name))
            continue;
        double t0 = sc_now_seconds();
        st = tracer_build(&tr[ntr], &all_tracers[d], mesh);
        if (st != SC_OK) {
            if (log) fprintf(log, "  %s: build failed: %s (skipped)\n", all_tracers[d].name, sc_strerror(st));
            continue;
        }
        if (log) fprintf(log, "  built %-24s %6.2f s  %.0f B/tri\n", all_tracers[d].name, sc_now_seconds() - t0,
                         tr[ntr].bytes_per_tri);
        ntr++;
    }
    if (ntr == 0) {
        if (err) snprintf(err, errlen, "no tracer available (names: see --help)");
        return SC_ERR_UNSUPPORTED;
    }

    /* Primary rays at the requested width, the camera's aspect kept. */
    sc_camera cam = *camera;
    cam.width = opt->width;
    cam.height = opt->height > 0 ? opt->height
                                 : (int)lround((double)opt->width * camera->height / camera->width);
    if (cam.height < 1) cam.height = 1;
    sc_rayset sets[SC_RAYS_KIND_COUNT];
    memset(sets, 0, sizeof sets);
    sc_hitrec *hits = NULL, *ref_hits = NULL;
    uint8_t *occ = NULL;
    size_t *sample = NULL;
    sc_ray *srays = NULL;
    st = sc_rayset_primary(&cam, &sets[SC_RAYS_PRIMARY]);
    if (st != SC_OK) {
        if (err) snprintf(err, errlen, "%s: primary rays: %s", scene_name, sc_strerror(st));
        goto done;
    }
    /* Shadow and diffuse rays start at primary hits. They come from one
     * fixed tracer (the first of the table: ours if built, else Embree) so
     * the sets do not depend on which tracers were asked for. */
    if (opt->ray_kinds & ((1u << SC_RAYS_SHADOW) | (1u << SC_RAYS_DIFFUSE))) {
        tracer reft;
        const tracer_def *rd = NULL;
        for (int d = 0; d < NDEFS && !rd; d++)
            if (!all_tracers[d].packet)
                rd = &all_tracers[d];
        ref_hits = malloc(sets[SC_RAYS_PRIMARY].count * sizeof *ref_hits);
        if (!rd || !ref_hits || tracer_build(&reft, rd, mesh) != SC_OK) {
            st = SC_ERR_OUT_OF_MEMORY;
            if (err) snprintf(err, errlen, "%s: no reference tracer for shadow rays", scene_name);
            goto done;
        }
        st = tracer_run(&reft, sets[SC_RAYS_PRIMARY].rays, sets[SC_RAYS_PRIMARY].count, ref_hits, NULL, NULL);
        tracer_free(&reft);
        if (st == SC_OK)
            st = sc_rayset_shadow(mesh, &sets[SC_RAYS_PRIMARY], ref_hits, light, &sets[SC_RAYS_SHADOW]);
        if (st == SC_OK)
            st = sc_rayset_diffuse(mesh, &sets[SC_RAYS_PRIMARY], ref_hits, opt->seed, &sets[SC_RAYS_DIFFUSE]);
        if (st != SC_OK) {
            if (err) snprintf(err, errlen, "%s: shadow/diffuse rays: %s", scene_name, sc_strerror(st));
            goto done;
        }
        if (log) fprintf(log, "  shadow/diffuse origins from %s's primary hits\n", rd->name);
    }
    float lo[3], hi[3];
    sc_mesh_bounds(mesh, lo, hi);
    if ((st = sc_rayset_random(lo, hi, opt->random_rays ? opt->random_rays : 1, opt->seed,
                               &sets[SC_RAYS_RANDOM])) != SC_OK ||
        (st = sc_rayset_adversarial(mesh, opt->adversarial_rays ? opt->adversarial_rays : 1, opt->seed,
                                    &sets[SC_RAYS_ADVERSARIAL])) != SC_OK) {
        if (err) snprintf(err, errlen, "%s: random/adversarial rays: %s", scene_name, sc_strerror(st));
        goto done;
    }

    size_t maxn = 1;
    for (int k = 0; k < SC_RAYS_KIND_COUNT; k++)
        if (sets[k].count > maxn)
            maxn = sets[k].count;
    hits = malloc(maxn * sizeof *hits);
    occ = malloc(maxn);
    sample = malloc(maxn * sizeof *sample);
    srays = malloc(maxn * sizeof *srays);
    if (!hits || !occ || !sample || !srays) {
        st = SC_ERR_OUT_OF_MEMORY;
        goto done;
    }

    size_t first_row = out->count;
    for (int k = 0; k < SC_RAYS_KIND_COUNT; k++) {
        const sc_rayset *set = &sets[k];
        if (!(opt->ray_kinds & (1u << k)) || set->count == 0)
            continue;
        /* An even stride through the set: every region of the image or
         * kind of adversarial ray is represented. */
        size_t ns = opt->oracle_rays < set->count ? opt->oracle_rays : set->count;
        for (size_t s = 0; s < ns; s++) {
            sample[s] = (size_t)((double)s * set->count / ns);
            srays[s] = set->rays[sample[s]];
        }
        sc_oracle orc;
        double t0 = sc_now_seconds();
        st = sc_oracle_run(mesh, srays, ns, opt->oracle_threads,
                           k == SC_RAYS_ADVERSARIAL ? SC_ORACLE_CROSSING : 0, &orc);
        if (st != SC_OK) {
            if (err) snprintf(err, errlen, "%s: oracle: %s", scene_name, sc_strerror(st));
            goto done;
        }
        size_t ohits = 0;
        for (size_t s = 0; s < ns; s++)
            ohits += (size_t)orc.hits[s].hit;
        if (log)
            fprintf(log, "  %-11s %7zu rays; oracle %zu rays (%zu hit) %.1f s, %.1f exact calls/ray\n",
                    sc_rayset_kind_name((sc_rayset_kind)k), set->count, ns, ohits, sc_now_seconds() - t0,
                    ns ? (double)orc.exact_calls / (double)ns : 0);
        int shadow = k == SC_RAYS_SHADOW;
        for (int ti = 0; ti < ntr; ti++) {
            const tracer *t = &tr[ti];
            if (shadow && t->def->packet)
                continue;                      /* packets here are closest-hit only */
            sc_cmp_counters ctr;
            memset(&ctr, 0, sizeof ctr);
            st = tracer_run(t, set->rays, set->count, hits, shadow ? occ : NULL, &ctr);
            if (st != SC_OK) {
                if (err) snprintf(err, errlen, "%s: %s failed: %s", scene_name, t->def->name, sc_strerror(st));
                sc_oracle_free(&orc);
                goto done;
            }
            accuracy acc;
            score(set, sample, &orc, hits, shadow ? occ : NULL, k == SC_RAYS_ADVERSARIAL, &acc);
            for (int th = 0; th < opt->nthreads; th++) {
                double times[64];
                int reps = opt->repeats < 64 ? opt->repeats : 64;
                for (int r = 0; r < reps; r++) {
                    st = timed_run(t, set->rays, set->count, hits, shadow ? occ : NULL, opt->threads[th],
                                   &times[r]);
                    if (st != SC_OK) {
                        sc_oracle_free(&orc);
                        goto done;
                    }
                }
                qsort(times, (size_t)reps, sizeof times[0], cmp_double);
                sc_cmp_row *row = row_add(out);
                if (!row) {
                    st = SC_ERR_OUT_OF_MEMORY;
                    sc_oracle_free(&orc);
                    goto done;
                }
                snprintf(row->scene, sizeof row->scene, "%s", scene_name);
                row->triangles = mesh->triangle_count;
                row->closed = closed;
                row->rays = (sc_rayset_kind)k;
                row->nrays = set->count;
                snprintf(row->tracer, sizeof row->tracer, "%s", t->def->name);
                row->threads = opt->threads[th];
                row->mrays_per_s = (double)set->count / times[reps / 2] / 1e6;
                row->speed_vs_embree = NAN;
                row->oracle_rays = acc.oracle_rays;
                row->hit_miss_disagree = acc.hit_miss;
                row->primid_disagree = acc.primid;
                row->holes = acc.holes;
                row->hole_rays = acc.hole_rays;
                row->grazes_missed = acc.grazes_missed;
                row->graze_rays = acc.graze_rays;
                row->t_err_median = acc.t_med;
                row->t_err_max = acc.t_max;
                row->bytes_per_tri = t->bytes_per_tri;
                row->has_prefilter_stats = t->prefilter;
                double nr = ctr.rays ? (double)ctr.rays : 1;
                row->sphere_tests_per_ray = t->prefilter ? (double)ctr.sphere_tests / nr : NAN;
                row->sphere_reject_rate = t->prefilter && ctr.sphere_tests
                                              ? (double)ctr.sphere_rejects / (double)ctr.sphere_tests : NAN;
                uint64_t passed = ctr.sphere_tests - ctr.sphere_rejects;
                row->false_positive_rate = t->fp_exact && passed ? (double)ctr.false_positives / (double)passed
                                                                 : NAN;
                row->tri_tests_per_ray = t->counted ? (double)ctr.tri_tests / nr : NAN;
            }
        }
        sc_oracle_free(&orc);
    }
    /* Speed against native Embree (rtcIntersect1 / rtcOccluded1), same set and threads. */
    for (size_t i = first_row; i < out->count; i++)
        for (size_t j = first_row; j < out->count; j++)
            if (strcmp(out->rows[j].tracer, "embree") == 0 && out->rows[j].rays == out->rows[i].rays &&
                out->rows[j].threads == out->rows[i].threads)
                out->rows[i].speed_vs_embree = out->rows[i].mrays_per_s / out->rows[j].mrays_per_s;
    st = SC_OK;
done:
    for (int k = 0; k < SC_RAYS_KIND_COUNT; k++)
        sc_rayset_free(&sets[k]);
    for (int i = 0; i < ntr; i++)
        tracer_free(&tr[i]);
    free(hits), free(ref_hits), free(occ), free(sample), free(srays);
    return st;
}

/* ---- output --------------------------------------------------------------- */

static void fmt_num(char *buf, size_t n, const char *fmt, double v)
{
    if (isnan(v))
        snprintf(buf, n, "-");
    else
        snprintf(buf, n, fmt, v);
}

int sc_cmp_write_csv(const sc_cmp_rows *rows, FILE *f)
{
    fprintf(f, "scene,triangles,rays,tracer,threads,mrays_per_s,oracle_rays,hit_miss_disagree,"
               "primid_disagree,t_err_max,holes,sphere_tests_per_ray,sphere_reject_rate,"
               "false_positive_rate,tri_tests_per_ray,bytes_per_tri,"
               "nrays,closed,t_err_median,hole_rays,speed_vs_embree,grazes_missed,graze_rays\n");
    for (size_t i = 0; i < rows->count; i++) {
        const sc_cmp_row *r = &rows->rows[i];
        char a[32], b[32], c[32], d[32], e[32], g[32], h[32];
        /* empty CSV cells for "not applicable" */
        snprintf(a, sizeof a, isnan(r->t_err_max) ? "" : "%.3e", r->t_err_max);
        snprintf(b, sizeof b, isnan(r->sphere_tests_per_ray) ? "" : "%.3f", r->sphere_tests_per_ray);
        snprintf(c, sizeof c, isnan(r->sphere_reject_rate) ? "" : "%.4f", r->sphere_reject_rate);
        snprintf(d, sizeof d, isnan(r->false_positive_rate) ? "" : "%.4f", r->false_positive_rate);
        snprintf(e, sizeof e, isnan(r->tri_tests_per_ray) ? "" : "%.3f", r->tri_tests_per_ray);
        snprintf(g, sizeof g, isnan(r->t_err_median) ? "" : "%.3e", r->t_err_median);
        snprintf(h, sizeof h, isnan(r->speed_vs_embree) ? "" : "%.3f", r->speed_vs_embree);
        sc_csv_str(f, r->scene);
        fprintf(f, ",%u,%s,", r->triangles, sc_rayset_kind_name(r->rays));
        sc_csv_str(f, r->tracer);
        fprintf(f, ",%d,%.3f,%zu,%zu,%zu,%s,%zu,%s,%s,%s,%s,%.1f,%zu,%d,%s,%zu,%s,%zu,%zu\n",
                r->threads, r->mrays_per_s,
                r->oracle_rays, r->hit_miss_disagree, r->primid_disagree, a, r->holes, b, c, d, e,
                r->bytes_per_tri, r->nrays, r->closed, g, r->hole_rays, h, r->grazes_missed, r->graze_rays);
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
        cJSON_AddBoolToObject(o, "closed", r->closed);
        cJSON_AddStringToObject(o, "rays", sc_rayset_kind_name(r->rays));
        cJSON_AddNumberToObject(o, "nrays", (double)r->nrays);
        cJSON_AddStringToObject(o, "tracer", r->tracer);
        cJSON_AddNumberToObject(o, "threads", r->threads);
        cJSON_AddNumberToObject(o, "mrays_per_s", r->mrays_per_s);
        json_num(o, "speed_vs_embree", r->speed_vs_embree);
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
            fprintf(f, "\n%s: %u triangles, %s\n", r->scene, r->triangles, r->closed ? "closed" : "open");
            fprintf(f, "%-11s %-24s %3s %8s %7s %6s %5s %5s %9s %9s %5s %6s %7s %6s %6s %7s %6s\n", "rays",
                    "tracer", "thr", "Mrays/s", "xEmbree", "oracle", "h/m", "prim", "t_err_med", "t_err_max",
                    "holes", "grazes", "sph/ray", "rej%", "fp%", "tri/ray", "B/tri");
            last_scene = r->scene;
        }
        char x[16], tm[16], tx[16], sp[16], rj[16], fp[16], tt[16], ho[24], gz[24];
        fmt_num(x, sizeof x, "%.2f", r->speed_vs_embree);
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
        fprintf(f, "%-11s %-24s %3d %8.2f %7s %6zu %5zu %5zu %9s %9s %5s %6s %7s %6s %6s %7s %6.0f\n",
                sc_rayset_kind_name(r->rays), r->tracer, r->threads, r->mrays_per_s, x, r->oracle_rays,
                r->hit_miss_disagree, r->primid_disagree, tm, tx, ho, gz, sp, rj, fp, tt, r->bytes_per_tri);
    }
}
