// principled and principledthin under the regularisers' requests (bsdf/principled.cpp,
// bsdf/principled_thin.cpp, principled.h): each microfacet lobe resolved on its own, the value
// bound that JG19's heuristics read, sampling against the pdf under a request, textured materials'
// bounds over their points, and a JG19 render through principled glass.
//
// Statistical tests and their levels:
// * Chi-square: the family has a significance of 1%, Sidak-corrected per test (as test_principled).
// * Render: PT and BPT estimate the same regularised integrand (JG19's choice is a function of the
//   path); their means over the imaged light's 20 x 20 pixels are compared within 3% (measured:
//   0.02% apart at 16 spp, seed 1; the imaged light's mean is about 30x plain PT's).
#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "bsdf/bsdf.h"
#include "bsdf/fresnel.h"
#include "bsdf/microfacet.h"
#include "bsdf/principled.h"
#include "bsdf/roughness_bound.h"
#include "bsdf_chi2.h"
#include "bsdf_compare.h"
#include "core/loader.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "core/texture/texture_factory.h"
#include "process.h"
#include "regularizer_paths.h"

using namespace lt;
using namespace lt::test;

namespace {


RegularizationRequest tauRequest(float tau, BoundForm form = BoundForm::Tight) {
    RegularizationRequest r;
    r.tau = tau;
    r.bound = form;
    return r;
}
RegularizationRequest minAlphaRequest(float a) {
    RegularizationRequest r;
    r.minAlpha = {a, a};
    return r;
}

struct Case {
    std::string name;
    BxdfPtr bxdf;
    bool bare;        // microfacet lobes only (no diffuse, sheen): every value is a regularised lobe's
    float eta;        // the refracted peak's (principled with spec_trans), 0: none
    bool transmits;   // wo below the surface too
};

std::vector<Case> cases() {
    std::vector<Case> c;
    {
        PrincipledParams p;  // a polished metal: the main reflection alone
        p.baseColor = Color(0.9f, 0.6f, 0.3f);
        p.metallic = 1.f;
        p.roughness = 0.05f;
        c.push_back({"metal", makePrincipled(p), true, 0.f, false});
    }
    {
        PrincipledParams p;  // glass: reflection and refraction of one distribution
        p.baseColor = Color(0.95f);
        p.specTrans = 1.f;
        p.roughness = 0.04f;
        p.eta = 1.5f;
        c.push_back({"glass", makePrincipled(p), true, 1.5f, true});
    }
    {
        PrincipledParams p;  // a sharp clearcoat over a rough dielectric base
        p.baseColor = Color(0.2f, 0.5f, 0.8f);
        p.roughness = 0.6f;
        p.clearcoat = 1.f;
        p.clearcoatGloss = 1.f;  // GTR1 alpha 0.001
        c.push_back({"clearcoat", makePrincipled(p), false, 0.f, false});
    }
    {
        PrincipledParams p;  // everything at once, anisotropic
        p.baseColor = Color(0.7f, 0.3f, 0.2f);
        p.roughness = 0.1f;
        p.anisotropic = 0.7f;
        p.metallic = 0.2f;
        p.specTrans = 0.5f;
        p.clearcoat = 0.5f;
        p.clearcoatGloss = 0.9f;
        p.sheen = 0.5f;
        p.specTint = 0.3f;
        p.eta = 1.4f;
        c.push_back({"mixture", makePrincipled(p), false, 1.4f, true});
    }
    {
        PrincipledThinParams p;  // a thin specular sheet: reflection and straight transmission
        p.baseColor = Color(0.9f);
        p.specTrans = 1.f;
        p.roughness = 0.05f;
        c.push_back({"thin sheet", makePrincipledThin(p), true, 0.f, true});
    }
    {
        PrincipledThinParams p;
        p.baseColor = Color(0.4f, 0.7f, 0.5f);
        p.specTrans = 0.6f;
        p.roughness = 0.1f;
        p.anisotropic = 0.5f;
        p.diffTrans = 0.8f;
        p.sheen = 0.4f;
        p.specTint = 0.5f;
        c.push_back({"thin mixture", makePrincipledThin(p), false, 0.f, true});
    }
    return c;
}

// The largest channel of f over pairs that reach each lobe's peak: uniform pairs, the model's own
// samples under ctx (they crowd the regularised peaks) and mirror / straight-through pairs from
// normal to grazing incidence.
float maxValue(const Bxdf& b, const BsdfContext& ctx) {
    float m = 0.f;
    auto at = [&](const Vec3& wo, const Vec3& wi) { m = std::max(m, maxComp(b.eval(wo, wi, ctx).f)); };
    Rng rng(17, 3);
    for (int k = 0; k < 4000; ++k) at(sampleUniformSphere(rng.uniform2()), sampleUniformSphere(rng.uniform2()));
    for (int k = 0; k < 2000; ++k) {
        const Vec3 wo = sampleUniformSphere(rng.uniform2());
        BsdfSample s;
        for (int j = 0; j < 4; ++j)
            if (b.sample(wo, rng.uniform(), rng.uniform2(), ctx, s)) at(wo, s.wi);
    }
    for (float t : {0.f, 30.f, 60.f, 80.f, 88.f, 89.5f}) {
        const Vec3 wo = dirDeg(t), mirror(-wo.x, -wo.y, wo.z);
        at(wo, mirror);
        at(wo, -mirror);
        at(wo, glm::normalize(mirror + Vec3(0.01f, 0.f, 0.f)));
    }
    return m;
}

}  // namespace

