// Tests of Mitsuba 3's thindielectric, null, polarizer (rgb), pplastic (rgb) and blendbsdf
// (bsdf/thin_dielectric.cpp, bsdf/pplastic.cpp, bsdf/blend.cpp): sampling against the pdf
// (chi-square), densities and weights in both transport modes, reciprocity and the adjoint
// relation, energy, Mitsuba's formulas, regularisation requests, the loader, and renders where
// PT, BPT and VCM must agree.
//
// Statistical tests and their levels:
// * Chi-square tests: the family of all chi-square tests in this file has a significance of 1%,
//   Sidak-corrected per test (as tests/test_bsdf.cpp). Fixed seeds: deterministic outcomes.
// * Monte Carlo means (albedos) are compared with z = 5 standard errors (a false alarm
//   probability below 1e-6 per comparison).
// * Renders: K = 8 seeds per integrator, 4x4 block means compared by Welch's t at family-wise
//   significance 1% per comparison (Sidak over the 16 blocks), as tests/test_plastic.cpp.
#include <catch2/catch.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "bsdf/bsdf.h"
#include "bsdf_compare.h"
#include "bsdf/fresnel.h"
#include "bsdf/microfacet.h"
#include "chi2.h"
#include "core/loader.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "core/texture/texture_factory.h"
#include "microfacet_models.h"
#include "render_compare.h"
#include "scene_builders.h"

using namespace lt;
using namespace lt::test;

