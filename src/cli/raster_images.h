/* What 'raster' and 'raster-check' share: the camera options, loading a
 * scene for the raster reference, and the pictures they write (every one
 * through sc_png_write, which writes atomically). */
#ifndef SPHERECULL_CLI_RASTER_IMAGES_H
#define SPHERECULL_CLI_RASTER_IMAGES_H

#include "spherecull/sc_image.h"
#include "spherecull/sc_raster.h"
#include "spherecull/sc_scene.h"

/* Without the raster reference both commands parse their options, then
 * only say so: one error line, exit status 1. */
int raster_unavailable(const char *cmd);

/* The options both commands take, first in their option tables. */
#define SC_RASTER_COMMON_OPTS                                                               \
    { "width", 0, "W", "image width", "the scene's" },                                      \
    { "height", 0, "H", "image height", "the scene's" },                                    \
    { "depth-mode", 0, "MODE", "auto|float|fixed24: the raster depth buffer", "auto" },     \
    { "eye", 0, "X,Y,Z", "camera position", "the scene's" },                                \
    { "target", 0, "X,Y,Z", "point the camera looks at", "the scene's" },                   \
    { "fov", 0, "DEG", "vertical field of view, in (0, 180)", "the scene's" }
enum { SC_RASTER_NCOMMON = 6 };

typedef struct raster_args {
    const char *scene;
    int width, height;           /* 0: the scene's */
    sc_raster_depth_mode depth_mode;
    int has_eye, has_target;
    double eye[3], target[3], fov;   /* camera overrides; fov 0: the scene's */
} raster_args;

/* Option `which` (< SC_RASTER_NCOMMON) or the SCENE operand (which -1):
 * 0, or 2 after an error line. */
int raster_common_option(const char *cmd, int which, const char *val, raster_args *a);

const char *raster_depth_mode_name(sc_raster_depth_mode m);

/* A loaded scene as the raster reference wants it. */
typedef struct loaded {
    sc_scene *scene;
    sc_scene_view view;
    sc_camera cam;
    float *colors;               /* per triangle, from the mesh colours */
    sc_mesh_view mesh;           /* the scene's triangles */
    sc_raster_options opt;
} loaded;

/* 1 on success, else 0 after an error line (as every function below). */
int raster_load(const char *cmd, const raster_args *a, loaded *L);
void raster_unload(loaded *L);
int raster_render(const char *cmd, loaded *L, sc_raster_image *img, double *seconds);

int raster_write_png(const char *cmd, const char *path, const sc_image *im);
/* IDs as 24-bit RGB, lossless: R = bits 0-7, G = 8-15, B = 16-23. */
int raster_write_ids(const char *cmd, const char *path, const sc_raster_image *img, size_t ntri);
/* 1/t between the nearest and farthest visible pixel, near bright. */
int raster_write_depth(const char *cmd, const char *path, const sc_raster_image *img, double *tmin_out,
                       double *tmax_out);
/* Disagreements (cls: 0 agree, 1 + sc_raster_diff) as dots over a dark preview. */
int raster_write_map(const char *cmd, const char *path, const sc_raster_image *img, const uint8_t *cls);
/* Per-pixel sphere tests on a log scale over the preview; *max_out the largest. */
int raster_write_overlay(const char *cmd, const char *path, const sc_raster_image *img, const uint32_t *tests,
                         uint32_t *max_out);
/* "map.png" -> "map-embree.png"; malloc'd, NULL when out of memory. */
char *raster_suffixed(const char *path, const char *name);

#endif
