// Mitsuba 3's plastic and roughplastic (their plugin documentation is the spec, the formulas those
// of its plastic.cpp and roughplastic.cpp): a dielectric coating of relative IOR eta = int_ior / ext_ior over a Lambertian base of reflectance R, one-sided (black
// where wo.z <= 0 or wi.z <= 0). With T(mu) the coating's transmittance from outside at cosine mu,
//   f = f_coat + R' T(mu_o) T(mu_i) / (pi eta^2),   R' = R / (1 - Fdr R)  (nonlinear)
//                                                     R / (1 - Fdr)    (linear, the default),
// Fdr the coating's diffuse reflectance from inside (the light that scatters back down to the base
// again, summed over the bounces: the geometric series of the nonlinear form). 1/eta^2: radiance
// leaving the base inside the coating spreads over the larger outside solid angle.
//   plastic       f_coat: the mirror reflection specR F(mu_o) (a delta lobe); T = 1 - F (exact
//                 Fresnel); Fdr = Mitsuba's fit fresnel_diffuse_reflectance(1 / eta) (Egan and
//                 Hilgeman 1973 for eta < 1, d'Eon and Irving 2011 otherwise).
//   roughplastic  f_coat: specR F(o.h) D G2 / (4 mu_o mu_i), Smith separable masking, GGX or
//                 Beckmann, isotropic alpha; T(mu) = 1 - (what the rough interface reflects or
//                 loses) and Fdr = 2 mean_k R_int(mu_k) mu_k over the table's 64 cosines mu_k,
//                 both over the material's own microfacet distribution at construction
//                 (RoughCoating below: Gauss-Legendre over the visible normals), T tabulated at
//                 the mu_k and interpolated linearly, as Mitsuba.
// f is symmetric in (wo, wi): reciprocal, the same in both transport modes (energy compensation of
// a regularised coating aside, which depends on the light side: energy_compensation.h).
// Sampling (Mitsuba's): the coating with probability P_c = (1 - T(mu_o)) w / ((1 - T(mu_o)) w +
// T(mu_o) (1 - w)), w = mean(specR) / (mean(R) + mean(specR)) (the specular sampling weight), else
// the base, cosine-weighted; the coating's normals are the visible ones (Heitz 2018, Heitz and d'Eon
// 2014; Mitsuba's sample_visible = false only changes the sampler, which we do not offer).
// Regularisation (bsdf.h): the coating is regularised on its own, as the conductors' lobe is: a
// rough coating resolves the request on its alpha (MicrofacetLobe::resolve), a smooth one becomes a
// GGX/Smith lobe where the request makes it rough, or KD13's cone (cone_mollifier.h), with the
// conductors' energy compensation. The base keeps its value (its T and Fdr are the material's own).
#include "bsdf/bsdf.h"
#include "core/texture/texture.h"
#include "bsdf/cone_mollifier.h"
#include "bsdf/energy_compensation.h"
#include "bsdf/fresnel.h"
#include "bsdf/microfacet.h"
#include "bsdf/roughness_bound.h"

#include <array>
#include <optional>
#include <vector>

