// Tests of Mitsuba 3's principled and principledthin BSDFs (bsdf/principled.cpp,
// bsdf/principled_thin.cpp): sampling against the pdf
// (chi-square), weights and densities in both transport modes, reciprocity, energy, Mitsuba's
// formulas, textured parameters, the loader, and renders where PT, BPT, VCM and LT must agree.
//
// Statistical tests and their levels:
// * Chi-square tests: each family (principled's, principledthin's) has a significance of 1%,
//   Sidak-corrected per test (as tests/test_bsdf.cpp). Fixed seeds: deterministic outcomes. Bins at
//   the lobe's own scale around the mirror and transmitted directions (finer for small alphas).
// * Monte Carlo means (albedos) are compared with z = 5 standard errors (a false alarm
//   probability below 1e-6 per comparison).
// * Renders: K = 8 seeds per integrator, 4x4 block means compared by Welch's t at family-wise
//   significance 1% per comparison (Sidak over the 16 blocks), as tests/test_bsdf_extra.cpp; LT
//   with twice the samples (checkAgreesWithPt). PPM is not compared: its merge radius biases it.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "bsdf/bsdf.h"
#include "bsdf/fresnel.h"
#include "bsdf/microfacet.h"
#include "bsdf/principled.h"
#include "bsdf_chi2.h"
#include "bsdf_compare.h"
#include "chi2.h"
#include "core/loader.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "core/texture/texture_factory.h"
#include "process.h"
#include "render_compare.h"
#include "scene_builders.h"

using namespace lt;
using namespace lt::test;

namespace {

bool close(float a, float b, float rel, float abs = 0.f) {
    return std::abs(a - b) <= abs + rel * std::max(std::abs(a), std::abs(b));
}
bool close(const Color& a, const Color& b, float rel, float abs = 0.f) {
    return close(a.x, b.x, rel, abs) && close(a.y, b.y, rel, abs) && close(a.z, b.z, rel, abs);
}
float etaOfSpecular(float s) { return 2.f / (1.f - std::sqrt(0.08f * s)) - 1.f; }

struct Case {
    std::string name;
    PrincipledParams p;
    float lobeAlpha;  // the sharpest lobe's alpha (the chi-square's cap scale)
    bool inside;      // also test wo below the surface (spec_trans > 0)
};

std::vector<Case> cases() {
    std::vector<Case> c;
    c.push_back({"defaults", PrincipledParams{}, 0.25f, false});
    {
        PrincipledParams p;
        p.baseColor = Color(0.2f, 0.8f, 0.1f);
        p.roughness = 0.3f;
        p.anisotropic = 0.8f;
        p.metallic = 0.7f;
        p.clearcoat = 0.9f;
        p.clearcoatGloss = 0.3f;
        p.sheen = 0.9f;
        p.sheenTint = 0.5f;
        p.specTint = 0.4f;
        p.eta = etaOfSpecular(0.7f);
        c.push_back({"metallic anisotropic clearcoat sheen", p, 0.03f, false});
    }
    {
        PrincipledParams p;
        p.baseColor = Color(0.3f, 0.6f, 0.8f);
        p.roughness = 0.3f;
        p.anisotropic = 0.4f;
        p.specTrans = 0.9f;
        p.clearcoat = 0.6f;
        p.sheen = 0.5f;
        p.flatness = 0.5f;
        p.eta = 1.5f;
        c.push_back({"spec_trans clearcoat flatness", p, 0.07f, true});
    }
    {
        // Small roughness: alpha 0.0025 (the chi-square's bins at the lobe's scale resolve it).
        PrincipledParams p;
        p.baseColor = Color(0.9f);
        p.roughness = 0.05f;
        p.specTrans = 1.f;
        p.eta = 1.33f;
        c.push_back({"smooth glass-like", p, 0.0025f, true});
    }
    {
        PrincipledParams p;
        p.roughness = 0.7f;
        p.clearcoat = 1.f;
        p.clearcoatGloss = 0.8f;  // GTR1 alpha 0.0208
        p.metallic = 0.2f;
        p.specTrans = 0.3f;
        p.eta = etaOfSpecular(0.3f);
        c.push_back({"glossy clearcoat over rough", p, 0.0208f, true});
    }
    return c;
}
const std::vector<float> kAngles = {0.f, 45.f, 80.f};
int chi2CaseCount() {
    int n = 0;
    for (const Case& c : cases()) n += int(kAngles.size()) * (c.inside ? 2 : 1);
    return n;
}

// Peaks: the mirror direction, and the refracted one where the case transmits.
void runChi2(const Case& c, const Vec3& wo, uint64_t seed, double level) {
    std::vector<Vec3> peaks{Vec3(-wo.x, -wo.y, wo.z)};
    Vec3 t;
    if (c.p.specTrans > 0.f && refractAbout(wo, Vec3(0.f, 0.f, 1.f), c.p.eta, t)) peaks.push_back(t);
    runLobeChi2(*makePrincipled(c.p), c.name, wo, peaks, c.lobeAlpha, seed, level);
}

// No request, a JG19 bound, and an OPSR roughness (each lobe's alphas raised: bsdf.h).
std::vector<RegularizationRequest> someRequests() {
    RegularizationRequest tau, rough;
    tau.tau = 300.f;
    rough.minAlpha = {0.05f, 0.05f};
    return {RegularizationRequest{}, tau, rough};
}

// A direction uniformly on the sphere.
Vec3 anyDir(Rng& rng) { return sampleUniformSphere(rng.uniform2()); }

// Bitwise the same values, densities and samples over a few pairs and both modes.
void requireSameModel(const Bxdf& a, const Bxdf& b) { requireSameEvalsAndSamples(a, b); }

}  // namespace