namespace {

constexpr float kPolyEta = 1.49f / 1.000277f;  // pplastic's default: polypropylene in air

Vec3 upper(const Vec2& u) {
    Vec3 w = sampleUniformSphere(u);
    w.z = std::abs(w.z);
    return w;
}
bool close(float a, float b, float rel, float abs = 0.f) {
    return std::abs(a - b) <= abs + rel * std::max(std::abs(a), std::abs(b));
}
bool close(const Color& a, const Color& b, float rel, float abs = 0.f) {
    return close(a.x, b.x, rel, abs) && close(a.y, b.y, rel, abs) && close(a.z, b.z, rel, abs);
}
RegularizationRequest minAlpha(float a) {
    RegularizationRequest r;
    r.minAlpha = {a, a};
    return r;
}

// ---- Models under test -----------------------------------------------------------------------
struct Named {
    std::string name;
    BxdfPtr b;
    bool twoSided = false;   // directions below the surface are valid
    float lobeAlpha = 0.f;   // the glossy lobe's alpha for the chi-square bins, 0: none narrow
    bool reciprocal = true;  // f(wo, wi) = f(wi, wo) and Radiance == Importance (else the adjoint relation)
};

std::vector<Named> pplastics() {
    std::vector<Named> v;
    for (auto d : kDists)
        for (float a : {0.05f, 0.3f})
            v.push_back({std::string("pplastic ") + distName(d) + " " + std::to_string(a),
                         makePolarizedPlastic(d, a, a, kPolyEta, Color(0.5f, 0.3f, 0.1f)), false, a});
    v.push_back({"pplastic GGX anisotropic 0.1 0.4", makePolarizedPlastic(MicrofacetType::GGX, 0.1f, 0.4f, 1.9f), false, 0.1f});
    v.push_back({"pplastic black base", makePolarizedPlastic(MicrofacetType::Beckmann, 0.06f, 0.06f, kPolyEta, Color(0.f)),
                 false, 0.06f});
    return v;
}

std::vector<Named> blends() {
    std::vector<Named> v;
    v.push_back({"blend diffuse and roughconductor 0.3",
                 makeBlend(makeDiffuse(Color(0.8f)),
                           makeRoughConductor(MicrofacetType::GGX, 0.1f, 0.1f, Color(0.2f), Color(3.f), Color(1.f)), 0.3f),
                 false, 0.1f});
    v.push_back({"blend roughplastic and smooth conductor 0.6",
                 makeBlend(makeRoughPlastic(MicrofacetType::GGX, 0.3f, kPolyEta, Color(0.f)),
                           makeConductor(Color(0.2f), Color(3.f), Color(1.f)), 0.6f),
                 false, 0.3f});
    v.push_back({"blend roughdielectric and diffuse 0.5",
                 makeBlend(makeRoughDielectric(MicrofacetType::GGX, 0.3f, 0.3f, 1.5f), makeDiffuse(Color(0.5f)), 0.5f), true,
                 0.3f, false});
    v.push_back({"blend pplastic and plastic 0.25",
                 makeBlend(makePolarizedPlastic(MicrofacetType::GGX, 0.2f, 0.2f, kPolyEta), makePlastic(1.5f, Color(0.4f)), 0.25f),
                 false, 0.2f});
    return v;
}

// ---- Chi-square --------------------------------------------------------------------------------
int chi2CaseCount() { return int((pplastics().size() + blends().size()) * 3); }

// Bins: a cap around the mirror direction at the lobe's scale, and the whole sphere around the
// normal. Delta samples count as lost (the pdf integrates to 1 minus their probability).
void runChi2(const Named& c, const Vec3& wo, uint64_t seed, double level) {
    const Bxdf& b = *c.b;
    const BsdfContext ctx(TransportMode::Radiance);
    chi2::SampleFn sampler = [&](Rng& rng, Vec3& w) {
        BsdfSample s;
        const float ul = rng.uniform();
        const Vec2 u = rng.uniform2();
        if (!b.sample(wo, ul, u, ctx, s) || (s.lobe & kDelta)) return false;
        w = s.wi;
        return true;
    };
    chi2::PdfFn pdf = [&](const Vec3& w) { return double(b.eval(wo, w, ctx).pdfFwd.value); };
    const Vec3 mirror(-wo.x, -wo.y, wo.z);
    std::vector<chi2::Region> regions;
    if (c.lobeAlpha > 0.f) {
        const float cosCap = std::cos(std::min(1.2f, 6.f * c.lobeAlpha + 0.02f));
        regions.push_back({chi2::Domain(mirror, 0.5 * c.lobeAlpha, 40, 80),
                           [mirror, cosCap](const Vec3& w) { return glm::dot(w, mirror) > cosCap; }});
    }
    regions.push_back({chi2::Domain(Vec3(0.f, 0.f, 1.f), 1.0, 40, 80), nullptr});
    chi2::Chi2Test test(sampler, 200000, seed);
    const chi2::Result res = test.run(pdf, regions, level);
    INFO(c.name << " wo.z " << wo.z << ": " << res.summary());
    CHECK(res.samplesInZeroBins == 0);
    CHECK(res.pValue >= res.significance);
    // 5 binomial standard errors + 2e-3 for the quadrature (as test_plastic.cpp).
    const double n = double(res.samples), lostFrac = double(res.lost) / n;
    const double se = std::sqrt(std::max(lostFrac * (1.0 - lostFrac), 1.0 / n) / n);
    CHECK(res.pdfIntegral <= 1.0 + 2e-3);
    CHECK(std::abs((1.0 - res.pdfIntegral) - lostFrac) <= 5.0 * se + 2e-3);
}

// ---- Loader ------------------------------------------------------------------------------------
std::string writeScene(const std::string& body) {
    const std::filesystem::path p =
        std::filesystem::temp_directory_path() / ("lt_test_bsdf_extra_" + std::to_string(getpid()) + ".xml");
    std::ofstream(p) << "<scene version=\"3.0.0\">\n" << body << "\n</scene>\n";
    return p.string();
}
// The loader's error for a scene of this body ("" if it loads).
std::string bodyError(const std::string& body) {
    const std::string path = writeScene(body);
    const std::string msg = loadError(path);
    std::filesystem::remove(path);
    return msg;
}
// Bitwise the same values, densities and samples over a few pairs and both modes.
// sameMaterial false: a textured material's instance against a constant model (the instance's
// name and bounds are its material's).
void requireIdentical(const Bxdf& a, const Bxdf& b, bool sameMaterial = true) {
    if (sameMaterial) CHECK(a.name() == b.name());
    CHECK(a.flags() == b.flags());
    if (sameMaterial) CHECK(a.continuation() == b.continuation());
    if (sameMaterial) CHECK(a.roughness() == b.roughness());
    for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance})
        if (sameMaterial) CHECK(a.valueBound(BsdfContext(mode)) == b.valueBound(BsdfContext(mode)));
    requireSameEvalsAndSamples(a, b);
}

}  // namespace

// ------------------------------------------------------------------------------------------------
TEST_CASE("chi2 pplastic and blendbsdf sampling against the eval pdf", "[bsdf_extra][chi2]") {
    const double level = chi2::sidakCorrectedLevel(0.01, chi2CaseCount());
    std::vector<Named> all = pplastics();
    for (const Named& b : blends()) all.push_back(b);
    uint64_t seed = 77;
    for (const Named& c : all)
        for (float t : {0.f, 45.f, 80.f}) runChi2(c, dirDeg(t), seed += 7919, level);
}

