// Random numbers. Every sample's stream is derived from (seed, pixel, sample index) so an image
// does not depend on how work is split between threads.
#pragma once
#include <cstdint>
#include "core/math.h"

namespace lt {

inline uint64_t splitmix64(uint64_t x) {
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

// PCG32 (O'Neill), XSH-RR output.
class Rng {
public:
    Rng() : Rng(0, 0) {}
    Rng(uint64_t seed, uint64_t stream) {
        state_ = 0u;
        inc_ = (stream << 1u) | 1u;
        next();
        state_ += seed;
        next();
    }
    // The stream for one sample: independent of thread scheduling.
    static Rng forSample(uint64_t seed, uint64_t pixelIndex, uint64_t sampleIndex, uint64_t domain = 0) {
        uint64_t a = splitmix64(seed ^ splitmix64(domain + 0x1234567ull));
        uint64_t b = splitmix64(a ^ splitmix64(pixelIndex + 0x9876543ull));
        uint64_t c = splitmix64(b ^ (sampleIndex * 0xD1B54A32D192ED03ull));
        return Rng(c, splitmix64(c ^ pixelIndex));
    }
    uint32_t next() {
        uint64_t old = state_;
        state_ = old * 6364136223846793005ull + inc_;
        uint32_t xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
        uint32_t rot = uint32_t(old >> 59u);
        return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31));
    }
    // A stream of its own, derived from this one's state and `salt` without advancing it: for
    // draws that must not shift this stream (a regulariser's extra connections: detail::lightSampleStream, integrators/transport/path_inline.h).
    Rng split(uint64_t salt) const { return Rng(state_ ^ splitmix64(salt), splitmix64(inc_ ^ salt)); }
    // Uniform in [0, 1).
    float uniform() { return float(next() >> 8) * 0x1.0p-24f; }
    Vec2 uniform2() { float a = uniform(); return Vec2(a, uniform()); }

private:
    uint64_t state_, inc_;
};

}  // namespace lt
