/* spherecull — what a traced ray reports.
 *
 * sc_hitrec: t (the ray parameter of the hit), u and v (the barycentric
 * weights of the triangle's second and third vertex: P = (1-u-v) V0 + u V1
 * + v V2) and prim, the triangle's index in the build input; prim ==
 * SC_HITREC_MISS for a miss (t, u, v are then unspecified). 16 bytes.
 * sc_hit_packet8/16 hold the same per lane, SoA, aligned like the ray
 * packets (32 and 64 bytes).
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

#define SC_HITREC_MISS UINT32_MAX

typedef struct sc_hitrec {
    float t, u, v;
    uint32_t prim;
} sc_hitrec;

typedef struct sc_hit_packet8 {
    SC_ALIGNAS(32) float t[8];
    float u[8], v[8];
    uint32_t prim[8];
} sc_hit_packet8;

typedef struct sc_hit_packet16 {
    SC_ALIGNAS(64) float t[16];
    float u[16], v[16];
    uint32_t prim[16];
} sc_hit_packet16;

SC_STATIC_ASSERT(sizeof(sc_hitrec) == 16, "sc_hitrec is 16 bytes");
SC_STATIC_ASSERT(sizeof(sc_hit_packet8) == 128, "hit packet8 is two cache lines");
SC_STATIC_ASSERT(sizeof(sc_hit_packet16) == 256, "hit packet16 is four cache lines");

#ifdef __cplusplus
}
#endif
#endif
