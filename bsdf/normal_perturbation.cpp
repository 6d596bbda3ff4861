// Mitsuba 3's normalmap and bumpmap adapters: the perturbed frames (normal_perturbation.h).
#include "bsdf/normal_perturbation.h"

#include <cmath>
#include <stdexcept>
#include "core/texture/texture.h"

namespace lt {

NormalPerturbation::NormalPerturbation(BxdfPtr nested, bool flipInvalid, bool shadowing)
    : nested_(std::move(nested)), flipInvalid_(flipInvalid) {
    if (!nested_) throw std::invalid_argument("normal perturbation without a nested BSDF");
    if (dynamic_cast<const NormalPerturbation*>(nested_.get()))
        throw std::invalid_argument("a normalmap or bumpmap cannot nest another one");
    lambert_ = nested_->lambert();
    textured_ = true;  // (atUv: the nested model)
    shadowTerminator_ = shadowing;
    continuation_ = nested_->continuation();
    cacheBounds();
}

Frame NormalPerturbation::frame(const TangentSpace& ts) const {
    const Frame& sh = ts.shading;
    Vec3 m = localNormal(ts);
    if (flipInvalid_) {
        // Mitsuba: flip where cos_theta(wi) * dot(wi, m) <= 0, wi the arrival direction in sh.
        const Vec3 wl = sh.toLocal(ts.wo);
        if (wl.z * glm::dot(wl, m) <= 0.f) m = Vec3(-m.x, -m.y, m.z);
    }
    const float len2 = glm::dot(m, m);
    if (!(len2 > 0.f) || !std::isfinite(len2)) return sh;
    const Vec3 n = m / std::sqrt(len2);
    // s' = e_x projected onto the plane of n': the tangent follows sh.s (Mitsuba's frame_wrt_si).
    Vec3 s(1.f - n.x * n.x, -n.x * n.y, -n.x * n.z);
    const float sl2 = glm::dot(s, s);
    if (!(sl2 > 1e-20f)) return Frame(sh.toWorld(n));  // n' along the tangent: any frame around it
    s /= std::sqrt(sl2);
    const Vec3 nw = glm::normalize(sh.toWorld(n)), sw = glm::normalize(sh.toWorld(s));
    return Frame(sw, glm::cross(nw, sw), nw);
}

namespace {

class NormalMapBxdf final : public NormalPerturbation {
public:
    NormalMapBxdf(TexturePtr map, BxdfPtr nested, bool flip, bool shadowing)
        : NormalPerturbation(std::move(nested), flip, shadowing), map_(std::move(map)) {
        if (!map_) throw std::invalid_argument("normalmap without its texture");
    }
    Vec3 localNormal(const TangentSpace& ts) const override { return 2.f * map_->eval(ts.uv) - Vec3(1.f); }
    std::string name() const override { return "normalmap(" + nested()->name() + ")"; }

private:
    TexturePtr map_;
};

class BumpMapBxdf final : public NormalPerturbation {
public:
    BumpMapBxdf(TexturePtr height, float scale, BxdfPtr nested, bool flip, bool shadowing)
        : NormalPerturbation(std::move(nested), flip, shadowing), height_(std::move(height)), scale_(scale) {
        if (!height_) throw std::invalid_argument("bumpmap without its texture");
    }
    Vec3 localNormal(const TangentSpace& ts) const override {
        const Vec2 g = scale_ * height_->evalGrad1(ts.uv);
        const Vec3& n = ts.shading.n;
        // Mitsuba: the displaced surface's tangents, ignoring the derivative of n itself.
        const Vec3 du = ts.dpdu + n * (g.x - glm::dot(n, ts.dpdu));
        const Vec3 dv = ts.dpdv + n * (g.y - glm::dot(n, ts.dpdv));
        Vec3 nb = glm::cross(du, dv);
        const float len2 = glm::dot(nb, nb);
        if (!(len2 > 0.f) || !std::isfinite(len2)) return Vec3(0.f, 0.f, 1.f);
        nb /= std::sqrt(len2);
        if (glm::dot(ts.ng, nb) < 0.f) nb = -nb;  // on the geometric normal's side
        return ts.shading.toLocal(nb);
    }
    std::string name() const override { return "bumpmap(" + nested()->name() + ")"; }

private:
    TexturePtr height_;
    float scale_;
};

}  // namespace

BxdfPtr makeNormalMap(std::shared_ptr<const Texture> normalmap, BxdfPtr nested, bool flipInvalid, bool shadowing) {
    return std::make_shared<NormalMapBxdf>(std::move(normalmap), std::move(nested), flipInvalid, shadowing);
}

BxdfPtr makeBumpMap(std::shared_ptr<const Texture> height, float scale, BxdfPtr nested, bool flipInvalid,
                    bool shadowing) {
    if (!std::isfinite(scale)) throw std::invalid_argument("bumpmap: scale must be finite");
    return std::make_shared<BumpMapBxdf>(std::move(height), scale, std::move(nested), flipInvalid, shadowing);
}

}  // namespace lt
