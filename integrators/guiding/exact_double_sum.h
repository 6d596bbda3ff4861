// Exact (associative) sums of non-negative doubles, for the training iterations' per-pixel sums of
// squares (trainer.h): the ExactSum of core/exact_sum.h widened to doubles. A fixed-point number
// with 96 fractional bits in a 256-bit integer (four 64-bit limbs); integer addition does not
// depend on the order of the terms, so MPI ranks that add disjoint sets of samples and then add
// their partial sums get the bits of one process adding them all.
//
// A summand x must be representable(): x >= 0 and x < 2^124 (the square of a mean of floats
// below 2^62, which is what the film accepts). A double is M 2^e with a 53-bit integer M; x is
// added exactly when it is a multiple of 2^-96 (every x >= 2^-44), otherwise truncated toward zero
// to one (error < 2^-96 a summand, still deterministic). The sum may reach 2^160 before it wraps
// (2^36 summands of the largest size); additions wrap modulo 2^256, so even then the bits are the
// same for every order.
#pragma once
#include <bit>
#include <cmath>
#include <cstdint>

namespace lt::guiding {

struct ExactDoubleSum {
    uint64_t limb[4] = {0, 0, 0, 0};  // little-endian; the sum is (limb[0] + limb[1] 2^64 + ...) 2^-96

    static bool representable(double x) { return x >= 0.0 && x < 0x1p124; }  // NaN fails both

    // Precondition: representable(x).
    void add(double x) {
        // |x| (a -0 is +0) = M 2^(E - 1075) for a normal double (exponent field E, M with the
        // implicit bit); x 2^96 = M 2^(E - 979). E <= 1146 since x < 2^124, so the shift is at most
        // 167 and M 2^167 < 2^220 fits. Subnormals (E = 0) shift out entirely.
        const uint64_t bits = std::bit_cast<uint64_t>(x) & 0x7fffffffffffffffull;
        const int e = int(bits >> 52);
        if (e == 0) return;
        const uint64_t m = (bits & 0xfffffffffffffull) | (uint64_t(1) << 52);
        const int s = e - 979;
        if (s <= -53) return;
        if (s < 0) return addAt(0, m >> -s, 0);
        const int i = s / 64, off = s % 64;
        if (i > 3) return;  // (not representable)
        addAt(i, m << off, off ? m >> (64 - off) : 0);
    }
    void add(const ExactDoubleSum& o) {
        unsigned carry = 0;
        for (int i = 0; i < 4; ++i) {
            const uint64_t a = limb[i], t = a + o.limb[i], u = t + carry;
            carry = unsigned(t < a) + unsigned(u < t);
            limb[i] = u;
        }
    }

    // The sum as a double, correctly rounded (round to nearest, ties to even).
    double value() const {
        int top = 3;
        while (top >= 0 && limb[top] == 0) --top;
        if (top < 0) return 0.0;
        // The highest set bit h; its 64 bits [h - 63, h] in t, and any bit below them as a sticky
        // bit in t's lowest bit (11 bits below the double's rounding position, so one rounding of
        // t to 53 bits is the correct rounding of the whole).
        const int h = 64 * top + 63 - std::countl_zero(limb[top]);
        if (h < 64) return std::ldexp(double(limb[0]), -96);
        const int lo = h - 63;
        const int li = lo / 64, lb = lo % 64;
        uint64_t t = limb[li] >> lb;
        if (lb) t |= limb[li + 1] << (64 - lb);
        bool sticky = lb && (limb[li] << (64 - lb)) != 0;
        for (int i = 0; i < li; ++i) sticky |= limb[i] != 0;
        return std::ldexp(double(t | uint64_t(sticky)), lo - 96);
    }

    bool operator==(const ExactDoubleSum&) const = default;

private:
    // Adds lo 2^(64 i) + hi 2^(64 (i + 1)), carrying up to the top limb (wrapping beyond it).
    void addAt(int i, uint64_t lo, uint64_t hi) {
        unsigned __int128 c = static_cast<unsigned __int128>(limb[i]) + lo;
        limb[i] = uint64_t(c);
        c >>= 64;
        c += hi;
        for (int j = i + 1; j < 4 && c; ++j) {
            c += limb[j];
            limb[j] = uint64_t(c);
            c >>= 64;
        }
    }
};

}  // namespace lt::guiding
