/* spherecull — a scene for tracing, the way Embree users build one: several
 * triangle meshes and rigid instances of other scenes under one handle,
 * created, filled, committed, traced and released (RTCScene's life).
 *
 *   sc_accel *tree, *world;
 *   sc_accel_new(NULL, &tree);                              // cfg NULL: sc_bvh_config_default
 *   sc_accel_attach_mesh(tree, &trunk, SC_ACCEL_COPY, NULL);          // geom 0
 *   sc_accel_attach_mesh(tree, &leaves, SC_ACCEL_COPY, NULL);         // geom 1
 *   sc_accel_commit(tree);                                  // one BVH over both meshes
 *   sc_accel_new(NULL, &world);
 *   sc_accel_attach_mesh(world, &ground, SC_ACCEL_SHARED, NULL);      // keep ground's arrays alive
 *   for (i = 0; i < 1000; i++)
 *       sc_accel_attach_instance(world, tree, xfm[i], NULL);          // inst i; retains tree
 *   sc_accel_release(tree);                                 // world still holds it
 *   sc_accel_commit(world);                                 // the top-level tree
 *   sc_accel_closest(world, &ray, &hit, NULL);              // hit.inst, hit.geom, hit.prim
 *   sc_accel_release(world);
 *
 * Two levels: a scene holds meshes and/or instances of scenes that hold
 * meshes only (an instanced scene cannot itself hold instances). Ids are
 * given in attach order from 0: meshes (geom) and instances (inst) count
 * separately. A hit reports the triangle's index in its mesh (prim), the
 * mesh's geom id in the scene that holds it, and the instance (inst,
 * SC_INVALID_ID for the scene's own meshes).
 *
 * Transforms are 3x4 row-major floats, object to world:
 *   world = M obj + T,   xfm = { m00, m01, m02, t0,  m10, m11, m12, t1,  m20, m21, m22, t2 }
 * (Embree's RTC_FORMAT_FLOAT3X4_ROW_MAJOR). M must be invertible.
 *
 * Exactness through instances. A world ray reaches an instance's meshes as
 * the object-space ray o' = M^-1 (o - T), d' = M^-1 d with M^-1 and the
 * products in double, rounded once to float (sc_accel_instance_ray gives
 * it); t is the same parameter in both spaces. The triangle tests are
 * exact (SC_TRI_EXACT) or watertight (SC_TRI_WATERTIGHT) for that rounded
 * ray, so a closed mesh seen through an instance has no holes: a ray from
 * inside it always hits it. Of the instances' hits the smallest t wins (of
 * equal t, the smaller inst, then geom, then prim: the answer does not
 * depend on the order the trees are walked in). hit.ng is the world-space
 * normal: cof(M) ng_object, which is (V1 - V0) x (V2 - V0) of the
 * transformed vertices (mirrors included), computed in float. An instance
 * is looked at only where the world ray meets its world box (the object's
 * box mapped by the transform in double, rounded outward, padded by 2^-20
 * of its extent); a rounded object ray can meet the object's geometry
 * outside that box only by an error that large, i.e. never for transforms
 * with a condition number below about 2^3 and hits within 2^10 box sizes of
 * the origin. An object-space ray the tracer would refuse (an origin beyond
 * 1e18, a zero or non-finite direction after rounding) misses that instance.
 *
 * Meshes (sc_mesh.h views): SC_ACCEL_SHARED keeps the view, so the arrays
 * must live and stay as they are until the scene is released (or until
 * their next commit or refit, for vertices that move); SC_ACCEL_COPY copies
 * them (packed) at attach. Either way vertices may move between frames:
 * change the arrays (shared) or hand new positions to
 * sc_accel_update_vertices, then sc_accel_refit.
 *
 * Refit (deforming meshes, same triangles): sc_accel_refit recomputes the
 * boxes and spheres of the scene's tree bottom-up (sc_bvh_refit) and
 * rebuilds its top level; the answers are those of a fresh build. The tree
 * keeps the shape of the build, so its SAH cost drifts as the mesh deforms;
 * past SC_ACCEL_REBUILD_GROWTH times the cost at its build (or when a
 * refit is impossible: a vertex became non-finite) the refit rebuilds
 * instead, and sc_accel_info counts which it did. The figure is measured in
 * docs/scenes.md.
 *
 * Lifetime: sc_accel_new gives one reference; an instance takes one on the
 * scene it instances; sc_accel_retain / sc_accel_release add and drop one,
 * and the last release frees the scene. Changing a scene (attach, update,
 * commit, refit) while it is instanced by a committed scene requires a
 * commit of that scene before it is traced again, as in Embree.
 *
 * Threads. A committed scene is read-only: any number of threads may trace
 * it at once (each with its own hit and stats). Attach, update, commit,
 * refit and trace of one scene must not overlap; distinct scenes may be
 * built, refitted and released concurrently, and retain/release are atomic,
 * so two scenes may instance one shared scene from two threads.
 * tests/test_threads.c checks this under ThreadSanitizer.
 */
