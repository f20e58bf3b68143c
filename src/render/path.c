/* The path tracer: a wavefront over one tile. All paths of a tile's sample
 * pass advance together, one segment at a time, so the back end sees
 * batches of up to 256 rays (camera rays, then bounce rays, then the shadow
 * rays of next-event estimation) instead of one ray per call: our stream
 * call and Embree's both gain from batches, and both back ends get the
 * same rays in the same order.
 *
 * Everything random comes from the path's own generator, seeded by (seed,
 * pixel, sample): the draws of one path do not depend on which other paths
 * share its batch. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/sc_rng.h"
#include "render_internal.h"

#define PI 3.14159265358979323846
#define MAX_PATHS (SC_RENDER_TILE * SC_RENDER_TILE)
/* Shadow rays to an area light stop this fraction short of the sampled
 * point, so they do not find the emitter itself (or a coplanar neighbour)
 * at t ~ 1 +- rounding. */
#define SHADOW_SHORT 1e-4

typedef struct path {
    sc_rng rng;
    double o[3], d[3];    /* next ray; d is unit */
    double thr[3];        /* throughput */
    double pdf_dir;       /* solid-angle pdf d was sampled with; 0 for the camera ray */
    int pixel;            /* index within the tile */
} path;

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static void tri_vertices(const sc_scene_view *v, uint32_t prim, double a[3], double b[3], double c[3])
{
    const uint32_t *ix = sc_mesh_triangle(&v->mesh, prim);
    const float *pa = sc_mesh_vertex(&v->mesh, ix[0]), *pb = sc_mesh_vertex(&v->mesh, ix[1]),
                *pc = sc_mesh_vertex(&v->mesh, ix[2]);
    for (int i = 0; i < 3; i++) {
        a[i] = pa[i];
        b[i] = pb[i];
        c[i] = pc[i];
    }
}

static double mean3(const float e[3])
{
    return ((double)e[0] + e[1] + e[2]) / 3.0;
}

static const float *emission_of(const sc_scene_view *v, uint32_t prim)
{
    return v->mesh_emission ? v->mesh_emission + 3 * (size_t)v->mesh_ids[prim] : NULL;
}

sc_status sc_path_prepare(sc_render_ctx *c)
{
    const sc_scene_view *v = c->v;
    c->emit_prims = NULL;
    c->emit_cdf = NULL;
    c->num_emit = 0;
    c->emit_total = 0;
    size_t n = 0;
    for (size_t t = 0; v->mesh_emission && t < v->mesh.triangle_count; t++)
        n += mean3(emission_of(v, (uint32_t)t)) > 0;
    if (n) {
        c->emit_prims = malloc(n * sizeof *c->emit_prims);
        c->emit_cdf = malloc(n * sizeof *c->emit_cdf);
        if (!c->emit_prims || !c->emit_cdf) {
            sc_path_release(c);
            return SC_ERR_OUT_OF_MEMORY;
        }
        double total = 0;
        for (size_t t = 0; t < v->mesh.triangle_count; t++) {
            double lum = mean3(emission_of(v, (uint32_t)t));
            if (!(lum > 0))
                continue;
            double a[3], b[3], cc[3], e0[3], e1[3], nrm[3];
            tri_vertices(v, (uint32_t)t, a, b, cc);
            for (int i = 0; i < 3; i++) {
                e0[i] = b[i] - a[i];
                e1[i] = cc[i] - a[i];
            }
            cross3(e0, e1, nrm);
            double w = 0.5 * sqrt(dot3(nrm, nrm)) * lum;
            if (!(w > 0))
                continue;   /* zero area: it can neither be sampled nor seen */
            total += w;
            c->emit_prims[c->num_emit] = (uint32_t)t;
            c->emit_cdf[c->num_emit++] = total;
        }
        c->emit_total = total;
    }
    c->num_light_choices = (int)v->num_lights + (c->num_emit > 0);
    return SC_OK;
}

void sc_path_release(sc_render_ctx *c)
{
    free(c->emit_prims);
    free(c->emit_cdf);
    c->emit_prims = NULL;
    c->emit_cdf = NULL;
    c->num_emit = 0;
}

