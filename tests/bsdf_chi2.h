// Chi-square of a BSDF's sampling against its eval pdf at the scale of its sharpest lobe (the
// principled tests' runner; tests/chi2.h is the harness).
#pragma once
#include <catch2/catch.hpp>
#include <cmath>
#include <string>
#include <vector>

#include "bsdf/bsdf.h"
#include "chi2.h"

namespace lt::test {

// Bins: caps around the mirror and the refracted direction at the lobe's scale, and the whole
// sphere around the normal.
// Chi-square of b's sampling against its pdf from wo, with fine bins (half the lobe's alpha) about
// each peak direction and coarse ones elsewhere; the lost samples (failed draws) are the pdf's
// missing mass: 5 binomial standard errors + 2e-3 for the quadrature (as test_bsdf_extra.cpp).
// ctx: the transport mode and request both sample and eval are given.
inline void runLobeChi2(const Bxdf& b, const std::string& name, const Vec3& wo, const std::vector<Vec3>& peaks,
                        float lobeAlpha, uint64_t seed, double level, const BsdfContext& ctx = kRadianceContext) {
    chi2::SampleFn sampler = [&](Rng& rng, Vec3& w) {
        BsdfSample s;
        const float ul = rng.uniform();
        const Vec2 u = rng.uniform2();
        if (!b.sample(wo, ul, u, ctx, s)) return false;
        w = s.wi;
        return true;
    };
    chi2::PdfFn pdf = [&](const Vec3& w) { return double(b.eval(wo, w, ctx).pdfFwd.value); };
    std::vector<chi2::Region> regions;
    const float cosCap = std::cos(std::min(1.2f, 6.f * lobeAlpha + 0.02f));
    for (const Vec3& peak : peaks)
        regions.push_back({chi2::Domain(peak, 0.5 * lobeAlpha, 40, 80),
                           [peak, cosCap](const Vec3& w) { return glm::dot(w, peak) > cosCap; }});
    regions.push_back({chi2::Domain(Vec3(0.f, 0.f, 1.f), 1.0, 40, 80), nullptr});
    chi2::Chi2Test test(sampler, 200000, seed);
    const chi2::Result res = test.run(pdf, regions, level);
    INFO(name << " wo " << wo.x << " " << wo.y << " " << wo.z << ": " << res.summary());
    CHECK(res.samplesInZeroBins == 0);
    CHECK(res.pValue >= res.significance);
    const double n = double(res.samples), lostFrac = double(res.lost) / n;
    const double se = std::sqrt(std::max(lostFrac * (1.0 - lostFrac), 1.0 / n) / n);
    CHECK(res.pdfIntegral <= 1.0 + 2e-3);
    CHECK(std::abs((1.0 - res.pdfIntegral) - lostFrac) <= 5.0 * se + 2e-3);
}

}  // namespace lt::test
