// Mitsuba 3's thindielectric, null and (non-polarised) polarizer: a sheet that reflects as a mirror
// and lets light through without bending it, two-sided, all delta lobes (their plugin docs are the
// spec; the formulas those of thindielectric.cpp, null.cpp and polarizer.cpp's rgb branch).
//   thindielectric  R' = R + T^2 R / (1 - R^2) = 2R / (1 + R), R = F(|cos theta_o|, eta) (the
//                   sheet's two interfaces and every internal bounce, R T R T ...), mirror
//                   reflection of weight specR R', straight transmission specT (1 - R'). The lobe
//                   is chosen with probability R'.
//   null            straight transmission of weight 1 (Mitsuba's pass-through).
//   polarizer       straight transmission of weight transmittance / 2: Mitsuba's rgb variants
//                   render an ideal linear polarizer as a neutral filter absorbing half the
//                   unpolarised light (theta and polarizing change nothing there).
// Straight-through transmission crosses no change of index (BsdfSample::eta = 1), so the value is
// the same in both transport modes and reciprocal: eta^2 scaling does not arise. R' depends on
// |cos| only, so the reverse lobe choice of a pair has the probability of the forward one.
// Regularisation (bsdf.h): KD13's cone spreads each delta lobe's weight over its cone (as the
// smooth dielectric's, cone_mollifier.h); minAlpha and tau are ignored: the lobes stay deltas
// (a sheet has no microfacet lobe to widen, and a dielectric with eta = 1 stays a delta too).
#include "bsdf/bsdf.h"
#include "bsdf/cone_mollifier.h"
#include "bsdf/fresnel.h"

namespace lt {

namespace {

class ThinSheetBxdf final : public Bxdf {
public:
    // reflects: whether the sheet has the Fresnel reflection (thindielectric); otherwise it only
    // transmits with weight specT.
    ThinSheetBxdf(std::string name, bool reflects, float eta, const Color& specR, const Color& specT)
        : name_(std::move(name)), reflects_(reflects && eta != 1.f), eta_(eta), specR_(specR), specT_(specT) {
        continuation_ = reflects_ ? std::max(continuationOf(specR), continuationOf(specT)) : continuationOf(specT);
        cacheBounds();
    }

    // R' at |cos theta| = c (0 for a sheet without reflection).
    float reflectance(float c) const {
        if (!reflects_) return 0.f;
        const float r = fresnelDielectric(std::abs(c), eta_);
        return r * 2.f / (1.f + r);
    }

    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override {
        BsdfEval e;
        if (!(ctx.reg.cone > 0.f) || wo.z == 0.f || wi.z == 0.f) return e;  // (delta lobes only)
        const ConeMollifier cone(ctx.reg.cone);
        const float r = reflectance(wo.z);
        if (wo.z * wi.z > 0.f) {
            if (reflects_) e.f = cone.eval(specR_ * r, wi, idealReflection(wo));
        } else {
            e.f = cone.eval(specT_ * (1.f - r), wi, DVec3(-double(wo.x), -double(wo.y), -double(wo.z)));
        }
        return e;
    }

    bool sample(const Vec3& wo, float uLobe, const Vec2&, const BsdfContext& ctx, BsdfSample& out) const override {
        if (wo.z == 0.f) return false;
        const float r = reflectance(wo.z);
        out.eta = 1.f;
        if (uLobe < r) {
            out.wi = Vec3(-wo.x, -wo.y, wo.z);
            if (ctx.directionOnly) return true;
            out.weight = specR_;  // specR R' / P(reflection)
            out.pdfFwd = out.pdfRev = SolidAnglePdf(r);
            out.lobe = kReflection | kDelta;
        } else {
            out.wi = -wo;
            if (ctx.directionOnly) return true;
            out.weight = specT_;  // specT (1 - R') / P(transmission)
            out.pdfFwd = out.pdfRev = SolidAnglePdf(1.f - r);
            out.lobe = kTransmission | kDelta;
        }
        return true;
    }

    uint32_t flags() const override { return (reflects_ ? kReflection : kNone) | kTransmission | kDelta; }
    float roughness() const override { return 0.f; }
    std::string name() const override { return name_; }
    bool deltaUnder(const BsdfContext& ctx) const override { return !(ctx.reg.cone > 0.f); }
    float valueBound(const BsdfContext& ctx) const override {
        return ctx.reg.cone > 0.f ? 1.f / coneSolidAngle(ctx.reg.cone) : kInf;  // (the cone's 1 / Omega)
    }

private:
    std::string name_;
    bool reflects_;
    float eta_;
    Color specR_, specT_;
};

}  // namespace

BxdfPtr makeThinDielectric(float eta, const Color& specularReflectance, const Color& specularTransmittance) {
    return std::make_shared<ThinSheetBxdf>("thindielectric", true, eta, specularReflectance, specularTransmittance);
}

BxdfPtr makeNull() { return std::make_shared<ThinSheetBxdf>("null", false, 1.f, Color(0.f), Color(1.f)); }

BxdfPtr makePolarizer(const Color& transmittance) {
    return std::make_shared<ThinSheetBxdf>("polarizer", false, 1.f, Color(0.f), transmittance * 0.5f);
}

}  // namespace lt
