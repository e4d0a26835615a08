/* sampler.h - the scene's <sampler> and the random numbers of one path sample (one pixel, one
 * sample index).
 *
 * Two kinds:
 * - independent: every number comes from the hashed PCG32 stream of (seed, pixel, sample)
 *   (math/rng.h), in the order the integrator asks for them;
 * - low discrepancy (ld): a draw names a dimension key (below) and gets 1 to 4 numbers from
 *   Owen-scrambled Sobol patterns (Burley 2020, "Practical Hash-based Owen Scrambling"): the
 *   first two from a 2-D pattern (Sobol dimensions 0 and 1, a (0, 2)-sequence), a third from a
 *   1-D pattern (dimension 0), a fourth pair from a second 2-D pattern. For each pattern the
 *   sample index is first shuffled by a nested uniform (Owen) scramble seeded by (seed, pixel,
 *   key, pattern), then each coordinate is Owen-scrambled with its own seed. So over the first
 *   2^k samples of a pixel each number of a draw falls once in each of the 2^k intervals
 *   [i / 2^k, (i+1) / 2^k), the first two form a (0, k, 2)-net, and different keys, patterns
 *   and pixels are decorrelated. Any number of keys pads the patterns to any path length.
 *
 * Every number is a pure function of (seed, pixel, sample index, key): no state is shared
 * between samples or threads, the image does not depend on the thread count, and the first n
 * samples of an N-sample render are the n-sample render whatever n and N (no power of two
 * needed). Routines that need a variable count of numbers (mask passes, the subsurface
 * prepass) draw from the hashed stream in both kinds. */
#ifndef OP_SAMPLER_H
#define OP_SAMPLER_H

#include <stdint.h>

#include "math/rng.h"
#include "scene/scene_desc.h"

/* independent: plain random numbers; ld: the Owen-scrambled Sobol numbers above (Mitsuba's
 * stratified, ldsampler, sobol, halton and hammersley all map to it). */
typedef enum op_sampler_type { OP_SAMPLER_INDEPENDENT, OP_SAMPLER_LD } op_sampler_type;

typedef struct op_sampler {
    op_sampler_type type;
    int spp;
} op_sampler;

/* Reads a <sampler> (NULL: independent, 4 samples, Mitsuba's default). sampleCount is rounded
 * up to a square for stratified and to a power of two for ldsampler, as Mitsuba does. */
op_status op_sampler_build(op_node *sampler, op_sampler *out, op_error *err);

/* Dimension keys of the integrator's layout: the pixel position (filter offset, 2 numbers),
 * the lens position (a thin lens's aperture, 2 numbers, drawn only by cameras with an aperture),
 * then per path vertex `depth` (0 = the camera ray's hit) the light sample of emitter `sub`
 * (as many as the emitter reads: position 2, then the triangle of an area light 1), the BSDF
 * sample (direction 2, then the lobe choice 1 where there is one; a phase function's direction
 * in a medium), Russian roulette (1) and the free-flight distances of the ray leaving the vertex
 * (channel 1, distance 1; `sub`: the index-matched boundaries passed before). */
enum { OP_DIM_LIGHT = 1, OP_DIM_BSDF = 2, OP_DIM_RR = 3, OP_DIM_MEDIUM = 4 };
#define OP_DIM_PIXEL 0u
#define OP_DIM_LENS 1u
#define OP_DIM(depth, kind, sub) \
    (((uint32_t)(depth) + 1u) << 20 | (uint32_t)(kind) << 16 | ((uint32_t)(sub) & 0xffffu))

/* n (0..4) numbers in [0, 1): point `index` of the scrambled patterns of (seed, key). seed is
 * a per-pixel hash (op_path_sampler_begin). */
void op_ld_point(uint64_t seed, uint32_t key, uint32_t index, int n, float *u);

/* The numbers of one path sample. */
typedef struct op_path_sampler {
    op_rng rng;     /* the hashed stream: every draw when !ld, the variable-count fallback */
    uint64_t seed;  /* per-pixel scramble seed (ld) */
    uint32_t index; /* the sample index within the pixel */
    uint32_t index_rev; /* its bits reversed */
    int ld;
} op_path_sampler;

/* The sampler of sample `sample` of pixel `pixel` under the render's seed. */
op_path_sampler op_path_sampler_begin(int ld, uint64_t seed, uint64_t pixel, uint32_t sample);
/* An independent sampler over an existing stream (the subsurface prepass). */
op_path_sampler op_path_sampler_from_rng(op_rng rng);

/* n (0..4) numbers for dimension key `key`: sample j of m the path sample takes for that key
 * (m = 1 for one; with m > 1, e.g. the direct integrator's emitterSamples, the m numbers of all
 * path samples of the pixel together form one sequence, index * m + j). */
void op_path_sample_k(op_path_sampler *ps, uint32_t key, uint32_t j, uint32_t m, int n, float *u);

static inline void op_path_sample(op_path_sampler *ps, uint32_t key, int n, float *u)
{
    op_path_sample_k(ps, key, 0, 1, n, u);
}

/* One number from the hashed stream (variable-count choices). */
static inline float op_path_random(op_path_sampler *ps)
{
    return op_rng_float(&ps->rng);
}

#endif
