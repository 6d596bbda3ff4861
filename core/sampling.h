// Sampling routines shared by BSDFs, lights and cameras.
#pragma once
#include <emmintrin.h>
#include <vector>
#include "core/math.h"

namespace lt {

// sin and cos of (pi/4) t for t in [-1, 1], without libm's sincosf (a call plus range reduction
// that this range does not need). Chebyshev-fitted polynomials in t^2 (fitted in 40-digit
// arithmetic); max abs error in float 9e-8 for sin, 8e-8 for cos (libm's sinf/cosf of the rounded
// float angle: 7e-8). cos(0) = 1 and sin(0) = 0 exactly. Tested in tests/test_sampling_fast.cpp.
struct SinCos {
    float sin, cos;
};
inline SinCos sinCosQuarterPi(float t) {
    const float y = t * t;
    return {t * (0.78539816097661834f +
                 y * (-0.080745434708101474f + y * (0.0024900068014923567f + y * -3.5954290725110749e-5f))),
            1.f + y * (-0.30842513734355484f +
                       y * (0.015854338147319281f + y * (-0.00032596138034687451f + y * 3.5419527281377598e-6f)))};
}
// Shirley-Chiu concentric map. With the larger |coordinate| as the radius r, the angle is (pi/4)t
// from the x axis, t = o.y / o.x, when |o.x| > |o.y|; else pi/2 - (pi/4)t from it, t = o.x / o.y
// (cos and sin swap). r == 0 only at the centre (then both coordinates are 0).
// The two cases are chosen by a lane mask, not a branch: which coordinate is the larger is a coin
// flip per sample, and a branch on it was mispredicted about every second call (cachegrind's
// branch simulation: 0.5 per call, the most of any line of ours).
inline Vec2 sampleConcentricDisk(const Vec2& u) {
    const Vec2 o = 2.f * u - Vec2(1.f);
    const __m128 ox = _mm_set_ss(o.x), oy = _mm_set_ss(o.y);
    const __m128 absMask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
    const __m128 xMajor = _mm_cmpgt_ss(_mm_and_ps(ox, absMask), _mm_and_ps(oy, absMask));
    auto select = [&](__m128 ifX, __m128 ifY) {
        return _mm_cvtss_f32(_mm_or_ps(_mm_and_ps(xMajor, ifX), _mm_andnot_ps(xMajor, ifY)));
    };
    const float r = select(ox, oy);
    if (r == 0.f) return Vec2(0.f);
    const SinCos sc = sinCosQuarterPi(select(oy, ox) / r);
    const __m128 a = _mm_set_ss(r * sc.cos), b = _mm_set_ss(r * sc.sin);
    return Vec2(select(a, b), select(b, a));
}
inline Vec3 sampleCosineHemisphere(const Vec2& u) {
    Vec2 d = sampleConcentricDisk(u);
    return Vec3(d.x, d.y, safeSqrt(1.f - d.x * d.x - d.y * d.y));
}
inline float cosineHemispherePdf(float cosTheta) { return cosTheta > 0.f ? cosTheta * kInvPi : 0.f; }
inline Vec3 sampleUniformSphere(const Vec2& u) {
    float z = 1.f - 2.f * u.x;
    float r = safeSqrt(1.f - z * z);
    float phi = 2.f * kPi * u.y;
    return Vec3(r * std::cos(phi), r * std::sin(phi), z);
}
inline constexpr float kUniformSpherePdf = 1.f / (4.f * kPi);
// Uniform barycentrics on a triangle (returns b1, b2).
inline Vec2 sampleUniformTriangle(const Vec2& u) {
    float su = std::sqrt(u.x);
    return Vec2(1.f - su, u.y * su);
}
// Uniform direction in a cone around +z with cos of the half angle cosMax.
// Solid angle of the cone: use coneSolidAngle (stable in float for tiny cones).
inline Vec3 sampleUniformCone(const Vec2& u, float cosMax) {
    float cosT = (1.f - u.x) + u.x * cosMax;
    float sinT = safeSqrt(1.f - cosT * cosT);
    float phi = 2.f * kPi * u.y;
    return Vec3(std::cos(phi) * sinT, std::sin(phi) * sinT, cosT);
}
// 4 pi sin^2(theta/2) == 2 pi (1 - cos theta), but without cancellation for small theta.
inline float coneSolidAngle(float halfAngle) { return 4.f * kPi * sqr(std::sin(0.5f * halfAngle)); }

inline float powerHeuristic(float a, float b) {
    if (std::isinf(a)) return 1.f;
    float a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.f ? a2 / (a2 + b2) : 0.f;
}

// Piecewise-constant 1D distribution (for the choice between lights, triangles by area).
// Sampling is a branch-free binary search (a fixed number of steps for a given size, so no
// mispredicted branches on random u) and remaps u within the bin by a multiplication; a bin's
// cdf and inverse width sit together (one cache line, one base pointer).
class Distribution1D {
public:
    Distribution1D() = default;
    explicit Distribution1D(const std::vector<float>& w) : bins_(w.size() + 1, Bin{0.0, 0.0}), n_(w.size()) {
        std::vector<double> cdf(w.size() + 1, 0.0);
        for (size_t i = 0; i < w.size(); ++i) cdf[i + 1] = cdf[i] + double(w[i]);
        total_ = cdf.back();
        for (size_t i = 1; i < cdf.size(); ++i)
            cdf[i] = total_ > 0 ? cdf[i] / total_ : double(i) / double(w.size());
        for (size_t i = 0; i < cdf.size(); ++i) {
            const double width = i < w.size() ? cdf[i + 1] - cdf[i] : 0.0;
            bins_[i] = {cdf[i], width > 0 ? 1.0 / width : 0.0};
        }
    }
    size_t size() const { return n_; }
    double total() const { return total_; }
    // Returns the bin i with cdf[i] <= u < cdf[i+1] (never a bin of zero weight); u is remapped
    // to [0,1) within the chosen bin.
    size_t sample(float u, float* remapped = nullptr) const {
        const Bin* b = bins_.data();
        size_t lo = 0, len = n_;
        while (len > 1) {
            size_t half = len / 2;
            lo = b[lo + half].cdf <= double(u) ? lo + half : lo;
            len -= half;
        }
        if (remapped) *remapped = float(std::min(0.99999994, (double(u) - b[lo].cdf) * b[lo].invWidth));
        return lo;
    }
    float probability(size_t i) const { return float(bins_[i + 1].cdf - bins_[i].cdf); }

private:
    struct Bin {
        double cdf;       // at the bin's start
        double invWidth;  // 1 / (width of the bin), 0 for an empty bin
    };
    std::vector<Bin> bins_;  // the n bins and one record holding cdf = 1 (the last bin's end)
    size_t n_ = 0;
    double total_ = 0;
};

}  // namespace lt
