// Mitsuba 3's principled BSDF (its documentation and src/bsdfs/principled.cpp are the spec): Burley,
// "Physically Based Shading at Disney" (2012) and "Extending the Disney BRDF to a BSDF with
// Integrated Subsurface Scattering" (2015), in Mitsuba's form. The interior is the z < 0 side.
//
// Lobes, with wo the walk's previous direction (Mitsuba's si.wi), wi the next, h the (generalised)
// half vector facing +z, F the exact dielectric Fresnel of wo.h, D and G the anisotropic GGX
// distribution and separable Smith masking of alpha_x,y = max(0.001, r^2 / a), max(0.001, r^2 a),
// a = sqrt(1 - 0.9 anisotropic), r = roughness; brdf = (1 - metallic)(1 - spec_trans),
// bsdf = (1 - metallic) spec_trans:
//  * main reflection, both sides: Fp D G / (4 |wo.z| |wi.z|); outside Fp = (1 - metallic)
//    (1 - spec_tint) F + metallic Schlick(base_color) + (1 - metallic) spec_tint Schlick(tint R0),
//    inside Fp = bsdf F. Mitsuba evaluates it only where F > 0.
//  * transmission (Walter et al. 2007): sqrt(base_color) bsdf (1 - F) D G eta_p^2 |wo.h| |wi.h| /
//    (|wo.z| |wi.z| (wo.h + eta_p wi.h)^2), eta_p = n_wi / n_wo, times 1 / eta_p^2 in Radiance mode
//    only (bsdf.h's convention; Mitsuba's Radiance scale).
//  * clearcoat, outside: 0.25 clearcoat Schlick(0.04) D_GTR1(h) G1(wo) G1(wi) (GTR1 of alpha
//    lerp(0.1, 0.001, clearcoat_gloss), Smith GGX G1 of alpha 0.25), without the 1 / (4 cos cos) of
//    a microfacet lobe: Mitsuba's form.
//  * diffuse, outside: brdf base_color / pi ((1 - Fo/2)(1 - Fi/2) + retro), Hanrahan-Krueger's
//    flattened form blended by flatness; sheen (where brdf > 0, as Mitsuba): sheen (1 - metallic)
//    Schlick weight(|wi.h|) lerp(1, tint, sheen_tint).
// Sampling (Mitsuba's, one-sample MIS over the lobes; the density is the mixture): outside, the
// diffuse (cosine), clearcoat (GTR1 normals) and main specular lobes are chosen in proportion to
// brdf diffuse_rate, 0.25 clearcoat clearcoat_rate and specular_rate; the specular lobe samples a
// GGX visible normal m and reflects with probability 1 - bsdf (1 - F(m)), refracts otherwise.
// Inside only the specular lobe: reflection with probability F(m). The choice never depends on
// anything but (wo, m), so the mixture density below is the sampler's exactly.
// The model is reciprocal with the Radiance scaling: f_rad(wo, wi) = f_imp(wi, wo).
// Regularisation (bsdf.h's requests, JG19 and OPSR): the main lobe and the clearcoat are resolved
// each on its own (principled.h), the diffuse and sheen lobes are left as they are. The main
// reflection and transmission share one distribution (the sampler draws m before choosing), so
// the main lobe takes per axis the larger of the two lobes' resolved alphas (as the rough
// dielectric's sampler). Glossy lobes are not energy-compensated (energy_compensation.h: as the
// glossy dielectric, whose reflection and refraction share the Fresnel split). No lobe is a delta
// (alpha >= 0.001), so KD13's cones change nothing.
#include "bsdf/principled.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "bsdf/fresnel.h"
#include "bsdf/microfacet.h"
#include "bsdf/roughness_bound.h"
#include "core/sampling.h"
#include "core/texture/texture.h"

