// Exact (associative) sums of non-negative floats, for the film: a fixed-point number with 64
// fractional bits in a 128-bit integer. Integer addition does not depend on the order of the
// terms, so threads and MPI ranks that add the same samples in any order, or add partial sums
// together, get the same bits (a double sum rounds at every step and does not).
//
// A summand x must be representable(): finite, x >= 0 and x < 2^62. A float is m 2^e with a
// 24-bit integer m; x is added exactly when it is a multiple of 2^-64 (every x >= 2^-41, as its
// last bit is then >= 2^-64), otherwise truncated toward zero to one (error < 2^-64 a summand,
// still deterministic; values below 2^-64 add nothing).
// The sum may reach 2^63 (2^127 in units of 2^-64) before it overflows: two summands of the
// largest size, or 2^40 summands of 2^23. Additions wrap modulo 2^128 (unsigned arithmetic), so
// even an overflowed sum is the same for every order; only its value() is then wrong.
#pragma once
#include <bit>
#include <cmath>
#include <cstdint>
#include "core/math.h"

namespace lt {

struct ExactSum {
    __int128 v = 0;  // the sum is v 2^-64

    static bool representable(float x) { return x >= 0.f && x < 0x1p62f; }  // NaN fails both

    // Precondition: representable(x).
    void add(float x) {
        // Bits of |x| (a -0 is +0): exponent field E, fraction f. A normal float is
        // (2^23 + f) 2^(E - 150), so x 2^64 = m 2^(E - 86) = (m 2^102) >> (188 - E), and E <= 188
        // since x < 2^62. m 2^102 < 2^126 fits; a shift of 127 leaves 0. Subnormals (E = 0) and
        // anything below 2^-64 shift out to (truncated) 0, so the implicit bit may be set for them too.
        const uint32_t bits = std::bit_cast<uint32_t>(x) & 0x7fffffffu;
        const uint32_t e = bits >> 23, m = (bits & 0x7fffffu) | 0x800000u;
        const uint32_t shift = 188u - e < 127u ? 188u - e : 127u;
        addRaw((static_cast<unsigned __int128>(m) << 102) >> shift);
    }
    void add(const ExactSum& o) { addRaw(static_cast<unsigned __int128>(o.v)); }

    // The sum as a double, correctly rounded (the int128 conversion rounds once; the scaling is exact).
    double value() const { return std::ldexp(static_cast<double>(v), -64); }

    bool operator==(const ExactSum&) const = default;

private:
    void addRaw(unsigned __int128 d) { v = static_cast<__int128>(static_cast<unsigned __int128>(v) + d); }
};

// Three channels (linear RGB).
struct ExactColorSum {
    ExactSum r, g, b;

    static bool representable(const Color& c) {
        return ExactSum::representable(c.x) && ExactSum::representable(c.y) && ExactSum::representable(c.z);
    }
    // Precondition: representable(c).
    void add(const Color& c) { r.add(c.x), g.add(c.y), b.add(c.z); }
    void add(const ExactColorSum& o) { r.add(o.r), g.add(o.g), b.add(o.b); }
    glm::dvec3 value() const { return glm::dvec3(r.value(), g.value(), b.value()); }

    bool operator==(const ExactColorSum&) const = default;
};

}  // namespace lt
