/* sampler.c - the scene's <sampler>, hash-scrambled Sobol points and the per-path-sample
 * numbers (see sampler.h).
 *
 * Everything works on bit-reversed 32-bit words: a number x in [0, 1) with binary digits
 * 0.b1 b2 b3 ... is held as the word whose bit 0 is b1, bit 1 is b2, and so on. An Owen
 * (nested uniform) scramble flips each digit b_i by a random function of the digits before it;
 * in the reversed word that is: bit i changes only as a function of bits 0..i-1, which is what
 * addition, multiplication by an odd number and x ^= x * (even number) do. The same view of
 * the sample index (its bit 0 as the top digit) makes the index shuffle an Owen scramble too:
 * it maps every aligned block of 2^k indices onto an aligned block of 2^k indices, and every
 * such block of the first two Sobol dimensions is a (0, k, 2)-net. */
#include "camera/sampler.h"

#include <math.h>
#include <string.h>

static inline uint32_t reverse_bits(uint32_t x)
{
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
}

/* A nested uniform scramble of a reversed word under the 64-bit seed s: each step changes bit
 * i only as a function of bits below i (so of the value's coarser digits); the seed's low half
 * is added (it alone flips the top digit, bit 0), its high half multiplies. */
static inline uint32_t owen_rev(uint32_t x, uint64_t s)
{
    uint32_t lo = (uint32_t)s, hi = (uint32_t)(s >> 32);
    x += lo;
    x ^= x * 0x6c8e9cf4u;
    x *= hi | 1u;
    x ^= x * 0xb5297a4cu;
    return x;
}

/* Both halves reversed at once: (reverse(lo) << 32) | reverse(hi) of x = (hi << 32) | lo. */
static inline uint64_t reverse_bits2(uint64_t x)
{
    x = ((x >> 1) & 0x5555555555555555ull) | ((x & 0x5555555555555555ull) << 1);
    x = ((x >> 2) & 0x3333333333333333ull) | ((x & 0x3333333333333333ull) << 2);
    x = ((x >> 4) & 0x0f0f0f0f0f0f0f0full) | ((x & 0x0f0f0f0f0f0f0f0full) << 4);
    x = ((x >> 8) & 0x00ff00ff00ff00ffull) | ((x & 0x00ff00ff00ff00ffull) << 8);
    x = ((x >> 16) & 0x0000ffff0000ffffull) | ((x & 0x0000ffff0000ffffull) << 16);
    return (x >> 32) | (x << 32);
}

/* The seed of pattern (pixel seed, key, part): a cheap mix (the scrambles mix further). */
static inline uint64_t pattern_seed(uint64_t seed, uint32_t key, uint32_t part)
{
    uint64_t h = seed ^ ((uint64_t)key * 0x9E3779B97F4A7C15ull) ^ ((uint64_t)part << 61);
    h ^= h >> 31;
    h *= 0xD6E8FEB86659FD93ull;
    return h ^ (h >> 32);
}

/* The seed of dimension d of a pattern seeded h. */
static inline uint64_t dim_seed(uint64_t h, uint64_t d)
{
    uint64_t s = h * (0xA0761D6478BD642Full + 2u * d);
    return s ^ (s >> 29);
}

/* The shuffled sample index from the reversed index: an Owen scramble of the index with its
 * bit 0 as the top digit, so bit k changes only as a function of the bits above it. */
static inline uint32_t shuffle(uint32_t index_rev, uint64_t h)
{
    return reverse_bits(owen_rev(index_rev, h));
}

static inline float to_unit(uint32_t x)
{
    return (float)(x >> 8) * 0x1.0p-24f;
}

/* One Owen-scrambled van der Corput number (Sobol dimension 0): the reversed word of the value
 * is the shuffled index itself. */
static void ld1(uint64_t seed, uint32_t key, uint32_t part, uint32_t index_rev, float *u)
{
    uint64_t h = pattern_seed(seed, key, part);
    uint32_t j = shuffle(index_rev, h);
    u[0] = to_unit(reverse_bits(owen_rev(j, dim_seed(h, 0))));
}

/* One Owen-scrambled point of Sobol dimensions 0 and 1, a (0, 2)-sequence. Dimension 1's
 * generator matrix is Pascal's triangle mod 2: digit q of the value is the XOR of the index
 * bits k whose binary digits contain q's (Lucas' theorem), a superset transform done in five
 * butterfly steps. */
