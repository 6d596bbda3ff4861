// Fresnel equations (unpolarised light) and refraction helpers, local shading frame.
#pragma once
#include "core/math.h"

namespace lt {

// Exact dielectric Fresnel reflectance. cosThetaI is the cosine between the incident direction
// and the (micro)normal n; eta = n_lower / n_upper is the relative IOR across the interface
// where "upper" is the side n points to. If cosThetaI < 0 the incident direction is on the
// lower side and eta is inverted internally. Returns 1 on total internal reflection. Exactly 0
// for eta == 1 (index-matched). If cosThetaT is given it receives the cosine of the refracted
// direction, with the sign of the side it lies on (opposite to cosThetaI; 0 on TIR).
inline float fresnelDielectric(float cosThetaI, float eta, float* cosThetaT = nullptr) {
    if (eta == 1.f) {
        if (cosThetaT) *cosThetaT = -cosThetaI;
        return 0.f;
    }
    const bool outside = cosThetaI >= 0.f;
    const float e = outside ? eta : 1.f / eta;
    const float ci = std::min(std::abs(cosThetaI), 1.f);
    const float sin2T = (1.f - ci * ci) / (e * e);
    if (sin2T >= 1.f) {
        if (cosThetaT) *cosThetaT = 0.f;
        return 1.f;
    }
    const float ct = std::sqrt(1.f - sin2T);
    if (cosThetaT) *cosThetaT = outside ? -ct : ct;
    const float rs = (ci - e * ct) / (ci + e * ct);
    const float rp = (e * ci - ct) / (e * ci + ct);
    return std::min(1.f, 0.5f * (rs * rs + rp * rp));
}

// Conductor Fresnel reflectance for a complex relative IOR eta + i k (per RGB channel), for
// light arriving from the dielectric side at cosine cosThetaI (its absolute value is used).
// eta = 0, k = 1 gives exactly 1 (Mitsuba's "none" perfect mirror).
inline float fresnelConductor(float cosThetaI, float eta, float k) {
    const float c = std::min(std::abs(cosThetaI), 1.f);
    const float c2 = c * c, s2 = 1.f - c2;
    const float eta2 = eta * eta, k2 = k * k;
    const float t0 = eta2 - k2 - s2;
    const float a2b2 = std::sqrt(t0 * t0 + 4.f * eta2 * k2);
    const float a = safeSqrt(0.5f * (a2b2 + t0));
    const float t1 = a2b2 + c2, t2 = 2.f * a * c;
    const float rs = t1 + t2 > 0.f ? (t1 - t2) / (t1 + t2) : 1.f;
    const float t3 = c2 * a2b2 + s2 * s2, t4 = t2 * s2;
    const float rp = t3 + t4 > 0.f ? rs * (t3 - t4) / (t3 + t4) : rs;
    return std::clamp(0.5f * (rs + rp), 0.f, 1.f);
}
inline Color fresnelConductor(float cosThetaI, const Color& eta, const Color& k) {
    return {fresnelConductor(cosThetaI, eta.x, k.x), fresnelConductor(cosThetaI, eta.y, k.y),
            fresnelConductor(cosThetaI, eta.z, k.z)};
}

// Mirror reflection of w about the normal n (both pointing away from the surface).
inline Vec3 reflectAbout(const Vec3& w, const Vec3& n) { return 2.f * glm::dot(w, n) * n - w; }

// Refraction of w (pointing away from the surface) through the (micro)normal n with relative
// IOR eta = n_lower / n_upper (n points to the upper side; w may be on either side). Returns
// false on total internal reflection. The result points away from the surface, on the other side.
inline bool refractAbout(const Vec3& w, const Vec3& n, float eta, Vec3& wt) {
    float cosI = glm::dot(w, n);
    float e = eta;
    Vec3 nn = n;
    if (cosI < 0.f) {
        e = 1.f / e;
        cosI = -cosI;
        nn = -n;
    }
    const float sin2T = std::max(0.f, 1.f - cosI * cosI) / (e * e);
    if (sin2T >= 1.f) return false;
    const float cosT = std::sqrt(1.f - sin2T);
    wt = -w / e + (cosI / e - cosT) * nn;
    return true;
}

}  // namespace lt