TEST_CASE("pplastic and blendbsdf weights are f cos over pdf and pdfRev is the swapped pdfFwd in both modes", "[bsdf_extra]") {
    std::vector<Named> all = pplastics();
    for (const Named& b : blends()) all.push_back(b);
    for (const Named& nb : all)
        for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
            const BsdfContext ctx(mode);
            Rng rng(42, 7);
            int tested = 0, delta = 0, bad = 0;
            for (int k = 0; k < 3000; ++k) {
                Vec3 wo = upper(rng.uniform2());
                if (nb.twoSided && rng.uniform() < 0.5f) wo.z = -wo.z;
                BsdfSample s;
                const float ul = rng.uniform();
                const Vec2 u = rng.uniform2();
                if (!nb.b->sample(wo, ul, u, ctx, s)) continue;
                if (s.lobe & kDelta) {
                    // The discrete probability of the lobe, the same for the reverse walk (the
                    // mirror reflection's |cos| is wo's).
                    ++delta;
                    if (!(s.pdfFwd.value > 0.f && s.pdfFwd.value <= 1.f && s.pdfRev.value == s.pdfFwd.value)) ++bad;
                    continue;
                }
                const BsdfEval e = nb.b->eval(wo, s.wi, ctx), rev = nb.b->eval(s.wi, wo, ctx);
                ++tested;
                const Color expect = e.f * std::abs(s.wi.z) / e.pdfFwd.value;
                const bool ok = isFinite(s.weight) && e.pdfFwd.value > 0.f && close(e.pdfFwd.value, s.pdfFwd.value, 1e-5f) &&
                                close(e.pdfRev.value, s.pdfRev.value, 1e-5f) && close(e.pdfRev.value, rev.pdfFwd.value, 1e-5f) &&
                                close(e.pdfFwd.value, rev.pdfRev.value, 1e-5f) && close(s.weight, expect, 1e-4f, 1e-7f);
                if (!ok) ++bad;
            }
            INFO(nb.name << " mode " << int(mode) << ": " << tested << " glossy, " << delta << " delta, bad " << bad);
            CHECK(tested > 800);
            CHECK(bad == 0);
        }
}

// Reciprocal models: f(wo, wi) = f(wi, wo) and one value in both modes. A blend with a refracting
// component: the adjoint relation f_Radiance(wo, wi) = f_Importance(wi, wo) for every pair.
TEST_CASE("pplastic and blendbsdf reciprocity and the adjoint relation", "[bsdf_extra]") {
    std::vector<Named> all = pplastics();
    for (const Named& b : blends()) all.push_back(b);
    for (const Named& nb : all) {
        Rng rng(5, 11);
        int pairs = 0, bad = 0;
        for (int k = 0; k < 3000; ++k) {
            Vec3 wo = upper(rng.uniform2());
            if (nb.twoSided && rng.uniform() < 0.5f) wo.z = -wo.z;
            BsdfSample s;
            const float ul = rng.uniform();
            const Vec2 u = rng.uniform2();
            if (!nb.b->sample(wo, ul, u, kRadianceContext, s) || (s.lobe & kDelta)) continue;
            ++pairs;
            const Vec3 wi = s.wi;
            const Color fR = nb.b->eval(wo, wi, kRadianceContext).f, fRswap = nb.b->eval(wi, wo, kRadianceContext).f;
            const Color fI = nb.b->eval(wo, wi, kImportanceContext).f, fIswap = nb.b->eval(wi, wo, kImportanceContext).f;
            const bool ok = nb.reciprocal ? close(fR, fRswap, 1e-5f, 1e-8f) && fR == fI && close(fI, fIswap, 1e-5f, 1e-8f)
                                          : close(fR, fIswap, 1e-4f, 1e-7f) && close(fI, fRswap, 1e-4f, 1e-7f);
            if (!ok) ++bad;
        }
        INFO(nb.name << " bad pairs " << bad << " of " << pairs);
        CHECK(pairs > 800);
        CHECK(bad == 0);
    }
    // The blend with a refracting component is not reciprocal: the check above can fail.
    const BxdfPtr glass = blends()[2].b;
    const Vec3 wo = dirDeg(30.f), wi = -dirDeg(20.f);  // (near the refraction of wo: eta 1.5)
    REQUIRE(glass->eval(wo, wi, kRadianceContext).f.x > 0.f);
    CHECK_FALSE(close(glass->eval(wo, wi, kRadianceContext).f, glass->eval(wi, wo, kRadianceContext).f, 1e-3f));
}

