// Rough diffuse reflection: Oren and Nayar's model ("Generalization of Lambert's reflectance
// model", SIGGRAPH 1994) with the parameters of Mitsuba 0.6's roughdiffuse plugin (its
// documentation is the spec; Mitsuba 3 has no such plugin): reflectance R (default 0.5), alpha the
// RMS slope of the V-grooves (default 0.2; Oren and Nayar's sigma = alpha / sqrt(2), Mitsuba's
// conversion), use_fast_approx. One-sided (black where wo.z <= 0 or wi.z <= 0).
// With theta_o, theta_i the polar angles, a = max, b = min of them, dphi the azimuth between them
// and s = sigma^2:
//   fast (the paper's qualitative model, Eq. 30):
//     f = R / pi (A + B max(0, cos dphi) sin a tan b),  A = 1 - s / (2 (s + 0.33)),
//                                                       B = 0.45 s / (s + 0.09)
//   full (Eqs. 27-29: direct illumination of the facets plus one interreflection):
//     f = R / pi (C1 + cos dphi C2 tan b + (1 - |cos dphi|) C3 tan((a + b) / 2))
//       + R^2 / pi C4 (1 - cos dphi (2 b / pi)^2),
//     C1 = A, C2 = 0.45 s / (s + 0.09) (sin a, or sin a - (2 b / pi)^3 where cos dphi <= 0),
//     C3 = 0.125 s / (s + 0.09) (4 a b / pi^2)^2, C4 = 0.17 s / (s + 0.13).
// Both are symmetric in (wo, wi): reciprocal, the same in both transport modes. alpha = 0 gives
// R / pi exactly (Lambert). The value grows without bound where both directions graze in the same
// azimuth (tan b), so no finite valueBound exists; the directional albedo stays finite.
// Sampling: cosine-weighted, as Mitsuba's. A diffuse lobe: regularisation requests leave it as it is.
#include "bsdf/bsdf.h"
#include "core/sampling.h"
#include "core/texture/texture.h"

namespace lt {

namespace {

class RoughDiffuseBxdf final : public Bxdf {
public:
    RoughDiffuseBxdf(const Color& r, float alpha, bool fast) : RoughDiffuseBxdf(r, alpha, fast, Instance{}) {
        continuation_ = continuationOf(r);
        cacheBounds();
    }
    // A textured material's model at one point (Bxdf::atUv; evaluated and sampled only).
    struct Instance {};
    RoughDiffuseBxdf(const Color& r, float alpha, bool fast, Instance) : r_(r), alpha_(alpha), fast_(fast) {
        const float sigma = alpha * 0.70710678f;  // 1 / sqrt(2)
        s_ = sigma * sigma;
    }

    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override {
        BsdfEval e;
        const float cosO = wo.z, cosI = wi.z;
        if (!(cosO > 0.f) || !(cosI > 0.f)) return e;
        e.f = value(wo, wi);
        if (ctx.valueOnly) return e;
        e.pdfFwd = SolidAnglePdf(cosI * kInvPi);
        e.pdfRev = SolidAnglePdf(cosO * kInvPi);
        return e;
    }
    bool sample(const Vec3& wo, float, const Vec2& u, const BsdfContext&, BsdfSample& out) const override {
        if (!(wo.z > 0.f)) return false;
        const Vec3 wi = sampleCosineHemisphere(u);
        if (!(wi.z > 0.f)) return false;
        const float pdf = wi.z * kInvPi;
        out.wi = wi;
        out.weight = value(wo, wi) * (wi.z / pdf);
        out.pdfFwd = SolidAnglePdf(pdf);
        out.pdfRev = SolidAnglePdf(wo.z * kInvPi);
        out.lobe = kReflection | kDiffuse;
        out.eta = 1.f;
        return true;
    }
    uint32_t flags() const override { return kReflection | kDiffuse; }
    float roughness() const override { return 1.f; }
    // (unbounded where both directions graze: see the top; R / pi without roughness)
    float valueBound(const BsdfContext&) const override { return s_ > 0.f ? kInf : maxComp(r_) * kInvPi; }
    std::string name() const override { return "roughdiffuse"; }

