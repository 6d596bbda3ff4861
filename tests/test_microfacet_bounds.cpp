// Tests of the JG19 maximum-value bound rho_bar(alpha) and its inverse alpha_hat(tau)
// (bsdf/roughness_bound.h).
//
// Bounded quantity (see roughness_bound.h):
// * Smith (separable G2): the Fresnel-free microfacet BSDF f of microfacet.h itself
//   (microfacetReflection: F = 1; microfacetTransmission: 1 - F = 1), both transport modes.
// * V-cavity: f |cos theta_o| |cos theta_i| (f itself is unbounded at grazing angles, which is
//   checked too).
// These are deterministic checks (fixed seeds, no statistics). The only tolerance on the bound
// is 1e-4 relative for float rounding: the Smith reflection bound is approached arbitrarily
// closely (f -> rho_bar for a grazing mirror pair), so rounding can land just above it.
#include <catch2/catch.hpp>

#include "bsdf/bsdf.h"
#include "bsdf/fresnel.h"
#include "bsdf/microfacet.h"
#include "bsdf/roughness_bound.h"
#include "microfacet_models.h"
#include "core/rng.h"
#include "core/sampling.h"

using namespace lt;
using namespace lt::test;

namespace {


// A direction whose cos(theta) is log-uniform in [1e-7, 1] (to probe grazing angles densely)
// or uniform, with a random azimuth, on the side `side`.
Vec3 randomDir(Rng& rng, float side) {
    const float c = rng.uniform() < 0.5f ? std::pow(10.f, -7.f * rng.uniform()) : rng.uniform();
    const float s = safeSqrt(1.f - c * c), phi = 2.f * kPi * rng.uniform();
    return {s * std::cos(phi), s * std::sin(phi), side * c};
}

// The bounded quantity for (masking, wo, wi, f).
float boundedQuantity(MaskingModel m, const Vec3& wo, const Vec3& wi, float f) {
    return m == MaskingModel::Smith ? f : f * std::abs(wo.z) * std::abs(wi.z);
}

}  // namespace