// pplastic's rgb formula (Mitsuba's eval `else` branch), written out with this project's microfacet
// functions: specR F(o.h) D G / (4 mu_o mu_i) + diffR (1 - F_o)(1 - F_i) / pi.
TEST_CASE("pplastic follows Mitsuba's rgb formula and lobe choice", "[bsdf_extra]") {
    const Color D(0.05f, 0.03f, 0.1f), S(0.9f, 1.f, 0.8f);
    for (auto dist : kDists) {
        const BxdfPtr b = makePolarizedPlastic(dist, 0.06f, 0.12f, kPolyEta, D, S);
        const Microfacet mf(dist, 0.06f, 0.12f, MaskingModel::Smith);
        for (float to : {0.f, 30.f, 70.f})
            for (float ti : {10.f, 50.f, 85.f}) {
                const Vec3 wo = dirDeg(to), wi = dirDeg(ti, 2.5f);
                const Vec3 h = glm::normalize(wo + wi);
                const float F = fresnelDielectric(glm::dot(wo, h), kPolyEta);
                const float spec = mf.D(h) * mf.G1(wo, h) * mf.G1(wi, h) / (4.f * wo.z * wi.z);
                const Color expect = S * (F * spec) + D * ((1.f - fresnelDielectric(wo.z, kPolyEta)) *
                                                           (1.f - fresnelDielectric(wi.z, kPolyEta)) * kInvPi);
                INFO(distName(dist) << " theta " << to << " " << ti);
                CHECK(close(b->eval(wo, wi, kRadianceContext).f, expect, 1e-4f, 1e-7f));
                // The density: w D_wo(h) / (4 o.h) + (1 - w) cos_i / pi, w = mean(S) / (mean(D) + mean(S)).
                const float w = 0.9f / (0.06f + 0.9f);
                const float pdf = w * mf.pdfVisible(wo, h) / (4.f * glm::dot(wo, h)) + (1.f - w) * wi.z * kInvPi;
                CHECK(b->eval(wo, wi, kRadianceContext).pdfFwd.value == Approx(pdf).epsilon(1e-4));
            }
        // One-sided: black below.
        CHECK(isBlack(b->eval(dirDeg(20.f), -dirDeg(30.f), kRadianceContext).f));
        BsdfSample s;
        CHECK_FALSE(b->sample(-dirDeg(20.f), 0.5f, Vec2(0.5f), kRadianceContext, s));
        CHECK(b->flags() == (kReflection | kGlossy | kDiffuse));
        CHECK(b->roughness() == Approx(0.06f));
        CHECK(b->name() == "pplastic");
    }
}

// Mitsuba's thindielectric: R' = R + T^2 R / (1 - R^2) with R = F(|cos|), reflection chosen with
// probability R', weights specR and specT, straight transmission (no bending), both sides.
TEST_CASE("thindielectric null and polarizer sample Mitsuba's delta lobes", "[bsdf_extra]") {
    const Color sr(0.9f, 0.8f, 0.7f), st(0.6f, 0.5f, 0.4f);
    const BxdfPtr thin = makeThinDielectric(1.333f / 1.000277f, sr, st);
    CHECK(thin->flags() == (kReflection | kTransmission | kDelta));
    CHECK(thin->isDelta());
    CHECK(thin->roughness() == 0.f);
    CHECK(thin->continuation() == Approx(0.9f));
    CHECK(thin->plainBound() == kInf);
    for (float t : {0.f, 40.f, 75.f, 89.f})
        for (float side : {1.f, -1.f}) {
            Vec3 wo = dirDeg(t);
            wo.z *= side;
            const float R = fresnelDielectric(std::abs(wo.z), 1.333f / 1.000277f), T = 1.f - R;
            const float Rp = R + T * T * R / (1.f - R * R);
            for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
                const BsdfContext ctx(mode);
                BsdfSample s;
                REQUIRE(thin->sample(wo, 0.999f * Rp, Vec2(0.3f), ctx, s));
                CHECK(s.lobe == (kReflection | kDelta));
                CHECK(s.wi == Vec3(-wo.x, -wo.y, wo.z));
                CHECK(s.pdfFwd.value == Approx(Rp).epsilon(1e-5));
                CHECK(s.weight == sr);
                // The reverse walk from wi reflects back to wo with the same probability.
                BsdfSample back;
                REQUIRE(thin->sample(s.wi, 0.999f * Rp, Vec2(0.3f), ctx, back));
                CHECK(back.wi == wo);
                CHECK(back.pdfFwd.value == s.pdfRev.value);
                REQUIRE(thin->sample(wo, std::min(1.001f * Rp + 1e-6f, 0.9999f), Vec2(0.3f), ctx, s));
                CHECK(s.lobe == (kTransmission | kDelta));
                CHECK(s.wi == -wo);  // (no bending)
                CHECK(s.eta == 1.f);
                CHECK(s.pdfFwd.value == Approx(1.f - Rp).epsilon(1e-5));
                CHECK(s.pdfRev.value == s.pdfFwd.value);
                CHECK(s.weight == st);  // (the same in both modes: no change of index)
                CHECK(isBlack(thin->eval(wo, s.wi, ctx).f));
                CHECK(thin->eval(wo, s.wi, ctx).pdfFwd.value == 0.f);
            }
        }
    const BxdfPtr null = makeNull(), pol = makePolarizer(Color(0.8f, 0.6f, 1.f));
    for (const auto& [b, w] : {std::pair{null, Color(1.f)}, std::pair{pol, Color(0.4f, 0.3f, 0.5f)}}) {
        CHECK(b->flags() == (kTransmission | kDelta));
        for (float ul : {0.f, 0.5f, 0.9999f}) {
            BsdfSample s;
            REQUIRE(b->sample(dirDeg(35.f), ul, Vec2(0.5f), kImportanceContext, s));
            CHECK(s.wi == -dirDeg(35.f));
            CHECK(s.weight == w);  // (polarizer: transmittance / 2, Mitsuba's rgb branch)
            CHECK(s.pdfFwd.value == 1.f);
            CHECK(s.pdfRev.value == 1.f);
        }
    }
    CHECK(null->name() == "null");
    CHECK(pol->name() == "polarizer");
    CHECK(pol->continuation() == Approx(0.5f));
    // Index matched: no reflection.
    CHECK(makeThinDielectric(1.f)->flags() == (kTransmission | kDelta));
}

