/* Scene loading: procedural generators against their closed-form geometry,
 * raw-buffer ingestion policy, JSON scenes, the mesh cache. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <unistd.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "spherecull/sc_scene.h"

#ifndef SC_TEST_DATA
#define SC_TEST_DATA "tests/data"
#endif

typedef struct warn_log {
    int count;
    char last[512];
} warn_log;

static void on_warn(void *ctx, const char *msg)
{
    warn_log *w = ctx;
    w->count++;
    snprintf(w->last, sizeof w->last, "%s", msg);
}

static sc_scene *load_ok(const char *spec, warn_log *w)
{
    sc_scene_options o;
    sc_scene_options_init(&o);
    o.warn = on_warn;
    o.warn_ctx = w;
    sc_scene *s = NULL;
    char err[512] = "";
    sc_status st = sc_scene_load(spec, &o, &s, err, sizeof err);
    if (st != SC_OK)
        print_error("%s: %s\n", spec, err);
    assert_int_equal(st, SC_OK);
    assert_non_null(s);
    return s;
}

typedef struct edge { uint32_t a, b; } edge;

static int edge_cmp(const void *x, const void *y)
{
    const edge *p = x, *q = y;
    if (p->a != q->a)
        return p->a < q->a ? -1 : 1;
    return p->b < q->b ? -1 : p->b > q->b;
}

/* The UV sphere must be a closed 2-manifold of genus 0 with every vertex on
 * the unit sphere: each undirected edge used by exactly two triangles, with
 * opposite orientations, and V - E + F = 2. */
static void test_sphere_closed_and_exact(void **state)
{
    (void)state;
    warn_log w = { 0 };
    sc_scene *s = load_ok("proc:sphere:5000", &w);
    sc_scene_view v;
    assert_int_equal(sc_scene_get_view(s, &v), SC_OK);
    size_t st = 3;
    while (4 * st * st - 4 * st < 5000)
        st++;
    assert_int_equal(v.mesh.triangle_count, 4 * st * st - 4 * st);
    for (size_t i = 0; i < v.mesh.vertex_count; i++) {
        const float *p = v.mesh.positions + 3 * i;
        double r = sqrt((double)p[0] * p[0] + (double)p[1] * p[1] + (double)p[2] * p[2]);
        assert_true(fabs(r - 1) < 2e-7);
    }
    size_t ne = 3 * v.mesh.triangle_count;
    edge *e = malloc(ne * sizeof *e), *d = malloc(ne * sizeof *d);
    assert_non_null(e);
    assert_non_null(d);
    for (size_t t = 0; t < v.mesh.triangle_count; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t a = v.mesh.indices[3 * t + k], b = v.mesh.indices[3 * t + (k + 1) % 3];
            assert_int_not_equal(a, b);
            e[3 * t + k] = (edge){ a < b ? a : b, a < b ? b : a };
            d[3 * t + k] = (edge){ a, b };
        }
    qsort(e, ne, sizeof *e, edge_cmp);
    qsort(d, ne, sizeof *d, edge_cmp);
    size_t unique = 0;
    for (size_t i = 0; i < ne; i += 2) {
        assert_true(i + 1 < ne);
        assert_int_equal(edge_cmp(&e[i], &e[i + 1]), 0);
        assert_true(i + 2 >= ne || edge_cmp(&e[i + 1], &e[i + 2]) != 0);
        unique++;
    }
    /* Consistent orientation: no directed edge appears twice. */
    for (size_t i = 0; i + 1 < ne; i++)
        assert_int_not_equal(edge_cmp(&d[i], &d[i + 1]), 0);
    assert_int_equal((long)v.mesh.vertex_count - (long)unique + (long)v.mesh.triangle_count, 2);
    free(e);
    free(d);
    sc_scene_stats ss;
    assert_int_equal(sc_scene_get_stats(s, &ss), SC_OK);
    assert_int_equal(ss.degenerate_triangles, 0);
    assert_int_equal(w.count, 0);
    /* A bare mesh gets a camera looking at it and a light. */
    assert_int_equal(v.num_lights, 1);
    double dist = sqrt(v.camera.eye[0] * v.camera.eye[0] + v.camera.eye[1] * v.camera.eye[1] +
                       v.camera.eye[2] * v.camera.eye[2]);
    assert_true(dist > 1.5);
    sc_scene_free(s);
}

