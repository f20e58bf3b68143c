/* The OSMesa raster reference against geometry whose image is known without
 * the rasterizer: a screen-filling quad, a tessellated sphere bounded by two
 * analytic spheres, and an independent double-precision brute-force ray cast
 * (every pixel centre against every triangle, rays from sc_camera_ray_dir).
 *
 * Run once per depth mode: argv[1] = "float" (FLOAT_REVERSED) or "fixed24". */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "common/sc_rng.h"
#include "spherecull/sc_raster.h"

#define SC_PI 3.14159265358979323846

static sc_raster_depth_mode g_mode = SC_RASTER_DEPTH_FLOAT_REVERSED;
static const char *g_mode_name = "float";

/* llvmpipe snaps vertices to 1/256 pixel (8 subpixel bits); twice that
 * bounds where a snapped edge or depth plane can sit relative to the exact
 * one. */
#define SNAP_PX (1.0 / 128)

typedef struct mesh_buf {
    float *pos;
    uint32_t *idx;
    float *col;
    size_t nv, nt;
} mesh_buf;

static sc_mesh_view as_mesh(const mesh_buf *m)
{
    sc_mesh_view r = { m->pos, m->nv, m->idx, m->nt, 0, 0 };
    return r;
}

static void mesh_free(mesh_buf *m)
{
    free(m->pos);
    free(m->idx);
    free(m->col);
    memset(m, 0, sizeof *m);
}

/* UV sphere: nlat bands, nlon segments, every vertex on the sphere. */
static mesh_buf uv_sphere(const double c[3], double r, int nlat, int nlon)
{
    mesh_buf m = { 0 };
    m.nv = (size_t)(nlat + 1) * (size_t)nlon;
    m.nt = 2 * (size_t)nlat * (size_t)nlon;
    m.pos = malloc(m.nv * 3 * sizeof *m.pos);
    m.idx = malloc(m.nt * 3 * sizeof *m.idx);
    assert_non_null(m.pos);
    assert_non_null(m.idx);
    for (int i = 0; i <= nlat; i++) {
        double th = SC_PI * i / nlat;
        for (int j = 0; j < nlon; j++) {
            double ph = 2 * SC_PI * j / nlon;
            float *p = m.pos + 3 * ((size_t)i * nlon + j);
            p[0] = (float)(c[0] + r * sin(th) * cos(ph));
            p[1] = (float)(c[1] + r * cos(th));
            p[2] = (float)(c[2] + r * sin(th) * sin(ph));
        }
    }
    size_t t = 0;
    for (int i = 0; i < nlat; i++)
        for (int j = 0; j < nlon; j++) {
            uint32_t a = (uint32_t)(i * nlon + j), b = (uint32_t)(i * nlon + (j + 1) % nlon);
            uint32_t c2 = a + (uint32_t)nlon, d = b + (uint32_t)nlon;
            uint32_t q[6] = { a, c2, b, b, c2, d };
            memcpy(m.idx + 3 * t, q, sizeof q);
            t += 2;
        }
    /* The pole rows hold nlon copies of one point: their degenerate
     * triangles stay in, as real meshes have them too. */
    return m;
}

/* Non-intersecting soup: triangle k lies in its own slab of depth along
 * axis w, so visibility is a strict depth order with no intersection
 * curves (where depth precision, not edges, would decide). */
static mesh_buf layered_soup(sc_rng *rng, size_t n, const double origin[3], double size)
{
    mesh_buf m = { 0 };
    m.nv = 3 * n;
    m.nt = n;
    m.pos = malloc(m.nv * 3 * sizeof *m.pos);
    m.idx = malloc(m.nt * 3 * sizeof *m.idx);
    m.col = malloc(m.nt * 3 * sizeof *m.col);
    assert_non_null(m.pos);
    assert_non_null(m.idx);
    assert_non_null(m.col);
    double slab = size / (double)n;
    for (size_t k = 0; k < n; k++) {
        /* Shuffle draw order against depth order so the depth test decides. */
        size_t layer = (k * 7919) % n;
        for (int v = 0; v < 3; v++) {
            float *p = m.pos + 3 * (3 * k + v);
            p[0] = (float)(origin[0] + sc_rng_range(rng, -0.5, 0.5) * size);
            p[1] = (float)(origin[1] + sc_rng_range(rng, -0.5, 0.5) * size);
            p[2] = (float)(origin[2] + (layer + sc_rng_range(rng, 0.1, 0.6)) * slab - 0.5 * size);
            m.idx[3 * k + v] = (uint32_t)(3 * k + v);
            m.col[3 * k + v] = (float)sc_rng_uniform(rng);
        }
    }
    return m;
}

/* Möller-Trumbore in double, nearest hit with t > 0; ties keep the lower
 * index, as the depth test keeps the first triangle drawn. */
typedef struct bf_hit {
    uint32_t id;
    double t;
} bf_hit;