TEST_CASE("rho_bar bounds the microfacet BSDF over dense direction pairs", "[bound]") {
    const float alphas[] = {1e-3f, 0.01f, 0.05f, 0.1f, 0.3f, 0.5f, 0.7f, 0.85f, 1.f};
    for (auto d : kDists)
        for (auto m : kMasks)
            for (float a : alphas) {
                const Microfacet mf(d, a, a, m);
                // ---- Reflection (F = 1) ----
                {
                    const float bound = maxValueBound(d, m, a, false, 1.5f);
                    Rng rng(1234, uint64_t(a * 1e4f));
                    double maxRatio = 0;
                    Vec3 worstO(0.f), worstI(0.f);
                    for (int k = 0; k < 100000; ++k) {
                        const Vec3 wo = randomDir(rng, 1.f);
                        Vec3 wi;
                        if (k % 3 == 0) {
                            wi = randomDir(rng, 1.f);
                        } else {  // near the specular peak: reflect about a normal drawn from D
                            const Vec3 n = mf.sampleD(rng.uniform2());
                            wi = reflectAbout(wo, n);
                            if (!(wi.z > 0.f)) continue;
                        }
                        const float q = boundedQuantity(m, wo, wi, microfacetReflection(mf, wo, wi));
                        REQUIRE(std::isfinite(q));
                        if (q / bound > maxRatio) {
                            maxRatio = q / bound;
                            worstO = wo;
                            worstI = wi;
                        }
                    }
                    INFO(distName(d) << " " << maskName(m) << " alpha=" << a << " reflection: max f/rho_bar=" << maxRatio
                                     << " at wo.z=" << worstO.z << " wi.z=" << worstI.z << " rho_bar=" << bound);
                    CHECK(maxRatio <= 1.0 + 1e-4);
                    // Tightness: Smith reaches the bound for a grazing mirror pair (cos << alpha),
                    // V-cavity (f cos cos = D G / 4) at normal incidence; both for m = n, where D
                    // peaks in the paper's range (Beckmann alpha <= 1/sqrt(2), GGX alpha <= 1).
                    const bool dPeaksAtN = d == MicrofacetType::GGX || a <= 0.7072f;
                    CHECK(maxRatio > 0.5);
                    if (!dPeaksAtN) {
                    } else if (m == MaskingModel::Smith) {
                        const float c = 1e-3f * a, s = safeSqrt(1.f - c * c);
                        const Vec3 wo(s, 0.f, c), wi(-s, 0.f, c);
                        CHECK(microfacetReflection(mf, wo, wi) / bound > 0.99f);
                    } else {
                        const Vec3 n(0.f, 0.f, 1.f);
                        CHECK(boundedQuantity(m, n, n, microfacetReflection(mf, n, n)) / bound > 0.99f);
                        // ... while the V-cavity f itself is unbounded (G = 1 for m = n):
                        const float c = 1e-2f, s = safeSqrt(1.f - c * c);
                        CHECK(microfacetReflection(mf, Vec3(s, 0.f, c), Vec3(-s, 0.f, c)) > 100.f * bound);
                    }
                    // The real rough conductor with a perfect-mirror Fresnel (eta 0, k 1): f <= rho_bar.
                    if (m == MaskingModel::Smith) {
                        const BxdfPtr b = makeRoughConductor(d, a, a, Color(0.f), Color(1.f), Color(1.f), m);
                        Rng r2(99, 1);
                        double mr = 0;
                        for (int k = 0; k < 20000; ++k) {
                            const Vec3 wo = randomDir(r2, 1.f);
                            const Vec3 wi = reflectAbout(wo, mf.sampleD(r2.uniform2()));
                            if (wi.z > 0.f) mr = std::max(mr, double(b->eval(wo, wi, TransportMode::Radiance).f.x / bound));
                        }
                        CHECK(mr <= 1.0 + 1e-4);
                        CHECK(mr > 0.0);
                    }
                }
                // ---- Refraction (1 - F = 1), both relative IORs and both modes ----
                for (float eta : {1.5f, 1.f / 1.5f, 1.1f})
                    for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
                        const float bound = maxValueBound(d, m, a, true, eta);
                        Rng rng(777, uint64_t(a * 1e4f) + uint64_t(eta * 100));
                        double maxRatio = 0;
                        int nonzero = 0;
                        for (int k = 0; k < 60000; ++k) {
                            const float side = (k & 1) ? 1.f : -1.f;
                            const Vec3 wo = randomDir(rng, side);
                            Vec3 wi;
                            if (k % 3 == 0) {
                                wi = randomDir(rng, -side);
                            } else {  // refract about a normal drawn from D (the peak region)
                                const Vec3 n = mf.sampleD(rng.uniform2());
                                if (!refractAbout(wo, n, eta, wi) || !(wi.z * side < 0.f)) continue;
                            }
                            const float f = microfacetTransmission(mf, wo, wi, eta, mode);
                            REQUIRE(std::isfinite(f));
                            if (f > 0.f) ++nonzero;
                            maxRatio = std::max(maxRatio, double(boundedQuantity(m, wo, wi, f) / bound));
                        }
                        INFO(distName(d) << " " << maskName(m) << " alpha=" << a << " eta=" << eta << " mode=" << int(mode)
                                         << " transmission: max/rho_bar=" << maxRatio << " rho_bar=" << bound);
                        CHECK(nonzero > 1000);
                        CHECK(maxRatio <= 1.0 + 1e-4);
                        if (m == MaskingModel::VCavity && (d == MicrofacetType::GGX || a <= 0.7072f)) {
                            // Tight at normal incidence in the mode whose n factor is max(n)^2.
                            const Vec3 up(0.f, 0.f, 1.f), dn(0.f, 0.f, -1.f);
                            const float best = std::max(microfacetTransmission(mf, up, dn, eta, mode),
                                                        microfacetTransmission(mf, dn, up, eta, mode));
                            CHECK(best / bound > 0.99f);
                        }
                    }
            }
}

