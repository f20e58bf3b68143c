/* Every prefilter mode gives exactly the hits of prefilter off — same primID,
 * same t, same any-hit answer — on every shipped scene (the .json files in scenes/) and on
 * every development mesh in ../shared/scenes when that folder exists.
 *
 * A sphere is only allowed to skip work, never to change an answer, so the
 * comparison is bit for bit. Rays: the scene camera's primary rays
 * (downsampled), random rays through the scene box, and any-hit rays towards
 * the first light from every primary hit.
 */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "common/sc_rng.h"
#include "spherecull/sc_scene.h"
#include "spherecull/sc_trace.h"

enum { PRIMARY_W = 160, RANDOM_RAYS = 20000 };

typedef struct rayset {
    sc_ray *rays;
    size_t count;
} rayset;

static void make_rays(const sc_scene_view *v, rayset *rs)
{
    sc_camera cam = v->camera;
    int w = PRIMARY_W, h = (int)fmax(1, round(PRIMARY_W * (double)cam.height / cam.width));
    cam.width = w, cam.height = h;
    sc_camera_frame f;
    assert_int_equal(sc_camera_frame_make(&cam, &f), SC_OK);
    rs->count = (size_t)w * h + RANDOM_RAYS;
    rs->rays = malloc(sizeof(sc_ray) * rs->count);
    assert_non_null(rs->rays);
    size_t n = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double d[3];
            sc_camera_ray_dir(&cam, &f, x + 0.5, y + 0.5, d);
            sc_ray *r = &rs->rays[n++];
            for (int k = 0; k < 3; k++) {
                r->org[k] = (float)cam.eye[k];
                r->dir[k] = (float)d[k];
            }
            r->tmin = 0, r->tmax = INFINITY;
        }
    float lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
    for (size_t i = 0; i < v->mesh.vertex_count; i++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fminf(lo[k], v->mesh.positions[3 * i + k]);
            hi[k] = fmaxf(hi[k], v->mesh.positions[3 * i + k]);
        }
    sc_rng rng;
    sc_rng_seed(&rng, 42);
    for (int i = 0; i < RANDOM_RAYS; i++) {
        sc_ray *r = &rs->rays[n++];
        double len = 0;
        for (int k = 0; k < 3; k++) {
            r->org[k] = (float)sc_rng_range(&rng, lo[k], hi[k]);
            r->dir[k] = (float)sc_rng_range(&rng, -1, 1);
            len += (double)r->dir[k] * r->dir[k];
        }
        if (len == 0)
            r->dir[0] = 1;
        r->tmin = 0, r->tmax = INFINITY;
    }
}

static sc_bvh *build(const sc_scene_view *v, sc_prefilter_mode mode, int leaf)
{
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    cfg.prefilter = mode;
    cfg.leaf_size = leaf;
    sc_bvh *bvh = NULL;
    assert_int_equal(sc_bvh_build(&v->mesh, &cfg, &bvh), SC_OK);
    return bvh;
}

/* Shadow ray from a hit point towards the first light (or straight up). */
static void shadow_ray(const sc_scene_view *v, const sc_ray *r, const sc_hitrec *h, sc_ray *s)
{
    float p[3], to[3];
    for (int k = 0; k < 3; k++)
        p[k] = r->org[k] + h->t * r->dir[k];
    float tmax = INFINITY;
    if (v->num_lights && v->lights[0].type == SC_LIGHT_POINT) {
        for (int k = 0; k < 3; k++)
            to[k] = v->lights[0].vec[k] - p[k];
        tmax = 0.999f;
    } else if (v->num_lights) {
        for (int k = 0; k < 3; k++)
            to[k] = -v->lights[0].vec[k];
    } else {
        to[0] = 0, to[1] = 1, to[2] = 0;
    }
    for (int k = 0; k < 3; k++) {
        s->org[k] = p[k];
        s->dir[k] = to[k];
    }
    s->tmin = 1e-4f * (1 + fabsf(h->t));
    s->tmax = tmax;
}

