/* rng.h - the renderer's random numbers: PCG32 (O'Neill 2014) streams seeded by a hash of
 * (pixel or point index, sample index, pass), so every estimate depends only on what it
 * estimates and never on thread scheduling. Header-only. */
#ifndef OP_MATH_RNG_H
#define OP_MATH_RNG_H

#include <stdint.h>

#include "opaline.h" /* op_hash64 */

typedef struct op_rng {
    uint64_t state, inc;
} op_rng;

static inline uint32_t op_rng_u32(op_rng *r)
{
    uint64_t old = r->state;
    r->state = old * 6364136223846793005ull + r->inc;
    uint32_t xs = (uint32_t)(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = (uint32_t)(old >> 59u);
    return (xs >> rot) | (xs << ((-rot) & 31));
}

/* A stream determined by (a, b, c) alone. */
static inline op_rng op_rng_seed(uint64_t a, uint64_t b, uint64_t c)
{
    op_rng r;
    uint64_t h = op_hash64(a ^ op_hash64(b ^ op_hash64(c)));
    r.state = 0;
    r.inc = (op_hash64(h + 1) << 1u) | 1u;
    op_rng_u32(&r);
    r.state += h;
    op_rng_u32(&r);
    return r;
}

/* Uniform float in [0, 1). */
static inline float op_rng_float(op_rng *r)
{
    return (float)(op_rng_u32(r) >> 8) * 0x1.0p-24f;
}

#endif
