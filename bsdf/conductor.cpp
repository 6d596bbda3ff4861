// Smooth (delta) and rough (microfacet) conductors, one-sided like Mitsuba 3: black when
// wo.z <= 0 or wi.z <= 0. eta + i k is the complex IOR relative to the exterior.
#include "bsdf/bsdf.h"
#include "bsdf/cone_mollifier.h"
#include "bsdf/energy_compensation.h"
#include "bsdf/fresnel.h"
#include "bsdf/microfacet.h"
#include "bsdf/roughness_bound.h"

#include <optional>

namespace lt {

namespace {

class ConductorBxdf final : public Bxdf {
public:
    ConductorBxdf(bool rough, MicrofacetType dist, float au, float av, MaskingModel masking, const Color& eta,
                  const Color& k, const Color& specR)
        : rough_(rough), lobe_{dist, masking, rough ? au : 0.f, rough ? av : 0.f}, eta_(eta), k_(k), specR_(specR) {
        if (!rough || au == av) comp_.emplace(lobe_);  // (energy_compensation.h: smooth or isotropic)
        continuation_ = continuationOf(specR);  // the Fresnel factor is <= 1 on top
        cacheBounds();
    }

    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override {
        if (!rough_ && ctx.reg.cone > 0.f) return evalCone(wo, wi, ctx.reg.cone);  // (whatever else is asked)
        const Request q = resolveFor(ctx.reg);
        const MicrofacetLobe::Resolved& a = q.alphas;
        if (a.delta) return BsdfEval{};
        if (!q.compensated) return evalRough(lobe_.microfacet(a), wo, wi, ctx.valueOnly);
        if (!rough_) return evalCompensated(lobe_.microfacet(a), wo, wi, ctx.mode, ctx.valueOnly);
        BsdfEval e = evalRough(lobe_.microfacet(a), wo, wi, ctx.valueOnly);
        e.f *= comp_->reflectionScale(lightSide(wo, wi, ctx.mode).z, a.u);
        return e;
    }

    bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const override {
        if (!(wo.z > 0.f)) return false;
        const Request q = resolveFor(ctx.reg);
        const MicrofacetLobe::Resolved& a = q.alphas;
        if (a.delta) {
            out.wi = Vec3(-wo.x, -wo.y, wo.z);
            out.weight = specR_ * fresnelConductor(wo.z, eta_, k_);
            out.pdfFwd = out.pdfRev = SolidAnglePdf(1.f);
            out.lobe = kReflection | kDelta;
            out.eta = 1.f;
            return true;
        }
        const Microfacet mf = lobe_.microfacet(a);
        float uExtra = uLobe;
        const Vec3 m = mf.sampleVisible(wo, u, uExtra);
        const float wom = glm::dot(wo, m);
        if (!(wom > 0.f)) return false;
        const Vec3 wi = reflectAbout(wo, m);
        if (!(wi.z > 0.f)) return false;
        if (ctx.directionOnly) {  // (the checks below may still refuse the full sample)
            out.wi = wi;
            return true;
        }
        // The densities only (evalRough's, at the pair's half vector): the weight below is the
        // value's closed form.
        const MicrofacetReflectionTerms r = microfacetReflectionTerms(mf, wo, wi);
        if (!(r.value > 0.f)) return false;  // (evalRough's densities are 0 there)
        const float pdfFwd = r.reflectDensity(wo, r.gO);
        if (!(pdfFwd > 0.f) || !std::isfinite(pdfFwd)) return false;
        const float g1 = mf.G1(wo, m);
        if (!(g1 > 0.f)) return false;
        out.wi = wi;
        // f cos / pdf = F D G2 / (4 cos_o) / (G1(wo) D / (4 cos_o)) = F G2 / G1(wo): no overflow.
        const float ratio = mf.G2(wo, wi, g1, mf.G1(wi, m)) / g1;
        if (q.compensated && !rough_) {  // (energy_compensation.h: F and 1 / E at the light side)
            const float muL = lightSide(wo, wi, ctx.mode).z;
            out.weight = specR_ * fresnelConductor(muL, eta_, k_) * (comp_->reflectionScale(muL, 0.5f * (a.u + a.v)) * ratio);
        } else {
            out.weight = specR_ * fresnelConductor(wom, eta_, k_) * ratio;
            if (q.compensated) out.weight *= comp_->reflectionScale(lightSide(wo, wi, ctx.mode).z, a.u);
        }
        out.pdfFwd = SolidAnglePdf(pdfFwd);
        out.pdfRev = SolidAnglePdf(r.reflectDensity(wi, r.gI));
        out.lobe = kReflection | kGlossy;
        out.eta = 1.f;
        return true;
    }