namespace lt {

namespace principled_detail {

float gtr1Peak(float alpha) {
    const double a2 = double(alpha) * double(alpha);
    return float((1.0 - a2) / (std::numbers::pi * a2 * std::log(1.0 / a2)));
}

float gtr1AlphaForBound(float bound) {
    if (!(bound < kInf)) return 0.f;
    if (gtr1Peak(kMaxGtr1Alpha) > bound) return kMaxGtr1Alpha;
    // In u = ln(1 / a^2) the peak is (1 - e^-u) e^u / (pi u), so ln peak - ln bound is
    // g(u) = ln(1 - e^-u) + u - ln(pi u) - ln bound, increasing (g' = 1 / (e^u - 1) + 1 - 1/u > 0);
    // its root is the alpha sought. Newton's steps from the large-u guess ln(pi bound ln(pi bound)),
    // kept inside a shrinking bracket (a bisection step where Newton's leaves it).
    const double logBound = std::log(double(bound));
    double lo = -std::log(double(kMaxGtr1Alpha) * kMaxGtr1Alpha), hi = -std::log(1e-12);  // alpha in [1e-6, 0.99]
    auto g = [&](double u) { return std::log(-std::expm1(-u)) + u - std::log(std::numbers::pi * u) - logBound; };
    const double pb = std::numbers::pi * double(bound);
    double u = std::clamp(std::log(pb * std::max(1.0, std::log(pb))), lo, hi);
    for (int i = 0; i < 60 && hi - lo > 1e-9 * hi; ++i) {
        const double gu = g(u);
        (gu > 0.0 ? hi : lo) = u;
        const double step = gu / (1.0 / std::expm1(u) + 1.0 - 1.0 / u);
        u = u - step > lo && u - step < hi ? u - step : 0.5 * (lo + hi);
        if (std::abs(step) < 1e-10 * u) break;
    }
    // The least float alpha whose peak, as gtr1Peak computes it, meets the bound.
    float a = std::min(float(std::exp(-0.5 * u)), kMaxGtr1Alpha);
    while (a < kMaxGtr1Alpha && gtr1Peak(a) > bound) a = std::nextafter(a, 1.f);
    while (a > 1e-6f && gtr1Peak(std::nextafter(a, 0.f)) <= bound) a = std::nextafter(a, 0.f);
    return a;
}

float resolveGtr1(float alpha, float weight, const RegularizationRequest& r) {
    float a = std::max({alpha, r.minAlpha.alphaU, r.minAlpha.alphaV});
    // (an alpha that meets the bound already stands: gtr1Peak falls with alpha)
    if (r.tau < kInf && weight > 0.f && a < kMaxGtr1Alpha && gtr1Peak(a) > r.tau / weight)
        a = std::max(a, gtr1AlphaForBound(r.tau / weight));
    return std::min(a, kMaxGtr1Alpha);
}

MicrofacetLobe::Resolved resolveWeighted(const MicrofacetLobe& lobe, float weight, const RegularizationRequest& r,
                                         bool transmission, float eta) {
    RegularizationRequest q = r;
    if (q.tau < kInf) q.tau = weight > 0.f ? q.tau / weight : kInf;
    return lobe.resolve(q, transmission, eta);
}

float diffuseShapeBound(float roughness) {
    const float rr = 2.f * roughness;
    return std::max({1.f, 0.5f + rr, 0.25f + rr * (1.f + rr)});
}

float diffuseSheenBound(float weight, float maxBase, float roughness, float flatness, float sheenWeight,
                        float sheenColour) {
    if (!(weight > 0.f)) return 0.f;
    if (flatness > 0.f) return kInf;
    const float diffuse = weight * maxBase * kInvPi * diffuseShapeBound(roughness);
    return sheenWeight > 0.f ? diffuse + sheenWeight * sheenColour : diffuse;
}

}  // namespace principled_detail

namespace {

using namespace principled_detail;

// What the value bound (Bxdf::valueBound) of a principled material is made of: the smallest main
// alpha (the anisotropic lobe's smaller one), the transmission's and the clearcoat's weights, the
// clearcoat's smallest alpha and the diffuse and sheen lobes' bound (+inf with flatness: the
// flattened form has none). A textured material takes each at its worst over the textures.
struct PrincipledBound {
    float mainAlpha, transWeight, ccWeight, ccAlpha, diffuse, eta;

