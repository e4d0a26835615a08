/* sampler.c - hash-scrambled Sobol points and the per-path-sample numbers (see sampler.h).
 *
 * Everything works on bit-reversed 32-bit words: a number x in [0, 1) with binary digits
 * 0.b1 b2 b3 ... is held as the word whose bit 0 is b1, bit 1 is b2, and so on. An Owen
 * (nested uniform) scramble flips each digit b_i by a random function of the digits before it;
 * in the reversed word that is: bit i changes only as a function of bits 0..i-1, which is what
 * addition, multiplication by an odd number and x ^= x * (even number) do. The same view of
 * the sample index (its bit 0 as the top digit) makes the index shuffle an Owen scramble too:
 * it maps every aligned block of 2^k indices onto an aligned block of 2^k indices, and every
 * such block of a Sobol sequence is a (t, k, s)-net. */
#include "sampler.h"

/* Sobol generator matrices of the first four dimensions (dimension 0 the van der Corput
 * sequence, then the primitive polynomials x + 1, x^2 + x + 1, x^3 + x + 1 with initial
 * direction numbers 1; 1, 3; 1, 3, 1 as in Joe and Kuo's table), reversed: row b is the
 * reversed direction number of index bit 31 - b, so XOR-ing the rows of the set bits of a
 * reversed index gives the reversed Sobol coordinates (tests/c/test_sampler.c checks the
 * stratification and net properties that follow from it). */
static const uint32_t sobol_rev[32][4] = {
    {0x80000000u, 0xffffffffu, 0xaaaa00a3u, 0xc900a00au},
    {0x40000000u, 0x55555555u, 0x77770071u, 0x45004004u},
    {0x20000000u, 0x33333333u, 0x3939003au, 0x2e003003u},
    {0x10000000u, 0x11111111u, 0x16160017u, 0x1f001001u},
    {0x08000000u, 0x0f0f0f0fu, 0x09a30009u, 0x0a000b6du},
    {0x04000000u, 0x05050505u, 0x06710006u, 0x0400079eu},
    {0x02000000u, 0x03030303u, 0x033a0003u, 0x030002a7u},
    {0x01000000u, 0x01010101u, 0x01170001u, 0x0100011au},
    {0x00800000u, 0x00ff00ffu, 0x00a3aaaau, 0x00b6dba4u},
    {0x00400000u, 0x00550055u, 0x00717777u, 0x0079e7dbu},
    {0x00200000u, 0x00330033u, 0x003a3939u, 0x002a7289u},
    {0x00100000u, 0x00110011u, 0x00171616u, 0x0011a105u},
    {0x00080000u, 0x000f000fu, 0x000909a3u, 0x000c9baeu},
    {0x00040000u, 0x00050005u, 0x00060671u, 0x000457dfu},
    {0x00020000u, 0x00030003u, 0x0003033au, 0x0002e28au},
    {0x00010000u, 0x00010001u, 0x00010117u, 0x0001f104u},
    {0x00008000u, 0x0000ffffu, 0x0000aa09u, 0x0000a0c3u},
    {0x00004000u, 0x00005555u, 0x00007706u, 0x00004041u},
    {0x00002000u, 0x00003333u, 0x00003903u, 0x0000302du},
    {0x00001000u, 0x00001111u, 0x00001601u, 0x0000101eu},
    {0x00000800u, 0x00000f0fu, 0x000009aau, 0x00000b67u},
    {0x00000400u, 0x00000505u, 0x00000677u, 0x0000079au},
    {0x00000200u, 0x00000303u, 0x00000339u, 0x000002a4u},
    {0x00000100u, 0x00000101u, 0x00000116u, 0x0000011bu},
    {0x00000080u, 0x000000ffu, 0x000000a3u, 0x000000c9u},
    {0x00000040u, 0x00000055u, 0x00000071u, 0x00000045u},
    {0x00000020u, 0x00000033u, 0x0000003au, 0x0000002eu},
    {0x00000010u, 0x00000011u, 0x00000017u, 0x0000001fu},
    {0x00000008u, 0x0000000fu, 0x00000009u, 0x0000000au},
    {0x00000004u, 0x00000005u, 0x00000006u, 0x00000004u},
    {0x00000002u, 0x00000003u, 0x00000003u, 0x00000003u},
    {0x00000001u, 0x00000001u, 0x00000001u, 0x00000001u},
};

static inline uint32_t reverse_bits(uint32_t x)
{
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
}

static inline int lowest_bit(uint32_t x) /* x != 0 */
{
#if defined(__GNUC__) || defined(__clang__)
    return __builtin_ctz(x);
#else
    int b = 0;
    while (!(x & 1u)) {
        x >>= 1;
        b++;
    }
    return b;
#endif
}

/* A nested uniform scramble of a reversed word under the 64-bit seed s: each step changes bit
 * i only as a function of bits below i (so of the value's coarser digits), and both halves of
 * the seed reach every bit, the top digit (bit 0) included. */
static inline uint32_t owen_rev(uint32_t x, uint64_t s)
{
    uint32_t lo = (uint32_t)s, hi = (uint32_t)(s >> 32);
    x += lo;
    x ^= x * 0x6c8e9cf4u;
    x *= hi | 1u;
    x ^= x * 0xb5297a4cu;
    x += hi;
    x ^= x * 0x1b56c4e8u;
    x *= (lo >> 7) | 1u;
    x ^= x * 0x68e31da4u;
    return x;
}

void op_ld_point(uint64_t seed, uint32_t key, uint32_t index, int n, float *u)
{
    uint64_t h = op_hash64(seed ^ ((uint64_t)key * 0x9E3779B97F4A7C15ull));
    uint32_t j = owen_rev(reverse_bits(index), h); /* the shuffled index, reversed */
    uint32_t v[4] = {0, 0, 0, 0};
    for (uint32_t r = j; r; r &= r - 1u) {
        const uint32_t *row = sobol_rev[lowest_bit(r)];
        v[0] ^= row[0];
        v[1] ^= row[1];
        v[2] ^= row[2];
        v[3] ^= row[3];
    }
    for (int d = 0; d < n && d < 4; d++) {
        uint32_t x = reverse_bits(owen_rev(v[d], op_hash64(h + (uint64_t)d + 1u)));
        u[d] = (float)(x >> 8) * 0x1.0p-24f;
    }
}

op_path_sampler op_path_sampler_begin(int ld, uint64_t seed, uint64_t pixel, uint32_t sample)
{
    op_path_sampler ps;
    ps.rng = op_rng_seed(seed, pixel, sample);
    ps.seed = op_hash64(op_hash64(seed ^ 0x4c4f5744495343ull) ^ pixel);
    ps.index = sample;
    ps.ld = ld;
    return ps;
}

op_path_sampler op_path_sampler_from_rng(op_rng rng)
{
    op_path_sampler ps;
    ps.rng = rng;
    ps.seed = 0;
    ps.index = 0;
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
    op_ld_point(ps->seed, key, ps->index * m + j, n, u);
}
