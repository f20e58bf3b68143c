/* Scene files with instances (scenes/README.md): the loader keeps each
 * object once and every instance's triangles flattened (the transform in
 * double, rounded once) with the bookkeeping sc_accel needs; bad instance
 * fields are one clear error; a render through the instances (one tree per
 * object, sc_scene_accel) matches the render of the flattened mesh except
 * on a few edge pixels, and its hits are the flattened mesh's triangles. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "spherecull/sc_accel.h"
#include "spherecull/sc_render.h"
#include "spherecull/sc_scene.h"
#include "spherecull/sc_trace.h"

static const char *const SCENE =
    "{ \"width\": 160, \"height\": 100,"
    "  \"camera\": { \"eye\": [0, 2.5, 6], \"target\": [0, 0, 0], \"fov\": 50 },"
    "  \"meshes\": ["
    "    { \"vertices\": [[-4, 0, -4], [4, 0, -4], [4, 0, 4], [-4, 0, 4]], \"faces\": [[0, 3, 2, 1]] },"
    "    { \"file\": \"proc:sphere:2k\", \"scale\": 0.4, \"translate\": [0, 0.5, 0], \"color\": [0.8, 0.2, 0.2],"
    "      \"instances\": { \"grid\": [3, 1, 3], \"spacing\": 1.2, \"rotate_jitter\": 90, \"scale_jitter\": 0.2 } },"
    "    { \"vertices\": [[0, 0, 0], [0.3, 0, 0], [0, 0.3, 0]], \"faces\": [[0, 1, 2]],"
    "      \"instances\": [ { \"translate\": [2, 1, 0] }, { \"rotate\": [0, 90, 0], \"scale\": [1, 2, 1], \"translate\": [-2, 1, 0] } ] }"
    "  ] }";

static sc_scene *load(const char *text, sc_status want, const char *msg)
{
    sc_scene *s = NULL;
    char err[512] = "";
    sc_status st = sc_scene_load_json_text(text, strlen(text), "t.json", NULL, NULL, &s, err, sizeof err);
    if (st != want)
        fail_msg("status %d, want %d: %s", st, want, err);
    if (msg && !strstr(err, msg))
        fail_msg("error '%s' does not say '%s'", err, msg);
    return s;
}

static void test_load(void **state)
{
    (void)state;
    sc_scene *s = load(SCENE, SC_OK, NULL);
    sc_scene_view v;
    assert_int_equal(sc_scene_get_view(s, &v), SC_OK);
    assert_int_equal(v.num_objects, 2);
    assert_int_equal(v.num_instances, 9 + 2);
    const size_t sphere = v.objects[0].triangle_count;
    assert_true(sphere >= 2000);
    assert_int_equal(v.objects[1].triangle_count, 1);
    /* the ground (2), 9 spheres, 2 triangles */
    assert_int_equal(v.mesh.triangle_count, 2 + 9 * sphere + 2);
    for (size_t i = 0; i < v.num_instances; i++) {
        const sc_scene_instance *in = &v.instances[i];
        const sc_mesh_view *o = &v.objects[in->object];
        assert_int_equal(in->object, i < 9 ? 0 : 1);
        assert_true(in->first_triangle + o->triangle_count <= v.mesh.triangle_count);
        /* every triangle of the instance: the object's, placed */
        for (size_t t = 0; t < o->triangle_count; t += 97) {
            const uint32_t *fi = sc_mesh_triangle(&v.mesh, in->first_triangle + t), *oi = sc_mesh_triangle(o, t);
            for (int c = 0; c < 3; c++) {
                const float *p = sc_mesh_vertex(&v.mesh, fi[c]), *q = sc_mesh_vertex(o, oi[c]);
                for (int k = 0; k < 3; k++) {
                    const float *x = in->xfm + 4 * k;
                    const float want =
                        (float)((double)x[0] * q[0] + (double)x[1] * q[1] + (double)x[2] * q[2] + x[3]);
                    assert_true(p[k] == want);
                }
            }
            assert_int_equal(v.mesh_ids[in->first_triangle + t], v.mesh_ids[v.instances[i < 9 ? 0 : 9].first_triangle + t]);
        }
    }
    /* the second placement: rotate 90 about y, scale y by 2, move */
    const float *x = v.instances[10].xfm;
    assert_true(fabsf(x[2] - 1) < 1e-6f && fabsf(x[5] - 2) < 1e-6f && x[3] == -2 && x[7] == 1);
    /* the jittered grid stays centred and spaced */
    assert_true(fabsf(v.instances[0].xfm[3] + 1.2f) < 1e-6f && fabsf(v.instances[8].xfm[11] - 1.2f) < 1e-6f);
    sc_scene_free(s);
}