static void test_procedural_counts_and_seed(void **state)
{
    (void)state;
    warn_log w = { 0 };
    const char *specs[] = { "proc:soup:10k", "proc:slivers:3000", "proc:terrain:20000" };
    const size_t want[] = { 10000, 3000, 20000 };
    for (int i = 0; i < 3; i++) {
        sc_scene *a = load_ok(specs[i], &w), *b = load_ok(specs[i], &w);
        sc_scene_view va, vb;
        sc_scene_get_view(a, &va);
        sc_scene_get_view(b, &vb);
        assert_true(va.mesh.triangle_count >= want[i]);
        assert_true(va.mesh.triangle_count < want[i] + want[i] / 50 + 300);
        assert_int_equal(va.mesh.vertex_count, vb.mesh.vertex_count);
        assert_memory_equal(va.mesh.positions, vb.mesh.positions, 3 * sizeof(float) * va.mesh.vertex_count);
        /* Everything stays in the advertised box (with the triangle size). */
        for (size_t k = 0; k < 3 * va.mesh.vertex_count; k++)
            assert_true(fabsf(va.mesh.positions[k]) < 1.25f);
        sc_scene_free(a);
        sc_scene_free(b);
    }
    /* Another seed, other triangles. */
    sc_scene_options o;
    sc_scene_options_init(&o);
    o.seed = 99;
    sc_scene *a, *b;
    char err[256];
    assert_int_equal(sc_scene_load("proc:soup:1000", NULL, &a, err, sizeof err), SC_OK);
    assert_int_equal(sc_scene_load("proc:soup:1000", &o, &b, err, sizeof err), SC_OK);
    sc_scene_view va, vb;
    sc_scene_get_view(a, &va);
    sc_scene_get_view(b, &vb);
    assert_true(memcmp(va.mesh.positions, vb.mesh.positions, 3 * sizeof(float) * va.mesh.vertex_count) != 0);
    sc_scene_free(a);
    sc_scene_free(b);
    /* Slivers are what their name says: min altitude / longest edge tiny. */
    sc_scene *sl = load_ok("proc:slivers:200", &w);
    sc_scene_view vs;
    sc_scene_get_view(sl, &vs);
    for (size_t t = 0; t < vs.mesh.triangle_count; t++) {
        double p[3][3], l2[3], n[3];
        for (int k = 0; k < 3; k++)
            for (int i = 0; i < 3; i++)
                p[k][i] = vs.mesh.positions[3 * vs.mesh.indices[3 * t + k] + i];
        for (int k = 0; k < 3; k++) {
            l2[k] = 0;
            for (int i = 0; i < 3; i++)
                l2[k] += (p[(k + 1) % 3][i] - p[k][i]) * (p[(k + 1) % 3][i] - p[k][i]);
        }
        double a0[3], a1[3];
        for (int i = 0; i < 3; i++) {
            a0[i] = p[1][i] - p[0][i];
            a1[i] = p[2][i] - p[0][i];
        }
        n[0] = a0[1] * a1[2] - a0[2] * a1[1];
        n[1] = a0[2] * a1[0] - a0[0] * a1[2];
        n[2] = a0[0] * a1[1] - a0[1] * a1[0];
        double area2 = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        double lmax2 = fmax(l2[0], fmax(l2[1], l2[2]));
        assert_true(area2 / lmax2 < 3e-4);   /* altitude / longest edge */
    }
    sc_scene_free(sl);
}

static void test_grid_reaches_a_million(void **state)
{
    (void)state;
    warn_log w = { 0 };
    sc_scene *s = load_ok("proc:grid:proc:sphere:10k:1M", &w);
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    size_t st = 3;
    while (4 * st * st - 4 * st < 10000)
        st++;
    size_t per = 4 * st * st - 4 * st, copies = (1000000 + per - 1) / per;
    assert_true(v.mesh.triangle_count >= 1000000);
    assert_int_equal(v.mesh.triangle_count, copies * per);
    assert_int_equal(v.num_meshes, 1);
    for (size_t t = 0; t < v.mesh.triangle_count; t++)
        assert_true(v.mesh.indices[3 * t] < v.mesh.vertex_count && v.mesh_ids[t] == 0);
    /* Copies sit 1.25 model widths apart on a square grid. */
    sc_scene_stats ss, one;
    sc_scene_get_stats(s, &ss);
    sc_scene *single = load_ok("proc:sphere:10k", &w);
    sc_scene_get_stats(single, &one);
    sc_scene_free(single);
    double ex = one.bounds_max[0] - one.bounds_min[0], ez = one.bounds_max[2] - one.bounds_min[2];
    size_t side = 1;
    while (side * side < copies)
        side++;
    double want = 1.25 * fmax(ex, ez) * (double)(side - 1) + ex;
    assert_true(fabs((ss.bounds_max[0] - ss.bounds_min[0]) - want) < 1e-4 * want);
    assert_true(fabs(ss.bytes_per_triangle - (12.0 * (double)ss.vertices + 16.0 * (double)ss.triangles) /
                                                 (double)ss.triangles) < 1e-9);
    sc_scene_free(s);
}

