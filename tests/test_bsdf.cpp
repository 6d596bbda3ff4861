// Tests of the materials library: sampling vs pdf (chi-square), pdf normalisation, sample
// weights, reciprocity, reverse pdfs, energy conservation, delta lobes and hard numerics.
//
// Statistical tests and their levels:
// * Chi-square tests: the family of ALL chi-square tests in this file has a significance of 1%,
//   Sidak-corrected per test (level = 1 - 0.99^(1/m), m = number of chi-square tests, ~5e-5). With
//   fixed seeds the outcome is deterministic; a correct sampler fails the family with
//   probability <= 1% over seeds, a wrong one fails with overwhelming probability at these
//   sample counts (200k-400k per test).
// * Monte Carlo means (white furnace, Fresnel lobe frequencies, lost fractions) are compared
//   with z = 5 standard errors (two-sided normal tail 5.7e-7 per check; with a few hundred checks
//   the family-wise false-alarm probability stays < 1e-3).
#include <catch2/catch.hpp>

#include <cstdio>
#include <optional>

#include "bsdf/bsdf.h"
#include "bsdf/fresnel.h"
#include "bsdf/ior.h"
#include "bsdf/microfacet.h"
#include "bsdf/roughness_bound.h"
#include "chi2.h"
#include "microfacet_models.h"
#include "core/rng.h"
#include "core/sampling.h"

using namespace lt;
using namespace lt::test;

namespace {

constexpr float kPhiO = 0.7f;  // azimuth of wo in most tests: not aligned with the anisotropy axes
const Color kCuEta(0.200438f, 0.924033f, 1.10221f), kCuK(3.91295f, 2.45285f, 2.14219f);

// The request of a minimum alpha (none when not given).
RegularizationRequest minAlphaRequest(const std::optional<Roughness>& minAlpha) {
    RegularizationRequest r;
    if (minAlpha) r.minAlpha = *minAlpha;
    return r;
}

Vec3 dirDeg(float thetaDeg, float phi = kPhiO) {
    const float t = glm::radians(thetaDeg);
    return {std::sin(t) * std::cos(phi), std::sin(t) * std::sin(phi), std::cos(t)};
}
std::string fmtCase(const char* what, MicrofacetType t, MaskingModel m, Vec2 a, float thetaDeg, float eta = 0.f) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "%s %s %s alpha=(%g,%g) theta=%g eta=%g", what, distName(t), maskName(m), a.x, a.y,
                  thetaDeg, eta);
    return buf;
}

const Vec2 kAlphas[] = {{0.01f, 0.01f}, {0.1f, 0.1f}, {0.5f, 0.5f}, {1.f, 1.f}, {0.05f, 0.3f}};
const float kThetas[] = {0.f, 45.f, 85.f};

// ---- Chi-square cases --------------------------------------------------------------------
struct Chi2Case {
    std::string name;
    BxdfPtr bxdf;
    Vec3 wo;
    std::optional<Roughness> rough;  // a minimum-alpha request (bsdf.h), if any
    long long n;
};

std::vector<Chi2Case> diffuseCases() {
    std::vector<Chi2Case> c;
    for (float t : kThetas) c.push_back({"diffuse theta=" + std::to_string(t), makeDiffuse(Color(0.8f)), dirDeg(t), {}, 200000});
    Vec3 below = dirDeg(45.f);
    below.z = -below.z;
    c.push_back({"twosided(diffuse) from below", makeTwoSided(makeDiffuse(Color(0.5f))), below, {}, 200000});
    return c;
}

std::vector<Chi2Case> conductorCases() {
    std::vector<Chi2Case> c;
    for (auto d : kDists)
        for (auto m : kMasks)
            for (Vec2 a : kAlphas)
                for (float t : kThetas)
                    c.push_back({fmtCase("roughconductor", d, m, a, t),
                                 makeRoughConductor(d, a.x, a.y, kCuEta, kCuK, Color(1.f), m), dirDeg(t), {}, 250000});
    Vec3 below = dirDeg(30.f);
    below.z = -below.z;
    c.push_back({"twosided(roughconductor GGX 0.3) from below",
                 makeTwoSided(makeRoughConductor(MicrofacetType::GGX, 0.3f, 0.3f, kCuEta, kCuK, Color(1.f))), below, {},
                 250000});
    c.push_back({"conductor (smooth) with minimum alpha (0.2,0.1)", makeConductor(kCuEta, kCuK, Color(1.f)),
                 dirDeg(45.f), Roughness{0.2f, 0.1f}, 250000});
    return c;
}

std::vector<Chi2Case> dielectricCases() {
    std::vector<Chi2Case> c;
    for (auto d : kDists)
        for (auto m : kMasks)
            for (Vec2 a : kAlphas)
                for (float t : kThetas)
                    for (float eta : {1.5f, 1.f / 1.5f})
                        c.push_back({fmtCase("roughdielectric", d, m, a, t, eta),
                                     makeRoughDielectric(d, a.x, a.y, eta, Color(1.f), Color(1.f), m), dirDeg(t), {},
                                     300000});
    // From inside the medium (wo.z < 0).
    for (auto d : kDists)
        for (auto m : kMasks)
            for (float a : {0.1f, 0.5f}) {
                Vec3 wo = dirDeg(45.f);
                wo.z = -wo.z;
                c.push_back({fmtCase("roughdielectric (inside)", d, m, Vec2(a), 135.f, 1.5f),
                             makeRoughDielectric(d, a, a, 1.5f, Color(1.f), Color(1.f), m), wo, {}, 300000});
            }
    c.push_back({"dielectric (smooth) with minimum alpha (0.15,0.15)", makeDielectric(1.5f), dirDeg(30.f),
                 Roughness{0.15f, 0.15f}, 300000});
    return c;
}

int totalChi2Tests() {
    static const int n = int(diffuseCases().size() + conductorCases().size() + dielectricCases().size());
    return n;
}
// Per-test level: family-wise 1% over all chi-square tests of this file (Sidak).
double chi2Level() { return chi2::sidakCorrectedLevel(0.01, totalChi2Tests()); }

