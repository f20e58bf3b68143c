/* The exact ray oracle (see oracle.h). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include <mpfr.h>

#include "crossing.h"
#include "oracle.h"
#include "sc_ref_ray.h"
#include "tri_filter.h"

enum { CLUSTER = 32 };

typedef struct oracle_mesh {
    size_t ntri, nclusters;
    double (*v)[9];          /* triangles in cluster order */
    uint32_t *id;            /* original triangle ids */
    double (*box)[6];        /* padded cluster boxes */
} oracle_mesh;

typedef struct cand {
    double t_lo;
    uint32_t k;              /* index into oracle_mesh order */
} cand;

typedef struct job {
    const oracle_mesh *m;
    const sc_ray *rays;
    sc_oracle_hit *hits;
    size_t begin, end;
    uint64_t candidates, exact_calls;
    int failed;
    int flags;
} job;

static uint64_t spread3(uint32_t x)
{
    uint64_t v = x & 0x1fffff;
    v = (v | v << 32) & 0x1f00000000ffffull;
    v = (v | v << 16) & 0x1f0000ff0000ffull;
    v = (v | v << 8) & 0x100f00f00f00f00full;
    v = (v | v << 4) & 0x10c30c30c30c30c3ull;
    v = (v | v << 2) & 0x1249249249249249ull;
    return v;
}

typedef struct mkey {
    uint64_t code;
    uint32_t tri;
} mkey;

static int cmp_mkey(const void *pa, const void *pb)
{
    const mkey *a = pa, *b = pb;
    if (a->code != b->code)
        return a->code < b->code ? -1 : 1;
    return (a->tri > b->tri) - (a->tri < b->tri);
}

static int cmp_cand(const void *pa, const void *pb)
{
    const cand *a = pa, *b = pb;
    if (a->t_lo != b->t_lo)
        return a->t_lo < b->t_lo ? -1 : 1;
    return (a->k > b->k) - (a->k < b->k);
}

static sc_status mesh_prepare(const sc_checked_mesh *checked, oracle_mesh *m)
{
    memset(m, 0, sizeof *m);
    const sc_mesh_view *mesh = &checked->view;
    const float *lo = checked->lo, *hi = checked->hi;
    size_t nt = mesh->triangle_count;
    mkey *keys = malloc(nt * sizeof *keys);
    m->v = malloc(nt * sizeof *m->v);
    m->id = malloc(nt * sizeof *m->id);
    m->nclusters = (nt + CLUSTER - 1) / CLUSTER;
    m->box = malloc(m->nclusters * sizeof *m->box);
    if (!keys || !m->v || !m->id || !m->box) {
        free(keys);
        return SC_ERR_OUT_OF_MEMORY;
    }
    m->ntri = nt;
    for (size_t t = 0; t < nt; t++) {
        uint32_t q[3];
        for (int a = 0; a < 3; a++) {
            double c = 0;
            for (int j = 0; j < 3; j++)
                c += sc_mesh_vertex(mesh, sc_mesh_triangle(mesh, t)[j])[a];
            double ext = (double)hi[a] - lo[a];
            double f = ext > 0 ? (c / 3 - lo[a]) / ext : 0;
            f = f < 0 ? 0 : f > 1 ? 1 : f;
            q[a] = (uint32_t)(f * 2097151.0);
        }
        keys[t].code = spread3(q[0]) | spread3(q[1]) << 1 | spread3(q[2]) << 2;
        keys[t].tri = (uint32_t)t;
    }
    qsort(keys, nt, sizeof *keys, cmp_mkey);
    for (size_t k = 0; k < nt; k++) {
        uint32_t t = keys[k].tri;
        m->id[k] = t;
        for (int j = 0; j < 3; j++)
            for (int a = 0; a < 3; a++)
                m->v[k][3 * j + a] = sc_mesh_vertex(mesh, sc_mesh_triangle(mesh, t)[j])[a];
    }
    free(keys);
    for (size_t c = 0; c < m->nclusters; c++) {
        double *b = m->box[c];
        b[0] = b[1] = b[2] = INFINITY;
        b[3] = b[4] = b[5] = -INFINITY;
        for (size_t k = c * CLUSTER; k < (c + 1) * CLUSTER && k < nt; k++)
            for (int j = 0; j < 3; j++)
                for (int a = 0; a < 3; a++) {
                    double x = m->v[k][3 * j + a];
                    if (x < b[a]) b[a] = x;
                    if (x > b[3 + a]) b[3 + a] = x;
                }
        sc_tf_box_pad(b);
    }
    return SC_OK;
}