    uint32_t flags() const override { return rough_ ? (kReflection | kGlossy) : (kReflection | kDelta); }
    bool deltaUnder(const BsdfContext& ctx) const override {
        return !(!rough_ && ctx.reg.cone > 0.f) && resolveFor(ctx.reg).alphas.delta;
    }
    float valueBound(const BsdfContext& ctx) const override {
        if (!rough_ && ctx.reg.cone > 0.f) return 1.f / coneSolidAngle(ctx.reg.cone);  // the cone's 1 / Omega
        const Request q = resolveFor(ctx.reg);
        if (q.alphas.delta) return kInf;
        // (Microfacet clamps each alpha to kMinAlpha; the smaller axis bounds an anisotropic lobe.)
        const float alpha = std::max(std::min(q.alphas.u, q.alphas.v), kMinAlpha);
        if (q.compensated) return comp_->valueBound(false, alpha, ctx.reg.bound);
        return maxValueBound(lobe_.type, lobe_.masking, alpha, false, 1.f, ctx.reg.bound);
    }
    // (one-sided: a pair below the surface is 0 under every request)
    PairGeometry pairGeometry(const Vec3& wo, const Vec3& wi) const override {
        if (!rough_ || lobe_.alphaU != lobe_.alphaV) return {};
        if (!(wo.z > 0.f) || !(wi.z > 0.f)) return PairGeometry{0.f, 0.f, 0.f, PairGeometry::Lobe::Zero, false};
        return microfacetPairGeometry(wo, wi, 1.f, lobe_.masking);
    }
    float requestRatio(const PairGeometry& g, const BsdfContext& ctx) const override {
        const Request q = resolveFor(ctx.reg);
        const float ratio = microfacetAlphaRatio(lobe_.type, lobe_.masking, lobe_.alphaU, q.alphas.u, g);
        if (!rough_ || !q.compensated || g.lobe != PairGeometry::Lobe::Reflection) return ratio;
        return ratio * comp_->reflectionScale(ctx.mode == TransportMode::Radiance ? g.cosI() : g.cosO(), q.alphas.u);
    }
    float requestPdfRatio(const PairGeometry& g, const RegularizationRequest& r) const override {
        return microfacetAlphaRatio(lobe_.type, lobe_.masking, lobe_.alphaU, resolveFor(r).alphas.u, g, true);
    }
    float requestRatioBound(const RegularizationRequest& r) const override {
        if (!rough_ || lobe_.alphaU != lobe_.alphaV) return kInf;
        const Request q = resolveFor(r);
        const float bound = microfacetAlphaRatioBound(lobe_.type, lobe_.alphaU, q.alphas.u);
        return q.compensated ? bound * comp_->boundFactor(false, q.alphas.u) : bound;
    }
    float roughness() const override { return rough_ ? scalarRoughness(lobe_.alphaU, lobe_.alphaV) : 0.f; }
    Roughness alpha() const override { return {lobe_.alphaU, lobe_.alphaV}; }
    std::string name() const override { return rough_ ? "roughconductor" : "conductor"; }

private:
    // A request resolved: the alphas, and whether the lobe is compensated (energy_compensation.h):
    // a smooth conductor made rough or a glossy isotropic one made rougher, where the compensation
    // can keep the value under the request's bound (a compensated lobe's bound is its own, alphaFor).
    struct Request {
        MicrofacetLobe::Resolved alphas;
        bool compensated = false;
    };
    Request resolveFor(const RegularizationRequest& r) const {
        if (!(r.compensate && comp_ && comp_->meets(r, false))) return {lobe_.resolve(r, false, 1.f), false};
        Request q{comp_->resolve(lobe_, r, false), false};
        q.compensated = !rough_ || q.alphas.u != lobe_.alphaU;
        return q;
    }
    // The light side of a pair (energy_compensation.h): wi for Radiance, wo for Importance.
    static const Vec3& lightSide(const Vec3& wo, const Vec3& wi, TransportMode mode) {
        return mode == TransportMode::Radiance ? wi : wo;
    }
    // specR F(mu_l) f1 / E_R(mu_l): the mirror's weight F spread over the rough lobe, l the light
    // side (wi for Radiance, wo for Importance).
    BsdfEval evalCompensated(const Microfacet& mf, const Vec3& wo, const Vec3& wi, TransportMode mode,
                             bool valueOnly) const {
        BsdfEval e;
        if (!(wo.z > 0.f) || !(wi.z > 0.f)) return e;
        const MicrofacetReflectionTerms r = microfacetReflectionTerms(mf, wo, wi);
        if (!(r.value > 0.f)) return e;
        const float muL = mode == TransportMode::Radiance ? wi.z : wo.z;
        e.f = specR_ * fresnelConductor(muL, eta_, k_) *
              (comp_->reflectionScale(muL, 0.5f * (mf.alphaU() + mf.alphaV())) * r.value);
        if (valueOnly) return e;
        e.pdfFwd = SolidAnglePdf(r.reflectDensity(wo, r.gO));
        e.pdfRev = SolidAnglePdf(r.reflectDensity(wi, r.gI));
        return e;
    }

