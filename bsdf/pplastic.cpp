// Mitsuba 3's pplastic (polarised plastic, after Baek et al. 2018) as its non-polarised (rgb)
// variants render it (the plugin docs and the `else` branches of pplastic.cpp's eval and pdf): a
// sum of two lobes, one-sided (black where wo.z <= 0 or wi.z <= 0),
//   f = specR F(o.h, eta) D(h) G2 / (4 mu_o mu_i)  +  diffR (1 - F(mu_o)) (1 - F(mu_i)) / pi,
// F the dielectric Fresnel reflectance of eta = int_ior / ext_ior, D GGX or Beckmann (possibly
// anisotropic), G2 = G1(wo) G1(wi) Smith (Mitsuba's separable form). Unlike plastic, no internal
// scattering and no 1/eta^2: the two lobes are added "ad hoc" (Mitsuba's words). f is symmetric in
// (wo, wi): reciprocal, one value in both transport modes.
// Sampling (Mitsuba's): the microfacet lobe (visible normals of wo) with probability
// w = mean(specR) / (mean(diffR) + mean(specR)), else the cosine-weighted hemisphere; the density is
// the mixture's, the weight f cos / pdf.
// Mitsuba clamps alpha to at least 1e-4 (its MicrofacetDistribution): the lobe is always glossy.
// Regularisation (bsdf.h): the microfacet lobe resolves the request on its alphas
// (MicrofacetLobe::resolve, reflection, no energy compensation); the diffuse lobe keeps its value.
// The cone is for smooth lobes: this model has none and ignores it.
#include "bsdf/bsdf.h"
#include "bsdf/fresnel.h"
#include "bsdf/microfacet.h"
#include "bsdf/roughness_bound.h"

namespace lt {

namespace {

float mean3(const Color& c) { return (c.x + c.y + c.z) / 3.f; }

class PolarizedPlasticBxdf final : public Bxdf {
public:
    PolarizedPlasticBxdf(MicrofacetType dist, float au, float av, float eta, const Color& diffR, const Color& specR)
        : lobe_{dist, MaskingModel::Smith, std::max(au, kMinAlpha), std::max(av, kMinAlpha)}, eta_(eta),
          diffR_(diffR * kInvPi), specR_(specR) {
        const float d = mean3(diffR), s = mean3(specR);
        pSpec_ = d + s > 0.f ? s / (d + s) : 0.5f;
        // The base's largest value: (1 - F)^2 is largest at normal incidence (F grows with the angle).
        const float t0 = 1.f - fresnelDielectric(1.f, eta_);
        diffBound_ = maxComp(diffR_) * t0 * t0;
        continuation_ = std::max(continuationOf(specR), continuationOf(diffR));
        cacheBounds();
    }

    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override {
        BsdfEval e;
        const float cosO = wo.z, cosI = wi.z;
        if (!(cosO > 0.f) || !(cosI > 0.f)) return e;
        e.f = diffR_ * ((1.f - fresnelDielectric(cosO, eta_)) * (1.f - fresnelDielectric(cosI, eta_)));
        if (!ctx.valueOnly) {
            e.pdfFwd = SolidAnglePdf((1.f - pSpec_) * cosI * kInvPi);
            e.pdfRev = SolidAnglePdf((1.f - pSpec_) * cosO * kInvPi);
        }
        const Microfacet mf = lobe_.microfacet(lobe_.resolve(ctx.reg, false, 1.f));
        const MicrofacetReflectionTerms r = microfacetReflectionTerms(mf, wo, wi);
        if (!(r.value > 0.f)) return e;
        // Fresnel at the average of wo.h and wi.h (equal up to rounding): exactly reciprocal.
        e.f += specR_ * (fresnelDielectric(0.5f * (glm::dot(wo, r.h) + glm::dot(wi, r.h)), eta_) * r.value);
        if (ctx.valueOnly) return e;
        e.pdfFwd.value += pSpec_ * r.reflectDensity(wo, r.gO);
        e.pdfRev.value += pSpec_ * r.reflectDensity(wi, r.gI);
        return e;
    }

    bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const override {
        if (!(wo.z > 0.f)) return false;
        const bool spec = uLobe < pSpec_;
        Vec3 wi;
        if (spec) {
            const Microfacet mf = lobe_.microfacet(lobe_.resolve(ctx.reg, false, 1.f));
            float unused = 0.f;
            const Vec3 m = mf.sampleVisible(wo, u, unused);
            if (!(glm::dot(wo, m) > 0.f)) return false;
            wi = reflectAbout(wo, m);
        } else {
            wi = sampleCosineHemisphere(u);
        }
        if (!(wi.z > 0.f)) return false;
        out.wi = wi;
        if (ctx.directionOnly) return true;
        BsdfContext full = ctx;
        full.valueOnly = false;
        const BsdfEval e = eval(wo, wi, full);
        if (!(e.pdfFwd.value > 0.f) || !std::isfinite(e.pdfFwd.value)) return false;
        out.weight = e.f * (wi.z / e.pdfFwd.value);
        out.pdfFwd = e.pdfFwd;
        out.pdfRev = e.pdfRev;
        out.lobe = spec ? (kReflection | kGlossy) : (kReflection | kDiffuse);
        out.eta = 1.f;
        return true;
    }

    uint32_t flags() const override { return kReflection | kGlossy | kDiffuse; }
    // The base's bound plus the lobe's (without Fresnel and colour, as the conductor's).
    float valueBound(const BsdfContext& ctx) const override {
        const MicrofacetLobe::Resolved a = lobe_.resolve(ctx.reg, false, 1.f);
        const float alpha = std::max(std::min(a.u, a.v), kMinAlpha);
        return diffBound_ + maxValueBound(lobe_.type, lobe_.masking, alpha, false, 1.f, ctx.reg.bound);
    }
    // The microfacet lobe's alpha: the lobe a request changes (as plastic's coating).
    float roughness() const override { return scalarRoughness(lobe_.alphaU, lobe_.alphaV); }
    Roughness alpha() const override { return {lobe_.alphaU, lobe_.alphaV}; }
    std::string name() const override { return "pplastic"; }

private:
    MicrofacetLobe lobe_;
    float eta_;
    Color diffR_;  // diffR / pi
    Color specR_;
    float pSpec_ = 0.5f;     // Mitsuba's specular sampling weight
    float diffBound_ = 0.f;  // the base's largest value
};

}  // namespace

BxdfPtr makePolarizedPlastic(MicrofacetType dist, float alphaU, float alphaV, float eta, const Color& diffuseReflectance,
                             const Color& specularReflectance) {
    return std::make_shared<PolarizedPlasticBxdf>(dist, alphaU, alphaV, eta, diffuseReflectance, specularReflectance);
}

}  // namespace lt
