// Mitsuba 3's principledthin (its documentation and src/bsdfs/principledthin.cpp are the spec):
// Burley 2015's thin-surface form of the Disney BSDF, a two-sided sheet that does not bend light.
// Both sides are the same: with s the sign of wo.z, the model is evaluated for (s wo, s wi), wo
// above. With h = normalize(wo + wi'), wi' = wi mirrored to the upper side, F the dielectric
// Fresnel of wo.h with eta, st = spec_trans, dt = diff_trans / 2:
//  * specular reflection: st F' D G / (4 |wo.z| |wi.z|), F' = lerp(F, Schlick(tint R0(eta)),
//    spec_tint), GGX of the main alphas (principled's);
//  * specular transmission (wi below): st base_color (1 - F) D_t G_t / (4 |wo.z| |wi.z|), GGX with
//    roughness scaled by 0.65 eta - 0.35 (Burley 2015, Fig. 15): the reflection mirrored through
//    the sheet, where wi.h < 0 (Mitsuba's macro-micro test);
//  * diffuse reflection with retro-reflection, flatness and sheen (principled's), times
//    (1 - st)(1 - dt); diffuse transmission (1 - st) dt base_color / pi.
// Sampling: Mitsuba's lobe probabilities st rate / 2 (each specular lobe), (1 - st)(1 - dt) rate,
// (1 - st) dt rate; the density is the mixture. The transmission's macro-micro test is not
// symmetric in (wo, wi), so the model is not reciprocal near its edge: Importance mode evaluates
// the Radiance model with the directions swapped (f*(wo, wi) = f(wo -> wi), bsdf.h), and a sample's
// weight there is that value over the sampling density. No light is bent: a transmission's eta is 1.
// Regularisation (bsdf.h's requests): the two specular lobes, both of the reflection's form, are
// resolved each on its own with weight spec_trans (principled.h); the diffuse lobes stay.
#include "bsdf/fresnel.h"
#include "bsdf/microfacet.h"
#include "bsdf/principled.h"
#include "bsdf/roughness_bound.h"
#include "core/sampling.h"
#include "core/texture/texture.h"

namespace lt {

namespace {

using namespace principled_detail;

Roughness thinTransAlphas(float roughness, float anisotropic, float eta) {
    return mainAlphas((0.65f * eta - 0.35f) * roughness, anisotropic);
}

// What the value bound of a principledthin material is made of (as principled.cpp's
// PrincipledBound): the smaller alpha of each specular lobe, their weight spec_trans, and the
// diffuse lobes' bounds on a reflection pair (+inf with flatness) and a transmission pair.
struct ThinBound {
    float reflAlpha, transAlpha, weight, diffuseR, diffuseT;

