// Tests of the libm-free sin/cos behind the concentric disk and the cosine hemisphere
// (core/sampling.h), and of SurfaceBsdf against a transcription of its straightforward form
// (each dot product computed where it is used), which it must reproduce bit for bit.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>

#include "bsdf/bsdf.h"
#include "bsdf/surface_bsdf.h"
#include "core/rng.h"
#include "core/sampling.h"

using namespace lt;

namespace {

// Shirley-Chiu in double from the same float o = 2u - 1 as the renderer (the reference).
glm::dvec2 diskReference(const Vec2& u) {
    const Vec2 o = 2.f * u - Vec2(1.f);
    const double x = o.x, y = o.y;
    if (x == 0 && y == 0) return glm::dvec2(0.0);
    const double q = 0.78539816339744830962;  // pi/4
    double r, theta;
    if (std::abs(x) > std::abs(y)) { r = x; theta = q * (y / x); }
    else { r = y; theta = 2 * q - q * (x / y); }
    return r * glm::dvec2(std::cos(theta), std::sin(theta));
}

}  // namespace

TEST_CASE("sinCosQuarterPi matches std::sin and std::cos over [-1, 1]", "[sampling]") {
    const double q = 0.78539816339744830962;
    double maxSin = 0, maxCos = 0, maxNorm = 0;
    const int n = 1 << 21;  // every 2^-21 of t: 4M+1 points
    for (int i = -n; i <= n; ++i) {
        const float t = float(i) / float(n);
        const SinCos sc = sinCosQuarterPi(t);
        maxSin = std::max(maxSin, std::abs(double(sc.sin) - std::sin(q * t)));
        maxCos = std::max(maxCos, std::abs(double(sc.cos) - std::cos(q * t)));
        maxNorm = std::max(maxNorm, std::abs(double(sc.sin) * sc.sin + double(sc.cos) * sc.cos - 1.0));
    }
    INFO("max abs error sin " << maxSin << " cos " << maxCos << " |sin^2+cos^2-1| " << maxNorm);
    CHECK(maxSin < 2e-7);
    CHECK(maxCos < 2e-7);
    CHECK(maxNorm < 4e-7);
    // Exact where it matters: the disk centre and the ends of the range are symmetric.
    CHECK(sinCosQuarterPi(0.f).sin == 0.f);
    CHECK(sinCosQuarterPi(0.f).cos == 1.f);
    CHECK(sinCosQuarterPi(-0.5f).sin == -sinCosQuarterPi(0.5f).sin);
    CHECK(sinCosQuarterPi(-0.5f).cos == sinCosQuarterPi(0.5f).cos);
}

TEST_CASE("concentric disk matches the libm map and the cosine hemisphere is unit with consistent pdf", "[sampling]") {
    // Dense grid over the square, including both diagonals (branch seams) and the edges.
    const int n = 1024;
    double maxDisk = 0, maxNorm = 0;
    int below = 0;
    for (int i = 0; i <= n; ++i)
        for (int j = 0; j <= n; ++j) {
            const Vec2 u(std::min(float(i) / n, 0.99999994f), std::min(float(j) / n, 0.99999994f));
            const Vec2 d = sampleConcentricDisk(u);
            const glm::dvec2 ref = diskReference(u);
            maxDisk = std::max(maxDisk, std::max(std::abs(d.x - ref.x), std::abs(d.y - ref.y)));
            const Vec3 w = sampleCosineHemisphere(u);
            maxNorm = std::max(maxNorm, std::abs(std::sqrt(double(w.x) * w.x + double(w.y) * w.y + double(w.z) * w.z) - 1.0));
            if (w.z < 0.f || w.x != d.x || w.y != d.y) ++below;
        }
    INFO("max |disk - reference| " << maxDisk << ", max ||w| - 1| " << maxNorm);
    CHECK(maxDisk < 3e-7);
    CHECK(maxNorm < 1e-6);
    CHECK(below == 0);
    CHECK(sampleConcentricDisk(Vec2(0.5f)) == Vec2(0.f));

    // pdf consistency: the map u -> w pushes the uniform density on [0,1]^2 to cos/pi, so the
    // Jacobian |dw/du1 x dw/du2| must equal 1/pdf = pi/cos (central differences, away from the
    // seams |o.x| = |o.y|, the centre and the rim where the derivatives are not smooth).
    Rng rng(7, 0);
    const float h = 1e-3f;
    double maxRel = 0;
    int checked = 0;
    while (checked < 20000) {
        const Vec2 u = rng.uniform2();
        const Vec2 o = 2.f * u - Vec2(1.f);
        if (std::abs(std::abs(o.x) - std::abs(o.y)) < 8 * h || std::max(std::abs(o.x), std::abs(o.y)) < 0.05f) continue;
        if (u.x < 2 * h || u.y < 2 * h || u.x > 1 - 2 * h || u.y > 1 - 2 * h) continue;
        const Vec3 w = sampleCosineHemisphere(u);
        if (w.z < 0.3f) continue;
        const glm::dvec3 d1 = (glm::dvec3(sampleCosineHemisphere(u + Vec2(h, 0))) - glm::dvec3(sampleCosineHemisphere(u - Vec2(h, 0)))) / (2.0 * h);
        const glm::dvec3 d2 = (glm::dvec3(sampleCosineHemisphere(u + Vec2(0, h))) - glm::dvec3(sampleCosineHemisphere(u - Vec2(0, h)))) / (2.0 * h);
        const double jac = glm::length(glm::cross(d1, d2));
        const double expected = 1.0 / cosineHemispherePdf(w.z);
        maxRel = std::max(maxRel, std::abs(jac / expected - 1.0));
        ++checked;
    }
    INFO("max relative Jacobian error " << maxRel);
    CHECK(maxRel < 5e-3);
}

