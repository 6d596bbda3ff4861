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
    virtual std::string name() const = 0;
};

using TexturePtr = std::shared_ptr<const Texture>;

}  // namespace lt
