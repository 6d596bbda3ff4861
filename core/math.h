// Basic math for the renderer: vectors (GLM, float), orthonormal frames, typed pdfs.
#pragma once
#include <glm/glm.hpp>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

namespace lt {

using Vec2 = glm::vec2;
using Vec3 = glm::vec3;
using DVec3 = glm::dvec3;
using Vec4 = glm::vec4;
using Mat4 = glm::mat4;
using Color = glm::vec3;  // linear RGB

inline constexpr float kPi = 3.14159265358979323846f;
inline constexpr float kInvPi = 0.31830988618379067154f;
inline constexpr float kInf = std::numeric_limits<float>::infinity();

inline float sqr(float x) { return x * x; }
inline float safeSqrt(float x) { return std::sqrt(std::max(0.f, x)); }
inline float maxComp(const Vec3& v) { return std::max(v.x, std::max(v.y, v.z)); }
inline float luminance(const Color& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }
// All three components +0 or -0 (NaN is not black), as c.x == 0 && c.y == 0 && c.z == 0, without
// the three compare-and-branch pairs: the bits of the three floats, or-ed, without the sign bits.
inline bool isBlack(const Color& c) {
    uint32_t x, y, z;
    std::memcpy(&x, &c.x, 4);
    std::memcpy(&y, &c.y, 4);
    std::memcpy(&z, &c.z, 4);
    return ((x | y | z) << 1) == 0u;
}
inline bool isFinite(const Color& c) { return std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z); }
inline float maxAbs(const Vec3& v) { return std::max(std::abs(v.x), std::max(std::abs(v.y), std::abs(v.z))); }

// Orthonormal frame; local z is the normal. Duff et al. 2017 branchless basis.
struct Frame {
    Vec3 s{1, 0, 0}, t{0, 1, 0}, n{0, 0, 1};
    Frame() = default;
    explicit Frame(const Vec3& normal) : n(normal) {
        float sign = std::copysign(1.f, n.z);
        float a = -1.f / (sign + n.z);
        float b = n.x * n.y * a;
        s = Vec3(1.f + sign * n.x * n.x * a, sign * b, -sign * n.x);
        t = Vec3(b, sign + n.y * n.y * a, -n.y);
    }
    Frame(const Vec3& s_, const Vec3& t_, const Vec3& n_) : s(s_), t(t_), n(n_) {}
    Vec3 toLocal(const Vec3& v) const { return {glm::dot(v, s), glm::dot(v, t), glm::dot(v, n)}; }
    Vec3 toWorld(const Vec3& v) const { return s * v.x + t * v.y + n * v.z; }
};

// ---- Typed pdfs -------------------------------------------------------------
// A density per unit solid angle and a density per unit area are different types, so a
// missing cos/d^2 conversion does not compile. Construction is explicit; arithmetic that
// keeps the measure (scaling by a probability, summing) is allowed.
template <class Tag>
struct Pdf {
    float value = 0.f;
    constexpr Pdf() = default;
    constexpr explicit Pdf(float v) : value(v) {}
    Pdf operator*(float p) const { return Pdf(value * p); }
    Pdf operator+(Pdf o) const { return Pdf(value + o.value); }
    Pdf& operator+=(Pdf o) { value += o.value; return *this; }
    bool isZero() const { return value == 0.f; }
};
struct SolidAngleTag {};
struct AreaTag {};
using SolidAnglePdf = Pdf<SolidAngleTag>;
using AreaPdf = Pdf<AreaTag>;

// Solid-angle density at x towards y -> area density at y: p_A = p_w * |cos_y| / d^2.
inline AreaPdf toArea(SolidAnglePdf p, float absCosAtTarget, float dist2) {
    return AreaPdf(p.value * absCosAtTarget / dist2);
}
inline SolidAnglePdf toSolidAngle(AreaPdf p, float absCosAtTarget, float dist2) {
    return absCosAtTarget > 0.f ? SolidAnglePdf(p.value * dist2 / absCosAtTarget) : SolidAnglePdf(0.f);
}

inline Vec3 transformPoint(const Mat4& m, const Vec3& p) { Vec4 r = m * Vec4(p, 1.f); return Vec3(r) / r.w; }
inline Vec3 transformVector(const Mat4& m, const Vec3& v) { return Vec3(m * Vec4(v, 0.f)); }
inline Vec3 transformNormal(const Mat4& m, const Vec3& n) {
    return glm::normalize(Vec3(glm::transpose(glm::inverse(m)) * Vec4(n, 0.f)));
}

// Reflect wo about n (both pointing away from the surface).
inline Vec3 reflect(const Vec3& wo, const Vec3& n) { return 2.f * glm::dot(wo, n) * n - wo; }

}  // namespace lt