    // sup f under r: the larger of a reflection pair's (main + clearcoat + diffuse) and a
    // transmission pair's (transmission only), each microfacet lobe resolved as the model does
    // (PrincipledBxdf::lobesFor; its smaller axis is resolved from mainAlpha here). The
    // reflection's term takes the reflection's own alpha_hat, not the larger one a refraction may
    // add: so it also bounds a textured material's points that do not refract.
    float value(const RegularizationRequest& r) const {
        const MicrofacetLobe lobe{MicrofacetType::GGX, MaskingModel::Smith, mainAlpha, mainAlpha};
        const float aR = resolveWeighted(lobe, 1.f, r, false, 1.f).u;
        float refl = maxValueBound(MicrofacetType::GGX, MaskingModel::Smith, aR, false, 1.f, r.bound) + diffuse;
        if (ccWeight > 0.f) refl += ccWeight * gtr1Peak(resolveGtr1(ccAlpha, ccWeight, r));
        if (!(transWeight > 0.f)) return refl;
        const float a = std::max(aR, resolveWeighted(lobe, transWeight, r, true, eta).u);
        return std::max(refl, transWeight * maxValueBound(MicrofacetType::GGX, MaskingModel::Smith, a, true, eta, r.bound));
    }
    // The largest bound under which a request changes a lobe: the microfacet lobes' own bounds.
    float changeable(BoundForm form) const {
        float b = maxValueBound(MicrofacetType::GGX, MaskingModel::Smith, mainAlpha, false, 1.f, form);
        if (transWeight > 0.f)
            b = std::max(b, transWeight * maxValueBound(MicrofacetType::GGX, MaskingModel::Smith, mainAlpha, true, eta, form));
        if (ccWeight > 0.f) b = std::max(b, ccWeight * gtr1Peak(ccAlpha));
        return b;
    }
};

class PrincipledBxdf final : public Bxdf {
public:
    struct Instance {};
    PrincipledBxdf(const PrincipledParams& p, Instance)
        : p_(p), mf_(MicrofacetType::GGX, mainAlphas(p.roughness, p.anisotropic).alphaU,
                     mainAlphas(p.roughness, p.anisotropic).alphaV),
          cc_{clearcoatAlpha(p.clearcoatGloss)} {
        brdf_ = (1.f - p.metallic) * (1.f - p.specTrans);
        bsdf_ = (1.f - p.metallic) * p.specTrans;
        tint_ = tintOf(p.baseColor);
        sheenColor_ = sheenColour(p.baseColor, p.sheenTint);
        sqrtBase_ = Color(std::sqrt(p.baseColor.x), std::sqrt(p.baseColor.y), std::sqrt(p.baseColor.z));
        bound_ = ownBound();
    }
    explicit PrincipledBxdf(const PrincipledParams& p) : PrincipledBxdf(p, Instance{}) {
        continuation_ = 1.f;  // the main reflection is a dielectric's of scale 1 (Fresnel alone weights it)
        cacheBounds();
        for (BoundForm f : {BoundForm::Tight, BoundForm::Published}) changeableBound_[int(f)] = bound_.changeable(f);
    }
    // Mitsuba's tint (the base colour over its luminance) and the sheen's colour.
    static Color tintOf(const Color& base) {
        const float lum = mitsubaLuminance(base);
        return lum > 0.f ? base / lum : Color(1.f);
    }
    static Color sheenColour(const Color& base, float sheenTint) {
        return Color(1.f) + (tintOf(base) - Color(1.f)) * sheenTint;
    }
    // The bound's terms of this model (the diffuse and sheen lobes' exactly).
    PrincipledBound ownBound() const {
        const float diffuse = diffuseSheenBound(brdf_, maxComp(p_.baseColor), p_.roughness, p_.flatness,
                                                p_.sheen * (1.f - p_.metallic), maxComp(sheenColor_));
        return {std::min(mf_.alphaU(), mf_.alphaV()), bsdf_, 0.25f * p_.clearcoat, cc_.alpha, diffuse, p_.eta};
    }

    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override {
        BsdfEval e;
        Pair q;
        const Lobes l = lobesFor(ctx.reg);
        if (!pair(wo, wi, q)) return e;
        e.f = value(wo, wi, q, ctx.mode, l);
        if (ctx.valueOnly) return e;
        e.pdfFwd = SolidAnglePdf(density(wo, wi, q, l));
        Pair r;
        if (pair(wi, wo, r)) e.pdfRev = SolidAnglePdf(density(wi, wo, r, l));
        return e;
    }

    bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const override {
        if (wo.z == 0.f) return false;
        const bool front = wo.z > 0.f;
        if (!front && !(bsdf_ > 0.f)) return false;
        const float s = front ? 1.f : -1.f;
        const Vec3 o = wo * s;
        const Lobes l = lobesFor(ctx.reg);
        float uExtra = 0.f;
        const Vec3 m = l.main.sampleVisible(o, u, uExtra);
        const float F = fresnelDielectric(glm::dot(wo, m), p_.eta);
        Probs pr;
        if (!probs(front, F, pr)) return false;
        Vec3 wi;
        uint32_t lobe;
        float eta = 1.f;
        if (uLobe < pr.diffuse) {
            wi = sampleCosineHemisphere(u);
            lobe = kReflection | kDiffuse;
        } else if (uLobe < pr.diffuse + pr.clearcoat) {
            const Vec3 mc = l.cc.sample(u);
            wi = reflectAbout(wo, mc);
            if (!(glm::dot(wo, mc) * s > 0.f) || !(glm::dot(wi, mc) * s > 0.f)) return false;
            lobe = kReflection | kGlossy;
        } else if (uLobe < pr.diffuse + pr.clearcoat + pr.transmission) {
            if (!refractAbout(wo, m, p_.eta, wi)) return false;
            if (!(glm::dot(wo, m) * s > 0.f) || !(glm::dot(wi, m) * s < 0.f)) return false;
            lobe = kTransmission | kGlossy;
            eta = front ? p_.eta : 1.f / p_.eta;
        } else {
            wi = reflectAbout(wo, m);
            if (!(glm::dot(wo, m) * s > 0.f) || !(glm::dot(wi, m) * s > 0.f)) return false;
            lobe = kReflection | kGlossy;
        }
        if (!(wi.z * wo.z > 0.f) && !(lobe & kTransmission)) return false;
        if (!(wi.z * wo.z < 0.f) && (lobe & kTransmission)) return false;
        Pair q;
        if (!pair(wo, wi, q)) return false;
        const float pdf = density(wo, wi, q, l);
        if (!(pdf > 0.f) || !std::isfinite(pdf)) return false;
        if (ctx.directionOnly) {
            out.wi = wi;
            return true;
        }
        const Color w = value(wo, wi, q, ctx.mode, l) * (std::abs(wi.z) / pdf);
        if (!std::isfinite(w.x + w.y + w.z)) return false;
        out.wi = wi;
        out.weight = w;
        out.pdfFwd = SolidAnglePdf(pdf);
        Pair r;
        out.pdfRev = SolidAnglePdf(pair(wi, wo, r) ? density(wi, wo, r, l) : 0.f);
        out.lobe = lobe;
        out.eta = eta;
        return true;
    }

    uint32_t flags() const override {
        uint32_t f = kReflection | kGlossy;
        if (brdf_ > 0.f) f |= kDiffuse;
        if (bsdf_ > 0.f) f |= kTransmission;
        return f;
    }
    float roughness() const override {
        float r = scalarRoughness(mf_.alphaU(), mf_.alphaV());
        if (p_.clearcoat > 0.f) r = std::min(r, cc_.alpha);
        return r;
    }
    Roughness alpha() const override { return {mf_.alphaU(), mf_.alphaV()}; }
    float valueBound(const BsdfContext& ctx) const override { return bound_.value(ctx.reg); }
    std::string name() const override { return "principled"; }

private:
    // The two microfacet lobes of one call: the material's, or as a request resolves them.
    struct Lobes {
        Microfacet main;
        Gtr1 cc;
    };
    Lobes lobesFor(const RegularizationRequest& r) const {
        if (r.empty()) return {mf_, cc_};
        const MicrofacetLobe own{MicrofacetType::GGX, MaskingModel::Smith, mf_.alphaU(), mf_.alphaV()};
        MicrofacetLobe::Resolved a = resolveWeighted(own, 1.f, r, false, 1.f);
        if (bsdf_ > 0.f) {
            const MicrofacetLobe::Resolved t = resolveWeighted(own, bsdf_, r, true, p_.eta);
            a.u = std::max(a.u, t.u);
            a.v = std::max(a.v, t.v);
        }
        const float cc = p_.clearcoat > 0.f ? resolveGtr1(cc_.alpha, 0.25f * p_.clearcoat, r) : cc_.alpha;
        return {Microfacet(MicrofacetType::GGX, a.u, a.v), Gtr1{cc}};
    }