namespace {

// The straightforward SurfaceBsdf (before the dot products were shared), transcribed.
struct ReferenceSurfaceBsdf {
    const Bxdf* bxdf;
    const Frame& frame;
    const Vec3& ng;
    bool consistent(const Vec3& w) const { return glm::dot(w, ng) * glm::dot(w, frame.n) > 0.f; }
    float adjointCorrection(const Vec3& wo, const Vec3& wi) const {
        float num = std::abs(glm::dot(wo, frame.n) * glm::dot(wi, ng));
        float den = std::abs(glm::dot(wo, ng) * glm::dot(wi, frame.n));
        return den > 0.f ? num / den : 0.f;
    }
    BsdfEval eval(const Vec3& woW, const Vec3& wiW, TransportMode mode) const {
        BsdfEval e;
        if (!consistent(woW) || !consistent(wiW)) return e;
        e = bxdf->eval(frame.toLocal(woW), frame.toLocal(wiW), BsdfContext(mode));
        if (mode == TransportMode::Importance) e.f *= adjointCorrection(woW, wiW);
        return e;
    }
    bool sample(const Vec3& woW, float uLobe, const Vec2& u, TransportMode mode, BsdfSample& s) const {
        if (!consistent(woW)) return false;
        if (!bxdf->sample(frame.toLocal(woW), uLobe, u, BsdfContext(mode), s)) return false;
        s.wi = frame.toWorld(s.wi);
        if (!consistent(s.wi)) return false;
        if (mode == TransportMode::Importance) s.weight *= adjointCorrection(woW, s.wi);
        return true;
    }
};

bool same(const BsdfEval& a, const BsdfEval& b) {
    return a.f == b.f && a.pdfFwd.value == b.pdfFwd.value && a.pdfRev.value == b.pdfRev.value;
}
bool same(const BsdfSample& a, const BsdfSample& b) {
    return a.wi == b.wi && a.weight == b.weight && a.pdfFwd.value == b.pdfFwd.value &&
           a.pdfRev.value == b.pdfRev.value && a.lobe == b.lobe && a.eta == b.eta;
}

}  // namespace

TEST_CASE("SurfaceBsdf eval and sample are bit-identical to the straightforward form", "[bsdf][sampling]") {
    const BxdfPtr bxdfs[] = {makeDiffuse(Color(0.2f, 0.5f, 0.8f)), makeTwoSided(makeDiffuse(Color(0.7f))),
                             makeRoughConductor(MicrofacetType::GGX, 0.3f, 0.1f, Color(0.2f, 0.9f, 1.1f),
                                                Color(3.9f, 2.4f, 2.1f), Color(1.f)),
                             makeRoughDielectric(MicrofacetType::Beckmann, 0.2f, 0.2f, 1.5f)};
    // The plain diffuse model goes through SurfaceBsdf's inline Lambert path (no virtual call),
    // every other one (the two-sided diffuse included) through the virtual calls: both are checked.
    CHECK(bxdfs[0]->lambert() != nullptr);
    for (int i = 1; i < 4; ++i) CHECK(bxdfs[i]->lambert() == nullptr);
    Rng rng(11, 0);
    int evals = 0, samples = 0, rejected = 0;
    for (const BxdfPtr& bxdf : bxdfs)
        for (int k = 0; k < 20000; ++k) {
            // A geometric normal and a shading normal tilted from it (up to ~35 degrees), so that
            // the consistency test rejects a fraction of the directions.
            const Vec3 ng = sampleUniformSphere(rng.uniform2());
            const Vec3 n = glm::normalize(ng + 0.7f * sampleUniformSphere(rng.uniform2()) * rng.uniform());
            const Frame frame(n);
            const Vec3 wo = sampleUniformSphere(rng.uniform2());
            const Vec3 wi = sampleUniformSphere(rng.uniform2());
            const SurfaceBsdf bsdf(bxdf.get(), frame, ng, Vec2(0.f));
            const ReferenceSurfaceBsdf ref{bxdf.get(), frame, ng};
            for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
                const BsdfEval a = bsdf.eval(wo, wi, mode), b = ref.eval(wo, wi, mode);
                if (!same(a, b)) {
                    FAIL_CHECK(bxdf->name() << " eval differs at k=" << k);
                    return;
                }
                ++evals;
                const float uLobe = rng.uniform();
                const Vec2 u = rng.uniform2();
                BsdfSample sa, sb;
                const bool oka = bsdf.sample(wo, uLobe, u, mode, sa), okb = ref.sample(wo, uLobe, u, mode, sb);
                if (oka != okb || (oka && !same(sa, sb))) {
                    FAIL_CHECK(bxdf->name() << " sample differs at k=" << k);
                    return;
                }
                if (oka) ++samples; else ++rejected;
            }
        }
    INFO(evals << " evals, " << samples << " samples, " << rejected << " rejected");
    CHECK(samples > 50000);
    CHECK(rejected > 1000);
}