static bf_hit brute_force_pixel(const mesh_buf *m, const double o[3], const double d[3])
{
    bf_hit best = { 0, INFINITY };
    for (size_t k = 0; k < m->nt; k++) {
        double v[3][3];
        for (int j = 0; j < 3; j++)
            for (int i = 0; i < 3; i++)
                v[j][i] = m->pos[3 * m->idx[3 * k + j] + i];
        double e1[3], e2[3], s[3], p[3], q[3];
        for (int i = 0; i < 3; i++) {
            e1[i] = v[1][i] - v[0][i];
            e2[i] = v[2][i] - v[0][i];
            s[i] = o[i] - v[0][i];
        }
        p[0] = d[1] * e2[2] - d[2] * e2[1];
        p[1] = d[2] * e2[0] - d[0] * e2[2];
        p[2] = d[0] * e2[1] - d[1] * e2[0];
        double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
        if (det == 0)
            continue;
        double inv = 1 / det;
        double u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) * inv;
        if (u < 0 || u > 1)
            continue;
        q[0] = s[1] * e1[2] - s[2] * e1[1];
        q[1] = s[2] * e1[0] - s[0] * e1[2];
        q[2] = s[0] * e1[1] - s[1] * e1[0];
        double w = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) * inv;
        if (w < 0 || u + w > 1)
            continue;
        double t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) * inv;
        if (t > 0 && t < best.t) {
            best.t = t;
            best.id = (uint32_t)(k + 1);
        }
    }
    return best;
}

