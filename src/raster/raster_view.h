/* Private to src/raster: the camera as an eye-space transform, shared by the
 * renderer and the edge classifier so both project identically. Done in
 * double on the CPU, relative to the eye, so that scenes far from the origin
 * lose no precision before the GL's float pipeline sees them. */
#ifndef SPHERECULL_RASTER_VIEW_H
#define SPHERECULL_RASTER_VIEW_H

#include "spherecull/sc_camera.h"

typedef struct sc_raster_view {
    double eye[3];
    sc_camera_frame frame;
    double width, height;
} sc_raster_view;

/* Eye coordinates: e[0] along right, e[1] along up, e[2] = d along the view
 * axis, which is also t along sc_camera_ray_dir (its forward part is 1). */
static inline void sc_raster_to_eye(const sc_raster_view *v, const float p[3], double e[3])
{
    double q[3] = { (double)p[0] - v->eye[0], (double)p[1] - v->eye[1], (double)p[2] - v->eye[2] };
    e[0] = q[0] * v->frame.right[0] + q[1] * v->frame.right[1] + q[2] * v->frame.right[2];
    e[1] = q[0] * v->frame.up[0] + q[1] * v->frame.up[1] + q[2] * v->frame.up[2];
    e[2] = q[0] * v->frame.forward[0] + q[1] * v->frame.forward[1] + q[2] * v->frame.forward[2];
}

/* Continuous pixel coordinates (y down) of an eye-space point with e[2] > 0;
 * the inverse of sc_camera_ray_dir. */
static inline void sc_raster_project(const sc_raster_view *v, const double e[3], double *px, double *py)
{
    *px = (e[0] / (e[2] * v->frame.half_w) + 1) * (0.5 * v->width);
    *py = (1 - e[1] / (e[2] * v->frame.half_h)) * (0.5 * v->height);
}

static inline sc_status sc_raster_view_make(const sc_camera *cam, sc_raster_view *v)
{
    sc_status st = sc_camera_frame_make(cam, &v->frame);
    if (st != SC_OK)
        return st;
    for (int i = 0; i < 3; i++)
        v->eye[i] = cam->eye[i];
    v->width = cam->width;
    v->height = cam->height;
    return SC_OK;
}

#endif
