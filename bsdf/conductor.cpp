// Smooth (delta) and rough (microfacet) conductors, one-sided like Mitsuba 3: black when
// wo.z <= 0 or wi.z <= 0. eta + i k is the complex IOR relative to the exterior.
#include "bsdf/bsdf.h"
#include "bsdf/cone_mollifier.h"
#include "bsdf/energy_compensation.h"
#include "bsdf/fresnel.h"
#include "bsdf/microfacet.h"
#include "bsdf/roughness_bound.h"
#include "bsdf/textured_microfacet.h"
#include "core/texture/texture.h"

#include <cstring>
#include <memory>
#include <mutex>
#include <optional>
#include <unordered_map>

namespace lt {

namespace {

// The energy compensations of a textured conductor's glossy isotropic lobes (energy_compensation.h:
// its tables depend on alpha_0 and take about a millisecond and 5 KB each), one per alpha_0 rounded
// to 7 mantissa bits (steps of 0.8%) where the alpha is textured, built on the first request at a
// point in that step and kept.
// (A bilinear alpha texture has a different alpha at every point: a table per point would cost a
// millisecond per vertex and grow without bound; at most 128 tables per octave of alpha are built.)
// An instance (atUv) resolves a request with the compensation of the untextured model of its
// rounded alpha, bit for bit where its alpha is on the grid.
class GlossyCompensations {
public:
    // round: whether the alphas vary over the surface (a constant alpha keeps its own table)
    GlossyCompensations(MicrofacetType type, MaskingModel masking, bool round)
        : type_(type), masking_(masking), round_(round) {}
    const LobeCompensation* at(float alpha0) const {
        uint32_t key;
        std::memcpy(&key, &alpha0, sizeof(key));
        if (round_) key = (key + (1u << 15)) & ~((1u << 16) - 1u);  // to 7 of the 23 mantissa bits
        float rounded;
        std::memcpy(&rounded, &key, sizeof(key));
        const std::lock_guard<std::mutex> lock(mutex_);
        std::unique_ptr<LobeCompensation>& c = byAlpha_[key];
        if (!c) c = std::make_unique<LobeCompensation>(MicrofacetLobe{type_, masking_, rounded, rounded});
        return c.get();
    }

private:
    MicrofacetType type_;
    MaskingModel masking_;
    bool round_;
    mutable std::mutex mutex_;
    mutable std::unordered_map<uint32_t, std::unique_ptr<LobeCompensation>> byAlpha_;
};

class ConductorBxdf final : public Bxdf {
public:
    ConductorBxdf(bool rough, MicrofacetType dist, float au, float av, MaskingModel masking, const Color& eta,
                  const Color& k, const Color& specR)
        : rough_(rough), lobe_{dist, masking, rough ? au : 0.f, rough ? av : 0.f}, eta_(eta), k_(k), specR_(specR) {
        if (!rough || au == av) {  // (energy_compensation.h: smooth or isotropic)
            own_ = std::make_unique<LobeCompensation>(lobe_);
            comp_ = own_.get();
        }
        continuation_ = continuationOf(specR);  // the Fresnel factor is <= 1 on top
        cacheBounds();
    }
    // A textured material's model at one point (Bxdf::atUv; evaluated and sampled only): the
    // model above with the point's values, its compensation the material's (smooth: `smooth`;
    // glossy isotropic: `glossy`'s for its alpha, fetched on the first request that needs it).
    // pairs: whether it offers pair geometry (not where the alphas are textured: the material's
    // requestRatio, which the integrators ask, knows no point's alpha).
    struct Instance {
        const LobeCompensation* smooth;
        const GlossyCompensations* glossy;
        bool pairs;
    };
    ConductorBxdf(bool rough, MicrofacetType dist, float au, float av, MaskingModel masking, const Color& eta,
                  const Color& k, const Color& specR, const Instance& in)
        : rough_(rough), lobe_{dist, masking, rough ? au : 0.f, rough ? av : 0.f}, eta_(eta), k_(k), specR_(specR),
          glossy_(rough && au == av ? in.glossy : nullptr), pairs_(in.pairs) {
        if (!rough) comp_ = in.smooth;
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
        if (!rough_ || lobe_.alphaU != lobe_.alphaV || !pairs_) return {};
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
        if (glossy_ && !comp_ && !r.empty()) comp_ = glossy_->at(lobe_.alphaU);  // (an instance's, once)
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
    std::unique_ptr<LobeCompensation> own_;  // (smooth or isotropic: compensated(); null in an instance)
    // The compensation resolveFor uses (own_'s, or an instance's from its material), and where an
    // instance's is fetched on demand.
    mutable const LobeCompensation* comp_ = nullptr;
    const GlossyCompensations* glossy_ = nullptr;
    bool pairs_ = true;
};

// A conductor with textured parameters (Mitsuba's roughconductor takes a texture for alpha,
// alpha_u, alpha_v, eta, k and specular_reflectance; conductor for eta, k and
// specular_reflectance). The model at a point is the untextured ConductorBxdf of the point's values
// (atUv), so a request resolves there exactly as on that model. Without a point the material is
// the model of the textures' means. Over the whole material (bsdf.h, textured()):
//   flags     the union over the alphas' range: a texture reaching below kMinAlpha where another
//             point is rough makes the material glossy and delta at once (a connection there
//             evaluates 0 at the smooth points, as a plastic's coating; the walk's own sample says
//             which lobe it took);
//   bounds    the rough lobe at the smallest alpha anywhere (its bound is the largest: maxValueBound
//             falls with alpha, the compensation's K(alpha; alpha_0) is largest at the smallest
//             alpha_0), the smooth points' own where there are any, and under a JG19 tau that a
//             compensated point meets by construction, tau;
//   ratios    where the alphas vary, no pair geometry (the integrators ask the material's
//             requestRatio, which knows no point's alpha: they evaluate instead) and no
//             requestRatioBound.
class TexturedConductorBxdf final : public TexturedMicrofacetBxdf<ConductorBxdf> {
public:
    TexturedConductorBxdf(bool rough, MicrofacetType dist, float au, float av, MaskingModel masking, const Color& eta,
                          const Color& k, const Color& specR, const ConductorTextures& t)
        : TexturedMicrofacetBxdf(rough, dist, masking, au, av, t.alphaU, t.alphaV), eta_(eta), k_(k), specR_(specR),
          t_(t), smoothComp_(MicrofacetLobe{dist, masking, 0.f, 0.f}), glossy_(dist, masking, alphaTextured_) {
        const float inv = 1.f / t.extEta;
        const AlphaRange& r = range();
        const Color meanEta = t.eta ? t.eta->meanValue() * inv : eta, meanK = t.k ? t.k->meanValue() * inv : k;
        const Color meanSpec = t.specularReflectance ? t.specularReflectance->meanValue() : specR;
        mean_ = std::make_unique<ConductorBxdf>(r.meanRough, dist, r.meanU, r.meanV, masking, meanEta, meanK, meanSpec);
        if (r.anyRough)
            roughPart_ = std::make_unique<ConductorBxdf>(true, dist, r.minAlpha, r.minAlpha, masking, meanEta, meanK,
                                                         meanSpec);
        if (r.anySmooth) smooth_ = std::make_unique<ConductorBxdf>(false, dist, 0.f, 0.f, masking, meanEta, meanK, meanSpec);
        flags_ = kReflection | (r.anyRough ? kGlossy : 0u) | (r.anySmooth ? kDelta : 0u);
        minPlain_ = roughPart_ ? roughPart_->plainBound() : 0.f;
        continuation_ = continuationOf(t.specularReflectance ? t.specularReflectance->maxValue() : specR);
        cacheBounds();
    }