static void ld2(uint64_t seed, uint32_t key, uint32_t part, uint32_t index_rev, float *u)
{
    uint64_t h = pattern_seed(seed, key, part);
    uint32_t j = shuffle(index_rev, h);
    uint32_t y = j;
    y ^= (y >> 1) & 0x55555555u;
    y ^= (y >> 2) & 0x33333333u;
    y ^= (y >> 4) & 0x0f0f0f0fu;
    y ^= (y >> 8) & 0x00ff00ffu;
    y ^= (y >> 16) & 0x0000ffffu;
    uint64_t both = (uint64_t)owen_rev(j, dim_seed(h, 0)) << 32 | owen_rev(y, dim_seed(h, 1));
    both = reverse_bits2(both);
    u[0] = to_unit((uint32_t)both);
    u[1] = to_unit((uint32_t)(both >> 32));
}

static void ld_point(uint64_t seed, uint32_t key, uint32_t index_rev, int n, float *u)
{
    if (n <= 0)
        return;
    if (n == 1) {
        ld1(seed, key, 0, index_rev, u);
        return;
    }
    ld2(seed, key, 0, index_rev, u);
    if (n == 3)
        ld1(seed, key, 1, index_rev, u + 2);
    else if (n >= 4)
        ld2(seed, key, 1, index_rev, u + 2);
}

void op_ld_point(uint64_t seed, uint32_t key, uint32_t index, int n, float *u)
{
    ld_point(seed, key, reverse_bits(index), n, u);
}

op_path_sampler op_path_sampler_begin(int ld, uint64_t seed, uint64_t pixel, uint32_t sample)
{
    op_path_sampler ps;
    ps.rng = op_rng_seed(seed, pixel, sample);
    ps.seed = op_hash64(op_hash64(seed ^ 0x4c4f5744495343ull) ^ pixel);
    ps.index = sample;
    ps.index_rev = reverse_bits(sample);
    ps.ld = ld;
    return ps;
}

op_path_sampler op_path_sampler_from_rng(op_rng rng)
{
    op_path_sampler ps;
    ps.rng = rng;
    ps.seed = 0;
    ps.index = 0;
    ps.index_rev = 0;
    ps.ld = 0;
    return ps;
}

void op_path_sample_k(op_path_sampler *ps, uint32_t key, uint32_t j, uint32_t m, int n, float *u)
{
    if (!ps->ld) {
        for (int d = 0; d < n; d++)
            u[d] = op_rng_float(&ps->rng);
        return;
    }
    ld_point(ps->seed, key, m == 1 ? ps->index_rev : reverse_bits(ps->index * m + j), n, u);
}

op_status op_sampler_build(op_node *sampler, op_sampler *out, op_error *err)
{
    out->type = OP_SAMPLER_INDEPENDENT;
    out->spp = 4;
    if (!sampler)
        return OP_OK;
    sampler->used = 1;
    static const char *const ld[] = {"stratified", "ldsampler",   "sobol",     "halton",
                                     "hammersley", "multijitter", "orthogonal"};
    int known = strcmp(sampler->type, "independent") == 0;
    for (size_t i = 0; i < sizeof ld / sizeof ld[0] && !known; i++)
        if (strcmp(sampler->type, ld[i]) == 0) {
            out->type = OP_SAMPLER_LD;
            known = 1;
        }
    if (!known)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sampler type=\"%s\">: unknown sampler "
                            "(independent, stratified, ldsampler, sobol, halton, hammersley, "
                            "multijitter, orthogonal)",
                            sampler->file, sampler->line, sampler->type);
    long long n;
    GET_OR_FAIL(op_node_int(sampler, "sampleCount", 4, &n, err));
    if (n < 1 || n > (1 << 24))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <sampler>: sampleCount %lld is not in "
                            "1..16777216", sampler->file, sampler->line, n);
    if (strcmp(sampler->type, "stratified") == 0) {
        long long r = (long long)ceil(sqrt((double)n));
        if (r * r != n)
            op_log(OP_LOG_WARN, "%s:%d: <sampler type=\"stratified\">: sampleCount %lld rounded "
                   "up to %lld (a square)", sampler->file, sampler->line, n, r * r);
        n = r * r;
    } else if (strcmp(sampler->type, "ldsampler") == 0) {
        long long p = 1;
        while (p < n)
            p *= 2;
        if (p != n)
            op_log(OP_LOG_WARN, "%s:%d: <sampler type=\"ldsampler\">: sampleCount %lld rounded "
                   "up to %lld (a power of two)", sampler->file, sampler->line, n, p);
        n = p;
    }
    /* Mitsuba's dimension (stratified, ldsampler) and scramble (sobol, halton, hammersley) are
     * accepted and not needed: every dimension is low-discrepancy, scrambled per pixel */
    long long dim, scramble;
    GET_OR_FAIL(op_node_int(sampler, "dimension", 4, &dim, err));
    GET_OR_FAIL(op_node_int(sampler, "scramble", -1, &scramble, err));
    out->spp = (int)n;
    return OP_OK;
}