    static float lobe(float alpha, float weight, const RegularizationRequest& r) {
        const MicrofacetLobe l{MicrofacetType::GGX, MaskingModel::Smith, alpha, alpha};
        const float a = resolveWeighted(l, weight, r, false, 1.f).u;
        return weight * maxValueBound(MicrofacetType::GGX, MaskingModel::Smith, a, false, 1.f, r.bound);
    }
    float value(const RegularizationRequest& r) const {
        if (!(weight > 0.f)) return std::max(diffuseR, diffuseT);
        return std::max(lobe(reflAlpha, weight, r) + diffuseR, lobe(transAlpha, weight, r) + diffuseT);
    }
    float changeable(BoundForm form) const {
        RegularizationRequest plain;
        plain.bound = form;
        return weight > 0.f ? std::max(lobe(reflAlpha, weight, plain), lobe(transAlpha, weight, plain)) : 0.f;
    }
};

class PrincipledThinBxdf final : public Bxdf {
public:
    struct Instance {};
    PrincipledThinBxdf(const PrincipledThinParams& p, Instance)
        : p_(p), mfR_(MicrofacetType::GGX, mainAlphas(p.roughness, p.anisotropic).alphaU,
                      mainAlphas(p.roughness, p.anisotropic).alphaV),
          mfT_(MicrofacetType::GGX, thinTransAlphas(p.roughness, p.anisotropic, p.eta).alphaU,
               thinTransAlphas(p.roughness, p.anisotropic, p.eta).alphaV) {
        const float lum = mitsubaLuminance(p.baseColor);
        tint_ = lum > 0.f ? p.baseColor / lum : Color(1.f);
        sheenColor_ = sheenColour(p.sheenTint);
        const float diffR = (1.f - p.specTrans) * (1.f - p.diffTrans);
        const float dR = diffuseSheenBound(diffR, maxComp(p.baseColor), p.roughness, p.flatness, p.sheen * diffR,
                                           maxComp(sheenColor_));
        bound_ = {std::min(mfR_.alphaU(), mfR_.alphaV()), std::min(mfT_.alphaU(), mfT_.alphaV()), p.specTrans, dR,
                  (1.f - p.specTrans) * p.diffTrans * maxComp(p.baseColor) * kInvPi};
    }
    explicit PrincipledThinBxdf(const PrincipledThinParams& p) : PrincipledThinBxdf(p, Instance{}) {
        continuation_ = 1.f;  // (the specular lobes' Fresnel weights are those of a dielectric of scale 1)
        cacheBounds();
        for (BoundForm f : {BoundForm::Tight, BoundForm::Published}) changeableBound_[int(f)] = bound_.changeable(f);
    }

    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override {
        BsdfEval e;
        if (wo.z == 0.f || wi.z == 0.f) return e;
        const Lobes l = lobesFor(ctx.reg);
        e.f = ctx.mode == TransportMode::Radiance ? valueAny(wo, wi, l) : valueAny(wi, wo, l);
        if (ctx.valueOnly) return e;
        e.pdfFwd = SolidAnglePdf(pdfAny(wo, wi, l));
        e.pdfRev = SolidAnglePdf(pdfAny(wi, wo, l));
        return e;
    }

    bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const override {
        if (wo.z == 0.f) return false;
        const float s = wo.z > 0.f ? 1.f : -1.f;
        const Vec3 o = wo * s;
        Probs pr;
        if (!probs(pr)) return false;
        const Lobes l = lobesFor(ctx.reg);
        Vec3 i;
        uint32_t lobe;
        float uExtra = 0.f;
        if (uLobe < pr.specR) {
            const Vec3 m = l.refl.sampleVisible(o, u, uExtra);
            i = reflectAbout(o, m);
            if (!(i.z > 0.f) || !(glm::dot(o, m) > 0.f) || !(glm::dot(i, m) > 0.f)) return false;
            lobe = kReflection | kGlossy;
        } else if (uLobe < pr.specR + pr.specT) {
            const Vec3 m = l.trans.sampleVisible(o, u, uExtra);
            i = reflectAbout(o, m);
            i.z = -i.z;
            if (!(i.z < 0.f) || !(glm::dot(o, m) > 0.f) || !(glm::dot(i, m) < 0.f)) return false;
            lobe = kTransmission | kGlossy;
        } else if (uLobe < pr.specR + pr.specT + pr.diffR) {
            i = sampleCosineHemisphere(u);
            lobe = kReflection | kDiffuse;
        } else {
            i = -sampleCosineHemisphere(u);
            lobe = kTransmission | kDiffuse;
        }
        if (i.z == 0.f) return false;
        const Vec3 wi = i * s;
        const float pdf = pdfFront(o, i, l);
        if (!(pdf > 0.f) || !std::isfinite(pdf)) return false;
        if (ctx.directionOnly) {
            out.wi = wi;
            return true;
        }
        const Color f = ctx.mode == TransportMode::Radiance ? valueAny(wo, wi, l) : valueAny(wi, wo, l);
        const Color w = f * (std::abs(i.z) / pdf);
        if (!std::isfinite(w.x + w.y + w.z)) return false;
        out.wi = wi;
        out.weight = w;
        out.pdfFwd = SolidAnglePdf(pdf);
        out.pdfRev = SolidAnglePdf(pdfAny(wi, wo, l));
        out.lobe = lobe;
        out.eta = 1.f;
        return true;
    }

