/* A small seeded PRNG for procedural scenes and ray sets: SplitMix64. Same
 * sequence on every machine (integer arithmetic only), cheap to seed per item
 * so results never depend on the order or the thread that generates them. */
#ifndef CORVID_SCENE_PRNG_H
#define CORVID_SCENE_PRNG_H

#include <stdint.h>

typedef struct cvs_rng {
    uint64_t state;
} cvs_rng;

static inline uint64_t cvs_mix64(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* An independent stream per (seed, stream): e.g. stream = ray index. */
static inline cvs_rng cvs_rng_make(uint64_t seed, uint64_t stream) {
    cvs_rng r = { cvs_mix64(seed * 0x9E3779B97F4A7C15ull + cvs_mix64(stream + 0x632BE59BD9B4E019ull)) };
    return r;
}

static inline uint64_t cvs_rng_u64(cvs_rng *r) {
    r->state += 0x9E3779B97F4A7C15ull;
    return cvs_mix64(r->state);
}

static inline uint32_t cvs_rng_u32(cvs_rng *r) { return (uint32_t)(cvs_rng_u64(r) >> 32); }

/* Uniform in [0, 1), 24 bits. */
static inline float cvs_rng_float(cvs_rng *r) { return (float)(cvs_rng_u32(r) >> 8) * 0x1.0p-24f; }

static inline float cvs_rng_range(cvs_rng *r, float lo, float hi) { return lo + (hi - lo) * cvs_rng_float(r); }

/* Uniform in [0, n), n >= 1. */
static inline uint32_t cvs_rng_below(cvs_rng *r, uint32_t n) {
    return (uint32_t)(((uint64_t)cvs_rng_u32(r) * n) >> 32);
}

#endif
