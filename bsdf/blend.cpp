// Mitsuba 3's blendbsdf (its plugin docs are the spec): the linear combination
//   f = (1 - w) f_first + w f_second,   w = weight in [0, 1] (a texture's value clamped to it),
// so weight 0 is the first nested BSDF and 1 the second, as Mitsuba's. Densities are the same
// mixture of the components' densities; sampling chooses the second component with probability
// w (Mitsuba's choice, uLobe rescaled for the component). A non-delta sample then carries the
// mixture's value over the mixture's density (both components evaluated: one consistent density
// for MIS, where Mitsuba returns the component's own weight). A delta sample of a component keeps
// its weight, f / P(lobe) = (w_c f_c) / (w_c P_c(lobe)), and its discrete probability times w_c in
// both directions (the generalised densities of integrators/transport/path.h): the component's
// choice is part of the sampled lobe, and the walk in the other direction makes it with the same
// probability.
// A mixture of delta and non-delta lobes is a connection end where it has a non-delta lobe (as
// plastic; PathVertex::connectible): connections evaluate the non-delta part.
// At weight 0 or 1 the blend is its component: every call is the component's, bit for bit.
// Regularisation: every request goes to the components, which resolve it on their own lobes.
#include "bsdf/bsdf.h"
#include "core/texture/texture.h"

#include <algorithm>
#include <stdexcept>

namespace lt {

namespace {

constexpr float kOneMinusEps = 0x1.fffffep-1f;

// The mixture of two models with weight w (of the second), shared by the material and its
// textured instances.
struct Mix {
    const Bxdf* a;  // first: weight 1 - w
    const Bxdf* b;  // second: weight w
    float w;

    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const {
        if (!(w > 0.f)) return a->eval(wo, wi, ctx);
        if (!(w < 1.f)) return b->eval(wo, wi, ctx);
        const BsdfEval ea = a->eval(wo, wi, ctx), eb = b->eval(wo, wi, ctx);
        BsdfEval e;
        e.f = ea.f * (1.f - w) + eb.f * w;
        if (ctx.valueOnly) return e;
        e.pdfFwd = SolidAnglePdf(ea.pdfFwd.value * (1.f - w) + eb.pdfFwd.value * w);
        e.pdfRev = SolidAnglePdf(ea.pdfRev.value * (1.f - w) + eb.pdfRev.value * w);
        return e;
    }

    bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const {
        if (!(w > 0.f)) return a->sample(wo, uLobe, u, ctx, out);
        if (!(w < 1.f)) return b->sample(wo, uLobe, u, ctx, out);
        const bool second = uLobe < w;
        const float wc = second ? w : 1.f - w;
        const float uc = std::min(second ? uLobe / w : (uLobe - w) / (1.f - w), kOneMinusEps);
        // (the full sample also for a direction-only call: whether it succeeds depends on the
        // mixture's density below)
        BsdfContext full = ctx;
        full.directionOnly = false;
        full.valueOnly = false;
        if (!(second ? b : a)->sample(wo, uc, u, full, out)) return false;
        if (out.lobe & kDelta) {
            out.pdfFwd = SolidAnglePdf(out.pdfFwd.value * wc);
            out.pdfRev = SolidAnglePdf(out.pdfRev.value * wc);
            return true;
        }
        const BsdfEval e = eval(wo, out.wi, full);
        if (!(e.pdfFwd.value > 0.f) || !std::isfinite(e.pdfFwd.value)) return false;
        out.weight = e.f * (std::abs(out.wi.z) / e.pdfFwd.value);
        out.pdfFwd = e.pdfFwd;
        out.pdfRev = e.pdfRev;
        return true;
    }
};

// The model at one point of a blend whose weight or components are textured (Bxdf::atUv).
class BlendAt final : public Bxdf {
public:
    BlendAt(const Bxdf& material, const Mix& m) : material_(material), m_(m) { continuation_ = material.continuation(); }
    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override { return m_.eval(wo, wi, ctx); }
    bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const override {
        return m_.sample(wo, uLobe, u, ctx, out);
    }
    uint32_t flags() const override { return material_.flags(); }
    float valueBound(const BsdfContext& ctx) const override { return material_.valueBound(ctx); }
    float roughness() const override { return material_.roughness(); }
    Roughness alpha() const override { return material_.alpha(); }
    std::string name() const override { return material_.name(); }

private:
    const Bxdf& material_;
    Mix m_;
};

class BlendBxdf final : public Bxdf {
public:
    BlendBxdf(BxdfPtr first, BxdfPtr second, float weight, TexturePtr weightTex)
        : first_(std::move(first)), second_(std::move(second)), weightTex_(std::move(weightTex)) {
        w_ = weightTex_ ? weightAt(weightTex_->meanValue()) : std::clamp(weight, 0.f, 1.f);
        // (a constant 0 or 1 is the component: its flags, bounds, roughness and calls, bit for bit)
        only_ = weightTex_ ? nullptr : !(w_ > 0.f) ? first_.get() : !(w_ < 1.f) ? second_.get() : nullptr;
        textured_ = only_ ? only_->textured() : (weightTex_ || first_->textured() || second_->textured());
        if (only_) {
            lambert_ = only_->lambert();
            continuation_ = only_->continuation();
        } else {
            continuation_ = std::max(first_->continuation(), second_->continuation());
        }
        if (textured_ && !only_) checkInstanceFits();
        cacheBounds();
    }

    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override {
        return mix().eval(wo, wi, ctx);
    }
    bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const override {
        return mix().sample(wo, uLobe, u, ctx, out);
    }
    const Bxdf* atUv(const Vec2& uv, void* storage, size_t capacity) const override {
        if (!textured_) return this;
        if (only_) return only_->atUv(uv, storage, capacity);
        // The instance at the start of the storage, the components' own instances after it (the
        // rest split between the textured ones).
        constexpr size_t kHead = (sizeof(BlendAt) + alignof(BxdfInstance) - 1) / alignof(BxdfInstance) * alignof(BxdfInstance);
        if (capacity < kHead) throw std::logic_error("Bxdf::atUv: instance storage too small");
        unsigned char* rest = static_cast<unsigned char*>(storage) + kHead;
        const size_t restCap = capacity - kHead;
        const bool both = first_->textured() && second_->textured();
        const size_t share = both ? restCap / 2 / alignof(BxdfInstance) * alignof(BxdfInstance) : restCap;
        Mix m{first_.get(), second_.get(), w_};
        if (first_->textured()) m.a = first_->atUv(uv, rest, share);
        if (second_->textured()) m.b = second_->atUv(uv, both ? rest + share : rest, share);
        if (weightTex_) m.w = weightAt(weightTex_->eval(uv));
        return emplaceInstance<BlendAt>(storage, capacity, *this, m);
    }