static void check_scene(const char *spec)
{
    sc_scene_options o;
    sc_scene_options_init(&o);
    sc_scene *scene = NULL;
    char err[512];
    sc_status st = sc_scene_load(spec, &o, &scene, err, sizeof err);
    if (st != SC_OK) {
        /* Shipped scenes need scripts/fetch-meshes.sh; say so rather than pass silently. */
        print_message("skip %s: %s\n", spec, err);
        return;
    }
    sc_scene_view v;
    assert_int_equal(sc_scene_get_view(scene, &v), SC_OK);
    rayset rs;
    make_rays(&v, &rs);
    sc_hitrec *ref = malloc(sizeof(sc_hitrec) * rs.count);
    int *ref_occ = malloc(sizeof(int) * rs.count);
    assert_non_null(ref);
    assert_non_null(ref_occ);
    static const int leaves[] = { 4, 16 };
    long compared = 0, mismatches = 0;
    for (size_t li = 0; li < sizeof leaves / sizeof leaves[0]; li++) {
        sc_bvh *off = build(&v, SC_PREFILTER_OFF, leaves[li]);
        for (size_t i = 0; i < rs.count; i++) {
            assert_int_equal(sc_trace_closest(off, &rs.rays[i], &ref[i], NULL), SC_OK);
            ref_occ[i] = -1;
            if (ref[i].prim != SC_HITREC_MISS) {
                sc_ray s;
                shadow_ray(&v, &rs.rays[i], &ref[i], &s);
                assert_int_equal(sc_trace_any(off, &s, &ref_occ[i], NULL), SC_OK);
            }
        }
        for (int m = SC_PREFILTER_CIRCUM; m < SC_PREFILTER_MODE_COUNT; m++) {
            sc_bvh *bvh = build(&v, (sc_prefilter_mode)m, leaves[li]);
            for (size_t i = 0; i < rs.count; i++) {
                sc_hitrec h;
                assert_int_equal(sc_trace_closest(bvh, &rs.rays[i], &h, NULL), SC_OK);
                int same = h.prim == ref[i].prim &&
                           (h.prim == SC_HITREC_MISS || memcmp(&h.t, &ref[i].t, sizeof h.t) == 0);
                if (same && ref_occ[i] >= 0) {
                    sc_ray s;
                    int occ = -1;
                    shadow_ray(&v, &rs.rays[i], &ref[i], &s);
                    assert_int_equal(sc_trace_any(bvh, &s, &occ, NULL), SC_OK);
                    same = occ == ref_occ[i];
                }
                compared++;
                if (!same && mismatches++ < 5)
                    print_error("%s leaf %d mode %d ray %zu: prim %u t %a vs off prim %u t %a\n", spec,
                                leaves[li], m, i, h.prim, h.t, ref[i].prim, ref[i].t);
            }
            sc_bvh_free(bvh);
        }
        sc_bvh_free(off);
    }
    print_message("%s: %zu triangles, %ld ray answers compared with prefilter off, %ld differ\n",
                  spec, v.mesh.triangle_count, compared, mismatches);
    assert_int_equal(mismatches, 0);
    free(ref);
    free(ref_occ);
    free(rs.rays);
    sc_scene_free(scene);
}

static void check_folder(const char *dir, const char *const *suffixes)
{
    DIR *d = opendir(dir);
    if (!d) {
        print_message("skip: no folder %s\n", dir);
        return;
    }
    char *names[64];
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) && n < 64) {
        size_t len = strlen(e->d_name);
        for (const char *const *s = suffixes; *s; s++) {
            size_t sl = strlen(*s);
            if (len > sl && strcmp(e->d_name + len - sl, *s) == 0) {
                names[n] = malloc(strlen(dir) + len + 2);
                sprintf(names[n++], "%s/%s", dir, e->d_name);
                break;
            }
        }
    }
    closedir(d);
    for (int i = 0; i < n; i++) {
        check_scene(names[i]);
        free(names[i]);
    }
}

static void test_shipped_scenes(void **state)
{
    (void)state;
    static const char *const json[] = { ".json", NULL };
    check_folder(SC_SCENES_DIR, json);
}

static void test_shared_scenes(void **state)
{
    (void)state;
    const char *dir = getenv("SC_TEST_SCENES");
    static const char *const meshes[] = { ".obj", ".ply", ".stl", ".3ds", ".glb", NULL };
    if (!dir) {
        print_message("skip: SC_TEST_SCENES not set\n");
        return;
    }
    check_folder(dir, meshes);
}

static void test_procedural_scenes(void **state)
{
    (void)state;
    check_scene("proc:sphere:20000");
    check_scene("proc:slivers:20000");
    check_scene("proc:soup:20000");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_procedural_scenes),
        cmocka_unit_test(test_shipped_scenes),
        cmocka_unit_test(test_shared_scenes),
    };
    return cmocka_run_group_tests_name("scene_modes", tests, NULL, NULL);
}