/* Emission from a scene file and from an OBJ material (Ke), inline
 * vertices and faces with the entry's transform. */
static void test_emission_and_inline(void **state)
{
    (void)state;
    const char *text =
        "{\"meshes\": ["
        " {\"vertices\": [[0,0,0],[1,0,0],[1,1,0],[0,1,0]], \"faces\": [[0,1,2,3]], \"translate\": [0, 0, 2],"
        "  \"scale\": 2, \"emission\": [3, 2, 1]},"
        " {\"vertices\": [[0,0,0],[1,0,0],[0,1,0]], \"faces\": [[0,1,2]], \"color\": [0.1, 0.2, 0.3]}],"
        " \"lights\": []}";
    sc_scene *s = NULL;
    char err[512];
    assert_int_equal(sc_scene_load_json_text(text, strlen(text), "t", NULL, NULL, &s, err, sizeof err), SC_OK);
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    assert_int_equal(v.mesh.triangle_count, 3);
    assert_int_equal(v.num_meshes, 2);
    /* The quad split along 0-2, scaled by 2 and moved to z = 2. */
    const uint32_t *t1 = sc_mesh_triangle(&v.mesh, 1);
    const float *p = sc_mesh_vertex(&v.mesh, t1[2]);
    assert_float_equal(p[0], 0.0f, 0);
    assert_float_equal(p[1], 2.0f, 0);
    assert_float_equal(p[2], 2.0f, 0);
    assert_float_equal(v.mesh_emission[0], 3.0f, 0);
    assert_float_equal(v.mesh_emission[1], 2.0f, 0);
    assert_float_equal(v.mesh_emission[2], 1.0f, 0);
    for (int i = 3; i < 6; i++)
        assert_float_equal(v.mesh_emission[i], 0.0f, 0);
    assert_float_equal(v.mesh_colors[4], 0.2f, 0);
    const float bad[3] = { 0, -1, 0 }, ok[3] = { 0.5f, 0, 0 };
    assert_int_equal(sc_scene_set_mesh_emission(s, 2, ok), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_scene_set_mesh_emission(s, 1, bad), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_scene_set_mesh_emission(s, 1, ok), SC_OK);
    sc_scene_get_view(s, &v);
    assert_float_equal(v.mesh_emission[3], 0.5f, 0);
    sc_scene_free(s);

    /* An OBJ whose material has Ke, through the import child and in process. */
    char dir[] = "/tmp/sc_emitXXXXXX";
    assert_non_null(mkdtemp(dir));
    char obj[256], mtl[256];
    snprintf(obj, sizeof obj, "%s/lamp.obj", dir);
    snprintf(mtl, sizeof mtl, "%s/lamp.mtl", dir);
    FILE *f = fopen(mtl, "w");
    assert_non_null(f);
    fputs("newmtl lamp\nKd 0.5 0.5 0.5\nKe 4 5 6\n", f);
    fclose(f);
    f = fopen(obj, "w");
    assert_non_null(f);
    fputs("mtllib lamp.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl lamp\nf 1 2 3\n", f);
    fclose(f);
    for (int in_process = 0; in_process < 2; in_process++) {
        sc_scene_options o;
        sc_scene_options_init(&o);
        o.import_in_process = in_process;
        assert_int_equal(sc_scene_load(obj, &o, &s, err, sizeof err), SC_OK);
        sc_scene_get_view(s, &v);
        assert_int_equal(v.num_meshes, 1);
        assert_float_equal(v.mesh_emission[0], 4.0f, 0);
        assert_float_equal(v.mesh_emission[2], 6.0f, 0);
        sc_scene_free(s);
    }
    remove(obj);
    remove(mtl);
    rmdir(dir);
}