// Energy: the expected sample weight (Importance mode: the light leaving wo's direction) is the
// albedo; never above 1 for white materials.
TEST_CASE("white furnace the new models create no energy", "[bsdf_extra]") {
    const int n = 60000;
    auto albedo = [&](const Bxdf& b, const Vec3& wo, double& se) {
        Rng rng(uint64_t(1e4f * std::abs(wo.z)) + 17, 3);
        double sum = 0.0, sum2 = 0.0;
        for (int k = 0; k < n; ++k) {
            BsdfSample s;
            const float ul = rng.uniform();
            const Vec2 u = rng.uniform2();
            if (!b.sample(wo, ul, u, kImportanceContext, s)) continue;
            sum += s.weight.x;
            sum2 += double(s.weight.x) * s.weight.x;
        }
        const double mean = sum / n;
        se = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
        return mean;
    };
    std::vector<std::pair<std::string, BxdfPtr>> white = {
        {"thindielectric", makeThinDielectric(1.5f)},
        {"null", makeNull()},
        {"polarizer", makePolarizer()},
        {"blend white diffuse and mirror", makeBlend(makeDiffuse(Color(1.f)), makeConductor(Color(0.f), Color(0.f), Color(1.f)), 0.4f)},
        {"blend white roughplastic and glass", makeBlend(makeRoughPlastic(MicrofacetType::GGX, 0.2f, 1.5f, Color(1.f)), makeDielectric(1.5f), 0.5f)},
    };
    for (auto d : kDists)
        for (float a : {0.01f, 0.1f, 0.5f, 1.f})
            white.push_back({std::string("pplastic white ") + distName(d) + " " + std::to_string(a),
                             makePolarizedPlastic(d, a, a, kPolyEta, Color(1.f), Color(1.f))});
    for (const auto& [name, b] : white)
        for (float t : {0.f, 40.f, 70.f, 85.f}) {
            double se;
            const double a = albedo(*b, dirDeg(t), se);
            INFO(name << " theta " << t << " albedo " << a << " +- " << se);
            CHECK(a <= 1.0 + 5.0 * se + 1e-6);
            CHECK(a > 0.3);
        }
    // The sheets with white lobes lose nothing: R' + (1 - R') = 1 on every sample (exactly 1).
    for (const auto& [name, b] : {white[0], white[1]}) {
        double se;
        CHECK(albedo(*b, dirDeg(60.f), se) == Approx(1.0).epsilon(1e-6));
    }
}