void runChi2(const Chi2Case& c, uint64_t seed) {
    const Bxdf& b = *c.bxdf;
    const RegularizationRequest r = minAlphaRequest(c.rough);
    const Vec3 wo = c.wo;
    chi2::SampleFn sampler = [&](Rng& rng, Vec3& w) {
        BsdfSample s;
        const float ul = rng.uniform();
        const Vec2 u = rng.uniform2();
        if (!b.sample(wo, ul, u, BsdfContext(TransportMode::Radiance, r), s)) return false;
        if (s.lobe & kDelta) return false;  // none of these cases has a delta lobe
        w = s.wi;
        return true;
    };
    chi2::PdfFn pdf = [&](const Vec3& w) {
        return double(b.eval(wo, w, BsdfContext(TransportMode::Radiance, r)).pdfFwd.value);
    };

    // Bin layout from an independent pilot run (other seed), so the binning does not depend on
    // the tested samples: one domain per hemisphere, centred on the lobe found there.
    const float side = wo.z >= 0.f ? 1.f : -1.f;
    chi2::Chi2Test pilot(sampler, 20000, seed ^ 0x9e3779b97f4a7c15ull);
    std::vector<Vec3> same, other;
    for (const Vec3& w : pilot.samples()) (w.z * side >= 0.f ? same : other).push_back(w);
    const chi2::LobeShape R = chi2::lobeShape(same, Vec3(-wo.x, -wo.y, wo.z));
    const chi2::LobeShape T = chi2::lobeShape(other, -wo);
    std::vector<chi2::Region> regions;
    if (b.flags() & kTransmission) {
        regions.push_back({chi2::Domain(R.axis, 0.5 * R.scale, 40, 80), [side](const Vec3& w) { return w.z * side >= 0.f; }});
        regions.push_back({chi2::Domain(T.axis, 0.5 * T.scale, 40, 80), nullptr});
    } else {
        regions.push_back({chi2::Domain(R.axis, 0.5 * R.scale, 40, 80), nullptr});
    }

    chi2::Chi2Test test(sampler, c.n, seed);
    const chi2::Result res = test.run(pdf, regions, chi2Level());
    INFO(c.name << ": " << res.summary());
    CHECK(res.samplesInZeroBins == 0);
    CHECK(res.pValue >= res.significance);
    // The pdf integrates to at most 1, and to exactly 1 minus the probability that sample()
    // fails (directions below the horizon etc.): compare with the observed lost fraction,
    // 5 binomial standard errors + 2e-3 for the quadrature (its per-bin tolerance is far below).
    const double n = double(res.samples);
    const double lostFrac = double(res.lost) / n;
    const double se = std::sqrt(std::max(lostFrac * (1.0 - lostFrac), 1.0 / n) / n);
    CHECK(res.pdfIntegral <= 1.0 + 2e-3);
    CHECK(std::abs((1.0 - res.pdfIntegral) - lostFrac) <= 5.0 * se + 2e-3);
}

void runChi2Cases(const std::vector<Chi2Case>& cases, uint64_t seedBase) {
    for (size_t i = 0; i < cases.size(); ++i) runChi2(cases[i], seedBase + 7919 * i);
}

// ---- BSDF collections for the deterministic checks ---------------------------------------
struct Named {
    std::string name;
    BxdfPtr b;
    std::optional<Roughness> rough;  // a minimum-alpha request (bsdf.h), if any
    bool indexMatched = false;
};
std::vector<Named> nonDeltaBsdfs() {
    std::vector<Named> v;
    v.push_back({"diffuse", makeDiffuse(Color(0.7f, 0.5f, 0.3f)), {}});
    v.push_back({"twosided(diffuse)", makeTwoSided(makeDiffuse(Color(0.7f))), {}});
    for (auto d : kDists)
        for (auto m : kMasks)
            for (Vec2 a : {Vec2(0.01f), Vec2(0.3f), Vec2(0.05f, 0.3f), Vec2(1.f)}) {
                v.push_back({fmtCase("roughconductor", d, m, a, 0), makeRoughConductor(d, a.x, a.y, kCuEta, kCuK, Color(1.f), m), {}});
                for (float eta : {1.5f, 1.f / 1.5f})
                    v.push_back({fmtCase("roughdielectric", d, m, a, 0, eta),
                                 makeRoughDielectric(d, a.x, a.y, eta, Color(0.9f), Color(0.8f), m), {}});
            }
    v.push_back({"twosided(roughconductor)", makeTwoSided(makeRoughConductor(MicrofacetType::Beckmann, 0.2f, 0.2f, kCuEta, kCuK, Color(1.f))), {}});
    v.push_back({"conductor+minAlpha", makeConductor(kCuEta, kCuK, Color(1.f)), Roughness{0.2f, 0.2f}});
    v.push_back({"dielectric+minAlpha", makeDielectric(1.33f), Roughness{0.1f, 0.3f}});
    return v;
}

bool close(float a, float b, float rel, float abs = 0.f) {
    return std::abs(a - b) <= abs + rel * std::max(std::abs(a), std::abs(b));
}
bool close(const Color& a, const Color& b, float rel, float abs = 0.f) {
    return close(a.x, b.x, rel, abs) && close(a.y, b.y, rel, abs) && close(a.z, b.z, rel, abs);
}

}  // namespace

// ------------------------------------------------------------------------------------------
TEST_CASE("chi2 diffuse and twosided diffuse", "[bsdf][chi2]") { runChi2Cases(diffuseCases(), 1000); }
TEST_CASE("chi2 rough conductor GGX and Beckmann with Smith and V-cavity", "[bsdf][chi2]") { runChi2Cases(conductorCases(), 2000); }
TEST_CASE("chi2 rough dielectric GGX and Beckmann with Smith and V-cavity", "[bsdf][chi2]") { runChi2Cases(dielectricCases(), 3000); }

