/* spherecull — seeded ray sets shared by every tracer in a comparison.
 *
 * Each generator is a pure function of its inputs and seed: the same mesh,
 * camera and seed give bit-identical rays on every machine, so spherecull,
 * Embree and the exact oracle all see the same sc_ray values. Rays that use
 * a random stream seed it per ray (seed, ray index), so a set does not
 * change when another set is added or generated in a different order.
 *
 * Sets:
 *   primary      one ray per pixel centre of an sc_camera, in 4x4 pixel tiles
 *                (tiles row-major, pixels row-major inside a tile) so that
 *                consecutive groups of 8/16 rays are coherent packets.
 *   shadow       from each primary hit point towards a point light; direction
 *                L - P unnormalised, tmax = 1 (the light itself is not hit).
 *   diffuse      cosine-weighted bounce about the geometric normal at each
 *                primary hit, on the side the primary ray came from.
 *   random       origins uniform in a box, directions uniform on the sphere.
 *   adversarial  a quarter each: aimed at mesh vertices, at midpoints of
 *                edges shared by two triangles, at interior points nearly
 *                parallel to their triangle (grazing, 1e-6..1e-2 rad), and at
 *                edge midpoints from the back side. Vertex and edge rays pass
 *                through their target exactly whenever the float format allows
 *                (flagged per ray in `exact`: O + t D equals the target in
 *                real arithmetic for the t stored in `aim_t`).
 *
 * Hit points for shadow/diffuse rays are offset along the geometric normal by
 * SC_RAYS_OFFSET times the mesh's bounding-box diagonal (towards the side the
 * primary ray came from), so no tracer is asked to resolve self-intersection
 * at t = 0 — every tracer gets the same offset origin.
 *
 * Threads: the generators and mesh checks read only their arguments and
 * write only their outputs (a set's arrays are allocated per call): any
 * number of threads may generate sets at once, also from one mesh. A set
 * is plain memory owned by the caller.
 */
#ifndef SPHERECULL_SC_RAYS_H
#define SPHERECULL_SC_RAYS_H

#include <stddef.h>
#include <stdint.h>

#include "sc_api.h"
#include "sc_camera.h"
#include "sc_hit.h"
#include "sc_mesh.h"
#include "sc_prefilter.h"
#include "sc_status.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SC_RAYS_OFFSET 1e-4

typedef enum sc_rayset_kind {
    SC_RAYS_PRIMARY = 0,
    SC_RAYS_SHADOW,
    SC_RAYS_DIFFUSE,
    SC_RAYS_RANDOM,
    SC_RAYS_ADVERSARIAL,
    SC_RAYS_KIND_COUNT
} sc_rayset_kind;

/* Why an adversarial ray was made. */
typedef enum sc_ray_tag {
    SC_RAY_TAG_NONE = 0,
    SC_RAY_TAG_VERTEX,       /* aimed at a mesh vertex */
    SC_RAY_TAG_EDGE,         /* aimed at the midpoint of a shared edge, front side */
    SC_RAY_TAG_EDGE_BACK,    /* the same from the back side */
    SC_RAY_TAG_GRAZING,      /* nearly parallel to the target triangle */
    SC_RAY_TAG_COUNT
} sc_ray_tag;

typedef struct sc_rayset {
    sc_rayset_kind kind;
    size_t count;
    sc_ray *rays;            /* count rays, 32-byte aligned */
    uint8_t *tag;            /* sc_ray_tag per ray (all NONE except adversarial) */
    uint8_t *exact;          /* 1: the ray passes exactly through its target */
    uint32_t *target;        /* adversarial: vertex / triangle id aimed at; shadow,
                                diffuse: index of the primary ray; else the ray index */
    float *aim_t;            /* adversarial: t at the target point, else 0 */
} sc_rayset;

/* Stable names "primary", "shadow", "diffuse", "random", "adversarial" and
 * "none", "vertex", "edge", "edge-back", "grazing". */
SC_API const char *sc_rayset_kind_name(sc_rayset_kind kind);
SC_API sc_status sc_rayset_kind_from_name(const char *name, sc_rayset_kind *out);
SC_API const char *sc_ray_tag_name(sc_ray_tag tag);

/* Frees the arrays and zeroes the struct; NULL and zeroed sets are fine. */
SC_API void sc_rayset_free(sc_rayset *set);

SC_API sc_status sc_rayset_primary(const sc_camera *cam, sc_rayset *out);

/* from: the set whose hits are given (usually primary); hits: one per ray of
 * from. Misses produce no ray, so out->count <= from->count. */
SC_API sc_status sc_rayset_shadow(const sc_checked_mesh *mesh, const sc_rayset *from,
                                  const sc_hitrec *hits, const float light[3], sc_rayset *out);
SC_API sc_status sc_rayset_diffuse(const sc_checked_mesh *mesh, const sc_rayset *from,
                                   const sc_hitrec *hits, uint64_t seed, sc_rayset *out);

/* lo/hi: the origin box (usually the mesh bounds). count >= 1. */
SC_API sc_status sc_rayset_random(const float lo[3], const float hi[3], size_t count, uint64_t seed,
                                  sc_rayset *out);

/* count >= 1; the mesh needs at least one non-degenerate triangle. */
SC_API sc_status sc_rayset_adversarial(const sc_checked_mesh *mesh, size_t count, uint64_t seed,
                                       sc_rayset *out);

/* A camera that frames the mesh's bounding box from the +z/+y diagonal
 * (used when a scene brings no camera). */
SC_API sc_status sc_camera_for_mesh(const sc_checked_mesh *mesh, int width, int height, sc_camera *cam);

#ifdef __cplusplus
}
#endif
#endif