// JG19's property: under a bound tau every regularised lobe's value stays below tau (the bare
// cases, where every value is a lobe's), and valueBound bounds the whole model under every request
// (the diffuse and sheen lobes' bound added), falls with tau and is finite.
TEST_CASE("GTR1's alpha for a bound is the least float alpha whose peak meets it", "[principled][regularization]") {
    // gtr1AlphaForBound solves gtr1Peak(alpha) = bound (Newton's method in ln(1 / alpha^2)): for
    // bounds from below the peak at alpha 0.99 up to 10^12 (log-spaced), the alpha returned meets
    // the bound, the next float below does not, and alpha falls as the bound rises.
    using namespace principled_detail;
    float last = 1.f;
    for (int i = 0; i <= 3000; ++i) {
        const float bound = float(std::pow(10.0, -0.6 + 12.6 * i / 3000.0));
        const float a = gtr1AlphaForBound(bound);
        INFO("bound " << bound << " alpha " << a);
        REQUIRE(a > 0.f);
        REQUIRE(a <= kMaxGtr1Alpha);
        if (a < kMaxGtr1Alpha) {
            CHECK(gtr1Peak(a) <= bound);
            if (a > 1e-6f) CHECK(gtr1Peak(std::nextafter(a, 0.f)) > bound);
        } else {
            CHECK(gtr1Peak(std::nextafter(a, 0.f)) > bound);  // (capped: even 0.99 does not meet it)
        }
        CHECK(a <= last);
        last = a;
    }
    CHECK(gtr1AlphaForBound(kInf) == 0.f);
}

TEST_CASE("principled and principledthin under a bound: each lobe stays under tau and valueBound bounds the model",
          "[principled][regularization]") {
    for (const Case& c : cases())
        for (BoundForm form : {BoundForm::Tight, BoundForm::Published})
            for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
                const Bxdf& b = *c.bxdf;
                const float plain = b.plainBound(form);
                INFO(c.name << " form " << int(form) << " mode " << int(mode) << " plain bound " << plain);
                REQUIRE(std::isfinite(plain));
                CHECK(maxValue(b, BsdfContext(mode)) <= plain * 1.001f);
                CHECK(b.changeableBound(form) > 0.f);
                CHECK(b.changeableBound(form) <= plain);
                float previous = 0.f;
                for (float tau : {3.f, 30.f, 300.f, 3000.f}) {
                    const BsdfContext ctx(mode, tauRequest(tau, form));
                    const float bound = b.valueBound(ctx), value = maxValue(b, ctx);
                    INFO("tau " << tau << ": bound " << bound << ", largest value " << value);
                    CHECK(value <= bound * 1.001f);
                    CHECK(bound >= previous);
                    CHECK(bound <= plain * 1.0001f);
                    previous = bound;
                    if (c.bare) {  // (where no alpha <= 1 meets tau, the lobes stop at alpha 1)
                        const float roughest = b.valueBound(BsdfContext(mode, minAlphaRequest(1.f)));
                        CHECK(bound <= std::max(tau, roughest) * 1.001f);
                        CHECK(value <= std::max(tau, roughest) * 1.001f);
                    }
                }
            }
}

