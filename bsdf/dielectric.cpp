// Smooth (delta) and rough (Walter et al. 2007) dielectric interfaces.
//
// eta = int_ior / ext_ior; the interior is the z < 0 side. When wo.z < 0 the walk is inside:
// all directions are negated and eta inverted, so the code below always works with wo above.
// The lobe (reflection / refraction) is chosen with the Fresnel reflectance F of the sampled
// microfacet (of the macro normal for the smooth case); specularReflectance/Transmittance only
// scale the values. BsdfSample::eta = n_wi / n_wo for refraction, 1 for reflection.
// An index-matched interface (eta == 1) has no reflection and a straight-through delta
// refraction, rough or not.
#include "bsdf/bsdf.h"
#include "bsdf/cone_mollifier.h"
#include "bsdf/energy_compensation.h"
#include "bsdf/fresnel.h"
#include "bsdf/microfacet.h"
#include "bsdf/roughness_bound.h"
#include "bsdf/textured_microfacet.h"
#include "core/texture/texture.h"

#include <memory>

namespace lt {

namespace {

class DielectricBxdf final : public Bxdf {
public:
    DielectricBxdf(bool rough, MicrofacetType dist, float au, float av, MaskingModel masking, float eta,
                   const Color& specR, const Color& specT)
        : rough_(rough), lobe_{dist, masking, rough ? au : 0.f, rough ? av : 0.f}, eta_(eta), specR_(specR),
          specT_(specT) {
        if (!rough && eta != 1.f) {  // (energy_compensation.h: smooth interfaces only)
            own_ = std::make_unique<LobeCompensation>(eta, true);
            comp_ = own_.get();
        }
        continuation_ = std::max(continuationOf(specR), continuationOf(specT));
        cacheBounds();
    }
    // A textured material's model at one point (Bxdf::atUv; evaluated and sampled only): the model
    // above with the point's values and the material's smooth compensation (eta is not textured).
    // pairs: whether it offers pair geometry (not where the alphas are textured: the material's
    // requestRatio, which the integrators ask, knows no point's alpha).
    struct Instance {
        const LobeCompensation* smooth;
        bool pairs;
    };
    DielectricBxdf(bool rough, MicrofacetType dist, float au, float av, MaskingModel masking, float eta,
                   const Color& specR, const Color& specT, const Instance& in)
        : rough_(rough), lobe_{dist, masking, rough ? au : 0.f, rough ? av : 0.f}, eta_(eta), specR_(specR),
          specT_(specT), pairs_(in.pairs) {
        if (!rough && eta != 1.f) comp_ = in.smooth;
    }

    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override {
        if (wo.z == 0.f || wi.z == 0.f) return BsdfEval{};
        if (ctx.reg.cone > 0.f && (eta_ == 1.f || !rough_))  // (a smooth interface: whatever else is asked)
            return evalCone(wo, wi, ctx.reg.cone, ctx.mode);
        if (eta_ == 1.f) return BsdfEval{};
        // The request resolved for the lobe of this pair (reflection or transmission).
        const bool comp = compensated(ctx.reg);
        const MicrofacetLobe::Resolved a = resolveFor(ctx.reg, !(wo.z * wi.z > 0.f), comp);
        if (a.delta) return BsdfEval{};
        if (comp) return evalCompensated(lobe_.microfacet(a), wo, wi, ctx.mode, ctx.valueOnly);
        return evalRough(lobe_.microfacet(a), wo, wi, ctx.mode, ctx.valueOnly);
    }

    bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const override {
        if (wo.z == 0.f) return false;
        const float s = wo.z > 0.f ? 1.f : -1.f;
        const Vec3 o = wo * s;
        const float etaRel = s > 0.f ? eta_ : 1.f / eta_;
        const TransportMode mode = ctx.mode;
        if (eta_ == 1.f) {  // index matched: straight through
            out.wi = -wo;
            out.weight = specT_;
            out.pdfFwd = out.pdfRev = SolidAnglePdf(1.f);
            out.lobe = kTransmission | kDelta;
            out.eta = 1.f;
            return true;
        }
        // The lobe is chosen only after the microfacet normal, so one alpha serves both lobes here:
        // a request is resolved with the larger alpha_hat of the two lobes' bounds, and the
        // returned pdfs and weight are those of that alpha. (eval resolves per pair; the walks
        // never sample a regularised BSDF, JG19 Sec. 3.)
        const bool macro = compensated(ctx.reg);  // (the compensated lobe: below)
        const MicrofacetLobe::Resolved a = resolveBoth(ctx.reg, macro);
        if (a.delta) {
            float cosT;
            const float F = fresnelDielectric(o.z, etaRel, &cosT);
            if (uLobe < F) {
                out.wi = Vec3(-wo.x, -wo.y, wo.z);
                out.weight = specR_;  // F / P(reflection) = 1
                out.pdfFwd = out.pdfRev = SolidAnglePdf(F);
                out.lobe = kReflection | kDelta;
                out.eta = 1.f;
            } else {
                Vec3 t;
                if (!refractAbout(o, Vec3(0.f, 0.f, 1.f), etaRel, t)) return false;
                out.wi = t * s;
                out.weight = specT_ * (mode == TransportMode::Radiance ? 1.f / (etaRel * etaRel) : 1.f);
                out.pdfFwd = out.pdfRev = SolidAnglePdf(1.f - F);
                out.lobe = kTransmission | kDelta;
                out.eta = etaRel;
            }
            return true;
        }
        const Microfacet mf = lobe_.microfacet(a);
        float uSel = uLobe;
        const Vec3 m = mf.sampleVisible(o, u, uSel);
        const float om = glm::dot(o, m);
        if (!(om > 0.f)) return false;
        // (a compensated lobe chooses by the macro Fresnel of wo, the weight its value spreads: the
        // sample weight is then G2 / G1 / E, with no 1 / F(facet) tail)
        const float F = macro ? fresnelDielectric(o.z, etaRel) : fresnelDielectric(om, etaRel);
        Vec3 i;
        bool reflect = uSel < F;
        if (reflect) {
            i = reflectAbout(o, m);
            if (!(i.z > 0.f)) return false;
        } else {
            if (!refractAbout(o, m, etaRel, i) || !(i.z < 0.f)) return false;
        }
        const Vec3 wi = i * s;
        if (ctx.directionOnly) {  // (the checks below may still refuse the full sample)
            out.wi = wi;
            return true;
        }
        // The densities only (the value is not needed: the weight below is its closed form).
        const float pdfFwd = pdfImpl(mf, wo, wi, macro);
        if (!(pdfFwd > 0.f) || !std::isfinite(pdfFwd)) return false;
        const float g1 = mf.G1(o, m);
        if (!(g1 > 0.f)) return false;
        // f cos / pdf simplifies to spec * G2 / G1(wo) (times 1/etap^2 for radiance refraction).
        const float ratio = mf.G2(o, i, m) / g1;
        out.wi = wi;
        out.pdfFwd = SolidAnglePdf(pdfFwd);
        out.pdfRev = SolidAnglePdf(pdfImpl(mf, wi, wo, macro));
        if (macro) {  // (the compensated value over the same density)
            out.weight = evalCompensated(mf, wo, wi, mode, true).f * (std::abs(wi.z) / pdfFwd);
            out.lobe = reflect ? (kReflection | kGlossy) : (kTransmission | kGlossy);
            out.eta = reflect ? 1.f : etaRel;
            return true;
        }
        if (reflect) {
            out.weight = specR_ * ratio;
            out.lobe = kReflection | kGlossy;
            out.eta = 1.f;
        } else {
            out.weight = specT_ * (ratio * (mode == TransportMode::Radiance ? 1.f / (etaRel * etaRel) : 1.f));
            out.lobe = kTransmission | kGlossy;
            out.eta = etaRel;
        }
        return true;
    }