static void mesh_release(oracle_mesh *m)
{
    free(m->v), free(m->id), free(m->box);
    memset(m, 0, sizeof *m);
}

static void *run_job(void *arg)
{
    job *j = arg;
    const oracle_mesh *m = j->m;
    size_t cap = 256, nc = 0, xcap = 0;
    cand *cs = malloc(cap * sizeof *cs);
    float (*xt)[9] = NULL;                 /* SC_ORACLE_CROSSING: candidates as floats */
    uint32_t *xid = NULL;
    mpfr_t best, t;
    mpfr_init2(best, 256);
    mpfr_init2(t, 256);
    if (!cs) {
        j->failed = 1;
        goto out;
    }
    for (size_t i = j->begin; i < j->end; i++) {
        const sc_ray *r = &j->rays[i];
        const double O[3] = { r->org[0], r->org[1], r->org[2] };
        const double D[3] = { r->dir[0], r->dir[1], r->dir[2] };
        const double tmin = r->tmin, tmax = r->tmax;
        sc_oracle_hit *h = &j->hits[i];
        memset(h, 0, sizeof *h);
        h->t = INFINITY;
        nc = 0;
        for (size_t c = 0; c < m->nclusters; c++) {
            if (!sc_tf_box_may_hit(m->box[c], O, D, tmin, tmax))
                continue;
            size_t end = (c + 1) * CLUSTER < m->ntri ? (c + 1) * CLUSTER : m->ntri;
            for (size_t k = c * CLUSTER; k < end; k++) {
                double tl;
                if (!sc_tri_filter(m->v[k], O, D, tmin, tmax, &tl))
                    continue;
                if (nc == cap) {
                    cand *ncs = realloc(cs, 2 * cap * sizeof *cs);
                    if (!ncs) {
                        j->failed = 1;
                        goto out;
                    }
                    cs = ncs, cap *= 2;
                }
                cs[nc].t_lo = tl;
                cs[nc].k = (uint32_t)k;
                nc++;
            }
        }
        j->candidates += nc;
        qsort(cs, nc, sizeof *cs, cmp_cand);
        int have = 0, later = 0;
        size_t q = 0;
        for (; q < nc; q++) {
            /* every later candidate starts beyond the best exact t: done */
            if (have && mpfr_cmp_d(best, cs[q].t_lo) < 0)
                break;
            const double *v = m->v[cs[q].k];
            j->exact_calls++;
            if (!sc_ref_ray_triangle_mpfr(O, D, tmin, tmax, v, v + 3, v + 6, t))
                continue;
            uint32_t id = m->id[cs[q].k];
            int cmp = have ? mpfr_cmp(t, best) : -1;
            if (cmp > 0)
                later = 1;
            if (cmp < 0) {
                later |= have;                     /* the old best lies beyond */
                mpfr_set_prec(best, mpfr_get_prec(t));
                mpfr_set(best, t, MPFR_RNDN);
                have = 1;
                h->tie_count = 0;
            }
            if (cmp <= 0) {
                if (h->tie_count < SC_ORACLE_MAX_TIES)
                    h->ties[h->tie_count] = id;
                h->tie_count++;
            }
        }
        if (have && !later && (j->flags & SC_ORACLE_LATER_HIT))
            for (; q < nc && !later; q++) {
                const double *v = m->v[cs[q].k];
                j->exact_calls++;
                if (sc_ref_ray_triangle_mpfr(O, D, tmin, tmax, v, v + 3, v + 6, t) && mpfr_cmp(t, best) > 0)
                    later = 1;
            }
        h->crosses = have && later;
        h->cross_t = INFINITY;
        if (j->flags & SC_ORACLE_CROSSING) {
            if (nc > xcap) {
                float (*nxt)[9] = realloc(xt, nc * sizeof *xt);
                if (nxt)
                    xt = nxt;
                uint32_t *nxid = realloc(xid, nc * sizeof *xid);
                if (nxid)
                    xid = nxid;
                if (!nxt || !nxid) {
                    j->failed = 1;
                    goto out;
                }
                xcap = nc;
            }
            for (size_t q2 = 0; q2 < nc; q2++) {
                for (int c = 0; c < 9; c++)
                    xt[q2][c] = (float)m->v[cs[q2].k][c];   /* exact: the mesh is float */
                xid[q2] = m->id[cs[q2].k];
            }
            sc_cross_result x;
            j->exact_calls += nc;
            if (sc_cross_classify(r, (const float (*)[9])xt, xid, nc, &x) != SC_OK) {
                j->failed = 1;
                goto out;
            }
            h->coplanar = (uint32_t)x.coplanar;
            h->first_kind = x.ngroups ? (int)x.groups[0].kind : SC_CROSS_NONE;
            size_t fc = sc_cross_result_first(&x);
            if (fc < x.ngroups) {
                const sc_cross_group *g = &x.groups[fc];
                h->cross_t = g->t;
                h->cross_tie_count = g->count;
                uint32_t nt = g->count < SC_ORACLE_MAX_TIES ? g->count : SC_ORACLE_MAX_TIES;
                for (uint32_t a = 0; a < nt; a++) {       /* ascending, like ties */
                    uint32_t b = a, id = g->tri[a];
                    for (; b > 0 && h->cross_ties[b - 1] > id; b--)
                        h->cross_ties[b] = h->cross_ties[b - 1];
                    h->cross_ties[b] = id;
                }
            }
            sc_cross_result_free(&x);
        }
        if (have) {
            h->hit = 1;
            h->t = mpfr_get_d(best, MPFR_RNDN);
            uint32_t nt = h->tie_count < SC_ORACLE_MAX_TIES ? h->tie_count : SC_ORACLE_MAX_TIES;
            for (uint32_t a = 1; a < nt; a++)          /* insertion sort: tiny sets */
                for (uint32_t b = a; b > 0 && h->ties[b - 1] > h->ties[b]; b--) {
                    uint32_t s = h->ties[b];
                    h->ties[b] = h->ties[b - 1], h->ties[b - 1] = s;
                }
        }
    }
out:
    free(cs);
    free(xt);
    free(xid);
    mpfr_clear(best);
    mpfr_clear(t);
    mpfr_free_cache();
    return NULL;
}

