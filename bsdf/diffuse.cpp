// Lambertian diffuse (one-sided, as Mitsuba 3's "diffuse") and the two-sided adapter.
#include "bsdf/bsdf.h"
#include "core/sampling.h"

namespace lt {

namespace {

class DiffuseBxdf final : public Bxdf {
public:
    explicit DiffuseBxdf(const Color& r) : r_(r), f_(r * kInvPi) {}

    // The cosines are read once into locals: for all the compiler knows the output may alias wo,
    // so reading wo.z after storing to it would be a reload (and a repeated > 0 test).
    BsdfEval eval(const Vec3& wo, const Vec3& wi, TransportMode, const Roughness*) const override {
        const float cosO = wo.z, cosI = wi.z;
        if (!(cosO > 0.f) || !(cosI > 0.f)) return BsdfEval{};
        // cosineHemispherePdf, cos > 0 known
        return BsdfEval{f_, SolidAnglePdf(cosI * kInvPi), SolidAnglePdf(cosO * kInvPi)};
    }

    bool sample(const Vec3& wo, float, const Vec2& u, TransportMode, BsdfSample& out,
                const Roughness*) const override {
        const float cosO = wo.z;
        if (!(cosO > 0.f)) return false;
        const Vec3 wi = sampleCosineHemisphere(u);
        if (!(wi.z > 0.f)) return false;
        out.wi.x = wi.x;  // per component: a Vec3 copy goes through the stack
        out.wi.y = wi.y;
        out.wi.z = wi.z;
        out.weight = r_;  // (R/pi) cos / (cos/pi)
        out.pdfFwd = SolidAnglePdf(wi.z * kInvPi);  // cosineHemispherePdf, cos > 0 known
        out.pdfRev = SolidAnglePdf(cosO * kInvPi);
        out.lobe = kReflection | kDiffuse;
        out.eta = 1.f;
        return true;
    }

    uint32_t flags() const override { return kReflection | kDiffuse; }
    float roughness() const override { return 1.f; }
    std::string name() const override { return "diffuse"; }

private:
    Color r_;
    Color f_;  // r_ / pi, the value of f
};

// Mitsuba's twosided: the inner BSDF seen from both sides. When wo is below the surface both
// directions are mirrored through the tangent plane (z negated) before calling the inner model.
class TwoSidedBxdf final : public Bxdf {
public:
    explicit TwoSidedBxdf(BxdfPtr inner) : inner_(std::move(inner)) {}

    BsdfEval eval(const Vec3& wo, const Vec3& wi, TransportMode mode, const Roughness* rough) const override {
        if (wo.z < 0.f) return inner_->eval(flip(wo), flip(wi), mode, rough);
        return inner_->eval(wo, wi, mode, rough);
    }

    bool sample(const Vec3& wo, float uLobe, const Vec2& u, TransportMode mode, BsdfSample& out,
                const Roughness* rough) const override {
        if (wo.z < 0.f) {
            if (!inner_->sample(flip(wo), uLobe, u, mode, out, rough)) return false;
            out.wi = flip(out.wi);
            return true;
        }
        return inner_->sample(wo, uLobe, u, mode, out, rough);
    }

    uint32_t flags() const override { return inner_->flags(); }
    float roughness() const override { return inner_->roughness(); }
    Roughness alpha() const override { return inner_->alpha(); }
    std::string name() const override { return "twosided(" + inner_->name() + ")"; }

private:
    static Vec3 flip(const Vec3& w) { return {w.x, w.y, -w.z}; }
    BxdfPtr inner_;
};

}  // namespace

BxdfPtr makeDiffuse(const Color& reflectance) { return std::make_shared<DiffuseBxdf>(reflectance); }

BxdfPtr makeTwoSided(BxdfPtr inner) { return std::make_shared<TwoSidedBxdf>(std::move(inner)); }

}  // namespace lt