namespace lt {

namespace {

constexpr double kPiD = 3.14159265358979323846;

// Mitsuba 3's fresnel_diffuse_reflectance(eta): the hemispherical (cosine-weighted) Fresnel
// reflectance seen from the side whose relative IOR is eta, fitted by Egan and Hilgeman (1973) for
// eta < 1 and by d'Eon and Irving (2011) for eta >= 1.
float fresnelDiffuseReflectance(float eta) {
    const float x = 1.f / eta;
    if (eta < 1.f) return -1.4399f * eta * eta + 0.7099f * eta + 0.6681f + 0.0636f * x;
    return 0.919317f + x * (-3.4793f + x * (6.75335f + x * (-7.80989f + x * (4.98554f - 1.36881f * x))));
}

float mean(const Color& c) { return (c.x + c.y + c.z) / 3.f; }

// Gauss-Legendre nodes and weights on [0, 1] (Newton's iteration on the Legendre polynomial P_n).
struct GaussLegendre {
    std::vector<double> x, w;
    explicit GaussLegendre(int n) : x(size_t(n)), w(size_t(n)) {
        for (int i = 0; i < (n + 1) / 2; ++i) {
            double z = std::cos(kPiD * (i + 0.75) / (n + 0.5)), dp = 1.0;
            for (int it = 0; it < 100; ++it) {
                double p1 = 1.0, p2 = 0.0;
                for (int j = 1; j <= n; ++j) {
                    const double p3 = p2;
                    p2 = p1;
                    p1 = ((2 * j - 1) * z * p2 - (j - 1) * p3) / j;
                }
                dp = n * (z * p1 - p2) / (z * z - 1.0);
                const double step = p1 / dp;
                z -= step;
                if (std::abs(step) < 1e-15) break;
            }
            x[size_t(i)] = 0.5 * (1.0 - z);
            x[size_t(n - 1 - i)] = 0.5 * (1.0 + z);
            w[size_t(i)] = w[size_t(n - 1 - i)] = 1.0 / ((1.0 - z * z) * dp * dp);
        }
    }
};

// Mitsuba 3's rough coating precomputation (roughplastic.cpp; microfacet.h, eval_transmittance and
// eval_reflectance), as expectations over the visible normals m ~ D_w of w = (sqrt(1 - mu^2), 0, mu):
//   T(mu)     = E[(1 - F(w.m, eta)) G1(t, m)],   t the refraction of w about m (0 on TIR or t.z >= 0)
//   R_int(mu) = E[F(w.m, 1 / eta) G1(r, m)],     r the reflection of w about m (0 for r.z <= 0)
// (light inside the coating sees relative IOR 1 / eta).
// Each expectation by Gauss-Legendre on the visible-normal sampler's square, as Mitsuba (its nodes
// crowd the square's edges, where the tails of the normals and total internal reflection lie):
// 32^2 nodes for T from outside (48^2 for eta < 1, which has total internal reflection there),
// 48^2 for R_int (Mitsuba: 128^2), within about 3e-4 of the converged values. Fdr is Mitsuba's:
// twice the mean of R_int mu over the 64 table cosines (its linear base is then Mitsuba's, whose
// render tests compare against it; the exact integral is about 1.5% larger).
struct RoughCoating {
    static constexpr int kRes = 64;  // table cosines mu_k = max(1e-6, k / 63), as Mitsuba's
    std::array<float, kRes> transmittance{};
    float fdr = 0.f;

    RoughCoating(const Microfacet& mf, float eta) {
        static const GaussLegendre gl32(32), gl48(48);
        for (int k = 0; k < kRes; ++k)
            transmittance[size_t(k)] =
                float(expectation(mf, std::max(1e-6f, float(k) / float(kRes - 1)), eta, true, eta > 1.f ? gl32 : gl48));
        // Fdr as Mitsuba defines it: twice the mean of R_int(mu) mu over the table's cosines (a
        // 64-node sum, about (63 Fdr_exact + R_int(1)) / 64, below the integral 2 int R_int mu dmu).
        double sum = 0.0;
        for (int k = 0; k < kRes; ++k) {
            const float mu = std::max(1e-6f, float(k) / float(kRes - 1));
            sum += expectation(mf, mu, 1.f / eta, false, gl48) * double(mu);
        }
        fdr = float(2.0 * sum / kRes);
    }
    // Mitsuba's lerp_gather over the table.
    float lookup(float mu) const {
        const float x = std::clamp(mu, 0.f, 1.f) * float(kRes - 1);
        const int i = std::min(int(x), kRes - 2);
        const float t = x - float(i);
        return (1.f - t) * transmittance[size_t(i)] + t * transmittance[size_t(i + 1)];
    }

private:
    static double expectation(const Microfacet& mf, float mu, float eta, bool transmit, const GaussLegendre& q) {
        const Vec3 w(std::sqrt(std::max(0.f, 1.f - mu * mu)), 0.f, mu);
        double sum = 0.0;
        for (size_t i = 0; i < q.x.size(); ++i)
            for (size_t j = 0; j < q.x.size(); ++j) {
                float unused = 0.f;
                const Vec3 m = mf.sampleVisible(w, Vec2(float(q.x[i]), float(q.x[j])), unused);
                const float wm = glm::dot(w, m);
                if (!(wm > 0.f)) continue;
                const float F = fresnelDielectric(wm, eta);
                Vec3 v;
                double value;
                if (transmit) {
                    if (!refractAbout(w, m, eta, v) || !(v.z < 0.f)) continue;
                    value = double(1.f - F) * mf.G1(v, m);
                } else {
                    v = reflectAbout(w, m);
                    if (!(v.z > 0.f)) continue;
                    value = double(F) * mf.G1(v, m);
                }
                sum += value * q.w[i] * q.w[j];
            }
        return sum;
    }
};

class PlasticBxdf final : public Bxdf {
public:
    // diffTex, specTex: the base's reflectance and the coating's specular reflectance as textures
    // (diffR and specR are then their means, for a caller without a point); the model at a point
    // is a PlasticAt (below) with the base and the coating's colour there.
    PlasticBxdf(bool rough, MicrofacetType dist, float alpha, float eta, const Color& diffR, const Color& specR,
                bool nonlinear, TexturePtr diffTex = nullptr, TexturePtr specTex = nullptr)
        : rough_(rough), lobe_{dist, MaskingModel::Smith, rough ? alpha : 0.f, rough ? alpha : 0.f}, eta_(eta),
          specR_(specR), nonlinear_(nonlinear), diffTex_(std::move(diffTex)), specTex_(std::move(specTex)) {
        if (rough_) {
            coating_.emplace(Microfacet(dist, alpha, alpha, MaskingModel::Smith), eta);
            fdr_ = coating_->fdr;
        } else {
            fdr_ = fresnelDiffuseReflectance(1.f / eta);
        }
        base_ = baseOf(diffR);
        diffR_ = diffR;
        float tMax = 0.f;  // (the table's nodes bound its interpolation; F is smallest near normal incidence)
        for (int k = 0; k <= 256; ++k) tMax = std::max(tMax, transmittance(float(k) / 256.f));
        const Color diffMax = diffTex_ ? diffTex_->maxValue() : diffR;
        baseBound_ = maxComp(baseOf(diffMax).color) * tMax * tMax;  // (R' grows with R)
        comp_.emplace(lobe_);  // (energy_compensation.h: smooth, or glossy and isotropic)
        continuation_ = std::max(continuationOf(specTex_ ? specTex_->maxValue() : specR), continuationOf(diffMax));
        textured_ = diffTex_ != nullptr || specTex_ != nullptr;
        cacheBounds();
    }