// ------------------------------------------------------------------------------------------------
TEST_CASE("chi2 principled sampling against the eval pdf", "[principled][chi2]") {
    const double level = chi2::sidakCorrectedLevel(0.01, chi2CaseCount());
    uint64_t seed = 91;
    for (const Case& c : cases())
        for (float t : kAngles) {
            runChi2(c, dirDeg(t), seed += 7919, level);
            if (c.inside) {
                Vec3 wo = dirDeg(t);
                wo.z = -wo.z;
                runChi2(c, wo, seed += 7919, level);
            }
        }
}

TEST_CASE("principled weights are f cos over pdf and pdfRev is the swapped pdfFwd in both modes", "[principled]") {
    for (const Case& c : cases()) {
        const BxdfPtr b = makePrincipled(c.p);
        for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance})
          for (const RegularizationRequest& req : someRequests()) {
            const BsdfContext ctx(mode, req);
            Rng rng(3, 5);
            int n = 0, bad = 0, trans = 0;
            for (int k = 0; k < 4000; ++k) {
                Vec3 wo = anyDir(rng);
                if (!c.inside) wo.z = std::abs(wo.z);
                BsdfSample s;
                const float ul = rng.uniform();
                const Vec2 u = rng.uniform2();
                if (!b->sample(wo, ul, u, ctx, s)) continue;
                ++n;
                if (s.lobe & kTransmission) ++trans;
                const BsdfEval e = b->eval(wo, s.wi, ctx), r = b->eval(s.wi, wo, ctx);
                const Color w = e.f * (std::abs(s.wi.z) / e.pdfFwd.value);
                const bool ok = close(w, s.weight, 1e-4f, 1e-6f) && close(e.pdfFwd.value, s.pdfFwd.value, 1e-5f) &&
                                close(e.pdfRev.value, s.pdfRev.value, 1e-5f) &&
                                close(r.pdfFwd.value, e.pdfRev.value, 1e-5f) &&
                                ((s.lobe & kTransmission) ? (s.wi.z * wo.z < 0.f) : (s.wi.z * wo.z > 0.f)) &&
                                ((s.lobe & kTransmission) ? s.eta == (wo.z > 0.f ? c.p.eta : 1.f / c.p.eta) : s.eta == 1.f);
                if (!ok) ++bad;
            }
            INFO(c.name << " mode " << int(mode) << " request tau " << req.tau << " minAlpha " << req.minAlpha.alphaU
                        << ": " << bad << " bad of " << n);
            CHECK(n > 2000);
            CHECK(bad == 0);
            if (c.p.specTrans > 0.f) CHECK(trans > 100);
        }
    }
}