TEST_CASE("microfacet D and the visible-normal pdf integrate to 1", "[bsdf][microfacet]") {
    // Deterministic quadrature; tolerance 2e-3 covers the quadrature error (per-bin 1e-7 over
    // 3200 bins) with a wide margin, while a wrong normalisation (e.g. a missing factor in
    // Lambda) moves the integrals by far more.
    for (auto d : kDists)
        for (auto m : kMasks)
            for (Vec2 a : {Vec2(0.01f), Vec2(0.1f), Vec2(0.5f), Vec2(1.f), Vec2(0.05f, 0.3f)}) {
                const Microfacet mf(d, a.x, a.y, m);
                const chi2::Domain dom(Vec3(0, 0, 1), 0.5 * std::min(a.x, a.y), 40, 80);
                const double iD = chi2::Chi2Test::integrateSphere([&](const Vec3& n) { return double(mf.pdfD(n)); }, dom, 1e-7);
                INFO(fmtCase("D cos", d, m, a, 0) << " integral=" << iD);
                CHECK(std::abs(iD - 1.0) < 2e-3);
                for (float t : {0.f, 45.f, 85.f, 89.f}) {
                    const Vec3 w = dirDeg(t);
                    const double iV = chi2::Chi2Test::integrateSphere([&](const Vec3& n) { return double(mf.pdfVisible(w, n)); }, dom, 1e-7);
                    INFO(fmtCase("D_w", d, m, a, t) << " integral=" << iV);
                    CHECK(std::abs(iV - 1.0) < 2e-3);
                }
            }
}

TEST_CASE("diffuse pdf integrates to 1", "[bsdf]") {
    const BxdfPtr b = makeDiffuse(Color(0.5f));
    const Vec3 wo = dirDeg(30.f);
    const chi2::Domain dom(Vec3(0, 0, 1), 1.0, 40, 80);
    const double I = chi2::Chi2Test::integrateSphere(
        [&](const Vec3& w) { return double(b->eval(wo, w, TransportMode::Radiance).pdfFwd.value); }, dom, 1e-8);
    CHECK(std::abs(I - 1.0) < 1e-3);
}

TEST_CASE("sample weight equals f cos over pdf and pdfs agree with eval and reverse pdf equals swapped pdf", "[bsdf]") {
    for (const Named& nb : nonDeltaBsdfs()) {
        const RegularizationRequest r = minAlphaRequest(nb.rough);
        for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
            Rng rng(42, 7);
            int tested = 0, bad = 0;
            std::string firstBad;
            for (int k = 0; k < 2000; ++k) {
                const Vec3 wo = sampleUniformSphere(rng.uniform2());
                BsdfSample s;
                const float ul = rng.uniform();
                const Vec2 u = rng.uniform2();
                if (!nb.b->sample(wo, ul, u, BsdfContext(mode, r), s)) continue;
                if (s.lobe & kDelta) continue;
                const BsdfEval e = nb.b->eval(wo, s.wi, BsdfContext(mode, r));
                const BsdfEval rev = nb.b->eval(s.wi, wo, BsdfContext(mode, r));
                ++tested;
                const Color expect = e.f * std::abs(s.wi.z) / e.pdfFwd.value;
                const bool ok = isFinite(s.weight) && e.pdfFwd.value > 0.f &&
                                close(e.pdfFwd.value, s.pdfFwd.value, 1e-4f) &&
                                close(e.pdfRev.value, s.pdfRev.value, 1e-4f) &&
                                close(e.pdfRev.value, rev.pdfFwd.value, 1e-4f) &&
                                close(e.pdfFwd.value, rev.pdfRev.value, 1e-4f) &&
                                close(s.weight, expect, 2e-3f, 1e-6f);
                if (!ok && bad++ == 0) {
                    char buf[400];
                    std::snprintf(buf, sizeof buf,
                                  "wo=(%g,%g,%g) wi=(%g,%g,%g) weight=(%g,%g,%g) f*cos/pdf=(%g,%g,%g) pdf s/e=%g/%g "
                                  "rev s/e/swapped=%g/%g/%g",
                                  wo.x, wo.y, wo.z, s.wi.x, s.wi.y, s.wi.z, s.weight.x, s.weight.y, s.weight.z, expect.x,
                                  expect.y, expect.z, s.pdfFwd.value, e.pdfFwd.value, s.pdfRev.value, e.pdfRev.value,
                                  rev.pdfFwd.value);
                    firstBad = buf;
                }
            }
            INFO(nb.name << " mode=" << int(mode) << " first mismatch: " << firstBad);
            CHECK(tested > 300);
            CHECK(bad == 0);
        }
    }
}

TEST_CASE("a direction-only sample draws the full sample's direction, and refuses only what it refuses", "[bsdf]") {
    // BsdfContext::directionOnly (OPSR's regularised sample in the path tracer draws the direction
    // first and the rest only where its ray may reach a light): with the same numbers, every
    // full sample's direction is the direction-only sample's, bit for bit, and a direction-only
    // sample that fails means a full sample that fails. Each BSDF with and without a request, and
    // the smooth ones with their requests (the delta lobes ignore the flag).
    std::vector<Named> bsdfs = nonDeltaBsdfs();
    bsdfs.push_back({"conductor", makeConductor(kCuEta, kCuK, Color(1.f)), {}});
    bsdfs.push_back({"dielectric", makeDielectric(1.5f), {}});
    for (const Named& nb : bsdfs) {
        INFO(nb.name);
        for (const std::optional<Roughness>& rough : {nb.rough, std::optional<Roughness>(Roughness{0.4f, 0.4f})}) {
            const BsdfContext ctx(TransportMode::Radiance, minAlphaRequest(rough));
            Rng rng(5, 9);
            int drawn = 0, refusedLater = 0;
            for (int k = 0; k < 4000; ++k) {
                const Vec3 wo = sampleUniformSphere(rng.uniform2());
                const float ul = rng.uniform();
                const Vec2 u = rng.uniform2();
                BsdfSample d, f;
                const bool direction = nb.b->sample(wo, ul, u, ctx.directionOnlyCopy(), d);
                const bool full = nb.b->sample(wo, ul, u, ctx, f);
                if (!direction) {
                    CHECK_FALSE(full);
                    continue;
                }
                if (!full) {
                    ++refusedLater;
                    continue;
                }
                ++drawn;
                CHECK(d.wi.x == f.wi.x);
                CHECK(d.wi.y == f.wi.y);
                CHECK(d.wi.z == f.wi.z);
            }
            INFO(refusedLater << " direction-only samples whose full sample was refused");
            CHECK(drawn > 1000);
        }
    }
}