    // The base at one point: R' / (pi eta^2) and Mitsuba's specular sampling weight from R and
    // the coating's colour specR there.
    struct Base {
        Color color{0.f};
        float specWeight = 0.5f;
        Color specR{1.f};
    };
    Base baseOf(const Color& diffR) const { return baseOf(diffR, specR_); }
    Base baseOf(const Color& diffR, const Color& specR) const {
        const Color denom = nonlinear_ ? Color(1.f) - diffR * fdr_ : Color(1.f - fdr_);
        const float dMean = mean(diffR), sMean = mean(specR);
        return {diffR / denom * (kInvPi / (eta_ * eta_)), dMean + sMean > 0.f ? sMean / (dMean + sMean) : 0.5f, specR};
    }

    const Bxdf* atUv(const Vec2& uv, void* storage, size_t capacity) const override;

    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override {
        return evalImpl(base_, wo, wi, ctx, true);
    }
    bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const override {
        return sampleImpl(base_, wo, uLobe, u, ctx, out);
    }

    bool sampleImpl(const Base& base, const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx,
                    BsdfSample& out) const {
        if (!(wo.z > 0.f)) return false;
        const float pCoat = coatingProbability(base, transmittance(wo.z));
        const bool coat = uLobe < pCoat;
        Vec3 wi;
        if (coat) {
            const Request q = resolveFor(ctx.reg);
            if (q.alphas.delta) {  // the mirror (a smooth coating): weight specR F / P_c
                out.wi = Vec3(-wo.x, -wo.y, wo.z);
                if (ctx.directionOnly) return true;
                out.weight = base.specR * (fresnelDielectric(wo.z, eta_) / pCoat);
                out.pdfFwd = out.pdfRev = SolidAnglePdf(pCoat);  // (wi.z == wo.z: the reverse choice is the same)
                out.lobe = kReflection | kDelta;
                out.eta = 1.f;
                return true;
            }
            float unused = 0.f;
            const Vec3 m = lobe_.microfacet(q.alphas).sampleVisible(wo, u, unused);
            if (!(glm::dot(wo, m) > 0.f)) return false;
            wi = reflectAbout(wo, m);
        } else {
            wi = sampleCosineHemisphere(u);
        }
        if (!(wi.z > 0.f)) return false;
        out.wi = wi;
        if (ctx.directionOnly) return true;
        // The mixture's value over its density (Mitsuba's roughplastic); the cone is no sampled lobe.
        const BsdfEval e = evalImpl(base, wo, wi, ctx, false);
        if (!(e.pdfFwd.value > 0.f) || !std::isfinite(e.pdfFwd.value)) return false;
        out.weight = e.f * (wi.z / e.pdfFwd.value);
        out.pdfFwd = e.pdfFwd;
        out.pdfRev = e.pdfRev;
        out.lobe = coat ? (kReflection | kGlossy) : (kReflection | kDiffuse);
        out.eta = 1.f;
        return true;
    }