/* rays[0..n) against a prepared mesh on `threads` threads into hits[0..n);
 * the work counts are added to *out. */
static sc_status run_prepared(const oracle_mesh *m, const sc_ray *rays, size_t n, int threads, int flags,
                              sc_oracle_hit *hits, sc_oracle *out)
{
    if (n == 0)
        return SC_OK;
    if ((size_t)threads > n)
        threads = (int)n;
    job *jobs = calloc((size_t)threads, sizeof *jobs);
    pthread_t *tid = calloc((size_t)threads, sizeof *tid);
    char *started = calloc((size_t)threads, 1);
    if (!jobs || !tid || !started) {
        free(jobs), free(tid), free(started);
        return SC_ERR_OUT_OF_MEMORY;
    }
    for (int k = 0; k < threads; k++) {
        jobs[k] = (job){ m, rays, hits, n * (size_t)k / (size_t)threads,
                         n * (size_t)(k + 1) / (size_t)threads, 0, 0, 0, flags };
        if (k > 0 && pthread_create(&tid[k], NULL, run_job, &jobs[k]) == 0)
            started[k] = 1;
        else if (k > 0)
            run_job(&jobs[k]);
    }
    run_job(&jobs[0]);
    int failed = jobs[0].failed;
    for (int k = 1; k < threads; k++) {
        if (started[k])
            pthread_join(tid[k], NULL);
        failed |= jobs[k].failed;
    }
    for (int k = 0; k < threads; k++) {
        out->candidates += jobs[k].candidates;
        out->exact_calls += jobs[k].exact_calls;
    }
    free(jobs), free(tid), free(started);
    return failed ? SC_ERR_OUT_OF_MEMORY : SC_OK;
}

static int bad_args(const sc_ray *rays, size_t n, int threads, int flags)
{
    return (n && !rays) || threads < 1 || threads > 256 || (flags & ~(SC_ORACLE_LATER_HIT | SC_ORACLE_CROSSING));
}

sc_status sc_oracle_run(const sc_checked_mesh *mesh, const sc_ray *rays, size_t n, int threads,
                        int flags, sc_oracle *out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    memset(out, 0, sizeof *out);
    if (!mesh || bad_args(rays, n, threads, flags))
        return SC_ERR_INVALID_ARGUMENT;
    sc_status st;
    oracle_mesh m;
    if ((st = mesh_prepare(mesh, &m)) != SC_OK) {
        mesh_release(&m);
        return st;
    }
    out->hits = malloc((n ? n : 1) * sizeof *out->hits);
    if (!out->hits) {
        mesh_release(&m);
        return SC_ERR_OUT_OF_MEMORY;
    }
    out->count = n;
    st = run_prepared(&m, rays, n, threads, flags, out->hits, out);
    mesh_release(&m);
    if (st != SC_OK)
        sc_oracle_free(out);
    return st;
}