// f_rad(wo, wi) = f_imp(wi, wo) (bsdf.h: Importance is the adjoint); reflection is symmetric and
// the same in both modes; a refraction's Radiance value carries 1 / eta_p^2, so it is not symmetric.
TEST_CASE("principled reciprocity and the adjoint relation", "[principled]") {
    for (const Case& c : cases()) {
        const BxdfPtr b = makePrincipled(c.p);
        Rng rng(7, 13);
        int nonZero = 0, refr = 0, bad = 0;
        for (int k = 0; k < 20000; ++k) {
            const Vec3 wo = anyDir(rng), wi = anyDir(rng);
            const Color fR = b->eval(wo, wi, kRadianceContext).f, fI = b->eval(wo, wi, kImportanceContext).f;
            const Color fRswap = b->eval(wi, wo, kRadianceContext).f, fIswap = b->eval(wi, wo, kImportanceContext).f;
            if (maxComp(fR) > 0.f) ++nonZero;
            bool ok = close(fR, fIswap, 2e-4f, 1e-7f) && close(fI, fRswap, 2e-4f, 1e-7f);
            if (wo.z * wi.z > 0.f) {
                ok = ok && fR == fI && close(fR, fRswap, 2e-4f, 1e-7f);
            } else if (maxComp(fR) > 0.f) {
                ++refr;
                const float e = wo.z > 0.f ? c.p.eta : 1.f / c.p.eta;  // eta_p = n_wi / n_wo
                ok = ok && close(fR * (e * e), fI, 2e-4f, 1e-7f);
            }
            if (!ok) ++bad;
        }
        INFO(c.name << ": " << bad << " bad of " << nonZero << " non-zero pairs (" << refr << " refractions)");
        CHECK(nonZero > 2000);
        if (c.p.specTrans > 0.f) CHECK(refr > 100);
        CHECK(bad == 0);
    }
}

// Energy: the expected sample weight in Importance mode (the light leaving along wo's side) is the
// albedo. The lobes that conserve energy in Mitsuba's model stay at or below 1 with a white
// base_color: a metal, a glass-like material from both sides, a clearcoat over a metal (bounded by
// 1.25: the coat's lobe, at most 0.25 clearcoat Schlick(0.04), is added to the metal's, Mitsuba's
// mixture being a sum of lobes, not a layering). The diffuse mixtures do not conserve energy in
// Mitsuba's model: Burley's retro-reflection and the dielectric reflection added on top of the
// diffuse lobe reach albedos of 1.03 to 1.05 at normal incidence and up to 1.31 at 85 degrees with a white
// base_color; there the sample weights' mean must equal an independent quadrature of f cos
// (uniform directions), so the excess is the model's value, not the sampler's.
TEST_CASE("white furnace principled lobes create no energy", "[principled]") {
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
    struct W {
        std::string name;
        PrincipledParams p;
        bool inside;
    };
    std::vector<W> white;
    for (float r : {0.05f, 0.3f, 0.8f}) {
        PrincipledParams metal;
        metal.baseColor = Color(1.f);
        metal.metallic = 1.f;
        metal.roughness = r;
        white.push_back({"white metal roughness " + std::to_string(r), metal, false});
        PrincipledParams glass = metal;
        glass.metallic = 0.f;
        glass.specTrans = 1.f;
        glass.eta = 1.5f;
        white.push_back({"white glass roughness " + std::to_string(r), glass, true});
        PrincipledParams coat = metal;
        coat.clearcoat = 1.f;
        coat.clearcoatGloss = 0.5f;
        white.push_back({"clearcoat over white metal roughness " + std::to_string(r), coat, false});
    }
    for (const W& w : white) {
        const BxdfPtr b = makePrincipled(w.p);
        for (float t : {0.f, 40.f, 70.f, 85.f})
            for (int side = 0; side < (w.inside ? 2 : 1); ++side) {
                Vec3 wo = dirDeg(t);
                if (side) wo.z = -wo.z;
                double se;
                const double a = albedo(*b, wo, se);
                INFO(w.name << " theta " << t << (side ? " inside" : "") << " albedo " << a << " +- " << se);
                CHECK(a <= (w.p.clearcoat > 0.f ? 1.25 : 1.0) + 5.0 * se + 1e-6);
                CHECK(a > 0.3);
            }
    }
    // The diffuse mixtures: the sampled albedo against a uniform-direction quadrature of f cos.
    for (float r : {0.3f, 0.8f}) {
        PrincipledParams d;
        d.baseColor = Color(1.f);
        d.roughness = r;
        PrincipledParams e = d;
        e.sheen = 1.f;
        e.clearcoat = 1.f;
        e.specTrans = 0.5f;
        for (const PrincipledParams& p : {d, e}) {
            const BxdfPtr b = makePrincipled(p);
            for (float t : {0.f, 70.f}) {
                const Vec3 wo = dirDeg(t);
                double se;
                const double a = albedo(*b, wo, se);
                Rng rng(99, 1);
                const int m = 200000;
                double sum = 0.0, sum2 = 0.0;
                for (int k = 0; k < m; ++k) {
                    const Vec3 wi = anyDir(rng);
                    const double v = double(b->eval(wo, wi, kImportanceContext).f.x) * std::abs(wi.z) * 4.0 * kPi;
                    sum += v;
                    sum2 += v * v;
                }
                const double q = sum / m, seQ = std::sqrt(std::max(0.0, sum2 / m - q * q) / m);
                INFO("roughness " << r << " sheen " << p.sheen << " theta " << t << ": sampled " << a << " +- " << se
                                  << ", quadrature " << q << " +- " << seQ);
                CHECK(std::abs(a - q) <= 5.0 * std::sqrt(se * se + seQ * seQ));
            }
        }
    }
}