    // What eval and the density share for one ordered pair.
    struct Pair {
        bool front, reflect;
        float etaPath;  // n_wi / n_wo for a refraction
        Vec3 h;         // facing +z
        float oh, ih, F;
        bool compatR, compatT;  // the macro and micro surfaces agree (Mitsuba's mac_mic_compatibility)
    };
    bool pair(const Vec3& wo, const Vec3& wi, Pair& q) const {
        if (wo.z == 0.f || wi.z == 0.f) return false;
        q.front = wo.z > 0.f;
        if (!q.front && !(bsdf_ > 0.f)) return false;  // inside, only the BSDF lobe scatters
        q.reflect = wo.z * wi.z > 0.f;
        if (!q.reflect && !(bsdf_ > 0.f)) return false;
        q.etaPath = q.front ? p_.eta : 1.f / p_.eta;
        // (a refraction's half vector from the outside and inside directions, n_out w_out + n_in w_in
        // up to scale: the same floats for (wo, wi) and (wi, wo), so the adjoint pair agrees to
        // rounding even in the distribution's far tails)
        const Vec3& out = q.front ? wo : wi;
        const Vec3& in = q.front ? wi : wo;
        Vec3 h = q.reflect ? wo + wi : out + in * p_.eta;
        const float len = glm::length(h);
        if (!(len > 0.f) || !std::isfinite(len)) return false;
        h /= len;
        if (h.z < 0.f) h = -h;
        q.h = h;
        q.oh = glm::dot(wo, h);
        q.ih = glm::dot(wi, h);
        // (F of wo.h, Mitsuba's, computed from the same floats for (wo, wi) and (wi, wo): the mean of
        // the two equal cosines of a reflection, the outside cosine of a refraction, whose Fresnel
        // is the same from both sides but ill-conditioned from the inside near the critical angle)
        const float outH = glm::dot(out, h);
        q.F = fresnelDielectric(q.reflect ? 0.5f * (q.oh + q.ih) : outH, p_.eta);
        const float s = q.front ? 1.f : -1.f;
        q.compatR = q.reflect && q.oh * s > 0.f && q.ih * s > 0.f;
        q.compatT = !q.reflect && q.oh * s > 0.f && q.ih * s < 0.f;
        return true;
    }

    Color value(const Vec3& wo, const Vec3& wi, const Pair& q, TransportMode mode, const Lobes& l) const {
        Color f(0.f);
        const float co = std::abs(wo.z), ci = std::abs(wi.z);
        if ((q.compatR && q.F > 0.f) || (q.compatT && q.F < 1.f)) {
            const float dg = l.main.D(q.h) * l.main.G1(wo, q.h) * l.main.G1(wi, q.h);
            if (q.compatR) {
                Color fp(0.f);
                if (q.front) {
                    const float etaIt = q.oh >= 0.f ? p_.eta : 1.f / p_.eta;
                    const float r0 = (etaIt - 1.f) / (etaIt + 1.f);
                    fp = Color((1.f - p_.metallic) * (1.f - p_.specTint) * q.F);
                    if (p_.metallic > 0.f) fp += p_.metallic * schlick(p_.baseColor, q.oh, p_.eta);
                    if (p_.specTint > 0.f)
                        fp += (1.f - p_.metallic) * p_.specTint * schlick(tint_ * (r0 * r0), q.oh, p_.eta);
                } else {
                    fp = Color(bsdf_ * q.F);
                }
                f += fp * (dg / (4.f * co * ci));
            } else if (bsdf_ > 0.f) {
                const float e = q.etaPath, scale = mode == TransportMode::Radiance ? 1.f / (e * e) : 1.f;
                const float den = q.oh + e * q.ih;
                const float t = std::abs(scale * (1.f - q.F) * dg * e * e * q.oh * q.ih / (co * ci * den * den));
                if (std::isfinite(t)) f += sqrtBase_ * (bsdf_ * t);
            }
        }
        if (!q.front || !q.reflect) return f;
        if (q.compatR && p_.clearcoat > 0.f) {
            const float fcc = schlick(0.04f, q.oh, p_.eta);
            f += Color(0.25f * p_.clearcoat * fcc * l.cc.D(q.h) * smithGgx1(wo, q.h, 0.25f) * smithGgx1(wi, q.h, 0.25f));
        }
        if (brdf_ > 0.f) {
            const float fo = schlickWeight(ci), fi = schlickWeight(co);
            const float cosD = glm::dot(q.h, wi);
            const float rr = 2.f * p_.roughness * cosD * cosD;
            float shape = (1.f - 0.5f * fi) * (1.f - 0.5f * fo) + rr * (fo + fi + fo * fi * (rr - 1.f));
            if (p_.flatness > 0.f) {
                const float fss90 = 0.5f * rr;
                const float fss = lerpf(1.f, fss90, fo) * lerpf(1.f, fss90, fi);
                const float ss = 1.25f * (fss * (1.f / (co + ci) - 0.5f) + 0.5f);
                shape = lerpf(shape, ss, p_.flatness);
            }
            f += p_.baseColor * (brdf_ * kInvPi * shape);
            if (p_.sheen > 0.f && 1.f - p_.metallic > 0.f)
                f += sheenColor_ * (p_.sheen * (1.f - p_.metallic) * schlickWeight(std::abs(cosD)));
        }
        return f;
    }

