/* The renderer's back end over a table tracer, so `render --tracer` and
 * `bench-render` run the path tracer on Embree (or any of our
 * configurations) through the same set-up 'compare' uses. */
#include <string.h>
#if defined(__SSE__)
#include <xmmintrin.h>
#endif

#include "tracer.h"

static sc_status run(const sc_tracer_backend *b, const sc_ray *rays, size_t n, sc_hitrec *hits, uint8_t *occ,
                     int coherent)
{
    const sc_tracer *t = coherent ? &b->coherent : &b->incoherent;
#if defined(__SSE__)
    const unsigned csr = _mm_getcsr();
    if (t->ftz)
        _mm_setcsr(csr | 0x8040);   /* FTZ | DAZ, as Embree asks, only while it runs */
#endif
    sc_status st = sc_tracer_run(t, rays, n, hits, occ, NULL);
#if defined(__SSE__)
    _mm_setcsr(csr);
#endif
    return st;
}

static sc_status closest(void *ctx, const sc_ray *rays, size_t n, sc_hitrec *hits, int coherent)
{
    return run(ctx, rays, n, hits, NULL, coherent);
}

static sc_status occluded(void *ctx, const sc_ray *rays, size_t n, uint8_t *occ, int coherent)
{
    return run(ctx, rays, n, NULL, occ, coherent);
}

void sc_tracer_render_backend(const sc_tracer *t, sc_tracer_backend *b)
{
    b->coherent = *t;
    b->coherent.incoherent = 0;
    b->incoherent = *t;
    b->incoherent.incoherent = 1;
    b->backend.closest = closest;
    b->backend.occluded = occluded;
    b->backend.ctx = b;
}