/* Ray-plane t of triangle id (1-based) along d, for depth tolerances. */
static double plane_t(const mesh_buf *m, uint32_t id, const double o[3], const double d[3])
{
    const uint32_t *tri = m->idx + 3 * (size_t)(id - 1);
    double a[3], e1[3], e2[3], n[3];
    for (int i = 0; i < 3; i++) {
        a[i] = m->pos[3 * tri[0] + i];
        e1[i] = m->pos[3 * tri[1] + i] - a[i];
        e2[i] = m->pos[3 * tri[2] + i] - a[i];
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    double num = (a[0] - o[0]) * n[0] + (a[1] - o[1]) * n[1] + (a[2] - o[2]) * n[2];
    return num / (d[0] * n[0] + d[1] * n[1] + d[2] * n[2]);
}

/* How far the raster depth may sit from the exact t: float rounding of the
 * clip coordinates and of the interpolation (16 ulps), the depth plane
 * moved by vertex snapping (its change over SNAP_PX), and for FIXED24 the
 * buffer's quantum d^2 (f - n) / (f n) 2^-24 four times: the GL forms
 * z_ndc = z_c / w_c in float where z_ndc is close to 1, so z_c, w_c, the
 * division and the interpolation can each be off by about one quantum
 * (measured: up to 2.5 quanta with the camera inside a sphere). */
static double depth_tolerance(const mesh_buf *m, const sc_camera *cam, const sc_camera_frame *fr,
                              const sc_raster_image *img, uint32_t id, int x, int y, double t)
{
    double tol = 16 * 0x1p-24 * t;
    double d0[3], dx[3], dy[3];
    sc_camera_ray_dir(cam, fr, x + 0.5, y + 0.5, d0);
    sc_camera_ray_dir(cam, fr, x + 0.5 + SNAP_PX, y + 0.5, dx);
    sc_camera_ray_dir(cam, fr, x + 0.5, y + 0.5 + SNAP_PX, dy);
    double t0 = plane_t(m, id, cam->eye, d0);
    tol += fabs(plane_t(m, id, cam->eye, dx) - t0) + fabs(plane_t(m, id, cam->eye, dy) - t0);
    if (img->depth_mode == SC_RASTER_DEPTH_FIXED24) {
        double n = img->near_dist, f = img->far_dist;
        tol += 4 * t * t * (f - n) / (f * n) * 0x1p-24;
    }
    return tol;
}

typedef struct agreement {
    size_t pixels, agree, at_edge, elsewhere, depth_bad;
    double worst_edge_px, worst_depth_rel, worst_tol_ratio;
} agreement;

static agreement compare_with_brute_force(const mesh_buf *m, const sc_camera *cam,
                                          const sc_raster_image *img)
{
    agreement a = { 0 };
    sc_camera_frame fr;
    assert_int_equal(sc_camera_frame_make(cam, &fr), SC_OK);
    sc_mesh_view mesh = as_mesh(m);
    for (int y = 0; y < cam->height; y++)
        for (int x = 0; x < cam->width; x++) {
            double d[3];
            sc_camera_ray_dir(cam, &fr, x + 0.5, y + 0.5, d);
            bf_hit h = brute_force_pixel(m, cam->eye, d);
            size_t p = (size_t)y * cam->width + x;
            uint32_t rid = img->ids[p];
            a.pixels++;
            if (rid == h.id) {
                a.agree++;
                if (rid) {
                    double err = fabs(img->depth[p] - h.t);
                    double tol = depth_tolerance(m, cam, &fr, img, rid, x, y, h.t);
                    if (!(err <= tol))
                        a.depth_bad++;
                    if (err / tol > a.worst_tol_ratio)
                        a.worst_tol_ratio = err / tol;
                    if (err / h.t > a.worst_depth_rel)
                        a.worst_depth_rel = err / h.t;
                } else {
                    assert_true(isinf(img->depth[p]));
                }
                continue;
            }
            double dist;
            assert_int_equal(sc_raster_edge_distance(&mesh, cam, img->near_dist, x, y, rid, h.id,
                                                     &dist), SC_OK);
            if (dist <= SC_RASTER_EDGE_RADIUS_PX) {
                a.at_edge++;
                if (dist > a.worst_edge_px)
                    a.worst_edge_px = dist;
            } else {
                a.elsewhere++;
                print_message("  elsewhere: pixel %d,%d raster %u brute force %u dist %.3g px\n",
                              x, y, (unsigned)rid, (unsigned)h.id, dist);
            }
        }
    return a;
}

static void report(const char *what, const agreement *a)
{
    print_message("[%s] %s: %zu px, agreement %.4f%%, %zu at edge (max %.3f px), %zu elsewhere, "
                  "%zu depth beyond tolerance, worst depth rel err %.3g (%.2f of tolerance)\n",
                  g_mode_name, what, a->pixels, 100.0 * a->agree / a->pixels, a->at_edge,
                  a->worst_edge_px, a->elsewhere, a->depth_bad, a->worst_depth_rel, a->worst_tol_ratio);
}

static sc_raster_options mode_options(void)
{
    sc_raster_options o;
    sc_raster_options_default(&o);
    o.depth_mode = g_mode;
    return o;
}

static void render_ok(const mesh_buf *m, const sc_camera *cam, sc_raster_image *img)
{
    sc_mesh_view mesh = as_mesh(m);
    sc_raster_options o = mode_options();
    o.colors = m->col;
    sc_status st = sc_raster_render(&mesh, cam, &o, img);
    if (st != SC_OK)
        print_message("sc_raster_render: %s: %s\n", sc_strerror(st), img->error);
    assert_int_equal(st, SC_OK);
    assert_int_equal(img->depth_mode, g_mode);
    assert_int_equal(img->width, cam->width);
    assert_int_equal(img->height, cam->height);
}

/* A quad far larger than the view, square to the view axis at distance 5:
 * every pixel sees it, at depth exactly 5. */
static void test_quad_fills_screen(void **state)
{
    (void)state;
    float pos[] = { -100, -100, 5, 100, -100, 5, 100, 100, 5, -100, 100, 5 };
    uint32_t idx[] = { 0, 1, 2, 0, 2, 3 };
    mesh_buf m = { pos, idx, NULL, 4, 2 };
    sc_camera cam = { { 0, 0, 0 }, { 0, 0, 1 }, { 0, 1, 0 }, 60, 97, 61 };
    sc_raster_image img;
    render_ok(&m, &cam, &img);
    size_t count[3] = { 0, 0, 0 };
    double worst = 0;
    for (size_t p = 0; p < (size_t)97 * 61; p++) {
        assert_in_range(img.ids[p], 1, 2);
        count[img.ids[p]]++;
        double err = fabs(img.depth[p] - 5.0);
        worst = err > worst ? err : worst;
    }
    /* The diagonal splits the screen: both triangles show. */
    assert_true(count[1] > 0 && count[2] > 0);
    double tol = 16 * 0x1p-24 * 5;
    if (img.depth_mode == SC_RASTER_DEPTH_FIXED24)
        tol += 4 * 25 * (img.far_dist - img.near_dist) / (img.far_dist * img.near_dist) * 0x1p-24;
    print_message("[%s] quad: depth %d bits, near %.9g far %.9g, worst |t - 5| = %.3g (tol %.3g)\n",
                  g_mode_name, img.depth_bits, img.near_dist, img.far_dist, worst, tol);
    assert_true(worst <= tol);
    sc_raster_image_free(&img);
}

/* The tessellated sphere lies between the ball through its vertices and the
 * ball touching its nearest face plane, so the set of covered pixels lies
 * between the pixel sets of those two balls' discs (widened by SNAP_PX). */
static void test_sphere_coverage(void **state)
{
    (void)state;
    const double c[3] = { 0.3, -0.2, 0.1 };
    mesh_buf m = uv_sphere(c, 1.0, 32, 64);
    sc_camera cam = { { 0.3, -0.2, 4.1 }, { 0.3, -0.2, 0.1 }, { 0, 1, 0 }, 40, 128, 96 };
    sc_camera_frame fr;
    assert_int_equal(sc_camera_frame_make(&cam, &fr), SC_OK);
    double rmax = 0, rin = INFINITY;
    for (size_t v = 0; v < m.nv; v++) {
        double q = 0;
        for (int i = 0; i < 3; i++)
            q += (m.pos[3 * v + i] - c[i]) * (m.pos[3 * v + i] - c[i]);
        rmax = fmax(rmax, sqrt(q));
    }
    for (size_t k = 0; k < m.nt; k++) {
        double o[3] = { c[0], c[1], c[2] }, dir[3], t;
        /* Distance to the face plane along its normal: plane_t of a ray
         * from the centre along the normal, times |normal|. */
        const uint32_t *tri = m.idx + 3 * k;
        double e1[3], e2[3];
        for (int i = 0; i < 3; i++) {
            e1[i] = m.pos[3 * tri[1] + i] - m.pos[3 * tri[0] + i];
            e2[i] = m.pos[3 * tri[2] + i] - m.pos[3 * tri[0] + i];
        }
        dir[0] = e1[1] * e2[2] - e1[2] * e2[1];
        dir[1] = e1[2] * e2[0] - e1[0] * e2[2];
        dir[2] = e1[0] * e2[1] - e1[1] * e2[0];
        double nn = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
        if (!(nn > 1e-9))
            continue;            /* degenerate pole triangle */
        t = plane_t(&m, (uint32_t)(k + 1), o, dir);
        rin = fmin(rin, fabs(t) * nn);
    }
    assert_true(rin > 0.99 && rin < rmax && rmax < 1.0001);

    sc_raster_image img;
    render_ok(&m, &cam, &img);
    /* SNAP_PX as an angle at the sphere's distance, in world units. */
    double dist_c = 4.0;
    double margin = SNAP_PX * 2 * fr.half_h / cam.height * dist_c * 1.1;
    size_t covered = 0, must = 0, may = 0;
    for (int y = 0; y < cam.height; y++)
        for (int x = 0; x < cam.width; x++) {
            double d[3], oc[3];
            sc_camera_ray_dir(&cam, &fr, x + 0.5, y + 0.5, d);
            double dd = 0, ocd = 0, ococ = 0;
            for (int i = 0; i < 3; i++) {
                oc[i] = c[i] - cam.eye[i];
                dd += d[i] * d[i];
                ocd += oc[i] * d[i];
                ococ += oc[i] * oc[i];
            }
            double line = sqrt(fmax(0, ococ - ocd * ocd / dd));
            uint32_t id = img.ids[(size_t)y * cam.width + x];
            assert_true(id <= m.nt);
            covered += id != 0;
            if (line <= rin - margin) {
                must++;
                assert_true(id != 0);
            }
            if (line <= rmax + margin)
                may++;
            else
                assert_true(id == 0);
        }
    print_message("[%s] sphere coverage: %zu px covered, bounds [%zu, %zu] (balls r=%.6f, %.6f)\n",
                  g_mode_name, covered, must, may, rin, rmax);
    assert_true(covered >= must && covered <= may);
    assert_true(must > 1000);

    /* Centre pixel: depth between the two balls' entry points. */
    int cx = cam.width / 2, cy = cam.height / 2;
    double d[3];
    sc_camera_ray_dir(&cam, &fr, cx + 0.5, cy + 0.5, d);
    double dd = 0, ocd = 0, ococ = 0;
    for (int i = 0; i < 3; i++) {
        double oc = c[i] - cam.eye[i];
        dd += d[i] * d[i];
        ocd += oc * d[i];
        ococ += oc * oc;
    }
    double t_out = (ocd - sqrt(ocd * ocd - dd * (ococ - rmax * rmax))) / dd;
    double t_in = (ocd - sqrt(ocd * ocd - dd * (ococ - rin * rin))) / dd;
    double tz = img.depth[(size_t)cy * cam.width + cx];
    uint32_t id = img.ids[(size_t)cy * cam.width + cx];
    double tol = depth_tolerance(&m, &cam, &fr, &img, id, cx, cy, t_in);
    print_message("[%s] centre depth %.9f in [%.9f, %.9f] +- %.3g\n", g_mode_name, tz, t_out, t_in, tol);
    assert_true(tz >= t_out - tol && tz <= t_in + tol);
    sc_raster_image_free(&img);
    mesh_free(&m);
}

static void check_agreement(const char *what, const mesh_buf *m, const sc_camera *cam)
{
    sc_raster_image img;
    render_ok(m, cam, &img);
    agreement a = compare_with_brute_force(m, cam, &img);
    report(what, &a);
    assert_true(a.agree * 1000 >= a.pixels * 995);
    assert_int_equal(a.elsewhere, 0);
    assert_int_equal(a.depth_bad, 0);
    sc_raster_image_free(&img);
}

static void test_sphere_vs_brute_force(void **state)
{
    (void)state;
    const double c[3] = { 0.3, -0.2, 0.1 };
    mesh_buf m = uv_sphere(c, 1.0, 24, 48);
    sc_camera cam = { { 2.5, 1.2, 3.4 }, { 0.3, -0.2, 0.1 }, { 0, 1, 0 }, 40, 120, 90 };
    check_agreement("sphere vs brute force", &m, &cam);
    mesh_free(&m);
}

/* Overlapping layers seen obliquely: the depth test must order them. A
 * random camera up vector and a non-square image catch orientation slips. */
static void test_soup_vs_brute_force(void **state)
{
    (void)state;
    sc_rng rng;
    sc_rng_seed(&rng, 6);
    const double origin[3] = { 0, 0, 0 };
    mesh_buf m = layered_soup(&rng, 300, origin, 2.0);
    sc_camera cam = { { 1.1, 0.7, 4.0 }, { 0.05, -0.1, 0 }, { 0.2, 1, 0.1 }, 50, 140, 80 };
    check_agreement("layered soup vs brute force", &m, &cam);
    mesh_free(&m);
}

/* The same soup 3e4 units from the origin (float spacing there is 2^-9):
 * eye-relative double transforms keep the raster as exact as near 0. */
static void test_far_from_origin(void **state)
{
    (void)state;
    sc_rng rng;
    sc_rng_seed(&rng, 7);
    const double origin[3] = { 3e4, -2e4, 1e4 };
    mesh_buf m = layered_soup(&rng, 100, origin, 2.0);
    sc_camera cam = { { 3e4 + 1.1, -2e4 + 0.7, 1e4 + 4.0 }, { 3e4, -2e4, 1e4 },
                      { 0, 1, 0 }, 50, 100, 75 };
    check_agreement("soup at 3e4 vs brute force", &m, &cam);
    mesh_free(&m);
}

/* Large depth range: a small sphere near the camera in front of a huge
 * far-away backdrop. */
static void test_depth_range(void **state)
{
    (void)state;
    const double c[3] = { 0, 0, -2 };
    mesh_buf s = uv_sphere(c, 0.5, 12, 24);
    mesh_buf m = { 0 };
    m.nv = s.nv + 4;
    m.nt = s.nt + 2;
    m.pos = malloc(m.nv * 3 * sizeof *m.pos);
    m.idx = malloc(m.nt * 3 * sizeof *m.idx);
    assert_non_null(m.pos);
    assert_non_null(m.idx);
    memcpy(m.pos, s.pos, s.nv * 3 * sizeof *m.pos);
    memcpy(m.idx, s.idx, s.nt * 3 * sizeof *m.idx);
    float quad[] = { -5e4, -5e4, -1e4, 5e4, -5e4, -1e4, 5e4, 5e4, -1e4, -5e4, 5e4, -1e4 };
    memcpy(m.pos + 3 * s.nv, quad, sizeof quad);
    uint32_t b = (uint32_t)s.nv;
    uint32_t qi[] = { b, b + 1, b + 2, b, b + 2, b + 3 };
    memcpy(m.idx + 3 * s.nt, qi, sizeof qi);
    sc_camera cam = { { 0, 0, 0 }, { 0, 0, -1 }, { 0, 1, 0 }, 45, 96, 96 };
    check_agreement("near sphere + far backdrop vs brute force", &m, &cam);
    mesh_free(&s);
    mesh_free(&m);
}

/* A camera inside the geometry: triangles reach behind the eye and are
 * clipped. */
static void test_camera_inside(void **state)
{
    (void)state;
    const double c[3] = { 0, 0, 0 };
    mesh_buf m = uv_sphere(c, 3.0, 16, 32);
    sc_camera cam = { { 0.4, 0.3, -0.5 }, { 2, 1, 1 }, { 0, 1, 0 }, 70, 96, 64 };
    check_agreement("camera inside a sphere vs brute force", &m, &cam);
    mesh_free(&m);
}

/* Preview: background bytes as asked; a face lit head-on gets its full
 * colour (ambient + diffuse = 1). */
static void test_preview(void **state)
{
    (void)state;
    float pos[] = { -1, -1, 5, 1, -1, 5, 0, 1, 5 };
    uint32_t idx[] = { 0, 1, 2 };
    float col[] = { 0.5f, 0.25f, 1.0f };
    sc_mesh_view mesh = { pos, 3, idx, 1, 0, 0 };
    sc_camera cam = { { 0, 0, 0 }, { 0, 0, 1 }, { 0, 1, 0 }, 60, 32, 32 };
    sc_raster_options o = mode_options();
    o.colors = col;
    o.light_dir[2] = -1;
    o.background[0] = 1;
    o.background[1] = 2;
    o.background[2] = 3;
    sc_raster_image img;
    assert_int_equal(sc_raster_render(&mesh, &cam, &o, &img), SC_OK);
    size_t bg = 0, lit = 0;
    for (size_t p = 0; p < 32 * 32; p++) {
        const uint8_t *c = img.rgb + 3 * p;
        if (img.ids[p] == 0) {
            assert_memory_equal(c, o.background, 3);
            bg++;
        } else {
            assert_int_equal(c[0], 128);
            assert_int_equal(c[1], 64);
            assert_int_equal(c[2], 255);
            lit++;
        }
    }
    assert_true(bg > 0 && lit > 0);
    sc_raster_image_free(&img);
}

static void test_errors(void **state)
{
    (void)state;
    float pos[] = { 0, 0, 5, 1, 0, 5, 0, 1, 5 };
    uint32_t idx[] = { 0, 1, 2 };
    sc_mesh_view mesh = { pos, 3, idx, 1, 0, 0 };
    sc_camera cam = { { 0, 0, 0 }, { 0, 0, 1 }, { 0, 1, 0 }, 60, 16, 16 };
    sc_raster_image img;
    assert_int_equal(sc_raster_render(NULL, &cam, NULL, &img), SC_ERR_INVALID_ARGUMENT);
    assert_true(img.error[0] != '\0' && strchr(img.error, '\n') == NULL);
    assert_null(img.ids);
    assert_int_equal(sc_raster_render(&mesh, NULL, NULL, &img), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_raster_render(&mesh, &cam, NULL, NULL), SC_ERR_INVALID_ARGUMENT);

    uint32_t bad_idx[] = { 0, 1, 3 };
    sc_mesh_view bad = mesh;
    bad.indices = bad_idx;
    assert_int_equal(sc_raster_render(&bad, &cam, NULL, &img), SC_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(img.error, "vertex 3"));

    float nan_pos[] = { 0, 0, 5, NAN, 0, 5, 0, 1, 5 };
    bad = mesh;
    bad.positions = nan_pos;
    assert_int_equal(sc_raster_render(&bad, &cam, NULL, &img), SC_ERR_NONFINITE);
    bad = mesh;
    bad.positions = NULL;
    assert_int_equal(sc_raster_render(&bad, &cam, NULL, &img), SC_ERR_INVALID_ARGUMENT);
    bad = mesh;
    bad.triangle_count = UINT32_MAX;
    assert_int_equal(sc_raster_render(&bad, &cam, NULL, &img), SC_ERR_LIMIT);

    sc_camera c2 = cam;
    c2.fov_y_deg = 180;
    assert_int_equal(sc_raster_render(&mesh, &c2, NULL, &img), SC_ERR_INVALID_ARGUMENT);
    c2 = cam;
    c2.up[1] = 0;
    c2.up[2] = 1;                /* parallel to the view */
    assert_int_equal(sc_raster_render(&mesh, &c2, NULL, &img), SC_ERR_INVALID_ARGUMENT);
    c2 = cam;
    c2.width = 0;
    assert_int_equal(sc_raster_render(&mesh, &c2, NULL, &img), SC_ERR_INVALID_ARGUMENT);
    c2 = cam;
    c2.width = 20000;            /* beyond llvmpipe's 16384 */
    assert_int_equal(sc_raster_render(&mesh, &c2, NULL, &img), SC_ERR_LIMIT);
    print_message("oversized image: %s\n", img.error);

    sc_raster_options o;
    sc_raster_options_default(&o);
    o.depth_mode = SC_RASTER_DEPTH_MODE_COUNT;
    assert_int_equal(sc_raster_render(&mesh, &cam, &o, &img), SC_ERR_INVALID_ARGUMENT);
    sc_raster_options_default(&o);
    o.near_dist = 2;
    o.far_dist = 1;
    assert_int_equal(sc_raster_render(&mesh, &cam, &o, &img), SC_ERR_INVALID_ARGUMENT);

    /* Empty scene: valid, all background. */
    sc_mesh_view empty = { NULL, 0, NULL, 0, 0, 0 };
    assert_int_equal(sc_raster_render(&empty, &cam, NULL, &img), SC_OK);
    for (size_t p = 0; p < 16 * 16; p++) {
        assert_int_equal(img.ids[p], 0);
        assert_true(isinf(img.depth[p]));
    }
    sc_raster_image_free(&img);
    sc_raster_image_free(NULL);

    double dist;
    assert_int_equal(sc_raster_edge_distance(&mesh, &cam, 0, 0, 0, 2, 0, &dist), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_raster_edge_distance(&mesh, &cam, 0, 16, 0, 1, 0, &dist), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_raster_edge_distance(&mesh, &cam, -1, 0, 0, 1, 0, &dist), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_raster_edge_distance(&mesh, &cam, 0, 0, 0, 1, 0, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_raster_edge_distance(&mesh, &cam, 0, 0, 0, 0, 0, &dist), SC_OK);
    assert_true(isinf(dist));
}

/* The edge classifier against sampling: around each pixel centre, rays on a
 * circle of radius 0.49 px (and the centre) are cast at a triangle with
 * sc_camera_ray_dir. If their hit/miss answers differ, an edge crosses that
 * disc, so the distance must be below 0.49; if the distance is below 0.45,
 * a straight edge cuts the 0.49 circle in an arc far longer than the sample
 * spacing, so the answers must differ (for a fat triangle with all vertices
 * far outside the disc, or any vertex inside it). */
static void edge_vs_sampling(const mesh_buf *m, const sc_camera *cam, double near_dist)
{
    sc_camera_frame fr;
    assert_int_equal(sc_camera_frame_make(cam, &fr), SC_OK);
    sc_mesh_view mesh = as_mesh(m);
    size_t near_edge = 0, checked = 0;
    for (int y = 0; y < cam->height; y++)
        for (int x = 0; x < cam->width; x++) {
            double dist;
            assert_int_equal(sc_raster_edge_distance(&mesh, cam, near_dist, x, y, 1, 0, &dist),
                             SC_OK);
            int hits = 0, total = 0;
            for (int k = -1; k < 64; k++) {
                double px = x + 0.5, py = y + 0.5;
                if (k >= 0) {
                    px += 0.49 * cos(2 * SC_PI * k / 64);
                    py += 0.49 * sin(2 * SC_PI * k / 64);
                }
                double d[3];
                sc_camera_ray_dir(cam, &fr, px, py, d);
                /* Clip as the classifier does: only t >= near counts. */
                bf_hit h = brute_force_pixel(m, cam->eye, d);
                hits += h.id != 0 && h.t >= near_dist;
                total++;
            }
            int varies = hits != 0 && hits != total;
            if (varies)
                assert_true(dist < 0.49 + 1e-9);
            if (dist < 0.45 && !varies)
                print_message("pixel %d,%d near %g: dist %.4f but hits %d/%d\n", x, y, near_dist,
                              dist, hits, total);
            if (dist < 0.45)
                assert_true(varies);
            near_edge += dist < 0.5;
            checked++;
        }
    assert_true(near_edge > 0 && near_edge < checked);
}

static void test_edge_distance(void **state)
{
    (void)state;
    /* A fat triangle in view, at an angle to the image plane. */
    float pos[] = { -1.0f, -0.8f, 4.0f, 1.2f, -0.5f, 6.0f, -0.1f, 1.1f, 5.0f };
    uint32_t idx[] = { 0, 1, 2 };
    mesh_buf m = { pos, idx, NULL, 3, 1 };
    sc_camera cam = { { 0, 0, 0 }, { 0, 0, 1 }, { 0, 1, 0 }, 50, 48, 40 };
    edge_vs_sampling(&m, &cam, 0);
    /* One vertex behind the eye: the clipped outline, no near plane. At
     * near 1 the clipped part is a fat trapezoid, its clip edge on screen. */
    float pos2[] = { -1.2f, -1.2f, 4.0f, 1.2f, -1.2f, 4.0f, 0.0f, 1.0f, -1.0f };
    mesh_buf m2 = { pos2, idx, NULL, 3, 1 };
    edge_vs_sampling(&m2, &cam, 0);
    /* ... and with a near plane at 1, whose clip edge is on screen. */
    edge_vs_sampling(&m2, &cam, 1.0);
    /* The distance is the same whichever slot the triangle is passed in. */
    sc_mesh_view mesh = as_mesh(&m);
    double a, b;
    assert_int_equal(sc_raster_edge_distance(&mesh, &cam, 0, 20, 17, 1, 0, &a), SC_OK);
    assert_int_equal(sc_raster_edge_distance(&mesh, &cam, 0, 20, 17, 0, 1, &b), SC_OK);
    assert_true(a == b && isfinite(a));
}

/* A mesh given as float4 vertices and index quads (the fourth entries are
 * poison, never read) rasterizes to exactly the ID buffer of the packed
 * mesh; a stride that is not a multiple of 4 is refused. */
static void test_strided_mesh(void **state)
{
    (void)state;
    float pos[] = { -1, -1, 5, 1, -1, 6, 0, 1, 5, 0.5f, 0.8f, 4, -0.7f, 0.2f, 7 };
    uint32_t idx[] = { 0, 1, 2, 1, 3, 2, 0, 2, 4 };
    float v4[5][4];
    uint32_t i4[3][4];
    for (int i = 0; i < 5; i++) {
        memcpy(v4[i], pos + 3 * i, 3 * sizeof(float));
        v4[i][3] = NAN;
    }
    for (int t = 0; t < 3; t++) {
        memcpy(i4[t], idx + 3 * t, 3 * sizeof(uint32_t));
        i4[t][3] = UINT32_MAX;
    }
    sc_mesh_view packed = { pos, 5, idx, 3, 0, 0 };
    sc_mesh_view strided = { &v4[0][0], 5, &i4[0][0], 3, sizeof v4[0], sizeof i4[0] };
    sc_camera cam = { { 0, 0, 0 }, { 0, 0, 1 }, { 0, 1, 0 }, 60, 48, 40 };
    sc_raster_options o = mode_options();
    sc_raster_image a, b;
    assert_int_equal(sc_raster_render(&packed, &cam, &o, &a), SC_OK);
    assert_int_equal(sc_raster_render(&strided, &cam, &o, &b), SC_OK);
    size_t npix = 48 * 40, covered = 0;
    assert_memory_equal(a.ids, b.ids, npix * sizeof *a.ids);
    for (size_t p = 0; p < npix; p++)
        covered += a.ids[p] != 0;
    assert_true(covered > npix / 50);          /* the comparison saw triangles */
    sc_raster_image_free(&a);
    sc_raster_image_free(&b);
    strided.vertex_stride = 14;
    assert_int_equal(sc_raster_render(&strided, &cam, &o, &b), SC_ERR_INVALID_ARGUMENT);
}

/* Classification on constructed disagreements: a duplicate triangle (the
 * raster keeps the first drawn; the second is a depth tie), an unrelated
 * triangle elsewhere on screen, a miss, and a pixel on an edge. */
static void test_classify(void **state)
{
    (void)state;
    float pos[] = { -1, -1, 5, 1, -1, 5, 0, 1, 5,        /* 0: centre */
                    -1, -1, 5, 1, -1, 5, 0, 1, 5,        /* 1: its duplicate */
                    2.0f, 2.0f, 5, 2.5f, 2.0f, 5, 2.2f, 2.5f, 5 }; /* 2: off to one side */
    uint32_t idx[] = { 0, 1, 2, 3, 4, 5, 6, 7, 8 };
    sc_mesh_view mesh = { pos, 9, idx, 3, 0, 0 };
    sc_camera cam = { { 0, 0, 0 }, { 0, 0, 1 }, { 0, 1, 0 }, 60, 64, 64 };
    sc_raster_options o = mode_options();
    sc_raster_image img;
    assert_int_equal(sc_raster_render(&mesh, &cam, &o, &img), SC_OK);
    int cx = 32, cy = 34;
    assert_int_equal(img.ids[(size_t)cy * 64 + cx], 1);
    sc_raster_diff kind;
    double dist;
    assert_int_equal(sc_raster_classify(&mesh, &cam, &img, cx, cy, 2, &kind, &dist), SC_OK);
    assert_int_equal(kind, SC_RASTER_DIFF_DEPTH_TIE);
    assert_true(dist > 0.5);
    assert_int_equal(sc_raster_classify(&mesh, &cam, &img, cx, cy, 3, &kind, NULL), SC_OK);
    assert_int_equal(kind, SC_RASTER_DIFF_ELSEWHERE);
    assert_int_equal(sc_raster_classify(&mesh, &cam, &img, cx, cy, 0, &kind, NULL), SC_OK);
    assert_int_equal(kind, SC_RASTER_DIFF_ELSEWHERE);
    assert_string_equal(sc_raster_diff_name(kind), "elsewhere");
    /* Agreement is not a disagreement. */
    assert_int_equal(sc_raster_classify(&mesh, &cam, &img, cx, cy, 1, &kind, NULL),
                     SC_ERR_INVALID_ARGUMENT);
    /* Walk left from the centre to the first background pixel x; the edge
     * of triangle 1 passes between the centres of x and x + 1, 1 px apart,
     * so their distances to it sum to at most 1 and one is at an edge. */
    int x = cx;
    while (x > 0 && img.ids[(size_t)cy * 64 + x] != 0)
        x--;
    assert_int_equal(img.ids[(size_t)cy * 64 + x], 0);
    assert_int_equal(img.ids[(size_t)cy * 64 + x + 1], 1);
    sc_raster_diff kind_in;
    double dist_in;
    assert_int_equal(sc_raster_classify(&mesh, &cam, &img, x, cy, 1, &kind, &dist), SC_OK);
    assert_int_equal(sc_raster_classify(&mesh, &cam, &img, x + 1, cy, 0, &kind_in, &dist_in), SC_OK);
    assert_true(dist + dist_in <= 1 + 1e-9);
    assert_int_equal(kind, dist <= 0.5 ? SC_RASTER_DIFF_AT_EDGE : SC_RASTER_DIFF_ELSEWHERE);
    assert_int_equal(kind_in, dist_in <= 0.5 ? SC_RASTER_DIFF_AT_EDGE : SC_RASTER_DIFF_ELSEWHERE);
    assert_true(kind == SC_RASTER_DIFF_AT_EDGE || kind_in == SC_RASTER_DIFF_AT_EDGE);
    assert_int_equal(sc_raster_classify(NULL, &cam, &img, x, cy, 1, &kind, NULL),
                     SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_raster_classify(&mesh, &cam, &img, 64, cy, 1, &kind, NULL),
                     SC_ERR_INVALID_ARGUMENT);
    sc_raster_image_free(&img);
}

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "fixed24") == 0) {
        g_mode = SC_RASTER_DEPTH_FIXED24;
        g_mode_name = "fixed24";
    } else if (argc > 1 && strcmp(argv[1], "float") != 0) {
        fprintf(stderr, "test_raster: unknown depth mode '%s' (float or fixed24)\n", argv[1]);
        return 2;
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_quad_fills_screen),
        cmocka_unit_test(test_strided_mesh),
        cmocka_unit_test(test_sphere_coverage),
        cmocka_unit_test(test_sphere_vs_brute_force),
        cmocka_unit_test(test_soup_vs_brute_force),
        cmocka_unit_test(test_far_from_origin),
        cmocka_unit_test(test_depth_range),
        cmocka_unit_test(test_camera_inside),
        cmocka_unit_test(test_preview),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_edge_distance),
        cmocka_unit_test(test_classify),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
