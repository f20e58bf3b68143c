/* The path tracer against closed forms, and its determinism:
 *   - a Lambert plane under a directional light (exact: rho C cos) and a
 *     point light (rho I cos / d^2 at the pixel), also against the direct
 *     integrator;
 *   - a white furnace: a convex sphere of albedo rho under a constant sky L
 *     is rho L wherever a pixel's footprint lies on it, exactly;
 *   - inside a closed emissive sphere (emission E, albedo rho) radiance is
 *     E (1 + rho + ... + rho^B) for B bounces, every emitter found both by
 *     next-event estimation and by bounce rays (multiple importance
 *     sampling: a wrong weight biases the sum);
 *   - the same image for 1 and 2 threads and two runs, and when the tiles
 *     are split between two calls (sc_render_tiles); the same radiance
 *     through a single-ray back end as through the stream calls; and, when
 *     Embree is built, the same radiance through Embree except at pixels
 *     whose paths passed near a triangle edge;
 *   - cancellation and argument checks. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "spherecull/sc_render.h"
#include "spherecull/sc_scene.h"
#ifdef SC_HAVE_EMBREE
#include "compare/tracer.h"
#include "spherecull/sc_mesh.h"
#endif

static sc_scene *load_json(const char *text)
{
    sc_scene *s = NULL;
    char err[512];
    sc_status st = sc_scene_load_json_text(text, strlen(text), "test", NULL, NULL, &s, err, sizeof err);
    if (st != SC_OK)
        fail_msg("%s", err);
    return s;
}

static sc_bvh *build(const sc_scene *s)
{
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    sc_bvh *bvh = NULL;
    assert_int_equal(sc_bvh_build(&v.mesh, NULL, &bvh), SC_OK);
    return bvh;
}

/* Renders with opt (path integrator set here) into a fresh radiance buffer. */
static float *render_radiance(const sc_scene *s, const sc_bvh *bvh, sc_render_options *o, sc_image *img)
{
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    float *rad = malloc((size_t)v.camera.width * (size_t)v.camera.height * 3 * sizeof(float));
    assert_non_null(rad);
    o->radiance = rad;
    assert_int_equal(sc_render(&v, bvh, o, img, NULL), SC_OK);
    return rad;
}

static void path_options(sc_render_options *o, int spp, int bounces)
{
    sc_render_options_init(o);
    o->integrator = SC_RENDER_PATH;
    o->spp = spp;
    o->bounces = bounces;
}

/* A 20 x 20 plane at y = 0 (albedo 0.5), seen from straight above. */
#define PLANE(light) \
    "{\"width\": 32, \"height\": 32, \"background\": [0,0,0], \"ambient\": 0," \
    " \"camera\": {\"eye\": [0, 3, 0], \"target\": [0, 0, 0], \"up\": [0, 0, -1], \"fov\": 20}," \
    " \"meshes\": [{\"vertices\": [[-10,0,-10],[10,0,-10],[10,0,10],[-10,0,10]], \"faces\": [[0,3,2,1]]," \
    " \"color\": [0.5, 0.5, 0.5]}], \"lights\": [" light "]}"

static void test_plane_directional(void **state)
{
    (void)state;
    /* cos = 0.8: radiance rho C cos = 0.5 * 1 * 0.8 everywhere. */
    sc_scene *s = load_json(PLANE("{\"type\": \"directional\", \"direction\": [-0.6, -0.8, 0]}"));
    sc_bvh *bvh = build(s);
    for (int bounces = 1; bounces <= 3; bounces += 2) {
        sc_render_options o;
        path_options(&o, 2, bounces);
        sc_image img = { 0 };
        float *rad = render_radiance(s, bvh, &o, &img);
        for (int i = 0; i < 32 * 32 * 3; i++)
            assert_float_equal(rad[i], 0.4f, 1e-6f);
        free(rad);
        sc_image_free(&img);
    }
    /* The direct integrator, same units: rho (ambient 0 + C cos). */
    sc_render_options o;
    sc_render_options_init(&o);
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    sc_image direct = { 0 };
    assert_int_equal(sc_render(&v, bvh, &o, &direct, NULL), SC_OK);
    uint8_t want = (uint8_t)lrint(255.0 * pow(0.4, 1 / 2.2));
    for (int i = 0; i < 32 * 32 * 3; i++)
        assert_int_equal(direct.rgb[i], want);
    sc_image_free(&direct);
    sc_bvh_free(bvh);
    sc_scene_free(s);
}

