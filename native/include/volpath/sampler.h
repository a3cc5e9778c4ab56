// Random numbers: PCG32 (O'Neill 2014) or an Owen-scrambled Sobol sequence, seeded by
// hashing (seed, pixel, sample index), so every pixel sample replays the same numbers on
// any thread, in any order.
#pragma once

#include "math.h"

namespace volpath {

// 64-bit finaliser (splitmix64): decorrelates nearby keys such as adjacent pixels.
inline uint64_t mix64(uint64_t x) {
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebULL;
    x ^= x >> 31;
    return x;
}

inline uint32_t reverse_bits(uint32_t x) {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
}

// The Laine-Karras permutation: on bit-reversed values it flips each bit depending only on
// the bits above it, i.e. a nested uniform (Owen) scramble of the base-2 digits (Burley
// 2020, "Practical Hash-based Owen Scrambling").
inline uint32_t laine_karras(uint32_t x, uint32_t seed) {
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}
inline uint32_t owen_scramble(uint32_t x, uint32_t seed) { return reverse_bits(laine_karras(reverse_bits(x), seed)); }

// The second dimension of the Sobol sequence (direction numbers v_k = v_(k-1) ^ (v_(k-1) >> 1),
// v_0 = 2^31), which with van der Corput (bit reversal) makes a (0, 2)-sequence. Linear
// over GF(2) in the index bits, so four byte tables give it in four lookups.
struct Sobol1Tables {
    uint32_t t[4][256];
    Sobol1Tables() {
        uint32_t v[32];
        v[0] = 1u << 31;
        for (int k = 1; k < 32; ++k) v[k] = v[k - 1] ^ (v[k - 1] >> 1);
        for (int b = 0; b < 4; ++b)
            for (uint32_t i = 0; i < 256; ++i) {
                uint32_t r = 0;
                for (int k = 0; k < 8; ++k)
                    if (i >> k & 1) r ^= v[8 * b + k];
                t[b][i] = r;
            }
    }
};
inline uint32_t sobol_1(uint32_t i) {
    static const Sobol1Tables tables;
    return tables.t[0][i & 255] ^ tables.t[1][(i >> 8) & 255] ^ tables.t[2][(i >> 16) & 255] ^ tables.t[3][i >> 24];
}

// A pixel sample's numbers. Independent (PCG32) or low-discrepancy: every next_1d/next_2d
// call is its own dimension, drawn from a padded, shuffled and Owen-scrambled Sobol
// (0, 2)-sequence over the pixel's sample indices (Burley 2020), so that e.g. the camera
// offsets, the channel choice and the first free flight are stratified across a pixel's
// samples. Both depend only on (seed, pixel, sample index): any thread, any order.
class Sampler {
public:
    Sampler(uint64_t seed, uint64_t pixel, uint64_t sample_index, bool low_discrepancy = false)
        : ld_(low_discrepancy), index_(uint32_t(sample_index)), reversed_index_(reverse_bits(index_)) {
        key_ = mix64(seed * 0x9e3779b97f4a7c15ULL ^ mix64(pixel + 0x632be59bd9b4e019ULL));
        inc_ = (mix64(key_ ^ 0xda942042e4dd58b5ULL) << 1u) | 1u;
        state_ = 0;
        next_u32();
        state_ += mix64(key_ + sample_index * 0xd1342543de82ef95ULL);
        next_u32();
    }
    uint32_t next_u32() {
        const uint64_t old = state_;
        state_ = old * 6364136223846793005ULL + inc_;
        const uint32_t xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
        const uint32_t rot = uint32_t(old >> 59u);
        return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
    }
    // Uniform in [0, 1) with 32 bits of resolution.
    // Each dimension shuffles the sample index by an Owen scramble of its own (so that
    // dimensions are not correlated), then Owen-scrambles the Sobol point. With vdC =
    // reverse_bits, vdC(owen(i)) = laine_karras(reverse_bits(i)), which saves two reversals.
    Real next_1d() {
        if (!ld_ || dimension_ >= kLowDiscrepancyDimensions) return independent_1d();
        const uint64_t h = dimension_hash();
        return owen_scramble(laine_karras(reversed_index_, uint32_t(h)), uint32_t(h >> 32)) * 0x1p-32;
    }
    // A number outside the dimensions, for draws whose count varies from sample to sample
    // (a shadow ray's, a flight's tentative collisions after the first): drawn from the
    // sequence, they would shift the path's later decisions onto other dimensions in each
    // sample, which then no longer form one stratified set.
    Real independent_1d() { return next_u32() * 0x1p-32; }
    Vec2 next_2d() {
        if (!ld_ || dimension_ >= kLowDiscrepancyDimensions) {
            const Real a = next_1d();
            return {a, next_1d()};
        }
        const uint64_t h = dimension_hash();
        const uint32_t x = laine_karras(reversed_index_, uint32_t(h));  // vdC of the shuffled index
        const uint32_t i = reverse_bits(x);                             // the shuffled index
        return {owen_scramble(x, uint32_t(h >> 32)) * 0x1p-32,
                owen_scramble(sobol_1(i), uint32_t((h * 0x9e3779b97f4a7c15ULL) >> 32)) * 0x1p-32};
    }
    // An independent stream derived from this one (for another branch of a path), one per
    // `stream` number; with low discrepancy, the same sample index in a fresh set of
    // dimensions. Its key must not depend on the sample index: each dimension's scramble
    // has to be shared by all of a pixel's samples, or their points are not one stratified
    // sequence.
    Sampler split(uint64_t stream) const { return Sampler(key_, 0x5eed + stream, index_, ld_); }

    // Beyond the first decisions of a path (camera, channel, the first few events) the
    // stratification is lost to diverging path lengths anyway, and hashing would cost long
    // random walks dearly: later dimensions are independent numbers.
    static constexpr uint64_t kLowDiscrepancyDimensions = 24;

private:
    uint64_t dimension_hash() { return mix64(key_ + ++dimension_ * 0x9e3779b97f4a7c15ULL); }

    bool ld_ = false;
    uint32_t index_ = 0, reversed_index_ = 0;
    uint64_t key_ = 0, dimension_ = 0;
    uint64_t state_ = 0, inc_ = 1;
};

// One uniform spent on a run of choices, each made with its own probability p: a choice
// not made leaves (u - p) / (1 - p), uniform again and independent of it, for the next
// (the remaining fraction, as pbrt's SampleDiscrete reuses it). The first number's
// stratification so carries through the run. Each remap coarsens u's 2^-32 grain by
// 1 / (1 - p); past 2^10 (a grain of 2^-22) the next choice draws a fresh, independent
// number (the first is the sampler's next dimension).
class ChoiceChain {
public:
    bool choose(Real p, Sampler &sampler) {
        if (u_ < 0) {
            u_ = drawn_ ? sampler.independent_1d() : sampler.next_1d();
            coarsening_ = 1;
            drawn_ = true;
        }
        if (u_ < p) {
            u_ = -1;
            return true;
        }
        u_ = (u_ - p) / (1 - p);
        coarsening_ /= 1 - p;
        if (!(coarsening_ <= 1024) || !(u_ < 1)) u_ = -1;
        return false;
    }

private:
    Real u_ = -1, coarsening_ = 1;
    bool drawn_ = false;
};

}  // namespace volpath
