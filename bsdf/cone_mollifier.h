// KD13's constant cone mollifier of a delta lobe (Kaplanyan and Dachsbacher 2013, Eq. 5; issue 14).
// A smooth conductor or dielectric evaluated with a request whose `cone` is eps > 0 replaces each
// of its delta lobes, delta(wi - w_ideal) / |cos wi| times the lobe's weight, by
//     weight * phi_eps(wi, w_ideal) / |cos wi|,   phi_eps = 1 / Omega(eps) inside the cone of
// half-angle eps around w_ideal (the walk's ideal reflected or refracted direction of wo), 0 outside,
// so that its integral against |cos wi| over the sphere is the lobe's weight (the Fresnel term, and
// the 1/eta^2 of radiance through refraction), as the delta's is; a cone cut by the horizon loses
// the part below. Omega(eps) = 4 pi sin^2(eps/2) (coneSolidAngle), never 2 pi (1 - cos eps): in
// float the latter is 0 for eps below ~3e-4.
// The test "wi in the cone" is |wi - w_ideal|^2 < 4 sin^2(eps/2) (the chord), in double from the
// float directions: no cos of a tiny angle is formed, and the directions' own rounding (~6e-8) is
// all that blurs the cone's edge.
#pragma once
#include <cmath>
#include "core/math.h"
#include "core/sampling.h"

namespace lt {

struct ConeMollifier {
    float invOmega = 0.f;  // 1 / Omega(eps)
    double chord2 = 0.0;   // 4 sin^2(eps/2): the squared chord of the cone's half-angle
    explicit ConeMollifier(float eps) {
        const double s = std::sin(0.5 * double(eps));
        chord2 = 4.0 * s * s;
        invOmega = 1.f / coneSolidAngle(eps);
    }
    bool contains(const Vec3& w, const DVec3& ideal) const {
        const double dx = double(w.x) - ideal.x, dy = double(w.y) - ideal.y, dz = double(w.z) - ideal.z;
        return dx * dx + dy * dy + dz * dz < chord2;
    }
    // The value of a lobe of weight `weight` towards wi (local frame) around `ideal`.
    Color eval(const Color& weight, const Vec3& wi, const DVec3& ideal) const {
        if (wi.z == 0.f || !contains(wi, ideal)) return Color(0.f);
        return weight * (invOmega / std::abs(wi.z));
    }
};

// The half-angle of the cone whose value 1 / Omega is `bound` (JG19 Fig. 4: rho_cone = tau, one
// knob for microfacet and smooth lobes): sin^2(eps/2) = 1 / (4 pi bound); pi for a bound at or below
// 1/(4 pi) (the whole sphere), 0 for +inf (no cone).
inline float coneForBound(float bound) {
    if (!(bound > 0.f)) return kPi;
    const double s2 = 1.0 / (4.0 * double(kPi) * double(bound));
    return s2 >= 1.0 ? kPi : float(2.0 * std::asin(std::sqrt(s2)));
}

// The ideal directions in double (local frame, wo unit, normal +z): the mirror direction, and the
// refracted one through relative IOR eta = n_lower / n_upper (wo on either side; false on total
// internal reflection).
inline DVec3 idealReflection(const Vec3& wo) { return DVec3(-double(wo.x), -double(wo.y), double(wo.z)); }
inline bool idealRefraction(const Vec3& wo, float eta, DVec3& out) {
    double c = wo.z, e = eta, side = 1.0;  // side: the sign of wo.z
    if (c < 0.0) e = 1.0 / e, c = -c, side = -1.0;
    const double sin2T = std::max(0.0, 1.0 - c * c) / (e * e);
    if (sin2T >= 1.0) return false;
    // -wo / e, plus the normal component -cos(theta_t) on the other side
    out = DVec3(-double(wo.x) / e, -double(wo.y) / e, -side * std::sqrt(1.0 - sin2T));
    return true;
}

}  // namespace lt