// A smooth material made rough with energy compensation (bsdf/energy_compensation.h) is not
// reciprocal by design (its value depends on the light side's cosine): there the adjoint relation
// f_rad(wo, wi) = f_imp(wi, wo), what the path space needs, is checked, and the uncompensated
// request is held to reciprocity.
TEST_CASE("reciprocity of reflection and adjoint relation of refraction", "[bsdf]") {
    for (const Named& nb : nonDeltaBsdfs())
      for (bool compensate : {true, false}) {
        RegularizationRequest r = minAlphaRequest(nb.rough);
        r.compensate = compensate;
        const bool adjointOnly = nb.b->isDelta() && !r.empty() && compensate;
        if (!compensate && !nb.b->isDelta()) continue;  // (the flag changes nothing there)
        Rng rng(5, 11);
        int refl = 0, refr = 0, bad = 0;
        std::string firstBad;
        for (int k = 0; k < 3000; ++k) {
            const Vec3 wo = sampleUniformSphere(rng.uniform2());
            BsdfSample s;
            const float ul = rng.uniform();
            const Vec2 u = rng.uniform2();
            if (!nb.b->sample(wo, ul, u, BsdfContext(TransportMode::Radiance, r), s) || (s.lobe & kDelta)) continue;
            const Vec3 wi = s.wi;
            const Color fR = nb.b->eval(wo, wi, BsdfContext(TransportMode::Radiance, r)).f;
            const Color fRswap = nb.b->eval(wi, wo, BsdfContext(TransportMode::Radiance, r)).f;
            const Color fIswap = nb.b->eval(wi, wo, BsdfContext(TransportMode::Importance, r)).f;
            const Color fI = nb.b->eval(wo, wi, BsdfContext(TransportMode::Importance, r)).f;
            bool ok;
            if (adjointOnly) {
                (wo.z * wi.z > 0.f ? refl : refr)++;
                ok = close(fR, fIswap, 1e-4f, 1e-7f);
            } else if (wo.z * wi.z > 0.f) {
                ++refl;
                ok = close(fR, fRswap, 1e-4f, 1e-7f) && close(fR, fI, 1e-6f);
            } else {
                ++refr;
                // Adjoint: f_rad(wo, wi) = f(wi -> wo) = f_imp(wi, wo).
                // Generalised reciprocity f(wi -> wo) / n_wo^2 = f(wo -> wi) / n_wi^2, i.e.
                // f_rad(wi, wo) = f_rad(wo, wi) etap^2 with etap = n_wi / n_wo = s.eta, and the
                // Importance value (no 1/etap^2 scaling) f_imp(wo, wi) = f_rad(wo, wi) etap^2.
                const float etap2 = s.eta * s.eta;
                ok = s.eta != 1.f && close(fR, fIswap, 1e-4f, 1e-7f) && close(fR * etap2, fI, 1e-4f, 1e-7f) &&
                     close(fR * etap2, fRswap, 1e-4f, 1e-7f);
            }
            if (!ok && bad++ == 0) {
                char buf[300];
                std::snprintf(buf, sizeof buf, "wo=(%g,%g,%g) wi=(%g,%g,%g) fR=%g fRswap=%g fI=%g fIswap=%g eta=%g", wo.x, wo.y,
                              wo.z, wi.x, wi.y, wi.z, fR.x, fRswap.x, fI.x, fIswap.x, s.eta);
                firstBad = buf;
            }
        }
        INFO(nb.name << (compensate ? "" : " uncompensated") << " first mismatch: " << firstBad << " (reflection pairs "
                     << refl << ", refraction pairs " << refr << ")");
        CHECK(refl + refr > 300);
        if (nb.b->flags() & kTransmission) CHECK(refr > 100);
        CHECK(bad == 0);
      }
}

TEST_CASE("refraction is not reciprocal between modes with eta squared scaling in Radiance only", "[bsdf]") {
    const BxdfPtr b = makeRoughDielectric(MicrofacetType::GGX, 0.3f, 0.3f, 1.5f);
    const Vec3 wo = dirDeg(30.f);
    const Vec3 wi = glm::normalize(Vec3(-0.2f, -0.1f, -1.f));
    const float fR = b->eval(wo, wi, TransportMode::Radiance).f.x;
    const float fI = b->eval(wo, wi, TransportMode::Importance).f.x;
    REQUIRE(fR > 0.f);
    // wo outside (n = 1), wi inside (n = 1.5): radiance entering from inside towards the
    // outside is divided by (n_wi/n_wo)^2 = 2.25.
    CHECK(fI / fR == Approx(2.25f).epsilon(1e-4));
}