/* ---- through instances ----------------------------------------------------- */

static void add_ids(uint32_t *set, uint32_t *count, const uint32_t *src, uint32_t src_count, const uint32_t *map,
                    size_t offset)
{
    uint32_t ns = src_count < SC_ORACLE_MAX_TIES ? src_count : SC_ORACLE_MAX_TIES;
    for (uint32_t k = 0; k < ns; k++) {
        uint32_t id = map ? map[src[k]] : (uint32_t)(offset + src[k]);
        if (*count < SC_ORACLE_MAX_TIES) {     /* ascending, like a single mesh's sets */
            uint32_t b = *count;
            for (; b > 0 && set[b - 1] > id; b--)
                set[b] = set[b - 1];
            set[b] = id;
        }
        (*count)++;
    }
    *count += src_count - ns;
}

/* Folds one mesh's answer for a ray into the scene's: the smallest exact t
 * wins, equal t (as doubles) join the tie set; ids through map (own mesh)
 * or plus offset (an instance's first triangle). */
static void merge_hit(sc_oracle_hit *d, const sc_oracle_hit *s, const uint32_t *map, size_t offset)
{
    if (s->hit) {
        if (!d->hit || s->t < d->t) {
            d->crosses = s->crosses || d->hit;     /* the old first hit lies beyond */
            d->hit = 1;
            d->t = s->t;
            d->first_kind = s->first_kind;
            d->tie_count = 0;
            add_ids(d->ties, &d->tie_count, s->ties, s->tie_count, map, offset);
        } else if (s->t == d->t) {
            d->crosses |= s->crosses;
            if (s->first_kind != d->first_kind)
                d->first_kind = s->first_kind == SC_CROSS_CROSS || d->first_kind == SC_CROSS_CROSS ? SC_CROSS_CROSS
                                                                                                 : SC_CROSS_AMBIG;
            add_ids(d->ties, &d->tie_count, s->ties, s->tie_count, map, offset);
        } else {
            d->crosses = 1;
        }
    }
    if (s->cross_t < d->cross_t) {
        d->cross_t = s->cross_t;
        d->cross_tie_count = 0;
        add_ids(d->cross_ties, &d->cross_tie_count, s->cross_ties, s->cross_tie_count, map, offset);
    } else if (isfinite(s->cross_t) && s->cross_t == d->cross_t) {
        add_ids(d->cross_ties, &d->cross_tie_count, s->cross_ties, s->cross_tie_count, map, offset);
    }
    d->coplanar += s->coplanar;
}

