// Textures: a colour as a function of a surface point's uv (Mitsuba 3's texture plugins; their
// documentation is the spec of parameters and conventions). A texture is immutable after
// construction and shared by every material that uses it.
#pragma once
#include <memory>
#include <string>
#include "core/math.h"

namespace lt {

class Texture {
public:
    virtual ~Texture() = default;
    // The value at uv (the surface's texture coordinates, before the texture's own to_uv).
    virtual Color eval(const Vec2& uv) const = 0;
    // Per channel, the largest value eval can return (bounds, Russian roulette) and the mean
    // over the texture's domain (a representative value where one scalar must stand for it).
    virtual Color maxValue() const = 0;
    virtual Color meanValue() const = 0;
    // Per channel, the smallest value eval can return (a bound that holds everywhere from below:
    // a textured roughness's smoothest point). 0, the bound of any non-negative texture, unless a
    // texture knows better.
    virtual Color minValue() const { return Color(0.f); }
    // The value at uv of a scalar parameter (an alpha): Mitsuba's eval_1, the grey value or
    // luminance of eval's colour (scalarOf, below) unless a texture's own differs. Bounded by
    // scalarOf of minValue and maxValue.
    virtual float evalScalar(const Vec2& uv) const;
    virtual std::string name() const = 0;
    // The gradient (d/du, d/dv) of the value's luminance (Mitsuba's eval_1_grad: a bump map's
    // height), in the surface's uv (to_uv included). 0 where the texture is piecewise constant.
    virtual Vec2 evalGrad1(const Vec2& /*uv*/) const { return Vec2(0.f); }
    // Mitsuba's Texture::resolution(): a bitmap's size in texels (width, height), (1, 1) for the
    // others (a projector's aspect and sampling grid read it).
    virtual glm::ivec2 resolution() const { return glm::ivec2(1); }
};

using TexturePtr = std::shared_ptr<const Texture>;

// A scalar parameter's value from a colour texture's (Mitsuba's eval_1: a grey value as it is,
// a colour's luminance). Monotone in every channel, so scalarOf(minValue()) and
// scalarOf(maxValue()) bound it over the texture.
inline float scalarOf(const Color& c) { return c.x == c.y && c.y == c.z ? c.x : luminance(c); }
inline float Texture::evalScalar(const Vec2& uv) const { return scalarOf(eval(uv)); }

}  // namespace lt
