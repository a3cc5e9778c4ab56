// Random numbers: PCG32 (O'Neill 2014) seeded by hashing (seed, pixel, sample index),
// so every pixel sample replays the same numbers on any thread, in any order.
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

class Sampler {
public:
    Sampler(uint64_t seed, uint64_t pixel, uint64_t sample_index) {
        const uint64_t key = mix64(seed * 0x9e3779b97f4a7c15ULL ^ mix64(pixel + 0x632be59bd9b4e019ULL));
        inc_ = (mix64(key ^ 0xda942042e4dd58b5ULL) << 1u) | 1u;
        state_ = 0;
        next_u32();
        state_ += mix64(key + sample_index * 0xd1342543de82ef95ULL);
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
    Real next_1d() { return next_u32() * 0x1p-32; }
    // An independent stream derived from this one (for a second branch of a path).
    Sampler split() {
        const uint64_t a = next_u32(), b = next_u32();
        return Sampler((a << 32) | b, 0x5eed, next_u32());
    }
    Vec2 next_2d() {
        const Real a = next_1d();
        return {a, next_1d()};
    }

private:
    uint64_t state_ = 0, inc_ = 1;
};

}  // namespace volpath
