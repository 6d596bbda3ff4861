// Sampling routines shared by BSDFs, lights and cameras.
#pragma once
#include <vector>
#include "core/math.h"

namespace lt {

inline Vec2 sampleConcentricDisk(const Vec2& u) {
    Vec2 o = 2.f * u - Vec2(1.f);
    if (o.x == 0 && o.y == 0) return Vec2(0.f);
    float r, theta;
    if (std::abs(o.x) > std::abs(o.y)) { r = o.x; theta = (kPi / 4) * (o.y / o.x); }
    else { r = o.y; theta = kPi / 2 - (kPi / 4) * (o.x / o.y); }
    return r * Vec2(std::cos(theta), std::sin(theta));
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

// Piecewise-constant 1D distribution (for lights by power, triangles by area).
// Sampling is a branch-free binary search (a fixed number of steps for a given size, so no
// mispredicted branches on random u) and remaps u within the bin by a multiplication.
class Distribution1D {
public:
    Distribution1D() = default;
    explicit Distribution1D(const std::vector<float>& w) : cdf_(w.size() + 1, 0.0), invWidth_(w.size(), 0.0) {
        for (size_t i = 0; i < w.size(); ++i) cdf_[i + 1] = cdf_[i] + double(w[i]);
        total_ = cdf_.back();
        for (size_t i = 1; i < cdf_.size(); ++i)
            cdf_[i] = total_ > 0 ? cdf_[i] / total_ : double(i) / double(w.size());
        for (size_t i = 0; i < w.size(); ++i) {
            double width = cdf_[i + 1] - cdf_[i];
            invWidth_[i] = width > 0 ? 1.0 / width : 0.0;
        }
    }
    size_t size() const { return invWidth_.size(); }
    double total() const { return total_; }
    // Returns the bin i with cdf[i] <= u < cdf[i+1] (never a bin of zero weight); u is remapped
    // to [0,1) within the chosen bin.
    size_t sample(float u, float* remapped = nullptr) const {
        size_t lo = 0, len = invWidth_.size();
        while (len > 1) {
            size_t half = len / 2;
            lo = cdf_[lo + half] <= double(u) ? lo + half : lo;
            len -= half;
        }
        if (remapped) *remapped = float(std::min(0.99999994, (double(u) - cdf_[lo]) * invWidth_[lo]));
        return lo;
    }
    float probability(size_t i) const { return float(cdf_[i + 1] - cdf_[i]); }

private:
    std::vector<double> cdf_, invWidth_;
    double total_ = 0;
};

}  // namespace lt