static void test_plane_point(void **state)
{
    (void)state;
    /* A point light of intensity 2 at height 1.5 over the origin: at plane
     * point (x, 0, z), cos = h / r and radiance rho I h / r^3. */
    sc_scene *s = load_json(PLANE("{\"type\": \"point\", \"position\": [0, 1.5, 0], \"intensity\": 2}"));
    sc_bvh *bvh = build(s);
    sc_render_options o;
    path_options(&o, 4, 1);
    sc_image img = { 0 };
    float *rad = render_radiance(s, bvh, &o, &img);
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    sc_camera_frame f;
    assert_int_equal(sc_camera_frame_make(&v.camera, &f), SC_OK);
    for (int y = 0; y < 32; y += 3)
        for (int x = 0; x < 32; x += 3) {
            double d[3];
            sc_camera_ray_dir(&v.camera, &f, x + 0.5, y + 0.5, d);
            double t = -3.0 / d[1], px = t * d[0], pz = t * d[2];
            double r = sqrt(px * px + pz * pz + 1.5 * 1.5);
            double want = 0.5 * 2 * 1.5 / (r * r * r);
            /* A pixel spans 0.033 units; the radiance varies by under 1 %
             * across it within this view. */
            assert_float_equal(rad[3 * (y * 32 + x)], want, 0.01 * want);
        }
    free(rad);
    sc_image_free(&img);
    sc_bvh_free(bvh);
    sc_scene_free(s);
}

/* The unit sphere (proc:sphere, 20k triangles) seen from (0, 0, 4). */
static void test_white_furnace(void **state)
{
    (void)state;
    sc_scene *s = load_json("{\"width\": 48, \"height\": 48, \"background\": [0.5, 0.5, 0.5],"
                            " \"camera\": {\"eye\": [0, 0, 4], \"target\": [0, 0, 0], \"up\": [0, 1, 0], \"fov\": 40},"
                            " \"meshes\": [{\"file\": \"proc:sphere:20k\", \"color\": [0.8, 0.8, 0.8]}],"
                            " \"lights\": []}");
    sc_bvh *bvh = build(s);
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    sc_camera_frame f;
    assert_int_equal(sc_camera_frame_make(&v.camera, &f), SC_OK);
    for (int bounces = 1; bounces <= 4; bounces += 3) {
        sc_render_options o;
        path_options(&o, 4, bounces);
        sc_image img = { 0 };
        float *rad = render_radiance(s, bvh, &o, &img);
        int inside = 0, outside = 0;
        for (int y = 0; y < 48; y++)
            for (int x = 0; x < 48; x++) {
                /* The largest angle between a corner ray of the pixel and
                 * the axis to the centre decides: every sample of the pixel
                 * hits the tessellated sphere (inscribed radius > 0.99) or
                 * none does. */
                double amax = 0, amin = 10;
                for (int k = 0; k < 4; k++) {
                    double d[3];
                    sc_camera_ray_dir(&v.camera, &f, x + (k & 1), y + (k >> 1), d);
                    double a = acos(-d[2] / sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]));
                    amax = fmax(amax, a);
                    amin = fmin(amin, a);
                }
                const float *p = rad + 3 * (y * 48 + x);
                if (amax < asin(0.98 / 4)) {
                    inside++;
                    for (int k = 0; k < 3; k++)
                        assert_float_equal(p[k], 0.4f, 1e-5f);   /* rho L */
                } else if (amin > asin(1.0 / 4)) {
                    outside++;
                    for (int k = 0; k < 3; k++)
                        assert_float_equal(p[k], 0.5f, 1e-6f);   /* L */
                }
            }
        assert_true(inside > 200 && outside > 400);
        free(rad);
        sc_image_free(&img);
    }
    sc_bvh_free(bvh);
    sc_scene_free(s);
}