    uint32_t flags() const override {
        if (eta_ == 1.f) return kTransmission | kDelta;
        return rough_ ? (kReflection | kTransmission | kGlossy) : (kReflection | kTransmission | kDelta);
    }
    PairGeometry pairGeometry(const Vec3& wo, const Vec3& wi) const override {
        if (!rough_ || eta_ == 1.f || lobe_.alphaU != lobe_.alphaV || !pairs_) return {};
        return microfacetPairGeometry(wo, wi, eta_, lobe_.masking);
    }
    // (the request resolved for the pair's lobe, as eval resolves it)
    // (pair geometry is a glossy lobe's, which is never compensated: the ratios are D' G2' / (D G2)
    // and its density's alone)
    float requestRatio(const PairGeometry& g, const BsdfContext& ctx) const override {
        const bool transmission = g.lobe == PairGeometry::Lobe::Transmission;
        return microfacetAlphaRatio(lobe_.type, lobe_.masking, lobe_.alphaU, resolveFor(ctx.reg, transmission, false).u, g);
    }
    float requestPdfRatio(const PairGeometry& g, const RegularizationRequest& r) const override {
        const bool transmission = g.lobe == PairGeometry::Lobe::Transmission;
        return microfacetAlphaRatio(lobe_.type, lobe_.masking, lobe_.alphaU, resolveFor(r, transmission, false).u, g,
                                    true);
    }
    // (both lobes: the request resolves to its own alpha for each)
    float requestRatioBound(const RegularizationRequest& r) const override {
        if (!rough_ || eta_ == 1.f || lobe_.alphaU != lobe_.alphaV) return kInf;
        return std::max(microfacetAlphaRatioBound(lobe_.type, lobe_.alphaU, resolveFor(r, false, false).u),
                        microfacetAlphaRatioBound(lobe_.type, lobe_.alphaU, resolveFor(r, true, false).u));
    }
    float roughness() const override { return rough_ ? scalarRoughness(lobe_.alphaU, lobe_.alphaV) : 0.f; }
    Roughness alpha() const override { return {lobe_.alphaU, lobe_.alphaV}; }
    std::string name() const override { return rough_ ? "roughdielectric" : "dielectric"; }
    // Rough as soon as either lobe's resolved alpha is (sample's resolveBoth).
    bool deltaUnder(const BsdfContext& ctx) const override {
        if (ctx.reg.cone > 0.f && (eta_ == 1.f || !rough_)) return false;  // the cone (evalCone)
        return eta_ == 1.f || resolveBoth(ctx.reg, compensated(ctx.reg)).delta;
    }
    // The larger of the reflection and transmission bounds, each with the alphas eval resolves
    // for its lobe. +inf when both are still deltas; a reflection lobe still a delta beside a
    // transmission made rough (a narrow range of tau) is left out, as eval leaves it out.
    float valueBound(const BsdfContext& ctx) const override {
        if (ctx.reg.cone > 0.f && (eta_ == 1.f || !rough_)) return 1.f / coneSolidAngle(ctx.reg.cone);  // 1 / Omega
        if (eta_ == 1.f) return kInf;
        const bool comp = compensated(ctx.reg);
        float bound = -1.f;
        for (bool transmission : {false, true}) {
            const MicrofacetLobe::Resolved a = resolveFor(ctx.reg, transmission, comp);
            if (a.delta) continue;
            const float alpha = std::max(std::min(a.u, a.v), kMinAlpha);
            bound = std::max(bound, comp
                                        ? comp_->valueBound(transmission, alpha, ctx.reg.bound)
                                        : maxValueBound(lobe_.type, lobe_.masking, alpha, transmission, eta_, ctx.reg.bound));
        }
        return bound < 0.f ? kInf : bound;
    }

private:
    // The request resolved for both lobes, per axis the larger alpha (which lobe's bound gives it
    // depends on eta, alpha and the bound's form).
    MicrofacetLobe::Resolved resolveBoth(const RegularizationRequest& r, bool comp) const {
        const MicrofacetLobe::Resolved t = resolveFor(r, true, comp), q = resolveFor(r, false, comp);
        return {std::max(t.u, q.u), std::max(t.v, q.v), t.delta && q.delta};
    }
    // Whether a request makes this smooth interface a compensated rough lobe (energy_compensation.h:
    // where the compensation keeps both lobes' values under the request's bound). A glossy
    // interface is not compensated: the Fresnel-free albedo ratio of each lobe misplaces the energy
    // that total internal reflection moves between the lobes as the normals widen.
    bool compensated(const RegularizationRequest& r) const {
        return r.compensate && comp_ && comp_->meets(r, false) && comp_->meets(r, true);
    }
    // The request resolved for one lobe, comp = compensated(r) (asked once per call); a compensated
    // lobe's bound is its own (alphaFor).
    MicrofacetLobe::Resolved resolveFor(const RegularizationRequest& r, bool transmission, bool comp) const {
        return comp ? comp_->resolve(lobe_, r, transmission) : lobe_.resolve(r, transmission, eta_);
    }

