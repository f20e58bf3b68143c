/* spherecull — the OSMesa raster reference.
 *
 * The same triangles and the same sc_camera, rasterized offscreen: a second
 * opinion on primary-ray visibility reached by a different road (depth
 * buffer and fill rules instead of ray traversal), and a quick preview.
 *
 * Only built when OSMesa is found (CMake target spherecull_raster, which
 * defines SC_HAVE_OSMESA for its consumers). The core library never depends
 * on it.
 *
 * Pixel conventions are those of sc_camera.h: pixel (x, y), row 0 at the top,
 * sampled at its centre (x + 0.5, y + 0.5). The rasterizer samples at pixel
 * centres too (no multisampling), so the ID of pixel (x, y) is what a ray
 * along sc_camera_ray_dir(cam, frame, x + 0.5, y + 0.5) sees, up to fill
 * rules on edges and depth-buffer precision.
 *
 * Threads: sc_raster_edge_distance and sc_raster_classify are reentrant
 * (CPU only, their arguments only). sc_raster_render creates and makes
 * current its own OSMesa context; call it from one thread at a time, since
 * OSMesa's thread safety is not something this project tests.
 */
#ifndef SPHERECULL_SC_RASTER_H
#define SPHERECULL_SC_RASTER_H

#include "sc_api.h"
#include <stddef.h>
#include <stdint.h>

#include "sc_camera.h"
#include "sc_mesh.h"
#include "sc_status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Meshes are sc_mesh_view (sc_mesh.h), borrowed for the duration of a
 * call; fewer than UINT32_MAX triangles (IDs are index + 1 in 32 bits). */

typedef enum sc_raster_depth_mode {
    /* FLOAT_REVERSED when the GL offers it, else FIXED24. */
    SC_RASTER_DEPTH_AUTO = 0,
    /* A 32-bit float depth buffer holding near/d (glClipControl 0..1, depth
     * test GREATER, no far plane): the same 2^-24 relative resolution at
     * every distance, so huge depth ranges keep their ordering. Needs GL 4.5
     * or ARB_clip_control plus framebuffer objects (llvmpipe has both). */
    SC_RASTER_DEPTH_FLOAT_REVERSED,
    /* GL 1.x only: the default 24-bit fixed-point depth buffer with a tight
     * near/far from the scene bounds. Relative depth resolution degrades as
     * (d / near) * 2^-24. */
    SC_RASTER_DEPTH_FIXED24,
    SC_RASTER_DEPTH_MODE_COUNT
} sc_raster_depth_mode;

typedef struct sc_raster_options {
    sc_raster_depth_mode depth_mode;
    /* Clip distances along the view axis; 0 = derived from the scene:
     * near just below the nearest vertex in front of the camera (a small
     * fraction of far if some triangle reaches behind the eye), far just
     * beyond the farthest vertex. Anything nearer than near is clipped. */
    double near_dist, far_dist;
    /* Direction towards the light, world space; all zero = from the
     * camera's upper right. */
    double light_dir[3];
    uint8_t background[3];       /* preview background, sRGB bytes */
    const float *colors;         /* preview RGB in [0, 1] per triangle; NULL = light grey */
} sc_raster_options;

/* The defaults: AUTO, derived near/far, camera light, dark grey background. */
SC_API void sc_raster_options_default(sc_raster_options *opt);

typedef struct sc_raster_image {
    int width, height;
    /* Row-major, row 0 at the top. 0 = background, else triangle index + 1. */
    uint32_t *ids;
    /* t along the primary ray: the hit point is eye + t * dir with dir from
     * sc_camera_ray_dir (unnormalized, unit component along the view axis),
     * so t is also the eye-space depth. +inf on background pixels. */
    float *depth;
    /* Lit preview, 3 bytes per pixel: each visible triangle flat shaded with
     * its face normal (turned towards the viewer) and one directional light. */
    uint8_t *rgb;
    double near_dist, far_dist;  /* what was used; far is +inf for FLOAT_REVERSED */
    sc_raster_depth_mode depth_mode; /* what was used, never AUTO */
    int depth_bits;
    char error[160];             /* one line describing a failure, else empty */
} sc_raster_image;