static void test_emissive_sphere(void **state)
{
    (void)state;
    /* Mirrored in x, so the triangles face inwards and emit towards the
     * camera at the centre. */
    sc_scene *s = load_json("{\"width\": 64, \"height\": 64, \"background\": [0, 0, 0],"
                            " \"camera\": {\"eye\": [0.1, 0.05, 0], \"target\": [1, 0.2, 0.3], \"up\": [0, 1, 0], \"fov\": 90},"
                            " \"meshes\": [{\"file\": \"proc:sphere:2k\", \"scale\": [-1, 1, 1],"
                            " \"color\": [0.5, 0.5, 0.5], \"emission\": [1, 1, 1]}], \"lights\": []}");
    sc_bvh *bvh = build(s);
    const int bounces[] = { 0, 1, 4, 8 };
    for (int b = 0; b < 4; b++) {
        sc_render_options o;
        path_options(&o, 16, bounces[b]);
        sc_image img = { 0 };
        float *rad = render_radiance(s, bvh, &o, &img);
        double want = 0, term = 1;
        for (int k = 0; k <= bounces[b]; k++, term *= 0.5)
            want += term;
        double sum = 0;
        for (int i = 0; i < 64 * 64; i++)
            sum += rad[3 * i];
        double mean = sum / (64 * 64);
        /* 65k paths: the standard error of the mean is below 0.2 % here. */
        if (fabs(mean - want) > 0.01 * want)
            fail_msg("bounces %d: mean radiance %.5f, closed form %.5f", bounces[b], mean, want);
        free(rad);
        sc_image_free(&img);
    }
    sc_bvh_free(bvh);
    sc_scene_free(s);
}

static const char *const room =
    "{\"width\": 40, \"height\": 30, \"background\": [0.2, 0.25, 0.3],"
    " \"camera\": {\"eye\": [0.5, 0.5, 2.0], \"target\": [0.5, 0.45, 0], \"up\": [0, 1, 0], \"fov\": 40},"
    " \"meshes\": ["
    "  {\"vertices\": [[0,0,0],[1,0,0],[1,0,1],[0,0,1]], \"faces\": [[0,1,2,3]], \"color\": [0.7,0.7,0.7]},"
    "  {\"vertices\": [[0,0,0],[0,1,0],[1,1,0],[1,0,0]], \"faces\": [[0,1,2,3]], \"color\": [0.7,0.7,0.7]},"
    "  {\"vertices\": [[0,0,0],[0,0,1],[0,1,1],[0,1,0]], \"faces\": [[0,1,2,3]], \"color\": [0.6,0.1,0.1]},"
    "  {\"vertices\": [[0.4,0.99,0.4],[0.6,0.99,0.4],[0.6,0.99,0.6],[0.4,0.99,0.6]], \"faces\": [[0,1,2,3]],"
    "   \"emission\": [8, 8, 8]},"
    "  {\"file\": \"proc:sphere:2k\", \"scale\": 0.2, \"translate\": [0.6, 0.2, 0.5], \"color\": [0.2,0.5,0.8]}],"
    " \"lights\": [{\"type\": \"point\", \"position\": [0.8, 0.8, 0.8], \"intensity\": 0.3}]}";