// Mitsuba's formulas, written out for a pair: the diffuse and retro-reflection with sheen (specular
// 0 makes eta 1: no dielectric reflection), and a metal's Schlick reflection.
TEST_CASE("principled follows Mitsuba's diffuse sheen and metal formulas", "[principled]") {
    const Vec3 wo = dirDeg(35.f, 0.2f), wi = dirDeg(60.f, 2.5f);
    const Vec3 h = glm::normalize(wo + wi);
    auto sw = [](float c) { return std::pow(std::clamp(1.f - c, 0.f, 1.f), 5.f); };
    {
        PrincipledParams p;
        p.baseColor = Color(0.6f, 0.3f, 0.2f);
        p.roughness = 0.7f;
        p.sheen = 0.8f;
        p.eta = 1.f;
        const Color f = makePrincipled(p)->eval(wo, wi, kRadianceContext).f;
        const float fo = sw(wi.z), fi = sw(wo.z), cd = glm::dot(h, wi), rr = 2.f * 0.7f * cd * cd;
        const float shape = (1.f - 0.5f * fo) * (1.f - 0.5f * fi) + rr * (fo + fi + fo * fi * (rr - 1.f));
        const Color expect = p.baseColor * (shape * kInvPi) + Color(0.8f * sw(cd));
        INFO(f.x << " " << expect.x);
        CHECK(close(f, expect, 1e-5f));
    }
    {
        PrincipledParams p;
        p.baseColor = Color(0.9f, 0.6f, 0.3f);
        p.roughness = 0.4f;
        p.metallic = 1.f;
        const Color f = makePrincipled(p)->eval(wo, wi, kRadianceContext).f;
        const Microfacet mf(MicrofacetType::GGX, 0.16f, 0.16f);
        const float c = glm::dot(wo, h);
        const Color F = p.baseColor + (Color(1.f) - p.baseColor) * sw(c);
        const Color expect = F * (mf.D(h) * mf.G1(wo, h) * mf.G1(wi, h) / (4.f * wo.z * wi.z));
        CHECK(close(f, expect, 1e-5f));
    }
    // The loader's specular: eta = 2 / (1 - sqrt(0.08 specular)) - 1 (specular 0.5: 1.5).
    CHECK(etaOfSpecular(0.5f) == Approx(1.5f).epsilon(1e-6));
}

TEST_CASE("textured principled is the untextured model of the point's values", "[principled]") {
    const glm::mat3 toUv(1.f);
    PrincipledParams base;
    base.baseColor = Color(0.3f, 0.6f, 0.8f);
    base.roughness = 0.15f;
    base.eta = etaOfSpecular(0.4f);
    PrincipledTextures t;
    t.anisotropic = makeCheckerboard(Color(0.2f), Color(0.7f), toUv);
    t.specTrans = makeCheckerboard(Color(0.7f), Color(0.1f), toUv);
    t.clearcoat = makeCheckerboard(Color(0.6f), Color(0.3f), toUv);
    t.sheen = makeCheckerboard(Color(0.2f), Color(0.9f), toUv);
    t.baseColor = makeCheckerboard(Color(0.1f, 0.2f, 0.3f), Color(0.9f, 0.5f, 0.4f), toUv);
    const BxdfPtr tex = makePrincipled(base, t);
    CHECK(tex->textured());
    CHECK(tex->anisotropic());
    CHECK((tex->flags() & kTransmission) != 0);
    CHECK((tex->flags() & kDiffuse) != 0);
    for (const Vec2& uv : {Vec2(0.25f, 0.25f), Vec2(0.75f, 0.25f)}) {
        PrincipledParams q = base;
        q.anisotropic = t.anisotropic->evalScalar(uv);
        q.specTrans = t.specTrans->evalScalar(uv);
        q.clearcoat = t.clearcoat->evalScalar(uv);
        q.sheen = t.sheen->evalScalar(uv);
        q.baseColor = t.baseColor->eval(uv);
        BxdfInstance storage;
        const Bxdf* at = tex->atUv(uv, storage.bytes, sizeof(storage.bytes));
        requireSameModel(*at, *makePrincipled(q));
    }
}