/* Renders the mesh as seen by cam. opt may be NULL (defaults). On success the
 * image owns its buffers (sc_raster_image_free); on failure they are NULL and
 * out->error says why.
 *   SC_ERR_INVALID_ARGUMENT  NULL pointers, a bad camera or option, an index
 *                            out of range
 *   SC_ERR_NONFINITE         a NaN or infinite vertex coordinate
 *   SC_ERR_LIMIT             too many triangles, or an image larger than the
 *                            GL allows
 *   SC_ERR_UNSUPPORTED       OSMesa could not create a context, or the
 *                            requested depth mode is not available
 *   SC_ERR_OUT_OF_MEMORY */
SC_API sc_status sc_raster_render(const sc_mesh_view *mesh, const sc_camera *cam,
                                  const sc_raster_options *opt, sc_raster_image *out);

/* Frees the buffers and zeroes the struct; NULL is fine. */
SC_API void sc_raster_image_free(sc_raster_image *img);

/* The half-pixel rule for classifying disagreements: a pixel whose centre
 * lies within this many pixels of a candidate triangle's projected edge is
 * "at an edge", where fill rules and rounding may legitimately differ. */
#define SC_RASTER_EDGE_RADIUS_PX 0.5

/* Screen-space distance, in pixels, from the centre of pixel (x, y) to the
 * nearest projected edge of triangles id_a and id_b (IDs as in the ID buffer:
 * index + 1, 0 = none, skipped). Triangles are clipped at near_dist along the
 * view axis first (pass the image's near_dist; 0 = clip only at the eye), and
 * the clip edge counts as an edge, since the rasterizer has one there too.
 * *dist_px = +inf when neither candidate has a visible part.
 * Needs no GL: also built into spherecull_raster, for the compare commands. */
SC_API sc_status sc_raster_edge_distance(const sc_mesh_view *mesh, const sc_camera *cam,
                                         double near_dist, int x, int y,
                                         uint32_t id_a, uint32_t id_b, double *dist_px);

/* A disagreement between the ID buffer and another source (a tracer) at one
 * pixel, classified:
 *   AT_EDGE    the centre lies within SC_RASTER_EDGE_RADIUS_PX of a projected
 *              edge of either triangle: fill rules and rounding decide there;
 *   DEPTH_TIE  both triangles cover the pixel centre and their depths along
 *              its ray differ by less than SC_RASTER_TIE_REL (relative), or
 *              for FIXED24 by less than 16 depth-buffer quanta: coplanar or
 *              interpenetrating surfaces, where the order is a coin toss;
 *   ELSEWHERE  neither: one of the two is wrong. */
typedef enum sc_raster_diff {
    SC_RASTER_DIFF_AT_EDGE = 0,
    SC_RASTER_DIFF_DEPTH_TIE,
    SC_RASTER_DIFF_ELSEWHERE,
    SC_RASTER_DIFF_COUNT
} sc_raster_diff;

#define SC_RASTER_TIE_REL 0x1p-16

/* "at-edge", "depth-tie", "elsewhere". */
SC_API const char *sc_raster_diff_name(sc_raster_diff kind);

/* Classifies pixel (x, y) where img (rendered from this mesh and camera)
 * holds one ID and other_id (same encoding, 0 = miss) another; edge_px (may
 * be NULL) receives sc_raster_edge_distance's answer. Agreeing IDs are
 * SC_ERR_INVALID_ARGUMENT: there is nothing to classify. */
SC_API sc_status sc_raster_classify(const sc_mesh_view *mesh, const sc_camera *cam,
                                    const sc_raster_image *img, int x, int y, uint32_t other_id,
                                    sc_raster_diff *kind, double *edge_px);

#ifdef __cplusplus
}
#endif
#endif
