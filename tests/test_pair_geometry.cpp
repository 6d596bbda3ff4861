// rho_hat / rho without evaluations (bsdf.h, PairGeometry; Bxdf::requestRatio): the ratio of a
// BSDF's value under a regularisation request to its plain value, from the pair's
// alpha-independent geometry, against the two evaluations it replaces. Deterministic (fixed
// seeds); the tolerance is float rounding: eval computes D in double and the rest in float, the
// ratio in double, so the two agree to a few float ulps of each factor (1e-4 relative leaves two
// orders of magnitude of margin, and a wrong factor, e.g. a missed alpha in one Lambda, is off by
// far more: the test "a wrong formula is detected" below shows it for the smallest change).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "bsdf/bsdf.h"
#include "bsdf/energy_compensation.h"
#include "bsdf/microfacet.h"
#include "bsdf/roughness_bound.h"
#include "bsdf/surface_bsdf.h"
#include "core/rng.h"
#include "core/sampling.h"

using namespace lt;

namespace {

const Color kCuEta(0.200438f, 0.924033f, 1.10221f), kCuK(3.91295f, 2.45285f, 2.14219f);

struct Model {
    std::string name;
    BxdfPtr bxdf;
};

std::vector<Model> roughModels() {
    std::vector<Model> m;
    char buf[160];
    for (MicrofacetType t : {MicrofacetType::GGX, MicrofacetType::Beckmann})
        for (MaskingModel k : {MaskingModel::Smith, MaskingModel::VCavity})
            for (float a : {1e-3f, 0.05f, 0.3f, 0.9f}) {
                const char* tn = t == MicrofacetType::GGX ? "GGX" : "Beckmann";
                const char* kn = k == MaskingModel::Smith ? "Smith" : "VCavity";
                std::snprintf(buf, sizeof buf, "conductor %s %s alpha %g", tn, kn, a);
                m.push_back({buf, makeRoughConductor(t, a, a, kCuEta, kCuK, Color(1.f), k)});
                for (float eta : {1.33f, 1.5f, 2.4f, 1.f / 1.5f}) {
                    std::snprintf(buf, sizeof buf, "dielectric %s %s alpha %g eta %g", tn, kn, a, eta);
                    m.push_back({buf, makeRoughDielectric(t, a, a, eta, Color(1.f), Color(1.f), k)});
                }
            }
    m.push_back({"twosided conductor GGX Smith alpha 0.2",
                 makeTwoSided(makeRoughConductor(MicrofacetType::GGX, 0.2f, 0.2f, kCuEta, kCuK, Color(1.f)))});
    return m;
}

std::vector<RegularizationRequest> requests() {
    std::vector<RegularizationRequest> r;
    // (each with and without the energy compensation of the lobe made rougher: a compensated
    // lobe's ratio has the factor E(alpha_0) / E(alpha) at the light side, energy_compensation.h)
    for (bool compensate : {true, false}) {
        for (float g : {0.002f, 0.08f, 0.5f, 1.f}) {
            RegularizationRequest q;
            q.minAlpha = {g, g};
            q.compensate = compensate;
            r.push_back(q);
        }
        for (float tau : {0.5f, 30.f, 1000.f}) {
            RegularizationRequest q;
            q.tau = tau;
            q.compensate = compensate;
            r.push_back(q);
            q.minAlpha = {0.1f, 0.1f};  // both (OPSR with JG19's bound)
            r.push_back(q);
        }
    }
    return r;
}

float channelSum(const Color& c) { return c.x + c.y + c.z; }

// Every rough model under every request on 300 random pairs (the transport modes alternating),
// with the pair's geometry, which each of these models has.
template <class F>
void forEachPair(Rng& rng, F&& f) {
    for (const Model& m : roughModels()) {
        INFO(m.name);
        for (const RegularizationRequest& req : requests()) {
            for (int i = 0; i < 300; ++i) {
                const Vec3 wo = sampleUniformSphere(rng.uniform2()), wi = sampleUniformSphere(rng.uniform2());
                const TransportMode mode = i % 2 ? TransportMode::Importance : TransportMode::Radiance;
                const PairGeometry g = m.bxdf->pairGeometry(wo, wi);
                REQUIRE(g.available());
                INFO("wo " << wo.x << " " << wo.y << " " << wo.z << " wi " << wi.x << " " << wi.y << " " << wi.z);
                f(*m.bxdf, req, wo, wi, mode, g);
            }
        }
    }
}

}  // namespace