    // The compensated rough lobe of a smooth interface (energy_compensation.h): each lobe's
    // Fresnel-free value times W / E at the light side l (wi for Radiance, wo for Importance),
    // W = F(mu_l) (reflection) or 1 - F(mu_l) (refraction) seen from l's side.
    BsdfEval evalCompensated(const Microfacet& mf, const Vec3& wo, const Vec3& wi, TransportMode mode,
                             bool valueOnly) const {
        BsdfEval e;
        const Vec3& l = mode == TransportMode::Radiance ? wi : wo;
        const float muL = std::abs(l.z), etaL = l.z > 0.f ? eta_ : 1.f / eta_;
        const float F = fresnelDielectric(muL, etaL);
        const float alpha = 0.5f * (mf.alphaU() + mf.alphaV());
        if (wo.z * wi.z > 0.f) {
            e.f = specR_ * (F * comp_->reflectionScale(muL, alpha) * microfacetReflection(mf, wo, wi));
        } else {
            if (!refractionGeometry(wo, wi).valid) return e;
            e.f = specT_ * ((1.f - F) * comp_->transmissionScale(muL, alpha, etaL) *
                            microfacetTransmission(mf, wo, wi, eta_, mode));
        }
        if (valueOnly) return e;
        e.pdfFwd = SolidAnglePdf(pdfImpl(mf, wo, wi, true));
        e.pdfRev = SolidAnglePdf(pdfImpl(mf, wi, wo, true));
        return e;
    }

    // KD13's cone (bsdf/cone_mollifier.h) around the ideal reflected and refracted directions of
    // wo, each with the weight of its delta sample: specR F, and specT (1 - F) (times 1/eta^2 for
    // radiance), F of the macro normal at wo; an index-matched interface has the straight-through
    // lobe only. The densities stay 0 (nothing samples it). (Used for a smooth or index-matched
    // interface, whatever else the request asks: JG19's bound then applies to rough lobes only.)
    BsdfEval evalCone(const Vec3& wo, const Vec3& wi, float eps, TransportMode mode) const {
        BsdfEval e;
        const ConeMollifier cone(eps);
        const float etaRel = wo.z > 0.f ? eta_ : 1.f / eta_;
        if (wo.z * wi.z > 0.f) {
            if (eta_ == 1.f) return e;
            const float F = fresnelDielectric(std::abs(wo.z), etaRel);
            e.f = cone.eval(specR_ * F, wi, idealReflection(wo));
            return e;
        }
        DVec3 t;
        if (!idealRefraction(wo, eta_, t)) return e;  // (total internal reflection: no transmission)
        const float F = fresnelDielectric(std::abs(wo.z), etaRel);
        const float radiance = mode == TransportMode::Radiance ? 1.f / (etaRel * etaRel) : 1.f;
        e.f = cone.eval(specT_ * ((1.f - F) * radiance), wi, t);
        return e;
    }

    // The rough lobes with the alphas of one call (the material's, or the regularised ones), for
    // wo.z != 0, wi.z != 0 and eta != 1.
    BsdfEval evalRough(const Microfacet& mf, const Vec3& wo, const Vec3& wi, TransportMode mode,
                       bool valueOnly = false) const {
        BsdfEval e;
        if (wo.z * wi.z > 0.f) {
            const Vec3 h = glm::normalize(wo + wi);
            e.f = specR_ * (reflectionFresnel(wo, wi, h) * microfacetReflection(mf, wo, wi));
        } else {
            const RefractionGeometry g = refractionGeometry(wo, wi);
            if (!g.valid) return e;
            e.f = specT_ * ((1.f - g.F) * microfacetTransmission(mf, wo, wi, eta_, mode));
        }
        if (valueOnly) return e;
        e.pdfFwd = SolidAnglePdf(pdfImpl(mf, wo, wi));
        e.pdfRev = SolidAnglePdf(pdfImpl(mf, wi, wo));
        return e;
    }

    // Fresnel of a reflection pair, symmetric in (wo, wi): wo.h == wi.h up to rounding, and
    // near the critical angle F is steep, so the average is used for bitwise reciprocity.
    float reflectionFresnel(const Vec3& wo, const Vec3& wi, const Vec3& h) const {
        const float side = wo.z > 0.f ? 1.f : -1.f;
        const float c = 0.5f * (glm::dot(wo, h) + glm::dot(wi, h)) * side;  // h faces wo's side
        return fresnelDielectric(c, eta_);
    }