    uint32_t flags() const override {
        uint32_t f = kReflection;
        if (p_.specTrans > 0.f) f |= kGlossy | kTransmission;
        if (p_.specTrans < 1.f) {
            if (p_.diffTrans < 1.f) f |= kDiffuse;
            if (p_.diffTrans > 0.f) f |= kDiffuse | kTransmission;
        }
        return f;
    }
    float roughness() const override {
        if (!(p_.specTrans > 0.f)) return 1.f;
        return std::min(scalarRoughness(mfR_.alphaU(), mfR_.alphaV()), scalarRoughness(mfT_.alphaU(), mfT_.alphaV()));
    }
    Roughness alpha() const override { return {mfR_.alphaU(), mfR_.alphaV()}; }
    float valueBound(const BsdfContext& ctx) const override { return bound_.value(ctx.reg); }
    std::string name() const override { return "principledthin"; }
    // The sheen's colour with this model's tint and sheen_tint t.
    Color sheenColour(float t) const { return Color(1.f) + (tint_ - Color(1.f)) * t; }

private:
    // The specular lobes of one call: the material's, or as a request resolves each.
    struct Lobes {
        Microfacet refl, trans;
    };
    Lobes lobesFor(const RegularizationRequest& r) const {
        if (r.empty()) return {mfR_, mfT_};
        auto resolve = [&](const Microfacet& m) {
            const MicrofacetLobe own{MicrofacetType::GGX, MaskingModel::Smith, m.alphaU(), m.alphaV()};
            const MicrofacetLobe::Resolved a = resolveWeighted(own, p_.specTrans, r, false, 1.f);
            return Microfacet(MicrofacetType::GGX, a.u, a.v);
        };
        return {resolve(mfR_), resolve(mfT_)};
    }
    struct Probs {
        float specR = 0.f, specT = 0.f, diffR = 0.f, diffT = 0.f;
    };
    bool probs(Probs& pr) const {
        const float st = p_.specTrans, dt = p_.diffTrans;
        pr.specR = st * p_.specReflRate * 0.5f;
        pr.specT = st * p_.specTransRate * 0.5f;
        pr.diffR = p_.diffReflRate * (1.f - st) * (1.f - dt);
        pr.diffT = p_.diffTransRate * (1.f - st) * dt;
        const float total = pr.specR + pr.specT + pr.diffR + pr.diffT;
        if (!(total > 0.f) || !std::isfinite(total)) return false;
        const float inv = 1.f / total;
        pr.specR *= inv;
        pr.specT *= inv;
        pr.diffR *= inv;
        pr.diffT *= inv;
        return true;
    }
    // The half vector of o (above) and i mirrored above; false where it does not exist.
    static bool half(const Vec3& o, const Vec3& i, Vec3& h) {
        h = o + Vec3(i.x, i.y, std::abs(i.z));
        const float len = glm::length(h);
        if (!(len > 0.f) || !std::isfinite(len)) return false;
        h /= len;
        return true;
    }
    Color valueAny(const Vec3& a, const Vec3& b, const Lobes& l) const {
        const float s = a.z > 0.f ? 1.f : -1.f;
        return valueFront(a * s, b * s, l);
    }
    float pdfAny(const Vec3& a, const Vec3& b, const Lobes& l) const {
        if (a.z == 0.f || b.z == 0.f) return 0.f;
        const float s = a.z > 0.f ? 1.f : -1.f;
        return pdfFront(a * s, b * s, l);
    }
    // f for o above (the side the model is defined on), i anywhere.
    Color valueFront(const Vec3& o, const Vec3& i, const Lobes& l) const {
        Color f(0.f);
        Vec3 h;
        if (i.z == 0.f || !half(o, i, h)) return f;
        const bool reflect = i.z > 0.f;
        const float co = o.z, ci = std::abs(i.z), st = p_.specTrans, dt = p_.diffTrans;
        const float oh = glm::dot(o, h), ih = glm::dot(i, h);
        if (st > 0.f && oh > 0.f) {
            const float F = fresnelDielectric(oh, p_.eta);
            if (reflect && ih > 0.f) {
                float fs = F;
                Color fp(F);
                if (p_.specTint > 0.f) {
                    const float r0 = (p_.eta - 1.f) / (p_.eta + 1.f);
                    fp = Color(fs) + (schlick(tint_ * (r0 * r0), oh, p_.eta) - Color(fs)) * p_.specTint;
                }
                const float dg = l.refl.D(h) * l.refl.G1(o, h) * l.refl.G1(i, h);
                f += fp * (st * dg / (4.f * co * ci));
            } else if (!reflect && ih < 0.f) {
                const float dg = l.trans.D(h) * l.trans.G1(o, h) * l.trans.G1(i, h);
                f += p_.baseColor * (st * (1.f - F) * dg / (4.f * co * ci));
            }
        }
        if (reflect && st < 1.f && dt < 1.f) {
            const float fo = schlickWeight(ci), fi = schlickWeight(co);
            const float cosD = ih;
            const float rr = 2.f * p_.roughness * cosD * cosD;
            float shape = (1.f - 0.5f * fi) * (1.f - 0.5f * fo) + rr * (fo + fi + fo * fi * (rr - 1.f));
            if (p_.flatness > 0.f) {
                const float fss90 = 0.5f * rr;
                const float fss = lerpf(1.f, fss90, fo) * lerpf(1.f, fss90, fi);
                const float ss = 1.25f * (fss * (1.f / (co + ci) - 0.5f) + 0.5f);
                shape = lerpf(shape, ss, p_.flatness);
            }
            f += p_.baseColor * ((1.f - st) * (1.f - dt) * kInvPi * shape);
            if (p_.sheen > 0.f) f += sheenColor_ * (p_.sheen * (1.f - st) * (1.f - dt) * schlickWeight(std::abs(cosD)));
        }
        if (!reflect && st < 1.f && dt > 0.f) f += p_.baseColor * ((1.f - st) * dt * kInvPi);
        return f;
    }
    float pdfFront(const Vec3& o, const Vec3& i, const Lobes& l) const {
        Probs pr;
        if (i.z == 0.f || !probs(pr)) return 0.f;
        const bool reflect = i.z > 0.f;
        float pdf = reflect ? pr.diffR * i.z * kInvPi : pr.diffT * (-i.z) * kInvPi;
        Vec3 h;
        if (p_.specTrans > 0.f && half(o, i, h)) {
            const float oh = glm::dot(o, h), ih = glm::dot(i, h);
            const float jac = 1.f / (4.f * std::abs(glm::dot(Vec3(i.x, i.y, std::abs(i.z)), h)));
            if (oh > 0.f && reflect && ih > 0.f) pdf += pr.specR * l.refl.pdfVisible(o, h) * jac;
            if (oh > 0.f && !reflect && ih < 0.f) pdf += pr.specT * l.trans.pdfVisible(o, h) * jac;
        }
        return std::isfinite(pdf) ? pdf : 0.f;
    }