    uint32_t flags() const override { return only_ ? only_->flags() : first_->flags() | second_->flags(); }
    bool deltaUnder(const BsdfContext& ctx) const override {
        return only_ ? only_->deltaUnder(ctx) : first_->deltaUnder(ctx) && second_->deltaUnder(ctx);
    }
    // A constant weight: the weighted sum of the components' bounds; a texture: the larger one
    // (every weight in [0, 1] mixes them to at most that).
    float valueBound(const BsdfContext& ctx) const override {
        if (only_) return only_->valueBound(ctx);
        const float a = first_->valueBound(ctx), b = second_->valueBound(ctx);
        if (weightTex_) return std::max(a, b);
        if (!(a < kInf) || !(b < kInf)) return kInf;
        return a * (1.f - w_) + b * w_;
    }
    PairGeometry pairGeometry(const Vec3& wo, const Vec3& wi) const override {
        return only_ ? only_->pairGeometry(wo, wi) : PairGeometry{};
    }
    float requestRatio(const PairGeometry& g, const BsdfContext& ctx) const override {
        return only_ ? only_->requestRatio(g, ctx) : 1.f;
    }
    float requestPdfRatio(const PairGeometry& g, const RegularizationRequest& r) const override {
        return only_ ? only_->requestPdfRatio(g, r) : 1.f;
    }
    float requestRatioBound(const RegularizationRequest& r) const override {
        return only_ ? only_->requestRatioBound(r) : kInf;
    }
    // The smoother component's (the lobe a request changes first, as plastic's coating).
    float roughness() const override { return smoother().roughness(); }
    Roughness alpha() const override { return smoother().alpha(); }
    bool anisotropic() const override { return first_->anisotropic() || second_->anisotropic(); }
    std::string name() const override {
        if (only_) return only_->name();
        return "blendbsdf(" + first_->name() + ", " + second_->name() + ")";
    }

private:
    // Mitsuba's eval_1 of the weight texture (the luminance of an RGB value), clamped to [0, 1].
    static float weightAt(const Color& c) { return std::clamp(luminance(c), 0.f, 1.f); }
    Mix mix() const { return Mix{first_.get(), second_.get(), w_}; }
    const Bxdf& smoother() const {
        if (only_) return *only_;
        return first_->roughness() <= second_->roughness() ? *first_ : *second_;
    }
    // A textured blend's instance must fit in the storage a two-sided adapter gives its inner model
    // (kInnerInstanceBytes), or at least in a surface point's (kInstanceBytes).
    void checkInstanceFits() const {
        BxdfInstance buf;
        try {
            atUv(Vec2(0.5f), buf.bytes, kInnerInstanceBytes);
        } catch (const std::logic_error&) {
            try {
                atUv(Vec2(0.5f), buf.bytes, sizeof(buf.bytes));
            } catch (const std::logic_error&) {
                throw std::invalid_argument("blendbsdf: its textured nested BSDFs are too large to combine at a point");
            }
        }
    }

    BxdfPtr first_, second_;
    TexturePtr weightTex_;
    float w_ = 0.5f;               // the constant weight, or the texture's mean (for a caller without a point)
    const Bxdf* only_ = nullptr;   // the component a constant weight of 0 or 1 selects
};

}  // namespace

BxdfPtr makeBlend(BxdfPtr first, BxdfPtr second, float weight, TexturePtr weightTexture) {
    if (!first || !second) throw std::invalid_argument("blendbsdf: two nested BSDFs are required");
    if (!weightTexture && !(weight >= 0.f && weight <= 1.f))
        throw std::invalid_argument("blendbsdf: weight must be in [0, 1]");
    return std::make_shared<BlendBxdf>(std::move(first), std::move(second), weight, std::move(weightTexture));
}

}  // namespace lt