    const Bxdf* atUv(const Vec2& uv, void* storage, size_t capacity) const override {
        float au, av;
        bool rough;
        alphasAt(uv, au, av, rough);
        // (divided as the loader divides a constant eta and k: the same floats)
        const Color eta = t_.eta ? t_.eta->eval(uv) / t_.extEta : eta_, k = t_.k ? t_.k->eval(uv) / t_.extEta : k_;
        const Color spec = t_.specularReflectance ? t_.specularReflectance->eval(uv) : specR_;
        return emplaceInstance<ConductorBxdf>(storage, capacity, rough, dist_, au, av, masking_, eta, k, spec,
                                              ConductorBxdf::Instance{&smoothComp_, &glossy_, !alphaTextured_});
    }
    bool deltaUnder(const BsdfContext& ctx) const override {
        return flags_ == (kReflection | kDelta) ? smooth_->deltaUnder(ctx) : isDelta();
    }
    float valueBound(const BsdfContext& ctx) const override {
        float b = smooth_ ? smooth_->valueBound(ctx) : 0.f;
        if (roughPart_) {
            b = std::max(b, roughPart_->valueBound(ctx));
            // (a compensated point meets tau up to the rounding of its bound: a few ulps)
            if (ctx.reg.tau < kInf && ctx.reg.compensate && ctx.reg.tau < 1.01f * minPlain_)
                b = std::max(b, ctx.reg.tau * 1.0001f);
        }
        return b;
    }

private:
    Color eta_, k_, specR_;
    ConductorTextures t_;
    LobeCompensation smoothComp_;     // the smooth points' (a smooth ConductorBxdf's own)
    GlossyCompensations glossy_;      // the glossy isotropic points', by alpha
    float minPlain_ = 0.f;            // the rough part's plain bound (its smallest alpha's)
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

BxdfPtr makeTexturedConductor(bool rough, MicrofacetType dist, float alphaU, float alphaV, const Color& eta,
                              const Color& k, const Color& specularReflectance, MaskingModel masking,
                              const ConductorTextures& textures) {
    if (!rough) {  // (as makeConductor)
        dist = MicrofacetType::GGX;
        masking = MaskingModel::Smith;
    }
    return std::make_shared<TexturedConductorBxdf>(rough, dist, alphaU, alphaV, masking, eta, k, specularReflectance,
                                                   textures);
}

}  // namespace lt