    PrincipledThinParams p_;
    Microfacet mfR_, mfT_;
    Color tint_{1.f}, sheenColor_{1.f};
    ThinBound bound_{};
};

// principledthin with textured parameters (as TexturedPrincipledBxdf): the point's model at atUv,
// the textures' means without a point, flags and roughness over the textures' ranges.
class TexturedPrincipledThinBxdf final : public Bxdf {
public:
    TexturedPrincipledThinBxdf(const PrincipledThinParams& p, const PrincipledThinTextures& t)
        : p_(p), t_(t), mean_(at(&Texture::meanValue), PrincipledThinBxdf::Instance{}) {
        const PrincipledThinParams lo = at(&Texture::minValue), hi = at(&Texture::maxValue);
        flags_ = kReflection;
        if (hi.specTrans > 0.f) flags_ |= kGlossy | kTransmission;
        if (lo.specTrans < 1.f) {
            if (lo.diffTrans < 1.f) flags_ |= kDiffuse;
            if (hi.diffTrans > 0.f) flags_ |= kDiffuse | kTransmission;
        }
        roughness_ = 1.f;
        const Roughness a = mainAlphas(lo.roughness, hi.anisotropic);
        const float etaScale = std::min(std::abs(0.65f * lo.eta - 0.35f), std::abs(0.65f * hi.eta - 0.35f));
        const Roughness b = mainAlphas(etaScale * lo.roughness, hi.anisotropic);
        if (hi.specTrans > 0.f)
            roughness_ = std::min(scalarRoughness(a.alphaU, a.alphaV), scalarRoughness(b.alphaU, b.alphaV));
        anisotropic_ = hi.anisotropic > 0.f;
        textured_ = true;
        continuation_ = 1.f;
        // The bound's terms at their worst over the textures' ranges (as TexturedPrincipledBxdf's;
        // the sheen's tint has no bound from a textured base's range).
        const float diffR = (1.f - lo.specTrans) * (1.f - lo.diffTrans);
        float sheenColour = 1.f;
        if (hi.sheenTint > 0.f) sheenColour = t_.baseColor ? kInf : maxComp(mean_.sheenColour(hi.sheenTint));
        const float dR = diffuseSheenBound(diffR, maxComp(hi.baseColor), hi.roughness, hi.flatness, hi.sheen * diffR,
                                           std::max(1.f, sheenColour));
        bound_ = {std::min(a.alphaU, a.alphaV), std::min(b.alphaU, b.alphaV), hi.specTrans, dR,
                  (1.f - lo.specTrans) * hi.diffTrans * maxComp(hi.baseColor) * kInvPi};
        cacheBounds();
        for (BoundForm f : {BoundForm::Tight, BoundForm::Published}) changeableBound_[int(f)] = bound_.changeable(f);
    }
    const Bxdf* atUv(const Vec2& uv, void* storage, size_t capacity) const override {
        const PrincipledThinParams q = resolved([&](const Texture& x) { return x.eval(uv); },
                                                [&](const Texture& x) { return x.evalScalar(uv); });
        return emplaceInstance<PrincipledThinBxdf>(storage, capacity, q, PrincipledThinBxdf::Instance{});
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
    std::string name() const override { return "principledthin(textured)"; }

private:
    PrincipledThinParams at(Color (Texture::*stat)() const) const {
        return resolved([&](const Texture& x) { return (x.*stat)(); },
                        [&](const Texture& x) { return scalarOf((x.*stat)()); });
    }
    // The parameters with each texture replaced by color(texture) (base_color) or scalar(texture).
    template <class C, class S>
    PrincipledThinParams resolved(C&& color, S&& scalarValue) const {
        PrincipledThinParams q = p_;
        auto scalar = [&](const TexturePtr& x, float& v, float scale) {
            if (x) v = scale * scalarValue(*x);
        };
        if (t_.baseColor) q.baseColor = color(*t_.baseColor);
        scalar(t_.roughness, q.roughness, 1.f);
        scalar(t_.anisotropic, q.anisotropic, 1.f);
        scalar(t_.specTrans, q.specTrans, 1.f);
        scalar(t_.specTint, q.specTint, 1.f);
        scalar(t_.sheen, q.sheen, 1.f);
        scalar(t_.sheenTint, q.sheenTint, 1.f);
        scalar(t_.flatness, q.flatness, 1.f);
        scalar(t_.diffTrans, q.diffTrans, 0.5f);
        scalar(t_.eta, q.eta, 1.f);
        return q;
    }
    PrincipledThinParams p_;
    PrincipledThinTextures t_;
    PrincipledThinBxdf mean_;
    ThinBound bound_{};
    uint32_t flags_ = 0;
    float roughness_ = 1.f;
    bool anisotropic_ = false;
};

}  // namespace

BxdfPtr makePrincipledThin(const PrincipledThinParams& p, const PrincipledThinTextures& t) {
    if (t.any()) return std::make_shared<TexturedPrincipledThinBxdf>(p, t);
    return std::make_shared<PrincipledThinBxdf>(p);
}

}  // namespace lt
