// Two BSDF models compared bit for bit over a few direction pairs and lobe choices, in both
// transport modes (a textured material's instance against the untextured model of its values, a
// degenerate mixture against its one component, a regularised model against the model of the
// alphas its request resolves to, ...): a evaluated and sampled under request ra, b under rb.
#pragma once
#include <catch2/catch.hpp>
#include "bsdf/bsdf.h"

namespace lt::test {

// The unit direction at polar angle thetaDeg (degrees) and azimuth phi (radians).
inline Vec3 dirDeg(float thetaDeg, float phi = 0.7f) {
    const float t = glm::radians(thetaDeg);
    return {std::sin(t) * std::cos(phi), std::sin(t) * std::sin(phi), std::cos(t)};
}

inline void requireSameEvalsAndSamples(const Bxdf& a, const Bxdf& b, const RegularizationRequest& ra = {},
                                       const RegularizationRequest& rb = {}) {
    const Vec3 dirs[] = {glm::normalize(Vec3(0.3f, 0.1f, 0.9f)), glm::normalize(Vec3(-0.2f, 0.4f, 0.7f)),
                         glm::normalize(Vec3(0.5f, -0.5f, 0.3f)), glm::normalize(Vec3(-0.3f, -0.1f, -0.9f))};
    for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
        const BsdfContext ctxA(mode, ra), ctxB(mode, rb);
        for (const Vec3& wo : dirs) {
            for (const Vec3& wi : dirs) {
                const BsdfEval ea = a.eval(wo, wi, ctxA), eb = b.eval(wo, wi, ctxB);
                CHECK(ea.f == eb.f);
                CHECK(ea.pdfFwd.value == eb.pdfFwd.value);
                CHECK(ea.pdfRev.value == eb.pdfRev.value);
            }
            for (float uLobe : {0.02f, 0.3f, 0.7f, 0.95f}) {
                BsdfSample sa, sb;
                const bool oka = a.sample(wo, uLobe, Vec2(0.3f, 0.6f), ctxA, sa);
                const bool okb = b.sample(wo, uLobe, Vec2(0.3f, 0.6f), ctxB, sb);
                REQUIRE(oka == okb);
                if (!oka) continue;
                CHECK(sa.wi == sb.wi);
                CHECK(sa.weight == sb.weight);
                CHECK(sa.pdfFwd.value == sb.pdfFwd.value);
                CHECK(sa.pdfRev.value == sb.pdfRev.value);
                CHECK(sa.lobe == sb.lobe);
                CHECK(sa.eta == sb.eta);
            }
        }
    }
}

}  // namespace lt::test
