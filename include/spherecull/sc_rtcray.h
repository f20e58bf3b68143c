/* spherecull — converting between Embree 3's RTCRay and sc_ray.
 *
 * sc_ray is not an RTCRay: the two share org, tnear/tmin and dir at bytes
 * 0..27, but RTCRay has `time` at byte 28 and `tfar` at byte 32, where sc_ray
 * ends with tmax at byte 28. Casting an RTCRay* to sc_ray* therefore reads
 * time (usually 0) as tmax, and the prefilter then rejects every hit. Convert
 * instead (four stores; the compiler keeps it in registers):
 *
 *   #include <embree3/rtcore_ray.h>      // first: this header needs RTCRay
 *   #include <spherecull/sc_rtcray.h>
 *   ...
 *   sc_ray r = sc_ray_from_rtc(&rayhit->ray);      // e.g. in a user-geometry callback
 *   unsigned live = ~sc_reject8(&r, &blk) & 0xffu;
 *
 * Embree's ray `time` (motion blur) has no counterpart: a prefilter sphere
 * bounds a static triangle. tests/test_rtcray.c checks the offsets stated
 * here against embree3/rtcore_ray.h (built when CMake finds Embree).
 *
 * Threads: inline conversions of the caller's structs; no shared state.
 */
#ifndef SPHERECULL_SC_RTCRAY_H
#define SPHERECULL_SC_RTCRAY_H

#ifndef RTC_VERSION_MAJOR
#error "include <embree3/rtcore_ray.h> (or <embree3/rtcore.h>) before <spherecull/sc_rtcray.h>"
#endif

#include "sc_prefilter.h"

/* The segment [tnear, tfar] of r as an sc_ray. */
static inline sc_ray sc_ray_from_rtc(const struct RTCRay *r)
{
    sc_ray s = { { r->org_x, r->org_y, r->org_z }, r->tnear, { r->dir_x, r->dir_y, r->dir_z }, r->tfar };
    return s;
}

/* An RTCRay for s: time 0, every mask bit, id 0, flags 0. */
static inline struct RTCRay sc_ray_to_rtc(const sc_ray *s)
{
    struct RTCRay r;
    r.org_x = s->org[0], r.org_y = s->org[1], r.org_z = s->org[2], r.tnear = s->tmin;
    r.dir_x = s->dir[0], r.dir_y = s->dir[1], r.dir_z = s->dir[2], r.time = 0;
    r.tfar = s->tmax, r.mask = 0xffffffffu, r.id = 0, r.flags = 0;
    return r;
}

#endif
