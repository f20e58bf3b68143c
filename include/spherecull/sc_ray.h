/* spherecull — a ray, and packets of 8 and 16 rays.
 *
 * A ray is the segment O + t D, tmin <= t <= tmax; D need not be unit
 * length. sc_ray is 32 bytes and is not an Embree RTCRay (that has `time`
 * where this has tmax): from Embree, convert with sc_ray_from_rtc
 * (sc_rtcray.h), never cast.
 *
 * Packets are SoA: lane i of sc_ray_packet8/16 is the ray (ox[i], oy[i],
 * oz[i]) + t (dx[i], dy[i], dz[i]), tmin[i] <= t <= tmax[i]. They are
 * aligned to their vector width (32 and 64 bytes); the calls that take them
 * check it.
 *
 * Threads: plain data; nothing here is shared by the library.
 */
#ifndef SPHERECULL_SC_RAY_H
#define SPHERECULL_SC_RAY_H

#include "sc_api.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sc_ray {
    float org[3];
    float tmin;
    float dir[3];
    float tmax;
} sc_ray;

typedef struct sc_ray_packet8 {
    SC_ALIGNAS(32) float ox[8];
    float oy[8], oz[8], tmin[8], dx[8], dy[8], dz[8], tmax[8];
} sc_ray_packet8;

typedef struct sc_ray_packet16 {
    SC_ALIGNAS(64) float ox[16];
    float oy[16], oz[16], tmin[16], dx[16], dy[16], dz[16], tmax[16];
} sc_ray_packet16;

SC_STATIC_ASSERT(sizeof(sc_ray) == 32, "sc_ray is 32 bytes");
SC_STATIC_ASSERT(sizeof(sc_ray_packet8) == 256, "packet8 is four cache lines");
SC_STATIC_ASSERT(sizeof(sc_ray_packet16) == 512, "packet16 is eight cache lines");

#ifdef __cplusplus
}
#endif
#endif
