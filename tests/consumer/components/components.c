/* The optional libraries from outside the tree: a procedural scene loaded
 * (scene), rendered and written as PNG (render), the same rays through
 * Embree (embree, when installed) against our tracer, and the raster
 * options (raster, when installed). argv[1]: where to write the PNG. */
#include <math.h>
#include <stdio.h>

#include <spherecull.h>
#include <spherecull/sc_image.h>
#include <spherecull/sc_render.h>
#include <spherecull/sc_scene.h>
#ifdef SC_HAVE_EMBREE
#include <spherecull/sc_embree.h>
#endif
#ifdef SC_HAVE_OSMESA
#include <spherecull/sc_raster.h>
#endif

#define FAIL(...) (fprintf(stderr, "components: " __VA_ARGS__), fputc('\n', stderr), 1)

int main(int argc, char **argv)
{
    if (argc != 2)
        return FAIL("usage: components OUT.png");
    char err[256];
    sc_scene *scene;
    if (sc_scene_load("proc:sphere:2000", NULL, &scene, err, sizeof err) != SC_OK)
        return FAIL("scene: %s", err);
    sc_scene_view v;
    sc_scene_get_view(scene, &v);
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    sc_bvh *bvh;
    if (sc_bvh_build(&v.mesh, &cfg, &bvh) != SC_OK)
        return FAIL("bvh build");

    sc_render_options opt;
    sc_render_options_init(&opt);
    opt.threads = 1;
    v.camera.width = 64, v.camera.height = 48;
    sc_image img;
    if (sc_render(&v, bvh, &opt, &img, NULL) != SC_OK)
        return FAIL("render");
    if (sc_png_write(argv[1], &img, err, sizeof err) != SC_OK)
        return FAIL("png: %s", err);
    sc_image_free(&img);

    /* A ray from outside at the sphere's centre hits it. */
    sc_scene_stats st;
    sc_scene_get_stats(scene, &st);
    float c[3];
    for (int k = 0; k < 3; k++)
        c[k] = (float)(0.5 * (st.bounds_min[k] + st.bounds_max[k]));
    float back = (float)(10 * (st.bounds_max[2] - st.bounds_min[2]));
    sc_ray ray = { { c[0], c[1], c[2] - back }, 0, { 0, 0, 1 }, INFINITY };
    sc_hitrec ours;
    if (sc_trace_closest(bvh, &ray, &ours, NULL) != SC_OK || ours.prim == SC_HITREC_MISS)
        return FAIL("our tracer missed the sphere");
#ifdef SC_HAVE_EMBREE
    sc_checked_mesh cm;
    sc_embree_config ecfg;
    sc_embree_config_default(&ecfg);
    sc_embree *e;
    if (sc_mesh_check(&v.mesh, &cm) != SC_OK || sc_embree_create(&cm, &ecfg, &e) != SC_OK)
        return FAIL("embree create");
    sc_hitrec theirs;
    if (sc_embree_intersect1(e, &ray, 1, &theirs, NULL) != SC_OK || theirs.prim == SC_HITREC_MISS)
        return FAIL("embree missed the sphere");
    if (fabsf(theirs.t - ours.t) > 1e-3f * ours.t)
        return FAIL("embree t %g, ours %g", theirs.t, ours.t);
    sc_embree_destroy(e);
    printf("components: embree ");
#endif
#ifdef SC_HAVE_OSMESA
    sc_raster_options ropt;
    sc_raster_options_default(&ropt);
    printf("raster ");
#endif
    printf("scene render: ok (%zu triangles, hit at t = %g)\n", v.mesh.triangle_count, ours.t);
    sc_bvh_free(bvh);
    sc_scene_free(scene);
    return 0;
}