TEST_CASE("blendbsdf weight 0 and 1 are its components bit for bit", "[bsdf_extra]") {
    const BxdfPtr comps[] = {makeDiffuse(Color(0.3f, 0.5f, 0.7f)),
                             makeRoughConductor(MicrofacetType::Beckmann, 0.2f, 0.1f, Color(0.2f), Color(3.f), Color(1.f)),
                             makePlastic(1.5f, Color(0.4f)), makeDielectric(1.5f), makeThinDielectric(1.33f),
                             makePolarizedPlastic(MicrofacetType::GGX, 0.1f, 0.1f, kPolyEta)};
    for (size_t i = 0; i < std::size(comps); ++i) {
        const BxdfPtr other = comps[(i + 1) % std::size(comps)];
        INFO("component " << comps[i]->name() << " other " << other->name());
        requireIdentical(*makeBlend(comps[i], other, 0.f), *comps[i]);
        requireIdentical(*makeBlend(other, comps[i], 1.f), *comps[i]);
    }
    // In between: the weighted sum, weight on the second (Mitsuba's convention).
    const BxdfPtr a = comps[0], b = comps[1], m = makeBlend(a, b, 0.25f);
    const Vec3 wo = dirDeg(30.f), wi = dirDeg(50.f, 2.f);
    const BsdfEval ea = a->eval(wo, wi, kRadianceContext), eb = b->eval(wo, wi, kRadianceContext), em = m->eval(wo, wi, kRadianceContext);
    CHECK(close(em.f, ea.f * 0.75f + eb.f * 0.25f, 1e-6f));
    CHECK(em.pdfFwd.value == Approx(0.75f * ea.pdfFwd.value + 0.25f * eb.pdfFwd.value).epsilon(1e-6));
    CHECK(m->flags() == (a->flags() | b->flags()));
    // A textured weight: the instance at a point is the constant blend with the texture's value
    // there (its luminance: a grey texture's value).
    const TexturePtr tex = makeCheckerboard(Color(0.2f), Color(0.9f), glm::mat3(1.f));
    const BxdfPtr tb = makeBlend(a, b, 0.5f, tex);
    CHECK(tb->textured());
    for (const Vec2 uv : {Vec2(0.1f, 0.1f), Vec2(0.6f, 0.1f)}) {
        BxdfInstance storage;
        const Bxdf* at = tb->atUv(uv, storage.bytes, sizeof(storage.bytes));
        const float w = luminance(tex->eval(uv));
        requireIdentical(*at, *makeBlend(a, b, w), false);
    }
    // Textured components inside a textured blend (their instances share the point's storage),
    // also inside a two-sided adapter's smaller storage.
    const BxdfPtr texDiffuse = makeTexturedDiffuse(tex);
    const BxdfPtr tt = makeBlend(texDiffuse, makeTexturedPlastic(false, MicrofacetType::GGX, 0.f, 1.5f, tex, Color(1.f), false), 0.5f, tex);
    const BxdfPtr two = makeTwoSided(tt);
    BxdfInstance storage;
    const Bxdf* at = two->atUv(Vec2(0.6f, 0.1f), storage.bytes, sizeof(storage.bytes));
    CHECK(!isBlack(at->eval(wo, wi, kRadianceContext).f));
}

