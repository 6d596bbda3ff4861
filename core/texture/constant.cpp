// A texture with one value everywhere: Mitsuba 3's `rawconstant` (src/spectra/rawconstant.cpp, a
// float or a 3D vector returned as is, no colour conversion), as a normal map's identity (0.5, 0.5, 1).
#include <stdexcept>
#include "core/texture/texture_factory.h"

namespace lt {

namespace {

class ConstantTexture final : public Texture {
public:
    explicit ConstantTexture(const Color& c) : c_(c) {}
    Color eval(const Vec2&) const override { return c_; }
    Color maxValue() const override { return c_; }
    Color meanValue() const override { return c_; }
    Color minValue() const override { return c_; }
    std::string name() const override { return "rawconstant"; }

private:
    Color c_;
};

}  // namespace

TexturePtr makeConstantTexture(const Color& value) {
    if (!isFinite(value)) throw std::invalid_argument("rawconstant: the value must be finite");
    return std::make_shared<const ConstantTexture>(value);
}

}  // namespace lt