/* Solid-angle density with which next-event estimation picks the direction
 * to a point on an emitter of radiance le at distance dist, seen at cosine
 * cos_l from its normal. */
static double light_pdf(const sc_render_ctx *c, const float le[3], double dist, double cos_l)
{
    if (!c->num_emit || !(cos_l > 0))
        return 0;
    double pdf_area = mean3(le) / c->emit_total / c->num_light_choices;
    return pdf_area * dist * dist / cos_l;
}

static double power_heuristic(double a, double b)
{
    return a * a / (a * a + b * b);
}

/* A shadow ray and what it adds if nothing blocks it. */
typedef struct shadow {
    double contrib[3];
    int pixel;
} shadow;

/* Next-event estimation from x (offset origin xo, unit facing normal n,
 * albedo rho): one light picked uniformly among the point and directional
 * lights and the set of emitters (a triangle of the set in proportion to
 * its weight). Returns 1 and fills the shadow ray if it may contribute. */
static int sample_light(const sc_render_ctx *c, path *p, const double xo[3], const double n[3],
                        const float rho[3], sc_ray *ray, shadow *sh)
{
    const sc_scene_view *v = c->v;
    const int choices = c->num_light_choices;
    int k = (int)(sc_rng_uniform(&p->rng) * choices);
    if (k >= choices)
        k = choices - 1;
    double to[3], tmax, scale[3];
    if (k < (int)v->num_lights) {
        const sc_light *L = &v->lights[k];
        double cosine, falloff;
        if (L->type == SC_LIGHT_DIRECTIONAL) {
            for (int i = 0; i < 3; i++)
                to[i] = -(double)L->vec[i];
            double len = sqrt(dot3(to, to));
            if (!(len > 0))
                return 0;
            for (int i = 0; i < 3; i++)
                to[i] /= len;
            cosine = dot3(n, to);
            falloff = 1;
            tmax = INFINITY;
        } else {
            for (int i = 0; i < 3; i++)
                to[i] = (double)L->vec[i] - xo[i];
            double d2 = dot3(to, to);
            if (!(d2 > 0))
                return 0;
            cosine = dot3(n, to) / sqrt(d2);
            falloff = 1 / d2;
            tmax = 1 - 1e-6;   /* to is unnormalised: the light is at t = 1 */
        }
        if (!(cosine > 0))
            return 0;
        for (int i = 0; i < 3; i++)
            scale[i] = (double)L->color[i] * cosine * falloff * choices;
    } else {
        double u = sc_rng_uniform(&p->rng) * c->emit_total;
        size_t lo = 0, hi = c->num_emit - 1;
        while (lo < hi) {   /* the first prefix sum above u */
            size_t mid = lo + (hi - lo) / 2;
            if (c->emit_cdf[mid] > u)
                hi = mid;
            else
                lo = mid + 1;
        }
        uint32_t prim = c->emit_prims[lo];
        double a[3], b[3], cc[3], e0[3], e1[3], nl[3], q[3];
        tri_vertices(v, prim, a, b, cc);
        double su = sqrt(sc_rng_uniform(&p->rng)), u2 = sc_rng_uniform(&p->rng);
        double b0 = 1 - su, b1 = u2 * su;
        for (int i = 0; i < 3; i++) {
            q[i] = b0 * a[i] + b1 * b[i] + (1 - b0 - b1) * cc[i];
            to[i] = q[i] - xo[i];
            e0[i] = b[i] - a[i];
            e1[i] = cc[i] - a[i];
        }
        cross3(e0, e1, nl);
        double d2 = dot3(to, to), nll = sqrt(dot3(nl, nl));
        if (!(d2 > 0) || !(nll > 0))
            return 0;
        double dist = sqrt(d2);
        /* One-sided: x must lie in front of the emitter. */
        double cos_x = dot3(n, to) / dist, cos_l = -dot3(nl, to) / (nll * dist);
        if (!(cos_x > 0) || !(cos_l > 0))
            return 0;
        const float *le = emission_of(v, prim);
        double pl = light_pdf(c, le, dist, cos_l), pb = cos_x / PI;
        double w = power_heuristic(pl, pb);
        for (int i = 0; i < 3; i++)
            scale[i] = (double)le[i] * (1 / PI) * cos_x * w / pl;
        tmax = 1 - SHADOW_SHORT;
    }
    for (int i = 0; i < 3; i++)
        sh->contrib[i] = p->thr[i] * rho[i] * scale[i];
    if (!(sh->contrib[0] > 0 || sh->contrib[1] > 0 || sh->contrib[2] > 0))
        return 0;
    sh->pixel = p->pixel;
    for (int i = 0; i < 3; i++) {
        ray->org[i] = (float)xo[i];
        ray->dir[i] = (float)to[i];
    }
    ray->tmin = 0;
    ray->tmax = (float)tmax;
    return 1;
}