    uint32_t flags() const override { return kReflection | kDiffuse | (rough_ ? kGlossy : kDelta); }
    // The base's bound (its largest value) plus the coating's: its lobe's as the conductor's
    // (without Fresnel and colour), the cone's 1 / Omega, or +inf while it is a delta.
    float valueBound(const BsdfContext& ctx) const override {
        if (!rough_ && ctx.reg.cone > 0.f) return baseBound_ + 1.f / coneSolidAngle(ctx.reg.cone);
        const Request q = resolveFor(ctx.reg);
        if (q.alphas.delta) return kInf;
        const float alpha = std::max(std::min(q.alphas.u, q.alphas.v), kMinAlpha);
        if (q.compensated) return baseBound_ + comp_->valueBound(false, alpha, ctx.reg.bound);
        return baseBound_ + maxValueBound(lobe_.type, lobe_.masking, alpha, false, 1.f, ctx.reg.bound);
    }
    // The coating's alpha: the lobe a request changes (OPSR regularises a vertex only where its
    // accumulated roughness exceeds the vertex's own, and 1, the base's, would exclude the coating).
    float roughness() const override { return rough_ ? scalarRoughness(lobe_.alphaU, lobe_.alphaV) : 0.f; }
    Roughness alpha() const override { return {lobe_.alphaU, lobe_.alphaV}; }
    std::string name() const override { return rough_ ? "roughplastic" : "plastic"; }

private:
    // A request resolved for the coating, as the conductor resolves it (conductor.cpp).
    struct Request {
        MicrofacetLobe::Resolved alphas;
        bool compensated = false;
    };
    Request resolveFor(const RegularizationRequest& r) const {
        if (!(r.compensate && comp_->meets(r, false))) return {lobe_.resolve(r, false, 1.f), false};
        Request q{comp_->resolve(lobe_, r, false), false};
        q.compensated = !rough_ || q.alphas.u != lobe_.alphaU;
        return q;
    }

    // The coating's transmittance from outside at cosine mu (> 0).
    float transmittance(float mu) const {
        return coating_ ? coating_->lookup(mu) : 1.f - fresnelDielectric(mu, eta_);
    }
    // P_c, the probability of sampling the coating from a direction whose transmittance is t.
    float coatingProbability(const Base& base, float t) const {
        t = std::clamp(t, 0.f, 1.f);
        const float c = (1.f - t) * base.specWeight, d = t * (1.f - base.specWeight);
        return c + d > 0.f ? c / (c + d) : 1.f;
    }