#ifndef SPHERECULL_SC_ACCEL_H
#define SPHERECULL_SC_ACCEL_H

#include <stddef.h>
#include <stdint.h>

#include "sc_api.h"
#include "sc_bvh.h"
#include "sc_hit.h"
#include "sc_mesh.h"
#include "sc_ray.h"
#include "sc_status.h"
#include "sc_trace.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Refit rebuilds once the refitted tree's SAH cost exceeds this multiple of
 * its cost when built (docs/scenes.md: the speed after refits against a
 * fresh build). */
#define SC_ACCEL_REBUILD_GROWTH 1.3

typedef struct sc_accel sc_accel;

enum { SC_ACCEL_SHARED = 0, SC_ACCEL_COPY = 1 };

typedef struct sc_accel_info {
    size_t meshes, instances;
    size_t triangles;            /* in the scene's own meshes */
    size_t instanced_triangles;  /* sum over instances of their scenes' triangles */
    size_t bytes;                /* what this scene owns: its tree, copied meshes, instances and
                                    top-level tree; instanced scenes count in their own info */
    double build_seconds;        /* of the last commit or refit */
    double sah_growth;           /* the tree's SAH cost over its cost when built (1 after a build) */
    unsigned builds, refits;     /* how often commit/refit built the tree afresh, and refitted it */
    int committed;
} sc_accel_info;

/* A new empty scene whose meshes will be built with cfg (NULL: the
 * default; copied). Errors: INVALID_ARGUMENT, OUT_OF_MEMORY. */
SC_API sc_status sc_accel_new(const sc_bvh_config *cfg, sc_accel **out);
SC_API void sc_accel_retain(sc_accel *accel);
SC_API void sc_accel_release(sc_accel *accel);

/* Attaches a triangle mesh (checked as sc_mesh_check checks, except that
 * non-finite vertices are allowed: such triangles are never hit). flags:
 * SC_ACCEL_SHARED or SC_ACCEL_COPY. *geom_id (may be NULL): its id. */
SC_API sc_status sc_accel_attach_mesh(sc_accel *accel, const sc_mesh_view *mesh, unsigned flags,
                                      uint32_t *geom_id);
/* Attaches an instance of a committed scene without instances, with the
 * transform xfm (3x4 row-major, object to world; finite, invertible).
 * Errors: INVALID_ARGUMENT (NULL, the scene itself, an uncommitted scene,
 * a scene with instances, a singular or non-finite transform). */
SC_API sc_status sc_accel_attach_instance(sc_accel *accel, sc_accel *object, const float xfm[12],
                                          uint32_t *inst_id);
/* Moves an instance (commit again before tracing). */
SC_API sc_status sc_accel_set_transform(sc_accel *accel, uint32_t inst_id, const float xfm[12]);
/* New positions for mesh geom_id, same vertex count: copied into a
 * SC_ACCEL_COPY mesh (stride as in sc_mesh_view, 0 = packed), or replacing
 * the view's positions (and stride) of a SC_ACCEL_SHARED one. Then commit
 * or refit. */
