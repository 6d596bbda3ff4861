// Lambertian diffuse (one-sided, as Mitsuba 3's "diffuse") and the two-sided adapter.
#include "bsdf/bsdf.h"
#include "core/sampling.h"

namespace lt {

namespace {

class DiffuseBxdf final : public Bxdf {
public:
    explicit DiffuseBxdf(const Color& r) : model_{r, r * kInvPi} {
        lambert_ = &model_;
        continuation_ = continuationOf(r);
        cacheBounds();
    }
    DiffuseBxdf(const DiffuseBxdf&) = delete;  // lambert_ points into this object
    DiffuseBxdf& operator=(const DiffuseBxdf&) = delete;

    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext&) const override { return model_.eval(wo, wi); }
    bool sample(const Vec3& wo, float, const Vec2& u, const BsdfContext&, BsdfSample& out) const override {
        return model_.sample(wo, u, out);
    }

    uint32_t flags() const override { return kReflection | kDiffuse; }
    float roughness() const override { return 1.f; }
    float valueBound(const BsdfContext&) const override { return maxComp(model_.f); }
    std::string name() const override { return "diffuse"; }

private:
    Lambert model_;
};

// Mitsuba's twosided: the inner BSDF seen from both sides. When wo is below the surface both
// directions are mirrored through the tangent plane (z negated) before calling the inner model.
class TwoSidedBxdf final : public Bxdf {
public:
    explicit TwoSidedBxdf(BxdfPtr inner) : inner_(std::move(inner)) {
        continuation_ = inner_->continuation();
        cacheBounds();
    }

    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override {
        if (wo.z < 0.f) return inner_->eval(flip(wo), flip(wi), ctx);
        return inner_->eval(wo, wi, ctx);
    }

    bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const override {
        if (wo.z < 0.f) {
            if (!inner_->sample(flip(wo), uLobe, u, ctx, out)) return false;
            out.wi = flip(out.wi);
            return true;
        }
        return inner_->sample(wo, uLobe, u, ctx, out);
    }

    uint32_t flags() const override { return inner_->flags(); }
    bool deltaUnder(const BsdfContext& ctx) const override { return inner_->deltaUnder(ctx); }
    float valueBound(const BsdfContext& ctx) const override { return inner_->valueBound(ctx); }
    // (tan^2 of each direction is the same mirrored)
    PairGeometry pairGeometry(const Vec3& wo, const Vec3& wi) const override {
        return wo.z < 0.f ? inner_->pairGeometry(flip(wo), flip(wi)) : inner_->pairGeometry(wo, wi);
    }
    float requestRatio(const PairGeometry& g, const BsdfContext& ctx) const override {
        return inner_->requestRatio(g, ctx);
    }
    float requestPdfRatio(const PairGeometry& g, const RegularizationRequest& r) const override {
        return inner_->requestPdfRatio(g, r);
    }
    // (the pairs are the inner model's, mirrored: the same bound)
    float requestRatioBound(const RegularizationRequest& r) const override { return inner_->requestRatioBound(r); }
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