    struct Probs {
        float diffuse = 0.f, clearcoat = 0.f, transmission = 0.f, reflection = 0.f;
    };
    // The lobes' selection probabilities given F of the specular lobe's microfacet normal.
    bool probs(bool front, float F, Probs& pr) const {
        if (front) {
            pr.diffuse = brdf_ * p_.diffuseRate;
            pr.clearcoat = 0.25f * p_.clearcoat * p_.clearcoatRate;
            pr.transmission = p_.specularRate * bsdf_ * (1.f - F);
            pr.reflection = p_.specularRate * (1.f - bsdf_ * (1.f - F));
        } else {
            pr.reflection = F;
            pr.transmission = 1.f - F;
        }
        const float total = pr.diffuse + pr.clearcoat + pr.transmission + pr.reflection;
        if (!(total > 0.f) || !std::isfinite(total)) return false;
        const float inv = 1.f / total;
        pr.diffuse *= inv;
        pr.clearcoat *= inv;
        pr.transmission *= inv;
        pr.reflection *= inv;
        return true;
    }

    // The mixture density of sampling wi given wo.
    float density(const Vec3& wo, const Vec3& wi, const Pair& q, const Lobes& l) const {
        Probs pr;
        if (!probs(q.front, q.F, pr)) return 0.f;
        const Vec3 o = q.front ? wo : -wo;
        float pdf = 0.f;
        if (q.compatR) {
            const float jac = 1.f / (4.f * std::abs(q.ih));
            pdf += pr.reflection * l.main.pdfVisible(o, q.h) * jac;
            if (pr.clearcoat > 0.f) pdf += pr.clearcoat * l.cc.pdf(q.h) * jac;
        }
        if (q.compatT && pr.transmission > 0.f) {
            const float den = q.oh + q.etaPath * q.ih;
            const float jac = q.etaPath * q.etaPath * std::abs(q.ih) / (den * den);
            pdf += pr.transmission * l.main.pdfVisible(o, q.h) * jac;
        }
        if (q.front && q.reflect) pdf += pr.diffuse * std::max(0.f, wi.z) * kInvPi;
        return std::isfinite(pdf) ? pdf : 0.f;
    }