    // f for wo.z > 0 and wi.z > 0.
    Color value(const Vec3& wo, const Vec3& wi) const {
        const float cosO = wo.z, cosI = wi.z;
        const float sinO = std::sqrt(std::max(0.f, 1.f - cosO * cosO));
        const float sinI = std::sqrt(std::max(0.f, 1.f - cosI * cosI));
        float cosDphi = 0.f;  // (undefined at the pole: 0, as Mitsuba)
        if (sinO > 1e-4f && sinI > 1e-4f)
            cosDphi = std::clamp((wo.x * wi.x + wo.y * wi.y) / (sinO * sinI), -1.f, 1.f);
        // a = the larger polar angle (the smaller cosine), b the smaller one.
        const bool iSteeper = cosI > cosO;
        const float sinA = iSteeper ? sinO : sinI, sinB = iSteeper ? sinI : sinO;
        const float tanB = iSteeper ? sinI / cosI : sinO / cosO;
        const float s = s_;
        if (fast_) {
            const float A = 1.f - 0.5f * s / (s + 0.33f), B = 0.45f * s / (s + 0.09f);
            return r_ * (kInvPi * (A + B * std::max(cosDphi, 0.f) * sinA * tanB));
        }
        const float thetaO = std::acos(std::min(cosO, 1.f)), thetaI = std::acos(std::min(cosI, 1.f));
        const float a = std::max(thetaO, thetaI), b = std::min(thetaO, thetaI);
        const float t = s / (s + 0.09f), ab = (4.f * kInvPi * kInvPi) * a * b, b2 = 2.f * b * kInvPi;
        const float c1 = 1.f - 0.5f * s / (s + 0.33f);
        const float c2 = 0.45f * t * (cosDphi > 0.f ? sinA : sinA - b2 * b2 * b2);
        const float c3 = 0.125f * t * ab * ab;
        const float c4 = 0.17f * s / (s + 0.13f);
        const float tanHalf = (sinA + sinB) / (std::sqrt(std::max(0.f, 1.f - sinA * sinA)) +
                                               std::sqrt(std::max(0.f, 1.f - sinB * sinB)));
        const Color single = r_ * (c1 + cosDphi * c2 * tanB + (1.f - std::abs(cosDphi)) * c3 * tanHalf);
        const Color twice = r_ * r_ * (c4 * (1.f - cosDphi * b2 * b2));
        return (single + twice) * kInvPi;
    }

private:
    Color r_;
    float alpha_;
    bool fast_;
    float s_ = 0.f;  // sigma^2
};

// roughdiffuse with a textured reflectance and/or alpha: the model at a point is the untextured
// one of the point's values (atUv); without a point, the model of the textures' means. Bounds:
// +inf where any alpha is positive, else the largest reflectance over pi.
class TexturedRoughDiffuseBxdf final : public Bxdf {
public:
    TexturedRoughDiffuseBxdf(const Color& r, float alpha, bool fast, TexturePtr rTex, TexturePtr aTex)
        : r_(r), alpha_(alpha), fast_(fast), rTex_(std::move(rTex)), aTex_(std::move(aTex)),
          mean_(rTex_ ? rTex_->meanValue() : r, aTex_ ? scalarOf(aTex_->meanValue()) : alpha, fast) {
        maxR_ = rTex_ ? rTex_->maxValue() : r;
        maxAlpha_ = aTex_ ? scalarOf(aTex_->maxValue()) : alpha;
        textured_ = true;
        continuation_ = continuationOf(maxR_);
        cacheBounds();
    }
    const Bxdf* atUv(const Vec2& uv, void* storage, size_t capacity) const override {
        return emplaceInstance<RoughDiffuseBxdf>(storage, capacity, rTex_ ? rTex_->eval(uv) : r_,
                                                 aTex_ ? aTex_->evalScalar(uv) : alpha_, fast_,
                                                 RoughDiffuseBxdf::Instance{});
    }
    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override { return mean_.eval(wo, wi, ctx); }
    bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const override {
        return mean_.sample(wo, uLobe, u, ctx, out);
    }
    uint32_t flags() const override { return kReflection | kDiffuse; }
    float roughness() const override { return 1.f; }
    float valueBound(const BsdfContext&) const override { return maxAlpha_ > 0.f ? kInf : maxComp(maxR_) * kInvPi; }
    std::string name() const override { return "roughdiffuse(textured)"; }

private:
    Color r_;
    float alpha_;
    bool fast_;
    TexturePtr rTex_, aTex_;
    RoughDiffuseBxdf mean_;
    Color maxR_{0.f};
    float maxAlpha_ = 0.f;
};

}  // namespace

BxdfPtr makeRoughDiffuse(const Color& reflectance, float alpha, bool fast, TexturePtr reflectanceTexture,
                         TexturePtr alphaTexture) {
    if (reflectanceTexture || alphaTexture)
        return std::make_shared<TexturedRoughDiffuseBxdf>(reflectance, alpha, fast, std::move(reflectanceTexture),
                                                          std::move(alphaTexture));
    return std::make_shared<RoughDiffuseBxdf>(reflectance, alpha, fast);
}

}  // namespace lt
