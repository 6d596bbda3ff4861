// The frame the textured conductor and dielectric share (conductor.cpp, dielectric.cpp): a
// material whose alphas (and other values) may be textures is sampled and evaluated through the
// untextured Model of its mean values (Bxdf::atUv gives a point's own model), its flags are the
// union over the alphas' range, and where the alphas vary it offers no pair geometry and no
// requestRatioBound (the integrators ask the material's requestRatio, which knows no point's
// alpha: they evaluate instead). The subclass builds mean_, roughPart_ (the rough lobe at the
// smallest alpha anywhere) and smooth_ (where some point is smooth) from range(), and gives its own
// bounds and deltaUnder.
#pragma once
#include <algorithm>
#include <memory>
#include <string>
#include "bsdf/bsdf.h"
#include "core/texture/texture.h"

namespace lt {

template <class Model>
class TexturedMicrofacetBxdf : public Bxdf {
public:
    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override { return mean_->eval(wo, wi, ctx); }
    bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const override {
        return mean_->sample(wo, uLobe, u, ctx, out);
    }
    uint32_t flags() const override { return flags_; }
    PairGeometry pairGeometry(const Vec3& wo, const Vec3& wi) const override {
        return alphaTextured_ ? PairGeometry{} : mean_->pairGeometry(wo, wi);
    }
    float requestRatio(const PairGeometry& g, const BsdfContext& ctx) const override { return mean_->requestRatio(g, ctx); }
    float requestPdfRatio(const PairGeometry& g, const RegularizationRequest& r) const override {
        return mean_->requestPdfRatio(g, r);
    }
    float requestRatioBound(const RegularizationRequest& r) const override {
        return alphaTextured_ ? kInf : mean_->requestRatioBound(r);
    }
    float roughness() const override { return mean_->roughness(); }
    Roughness alpha() const override { return mean_->alpha(); }
    bool anisotropic() const override {
        return (rough_ && alphaUTex_ != alphaVTex_) || (!alphaUTex_ && !alphaVTex_ && mean_->anisotropic());
    }
    std::string name() const override { return mean_->name() + "(textured)"; }

protected:
    // The alphas' statistics over the textures (constants where untextured; a texture's scalar is
    // its grey value or luminance) and what they imply.
    struct AlphaRange {
        float meanU, meanV, minU, minV, maxU, maxV;
        bool anyRough, anySmooth, meanRough;  // (makeRough*'s test: rough where either alpha reaches kMinAlpha)
        float minAlpha;                        // the smallest alpha anywhere (>= 0)
    };
    TexturedMicrofacetBxdf(bool rough, MicrofacetType dist, MaskingModel masking, float au, float av,
                           const TexturePtr& alphaU, const TexturePtr& alphaV)
        : rough_(rough), dist_(dist), masking_(masking), au_(au), av_(av), alphaUTex_(alphaU), alphaVTex_(alphaV),
          alphaTextured_(rough && (alphaU || alphaV)) {
        auto scalar = [](const TexturePtr& x, float c, Color (Texture::*f)() const) {
            return x ? scalarOf(((*x).*f)()) : c;
        };
        AlphaRange& r = range_;
        r.meanU = scalar(alphaU, au, &Texture::meanValue), r.meanV = scalar(alphaV, av, &Texture::meanValue);
        r.minU = scalar(alphaU, au, &Texture::minValue), r.minV = scalar(alphaV, av, &Texture::minValue);
        r.maxU = scalar(alphaU, au, &Texture::maxValue), r.maxV = scalar(alphaV, av, &Texture::maxValue);
        r.anyRough = rough && std::max(r.maxU, r.maxV) >= kMinAlpha;
        r.anySmooth = !rough || !(std::max(r.minU, r.minV) >= kMinAlpha);
        r.meanRough = rough && std::max(r.meanU, r.meanV) >= kMinAlpha;
        r.minAlpha = std::max(0.f, std::min(r.minU, r.minV));
        textured_ = true;
    }
    const AlphaRange& range() const { return range_; }
    // A point's alphas, and whether it is rough.
    void alphasAt(const Vec2& uv, float& au, float& av, bool& rough) const {
        au = alphaUTex_ ? alphaUTex_->evalScalar(uv) : au_;
        av = alphaVTex_ ? (alphaVTex_ == alphaUTex_ ? au : alphaVTex_->evalScalar(uv)) : av_;
        rough = rough_ && std::max(au, av) >= kMinAlpha;
    }

    bool rough_;
    MicrofacetType dist_;
    MaskingModel masking_;
    float au_, av_;
    TexturePtr alphaUTex_, alphaVTex_;
    bool alphaTextured_;
    uint32_t flags_ = 0;
    std::unique_ptr<Model> mean_, roughPart_, smooth_;

private:
    AlphaRange range_;
};

}  // namespace lt