TEST_CASE("white furnace sampled albedo at most 1", "[bsdf]") {
    std::vector<Named> all = nonDeltaBsdfs();
    all.push_back({"conductor Cu (smooth)", makeConductor(kCuEta, kCuK, Color(1.f)), {}});
    all.push_back({"conductor none (smooth)", makeConductor(Color(0.f), Color(1.f), Color(1.f)), {}});
    all.push_back({"dielectric 1.5 (smooth)", makeDielectric(1.5f), {}});
    all.push_back({"dielectric 1/1.5 (smooth)", makeDielectric(1.f / 1.5f), {}});
    for (auto d : kDists)
        for (auto m : kMasks)
            for (float a : {0.05f, 0.5f, 1.f}) {
                all.push_back({fmtCase("roughconductor none", d, m, Vec2(a), 0),
                               makeRoughConductor(d, a, a, Color(0.f), Color(1.f), Color(1.f), m), {}});
                all.push_back({fmtCase("roughdielectric white", d, m, Vec2(a), 0, 1.5f),
                               makeRoughDielectric(d, a, a, 1.5f, Color(1.f), Color(1.f), m), {}});
            }
    const int n = 40000;
    for (const Named& nb : all) {
        const RegularizationRequest r = minAlphaRequest(nb.rough);
        for (float t : {0.f, 30.f, 60.f, 80.f, 89.f})
            for (float side : {1.f, -1.f}) {
                Vec3 wo = dirDeg(t);
                wo.z *= side;
                // Energy conservation concerns light arriving from wo and scattered into all wi:
                // the integral of f(wo -> wi) |cos wi|, i.e. the Importance-mode value. (In
                // Radiance mode refraction into the thinner medium scales by eta^2 > 1 and the
                // "albedo" legitimately exceeds 1.)
                Rng rng(uint64_t(t * 10 + side), 3);
                double sum[3] = {0, 0, 0}, sum2[3] = {0, 0, 0};
                for (int k = 0; k < n; ++k) {
                    BsdfSample s;
                    const float ul = rng.uniform();
                    const Vec2 u = rng.uniform2();
                    if (!nb.b->sample(wo, ul, u, BsdfContext(TransportMode::Importance, r), s)) continue;
                    for (int c = 0; c < 3; ++c) {
                        sum[c] += s.weight[c];
                        sum2[c] += double(s.weight[c]) * s.weight[c];
                    }
                }
                for (int c = 0; c < 3; ++c) {
                    const double mean = sum[c] / n;
                    const double se = std::sqrt(std::max(0.0, sum2[c] / n - mean * mean) / n);
                    INFO(nb.name << " theta=" << t << " side=" << side << " channel " << c << " albedo=" << mean << " +- " << se);
                    CHECK(mean <= 1.0 + 5.0 * se + 1e-6);
                }
            }
    }
    // Lower bounds: the test above must not pass by returning nothing. A mirror-like Smith GGX
    // perfect conductor at alpha 0.05 loses < 1% at normal incidence; a smooth dielectric
    // conserves energy exactly (every weight is 1 in Importance mode).
    {
        const BxdfPtr b = makeRoughConductor(MicrofacetType::GGX, 0.05f, 0.05f, Color(0.f), Color(1.f), Color(1.f));
        Rng rng(9, 9);
        double sum = 0;
        for (int k = 0; k < n; ++k) {
            BsdfSample s;
            const float ul = rng.uniform();
            const Vec2 u = rng.uniform2();
            if (b->sample(dirDeg(0.f), ul, u, TransportMode::Importance, s)) sum += s.weight.x;
        }
        CHECK(sum / n > 0.99);
        const BxdfPtr g = makeDielectric(1.5f);
        for (float t : {0.f, 40.f, 80.f})
            for (int k = 0; k < 100; ++k) {
                BsdfSample s;
                REQUIRE(g->sample(dirDeg(t), rng.uniform(), rng.uniform2(), TransportMode::Importance, s));
                CHECK(s.weight.x == Approx(1.f).epsilon(1e-6));
            }
    }
}

TEST_CASE("smooth dielectric Fresnel-weighted lobe choice and directions and weights", "[bsdf][delta]") {
    for (float eta : {1.5f, 1.f / 1.5f, 1.33f})
        for (float t : {0.f, 30.f, 60.f, 85.f})
            for (float side : {1.f, -1.f}) {
                const BxdfPtr b = makeDielectric(eta, Color(0.9f), Color(0.7f));
                Vec3 wo = dirDeg(t);
                wo.z *= side;
                const float etaRel = side > 0 ? eta : 1.f / eta;  // n(wi side, after refraction) / n(wo side)
                float cosT;
                const float F = fresnelDielectric(std::abs(wo.z), etaRel, &cosT);
                Rng rng(uint64_t(t * 100 + eta * 7 + side), 1);
                const int n = 100000;
                int nRefl = 0;
                for (int k = 0; k < n; ++k) {
                    BsdfSample s;
                    REQUIRE(b->sample(wo, rng.uniform(), rng.uniform2(), TransportMode::Radiance, s));
                    REQUIRE((s.lobe & kDelta));
                    CHECK(b->eval(wo, s.wi, TransportMode::Radiance).f == Color(0.f));
                    if (s.lobe & kReflection) {
                        ++nRefl;
                        if (k < 50) {
                            CHECK(close(s.wi, Vec3(-wo.x, -wo.y, wo.z), 1e-5f, 1e-6f));
                            CHECK(close(s.weight, Color(0.9f), 1e-5f));
                            CHECK(s.pdfFwd.value == Approx(F));
                            CHECK(s.eta == 1.f);
                        }
                    } else if (k < 50) {
                        // Snell: n_o sin_o = n_i sin_i, opposite side, same plane of incidence.
                        const float sinO = std::hypot(wo.x, wo.y), sinI = std::hypot(s.wi.x, s.wi.y);
                        CHECK(sinO == Approx(etaRel * sinI).margin(1e-5));
                        CHECK(s.wi.z * wo.z < 0.f);
                        CHECK(s.eta == Approx(etaRel));
                        CHECK(s.pdfFwd.value == Approx(1.f - F));
                        CHECK(close(s.weight, Color(0.7f / (etaRel * etaRel)), 1e-5f));
                        BsdfSample si;
                        REQUIRE(b->sample(wo, 0.999999f, Vec2(0.5f), TransportMode::Importance, si));
                        if (si.lobe & kTransmission) CHECK(close(si.weight, Color(0.7f), 1e-5f));
                    }
                }
                // Reflection frequency ~ Binomial(n, F): 5 standard errors (see top).
                const double se = std::sqrt(std::max(double(F) * (1.0 - F), 1e-12) / n);
                INFO("eta=" << eta << " theta=" << t << " side=" << side << " F=" << F << " freq=" << double(nRefl) / n);
                CHECK(std::abs(double(nRefl) / n - F) <= 5.0 * se + 1e-9);
            }
}

TEST_CASE("smooth conductor mirror direction and Fresnel weight and no eval", "[bsdf][delta]") {
    const BxdfPtr cu = makeConductor(kCuEta, kCuK, Color(1.f));
    const BxdfPtr mirror = makeConductor(Color(0.f), Color(1.f), Color(0.5f));
    for (float t : {0.f, 45.f, 89.f}) {
        const Vec3 wo = dirDeg(t);
        BsdfSample s;
        REQUIRE(cu->sample(wo, 0.3f, Vec2(0.2f, 0.7f), TransportMode::Radiance, s));
        CHECK((s.lobe & kDelta));
        CHECK(close(s.wi, Vec3(-wo.x, -wo.y, wo.z), 1e-6f));
        CHECK(close(s.weight, fresnelConductor(wo.z, kCuEta, kCuK), 1e-6f));
        CHECK(s.weight.x > s.weight.z);  // copper is reddish
        CHECK(cu->eval(wo, s.wi, TransportMode::Radiance).f == Color(0.f));
        REQUIRE(mirror->sample(wo, 0.3f, Vec2(0.2f, 0.7f), TransportMode::Radiance, s));
        CHECK(close(s.weight, Color(0.5f), 1e-6f));
    }
    BsdfSample s;
    CHECK_FALSE(cu->sample(Vec3(0, 0, -1), 0.5f, Vec2(0.5f), TransportMode::Radiance, s));
}

