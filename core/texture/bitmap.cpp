// Mitsuba 3's bitmap texture (src/textures/bitmap.cpp, whose look-ups are Dr.Jit's
// dr::Texture::eval: include/drjit/texture_impl.h, tex_eval and tex_wrap).
#include <cmath>
#include <cstdint>
#include <utility>
#include "core/texture/texture_factory.h"

namespace lt {

namespace {

// Texel indices stay far from int64 overflow (and float coordinates this large have no fraction).
constexpr float kMaxCoord = 1e9f;

// uv' with a non-finite or huge component made harmless (a texture never returns NaN).
inline float sanitise(float x) {
    if (!std::isfinite(x)) return 0.f;
    return std::fmin(std::fmax(x, -kMaxCoord), kMaxCoord);
}

// Dr.Jit's tex_wrap on one integer texel index, n the resolution along that axis.
inline int64_t wrapIndex(int64_t i, int64_t n, TextureWrap wrap) {
    switch (wrap) {
        case TextureWrap::Clamp:
            return i < 0 ? 0 : (i >= n ? n - 1 : i);
        case TextureWrap::Repeat: {
            int64_t m = i % n;
            return m < 0 ? m + n : m;
        }
        case TextureWrap::Mirror: {
            // Period 2n: the image, then the image reflected (edge texels repeated).
            int64_t m = i % (2 * n);
            if (m < 0) m += 2 * n;
            return m < n ? m : 2 * n - 1 - m;
        }
    }
    return 0;
}

class BitmapTexture final : public Texture {
public:
    BitmapTexture(Image img, TextureFilter filter, TextureWrap wrap, const glm::mat3& toUv, std::string name)
        : img_(std::move(img)), filter_(filter), wrap_(wrap), toUv_(toUv), name_(std::move(name)),
          res_(float(img_.width), float(img_.height)) {
        if (img_.width <= 0 || img_.height <= 0 || img_.pixels.size() != size_t(img_.width) * size_t(img_.height))
            throw ImageError(name_ + ": empty or inconsistent image (" + std::to_string(img_.width) + "x" +
                             std::to_string(img_.height) + ")");
        // Mitsuba pads images under 2x2 texels to 2x2 by repeating the last row / column; every
        // look-up gives the same value either way, so the image is kept as it is.
        double sum[3] = {0.0, 0.0, 0.0};
        max_ = min_ = img_.pixels[0];
        for (size_t i = 0; i < img_.pixels.size(); ++i) {
            const Color& c = img_.pixels[i];
            if (!isFinite(c))
                throw ImageError(name_ + ": texel (" + std::to_string(i % size_t(img_.width)) + ", " +
                                 std::to_string(i / size_t(img_.width)) + ") is NaN or infinite");
            max_ = glm::max(max_, c);
            min_ = glm::min(min_, c);
            for (int k = 0; k < 3; ++k) sum[k] += c[k];
        }
        const double n = double(img_.pixels.size());
        mean_ = Color(float(sum[0] / n), float(sum[1] / n), float(sum[2] / n));
    }

    Color eval(const Vec2& uv) const override {
        // to_uv: Mitsuba's affine transform of the point (u, v, 1).
        const Vec3 t = toUv_ * Vec3(uv.x, uv.y, 1.f);
        const float u = sanitise(t.x), v = sanitise(t.y);
        if (filter_ == TextureFilter::Nearest) {
            const int64_t x = wrapIndex(int64_t(std::floor(u * res_.x)), img_.width, wrap_);
            const int64_t y = wrapIndex(int64_t(std::floor(v * res_.y)), img_.height, wrap_);
            return texel(x, y);
        }
        // Bilinear: texel centres at (i + 0.5) / n, hence the half-texel shift.
        const float px = u * res_.x - 0.5f, py = v * res_.y - 0.5f;
        const float fx = std::floor(px), fy = std::floor(py);
        const float wx = px - fx, wy = py - fy;
        const int64_t ix = int64_t(fx), iy = int64_t(fy);
        const int64_t x0 = wrapIndex(ix, img_.width, wrap_), x1 = wrapIndex(ix + 1, img_.width, wrap_);
        const int64_t y0 = wrapIndex(iy, img_.height, wrap_), y1 = wrapIndex(iy + 1, img_.height, wrap_);
        const Color top = (1.f - wx) * texel(x0, y0) + wx * texel(x1, y0);
        const Color bottom = (1.f - wx) * texel(x0, y1) + wx * texel(x1, y1);
        return (1.f - wy) * top + wy * bottom;
    }

    // Mitsuba's eval_1_grad: the analytic derivative of the bilinear interpolation of the texels'
    // luminance, d/dpx = (1 - wy)(f10 - f00) + wy (f11 - f01) (and alike for py), times the
    // resolution (p = uv' res - 0.5), then through to_uv's linear part (transposed). Nearest: 0.
    Vec2 evalGrad1(const Vec2& uv) const override {
        if (filter_ == TextureFilter::Nearest) return Vec2(0.f);
        const Vec3 t = toUv_ * Vec3(uv.x, uv.y, 1.f);
        const float px = sanitise(t.x) * res_.x - 0.5f, py = sanitise(t.y) * res_.y - 0.5f;
        const float fx = std::floor(px), fy = std::floor(py);
        const float wx = px - fx, wy = py - fy;
        const int64_t ix = int64_t(fx), iy = int64_t(fy);
        const int64_t x0 = wrapIndex(ix, img_.width, wrap_), x1 = wrapIndex(ix + 1, img_.width, wrap_);
        const int64_t y0 = wrapIndex(iy, img_.height, wrap_), y1 = wrapIndex(iy + 1, img_.height, wrap_);
        // (Mitsuba's luminance weights)
        auto lum = [](const Color& c) { return 0.212671f * c.x + 0.715160f * c.y + 0.072169f * c.z; };
        const float f00 = lum(texel(x0, y0)), f10 = lum(texel(x1, y0)), f01 = lum(texel(x0, y1)),
                    f11 = lum(texel(x1, y1));
        const float dx = ((1.f - wy) * (f10 - f00) + wy * (f11 - f01)) * res_.x;
        const float dy = ((1.f - wx) * (f01 - f00) + wx * (f11 - f10)) * res_.y;
        // d/du = a00 dx + a10 dy, d/dv = a01 dx + a11 dy (a_rc the 2x2 linear part, glm column-major).
        return Vec2(toUv_[0][0] * dx + toUv_[0][1] * dy, toUv_[1][0] * dx + toUv_[1][1] * dy);
    }

    Color maxValue() const override { return max_; }
    Color minValue() const override { return min_; }
    Color meanValue() const override { return mean_; }
    glm::ivec2 resolution() const override { return glm::ivec2(img_.width, img_.height); }
    std::string name() const override { return name_; }

private:
    // Row y = 0 is the image's top row: Mitsuba's tensor is the bitmap's rows in file order
    // (top first), indexed [floor(v * height)][floor(u * width)].
    const Color& texel(int64_t x, int64_t y) const { return img_.pixels[size_t(y) * size_t(img_.width) + size_t(x)]; }

    Image img_;
    TextureFilter filter_;
    TextureWrap wrap_;
    glm::mat3 toUv_;
    std::string name_;
    Vec2 res_;
    Color max_{0.f}, mean_{0.f}, min_{0.f};
};

}  // namespace

TexturePtr makeBitmap(Image linearRgb, TextureFilter filter, TextureWrap wrap, const glm::mat3& toUv,
                      std::string name) {
    return std::make_shared<const BitmapTexture>(std::move(linearRgb), filter, wrap, toUv, std::move(name));
}

}  // namespace lt