    // KD13's cone around the mirror direction (bsdf/cone_mollifier.h): the weight of the delta
    // sample, specR F(cos theta_o), spread over the cone. The densities stay 0 (nothing samples it).
    BsdfEval evalCone(const Vec3& wo, const Vec3& wi, float eps) const {
        BsdfEval e;
        if (!(wo.z > 0.f) || !(wi.z > 0.f)) return e;
        e.f = ConeMollifier(eps).eval(specR_ * fresnelConductor(wo.z, eta_, k_), wi, idealReflection(wo));
        return e;
    }

    // The rough lobe with the alphas of one call (the material's, or the regularised ones). The
    // densities of sampling the reflection about h, D_w(h) / (4 w.h), from the value's terms.
    BsdfEval evalRough(const Microfacet& mf, const Vec3& wo, const Vec3& wi, bool valueOnly = false) const {
        BsdfEval e;
        if (!(wo.z > 0.f) || !(wi.z > 0.f)) return e;
        const MicrofacetReflectionTerms r = microfacetReflectionTerms(mf, wo, wi);
        if (!(r.value > 0.f)) return e;
        // Fresnel at the average of wo.h and wi.h (equal up to rounding): exactly reciprocal.
        e.f = specR_ * fresnelConductor(0.5f * (glm::dot(wo, r.h) + glm::dot(wi, r.h)), eta_, k_) * r.value;
        if (valueOnly) return e;
        e.pdfFwd = SolidAnglePdf(r.reflectDensity(wo, r.gO));
        e.pdfRev = SolidAnglePdf(r.reflectDensity(wi, r.gI));
        return e;
    }

    bool rough_;
    MicrofacetLobe lobe_;
    Color eta_, k_, specR_;
    std::optional<LobeCompensation> comp_;  // (smooth or isotropic: compensated())
};

}  // namespace

BxdfPtr makeConductor(const Color& eta, const Color& k, const Color& specularReflectance) {
    // A smooth conductor given a regularisation request (bsdf.h) becomes a GGX/Smith rough conductor.
    return std::make_shared<ConductorBxdf>(false, MicrofacetType::GGX, 0.f, 0.f, MaskingModel::Smith, eta, k,
                                           specularReflectance);
}

BxdfPtr makeRoughConductor(MicrofacetType dist, float alphaU, float alphaV, const Color& eta, const Color& k,
                           const Color& specularReflectance, MaskingModel masking) {
    const bool rough = std::max(alphaU, alphaV) >= kMinAlpha;
    return std::make_shared<ConductorBxdf>(rough, dist, alphaU, alphaV, masking, eta, k, specularReflectance);
}

}  // namespace lt