TEST_CASE("principled requests raise each lobe's alphas on its own", "[principled][regularization]") {
    const Vec3 n(0.f, 0.f, 1.f);
    SECTION("no request and a cone change nothing, bit for bit") {
        RegularizationRequest cone;
        cone.cone = 0.1f;
        for (const Case& c : cases()) {
            INFO(c.name);
            requireSameEvalsAndSamples(*c.bxdf, *c.bxdf, RegularizationRequest{}, cone);
            CHECK(c.bxdf->valueBound(BsdfContext(TransportMode::Radiance, cone)) == c.bxdf->plainBound());
        }
    }
    SECTION("a metal under a roughness request is the metal of that roughness, bit for bit") {
        PrincipledParams p;
        p.baseColor = Color(0.9f, 0.6f, 0.3f);
        p.metallic = 1.f;
        p.roughness = 0.1f;  // alpha 0.01
        PrincipledParams rougher = p;
        rougher.roughness = 0.3f;
        const float a = rougher.roughness * rougher.roughness;
        requireSameEvalsAndSamples(*makePrincipled(p), *makePrincipled(rougher), minAlphaRequest(a), {});
        // A request below the material's alphas changes nothing.
        requireSameEvalsAndSamples(*makePrincipled(rougher), *makePrincipled(rougher), minAlphaRequest(0.01f), {});
    }
    SECTION("the clearcoat is raised while a rougher main lobe stays") {
        // Main alpha 0.36 > 0.2: only the GTR1 lobe changes; at normal incidence its value is
        // 0.25 clearcoat Schlick(0.04, 1) D(n) G1 G1 with G1 = 1, so the difference is
        // 0.25 clearcoat 0.04 (D_0.2(n) - D_0.001(n)).
        PrincipledParams p;
        p.roughness = 0.6f;
        p.clearcoat = 0.8f;
        p.clearcoatGloss = 1.f;
        const BxdfPtr b = makePrincipled(p);
        const float plain = b->eval(n, n, kRadianceContext).f.x;
        const float req = b->eval(n, n, BsdfContext(TransportMode::Radiance, minAlphaRequest(0.2f))).f.x;
        const float expect = 0.25f * 0.8f * 0.04f * (principled_detail::gtr1Peak(0.2f) - principled_detail::gtr1Peak(0.001f));
        CHECK(principled_detail::Gtr1{0.001f}.D(n) == Approx(principled_detail::gtr1Peak(0.001f)).epsilon(1e-5));
        CHECK(req - plain == Approx(expect).epsilon(2e-3));
        CHECK(req < plain);  // (the sharp coat's peak is higher than the raised one's)
    }
    SECTION("glass and the thin sheet at normal incidence, by hand") {
        // D_a(n) = 1 / (pi a^2), G1 = 1 at normal incidence: the main reflection F D / 4, the
        // refraction 0 there (h = n is not a refraction's half vector for wi = -n unless eta = 1),
        // the sheet's reflection st F D / 4 and straight transmission st base (1 - F) D / 4.
        const float a = 0.2f, d = 1.f / (kPi * a * a), F = fresnelDielectric(1.f, 1.5f);
        const RegularizationRequest r = minAlphaRequest(a);
        PrincipledParams g;
        g.specTrans = 1.f;
        g.roughness = 0.04f;
        g.eta = 1.5f;
        CHECK(makePrincipled(g)->eval(n, n, BsdfContext(TransportMode::Radiance, r)).f.x == Approx(F * d / 4.f).epsilon(1e-4));
        PrincipledThinParams t;
        t.baseColor = Color(0.5f);
        t.specTrans = 1.f;
        t.roughness = 0.05f;
        t.eta = 1.5f;
        const BxdfPtr sheet = makePrincipledThin(t);
        const BsdfContext ctx(TransportMode::Radiance, r);
        CHECK(sheet->eval(n, n, ctx).f.x == Approx(F * d / 4.f).epsilon(1e-4));
        CHECK(sheet->eval(n, -n, ctx).f.x == Approx(0.5f * (1.f - F) * d / 4.f).epsilon(1e-4));
        CHECK(sheet->eval(n, n, ctx).f.x < sheet->eval(n, n, kRadianceContext).f.x);
    }
    SECTION("a bound resolves the refraction with its weight spec_trans, the reflection with 1") {
        // The shared alphas are the larger of alpha_hat(tau) for the reflection and
        // alpha_hat(tau / spec_trans) for the refraction; the bound is the larger of a reflection
        // pair's (the main lobe at the reflection's alpha_hat + the diffuse lobe's
        // (1 - spec_trans) max(base) / pi * shape bound) and a refraction pair's (spec_trans times
        // the refraction's bound at the shared alphas).
        for (float st : {1.f, 0.4f}) {
            PrincipledParams p;
            p.baseColor = Color(0.5f, 0.6f, 0.7f);
            p.specTrans = st;
            p.roughness = 0.04f;
            p.eta = 1.5f;
            const float tau = 50.f;
            auto hat = [&](bool trans, float t) {
                return alphaForBound(MicrofacetType::GGX, MaskingModel::Smith, t, trans, 1.5f, BoundForm::Tight);
            };
            auto rho = [&](bool trans, float a) {
                return maxValueBound(MicrofacetType::GGX, MaskingModel::Smith, a, trans, 1.5f, BoundForm::Tight);
            };
            const float a = std::max(hat(false, tau), hat(true, tau / st));
            const float diffuse = (1.f - st) * 0.7f * kInvPi * principled_detail::diffuseShapeBound(p.roughness);
            const float bound = makePrincipled(p)->valueBound(BsdfContext(TransportMode::Radiance, tauRequest(tau)));
            INFO("spec_trans " << st);
            CHECK(bound == Approx(std::max(rho(false, hat(false, tau)) + diffuse, st * rho(true, a))).epsilon(1e-5));
            if (st == 1.f) CHECK(bound <= tau * 1.001f);
        }
    }
}

