// Mitsuba 3's checkerboard texture (src/textures/checkerboard.cpp, its eval: the RGB result).
#include <cmath>
#include <stdexcept>
#include "core/texture/texture_factory.h"

namespace lt {

namespace {

class CheckerboardTexture final : public Texture {
public:
    CheckerboardTexture(const Color& c0, const Color& c1, const glm::mat3& toUv) : c0_(c0), c1_(c1), toUv_(toUv) {}

    Color eval(const Vec2& uv) const override {
        const Vec3 t = toUv_ * Vec3(uv.x, uv.y, 1.f);
        // Mitsuba: mask = uv - floor(uv) > 0.5 per axis; color0 where the two agree. (Its scalar
        // eval_1 swaps the colours; the colour look-up, eval, is the one followed here.) A NaN
        // gives false in both comparisons: color0.
        const bool hu = t.x - std::floor(t.x) > 0.5f;
        const bool hv = t.y - std::floor(t.y) > 0.5f;
        return hu == hv ? c0_ : c1_;
    }

    // Mitsuba's eval_1 (a scalar parameter such as a roughconductor's alpha) has color0 where the
    // two masks differ, the colours of eval swapped; its render tests' references follow it
    // (test_textured_roughconductor passes with it and fails without).
    float evalScalar(const Vec2& uv) const override {
        const Vec3 t = toUv_ * Vec3(uv.x, uv.y, 1.f);
        const bool hu = t.x - std::floor(t.x) > 0.5f;
        const bool hv = t.y - std::floor(t.y) > 0.5f;
        return scalarOf(hu == hv ? c1_ : c0_);
    }
    Color maxValue() const override { return glm::max(c0_, c1_); }
    Color minValue() const override { return glm::min(c0_, c1_); }
    // Each colour covers half of every period.
    Color meanValue() const override { return 0.5f * (c0_ + c1_); }
    std::string name() const override { return "checkerboard"; }

private:
    Color c0_, c1_;
    glm::mat3 toUv_;
};

}  // namespace

TexturePtr makeCheckerboard(const Color& color0, const Color& color1, const glm::mat3& toUv) {
    if (!isFinite(color0) || !isFinite(color1))
        throw std::invalid_argument("checkerboard: color0 and color1 must be finite");
    return std::make_shared<const CheckerboardTexture>(color0, color1, toUv);
}

}  // namespace lt