static void test_raw_buffers(void **state)
{
    (void)state;
    warn_log w = { 0 };
    sc_scene_options o;
    sc_scene_options_init(&o);
    o.warn = on_warn;
    o.warn_ctx = &w;
    o.max_triangles = 4;
    sc_scene *s;
    assert_int_equal(sc_scene_create(&o, &s), SC_OK);
    char err[256];
    const float nan = NAN, inf = INFINITY;
    const float pos[] = { 0, 0, 0, 1, 0, 0, 0, 1, 0, nan, 0, 0, 0, 0, inf, 2, 0, 0 };
    const uint32_t idx[] = { 0, 1, 2, 0, 1, 3, 4, 1, 2, 0, 1, 5 };   /* 2 bad, 1 degenerate */
    const uint32_t bad_idx[] = { 0, 1, 6 };
    assert_int_equal(sc_scene_add_mesh(s, pos, 6, bad_idx, 1, NULL, err, sizeof err),
                     SC_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err, "out of range"));
    assert_int_equal(sc_scene_add_mesh(NULL, pos, 6, idx, 4, NULL, err, sizeof err),
                     SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_scene_add_mesh(s, NULL, 6, idx, 4, NULL, err, sizeof err),
                     SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_scene_add_mesh(s, pos, 6, idx, 4, NULL, err, sizeof err), SC_OK);
    sc_scene_stats ss;
    sc_scene_get_stats(s, &ss);
    assert_int_equal(ss.triangles, 2);
    assert_int_equal(ss.dropped_nonfinite, 2);
    assert_int_equal(ss.degenerate_triangles, 1);
    assert_int_equal(w.count, 1);
    assert_non_null(strstr(w.last, "NaN"));
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    for (size_t i = 0; i < 3 * v.mesh.vertex_count; i++)
        assert_true(isfinite(v.mesh.positions[i]));
    /* The cap: 2 + 3 > 4 refuses and leaves the scene as it was. */
    const uint32_t three[] = { 0, 1, 2, 0, 1, 2, 0, 1, 2 };
    assert_int_equal(sc_scene_add_mesh(s, pos, 3, three, 3, NULL, err, sizeof err), SC_ERR_LIMIT);
    assert_non_null(strstr(err, "cap"));
    sc_scene_get_stats(s, &ss);
    assert_int_equal(ss.triangles, 2);
    assert_int_equal(ss.meshes, 1);
    /* Camera and lights are checked too. */
    sc_camera cam = { .eye = { 0, 0, 1 }, .target = { 0, 0, 1 }, .up = { 0, 1, 0 },
                      .fov_y_deg = 40, .width = 10, .height = 10 };
    assert_int_equal(sc_scene_set_camera(s, &cam), SC_ERR_INVALID_ARGUMENT);
    cam.target[2] = 0;
    cam.width = 100000;
    assert_int_equal(sc_scene_set_camera(s, &cam), SC_ERR_LIMIT);
    sc_light l = { .type = SC_LIGHT_DIRECTIONAL, .vec = { 0, 0, 0 }, .color = { 1, 1, 1 } };
    assert_int_equal(sc_scene_add_light(s, &l), SC_ERR_INVALID_ARGUMENT);
    l.vec[1] = -3;
    assert_int_equal(sc_scene_add_light(s, &l), SC_OK);
    sc_scene_get_view(s, &v);
    assert_true(fabsf(v.lights[0].vec[1] + 1) < 1e-7f);
    sc_scene_free(s);
    assert_int_equal(sc_scene_get_view(NULL, &v), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_scene_create(NULL, NULL), SC_ERR_INVALID_ARGUMENT);
}