TEST_CASE("chi2 principled and principledthin sampling under requests against the eval pdf",
          "[principled][regularization][chi2]") {
    // Bins at the scale of the regularised lobes (tau 300 raises GGX reflection to about 0.18; the
    // roughness request to 0.05; the clearcoat under tau stays sharper: its bins at 0.02).
    const std::vector<std::pair<std::string, RegularizationRequest>> requests = {{"tau 300", tauRequest(300.f)},
                                                                                {"alpha 0.05", minAlphaRequest(0.05f)}};
    int count = 0;
    for (const Case& c : cases()) count += int(requests.size()) * (c.transmits ? 2 : 1);
    const double level = chi2::sidakCorrectedLevel(0.01, count);
    uint64_t seed = 4441;
    for (const Case& c : cases())
        for (const auto& [label, r] : requests)
            for (float side : {1.f, -1.f}) {
                if (side < 0.f && !c.transmits) continue;
                Vec3 wo = dirDeg(40.f);
                wo.z *= side;
                const Vec3 mirror(-wo.x, -wo.y, wo.z);
                std::vector<Vec3> peaks{mirror};
                Vec3 t;
                if (c.eta > 0.f && refractAbout(wo, Vec3(0.f, 0.f, 1.f), c.eta, t)) peaks.push_back(t);
                if (c.eta == 0.f && c.transmits) peaks.push_back(-mirror);
                runLobeChi2(*c.bxdf, c.name + " " + label, wo, peaks, 0.02f, seed += 7919, level,
                            BsdfContext(TransportMode::Radiance, r));
            }
}