static void test_deterministic(void **state)
{
    (void)state;
    sc_scene *s = load_json(room);
    sc_bvh *bvh = build(s);
    sc_image img[3] = { { 0 }, { 0 }, { 0 } };
    float *rad[3];
    const int threads[3] = { 1, 2, 2 };
    for (int r = 0; r < 3; r++) {
        sc_render_options o;
        path_options(&o, 4, 4);
        o.threads = threads[r];
        rad[r] = render_radiance(s, bvh, &o, &img[r]);
    }
    size_t n = (size_t)img[0].width * (size_t)img[0].height * 3;
    for (int r = 1; r < 3; r++) {
        assert_memory_equal(img[0].rgb, img[r].rgb, n);
        assert_memory_equal(rad[0], rad[r], n * sizeof(float));
    }
    /* Asking for the edge mask (shadow rays as closest-hit queries) changes
     * no pixel. */
    {
        sc_render_options o;
        path_options(&o, 4, 4);
        uint8_t *edge = calloc(n / 3, 1);
        assert_non_null(edge);
        o.edge = edge;
        sc_image e = { 0 };
        float *re = render_radiance(s, bvh, &o, &e);
        assert_memory_equal(re, rad[0], n * sizeof(float));
        size_t marked = 0;
        for (size_t i = 0; i < n / 3; i++)
            marked += edge[i];
        assert_true(marked < n / 3 / 2);
        free(edge);
        free(re);
        sc_image_free(&e);
    }
    /* Something was lit, and the seed matters. */
    double sum = 0;
    for (size_t i = 0; i < n; i++)
        sum += rad[0][i];
    assert_true(sum > 0.05 * (double)n);
    sc_render_options o;
    path_options(&o, 4, 4);
    o.seed = 2;
    sc_image other = { 0 };
    float *rad2 = render_radiance(s, bvh, &o, &other);
    assert_true(memcmp(rad2, rad[0], n * sizeof(float)) != 0);
    free(rad2);
    sc_image_free(&other);
    for (int r = 0; r < 3; r++) {
        free(rad[r]);
        sc_image_free(&img[r]);
    }
    sc_bvh_free(bvh);
    sc_scene_free(s);
}

/* sc_render_tiles, as the MPI driver uses it: two calls stand for two
 * processes, one rendering the even tiles, the other the odd ones; the
 * second's combine adds the first's buffers. Its image is the one of a
 * single call, bit for bit, for the path tracer and for the depth view
 * (whose scale comes from every pixel); a status combine returns is what
 * sc_render returns. */
typedef struct {
    int next;                 /* the next tile this "process" takes (steps of 2) */
    float *color, *value;     /* the first process's buffers, kept */
    size_t pixels;
    sc_status verdict;        /* what combine answers */
    int combines;
} split_tiles;

static int split_next(void *ctx)
{
    split_tiles *t = ctx;
    return __atomic_fetch_add(&t->next, 2, __ATOMIC_RELAXED);
}

static split_tiles *split_first;   /* the first process's state, for the second's combine */

static sc_status split_combine(void *ctx, sc_status local, float *color, float *value, size_t pixels,
                               sc_render_stats *stats)
{
    split_tiles *t = ctx;
    (void)stats;
    t->combines++;
    if (local != SC_OK || t->verdict != SC_OK)
        return local != SC_OK ? local : t->verdict;
    if (t == split_first) {
        t->color = malloc(pixels * 3 * sizeof(float));
        t->value = malloc(pixels * sizeof(float));
        assert_non_null(t->color);
        assert_non_null(t->value);
        memcpy(t->color, color, pixels * 3 * sizeof(float));
        memcpy(t->value, value, pixels * sizeof(float));
        t->pixels = pixels;
        return SC_OK;
    }
    assert_int_equal(pixels, split_first->pixels);
    for (size_t i = 0; i < 3 * pixels; i++)
        color[i] += split_first->color[i];
    for (size_t i = 0; i < pixels; i++)
        value[i] += split_first->value[i];
    return SC_OK;
}

