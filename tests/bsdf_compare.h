// Two BSDF models compared bit for bit over a few direction pairs and lobe choices, in both
// transport modes (a textured material's instance against the untextured model of its values, a
// degenerate mixture against its one component, ...).
#pragma once
#include <catch2/catch.hpp>
#include "bsdf/bsdf.h"

namespace lt::test {

inline void requireSameEvalsAndSamples(const Bxdf& a, const Bxdf& b) {
    const Vec3 dirs[] = {glm::normalize(Vec3(0.3f, 0.1f, 0.9f)), glm::normalize(Vec3(-0.2f, 0.4f, 0.7f)),
                         glm::normalize(Vec3(0.5f, -0.5f, 0.3f)), glm::normalize(Vec3(-0.3f, -0.1f, -0.9f))};
    for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
        const BsdfContext ctx(mode);
        for (const Vec3& wo : dirs) {
            for (const Vec3& wi : dirs) {
                const BsdfEval ea = a.eval(wo, wi, ctx), eb = b.eval(wo, wi, ctx);
                CHECK(ea.f == eb.f);
                CHECK(ea.pdfFwd.value == eb.pdfFwd.value);
                CHECK(ea.pdfRev.value == eb.pdfRev.value);
            }
            for (float uLobe : {0.02f, 0.3f, 0.7f, 0.95f}) {
                BsdfSample sa, sb;
                const bool oka = a.sample(wo, uLobe, Vec2(0.3f, 0.6f), ctx, sa);
                const bool okb = b.sample(wo, uLobe, Vec2(0.3f, 0.6f), ctx, sb);
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