TEST_CASE("Fresnel equations", "[bsdf][fresnel]") {
    CHECK(fresnelDielectric(1.f, 1.5f) == Approx(0.04f).epsilon(1e-4));
    CHECK(fresnelDielectric(-1.f, 1.5f) == Approx(0.04f).epsilon(1e-4));
    CHECK(fresnelDielectric(0.3f, 1.f) == 0.f);
    CHECK(fresnelDielectric(0.f, 1.f) == 0.f);
    CHECK(fresnelDielectric(0.f, 1.5f) == Approx(1.f));
    // TIR from inside beyond the critical angle (sin = 1/1.5).
    CHECK(fresnelDielectric(-std::cos(std::asin(1.f / 1.5f) + 0.01f), 1.5f) == 1.f);
    CHECK(fresnelDielectric(-std::cos(std::asin(1.f / 1.5f) - 0.01f), 1.5f) < 1.f);
    // Reciprocity of the Fresnel reflectance across a refraction pair.
    float cosT;
    const float F = fresnelDielectric(0.6f, 1.5f, &cosT);
    CHECK(cosT < 0.f);
    CHECK(fresnelDielectric(cosT, 1.5f) == Approx(F).epsilon(1e-5));
    // Conductor formula with k = 0 reduces to the dielectric one; eta = 0, k = 1 is a perfect mirror.
    for (float c : {0.05f, 0.3f, 0.7f, 1.f}) {
        CHECK(fresnelConductor(c, 1.5f, 0.f) == Approx(fresnelDielectric(c, 1.5f)).epsilon(1e-4));
        CHECK(fresnelConductor(c, 0.f, 1.f) == 1.f);
    }
    // Normal incidence: ((n-1)^2 + k^2) / ((n+1)^2 + k^2).
    CHECK(fresnelConductor(1.f, 0.2f, 3.9f) == Approx((0.64f + 3.9f * 3.9f) / (1.44f + 3.9f * 3.9f)).epsilon(1e-4));
}

TEST_CASE("regularisation request (minimum alpha) and delta threshold", "[bsdf]") {
    const Vec3 wo = dirDeg(30.f), wi = glm::normalize(Vec3(-0.4f, -0.3f, 0.8f));
    const BxdfPtr smooth = makeConductor(kCuEta, kCuK, Color(1.f));
    const BxdfPtr rough = makeRoughConductor(MicrofacetType::GGX, 0.2f, 0.2f, kCuEta, kCuK, Color(1.f));
    CHECK(RegularizationRequest{}.empty());
    CHECK(smooth->eval(wo, wi, TransportMode::Radiance).f == Color(0.f));
    // (uncompensated: the smooth conductor is then the rough one; compensated it keeps the mirror's
    // albedo, bsdf/energy_compensation.h, and its value is larger by 1 / E, its densities the same)
    BsdfContext ctx(TransportMode::Radiance, minAlphaRequest(Roughness{0.2f, 0.2f}));
    ctx.reg.compensate = false;
    CHECK_FALSE(ctx.reg.empty());
    const BsdfEval a = smooth->eval(wo, wi, ctx), b = rough->eval(wo, wi, TransportMode::Radiance);
    CHECK(a.f.x > 0.f);
    CHECK(close(a.f, b.f, 1e-6f));
    CHECK(a.pdfFwd.value == Approx(b.pdfFwd.value));
    ctx.reg.compensate = true;
    const BsdfEval ac = smooth->eval(wo, wi, ctx);
    CHECK(ac.f.x > a.f.x);
    CHECK(ac.pdfFwd.value == a.pdfFwd.value);
    // A minimum never makes a lobe smoother: below the material's alpha it changes nothing (bitwise),
    // and below kMinAlpha a smooth lobe stays a delta.
    const BsdfContext tiny(TransportMode::Radiance, minAlphaRequest(Roughness{0.5f * kMinAlpha, 0.5f * kMinAlpha}));
    const BsdfEval c = rough->eval(wo, wi, tiny);
    CHECK(c.f == b.f);
    CHECK(c.pdfFwd.value == b.pdfFwd.value);
    CHECK(c.pdfRev.value == b.pdfRev.value);
    CHECK(smooth->eval(wo, wi, tiny).f == Color(0.f));
    BsdfSample s;
    REQUIRE(smooth->sample(wo, 0.5f, Vec2(0.3f), tiny, s));
    CHECK((s.lobe & kDelta));
    // Factories: alpha below kMinAlpha gives the smooth variant.
    CHECK(makeRoughConductor(MicrofacetType::GGX, 1e-5f, 1e-5f, kCuEta, kCuK, Color(1.f))->isDelta());
    CHECK(makeRoughDielectric(MicrofacetType::Beckmann, 1e-5f, 1e-5f, 1.5f)->isDelta());
    CHECK_FALSE(rough->isDelta());
    CHECK(rough->roughness() == Approx(0.2f));
    CHECK(smooth->roughness() == 0.f);
    CHECK(makeDiffuse(Color(1.f))->roughness() == 1.f);
    // (OPSR's convention, the reference attenuation file's: an anisotropic lobe counts min(alpha_u, alpha_v))
    CHECK(makeRoughConductor(MicrofacetType::GGX, 0.1f, 0.4f, kCuEta, kCuK, Color(1.f))->roughness() == Approx(0.1f));
    CHECK(makeTwoSided(makeRoughConductor(MicrofacetType::GGX, 0.7f, 1.5f, kCuEta, kCuK, Color(1.f)))->roughness() == Approx(0.7f));
    CHECK(makeRoughDielectric(MicrofacetType::GGX, 1.2f, 2.f, 1.5f)->roughness() == 1.f);  // clamped
    CHECK(makeRoughConductor(MicrofacetType::GGX, 0.1f, 0.4f, kCuEta, kCuK, Color(1.f))->alpha().alphaV == 0.4f);
}

