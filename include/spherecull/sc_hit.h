/* spherecull — what a traced ray reports.
 *
 * sc_hitrec: t (the ray parameter of the hit), u and v (the barycentric
 * weights of the triangle's second and third vertex: P = (1-u-v) V0 + u V1
 * + v V2), prim (the triangle's index in its mesh), ng (the geometric
 * normal (V1 - V0) x (V2 - V0), not normalised, computed in float from the
 * vertices as given: Embree's Ng), geom (which geometry of the scene: 0 for
 * a BVH over one mesh) and inst (which instance: SC_INVALID_ID when the
 * geometry was not reached through an instance). A miss has prim ==
 * SC_HITREC_MISS, geom == inst == SC_INVALID_ID, ng == 0, t == the ray's
 * tmax and u == v == 0. 36 bytes.
 * sc_hit_packet8/16 hold the same per lane, SoA, aligned like the ray
 * packets (32 and 64 bytes). On the heap: aligned_alloc(32, sizeof
 * (sc_hit_packet8)) (288 bytes, not a multiple of 64) and aligned_alloc(64,
 * sizeof (sc_hit_packet16)) (576 bytes).
 *
 * Threads: plain data; nothing here is shared by the library.
 */
#ifndef SPHERECULL_SC_HIT_H
#define SPHERECULL_SC_HIT_H

#include <stdint.h>

#include "sc_api.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SC_INVALID_ID UINT32_MAX
#define SC_HITREC_MISS SC_INVALID_ID

typedef struct sc_hitrec {
    float t, u, v;
    uint32_t prim;
    float ng[3];
    uint32_t geom, inst;
} sc_hitrec;

typedef struct sc_hit_packet8 {
    SC_ALIGNAS(32) float t[8];
    float u[8], v[8];
    uint32_t prim[8];
    float ng_x[8], ng_y[8], ng_z[8];
    uint32_t geom[8], inst[8];
} sc_hit_packet8;

typedef struct sc_hit_packet16 {
    SC_ALIGNAS(64) float t[16];
    float u[16], v[16];
    uint32_t prim[16];
    float ng_x[16], ng_y[16], ng_z[16];
    uint32_t geom[16], inst[16];
} sc_hit_packet16;

SC_STATIC_ASSERT(sizeof(sc_hitrec) == 36, "sc_hitrec is 36 bytes");
SC_STATIC_ASSERT(sizeof(sc_hit_packet8) == 288, "hit packet8 is 9 rows of 8");
SC_STATIC_ASSERT(sizeof(sc_hit_packet16) == 576, "hit packet16 is 9 rows of 16");

#ifdef __cplusplus
}
#endif
#endif
