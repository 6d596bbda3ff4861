// Lambertian diffuse (one-sided, as Mitsuba 3's "diffuse") and the two-sided adapter.
#include "bsdf/bsdf.h"
#include "core/sampling.h"
#include "core/texture/texture.h"

namespace lt {

namespace {

class DiffuseBxdf final : public Bxdf {
public:
    explicit DiffuseBxdf(const Color& r) : model_{r, r * kInvPi} {
        lambert_ = &model_;
        continuation_ = continuationOf(r);
        cacheBounds();
    }
    // A textured material's instance at one point: evaluated and sampled only (Bxdf::atUv), so
    // without the bounds' cache.
    struct Instance {};
    DiffuseBxdf(const Color& r, Instance) : model_{r, r * kInvPi} { lambert_ = &model_; }
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

// Lambert's model whose reflectance is a texture: the model at a point is a DiffuseBxdf instance.
// Without a point (a caller that bypasses atUv) it is the texture's mean.
class TexturedDiffuseBxdf final : public Bxdf {
public:
    explicit TexturedDiffuseBxdf(TexturePtr r) : texture_(std::move(r)), mean_{texture_->meanValue(), texture_->meanValue() * kInvPi} {
        textured_ = true;
        continuation_ = continuationOf(texture_->maxValue());
        cacheBounds();
    }
    const Bxdf* atUv(const Vec2& uv, void* storage, size_t capacity) const override {
        return emplaceInstance<DiffuseBxdf>(storage, capacity, texture_->eval(uv), DiffuseBxdf::Instance{});
    }
    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext&) const override { return mean_.eval(wo, wi); }
    bool sample(const Vec3& wo, float, const Vec2& u, const BsdfContext&, BsdfSample& out) const override {
        return mean_.sample(wo, u, out);
    }
    uint32_t flags() const override { return kReflection | kDiffuse; }
    float roughness() const override { return 1.f; }
    float valueBound(const BsdfContext&) const override { return maxComp(texture_->maxValue()) * kInvPi; }
    std::string name() const override { return "diffuse(" + texture_->name() + ")"; }

private:
    TexturePtr texture_;
    Lambert mean_;
};

// Mitsuba's twosided: the inner BSDF seen from both sides. When wo is below the surface both
// directions are mirrored through the tangent plane (z negated) before calling the inner model.
class TwoSidedBxdf final : public Bxdf {
public:
    explicit TwoSidedBxdf(BxdfPtr inner) : inner_(std::move(inner)), innerModel_(inner_.get()) {
        textured_ = inner_->textured();
        continuation_ = inner_->continuation();
        cacheBounds();
    }
    // A textured inner model's instance, inside this adapter's own instance (evaluated and sampled
    // only: see Bxdf::atUv).
    struct Instance {};
    TwoSidedBxdf(const TwoSidedBxdf& material, const Vec2& uv, Instance)
        : innerModel_(material.inner_->atUv(uv, innerStorage_, sizeof(innerStorage_))) {}
    const Bxdf* atUv(const Vec2& uv, void* storage, size_t capacity) const override {
        if (!textured_) return this;
        return emplaceInstance<TwoSidedBxdf>(storage, capacity, *this, uv, Instance{});
    }

    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override {
        if (wo.z < 0.f) return innerModel_->eval(flip(wo), flip(wi), ctx);
        return innerModel_->eval(wo, wi, ctx);
    }

    bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const override {
        if (wo.z < 0.f) {
            if (!innerModel_->sample(flip(wo), uLobe, u, ctx, out)) return false;
            out.wi = flip(out.wi);
            return true;
        }
        return innerModel_->sample(wo, uLobe, u, ctx, out);
    }

    uint32_t flags() const override { return innerModel_->flags(); }
    bool deltaUnder(const BsdfContext& ctx) const override { return innerModel_->deltaUnder(ctx); }
    float valueBound(const BsdfContext& ctx) const override { return innerModel_->valueBound(ctx); }
    // (tan^2 of each direction is the same mirrored)
    PairGeometry pairGeometry(const Vec3& wo, const Vec3& wi) const override {
        return wo.z < 0.f ? innerModel_->pairGeometry(flip(wo), flip(wi)) : innerModel_->pairGeometry(wo, wi);
    }
    float requestRatio(const PairGeometry& g, const BsdfContext& ctx) const override {
        return innerModel_->requestRatio(g, ctx);
    }
    float requestPdfRatio(const PairGeometry& g, const RegularizationRequest& r) const override {
        return innerModel_->requestPdfRatio(g, r);
    }
    // (the pairs are the inner model's, mirrored: the same bound)
    float requestRatioBound(const RegularizationRequest& r) const override { return innerModel_->requestRatioBound(r); }
    float roughness() const override { return innerModel_->roughness(); }
    Roughness alpha() const override { return innerModel_->alpha(); }
    bool anisotropic() const override { return innerModel_->anisotropic(); }
    std::string name() const override { return "twosided(" + innerModel_->name() + ")"; }

private:
    static Vec3 flip(const Vec3& w) { return {w.x, w.y, -w.z}; }
    BxdfPtr inner_;               // the material's inner model (null in an instance)
    const Bxdf* innerModel_;      // the model evaluated: inner_, or its instance in innerStorage_
    alignas(BxdfInstance) unsigned char innerStorage_[kInnerInstanceBytes];
};

}  // namespace

BxdfPtr makeDiffuse(const Color& reflectance) { return std::make_shared<DiffuseBxdf>(reflectance); }

BxdfPtr makeTwoSided(BxdfPtr inner) {
    if (dynamic_cast<const TwoSidedBxdf*>(inner.get())) return inner;  // mirrored twice is mirrored once
    return std::make_shared<TwoSidedBxdf>(std::move(inner));
}

BxdfPtr makeTexturedDiffuse(TexturePtr reflectance) { return std::make_shared<TexturedDiffuseBxdf>(std::move(reflectance)); }

}  // namespace lt