TEST_CASE("textured principled: the material's bounds hold at every point", "[principled][regularization]") {
    const glm::mat3 toUv(1.f);
    PrincipledParams base;
    base.roughness = 0.3f;
    PrincipledTextures t;
    t.roughness = makeCheckerboard(Color(0.03f), Color(0.5f), toUv);
    t.specTrans = makeCheckerboard(Color(0.f), Color(0.8f), toUv);
    t.clearcoat = makeCheckerboard(Color(1.f), Color(0.2f), toUv);
    t.clearcoatGloss = makeCheckerboard(Color(0.5f), Color(1.f), toUv);
    t.metallic = makeCheckerboard(Color(0.6f), Color(0.f), toUv);
    PrincipledThinParams thinBase;
    thinBase.specTrans = 0.7f;
    PrincipledThinTextures tt;
    tt.roughness = makeCheckerboard(Color(0.04f), Color(0.4f), toUv);
    tt.eta = makeCheckerboard(Color(1.2f), Color(1.7f), toUv);
    tt.diffTrans = makeCheckerboard(Color(0.f), Color(1.f), toUv);
    for (const BxdfPtr& tex : {makePrincipled(base, t), makePrincipledThin(thinBase, tt)}) {
        REQUIRE(tex->textured());
        for (const RegularizationRequest& r : {RegularizationRequest{}, tauRequest(30.f), tauRequest(3000.f),
                                               tauRequest(30.f, BoundForm::Published), minAlphaRequest(0.1f)}) {
            const BsdfContext ctx(TransportMode::Radiance, r);
            const float material = tex->valueBound(ctx);
            CHECK(std::isfinite(material));
            for (const Vec2& uv : {Vec2(0.25f, 0.25f), Vec2(0.75f, 0.25f), Vec2(0.25f, 0.75f), Vec2(0.75f, 0.75f)}) {
                BxdfInstance storage;
                const Bxdf* at = tex->atUv(uv, storage.bytes, sizeof(storage.bytes));
                INFO(tex->name() << " uv " << uv.x << " " << uv.y << " tau " << r.tau << " point " << at->valueBound(ctx)
                                 << " material " << material);
                CHECK(at->valueBound(ctx) <= material * 1.0001f);
                CHECK(maxValue(*at, ctx) <= material * 1.001f);
            }
        }
        for (BoundForm form : {BoundForm::Tight, BoundForm::Published}) {
            CHECK(tex->changeableBound(form) > 0.f);
            CHECK(tex->changeableBound(form) <= tex->plainBound(form));
        }
    }
}

TEST_CASE("JG19 renders a point light seen through principled glass, PT and BPT alike", "[principled][regularization][jg19][render]") {
    // scenes/hard/specular-point-view.xml with its smooth glass sphere made principled glass of
    // roughness 0.03 (alpha 0.001): the imaged light is a near-delta path (L S S E). Mean over the
    // 20 x 20 centre at 64 x 64 (measured): plain VCM 11.33 (512 spp), plain PT 11.61 (2048 spp),
    // PT+JG19 11.46 (256 spp). At 16 spp plain PT finds the glossy peak in almost no sample (0.36,
    // seed 1) while PT+JG19 gives 10.56 and BPT+JG19 10.56 (0.02% apart: one regularised
    // integrand). Before principled resolved requests, JG19's image was plain PT's.
    TempDir dir("lt_test_principled_reg");
    std::string xml = readText(std::string(LT_SOURCE_DIR) + "/scenes/hard/specular-point-view.xml");
    const std::string glass = R"(<bsdf type="dielectric">
            <string name="int_ior" value="bk7"/>
            <string name="ext_ior" value="air"/>
        </bsdf>)";
    const size_t at = xml.find(glass);
    REQUIRE(at != std::string::npos);
    xml.replace(at, glass.size(), R"(<bsdf type="principled"><float name="spec_trans" value="1"/>
        <float name="roughness" value="0.03"/><float name="eta" value="1.5168"/><rgb name="base_color" value="1"/></bsdf>)");
    const Scene scene(loadScene(dir.write("view.xml", xml), {{"res", "64"}}));
    RenderStats st;
    RenderSettings plainPt = settingsFor("pt", 16);
    plainPt.maxDepth = 12;
    plainPt.seed = 1;
    const double plain = cropMean(renderImage(scene, plainPt, st), 64, 22, 22, 20, 20);
    double disc[2];
    for (int i = 0; i < 2; ++i) {
        RenderSettings s = plainPt;
        s.integrator = i ? "bpt" : "pt";
        s.regularizer = "jg19";
        disc[i] = cropMean(renderImage(scene, s, st), 64, 22, 22, 20, 20);
        CHECK(st.regularisedContributions > 0);
    }
    INFO("plain PT " << plain << ", PT+JG19 " << disc[0] << ", BPT+JG19 " << disc[1]);
    CHECK(disc[0] > 10.0 * plain);
    CHECK(std::abs(disc[1] / disc[0] - 1.0) < 0.03);
}