static void test_tiles_hook(void **state)
{
    (void)state;
    sc_scene *s = load_json(room);
    sc_bvh *bvh = build(s);
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    for (int view = 0; view < 2; view++) {
        sc_render_options o;
        if (view == 0) {
            path_options(&o, 2, 3);
        } else {
            sc_render_options_init(&o);
            o.debug = SC_RENDER_DEPTH;
        }
        sc_image whole = { 0 }, part[2] = { { 0 }, { 0 } };
        assert_int_equal(sc_render(&v, bvh, &o, &whole, NULL), SC_OK);
        split_tiles t[2] = { { .next = 0 }, { .next = 1 } };
        split_first = &t[0];
        for (int p = 0; p < 2; p++) {
            sc_render_tiles hook = { split_next, split_combine, &t[p] };
            o.tiles = &hook;
            assert_int_equal(sc_render(&v, bvh, &o, &part[p], NULL), SC_OK);
            assert_int_equal(t[p].combines, 1);
        }
        size_t n = (size_t)whole.width * (size_t)whole.height * 3;
        /* the first "process" alone has holes; both together are the image */
        assert_true(memcmp(part[0].rgb, whole.rgb, n) != 0);
        assert_memory_equal(part[1].rgb, whole.rgb, n);
        free(t[0].color);
        free(t[0].value);
        sc_image_free(&whole);
        sc_image_free(&part[0]);
        sc_image_free(&part[1]);
    }
    /* a failure elsewhere: combine's verdict is the render's */
    sc_render_options o;
    path_options(&o, 1, 1);
    split_tiles bad = { .next = 0, .verdict = SC_ERR_IO };
    split_first = NULL;
    sc_render_tiles hook = { split_next, split_combine, &bad };
    o.tiles = &hook;
    sc_image img = { 0 };
    assert_int_equal(sc_render(&v, bvh, &o, &img, NULL), SC_ERR_IO);
    assert_int_equal(bad.combines, 1);
    assert_null(img.rgb);
    /* a hook without its functions is refused */
    sc_render_tiles empty = { NULL, NULL, NULL };
    o.tiles = &empty;
    assert_int_equal(sc_render(&v, bvh, &o, &img, NULL), SC_ERR_INVALID_ARGUMENT);
    sc_bvh_free(bvh);
    sc_scene_free(s);
}

/* A back end of single-ray calls: another code path to the same answers. */
static sc_status one_closest(void *ctx, const sc_ray *rays, size_t n, sc_hitrec *hits, int coherent)
{
    (void)coherent;
    for (size_t i = 0; i < n; i++)
        if (sc_trace_closest(ctx, &rays[i], &hits[i], NULL) != SC_OK)
            return SC_ERR_INVALID_ARGUMENT;
    return SC_OK;
}

static sc_status one_occluded(void *ctx, const sc_ray *rays, size_t n, uint8_t *occ, int coherent)
{
    (void)coherent;
    for (size_t i = 0; i < n; i++) {
        int hit = 0;
        if (sc_trace_any(ctx, &rays[i], &hit, NULL) != SC_OK)
            return SC_ERR_INVALID_ARGUMENT;
        occ[i] = (uint8_t)hit;
    }
    return SC_OK;
}

static void test_backend_single_rays(void **state)
{
    (void)state;
    sc_scene *s = load_json(room);
    sc_bvh *bvh = build(s);
    sc_render_options o;
    path_options(&o, 4, 4);
    sc_image a = { 0 }, b = { 0 };
    float *ra = render_radiance(s, bvh, &o, &a);
    sc_render_backend be = { one_closest, one_occluded, bvh };
    path_options(&o, 4, 4);
    o.backend = &be;
    float *rb = render_radiance(s, NULL, &o, &b);
    assert_memory_equal(ra, rb, (size_t)a.width * (size_t)a.height * 3 * sizeof(float));
    free(ra);
    free(rb);
    sc_image_free(&a);
    sc_image_free(&b);
    sc_bvh_free(bvh);
    sc_scene_free(s);
}

#ifdef SC_HAVE_EMBREE
/* Same rays, same seeds: the image of Embree's watertight (robust) build
 * equals ours wherever no path of the pixel passed within
 * SC_RENDER_EDGE_BARY of a triangle edge (in either back end's hits), where
 * the two may legitimately pick different triangles. (Embree's default
 * build is not watertight: a ray it lets through a shared edge reports a
 * triangle behind, far from any edge.) */
