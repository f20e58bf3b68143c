/* A stream's run of 16 rays into a packet: the rays' fields transposed into
 * the packet's rows, every ray checked as sc_ray_valid, and the run's
 * coherence, in one pass. Streams call it for every run, so each ISA level
 * has its own (stream_gather_x86.h, the same answers); this is the scalar
 * specification.
 *
 * Coherent: the directions, scaled to unit L1 length, lie in a box at most
 * SC_STREAM_SPREAD wide on every axis (camera tiles, a tile's shadow rays to
 * one light). Near: not that, but the origins lie within SC_STREAM_ORIGINS
 * of the scene's extent on every axis (the bounces of one pixel tile: the
 * packet kernel hands the lanes that part ways to the single-ray kernel, and
 * the stream may send the run one by one instead). Random rays pass
 * neither and go one by one, which measured 1.4x faster for them than packets
 * (docs/compare.md, "Packets and streams"). Coherence only chooses the path:
 * packets and single rays give the same hits. */
#ifndef SPHERECULL_TRACE_STREAM_GATHER_H
#define SPHERECULL_TRACE_STREAM_GATHER_H

#include <math.h>
#include <stddef.h>

#include "ray_setup.h"
#include "spherecull/sc_ray.h"

#define SC_STREAM_SPREAD 0.2f
#define SC_STREAM_ORIGINS (1.0f / 16)

/* What stream_gather16 found. */
enum { SC_GATHER_REFUSED = -1, SC_GATHER_INCOHERENT = 0, SC_GATHER_COHERENT = 1, SC_GATHER_NEAR = 2 };

/* Rays 0..15 at ray_stride bytes from rays into p's rows; lo, hi: the
 * scene's box. SC_GATHER_REFUSED if a ray fails sc_ray_valid (p is then
 * partly written), else whether the run is coherent: SC_GATHER_COHERENT
 * for narrow directions, SC_GATHER_NEAR for near origins whose directions
 * are not narrow (a tile's bounces, which the stream may still send one by
 * one: sc_stream_run), SC_GATHER_INCOHERENT for neither. */
static inline int sc_stream_gather16_ref(const char *rays, size_t ray_stride, const float *lo, const float *hi,
                                         sc_ray_packet16 *p)
{
    float dlo[3], dhi[3], olo[3], ohi[3];
    float *org[3] = { p->ox, p->oy, p->oz }, *dir[3] = { p->dx, p->dy, p->dz };
    int refused = 0;
    for (int a = 0; a < 3; a++)
        dlo[a] = olo[a] = INFINITY, dhi[a] = ohi[a] = -INFINITY;
    for (unsigned i = 0; i < 16; i++) {
        const sc_ray *r = (const sc_ray *)(const void *)(rays + i * ray_stride);
        refused |= !sc_ray_valid(r);
        p->tmin[i] = r->tmin, p->tmax[i] = r->tmax;
        const float inv = 1 / (fabsf(r->dir[0]) + fabsf(r->dir[1]) + fabsf(r->dir[2]));
        for (int a = 0; a < 3; a++) {
            const float u = r->dir[a] * inv, o = r->org[a];
            org[a][i] = o, dir[a][i] = r->dir[a];
            dlo[a] = sc_fmin(dlo[a], u), dhi[a] = sc_fmax(dhi[a], u);
            olo[a] = sc_fmin(olo[a], o), ohi[a] = sc_fmax(ohi[a], o);
        }
    }
    if (refused)
        return SC_GATHER_REFUSED;
    int narrow = 1, near = 1;
    for (int a = 0; a < 3; a++) {
        narrow &= dhi[a] - dlo[a] <= SC_STREAM_SPREAD;
        near &= ohi[a] - olo[a] <= SC_STREAM_ORIGINS * (hi[a] - lo[a]);
    }
    return narrow ? SC_GATHER_COHERENT : near ? SC_GATHER_NEAR : SC_GATHER_INCOHERENT;
}

#endif