TEST_CASE("requestRatio equals the quotient of the two evaluations for every rough isotropic lobe") {
    Rng rng(17, 3);
    int compared = 0, zeros = 0, transmissions = 0;
    forEachPair(rng, [&](const Bxdf& b, const RegularizationRequest& req, const Vec3& wo, const Vec3& wi,
                         TransportMode mode, const PairGeometry& g) {
        const float plain = channelSum(b.eval(wo, wi, BsdfContext(mode)).f);
        const float hat = channelSum(b.eval(wo, wi, BsdfContext(mode, req)).f);
        const float r = b.requestRatio(g, BsdfContext(mode, req));
        INFO("plain " << plain << " hat " << hat << " ratio " << r);
        if (g.lobe == PairGeometry::Lobe::Zero) {
            // Claimed 0 under every request: the plain and the request's values are 0.
            CHECK(plain == 0.f);
            CHECK(hat == 0.f);
            CHECK(r == 1.f);
            ++zeros;
            return;
        }
        transmissions += g.lobe == PairGeometry::Lobe::Transmission;
        if (plain == hat) {
            // (the request leaves this pair's alpha as it is: exactly 1, as regularisedRatio)
            if (plain > 0.f) CHECK(r == 1.f);
            return;
        }
        if (plain < 1e-30f || hat < 1e-30f) return;  // (float underflow in eval: not comparable)
        CHECK(r == Approx(hat / plain).epsilon(1e-4));
        ++compared;
    });
    // The sweep reached every case it is for.
    CHECK(compared > 20000);
    CHECK(zeros > 1000);
    CHECK(transmissions > 5000);
}

TEST_CASE("requestPdfRatio equals the quotient of the two evaluations' densities for every rough isotropic lobe") {
    // The sampling density of wi (pdfFwd) under the request over the plain one, against the two
    // evaluations, on the models, requests and random pairs of the value test. Tolerance 1e-4: the
    // ratio is formed in double from tan^2 of the pair, the densities in float (as for the values).
    Rng rng(29, 5);
    int compared = 0, transmissions = 0, grazing = 0;
    forEachPair(rng, [&](const Bxdf& b, const RegularizationRequest& req, const Vec3& wo, const Vec3& wi,
                         TransportMode mode, const PairGeometry& g) {
        if (g.lobe == PairGeometry::Lobe::Zero) return;  // (the value test checks those)
        const BsdfEval plain = b.eval(wo, wi, BsdfContext(mode));
        const BsdfEval hat = b.eval(wo, wi, BsdfContext(mode, req));
        const float p = b.requestPdfRatio(g, req);
        INFO("plain pdf " << plain.pdfFwd.value << " hat pdf " << hat.pdfFwd.value << " ratio " << p);
        if (plain.pdfFwd.value == hat.pdfFwd.value) {
            if (plain.pdfFwd.value > 0.f && channelSum(plain.f) == channelSum(hat.f)) CHECK(p == 1.f);
            return;
        }
        if (plain.pdfFwd.value < 1e-30f || hat.pdfFwd.value < 1e-30f) return;  // (float underflow)
        CHECK(p == Approx(hat.pdfFwd.value / plain.pdfFwd.value).epsilon(1e-4));
        transmissions += g.lobe == PairGeometry::Lobe::Transmission;
        grazing += std::abs(wo.z) < 0.1f;
        ++compared;
    });
    CHECK(compared > 20000);
    CHECK(transmissions > 5000);
    CHECK(grazing > 1000);
}

TEST_CASE("requestRatio is exactly 1 where the request changes no alpha") {
    const BxdfPtr b = makeRoughConductor(MicrofacetType::GGX, 0.3f, 0.3f, kCuEta, kCuK, Color(1.f));
    RegularizationRequest below;
    below.minAlpha = {0.2f, 0.2f};
    const PairGeometry g = b->pairGeometry(Vec3(0.3f, 0.1f, 0.95f), Vec3(-0.2f, 0.4f, 0.89f));
    REQUIRE(g.lobe == PairGeometry::Lobe::Reflection);
    for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
        CHECK(b->requestRatio(g, BsdfContext(mode, below)) == 1.f);
        CHECK(b->requestRatio(g, BsdfContext(mode)) == 1.f);
    }
}