// A bound tau is resolved inside each lobe: alpha_hat = alphaForBound of the lobe's own
// distribution, masking, reflection or transmission and eta (the caller knows none of them).
// (each bound form; without the compensation, which changes smooth lobes' and glossy conductors'
// alpha_hat and glossy conductors' values)
TEST_CASE("regularisation request (bound tau) is resolved per lobe", "[bsdf]") {
  for (BoundForm form : {BoundForm::Published, BoundForm::Tight}) {
    const float tau = 20.f;
    auto withTau = [&](TransportMode mode) {
        RegularizationRequest r;
        r.tau = tau;
        r.bound = form;
        r.compensate = false;
        return BsdfContext(mode, r);
    };
    auto withMin = [](TransportMode mode, float a) {
        RegularizationRequest r = minAlphaRequest(Roughness{a, a});
        r.compensate = false;
        return BsdfContext(mode, r);
    };
    auto same = [](const BsdfEval& x, const BsdfEval& y) {
        return x.f == y.f && x.pdfFwd.value == y.pdfFwd.value && x.pdfRev.value == y.pdfRev.value;
    };
    const Vec3 wo = dirDeg(30.f);
    const Vec3 wr = glm::normalize(Vec3(-0.4f, -0.3f, 0.8f)), wt = glm::normalize(Vec3(-0.2f, -0.1f, -1.f));
    for (auto d : kDists)
        for (auto m : kMasks) {
            INFO(distName(d) << " " << maskName(m));
            INFO(" form " << int(form));
            const float aR = alphaForBound(d, m, tau, false, 1.5f, form), aT = alphaForBound(d, m, tau, true, 1.5f, form);
            REQUIRE(aR > 0.01f);
            // (the published transmission bound is the larger; the tight one need not be)
            if (form == BoundForm::Published) REQUIRE(aT > aR);
            const float aSample = std::max(aR, aT);
            const BxdfPtr cu = makeRoughConductor(d, 0.01f, 0.01f, kCuEta, kCuK, Color(1.f), m);
            for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
                CHECK(same(cu->eval(wo, wr, withTau(mode)), cu->eval(wo, wr, withMin(mode, aR))));
                const BxdfPtr glass = makeRoughDielectric(d, 0.01f, 0.01f, 1.5f, Color(1.f), Color(1.f), m);
                CHECK(same(glass->eval(wo, wr, withTau(mode)), glass->eval(wo, wr, withMin(mode, aR))));
                CHECK(same(glass->eval(wo, wt, withTau(mode)), glass->eval(wo, wt, withMin(mode, aT))));
                CHECK(glass->eval(wo, wt, withTau(mode)).f.x > 0.f);
                // sample() takes one alpha for both lobes (the larger alpha_hat): its pdfs are
                // those of eval with that minimum.
                BsdfSample s;
                for (float uLobe : {0.01f, 0.99f})
                    if (glass->sample(wo, uLobe, Vec2(0.3f, 0.6f), withTau(mode), s)) {
                        const BsdfEval e = glass->eval(wo, s.wi, withMin(mode, aSample));
                        CHECK(s.pdfFwd.value == e.pdfFwd.value);
                        CHECK(s.pdfRev.value == e.pdfRev.value);
                        CHECK_FALSE((s.lobe & kDelta));
                    }
            }
            // Rougher than alpha_hat already: the bound changes nothing.
            const BxdfPtr wide = makeRoughConductor(d, 0.9f, 0.9f, kCuEta, kCuK, Color(1.f), m);
            const TransportMode rad = TransportMode::Radiance;
            CHECK(same(wide->eval(wo, wr, withTau(rad)), wide->eval(wo, wr, rad)));
        }
    // A smooth dielectric under a bound becomes a rough GGX/Smith one, inside a two-sided adapter too.
    const BxdfPtr smooth = makeTwoSided(makeDielectric(1.5f));
    const float aT = alphaForBound(MicrofacetType::GGX, MaskingModel::Smith, tau, true, 1.5f, form);
    const BsdfEval e = smooth->eval(wo, wt, withTau(TransportMode::Radiance));
    CHECK(e.f.x > 0.f);
    CHECK(same(e, makeRoughDielectric(MicrofacetType::GGX, aT, aT, 1.5f)->eval(wo, wt, TransportMode::Radiance)));
    // tau = +inf is no request.
    RegularizationRequest none;
    none.tau = kInf;
    CHECK(none.empty());
  }
}