TEST_CASE("regularisation requests on pplastic and the delta sheets", "[bsdf_extra][regularization]") {
    // pplastic: the microfacet lobe takes the request's alpha; the base keeps its value.
    const BxdfPtr p = makePolarizedPlastic(MicrofacetType::GGX, 0.05f, 0.05f, kPolyEta, Color(0.f));
    const BxdfPtr p3 = makePolarizedPlastic(MicrofacetType::GGX, 0.3f, 0.3f, kPolyEta, Color(0.f));
    const BsdfContext req(TransportMode::Radiance, minAlpha(0.3f));
    for (const Vec3& wi : {dirDeg(40.f, 3.6f), dirDeg(70.f, 1.f), dirDeg(10.f)})
        CHECK(close(p->eval(dirDeg(40.f), wi, req).f, p3->eval(dirDeg(40.f), wi, kRadianceContext).f, 1e-6f));
    const BxdfPtr base = makePolarizedPlastic(MicrofacetType::GGX, 0.05f, 0.05f, kPolyEta, Color(0.5f), Color(0.f));
    CHECK(base->eval(dirDeg(40.f), dirDeg(20.f), req).f == base->eval(dirDeg(40.f), dirDeg(20.f), kRadianceContext).f);
    CHECK(p->valueBound(req) < p->valueBound(kRadianceContext));
    // The value bound holds over sampled pairs.
    for (const BsdfContext& ctx : {BsdfContext(kRadianceContext), req}) {
        const BxdfPtr q = makePolarizedPlastic(MicrofacetType::Beckmann, 0.1f, 0.1f, kPolyEta, Color(0.9f));
        const float bound = q->valueBound(ctx);
        Rng rng(3, 4);
        float largest = 0.f;
        for (int k = 0; k < 20000; ++k) {
            const Vec3 wo = upper(rng.uniform2());
            BsdfSample s;
            if (!q->sample(wo, rng.uniform(), rng.uniform2(), ctx, s)) continue;
            largest = std::max(largest, maxComp(q->eval(wo, s.wi, ctx).f));
        }
        CHECK(largest <= bound);
        CHECK(largest > 0.f);
    }
    // The sheets: KD13's cone spreads each delta lobe's weight over its cone; minAlpha and tau
    // leave them deltas.
    const BxdfPtr thin = makeThinDielectric(1.5f, Color(1.f), Color(0.5f));
    CHECK(thin->deltaUnder(BsdfContext(TransportMode::Radiance, minAlpha(0.3f))));
    CHECK(thin->valueBound(BsdfContext(TransportMode::Radiance, minAlpha(0.3f))) == kInf);
    RegularizationRequest cone;
    cone.cone = 0.05f;
    const BsdfContext cctx(TransportMode::Importance, cone);
    CHECK_FALSE(thin->deltaUnder(cctx));
    CHECK(thin->valueBound(cctx) == Approx(1.f / coneSolidAngle(0.05f)));
    const Vec3 wo = dirDeg(50.f);
    const float R = fresnelDielectric(wo.z, 1.5f), Rp = 2.f * R / (1.f + R);
    const Vec3 nearMirror = glm::normalize(Vec3(-wo.x, -wo.y, wo.z) + Vec3(0.02f, 0.f, 0.f));
    const Vec3 nearStraight = glm::normalize(-wo + Vec3(0.02f, 0.f, 0.f));
    CHECK(thin->eval(wo, nearMirror, cctx).f.x == Approx(Rp / (coneSolidAngle(0.05f) * nearMirror.z)).epsilon(1e-4));
    CHECK(thin->eval(wo, nearStraight, cctx).f.x ==
          Approx(0.5f * (1.f - Rp) / (coneSolidAngle(0.05f) * std::abs(nearStraight.z))).epsilon(1e-4));
    CHECK(isBlack(thin->eval(wo, dirDeg(10.f), cctx).f));
    CHECK(thin->eval(wo, nearMirror, cctx).pdfFwd.value == 0.f);  // (never sampled)
    CHECK(!isBlack(makeNull()->eval(wo, nearStraight, cctx).f));
    // A blend passes the request to its components.
    const BxdfPtr bl = makeBlend(makeDiffuse(Color(0.5f)), thin, 0.5f);
    CHECK(bl->eval(wo, nearMirror, cctx).f.x ==
          Approx(0.5f * 0.5f * kInvPi + 0.5f * thin->eval(wo, nearMirror, cctx).f.x).epsilon(1e-5));
}