TEST_CASE("requestRatioBound bounds requestRatio over every pair and is approached in the tails") {
    // OPSR's path tracer lets the walk's own sample stand for the regularised one where this bound
    // is at most 4 (opsr.h (4)): its weight is then at most 4 times the walk's own. Checked on the
    // sweep's random pairs: every finite bound holds (to float rounding, 1e-5 relative; the GGX
    // half of the models), and the pairs come within 10% of it for some lobe (it is D's quotient
    // at tan^2 h -> inf, not a loose one). The cases without a bound are checked by hand below.
    Rng rng(31, 7);
    int bounded = 0, unbounded = 0;
    float closest = 0.f;
    forEachPair(rng, [&](const Bxdf& b, const RegularizationRequest& req, const Vec3&, const Vec3&, TransportMode mode,
                         const PairGeometry& g) {
        const float bound = b.requestRatioBound(req);
        const float r = b.requestRatio(g, BsdfContext(mode, req));
        INFO("ratio " << r << " bound " << bound);
        if (!(bound < kInf)) {
            ++unbounded;
            return;
        }
        CHECK(r <= bound * (1.f + 1e-5f));
        if (bound > 1.5f) closest = std::max(closest, r / bound);
        ++bounded;
    });
    CHECK(bounded > 30000);
    CHECK(unbounded > 30000);
    CHECK(closest > 0.9f);
    // By hand: (b / a)^2 for GGX, +inf for Beckmann made rougher, 1 where nothing changes
    // (uncompensated; compensated: times the lobe's K, below).
    RegularizationRequest to08;
    to08.minAlpha = {0.08f, 0.08f};
    to08.compensate = false;
    for (MaskingModel k : {MaskingModel::Smith, MaskingModel::VCavity}) {
        CHECK(makeRoughConductor(MicrofacetType::GGX, 0.05f, 0.05f, kCuEta, kCuK, Color(1.f), k)->requestRatioBound(to08) ==
              Approx(2.56f).epsilon(1e-5));
        CHECK(makeRoughDielectric(MicrofacetType::GGX, 0.05f, 0.05f, 1.5f, Color(1.f), Color(1.f), k)
                  ->requestRatioBound(to08) == Approx(2.56f).epsilon(1e-5));
        // Mitsuba's twosided: the inner model's pairs, mirrored, and so its bound.
        CHECK(makeTwoSided(makeRoughConductor(MicrofacetType::GGX, 0.05f, 0.05f, kCuEta, kCuK, Color(1.f), k))
                  ->requestRatioBound(to08) == Approx(2.56f).epsilon(1e-5));
        CHECK(!(makeRoughConductor(MicrofacetType::Beckmann, 0.05f, 0.05f, kCuEta, kCuK, Color(1.f), k)
                    ->requestRatioBound(to08) < kInf));
    }
    CHECK(makeRoughConductor(MicrofacetType::Beckmann, 0.3f, 0.3f, kCuEta, kCuK, Color(1.f))->requestRatioBound(to08) ==
          1.f);
    // Compensated (the default): D's quotient times the lobe's K, the sup of E(alpha_0) / E(alpha).
    RegularizationRequest to08c = to08;
    to08c.compensate = true;
    const LobeCompensation k05(MicrofacetLobe{MicrofacetType::GGX, MaskingModel::Smith, 0.05f, 0.05f});
    REQUIRE(k05.boundFactor(false, 0.08f) > 1.f);
    CHECK(makeRoughConductor(MicrofacetType::GGX, 0.05f, 0.05f, kCuEta, kCuK, Color(1.f))->requestRatioBound(to08c) ==
          Approx(2.56f * k05.boundFactor(false, 0.08f)).epsilon(1e-5));
    CHECK(makeRoughConductor(MicrofacetType::GGX, 0.3f, 0.3f, kCuEta, kCuK, Color(1.f))
              ->requestRatioBound(RegularizationRequest{}) == 1.f);
    // No bound the models know: anisotropic, smooth (a delta made rough), Lambert, index-matched.
    CHECK(!(makeRoughConductor(MicrofacetType::GGX, 0.05f, 0.3f, kCuEta, kCuK, Color(1.f))->requestRatioBound(to08) < kInf));
    CHECK(!(makeConductor(kCuEta, kCuK, Color(1.f))->requestRatioBound(to08) < kInf));
    CHECK(!(makeDielectric(1.5f)->requestRatioBound(to08) < kInf));
    CHECK(!(makeDiffuse(Color(0.5f))->requestRatioBound(to08) < kInf));
    CHECK(!(makeRoughDielectric(MicrofacetType::GGX, 0.05f, 0.05f, 1.f)->requestRatioBound(to08) < kInf));
    // JG19's bound resolves to its own alpha per lobe: the dielectric's is the larger of the two.
    RegularizationRequest tau;
    tau.tau = 30.f;
    tau.compensate = false;
    const BxdfPtr glass = makeRoughDielectric(MicrofacetType::GGX, 0.01f, 0.01f, 1.5f);
    // (the request's bound form: tight by default)
    const float aR = alphaForBound(MicrofacetType::GGX, MaskingModel::Smith, 30.f, false, 1.5f, BoundForm::Tight);
    const float aT = alphaForBound(MicrofacetType::GGX, MaskingModel::Smith, 30.f, true, 1.5f, BoundForm::Tight);
    const float b = std::max(aR, aT) / 0.01f;
    CHECK(glass->requestRatioBound(tau) == Approx(b * b).epsilon(1e-5));
}