    // The base and the coating's non-delta lobe under ctx's request, with the mixture's densities.
    // cone: whether a smooth coating takes KD13's cone (eval; not sample, which never draws it).
public:
    BsdfEval evalImpl(const Base& base, const Vec3& wo, const Vec3& wi, const BsdfContext& ctx, bool cone) const {
        BsdfEval e;
        const float cosO = wo.z, cosI = wi.z;
        if (!(cosO > 0.f) || !(cosI > 0.f)) return e;
        const float tO = transmittance(cosO), tI = transmittance(cosI);
        e.f = base.color * (tO * tI);
        const float pCoatO = ctx.valueOnly ? 0.f : coatingProbability(base, tO);
        const float pCoatI = ctx.valueOnly ? 0.f : coatingProbability(base, tI);
        if (!ctx.valueOnly) {
            e.pdfFwd = SolidAnglePdf((1.f - pCoatO) * cosI * kInvPi);
            e.pdfRev = SolidAnglePdf((1.f - pCoatI) * cosO * kInvPi);
        }
        if (!rough_ && ctx.reg.cone > 0.f) {  // (whatever else is asked, as the smooth conductor)
            if (cone)
                e.f += ConeMollifier(ctx.reg.cone).eval(base.specR * fresnelDielectric(cosO, eta_), wi, idealReflection(wo));
            return e;
        }
        const Request q = resolveFor(ctx.reg);
        if (q.alphas.delta) return e;
        const Microfacet mf = lobe_.microfacet(q.alphas);
        const MicrofacetReflectionTerms r = microfacetReflectionTerms(mf, wo, wi);
        if (!(r.value > 0.f)) return e;
        const float muL = ctx.mode == TransportMode::Radiance ? cosI : cosO;  // (the light side)
        if (q.compensated && !rough_) {  // specR F(mu_l) f1 / E(mu_l): the mirror's weight spread over the lobe
            e.f += base.specR * (fresnelDielectric(muL, eta_) *
                             comp_->reflectionScale(muL, 0.5f * (mf.alphaU() + mf.alphaV())) * r.value);
        } else {
            // Fresnel at the average of wo.h and wi.h (equal up to rounding): exactly reciprocal.
            float coat = fresnelDielectric(0.5f * (glm::dot(wo, r.h) + glm::dot(wi, r.h)), eta_) * r.value;
            if (q.compensated) coat *= comp_->reflectionScale(muL, q.alphas.u);
            e.f += base.specR * coat;
        }
        if (ctx.valueOnly) return e;
        e.pdfFwd.value += pCoatO * r.reflectDensity(wo, r.gO);
        e.pdfRev.value += pCoatI * r.reflectDensity(wi, r.gI);
        return e;
    }

private:
    bool rough_;
    MicrofacetLobe lobe_;  // the coating (alphas 0 when smooth)
    float eta_;
    Color specR_;
    bool nonlinear_;
    float fdr_ = 0.f;          // the base's internal diffuse reflectance Fdr
    TexturePtr diffTex_;       // the base's reflectance as a texture, or null
    TexturePtr specTex_;       // the coating's specular reflectance as a texture, or null
    Color diffR_{0.f};         // the base's reflectance (a texture's mean)
    Base base_;                // R' / (pi eta^2), Mitsuba's specular sampling weight w
    float baseBound_ = 0.f;    // the largest value of the base's term (over the texture too)
    std::optional<RoughCoating> coating_;   // (rough only)
    std::optional<LobeCompensation> comp_;  // (always: the coating is a reflection lobe, isotropic)
};

// A textured plastic's model at one point: the material's coating with the base there
// (Bxdf::atUv; evaluated and sampled only).
class PlasticAt final : public Bxdf {
public:
    PlasticAt(const PlasticBxdf& m, const Color& diffR, const Color& specR) : m_(m), base_(m.baseOf(diffR, specR)) {}
    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override {
        return m_.evalImpl(base_, wo, wi, ctx, true);
    }
    bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const override {
        return m_.sampleImpl(base_, wo, uLobe, u, ctx, out);
    }
    uint32_t flags() const override { return m_.flags(); }
    float valueBound(const BsdfContext& ctx) const override { return m_.valueBound(ctx); }
    float roughness() const override { return m_.roughness(); }
    Roughness alpha() const override { return m_.alpha(); }
    std::string name() const override { return m_.name(); }

private:
    const PlasticBxdf& m_;
    PlasticBxdf::Base base_;
};

const Bxdf* PlasticBxdf::atUv(const Vec2& uv, void* storage, size_t capacity) const {
    if (!textured_) return this;
    return emplaceInstance<PlasticAt>(storage, capacity, *this, diffTex_ ? diffTex_->eval(uv) : diffR_,
                                      specTex_ ? specTex_->eval(uv) : specR_);
}

}  // namespace

BxdfPtr makeTexturedPlastic(bool rough, MicrofacetType dist, float alpha, float eta, TexturePtr diffuseReflectance,
                            const Color& specularReflectance, bool nonlinear) {
    const Color mean = diffuseReflectance->meanValue();
    return std::make_shared<PlasticBxdf>(rough && alpha >= kMinAlpha, rough ? dist : MicrofacetType::GGX,
                                         rough ? alpha : 0.f, eta, mean, specularReflectance, nonlinear,
                                         std::move(diffuseReflectance));
}

BxdfPtr makeTexturedPlastic(bool rough, MicrofacetType dist, float alpha, float eta, TexturePtr diffuseReflectance,
                            const Color& diffuseConstant, TexturePtr specularReflectance,
                            const Color& specularConstant, bool nonlinear) {
    const Color diffR = diffuseReflectance ? diffuseReflectance->meanValue() : diffuseConstant;
    const Color specR = specularReflectance ? specularReflectance->meanValue() : specularConstant;
    return std::make_shared<PlasticBxdf>(rough && alpha >= kMinAlpha, rough ? dist : MicrofacetType::GGX,
                                         rough ? alpha : 0.f, eta, diffR, specR, nonlinear,
                                         std::move(diffuseReflectance), std::move(specularReflectance));
}

BxdfPtr makePlastic(float eta, const Color& diffuseReflectance, const Color& specularReflectance, bool nonlinear) {
    // Given a regularisation request (bsdf.h) the smooth coating becomes a GGX/Smith rough one.
    return std::make_shared<PlasticBxdf>(false, MicrofacetType::GGX, 0.f, eta, diffuseReflectance,
                                         specularReflectance, nonlinear);
}

BxdfPtr makeRoughPlastic(MicrofacetType dist, float alpha, float eta, const Color& diffuseReflectance,
                         const Color& specularReflectance, bool nonlinear) {
    const bool rough = alpha >= kMinAlpha;
    return std::make_shared<PlasticBxdf>(rough, dist, alpha, eta, diffuseReflectance, specularReflectance, nonlinear);
}

}  // namespace lt