TEST_CASE("loader builds the new BSDFs with Mitsuba's names and defaults", "[bsdf_extra][loader]") {
    const std::string path = writeScene(R"(
        <bsdf type="thindielectric" id="a"/>
        <bsdf type="thindielectric" id="b">
            <string name="int_ior" value="water"/><string name="ext_ior" value="air"/>
            <rgb name="specular_transmittance" value="0.5"/>
        </bsdf>
        <bsdf type="null" id="c"/>
        <bsdf type="polarizer" id="d"><spectrum name="theta" value="90"/><rgb name="transmittance" value="0.8"/></bsdf>
        <bsdf type="pplastic" id="e"/>
        <bsdf type="pplastic" id="f">
            <rgb name="diffuse_reflectance" value="0.05, 0.03, 0.1"/><float name="alpha" value="0.06"/>
            <string name="distribution" value="ggx"/>
        </bsdf>
        <bsdf type="blendbsdf" id="g">
            <float name="weight" value="0.25"/>
            <bsdf type="diffuse"/>
            <bsdf type="conductor"/>
        </bsdf>
        <bsdf type="blendbsdf" id="h">
            <bsdf type="conductor" name="bsdf_1"/>
            <bsdf type="diffuse" name="bsdf_0"/>
        </bsdf>)");
    const SceneDesc s = loadScene(path);
    std::filesystem::remove(path);
    REQUIRE(s.bsdfs.size() == 8);
    const float bk7 = 1.5046f / 1.000277f;
    requireIdentical(*s.bsdfs[0], *makeThinDielectric(bk7));
    requireIdentical(*s.bsdfs[1], *makeThinDielectric(1.333f / 1.000277f, Color(1.f), Color(0.5f)));
    requireIdentical(*s.bsdfs[2], *makeNull());
    requireIdentical(*s.bsdfs[3], *makePolarizer(Color(0.8f)));
    requireIdentical(*s.bsdfs[4], *makePolarizedPlastic(MicrofacetType::Beckmann, 0.1f, 0.1f, kPolyEta));
    requireIdentical(*s.bsdfs[5], *makePolarizedPlastic(MicrofacetType::GGX, 0.06f, 0.06f, kPolyEta, Color(0.05f, 0.03f, 0.1f)));
    const BxdfPtr mirror = makeConductor(Color(0.f), Color(1.f), Color(1.f));  // (Mitsuba 3's "none")
    requireIdentical(*s.bsdfs[6], *makeBlend(makeDiffuse(Color(0.5f)), mirror, 0.25f));
    // Named nested BSDFs in Mitsuba's key order (bsdf_0 first whatever the document order), weight 0.5.
    requireIdentical(*s.bsdfs[7], *makeBlend(makeDiffuse(Color(0.5f)), mirror, 0.5f));
    // Errors name the file, the line and the parameter or element.
    const std::pair<const char*, const char*> bad[] = {
        {R"(<bsdf type="blendbsdf"><float name="weight" value="1.5"/><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>)", "weight"},
        {R"(<bsdf type="blendbsdf"><float name="weight" value="-0.1"/><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>)", "weight"},
        {R"(<bsdf type="blendbsdf"><float name="weight" value="nan"/><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>)", "weight"},
        {R"(<bsdf type="blendbsdf"><bsdf type="diffuse"/></bsdf>)", "two nested"},
        {R"(<bsdf type="blendbsdf"><bsdf type="diffuse"/><bsdf type="diffuse"/>
            <bsdf type="diffuse"/></bsdf>)", "a third one"},
        {R"(<bsdf type="thindielectric"><float name="int_ior" value="-1"/></bsdf>)", "int_ior"},
        {R"(<bsdf type="thindielectric"><rgb name="specular_reflectance" value="-1"/></bsdf>)", "specular_reflectance"},
        {R"(<bsdf type="thindielectric"><float name="alpha" value="0.1"/></bsdf>)", "alpha"},
        {R"(<bsdf type="null"><float name="alpha" value="0.1"/></bsdf>)", "alpha"},
        {R"(<bsdf type="polarizer"><rgb name="transmittance" value="-0.5"/></bsdf>)", "transmittance"},
        {R"(<bsdf type="pplastic"><float name="int_ior" value="1.2"/><float name="ext_ior" value="1.2"/></bsdf>)", "int_ior"},
        {R"(<bsdf type="pplastic"><float name="alpha" value="-0.2"/></bsdf>)", "alpha"},
        {R"(<bsdf type="pplastic"><string name="masking" value="vcavity"/></bsdf>)", "masking"},
    };
    for (const auto& [xml, what] : bad) {
        const std::string msg = bodyError(xml);
        INFO(xml << " -> " << msg);
        CHECK(msg.find(what) != std::string::npos);
        CHECK(msg.find("lt_test_bsdf_extra_") != std::string::npos);  // the file
        CHECK(msg.find(".xml:") != std::string::npos);                 // and the line
    }
}

// The Cornell box with the panel and the sphere of each new material: PT's, BPT's and VCM's images
// agree (each a different mix of techniques: a straight delta transmission must carry eta 1 and its
// lobe probability into the MIS densities, a blend of delta and non-delta lobes is a connection end).
TEST_CASE("Cornell box with the new materials: PT BPT and VCM agree", "[bsdf_extra][statistical]") {
    const std::vector<std::pair<std::string, BxdfPtr>> panels = {
        {"thindielectric", makeThinDielectric(1.5f, Color(1.f), Color(0.9f))},
        {"polarizer", makePolarizer(Color(0.9f))},
        {"pplastic", makePolarizedPlastic(MicrofacetType::GGX, 0.2f, 0.2f, kPolyEta, Color(0.6f, 0.4f, 0.2f))},
        {"blend diffuse and smooth mirror", makeBlend(makeDiffuse(Color(0.6f)), makeConductor(Color(0.f), Color(0.f), Color(0.9f)), 0.5f)},
    };
    for (const auto& [name, panel] : panels) {
        const SceneDesc d = cornellBox(16, panel);
        RenderSettings s;
        s.spp = 32;
        s.maxDepth = 5;
        s.integrator = "pt";
        const auto ref = blockStats(d, s, 8, 4);
        for (const char* integ : {"bpt", "vcm"}) {
            s.integrator = integ;
            double worst;
            const int bad = differingBlocks(ref, blockStats(d, s, 8, 4), 0.01, &worst);
            INFO(name << ": pt against " << integ << ": " << bad << " blocks differ, worst |t|/crit " << worst);
            CHECK(bad == 0);
        }
    }
}