static void test_backend_embree(void **state)
{
    (void)state;
    sc_scene *s = load_json(room);
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    sc_bvh *bvh = build(s);
    sc_checked_mesh cm;
    assert_int_equal(sc_mesh_check(&v.mesh, &cm), SC_OK);
    sc_tracer t;
    sc_status st = sc_tracer_build(&t, sc_tracer_find("embree-robust"), &cm);
    if (st == SC_ERR_UNSUPPORTED) {
        sc_bvh_free(bvh);
        sc_scene_free(s);
        skip();
    }
    assert_int_equal(st, SC_OK);
    t.ftz = 1;
    sc_tracer_backend be;
    sc_tracer_render_backend(&t, &be);
    size_t npx = (size_t)v.camera.width * (size_t)v.camera.height;
    uint8_t *ea = calloc(npx, 1), *eb = calloc(npx, 1);
    assert_true(ea && eb);
    sc_render_options o;
    path_options(&o, 8, 4);
    o.edge = ea;
    sc_image a = { 0 }, b = { 0 };
    float *ra = render_radiance(s, bvh, &o, &a);
    path_options(&o, 8, 4);
    o.edge = eb;
    o.backend = &be.backend;
    float *rb = render_radiance(s, NULL, &o, &b);
    size_t edge = 0, differ = 0;
    for (size_t i = 0; i < npx; i++) {
        int same = memcmp(ra + 3 * i, rb + 3 * i, 3 * sizeof(float)) == 0;
        if (ea[i] || eb[i])
            edge++;
        else
            differ += !same;
    }
    if (differ)
        fail_msg("%zu pixels away from edges differ between spherecull and Embree", differ);
    assert_true(edge < npx / 2);
    free(ra);
    free(rb);
    free(ea);
    free(eb);
    sc_image_free(&a);
    sc_image_free(&b);
    sc_tracer_free(&t);
    sc_bvh_free(bvh);
    sc_scene_free(s);
}
#endif

static void test_cancel_and_arguments(void **state)
{
    (void)state;
    sc_scene *s = load_json(room);
    sc_bvh *bvh = build(s);
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    sc_render_options o;
    path_options(&o, 1, 1);
    volatile int stop = 1;
    o.cancel = &stop;
    sc_image img = { 0 };
    assert_int_equal(sc_render(&v, bvh, &o, &img, NULL), SC_ERR_CANCELLED);
    assert_null(img.rgb);
    struct {
        int spp, bounces, rr, debug;
        double exposure;
    } bad[] = { { 0, 1, 3, 0, 0 }, { 65537, 1, 3, 0, 0 }, { 1, -1, 3, 0, 0 }, { 1, 65, 3, 0, 0 },
                { 1, 1, 0, 0, 0 }, { 1, 1, 3, SC_RENDER_NORMALS, 0 }, { 1, 1, 3, 0, NAN } };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        path_options(&o, bad[i].spp, bad[i].bounces);
        o.rr_depth = bad[i].rr;
        o.debug = (sc_render_debug)bad[i].debug;
        o.exposure = bad[i].exposure;
        assert_int_equal(sc_render(&v, bvh, &o, &img, NULL), SC_ERR_INVALID_ARGUMENT);
    }
    path_options(&o, 1, 1);
    assert_int_equal(sc_render(&v, NULL, &o, &img, NULL), SC_ERR_INVALID_ARGUMENT);   /* no tracer */
    sc_render_integrator in;
    assert_int_equal(sc_render_integrator_from_name("path", &in), SC_OK);
    assert_int_equal(in, SC_RENDER_PATH);
    assert_int_equal(sc_render_integrator_from_name("paths", &in), SC_ERR_INVALID_ARGUMENT);
    assert_string_equal(sc_render_integrator_name(SC_RENDER_DIRECT), "direct");
    sc_bvh_free(bvh);
    sc_scene_free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_plane_directional),
        cmocka_unit_test(test_plane_point),
        cmocka_unit_test(test_white_furnace),
        cmocka_unit_test(test_emissive_sphere),
        cmocka_unit_test(test_deterministic),
        cmocka_unit_test(test_tiles_hook),
        cmocka_unit_test(test_backend_single_rays),
#ifdef SC_HAVE_EMBREE
        cmocka_unit_test(test_backend_embree),
#endif
        cmocka_unit_test(test_cancel_and_arguments),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