TEST_CASE("loader builds principled with Mitsuba's names and defaults and refuses bad values", "[principled][loader]") {
    TempDir dir("lt_test_principled");
    auto body = [&](const std::string& b) {
        return dir.write("s.xml", "<scene version=\"3.0.0\">\n" + b + "\n</scene>\n");
    };
    {
        const SceneDesc s = loadScene(body(R"(
            <bsdf type="principled" id="a"/>
            <bsdf type="principled" id="b">
                <rgb name="base_color" value="0.2, 0.8, 0.1"/><float name="roughness" value="0.15"/>
                <float name="metallic" value="0.3"/><float name="specular" value="0.7"/>
                <float name="spec_trans" value="0.4"/><float name="anisotropic" value="0.5"/>
                <float name="sheen" value="0.3"/><float name="sheen_tint" value="0.2"/>
                <float name="clearcoat" value="0.6"/><float name="clearcoat_gloss" value="0.3"/>
                <float name="spec_tint" value="0.4"/><float name="flatness" value="0.1"/>
                <float name="main_specular_sampling_rate" value="0.5"/>
            </bsdf>
            <bsdf type="principled" id="c"><float name="eta" value="1"/><float name="spec_trans" value="1"/></bsdf>
            <bsdf type="principled" id="d">
                <texture name="metallic" type="checkerboard"><float name="color0" value="0.7"/><float name="color1" value="0.1"/></texture>
            </bsdf>)"));
        REQUIRE(s.bsdfs.size() == 4);
        requireSameModel(*s.bsdfs[0], *makePrincipled(PrincipledParams{}));
        PrincipledParams b;
        b.baseColor = Color(0.2f, 0.8f, 0.1f);
        b.roughness = 0.15f;
        b.metallic = 0.3f;
        b.eta = etaOfSpecular(0.7f);
        b.specTrans = 0.4f;
        b.anisotropic = 0.5f;
        b.sheen = 0.3f;
        b.sheenTint = 0.2f;
        b.clearcoat = 0.6f;
        b.clearcoatGloss = 0.3f;
        b.specTint = 0.4f;
        b.flatness = 0.1f;
        b.specularRate = 0.5f;
        requireSameModel(*s.bsdfs[1], *makePrincipled(b));
        PrincipledParams c;
        c.eta = 1.001f;  // (Mitsuba: no transmission through an index-matched interface)
        c.specTrans = 1.f;
        requireSameModel(*s.bsdfs[2], *makePrincipled(c));
        CHECK(s.bsdfs[3]->textured());
    }
    const std::vector<std::pair<std::string, std::string>> bad = {
        {R"(<bsdf type="principled"><float name="eta" value="1.5"/><float name="specular" value="0.5"/></bsdf>)", "specular"},
        {R"(<bsdf type="principled"><float name="roughness" value="-0.1"/></bsdf>)", "roughness"},
        {R"(<bsdf type="principled"><float name="sheen" value="1.2"/></bsdf>)", "sheen"},
        {R"(<bsdf type="principled"><float name="specular" value="2"/></bsdf>)", "specular"},
        {R"(<bsdf type="principled"><float name="eta" value="0"/></bsdf>)", "eta"},
        {R"(<bsdf type="principled"><float name="clearcoat_sampling_rate" value="-1"/></bsdf>)", "clearcoat_sampling_rate"},
        {R"(<bsdf type="principled"><rgb name="base_color" value="-0.1, 0.5, 0.5"/></bsdf>)", "base_color"},
        {R"(<bsdf type="principled"><float name="no_such_parameter" value="1"/></bsdf>)", "no_such_parameter"},
        {R"(<bsdf type="principled">
                <texture name="clearcoat" type="checkerboard"><float name="color0" value="1.5"/></texture></bsdf>)", "clearcoat"},
        {R"(<bsdf type="principled">
                <texture name="eta" type="checkerboard"/></bsdf>)", "eta"},
    };
    for (const auto& [b, param] : bad) {
        const std::string msg = loadError(body(b));
        INFO(b << " -> " << msg);
        CHECK(msg.find(param) != std::string::npos);
        CHECK(msg.find("s.xml:") != std::string::npos);  // the file and the line
    }
}

// The Cornell box with a principled panel and sphere: PT's, BPT's, VCM's and LT's images agree (each a
// different mix of techniques: BPT and VCM connect at the principled vertices and weight by their
// reverse densities; refraction carries eta into the MIS densities).
TEST_CASE("Cornell box with principled materials: PT BPT VCM and LT agree", "[principled][statistical]") {
    std::vector<std::pair<std::string, BxdfPtr>> panels;
    {
        PrincipledParams p;
        p.baseColor = Color(0.3f, 0.6f, 0.8f);
        p.roughness = 0.3f;
        p.specTrans = 0.7f;
        p.clearcoat = 0.6f;
        p.sheen = 0.5f;
        p.eta = etaOfSpecular(0.4f);
        panels.push_back({"spec_trans clearcoat sheen", makePrincipled(p)});
    }
    {
        PrincipledParams p;
        p.baseColor = Color(0.2f, 0.8f, 0.1f);
        p.roughness = 0.25f;
        p.metallic = 0.6f;
        p.anisotropic = 0.6f;
        p.clearcoat = 0.9f;
        p.sheen = 0.9f;
        p.eta = etaOfSpecular(0.7f);
        panels.push_back({"metallic anisotropic clearcoat", makePrincipled(p)});
    }
    for (const auto& [name, panel] : panels) {
        SceneDesc d = cornellBox(16, panel);
        {
            // (the white walls too: the light's first bounces, where BPT's and VCM's light subpaths
            // evaluate the BSDF in Importance mode)
            PrincipledParams w;
            w.baseColor = Color(0.7f);
            w.sheen = 0.3f;
            d.bsdfs[0] = makePrincipled(w);
        }
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
        // Light tracing alone: every light path's vertex evaluated in Importance mode.
        INFO(name);
        checkAgreesWithPt(d, s, {"lt"}, 8);
    }
}

// ---- principledthin ----------------------------------------------------------------------------
namespace {

struct ThinCase {
    std::string name;
    PrincipledThinParams p;
    float lobeAlpha;  // the sharpest specular lobe's alpha (the chi-square's cap scale)
};
std::vector<ThinCase> thinCases() {
    std::vector<ThinCase> c;
    {
        PrincipledThinParams p;
        p.baseColor = Color(0.7f, 0.1f, 0.1f);
        p.anisotropic = 0.5f;
        p.specTrans = 0.5f;
        p.diffTrans = 0.35f;
        p.sheen = 0.5f;
        p.eta = 1.33f;
        c.push_back({"thin scene-like", p, 0.07f});
    }
    {
        PrincipledThinParams p;
        p.baseColor = Color(0.9f, 0.8f, 0.7f);
        p.roughness = 0.2f;
        p.specTrans = 0.9f;
        p.specTint = 0.5f;
        p.flatness = 0.5f;
        p.diffTrans = 0.5f;
        p.eta = 1.5f;
        c.push_back({"thin glossy", p, 0.018f});
    }
    {
        PrincipledThinParams p;
        p.roughness = 0.05f;
        p.specTrans = 1.f;
        p.eta = 1.2f;
        c.push_back({"thin smooth sheet", p, 0.0009f});
    }
    return c;
}
int thinChi2CaseCount() { return int(thinCases().size() * kAngles.size() * 2); }

// Peaks: the mirror direction and the straight-through one (the sheet does not bend light).
void runThinChi2(const ThinCase& c, const Vec3& wo, uint64_t seed, double level) {
    const Vec3 mirror(-wo.x, -wo.y, wo.z);
    runLobeChi2(*makePrincipledThin(c.p), c.name, wo, {mirror, -mirror}, c.lobeAlpha, seed, level);
}

}  // namespace

TEST_CASE("chi2 principledthin sampling against the eval pdf", "[principled][thin][chi2]") {
    const double level = chi2::sidakCorrectedLevel(0.01, thinChi2CaseCount());
    uint64_t seed = 313;
    for (const ThinCase& c : thinCases())
        for (float t : kAngles)
            for (float side : {1.f, -1.f}) {
                Vec3 wo = dirDeg(t);
                wo.z *= side;
                runThinChi2(c, wo, seed += 7919, level);
            }
}

// Weights and densities in both modes; the adjoint relation f_rad(wo, wi) = f_imp(wi, wo); both
// sides the same; no light bent (eta 1).
TEST_CASE("principledthin weights densities adjoint and two sides", "[principled][thin]") {
    for (const ThinCase& c : thinCases()) {
        const BxdfPtr b = makePrincipledThin(c.p);
        for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance})
          for (const RegularizationRequest& req : someRequests()) {
            const BsdfContext ctx(mode, req);
            Rng rng(3, 5);
            int n = 0, bad = 0, trans = 0;
            for (int k = 0; k < 4000; ++k) {
                const Vec3 wo = anyDir(rng);
                BsdfSample s;
                const float ul = rng.uniform();
                const Vec2 u = rng.uniform2();
                if (!b->sample(wo, ul, u, ctx, s)) continue;
                ++n;
                if (s.lobe & kTransmission) ++trans;
                const BsdfEval e = b->eval(wo, s.wi, ctx), r = b->eval(s.wi, wo, ctx);
                const Color w = e.f * (std::abs(s.wi.z) / e.pdfFwd.value);
                const bool ok = close(w, s.weight, 1e-4f, 1e-6f) && close(e.pdfFwd.value, s.pdfFwd.value, 1e-5f) &&
                                close(e.pdfRev.value, s.pdfRev.value, 1e-5f) &&
                                close(r.pdfFwd.value, e.pdfRev.value, 1e-5f) && s.eta == 1.f &&
                                ((s.lobe & kTransmission) ? (s.wi.z * wo.z < 0.f) : (s.wi.z * wo.z > 0.f));
                if (!ok) ++bad;
            }
            INFO(c.name << " mode " << int(mode) << " request tau " << req.tau << " minAlpha " << req.minAlpha.alphaU
                        << ": " << bad << " bad of " << n);
            CHECK(n > 3000);
            CHECK(trans > 100);
            CHECK(bad == 0);
        }
        Rng rng(7, 13);
        int bad = 0, nonZero = 0;
        for (int k = 0; k < 20000; ++k) {
            const Vec3 wo = anyDir(rng), wi = anyDir(rng);
            const Color fR = b->eval(wo, wi, kRadianceContext).f;
            if (maxComp(fR) > 0.f) ++nonZero;
            bool ok = fR == b->eval(wi, wo, kImportanceContext).f && fR == b->eval(-wo, -wi, kRadianceContext).f;
            if (wo.z * wi.z > 0.f) ok = ok && close(fR, b->eval(wi, wo, kRadianceContext).f, 2e-4f, 1e-7f);
            if (!ok) ++bad;
        }
        INFO(c.name << ": " << bad << " bad of " << nonZero);
        CHECK(nonZero > 10000);
        CHECK(bad == 0);
    }
}

