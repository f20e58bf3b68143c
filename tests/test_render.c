/* Rendering: the silhouette of a tessellated sphere against the analytic
 * projected disc, determinism across thread counts, argument checks. */
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

static sc_scene *sphere_scene(int w, int h, const double eye[3], sc_bvh **bvh, sc_prefilter_mode pf)
{
    sc_scene *s;
    char err[256];
    assert_int_equal(sc_scene_load("proc:sphere:200k", NULL, &s, err, sizeof err), SC_OK);
    sc_camera cam = { .eye = { eye[0], eye[1], eye[2] }, .target = { 0, 0, 0 }, .up = { 0, 1, 0 },
                      .fov_y_deg = 40, .width = w, .height = h };
    assert_int_equal(sc_scene_set_camera(s, &cam), SC_OK);
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    cfg.prefilter = pf;
    assert_int_equal(sc_bvh_build(&v.mesh, &cfg, bvh),
                     SC_OK);
    return s;
}

/* A pixel centre sees the unit sphere iff its ray's angle to the centre is
 * below asin(1/d): an exact test in double, independent of the tracer. */
static long analytic_count(const sc_camera *cam)
{
    sc_camera_frame f;
    assert_int_equal(sc_camera_frame_make(cam, &f), SC_OK);
    double d2 = cam->eye[0] * cam->eye[0] + cam->eye[1] * cam->eye[1] + cam->eye[2] * cam->eye[2];
    long n = 0;
    for (int y = 0; y < cam->height; y++)
        for (int x = 0; x < cam->width; x++) {
            double dir[3];
            sc_camera_ray_dir(cam, &f, x + 0.5, y + 0.5, dir);
            double dd = dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2];
            double b = -(cam->eye[0] * dir[0] + cam->eye[1] * dir[1] + cam->eye[2] * dir[2]);
            /* squared distance of the centre from the line: d2 - b^2/dd */
            n += b > 0 && d2 - b * b / dd < 1.0;
        }
    return n;
}

static void test_sphere_silhouette(void **state)
{
    (void)state;
    const double eyes[][3] = { { 0, 0, 4 }, { 1.2, 0.7, 3.1 } };   /* centred, and off-axis */
    const sc_prefilter_mode modes[] = { SC_PREFILTER_OFF, SC_PREFILTER_MINIMAL };
    for (int e = 0; e < 2; e++)
        for (int m = 0; m < 2; m++) {
            sc_bvh *bvh;
            sc_scene *s = sphere_scene(400, 300, eyes[e], &bvh, modes[m]);
            sc_scene_view v;
            sc_scene_get_view(s, &v);
            sc_render_options o;
            sc_render_options_init(&o);
            o.debug = SC_RENDER_ID;   /* misses black, hits never black */
            sc_image img;
            assert_int_equal(sc_render(&v, bvh, &o, &img, NULL), SC_OK);
            long hits = 0;
            for (size_t i = 0; i < (size_t)img.width * (size_t)img.height; i++)
                hits += img.rgb[3 * i] || img.rgb[3 * i + 1] || img.rgb[3 * i + 2];
            long want = analytic_count(&v.camera);
            double rel = fabs((double)hits - (double)want) / (double)want;
            print_message("eye %d prefilter %d: %ld silhouette pixels, analytic %ld, rel. diff %.2e\n",
                          e, (int)modes[m], hits, want, rel);
            assert_true(want > 20000);
            assert_true(rel < 0.005);
            sc_image_free(&img);
            sc_bvh_free(bvh);
            sc_scene_free(s);
        }
}

static void test_deterministic(void **state)
{
    (void)state;
    sc_scene *s;
    char err[256];
    assert_int_equal(sc_scene_load("proc:terrain:20k", NULL, &s, err, sizeof err), SC_OK);
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    v.camera.width = 96;
    v.camera.height = 64;
    sc_bvh *bvh;
    assert_int_equal(sc_bvh_build(&v.mesh, NULL, &bvh),
                     SC_OK);
    sc_render_options o;
    sc_render_options_init(&o);
    o.ao_samples = 4;
    o.seed = 7;
    sc_image a, b, c;
    o.threads = 1;
    assert_int_equal(sc_render(&v, bvh, &o, &a, NULL), SC_OK);
    o.threads = 2;
    assert_int_equal(sc_render(&v, bvh, &o, &b, NULL), SC_OK);
    assert_memory_equal(a.rgb, b.rgb, 3 * 96 * 64);
    o.seed = 8;
    assert_int_equal(sc_render(&v, bvh, &o, &c, NULL), SC_OK);
    assert_true(memcmp(a.rgb, c.rgb, 3 * 96 * 64) != 0);
    /* Shaded pixels are lit: not all background, not all black. */
    long lit = 0;
    for (size_t i = 0; i < 3 * 96 * 64; i++)
        lit += a.rgb[i] > 40;
    assert_true(lit > 1000);
    sc_image_free(&a);
    sc_image_free(&b);
    sc_image_free(&c);
    sc_render_stats st;
    o.debug = SC_RENDER_HEAT;
    assert_int_equal(sc_render(&v, bvh, &o, &a, &st), SC_OK);
    assert_int_equal(st.primary_rays, 96 * 64);
    assert_true(st.trace.rays >= st.primary_rays);
    sc_image_free(&a);
    /* Bad arguments. */
    assert_int_equal(sc_render(NULL, bvh, &o, &a, NULL), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_render(&v, NULL, &o, &a, NULL), SC_ERR_INVALID_ARGUMENT);
    o.ao_samples = -1;
    assert_int_equal(sc_render(&v, bvh, &o, &a, NULL), SC_ERR_INVALID_ARGUMENT);
    o.ao_samples = 0;
    o.debug = SC_RENDER_DEBUG_COUNT;
    assert_int_equal(sc_render(&v, bvh, &o, &a, NULL), SC_ERR_INVALID_ARGUMENT);
    o.debug = SC_RENDER_SHADED;
    v.camera.fov_y_deg = 0;
    assert_int_equal(sc_render(&v, bvh, &o, &a, NULL), SC_ERR_INVALID_ARGUMENT);
    sc_render_debug d;
    assert_int_equal(sc_render_debug_from_name("heat", &d), SC_OK);
    assert_int_equal(d, SC_RENDER_HEAT);
    assert_int_equal(sc_render_debug_from_name("x", &d), SC_ERR_INVALID_ARGUMENT);
    sc_bvh_free(bvh);
    sc_scene_free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sphere_silhouette),
        cmocka_unit_test(test_deterministic),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