    // Generalised half vector (facing +z) and Fresnel reflectance of a refraction pair, computed
    // from the unordered pair {wo, wi} (so forward and reverse evaluations agree bitwise). F is
    // evaluated from the optically thinner side, where it is well conditioned (from the denser
    // side, cos(theta_t) = sqrt(1 - sin^2) cancels catastrophically near the critical angle).
    struct RefractionGeometry {
        Vec3 h{0, 0, 1};
        float F = 1.f;
        bool valid = false;
    };
    RefractionGeometry refractionGeometry(const Vec3& a, const Vec3& b) const {
        RefractionGeometry g;
        const Vec3& up = a.z > 0.f ? a : b;
        const Vec3& dn = a.z > 0.f ? b : a;
        Vec3 h = up + dn * eta_;
        const float l2 = glm::dot(h, h);
        if (!(l2 > 0.f)) return g;
        h /= std::sqrt(l2);
        if (h.z < 0.f) h = -h;
        g.h = h;
        const float cu = glm::dot(up, h), cd = glm::dot(dn, h);
        g.valid = cu > 0.f && cd < 0.f;
        g.F = eta_ > 1.f ? fresnelDielectric(cu, eta_) : fresnelDielectric(cd, eta_);
        return g;
    }

    // Density (solid angle, including the Fresnel lobe choice) with which sample() produces wi
    // from wo; macro: the lobe chosen by the Fresnel of wo at the macro normal (a compensated lobe).
    float pdfImpl(const Microfacet& mf, const Vec3& wo, const Vec3& wi, bool macro = false) const {
        if (wo.z == 0.f || wi.z == 0.f) return 0.f;
        const float s = wo.z > 0.f ? 1.f : -1.f;
        const Vec3 o = wo * s;  // visible normals are sampled from wo flipped to the upper side
        if (wo.z * wi.z > 0.f) {
            const Vec3 h = glm::normalize(wo + wi) * s;  // facing +z in the flipped frame
            const float oh = glm::dot(o, h);
            if (!(oh > 0.f)) return 0.f;
            const float F = macro ? macroFresnel(wo) : reflectionFresnel(wo, wi, glm::normalize(wo + wi));
            return mf.pdfVisible(o, h) / (4.f * oh) * F;
        }
        const RefractionGeometry g = refractionGeometry(wo, wi);
        if (!g.valid) return 0.f;
        // h is the same vector in the flipped frame (D is centrally symmetric, h faces +z).
        const float oh = glm::dot(o, g.h);
        if (!(oh > 0.f)) return 0.f;
        // Jacobian dw_m / dw_i = n_wi^2 |wi.h| / (n_wo wo.h + n_wi wi.h)^2 (n_up = 1, n_down = eta).
        const float nwi = wi.z > 0.f ? 1.f : eta_;
        const Vec3& up = wo.z > 0.f ? wo : wi;
        const Vec3& dn = wo.z > 0.f ? wi : wo;
        const float denom = glm::dot(up, g.h) + eta_ * glm::dot(dn, g.h);
        if (denom == 0.f) return 0.f;
        return mf.pdfVisible(o, g.h) * nwi * nwi * std::abs(glm::dot(wi, g.h)) / (denom * denom) *
               (1.f - (macro ? macroFresnel(wo) : g.F));
    }
    // The Fresnel reflectance of w at the macro normal, from w's side.
    float macroFresnel(const Vec3& w) const {
        return fresnelDielectric(std::abs(w.z), w.z > 0.f ? eta_ : 1.f / eta_);
    }