// Energy: a white sheet of pure specular lobes or pure diffuse transmission loses energy or keeps it
// (the diffuse transmission alone: exactly 1); the diffuse reflection mixtures have Burley's
// retro-reflection, as principled's.
TEST_CASE("white furnace principledthin specular and transmission lobes create no energy", "[principled][thin]") {
    const int n = 60000;
    std::vector<std::pair<std::string, PrincipledThinParams>> white;
    for (float r : {0.05f, 0.3f, 0.8f}) {
        PrincipledThinParams p;
        p.baseColor = Color(1.f);
        p.roughness = r;
        p.specTrans = 1.f;
        p.eta = 1.5f;
        white.push_back({"white specular sheet roughness " + std::to_string(r), p});
    }
    PrincipledThinParams lambertT;
    lambertT.baseColor = Color(1.f);
    lambertT.diffTrans = 1.f;
    white.push_back({"white diffuse transmission", lambertT});
    for (const auto& [name, p] : white) {
        const BxdfPtr b = makePrincipledThin(p);
        for (float t : {0.f, 40.f, 70.f, 85.f}) {
            const Vec3 wo = dirDeg(t);
            Rng rng(uint64_t(1e4f * wo.z) + 5, 9);
            double sum = 0.0, sum2 = 0.0;
            for (int k = 0; k < n; ++k) {
                BsdfSample s;
                const float ul = rng.uniform();
                const Vec2 u = rng.uniform2();
                if (!b->sample(wo, ul, u, kImportanceContext, s)) continue;
                sum += s.weight.x;
                sum2 += double(s.weight.x) * s.weight.x;
            }
            const double a = sum / n, se = std::sqrt(std::max(0.0, sum2 / n - a * a) / n);
            INFO(name << " theta " << t << " albedo " << a << " +- " << se);
            CHECK(a <= 1.0 + 5.0 * se + 1e-6);
            CHECK(a > 0.05);  // (a rough sheet at grazing incidence keeps about 0.11 in Mitsuba's model)
            if (p.specTrans == 0.f) CHECK(a == Approx(1.0).epsilon(1e-5));
        }
    }
}