static void test_bad(void **state)
{
    (void)state;
    static const struct {
        const char *instances;
        sc_status st;
        const char *msg;
    } cases[] = {
        { "5", SC_ERR_PARSE, "instances must be" },
        { "[]", SC_ERR_PARSE, "1.." },
        { "[ 3 ]", SC_ERR_PARSE, "instances[0] must be an object" },
        { "[ { \"scale\": 0 } ]", SC_ERR_PARSE, "scale" },
        { "{ \"spacing\": 1 }", SC_ERR_PARSE, "grid is required" },
        { "{ \"grid\": [0, 1, 1] }", SC_ERR_PARSE, "whole numbers" },
        { "{ \"grid\": [1.5, 1, 1] }", SC_ERR_PARSE, "whole numbers" },
        { "{ \"grid\": [1000, 1000, 10] }", SC_ERR_LIMIT, "more than" },
        { "{ \"grid\": [2, 2, 2], \"scale_jitter\": 2 }", SC_ERR_PARSE, "scale_jitter" },
        { "{ \"grid\": [100, 100, 100] }", SC_ERR_LIMIT, "cap" },
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char text[512];
        snprintf(text, sizeof text, "{ \"meshes\": [ { \"file\": \"proc:sphere:100\", \"instances\": %s } ] }",
                 cases[i].instances);
        sc_scene_options o;
        sc_scene_options_init(&o);
        o.max_triangles = 1000000;
        sc_scene *s = NULL;
        char err[512] = "";
        sc_status st = sc_scene_load_json_text(text, strlen(text), "t.json", NULL, &o, &s, err, sizeof err);
        if (st != cases[i].st || !strstr(err, cases[i].msg) || !strstr(err, "t.json"))
            fail_msg("instances %s: status %d '%s', want %d '%s'", cases[i].instances, st, err, cases[i].st,
                     cases[i].msg);
        assert_null(s);
    }
}

static void test_render_and_hits(void **state)
{
    (void)state;
    sc_scene *s = load(SCENE, SC_OK, NULL);
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    sc_bvh *flat;
    assert_int_equal(sc_bvh_build(&v.mesh, NULL, &flat), SC_OK);
    sc_scene_accel *sa;
    assert_int_equal(sc_scene_accel_build(&v, NULL, &sa), SC_OK);
    sc_render_backend be;
    sc_scene_accel_backend(sa, &be);
    size_t total;
    double secs;
    sc_accel_info wi;
    assert_int_equal(sc_scene_accel_info(sa, &wi, &total, &secs), SC_OK);
    assert_int_equal(wi.instances, 11);
    assert_int_equal(wi.triangles, 2);   /* the ground: the one mesh no instance owns */
    /* rays from above at the scene: the same triangle as the flattened mesh's tree */
    enum { N = 4000 };
    sc_ray *rays = malloc(N * sizeof *rays);
    sc_hitrec *h = malloc(N * sizeof *h);
    uint8_t *occ = malloc(N);
    uint64_t r = 99;
    for (int i = 0; i < N; i++) {
        r = r * 6364136223846793005ull + 1442695040888963407ull;
        float x = (float)((r >> 40) % 1000) / 1000.0f * 5 - 2.5f, z = (float)((r >> 20) % 1000) / 1000.0f * 5 - 2.5f;
        sc_ray ray = { { x, 4, z + 3 }, 0, { 0.05f * x, -1, -0.6f }, INFINITY };
        rays[i] = ray;
    }
    assert_int_equal(be.closest(be.ctx, rays, N, h, 0), SC_OK);
    assert_int_equal(be.occluded(be.ctx, rays, N, occ, 0), SC_OK);
    int same = 0, inst_hits = 0;
    for (int i = 0; i < N; i++) {
        sc_hitrec f;
        assert_int_equal(sc_trace_closest(flat, &rays[i], &f, NULL), SC_OK);
        assert_int_equal(occ[i], h[i].prim != SC_HITREC_MISS);
        assert_int_equal(h[i].inst, SC_INVALID_ID);
        if (h[i].prim == f.prim && fabsf(h[i].t - f.t) <= 1e-5f * f.t)
            same++;
        inst_hits += h[i].prim != SC_HITREC_MISS && h[i].prim >= 2;
    }
    print_message("%d of %d rays report the flattened mesh's triangle (%d on instances)\n", same, N, inst_hits);
    assert_true(inst_hits > N / 8);
    assert_true(same >= N - N / 200);
    /* the image through the instances against the flattened mesh's */
    sc_render_options o;
    sc_render_options_init(&o);
    o.threads = 1;
    sc_image a, b;
    assert_int_equal(sc_render(&v, flat, &o, &a, NULL), SC_OK);
    o.backend = &be;
    assert_int_equal(sc_render(&v, NULL, &o, &b, NULL), SC_OK);
    size_t differ = 0, px = (size_t)a.width * (size_t)a.height;
    for (size_t i = 0; i < px; i++)
        differ += memcmp(a.rgb + 3 * i, b.rgb + 3 * i, 3) != 0;
    print_message("%zu of %zu pixels differ\n", differ, px);
    assert_true(differ <= px / 100);
    sc_image_free(&a);
    sc_image_free(&b);
    free(rays), free(h), free(occ);
    sc_scene_accel_free(sa);
    sc_bvh_free(flat);
    sc_scene_free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_load),
        cmocka_unit_test(test_bad),
        cmocka_unit_test(test_render_and_hits),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