    PrincipledParams p_;
    Microfacet mf_;
    Gtr1 cc_;
    float brdf_ = 0.f, bsdf_ = 0.f;
    Color tint_{1.f}, sheenColor_{1.f}, sqrtBase_{0.f};
    PrincipledBound bound_{};
};

// principled with textured parameters: the model at a point is the untextured one of the point's
// values (atUv); without a point, the model of the textures' means. Flags, roughness and alpha
// describe the material over the textures' ranges.
class TexturedPrincipledBxdf final : public Bxdf {
public:
    TexturedPrincipledBxdf(const PrincipledParams& p, const PrincipledTextures& t)
        : p_(p), t_(t), mean_(at(&Texture::meanValue), PrincipledBxdf::Instance{}) {
        const PrincipledParams lo = at(&Texture::minValue), hi = at(&Texture::maxValue);
        bound_ = worstBound(lo, hi);
        flags_ = kReflection | kGlossy;
        if ((1.f - lo.metallic) * (1.f - lo.specTrans) > 0.f) flags_ |= kDiffuse;
        if ((1.f - lo.metallic) * hi.specTrans > 0.f) flags_ |= kTransmission;
        const Roughness a = mainAlphas(lo.roughness, hi.anisotropic);
        roughness_ = scalarRoughness(a.alphaU, a.alphaV);
        if (hi.clearcoat > 0.f) roughness_ = std::min(roughness_, clearcoatAlpha(hi.clearcoatGloss));
        anisotropic_ = hi.anisotropic > 0.f;
        textured_ = true;
        continuation_ = 1.f;
        cacheBounds();
        for (BoundForm f : {BoundForm::Tight, BoundForm::Published}) changeableBound_[int(f)] = bound_.changeable(f);
    }
    const Bxdf* atUv(const Vec2& uv, void* storage, size_t capacity) const override {
        const PrincipledParams q = resolved([&](const Texture& x) { return x.eval(uv); },
                                            [&](const Texture& x) { return x.evalScalar(uv); });
        return emplaceInstance<PrincipledBxdf>(storage, capacity, q, PrincipledBxdf::Instance{});
    }
    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override { return mean_.eval(wo, wi, ctx); }
    bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const override {
        return mean_.sample(wo, uLobe, u, ctx, out);
    }
    uint32_t flags() const override { return flags_; }
    float roughness() const override { return roughness_; }
    Roughness alpha() const override { return mean_.alpha(); }
    bool anisotropic() const override { return anisotropic_; }
    float valueBound(const BsdfContext& ctx) const override { return bound_.value(ctx.reg); }
    std::string name() const override { return "principled(textured)"; }

private:
    // The bound's terms at their worst over the textures' ranges [lo, hi] (every point's model's
    // bound is at most the material's: each term grows with the weights and falls with the alphas).
    PrincipledBound worstBound(const PrincipledParams& lo, const PrincipledParams& hi) const {
        // (the sheen's tint is base / luminance(base): no bound from a textured base's range)
        float sheenColour = 1.f;
        if (hi.sheenTint > 0.f)
            sheenColour = t_.baseColor ? kInf : maxComp(PrincipledBxdf::sheenColour(p_.baseColor, hi.sheenTint));
        const float diffuse = diffuseSheenBound((1.f - lo.metallic) * (1.f - lo.specTrans), maxComp(hi.baseColor),
                                                hi.roughness, hi.flatness, hi.sheen * (1.f - lo.metallic),
                                                std::max(1.f, sheenColour));
        const Roughness a = mainAlphas(lo.roughness, hi.anisotropic);
        return {std::min(a.alphaU, a.alphaV), (1.f - lo.metallic) * hi.specTrans, 0.25f * hi.clearcoat,
                clearcoatAlpha(hi.clearcoatGloss), diffuse, p_.eta};
    }
    // The parameters with each texture replaced by one of its statistics.
    PrincipledParams at(Color (Texture::*stat)() const) const {
        return resolved([&](const Texture& x) { return (x.*stat)(); },
                        [&](const Texture& x) { return scalarOf((x.*stat)()); });
    }
    // The parameters with each texture replaced by color(texture) (base_color) or scalar(texture).
    template <class C, class S>
    PrincipledParams resolved(C&& color, S&& scalarValue) const {
        PrincipledParams q = p_;
        auto scalar = [&](const TexturePtr& x, float& v) {
            if (x) v = scalarValue(*x);
        };
        if (t_.baseColor) q.baseColor = color(*t_.baseColor);
        scalar(t_.roughness, q.roughness);
        scalar(t_.anisotropic, q.anisotropic);
        scalar(t_.metallic, q.metallic);
        scalar(t_.specTrans, q.specTrans);
        scalar(t_.specTint, q.specTint);
        scalar(t_.sheen, q.sheen);
        scalar(t_.sheenTint, q.sheenTint);
        scalar(t_.flatness, q.flatness);
        scalar(t_.clearcoat, q.clearcoat);
        scalar(t_.clearcoatGloss, q.clearcoatGloss);
        return q;
    }
    PrincipledParams p_;
    PrincipledTextures t_;
    PrincipledBxdf mean_;
    PrincipledBound bound_{};
    uint32_t flags_ = 0;
    float roughness_ = 1.f;
    bool anisotropic_ = false;
};

}  // namespace

BxdfPtr makePrincipled(const PrincipledParams& p, const PrincipledTextures& t) {
    if (t.any()) return std::make_shared<TexturedPrincipledBxdf>(p, t);
    return std::make_shared<PrincipledBxdf>(p);
}

}  // namespace lt