/* A cosine-weighted direction about the unit normal n. */
static double sample_cosine(sc_rng *r, const double n[3], double out[3])
{
    double u1 = sc_rng_uniform(r), u2 = sc_rng_uniform(r);
    double rr = sqrt(u1), ph = 2 * PI * u2, z = sqrt(1 - u1);
    /* Duff et al. 2017, "Building an orthonormal basis, revisited". */
    double sgn = n[2] >= 0 ? 1.0 : -1.0;
    double a = -1 / (sgn + n[2]), b = n[0] * n[1] * a;
    double t1[3] = { 1 + sgn * n[0] * n[0] * a, sgn * b, -sgn * n[0] };
    double t2[3] = { b, sgn + n[1] * n[1] * a, -n[1] };
    double x = rr * cos(ph), y = rr * sin(ph);
    for (int i = 0; i < 3; i++)
        out[i] = x * t1[i] + y * t2[i] + z * n[i];
    double len = sqrt(dot3(out, out));
    for (int i = 0; i < 3; i++)
        out[i] /= len;
    return z;
}

/* The hit point from the primitive alone, in double on the ray as traced:
 * the back end's t and barycentrics differ in the last bits between back
 * ends, its choice of triangle does not (away from edges). Writes the
 * unnormalised normal (V1 - V0) x (V2 - V0), the point and its t; returns 1
 * if the point lies within SC_RENDER_EDGE_BARY of an edge (or the triangle
 * is degenerate). */
static int locate_hit(const sc_scene_view *v, const sc_hitrec *h, const sc_ray *r, double ng[3], double x[3],
                      double *t_out)
{
    double a[3], b[3], cc[3], e0[3], e1[3], ro[3], rd[3];
    tri_vertices(v, h->prim, a, b, cc);
    for (int k = 0; k < 3; k++) {
        e0[k] = b[k] - a[k];
        e1[k] = cc[k] - a[k];
        ro[k] = r->org[k];
        rd[k] = r->dir[k];
    }
    cross3(e0, e1, ng);
    double nn = dot3(ng, ng), den = dot3(ng, rd), t = h->t;
    if (nn > 0 && den != 0) {
        double ao[3] = { a[0] - ro[0], a[1] - ro[1], a[2] - ro[2] };
        t = dot3(ng, ao) / den;
    }
    for (int k = 0; k < 3; k++)
        x[k] = ro[k] + t * rd[k];
    *t_out = t;
    if (!(nn > 0))
        return 1;
    double pa[3], pb[3], pc[3], q[3];
    for (int k = 0; k < 3; k++) {
        pa[k] = a[k] - x[k];
        pb[k] = b[k] - x[k];
        pc[k] = cc[k] - x[k];
    }
    cross3(pb, pc, q);
    double l0 = dot3(ng, q) / nn;
    cross3(pc, pa, q);
    double l1 = dot3(ng, q) / nn, l2 = 1 - l0 - l1;
    return fmin(l0, fmin(l1, l2)) < SC_RENDER_EDGE_BARY;
}