TEST_CASE("pairGeometry is unavailable where the form does not hold") {
    const Vec3 wo(0.3f, 0.1f, 0.95f), wi(-0.2f, 0.4f, 0.89f);
    CHECK(!makeDiffuse(Color(0.5f))->pairGeometry(wo, wi).available());
    CHECK(!makeConductor(kCuEta, kCuK, Color(1.f))->pairGeometry(wo, wi).available());       // a delta
    CHECK(!makeDielectric(1.5f)->pairGeometry(wo, wi).available());                           // a delta
    CHECK(!makeRoughDielectric(MicrofacetType::GGX, 0.2f, 0.2f, 1.f)->pairGeometry(wo, wi).available());  // index-matched
    CHECK(!makeRoughConductor(MicrofacetType::GGX, 0.05f, 0.3f, kCuEta, kCuK, Color(1.f))->pairGeometry(wo, wi).available());
}

TEST_CASE("SurfaceBsdf's pairGeometry is the local one, and Zero where the normals disagree") {
    const BxdfPtr b = makeRoughDielectric(MicrofacetType::GGX, 0.2f, 0.2f, 1.5f);
    const Vec3 n = glm::normalize(Vec3(0.3f, -0.2f, 0.9f));
    const Frame frame(n);
    const Vec3 woL(0.3f, 0.1f, 0.95f), wiL(-0.2f, 0.4f, -0.89f);
    const Vec3 wo = frame.toWorld(glm::normalize(woL)), wi = frame.toWorld(glm::normalize(wiL));
    RegularizationRequest req;
    req.minAlpha = {0.6f, 0.6f};
    const SurfaceBsdf s(b.get(), frame, n, Vec2(0.f));
    const PairGeometry world = s.pairGeometry(wo, wi), local = b->pairGeometry(glm::normalize(woL), glm::normalize(wiL));
    REQUIRE(world.lobe == PairGeometry::Lobe::Transmission);
    const BsdfContext ctx(TransportMode::Radiance, req);
    CHECK(b->requestRatio(world, ctx) == Approx(b->requestRatio(local, ctx)).epsilon(1e-5));
    CHECK(b->requestRatio(world, ctx) ==
          Approx(channelSum(s.eval(wo, wi, BsdfContext(TransportMode::Radiance, req)).f) /
                 channelSum(s.eval(wo, wi, BsdfContext(TransportMode::Radiance)).f))
              .epsilon(1e-4));
    // A geometric normal on the other side of wi than the shading normal: eval is 0, and so the
    // geometry says for every request.
    const Vec3 ng = glm::normalize(n - 3.f * wi * glm::dot(wi, n));
    REQUIRE(glm::dot(ng, wi) * glm::dot(n, wi) < 0.f);
    const SurfaceBsdf leak(b.get(), frame, ng, Vec2(0.f));
    CHECK(leak.pairGeometry(wo, wi).lobe == PairGeometry::Lobe::Zero);
    CHECK(isBlack(leak.eval(wo, wi, BsdfContext(TransportMode::Radiance, req)).f));
}

TEST_CASE("microfacetAlphaRatio: a wrong formula is detected") {
    // The comparison above must be able to fail: the ratio with the request's alpha a few ulps
    // of 1e-3 off (a Lambda evaluated at the wrong alpha would be off by far more) differs from
    // the evaluations' quotient by more than the tolerance on a grazing pair.
    const PairGeometry g = microfacetPairGeometry(glm::normalize(Vec3(0.95f, 0.f, 0.1f)),
                                                  glm::normalize(Vec3(-0.6f, 0.3f, 0.7f)), 1.f, MaskingModel::Smith);
    REQUIRE(g.lobe == PairGeometry::Lobe::Reflection);
    const float right = microfacetAlphaRatio(MicrofacetType::GGX, MaskingModel::Smith, 0.05f, 0.3f, g);
    const float off = microfacetAlphaRatio(MicrofacetType::GGX, MaskingModel::Smith, 0.05f, 0.3f * 1.001f, g);
    CHECK(off != Approx(right).epsilon(1e-4));
}