TEST_CASE("hard numerics with alpha kMinAlpha at grazing and normal incidence and eta 1", "[bsdf][numerics]") {
    std::vector<Named> v;
    for (auto d : kDists)
        for (auto m : kMasks) {
            v.push_back({fmtCase("roughconductor", d, m, Vec2(kMinAlpha), 0), makeRoughConductor(d, kMinAlpha, kMinAlpha, kCuEta, kCuK, Color(1.f), m), {}});
            v.push_back({fmtCase("roughdielectric", d, m, Vec2(kMinAlpha), 0, 1.5f), makeRoughDielectric(d, kMinAlpha, kMinAlpha, 1.5f, Color(1.f), Color(1.f), m), {}});
            v.push_back({fmtCase("roughdielectric", d, m, Vec2(kMinAlpha), 0, 1.f), makeRoughDielectric(d, kMinAlpha, kMinAlpha, 1.f, Color(1.f), Color(1.f), m), {}, true});
            v.push_back({fmtCase("roughdielectric", d, m, Vec2(0.3f), 0, 1.f), makeRoughDielectric(d, 0.3f, 0.3f, 1.f, Color(1.f), Color(1.f), m), {}, true});
        }
    v.push_back({"dielectric eta=1", makeDielectric(1.f), {}, true});
    for (const Named& nb : v)
        for (float t : {0.f, 89.9f})
            for (float side : {1.f, -1.f})
                for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
                    Vec3 wo = dirDeg(t);
                    wo.z *= side;
                    Rng rng(77, 1);
                    int ok = 0, bad = 0;
                    for (int k = 0; k < 20000; ++k) {
                        BsdfSample s;
                        if (!nb.b->sample(wo, rng.uniform(), rng.uniform2(), mode, s)) continue;
                        ++ok;
                        const BsdfEval e = nb.b->eval(wo, s.wi, mode);
                        const BsdfEval er = nb.b->eval(s.wi, wo, mode);
                        const bool finite = isFinite(s.weight) && isFinite(s.wi) && std::isfinite(s.pdfFwd.value) &&
                                            std::isfinite(s.pdfRev.value) && s.pdfFwd.value > 0.f && isFinite(e.f) &&
                                            std::isfinite(e.pdfFwd.value) && std::isfinite(e.pdfRev.value) &&
                                            isFinite(er.f) && std::isfinite(er.pdfFwd.value) && std::isfinite(s.eta) &&
                                            std::abs(glm::length(s.wi) - 1.f) < 1e-3f &&
                                            (mode == TransportMode::Radiance || maxComp(s.weight) <= 1.f + 1e-3f);
                        if (!finite) ++bad;
                    }
                    // The exact specular pair (the peak) must evaluate to finite values too.
                    const BsdfEval peak = nb.b->eval(wo, Vec3(-wo.x, -wo.y, wo.z), mode);
                    INFO(nb.name << " theta=" << t << " side=" << side << " mode=" << int(mode) << " samples ok=" << ok);
                    CHECK(bad == 0);
                    CHECK(isFinite(peak.f));
                    CHECK(std::isfinite(peak.pdfFwd.value));
                    if (nb.indexMatched) {
                        // Index matched: straight-through delta, no reflection.
                        BsdfSample s;
                        REQUIRE(nb.b->sample(wo, 0.01f, Vec2(0.3f), mode, s));
                        CHECK((s.lobe & kDelta));
                        CHECK((s.lobe & kTransmission));
                        CHECK(close(s.wi, -wo, 1e-6f));
                        CHECK(peak.f == Color(0.f));
                    }
                }
}

TEST_CASE("named IORs and conductor presets", "[bsdf][ior]") {
    CHECK(*namedIor("bk7") == Approx(1.5046f));
    CHECK(*namedIor("vacuum") == 1.f);
    CHECK(*namedIor("water") == Approx(1.333f));
    CHECK(*namedIor("diamond") == Approx(2.419f));
    CHECK(*namedIor("fused quartz") == Approx(1.458f));
    CHECK(*namedIor("acrylic glass") == Approx(1.49f));
    CHECK(*namedIor("air") == Approx(1.000277f));
    CHECK(*namedIor("amber") == Approx(1.55f));
    CHECK(*namedIor("polypropylene") == Approx(1.49f));
    CHECK(*namedIor("pet") == Approx(1.575f));
    for (const char* n : {"helium", "hydrogen", "water ice", "ethanol", "carbon tetrachloride", "benzene", "silicone oil",
                          "bromine", "sodium chloride"})
        CHECK(namedIor(n).has_value());
    CHECK_FALSE(namedIor("unobtainium").has_value());
    CHECK(namedIorList().size() >= 20);
    const auto cu = conductorPreset("Cu");
    REQUIRE(cu);
    CHECK(close(cu->eta, kCuEta, 1e-5f));
    CHECK(close(cu->k, kCuK, 1e-5f));
    for (const char* n : {"none", "Au", "Ag", "Cu", "Al", "Cr"}) CHECK(conductorPreset(n).has_value());
    const auto none = conductorPreset("none");
    CHECK(fresnelConductor(0.5f, none->eta, none->k) == Color(1.f));
    // Gold reflects red more than blue; silver and aluminium are bright at normal incidence.
    const auto au = conductorPreset("Au");
    const Color fAu = fresnelConductor(1.f, au->eta, au->k);
    CHECK(fAu.x > fAu.z);
    CHECK(luminance(fresnelConductor(1.f, conductorPreset("Ag")->eta, conductorPreset("Ag")->k)) > 0.9f);
    CHECK(luminance(fresnelConductor(1.f, conductorPreset("Al")->eta, conductorPreset("Al")->k)) > 0.85f);
}

// Russian roulette (path.h): the continuation probability is the largest channel of a lobe's
// scale, clamped to [0, 1], the same for every direction; the sampled weight of a Lambert bounce
// over it never exceeds 1 (no throughput grows).
TEST_CASE("continuation probability of each model, and Lambert weights over it are at most 1", "[bsdf][roulette]") {
    CHECK(makeDiffuse(Color(0.6f, 0.1f, 0.1f))->continuation() == 0.6f);
    CHECK(makeDiffuse(Color(1.5f, 0.2f, 0.2f))->continuation() == 1.f);
    CHECK(makeDiffuse(Color(0.f))->continuation() == 0.f);
    CHECK(makeTwoSided(makeDiffuse(Color(0.1f, 0.3f, 0.2f)))->continuation() == 0.3f);
    CHECK(makeConductor(Color(0.2f), Color(3.f), Color(0.9f, 0.5f, 0.4f))->continuation() == 0.9f);
    CHECK(makeRoughConductor(MicrofacetType::GGX, 0.3f, 0.3f, Color(0.2f), Color(3.f), Color(0.25f))->continuation() ==
          0.25f);
    CHECK(makeDielectric(1.5f)->continuation() == 1.f);
    CHECK(makeDielectric(1.5f, Color(0.2f), Color(0.7f, 0.1f, 0.1f))->continuation() == 0.7f);
    CHECK(makeRoughDielectric(MicrofacetType::Beckmann, 0.2f, 0.2f, 1.33f, Color(0.8f), Color(0.5f))->continuation() ==
          0.8f);

    const BxdfPtr d = makeDiffuse(Color(0.5f, 0.8f, 0.2f));
    Rng rng(7, 0);
    for (int i = 0; i < 1000; ++i) {
        const Vec3 wo = sampleCosineHemisphere(rng.uniform2());
        BsdfSample s;
        if (!d->sample(wo, rng.uniform(), rng.uniform2(), plainContext(TransportMode::Radiance), s)) continue;
        CHECK(maxComp(s.weight / d->continuation()) <= 1.f + 1e-6f);
    }
}
