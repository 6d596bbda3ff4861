#include "core/envmap.h"
#include "core/texture/texture_factory.h"

#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <numbers>

namespace lt {

namespace {
constexpr double kPiD = std::numbers::pi;
// Largest float below 1 (a remapped sample stays inside its cell).
constexpr float kOneMinusEps = 0x1.fffffep-1f;
}  // namespace

bool isOrthonormal(const Mat4& m, float tol) {
    const glm::mat3 l(m);
    const glm::mat3 p = glm::transpose(l) * l;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            if (!(std::abs(p[i][j] - (i == j ? 1.f : 0.f)) <= tol)) return false;
    return true;
}

EnvironmentMap::EnvironmentMap(const Image& img, const Mat4& toWorld, float scale, const std::string& name)
    : name_(name), scale_(scale) {
    if (img.width < 1 || img.height < 1 || img.pixels.size() != size_t(img.width) * size_t(img.height))
        throw EnvmapError(fmt::format("{}: the environment map image is empty", name));
    if (!(std::isfinite(scale) && scale >= 0.f))
        throw EnvmapError(fmt::format("{}: the envmap scale must be finite and >= 0 (got {})", name, scale));
    if (!isOrthonormal(toWorld))
        throw EnvmapError(fmt::format("{}: the envmap's to_world must be a rotation (no scale or shear)", name));
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const Color& c = img.at(x, y);
            for (int k = 0; k < 3; ++k) {
                const float v = c[k];
                if (std::isfinite(v) && v >= 0.f) continue;
                throw EnvmapError(fmt::format("{}: texel ({}, {}) has {} channel {} (environment map radiance must be "
                                              "finite and >= 0)",
                                              name, x, y, std::isnan(v) ? "a NaN in" : std::isinf(v) ? "an infinite" : "a negative",
                                              "RGB"[k]));
            }
        }
    // At least 2 x 3, the last column and row repeated (Mitsuba's Bitmap::pad_to).
    w_ = std::max(img.width, 2);
    h_ = std::max(img.height, 3);
    texels_.resize(size_t(w_) * size_t(h_));
    for (int y = 0; y < h_; ++y)
        for (int x = 0; x < w_; ++x)
            texels_[size_t(y) * w_ + x] = img.at(std::min(x, img.width - 1), std::min(y, img.height - 1));
    toWorld_ = glm::mat3(toWorld);
    toLocal_ = glm::inverse(toWorld_);

    const int W = w_, H = h_, R = h_ - 1;  // R cell rows between the H texel rows
    cosRow_.resize(size_t(H));
    for (int y = 0; y < H; ++y) cosRow_[size_t(y)] = float(std::cos(kPiD * y / R));
    cosRow_.front() = 1.f;
    cosRow_.back() = -1.f;
    std::vector<float> lum(texels_.size());
    for (size_t i = 0; i < texels_.size(); ++i) {
        lum[i] = luminance(texels_[i]);
        maxLum_ = std::max(maxLum_, lum[i]);
    }
    // Cell (row r, column c) spans theta in [theta_r, theta_{r+1}] and u in [(c + 1/2) / W,
    // (c + 3/2) / W]; its weight is the integral over it of the bilinear luminance times
    // sin(theta): in phi the mean of each row's two corners, in theta the exact integrals of
    // (1 - t) sin(theta) and t sin(theta), t = (theta - theta_r) / dTheta.
    const double dPhi = 2.0 * kPiD / W;
    std::vector<double> cellWeight(size_t(R) * W);
    std::vector<float> rowWeight(static_cast<size_t>(R));
    double total = 0.0;
    for (int r = 0; r < R; ++r) {
        const double a = kPiD * r / R, b = kPiD * (r + 1) / R, d = b - a;
        const double iB = std::max(0.0, (std::sin(b) - std::sin(a) - d * std::cos(b)) / d);
        const double iA = std::max(0.0, (std::cos(a) - std::cos(b)) - iB);
        double rowSum = 0.0;
        for (int c = 0; c < W; ++c) {
            const int c1 = c + 1 == W ? 0 : c + 1;
            const double top = 0.5 * (double(lum[size_t(r) * W + c]) + double(lum[size_t(r) * W + c1]));
            const double bottom = 0.5 * (double(lum[size_t(r + 1) * W + c]) + double(lum[size_t(r + 1) * W + c1]));
            const double w = dPhi * (top * iA + bottom * iB);
            cellWeight[size_t(r) * W + c] = w;
            rowSum += w;
        }
        rowWeight[size_t(r)] = float(rowSum);
        total += rowSum;
    }
    integral_ = total;
    cdf_.assign(size_t(R) * (W + 1), 0.f);
    cellPdf_.assign(size_t(R) * W, 0.f);
    if (!(total > 0.0)) return;  // a black map: nothing to sample, density 0
    rows_ = Distribution1D(rowWeight);
    for (int r = 0; r < R; ++r) {
        float* cdf = &cdf_[size_t(r) * (W + 1)];
        double rowSum = 0.0, run = 0.0;
        for (int c = 0; c < W; ++c) rowSum += cellWeight[size_t(r) * W + c];
        for (int c = 0; c < W; ++c) {  // (a row of weight 0 is never chosen)
            run += cellWeight[size_t(r) * W + c];
            cdf[c + 1] = rowSum > 0.0 ? float(run / rowSum) : float(c + 1) / float(W);
        }
        cdf[W] = 1.f;
        const double omega = dPhi * (std::cos(kPiD * r / R) - std::cos(kPiD * (r + 1) / R));
        for (int c = 0; c < W; ++c) cellPdf_[size_t(r) * W + c] = float(cellWeight[size_t(r) * W + c] / (total * omega));
    }
}

