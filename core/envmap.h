// Mitsuba 3's `envmap` emitter (src/emitters/envmap.cpp, v3.9): an RGB lat-long image at
// infinity, its radiance times `scale`, rotated by `to_world`, and the density with which the
// lights sample its directions.
//
// Mapping (Mitsuba's direction_to_uv / uv_to_direction, in the map's own frame, w = to_world^-1 of
// the world direction towards the sky): u = atan2(w.x, -w.z) / 2 pi wrapped to [0, 1),
// v = acos(w.y) / pi; back, w = (sin phi sin theta, cos theta, -cos phi sin theta) with
// phi = 2 pi u, theta = pi v. So +Y is the top row, u = 0 looks along -Z, u = 1/4 along +X.
// Radiance: bilinear between texels; column x (of W) is centred at u = (x + 1/2) / W and wraps
// around, row y (of H) lies at v = y / (H - 1) exactly (row 0 the +Y pole, row H-1 the -Y pole).
// (Mitsuba up to 3.8 centred column x at u = x / W: half a texel further along -phi.) Maps smaller
// than 2 x 3 are padded to it by repeating the last column and row, as Mitsuba's Bitmap::pad_to.
//
// Sampling (ours; Mitsuba warps a piecewise-bilinear density over the texel grid): the cells
// between four neighbouring texels, W columns by H - 1 rows, each chosen with probability
// proportional to the integral over the cell of the radiance's luminance times sin(theta) (the
// bilinear luminance times sin theta integrated exactly: a cell is chosen wherever the radiance
// is not 0 in it, so light paths reach every lit direction), and inside the cell a direction
// uniform in solid angle (phi uniform, cos theta uniform). The solid-angle density is constant
// per cell: p(w) = P(cell) / Omega(cell), Omega(cell) = (2 pi / W)(cos theta_y - cos theta_{y+1}),
// bounded (no 1 / sin theta at the poles). Mitsuba's mis_compensation is not applied (the loader
// warns): the emission and next-event densities must be the same function (core/lights.h).
#pragma once
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>
#include "core/image.h"
#include "core/math.h"
#include "core/sampling.h"

namespace lt {

struct EnvmapError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// Is m's linear part orthonormal (a rotation, possibly with a reflection) to within tol per
// entry of m^T m - I? The envmap's to_world must be: Mitsuba applies it to unit directions.
bool isOrthonormal(const Mat4& m, float tol = 1e-4f);

class EnvironmentMap {
public:
    // From linear RGB texels (row 0 at the top). Throws EnvmapError, naming `name`, for a texel
    // that is NaN, infinite or negative, an empty image, or a to_world that is not orthonormal.
    // The translation of toWorld is ignored (directions only); scale must be finite and >= 0.
    EnvironmentMap(const Image& img, const Mat4& toWorld, float scale, const std::string& name);

    int width() const { return w_; }    // after padding
    int height() const { return h_; }
    float scale() const { return scale_; }
    const std::string& name() const { return name_; }

    // Radiance arriving from the world direction `toSky` (unit, from the scene towards the sky).
    Color eval(const Vec3& toSky) const;
    // The same at map coordinates (u, v) in [0, 1]^2 (u wraps).
    Color evalUv(float u, float v) const;
    // Map coordinates of a world direction and back (Mitsuba's direction_to_uv, uv_to_direction).
    Vec2 directionToUv(const Vec3& toSky) const;
    Vec3 uvToDirection(const Vec2& uv) const;

    struct Sample {
        Vec3 toSky{0.f, 1.f, 0.f};  // world direction towards the sky
        float pdf = 0.f;            // solid angle; 0: nothing sampled (a black map)
        Color value{0.f};           // eval(toSky)
    };
    Sample sample(const Vec2& u) const;
    float pdf(const Vec3& toSky) const;  // solid angle

    // Integral over the sphere of the radiance's luminance (with scale): the light's power is
    // pi r^2 times it for a disk of radius r.
    float luminanceIntegral() const { return float(integral_ * double(scale_)); }
    // The largest luminance over the integral (1 / (4 pi) for a constant map): the maximum of the
    // emission's normalised directional profile (JG19's rho_bar of the light).
    float directionalBound() const { return integral_ > 0.0 ? float(double(maxLum_) / integral_) : 0.f; }

private:
    int cellOf(const Vec3& local, int& row) const;  // column of the cell holding a local direction
    const Color& texel(int x, int y) const { return texels_[size_t(y) * w_ + x]; }

    std::string name_;
    int w_ = 0, h_ = 0;
    std::vector<Color> texels_;
    float scale_ = 1.f;
    glm::mat3 toWorld_{1.f}, toLocal_{1.f};
    std::vector<float> cosRow_;     // cos(theta) of each texel row: cos(pi y / (H - 1))
    Distribution1D rows_;           // the cell rows, by their summed weights
    std::vector<float> cdf_;        // per cell row, W + 1 entries: the columns' cumulative weights
    std::vector<float> cellPdf_;    // per cell: the solid-angle density
    double integral_ = 0.0;         // integral of the luminance over the sphere (without scale)
    float maxLum_ = 0.f;            // the largest texel luminance (without scale)
};

// Reads the image (EXR, HDR, PFM: readImage) and builds the map; ImageError or EnvmapError name the file.
std::shared_ptr<const EnvironmentMap> loadEnvironmentMap(const std::string& path, const Mat4& toWorld, float scale);

}  // namespace lt