static void test_json_fixture(void **state)
{
    (void)state;
    warn_log w = { 0 };
    sc_scene *s = load_ok(SC_TEST_DATA "/scene_ok.json", &w);
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    assert_int_equal(w.count, 0);
    assert_int_equal(v.camera.width, 64);
    assert_int_equal(v.camera.height, 48);
    assert_true(v.camera.fov_y_deg == 35);
    assert_true(v.camera.eye[2] == 6 && v.camera.target[1] == 0.5);
    assert_true(v.background[2] == 0.3f && v.ambient == 0.25f);
    /* tetra (4) + sphere + tetra (4) + ground (2); 4 meshes. */
    assert_int_equal(v.num_meshes, 4);
    /* The material colour from tetra.mtl, the overrides, the ground. */
    assert_true(v.mesh_colors[0] == 1.0f && v.mesh_colors[1] == 0.5f && v.mesh_colors[2] == 0.25f);
    assert_true(v.mesh_colors[3] == 0.2f && v.mesh_colors[5] == 0.8f);
    assert_true(v.mesh_colors[6] == 0 && v.mesh_colors[7] == 1);
    /* Transforms: the sphere is scaled 0.5 about (2, 0.5, 0); the second
     * tetra is turned 90 degrees about y: (1,0,0) -> (0,0,-1), then moved. */
    for (size_t t = 0; t < v.mesh.triangle_count; t++) {
        for (int k = 0; k < 3; k++) {
            const float *p = v.mesh.positions + 3 * v.mesh.indices[3 * t + k];
            if (v.mesh_ids[t] == 1) {
                double r = sqrt((p[0] - 2.0) * (p[0] - 2.0) + (p[1] - 0.5) * (p[1] - 0.5) + p[2] * p[2]);
                assert_true(fabs(r - 0.5) < 1e-6);
            } else if (v.mesh_ids[t] == 2) {
                assert_true(p[0] >= -2.0f - 1e-6f && p[0] <= -1.0f + 1e-6f);
                assert_true(p[2] >= -1.0f - 1e-6f && p[2] <= 1e-6f);
            } else if (v.mesh_ids[t] == 3) {
                assert_true(p[1] == 0.0f);   /* ground touches the lowest point */
            }
        }
    }
    assert_int_equal(v.num_lights, 2);
    assert_int_equal(v.lights[0].type, SC_LIGHT_DIRECTIONAL);
    assert_true(v.lights[0].vec[1] == -1.0f && v.lights[0].color[0] == 0.5f);
    assert_int_equal(v.lights[1].type, SC_LIGHT_POINT);
    assert_true(v.lights[1].vec[1] == 5.0f && v.lights[1].color[1] == 10.0f);
    sc_scene_free(s);
}

static void test_cache_prefix(void **state)
{
    (void)state;
    char dir[4096];
    sc_scene_options o;
    sc_scene_options_init(&o);
    o.mesh_cache_dir = SC_TEST_DATA;
    assert_int_equal(sc_scene_mesh_cache_dir(&o, dir, sizeof dir), SC_OK);
    assert_string_equal(dir, SC_TEST_DATA);
    sc_scene *s;
    char err[512];
    assert_int_equal(sc_scene_load("cache:tetra.obj", &o, &s, err, sizeof err), SC_OK);
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    assert_int_equal(v.mesh.triangle_count, 4);
    sc_scene_free(s);
    assert_int_equal(sc_scene_load("cache:absent.off", &o, &s, err, sizeof err), SC_ERR_IO);
    assert_null(s);
    assert_non_null(strstr(err, "fetch-meshes"));
    assert_int_equal(sc_scene_load("cache:", &o, &s, err, sizeof err), SC_ERR_PARSE);
}

/* The CGAL meshes from scripts/fetch-meshes.sh, when the cache is filled. */
static void test_cgal_meshes(void **state)
{
    (void)state;
    char dir[4096], path[4200];
    if (sc_scene_mesh_cache_dir(NULL, dir, sizeof dir) != SC_OK)
        skip();
    snprintf(path, sizeof path, "%s/bunny00.off", dir);
    FILE *f = fopen(path, "rb");
    if (!f)
        skip();
    fclose(f);
    warn_log w = { 0 };
    sc_scene *s = load_ok("cache:bunny00.off", &w);
    sc_scene_stats ss;
    sc_scene_get_stats(s, &ss);
    /* The header of bunny00.off says 37706 vertices, 75408 faces. */
    assert_int_equal(ss.triangles, 75408);
    assert_int_equal(ss.vertices, 37706);
    assert_true(ss.bytes_per_triangle > 21.9 && ss.bytes_per_triangle < 22.1);
    sc_scene_free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sphere_closed_and_exact),
        cmocka_unit_test(test_procedural_counts_and_seed),
        cmocka_unit_test(test_grid_reaches_a_million),
        cmocka_unit_test(test_raw_buffers),
        cmocka_unit_test(test_emission_and_inline),
        cmocka_unit_test(test_json_fixture),
        cmocka_unit_test(test_cache_prefix),
        cmocka_unit_test(test_cgal_meshes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