sc_status sc_oracle_run_scene(const sc_oracle_scene *sc, const sc_ray *rays, size_t n, int threads, int flags,
                              sc_oracle *out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    memset(out, 0, sizeof *out);
    if (!sc || bad_args(rays, n, threads, flags) || (sc->own && !sc->own_prim) ||
        (sc->num_objects && !sc->objects) || (sc->num_instances && (!sc->instances || !sc->object_ray)))
        return SC_ERR_INVALID_ARGUMENT;
    for (size_t i = 0; i < sc->num_instances; i++)
        if (sc->instances[i].object >= sc->num_objects)
            return SC_ERR_INVALID_ARGUMENT;
    out->hits = malloc((n ? n : 1) * sizeof *out->hits);
    sc_oracle_hit *part = malloc((n ? n : 1) * sizeof *part);
    sc_ray *orays = malloc((n ? n : 1) * sizeof *orays);
    size_t *idx = malloc((n ? n : 1) * sizeof *idx);
    sc_status st = SC_ERR_OUT_OF_MEMORY;
    if (!out->hits || !part || !orays || !idx)
        goto done;
    out->count = n;
    for (size_t i = 0; i < n; i++) {
        memset(&out->hits[i], 0, sizeof out->hits[i]);
        out->hits[i].t = out->hits[i].cross_t = INFINITY;
    }
    st = SC_OK;
    if (sc->own && sc->own->view.triangle_count) {
        oracle_mesh m;
        if ((st = mesh_prepare(sc->own, &m)) == SC_OK)
            st = run_prepared(&m, rays, n, threads, flags, part, out);
        mesh_release(&m);
        for (size_t i = 0; st == SC_OK && i < n; i++)
            merge_hit(&out->hits[i], &part[i], sc->own_prim, 0);
    }
    for (size_t k = 0; k < sc->num_objects && st == SC_OK; k++) {
        const sc_checked_mesh *obj = &sc->objects[k];
        if (!obj->view.triangle_count)
            continue;
        oracle_mesh m;
        if ((st = mesh_prepare(obj, &m)) != SC_OK) {
            mesh_release(&m);
            break;
        }
        /* the object's box, padded as the cluster boxes are: an object ray
         * that misses it misses every triangle */
        double box[6] = { obj->lo[0], obj->lo[1], obj->lo[2], obj->hi[0], obj->hi[1], obj->hi[2] };
        sc_tf_box_pad(box);
        for (size_t i = 0; i < sc->num_instances && st == SC_OK; i++) {
            if (sc->instances[i].object != k)
                continue;
            size_t ns = 0;
            for (size_t r = 0; r < n; r++) {
                sc_ray o;
                if (sc->object_ray(sc->ctx, i, &rays[r], &o) != SC_OK) {
                    st = SC_ERR_INVALID_ARGUMENT;
                    break;
                }
                const double O[3] = { o.org[0], o.org[1], o.org[2] }, D[3] = { o.dir[0], o.dir[1], o.dir[2] };
                if (sc_tf_box_may_hit(box, O, D, o.tmin, o.tmax)) {
                    idx[ns] = r;
                    orays[ns++] = o;
                }
            }
            if (st == SC_OK)
                st = run_prepared(&m, orays, ns, threads, flags, part, out);
            for (size_t q = 0; st == SC_OK && q < ns; q++)
                merge_hit(&out->hits[idx[q]], &part[q], NULL, sc->instances[i].first_triangle);
        }
        mesh_release(&m);
    }
done:
    free(part), free(orays), free(idx);
    if (st != SC_OK)
        sc_oracle_free(out);
    return st;
}

void sc_oracle_free(sc_oracle *o)
{
    if (!o)
        return;
    free(o->hits);
    memset(o, 0, sizeof *o);
}

int sc_oracle_accepts(const sc_oracle *o, size_t i, uint32_t prim)
{
    if (!o || i >= o->count || !o->hits[i].hit)
        return 0;
    const sc_oracle_hit *h = &o->hits[i];
    uint32_t nt = h->tie_count < SC_ORACLE_MAX_TIES ? h->tie_count : SC_ORACLE_MAX_TIES;
    for (uint32_t k = 0; k < nt; k++)
        if (h->ties[k] == prim)
            return 1;
    return h->tie_count > SC_ORACLE_MAX_TIES;
}

static int in_set(const uint32_t *set, uint32_t count, uint32_t prim)
{
    uint32_t n = count < SC_ORACLE_MAX_TIES ? count : SC_ORACLE_MAX_TIES;
    for (uint32_t k = 0; k < n; k++)
        if (set[k] == prim)
            return 1;
    return count > SC_ORACLE_MAX_TIES;
}

/* Slack for "at or before" an exact event: far above a float tracer's t error
 * (a few ulps times the conditioning of the hit), far below the gap to the
 * next surface on any mesh here. */
#define JUDGE_REL 1e-4

sc_oracle_verdict sc_oracle_judge(const sc_oracle *o, size_t i, uint32_t prim, float t)
{
    if (!o || i >= o->count)
        return SC_VERDICT_OK;
    const sc_oracle_hit *h = &o->hits[i];
    int hit = prim != SC_HITREC_MISS;
    if (isfinite(h->cross_t)) {
        int stopped = hit && (in_set(h->cross_ties, h->cross_tie_count, prim) ||
                              in_set(h->ties, h->tie_count, prim) ||
                              (double)t <= h->cross_t + JUDGE_REL * fabs(h->cross_t));
        if (!stopped)
            return SC_VERDICT_HOLE;
    }
    if (h->hit && h->first_kind == SC_CROSS_TOUCH) {
        int seen = hit && (in_set(h->ties, h->tie_count, prim) || (double)t <= h->t + JUDGE_REL * fabs(h->t));
        if (!seen)
            return SC_VERDICT_GRAZE_MISSED;
    }
    return SC_VERDICT_OK;
}