    bool rough_;
    MicrofacetLobe lobe_;
    float eta_;
    Color specR_, specT_;
    std::unique_ptr<LobeCompensation> own_;   // (a smooth interface's: compensated(); null in an instance)
    const LobeCompensation* comp_ = nullptr;  // own_'s, or an instance's material's
    bool pairs_ = true;
};

// A dielectric with textured parameters (Mitsuba 3's roughdielectric takes a texture for alpha,
// alpha_u, alpha_v, specular_reflectance and specular_transmittance, dielectric for the last two):
// the model at a point is the untextured DielectricBxdf of the point's values (atUv); without a
// point, the model of the textures' means. Over the material, as the textured conductor
// (conductor.cpp): flags the union over the alphas' range (a smooth point beside rough ones:
// glossy and delta), bounds the rough lobes' at the smallest alpha anywhere (a glossy interface is
// never compensated, so its bound falls with alpha) and the smooth points' own, no pair geometry
// where the alphas vary.
class TexturedDielectricBxdf final : public TexturedMicrofacetBxdf<DielectricBxdf> {
public:
    TexturedDielectricBxdf(bool rough, MicrofacetType dist, float au, float av, MaskingModel masking, float eta,
                           const Color& specR, const Color& specT, const DielectricTextures& t)
        : TexturedMicrofacetBxdf(rough, dist, masking, au, av, t.alphaU, t.alphaV), eta_(eta), specR_(specR),
          specT_(specT), t_(t) {
        const AlphaRange& r = range();
        const Color meanR = t.specularReflectance ? t.specularReflectance->meanValue() : specR;
        const Color meanT = t.specularTransmittance ? t.specularTransmittance->meanValue() : specT;
        if (eta != 1.f) smoothComp_ = std::make_unique<LobeCompensation>(eta, true);
        mean_ = std::make_unique<DielectricBxdf>(r.meanRough, dist, r.meanU, r.meanV, masking, eta, meanR, meanT);
        if (r.anyRough)
            roughPart_ = std::make_unique<DielectricBxdf>(true, dist, r.minAlpha, r.minAlpha, masking, eta, meanR, meanT);
        if (r.anySmooth) smooth_ = std::make_unique<DielectricBxdf>(false, dist, 0.f, 0.f, masking, eta, meanR, meanT);
        flags_ = eta == 1.f ? (kTransmission | kDelta)
                            : kReflection | kTransmission | (r.anyRough ? kGlossy : 0u) | (r.anySmooth ? kDelta : 0u);
        continuation_ = std::max(continuationOf(t.specularReflectance ? t.specularReflectance->maxValue() : specR),
                                 continuationOf(t.specularTransmittance ? t.specularTransmittance->maxValue() : specT));
        cacheBounds();
    }

    const Bxdf* atUv(const Vec2& uv, void* storage, size_t capacity) const override {
        float au, av;
        bool rough;
        alphasAt(uv, au, av, rough);
        const Color r = t_.specularReflectance ? t_.specularReflectance->eval(uv) : specR_;
        const Color tr = t_.specularTransmittance ? t_.specularTransmittance->eval(uv) : specT_;
        return emplaceInstance<DielectricBxdf>(storage, capacity, rough, dist_, au, av, masking_, eta_, r, tr,
                                               DielectricBxdf::Instance{smoothComp_.get(), !alphaTextured_});
    }
    bool deltaUnder(const BsdfContext& ctx) const override {
        if (!(flags_ & kGlossy)) return (smooth_ ? smooth_.get() : mean_.get())->deltaUnder(ctx);
        return false;
    }
    float valueBound(const BsdfContext& ctx) const override {
        if (eta_ == 1.f) return mean_->valueBound(ctx);
        float b = smooth_ ? smooth_->valueBound(ctx) : 0.f;
        if (roughPart_) b = std::max(b, roughPart_->valueBound(ctx));
        return b;
    }

private:
    float eta_;
    Color specR_, specT_;
    DielectricTextures t_;
    std::unique_ptr<LobeCompensation> smoothComp_;  // the smooth points' (null for eta 1)
};

}  // namespace

BxdfPtr makeDielectric(float eta, const Color& specularReflectance, const Color& specularTransmittance) {
    // Given a regularisation request (bsdf.h) a smooth dielectric becomes a GGX/Smith rough dielectric.
    return std::make_shared<DielectricBxdf>(false, MicrofacetType::GGX, 0.f, 0.f, MaskingModel::Smith, eta,
                                            specularReflectance, specularTransmittance);
}

BxdfPtr makeRoughDielectric(MicrofacetType dist, float alphaU, float alphaV, float eta,
                            const Color& specularReflectance, const Color& specularTransmittance,
                            MaskingModel masking) {
    const bool rough = std::max(alphaU, alphaV) >= kMinAlpha;
    return std::make_shared<DielectricBxdf>(rough, dist, alphaU, alphaV, masking, eta, specularReflectance,
                                            specularTransmittance);
}

BxdfPtr makeTexturedDielectric(bool rough, MicrofacetType dist, float alphaU, float alphaV, float eta,
                               const Color& specularReflectance, const Color& specularTransmittance,
                               MaskingModel masking, const DielectricTextures& textures) {
    if (!rough) {  // (as makeDielectric)
        dist = MicrofacetType::GGX;
        masking = MaskingModel::Smith;
    }
    return std::make_shared<TexturedDielectricBxdf>(rough, dist, alphaU, alphaV, masking, eta, specularReflectance,
                                                    specularTransmittance, textures);
}

}  // namespace lt