static uint64_t stream_seed(uint64_t seed, uint64_t pixel, uint64_t sample)
{
    uint64_t x = seed;
    uint64_t h = sc_rng_splitmix(&x);
    x = h ^ (pixel * 0x9e3779b97f4a7c15ull);
    h = sc_rng_splitmix(&x);
    x = h ^ (sample * 0xc2b2ae3d27d4eb4full);
    return sc_rng_splitmix(&x);
}

struct sc_path_work {
    path paths[MAX_PATHS];
    int active[MAX_PATHS];
    sc_ray rays[MAX_PATHS];
    sc_hitrec hits[MAX_PATHS];
    sc_ray shadow_rays[MAX_PATHS];
    shadow shadows[MAX_PATHS];
    uint8_t occluded[MAX_PATHS];
    double sum[MAX_PATHS][3];
    uint8_t edge[MAX_PATHS];
};

sc_path_work *sc_path_work_new(void)
{
    return malloc(sizeof(sc_path_work));
}

void sc_path_work_free(sc_path_work *w)
{
    free(w);
}

void sc_path_tile(const sc_render_ctx *c, sc_path_work *w, int x0, int y0, int x1, int y1, float *accum,
                  uint8_t *edge, sc_render_stats *st)
{
    const sc_scene_view *v = c->v;
    const sc_render_options *o = c->o;
    const sc_camera *cam = &v->camera;
    const int tw = x1 - x0, np = tw * (y1 - y0);
    memset(w->sum, 0, sizeof w->sum);
    memset(w->edge, 0, sizeof w->edge);
    sc_trace_stats *ts = c->collect ? &st->trace : NULL;

    for (int s = 0; s < o->spp; s++) {
        int n = 0;
        for (int py = y0; py < y1; py++)
            for (int px = x0; px < x1; px++, n++) {
                path *p = &w->paths[n];
                uint64_t global = (uint64_t)py * (uint64_t)cam->width + (uint64_t)px;
                sc_rng_seed(&p->rng, stream_seed(o->seed, global, (uint64_t)s));
                double jx = sc_rng_uniform(&p->rng), jy = sc_rng_uniform(&p->rng);
                sc_camera_ray_dir(cam, &c->frame, px + jx, py + jy, p->d);
                double len = sqrt(dot3(p->d, p->d));
                for (int i = 0; i < 3; i++) {
                    p->d[i] /= len;
                    p->o[i] = cam->eye[i];
                    p->thr[i] = 1;
                }
                p->pdf_dir = 0;
                p->pixel = n;
                w->active[n] = n;
            }
        for (int depth = 0; n > 0; depth++) {
            for (int i = 0; i < n; i++) {
                const path *p = &w->paths[w->active[i]];
                sc_ray *r = &w->rays[i];
                for (int k = 0; k < 3; k++) {
                    r->org[k] = (float)p->o[k];
                    r->dir[k] = (float)p->d[k];
                }
                r->tmin = 0;
                r->tmax = INFINITY;
            }
            /* A ray the back end refuses (none of ours should be) gets no
             * result: it sees the background. */
            for (int i = 0; i < n; i++)
                w->hits[i].prim = SC_HITREC_MISS;
            (void)sc_render_closest(c, w->rays, (size_t)n, w->hits, depth == 0, ts);
            if (depth == 0)
                st->primary_rays += (uint64_t)n;
            else
                st->bounce_rays += (uint64_t)n;

            int alive = 0, ns = 0;
            for (int i = 0; i < n; i++) {
                path *p = &w->paths[w->active[i]];
                const sc_hitrec *h = &w->hits[i];
                const sc_ray *r = &w->rays[i];
                double *sum = w->sum[p->pixel];
                if (h->prim == SC_HITREC_MISS || h->prim >= v->mesh.triangle_count) {
                    for (int k = 0; k < 3; k++)
                        sum[k] += p->thr[k] * v->background[k];
                    continue;
                }
                double ng[3], x[3], t;
                if (locate_hit(v, h, r, ng, x, &t))
                    w->edge[p->pixel] = 1;
                double nn = dot3(ng, ng), rd[3] = { r->dir[0], r->dir[1], r->dir[2] };
                double nrm[3], nl = sqrt(nn);
                for (int k = 0; k < 3; k++)
                    nrm[k] = nl > 0 ? ng[k] / nl : -p->d[k];
                double cos_in = -dot3(nrm, p->d);
                const int front = cos_in > 0;   /* emitters emit on their front side only */
                if (!front) {
                    for (int k = 0; k < 3; k++)
                        nrm[k] = -nrm[k];
                    cos_in = -cos_in;
                }
                const float *le = emission_of(v, h->prim);
                if (front && le && (le[0] > 0 || le[1] > 0 || le[2] > 0)) {
                    double wgt = 1;
                    if (p->pdf_dir > 0 && nl > 0) {
                        double dist = t * sqrt(dot3(rd, rd));
                        wgt = power_heuristic(p->pdf_dir, light_pdf(c, le, dist, cos_in));
                    }
                    for (int k = 0; k < 3; k++)
                        sum[k] += p->thr[k] * le[k] * wgt;
                }
                if (depth >= o->bounces)
                    continue;
                const float *rho = v->mesh_colors + 3 * (size_t)v->mesh_ids[h->prim];
                double xo[3];
                for (int k = 0; k < 3; k++)
                    xo[k] = x[k] + c->eps * nrm[k];
                if (c->num_light_choices > 0 &&
                    sample_light(c, p, xo, nrm, rho, &w->shadow_rays[ns], &w->shadows[ns]))
                    ns++;
                double dn[3];
                double cosine = sample_cosine(&p->rng, nrm, dn);
                if (!(cosine > 0))
                    continue;
                for (int k = 0; k < 3; k++) {
                    p->thr[k] *= rho[k];   /* (rho / pi) cos / (cos / pi) */
                    p->o[k] = xo[k];
                    p->d[k] = dn[k];
                }
                p->pdf_dir = cosine / PI;
                if (depth + 1 >= o->rr_depth) {
                    double q = fmin(0.95, fmax(p->thr[0], fmax(p->thr[1], p->thr[2])));
                    if (!(sc_rng_uniform(&p->rng) < q))
                        continue;
                    for (int k = 0; k < 3; k++)
                        p->thr[k] /= q;
                }
                if (!(p->thr[0] > 0 || p->thr[1] > 0 || p->thr[2] > 0))
                    continue;
                w->active[alive++] = w->active[i];
            }
            if (ns) {
                st->shadow_rays += (uint64_t)ns;
                memset(w->occluded, 1, (size_t)ns);   /* a refused shadow ray: no light */
                if (edge) {
                    /* Asked where paths pass near edges: the shadow rays
                     * find their nearest blocker, so a blocker hit near an
                     * edge (where a back end may legitimately miss it)
                     * marks the pixel. Same answer as the any-hit query. */
                    for (int j = 0; j < ns; j++)
                        w->hits[j].prim = SC_HITREC_MISS;
                    (void)sc_render_closest(c, w->shadow_rays, (size_t)ns, w->hits, 0, ts);
                    for (int j = 0; j < ns; j++) {
                        const sc_hitrec *h = &w->hits[j];
                        w->occluded[j] = h->prim != SC_HITREC_MISS;
                        double ng[3], x[3], t;
                        if (h->prim < v->mesh.triangle_count && locate_hit(v, h, &w->shadow_rays[j], ng, x, &t))
                            w->edge[w->shadows[j].pixel] = 1;
                    }
                } else {
                    (void)sc_render_occluded(c, w->shadow_rays, (size_t)ns, w->occluded, 0, ts);
                }
                for (int j = 0; j < ns; j++)
                    if (!w->occluded[j])
                        for (int k = 0; k < 3; k++)
                            w->sum[w->shadows[j].pixel][k] += w->shadows[j].contrib[k];
            }
            n = alive;
        }
    }
    for (int i = 0; i < np; i++) {
        int px = x0 + i % tw, py = y0 + i / tw;
        size_t g = (size_t)py * (size_t)cam->width + (size_t)px;
        for (int k = 0; k < 3; k++)
            accum[3 * g + k] = (float)(w->sum[i][k] / o->spp);
        if (edge)
            edge[g] = w->edge[i];
    }
}