TEST_CASE("rho_bar matches JG19 Eqs 8-9 in the paper range", "[bound]") {
    const double pi = 3.14159265358979323846;
    for (double a : {0.01, 0.1, 0.3, 0.7}) {
        const double inv = 1.0 / (4.0 * pi * a * a);
        CHECK(maxValueBound(MicrofacetType::GGX, MaskingModel::VCavity, float(a), false, 1.5f) == Approx(inv).epsilon(1e-5));
        CHECK(maxValueBound(MicrofacetType::GGX, MaskingModel::Smith, float(a), false, 1.5f) == Approx(inv * 4.0 / (a * a)).epsilon(1e-5));
        CHECK(maxValueBound(MicrofacetType::Beckmann, MaskingModel::Smith, float(a), false, 1.5f) == Approx(inv * 4.0 * pi / (a * a)).epsilon(1e-5));
        CHECK(maxValueBound(MicrofacetType::Beckmann, MaskingModel::VCavity, float(a), false, 1.5f) == Approx(inv).epsilon(1e-5));
        // Eq. 9: max(n_i, n_t)^2 / (pi alpha^2 (n_i - n_t)^2) G_bar, here with n = 1 and 1.5.
        const double t = 2.25 / (pi * a * a * 0.25);
        CHECK(maxValueBound(MicrofacetType::GGX, MaskingModel::VCavity, float(a), true, 1.5f) == Approx(t).epsilon(1e-5));
        CHECK(maxValueBound(MicrofacetType::GGX, MaskingModel::Smith, float(a), true, 1.5f) == Approx(t * 4.0 / (a * a)).epsilon(1e-5));
        CHECK(maxValueBound(MicrofacetType::Beckmann, MaskingModel::Smith, float(a), true, 1.f / 1.5f) ==
              Approx(t * 4.0 * pi / (a * a)).epsilon(1e-5));
    }
    CHECK(std::isinf(maxValueBound(MicrofacetType::GGX, MaskingModel::Smith, 0.1f, true, 1.f)));
    CHECK(std::isinf(maxValueBound(MicrofacetType::GGX, MaskingModel::Smith, 0.f, false, 1.5f)));
}

TEST_CASE("alpha_hat inverts rho_bar and both are monotone on 1e-3 to 1", "[bound]") {
    for (auto d : kDists)
        for (auto m : kMasks)
            for (int lobe = 0; lobe < 4; ++lobe) {
                const bool trans = lobe > 0;
                const float eta = lobe == 1 ? 1.5f : lobe == 2 ? 1.f / 1.5f : 1.2f;
                double prevRho = kInf, prevAlpha = 0, worst = 0;
                bool monotone = true;
                for (int k = 0; k <= 400; ++k) {
                    const float a = std::pow(10.f, -3.f + 3.f * k / 400.f);
                    const float rho = maxValueBound(d, m, a, trans, eta);
                    const float ah = alphaForBound(d, m, rho, trans, eta);
                    worst = std::max(worst, std::abs(double(ah) - a) / a);
                    if (!(rho < prevRho)) monotone = false;
                    if (!(ah > prevAlpha)) monotone = false;  // alpha_hat decreasing in tau
                    prevRho = rho;
                    prevAlpha = ah;
                }
                INFO(distName(d) << " " << maskName(m) << " transmission=" << trans << " eta=" << eta
                                 << " worst relative inversion error=" << worst);
                CHECK(worst <= 1e-3);
                CHECK(monotone);
                // Out of range: tau below rho_bar(1) gives 1, tau = inf gives 0, eta = 1 gives 1.
                CHECK(alphaForBound(d, m, 0.5f * maxValueBound(d, m, 1.f, trans, eta), trans, eta) == 1.f);
                CHECK(alphaForBound(d, m, kInf, trans, eta) == 0.f);
            }
    CHECK(alphaForBound(MicrofacetType::GGX, MaskingModel::Smith, 10.f, true, 1.f) == 1.f);
    // Regularisation of a BSDF with alpha_hat keeps its maximum value below tau (Smith).
    const float tau = 50.f;
    const float ah = alphaForBound(MicrofacetType::GGX, MaskingModel::Smith, tau, false, 1.f);
    const Microfacet mf(MicrofacetType::GGX, ah, ah);
    const float c = 1e-4f * ah, s = safeSqrt(1.f - c * c);
    const float fPeak = microfacetReflection(mf, Vec3(s, 0.f, c), Vec3(-s, 0.f, c));
    CHECK(fPeak <= tau * (1.f + 1e-4f));
    CHECK(fPeak > 0.99f * tau);
}
