/* Small deterministic PRNG (splitmix64 seeding xoshiro256**): the same
 * seed gives the same triangles and rays on every machine and tracer. */
#ifndef SPHERECULL_SC_RNG_H
#define SPHERECULL_SC_RNG_H

#include <stdint.h>

typedef struct sc_rng { uint64_t s[4]; } sc_rng;

static inline uint64_t sc_rng_splitmix(uint64_t *x)
{
    uint64_t z = (*x += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static inline void sc_rng_seed(sc_rng *r, uint64_t seed)
{
    for (int i = 0; i < 4; i++)
        r->s[i] = sc_rng_splitmix(&seed);
}

static inline uint64_t sc_rng_next(sc_rng *r)
{
    uint64_t *s = r->s;
    uint64_t result = ((s[1] * 5) << 7 | (s[1] * 5) >> 57) * 9;
    uint64_t t = s[1] << 17;
    s[2] ^= s[0]; s[3] ^= s[1]; s[1] ^= s[2]; s[0] ^= s[3];
    s[2] ^= t;
    s[3] = s[3] << 45 | s[3] >> 19;
    return result;
}

/* Uniform in [0, 1), 53 random bits. */
static inline double sc_rng_uniform(sc_rng *r)
{
    return (double)(sc_rng_next(r) >> 11) * 0x1.0p-53;
}

/* Uniform in [lo, hi). */
static inline double sc_rng_range(sc_rng *r, double lo, double hi)
{
    return lo + (hi - lo) * sc_rng_uniform(r);
}

#endif