SC_API sc_status sc_accel_update_vertices(sc_accel *accel, uint32_t geom_id, const float *positions,
                                          size_t vertex_stride);

/* Builds what changed: the tree over the scene's meshes (one BVH over all
 * of them) and the top level over its instances. Errors: INVALID_ARGUMENT
 * (an instanced scene no longer committed), OUT_OF_MEMORY, those of
 * sc_bvh_build; on an error the scene is left uncommitted. */
SC_API sc_status sc_accel_commit(sc_accel *accel);
/* Refit after vertices moved (see above); a scene never committed, or whose
 * meshes changed in number, is committed instead. */
SC_API sc_status sc_accel_refit(sc_accel *accel);

/* As sc_trace_closest / sc_trace_any (sc_trace.h): the same ray rules,
 * semantics and statistics, over the whole scene. Errors: INVALID_ARGUMENT
 * also for a scene not committed. Through instances an any-hit ray (or
 * packet) first tries the instance that last occluded one on the calling
 * thread (if the ray passes its box), while that keeps paying; the speed
 * and the statistics depend on that, the answer does not. */
SC_API sc_status sc_accel_closest(const sc_accel *accel, const sc_ray *ray, sc_hitrec *hit,
                                  sc_trace_stats *stats);
SC_API sc_status sc_accel_any(const sc_accel *accel, const sc_ray *ray, int *occluded, sc_trace_stats *stats);
/* Packets, as sc_trace_closest8/16 / sc_trace_any8/16 (the same SoA rays,
 * valid lanes, alignment and errors): lane i is bit for bit what
 * sc_accel_closest / sc_accel_any returns for ray i. Through instances the
 * packet walks the top tree together, and the lanes that reach an instance
 * go through its tree as one packet of object-space rays (where the packet
 * is wide next to the instance, lane by lane). A packet without a valid
 * lane is a no-op. Pays for coherent rays (a camera tile,
 * shadow rays of a tile to one light), as sc_trace.h's packets do. */
SC_API sc_status sc_accel_closest8(const sc_accel *accel, const int32_t valid[8], const sc_ray_packet8 *rays,
                                   sc_hit_packet8 *hits, sc_trace_stats *stats);
SC_API sc_status sc_accel_closest16(const sc_accel *accel, const int32_t valid[16], const sc_ray_packet16 *rays,
                                    sc_hit_packet16 *hits, sc_trace_stats *stats);
SC_API sc_status sc_accel_any8(const sc_accel *accel, const int32_t valid[8], const sc_ray_packet8 *rays,
                               int32_t occluded[8], sc_trace_stats *stats);
SC_API sc_status sc_accel_any16(const sc_accel *accel, const int32_t valid[16], const sc_ray_packet16 *rays,
                                int32_t occluded[16], sc_trace_stats *stats);
/* Streams, as sc_trace_closest_n / sc_trace_any_n: coherent runs of 16 as
 * packets (through instances too), the rest ray by ray; the answers of the
 * single-ray calls, bit for bit. */
SC_API sc_status sc_accel_closest_n(const sc_accel *accel, const sc_ray *rays, size_t ray_stride, sc_hitrec *hits,
                                    size_t hit_stride, size_t n, unsigned flags, sc_trace_stats *stats);
SC_API sc_status sc_accel_any_n(const sc_accel *accel, const sc_ray *rays, size_t ray_stride, int32_t *occluded,
                                size_t occluded_stride, size_t n, unsigned flags, sc_trace_stats *stats);

/* The object-space ray of world ray `ray` in instance inst_id, as the
 * tracer computes it (see above). INVALID_ARGUMENT for a bad id or ray. */
SC_API sc_status sc_accel_instance_ray(const sc_accel *accel, uint32_t inst_id, const sc_ray *ray, sc_ray *out);
SC_API sc_status sc_accel_get_info(const sc_accel *accel, sc_accel_info *info);

#ifdef __cplusplus
}
#endif

#endif