TEST_CASE("loader builds principledthin with Mitsuba's names and defaults and refuses bad values", "[principled][thin][loader]") {
    TempDir dir("lt_test_principledthin");
    auto body = [&](const std::string& b) {
        return dir.write("s.xml", "<scene version=\"3.0.0\">\n" + b + "\n</scene>\n");
    };
    const SceneDesc s = loadScene(body(R"(
        <bsdf type="principledthin" id="a"/>
        <bsdf type="principledthin" id="b">
            <rgb name="base_color" value="0.7, 0.1, 0.1"/><float name="spec_trans" value="0.5"/>
            <float name="diff_trans" value="1.4"/><float name="eta" value="1.33"/><float name="sheen" value="0.2"/>
            <float name="diffuse_transmittance_sampling_rate" value="0.5"/>
        </bsdf>
        <bsdf type="principledthin" id="c">
            <texture name="eta" type="checkerboard"><float name="color0" value="1.2"/><float name="color1" value="1.6"/></texture>
        </bsdf>)"));
    REQUIRE(s.bsdfs.size() == 3);
    requireSameModel(*s.bsdfs[0], *makePrincipledThin(PrincipledThinParams{}));
    PrincipledThinParams b;
    b.baseColor = Color(0.7f, 0.1f, 0.1f);
    b.specTrans = 0.5f;
    b.diffTrans = 0.7f;  // (Mitsuba's diff_trans / 2)
    b.eta = 1.33f;
    b.sheen = 0.2f;
    b.diffTransRate = 0.5f;
    requireSameModel(*s.bsdfs[1], *makePrincipledThin(b));
    CHECK(s.bsdfs[2]->textured());
    const std::vector<std::pair<std::string, std::string>> bad = {
        {R"(<bsdf type="principledthin"><float name="diff_trans" value="2.5"/></bsdf>)", "diff_trans"},
        {R"(<bsdf type="principledthin"><float name="spec_trans" value="1.1"/></bsdf>)", "spec_trans"},
        {R"(<bsdf type="principledthin"><float name="eta" value="-1"/></bsdf>)", "eta"},
        {R"(<bsdf type="principledthin"><float name="metallic" value="0.5"/></bsdf>)", "metallic"},
        {R"(<bsdf type="principledthin"><float name="specular_reflectance_sampling_rate" value="-2"/></bsdf>)",
         "specular_reflectance_sampling_rate"},
    };
    for (const auto& [text, param] : bad) {
        const std::string msg = loadError(body(text));
        INFO(text << " -> " << msg);
        CHECK(msg.find(param) != std::string::npos);
        CHECK(msg.find("s.xml:") != std::string::npos);
    }
}

// A principledthin panel (two-sided: the box's light reaches both of its sides) and sphere, and
// principled walls: PT, BPT, VCM and LT agree.
TEST_CASE("Cornell box with a principledthin panel: PT BPT VCM and LT agree", "[principled][thin][statistical]") {
    PrincipledThinParams p = thinCases()[0].p;
    SceneDesc d = cornellBox(16, makePrincipledThin(p));
    PrincipledParams w;
    w.baseColor = Color(0.7f);
    w.sheen = 0.3f;
    d.bsdfs[0] = makePrincipled(w);
    RenderSettings s;
    s.spp = 32;
    s.maxDepth = 5;
    s.integrator = "pt";
    const auto ref = blockStats(d, s, 8, 4);
    for (const char* integ : {"bpt", "vcm"}) {
        s.integrator = integ;
        double worst;
        const int bad = differingBlocks(ref, blockStats(d, s, 8, 4), 0.01, &worst);
        INFO("pt against " << integ << ": " << bad << " blocks differ, worst |t|/crit " << worst);
        CHECK(bad == 0);
    }
    checkAgreesWithPt(d, s, {"lt"}, 8);
}
