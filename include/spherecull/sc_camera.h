/* spherecull — the pinhole camera shared by the tracer and the raster
 * reference, so both see exactly the same rays and pixels.
 *
 * Pixel (x, y), x to the right and y downwards, is sampled at its centre
 * (x + 0.5, y + 0.5). The image plane spans the vertical field of view
 * fov_y_deg; the horizontal extent follows from width / height.
 *
 * Threads: every function here reads only its arguments and writes only
 * its outputs: any number of threads may call them at once.
 */
#ifndef SPHERECULL_SC_CAMERA_H
#define SPHERECULL_SC_CAMERA_H

#include "sc_api.h"
#include "sc_status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sc_camera {
    double eye[3], target[3], up[3];
    double fov_y_deg;            /* vertical field of view, (0, 180) */
    int width, height;           /* pixels, >= 1 */
} sc_camera;

/* Orthonormal basis derived from a camera: right, true up, forward (unit),
 * and the half-extents of the image plane at distance 1. */
typedef struct sc_camera_frame {
    double right[3], up[3], forward[3];
    double half_w, half_h;
} sc_camera_frame;

/* SC_ERR_INVALID_ARGUMENT for a NULL, non-finite or zero-length view, up
 * parallel to the view, fov outside (0, 180), or a non-positive size. */
SC_API sc_status sc_camera_frame_make(const sc_camera *cam, sc_camera_frame *frame);

/* Unnormalized direction through pixel (px, py) (continuous pixel coordinates;
 * use px = x + 0.5 for centres). */
SC_API void sc_camera_ray_dir(const sc_camera *cam, const sc_camera_frame *frame,
                              double px, double py, double dir[3]);

#ifdef __cplusplus
}
#endif
#endif