Vec2 EnvironmentMap::directionToUv(const Vec3& toSky) const {
    const Vec3 l = toLocal_ * toSky;
    float u = std::atan2(l.x, -l.z) * (0.5f * kInvPi);
    if (u < 0.f) u += 1.f;
    if (u >= 1.f) u = 0.f;
    const float len = glm::length(l);
    const float cosT = len > 0.f ? std::clamp(l.y / len, -1.f, 1.f) : 1.f;
    return Vec2(u, std::acos(cosT) * kInvPi);
}

Vec3 EnvironmentMap::uvToDirection(const Vec2& uv) const {
    const float theta = uv.y * kPi, phi = uv.x * (2.f * kPi);
    const float st = std::sin(theta);
    return toWorld_ * Vec3(std::sin(phi) * st, std::cos(theta), -std::cos(phi) * st);
}

Color EnvironmentMap::evalUv(float u, float v) const {
    u -= std::floor(u);
    v = std::clamp(v, 0.f, 1.f);
    const float x = u * float(w_) - 0.5f;
    const float x0 = std::floor(x);
    const float fx = x - x0;
    int i0 = int(x0);
    if (i0 < 0) i0 += w_;
    if (i0 >= w_) i0 -= w_;
    const int i1 = i0 + 1 == w_ ? 0 : i0 + 1;
    const float y = v * float(h_ - 1);
    const int j0 = std::min(int(y), h_ - 2);
    const float fy = y - float(j0);
    const Color top = (1.f - fx) * texel(i0, j0) + fx * texel(i1, j0);
    const Color bottom = (1.f - fx) * texel(i0, j0 + 1) + fx * texel(i1, j0 + 1);
    return ((1.f - fy) * top + fy * bottom) * scale_;
}

Color EnvironmentMap::eval(const Vec3& toSky) const {
    const Vec2 uv = directionToUv(toSky);
    return evalUv(uv.x, uv.y);
}

int EnvironmentMap::cellOf(const Vec3& l, int& row) const {
    const double len = std::sqrt(double(l.x) * l.x + double(l.y) * l.y + double(l.z) * l.z);
    const double cosT = len > 0.0 ? std::clamp(double(l.y) / len, -1.0, 1.0) : 1.0;
    row = std::min(int(std::acos(cosT) / kPiD * (h_ - 1)), h_ - 2);
    double u = std::atan2(double(l.x), -double(l.z)) / (2.0 * kPiD);
    if (u < 0.0) u += 1.0;
    int c = int(std::floor(u * w_ - 0.5));
    if (c < 0) c += w_;
    if (c >= w_) c -= w_;
    return c;
}

float EnvironmentMap::pdf(const Vec3& toSky) const {
    if (!(integral_ > 0.0)) return 0.f;
    int row;
    const int c = cellOf(toLocal_ * toSky, row);
    return cellPdf_[size_t(row) * w_ + c];
}

EnvironmentMap::Sample EnvironmentMap::sample(const Vec2& u) const {
    Sample s;
    if (!(integral_ > 0.0)) return s;
    float ur;
    const int r = int(rows_.sample(u.x, &ur));
    const float* cdf = &cdf_[size_t(r) * (w_ + 1)];
    // The column c with cdf[c] <= u.y < cdf[c + 1] (never one of zero weight).
    const int c = int(std::upper_bound(cdf + 1, cdf + w_, u.y) - (cdf + 1));
    const float width = cdf[c + 1] - cdf[c];
    const float uc = width > 0.f ? std::clamp((u.y - cdf[c]) / width, 0.f, kOneMinusEps) : 0.5f;
    // Uniform in solid angle inside the cell: cos(theta) and phi uniform.
    const float cosT = std::clamp(cosRow_[size_t(r)] + ur * (cosRow_[size_t(r) + 1] - cosRow_[size_t(r)]), -1.f, 1.f);
    const float sinT = safeSqrt(1.f - cosT * cosT);
    const float uu = (float(c) + 0.5f + uc) / float(w_);
    const float phi = uu * (2.f * kPi);
    const Vec3 local(std::sin(phi) * sinT, cosT, -std::cos(phi) * sinT);
    s.toSky = glm::normalize(toWorld_ * local);
    s.pdf = cellPdf_[size_t(r) * w_ + c];
    s.value = evalUv(uu, std::acos(cosT) * kInvPi);
    return s;
}

std::shared_ptr<const EnvironmentMap> loadEnvironmentMap(const std::string& path, const Mat4& toWorld, float scale) {
    const Image img = loadTextureImage(path, false);  // EXR/PFM/HDR linear; PNG/JPEG/... sRGB-decoded
    return std::make_shared<const EnvironmentMap>(img, toWorld, scale, path);
}

}  // namespace lt
