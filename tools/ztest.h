// Mitsuba 3's per-pixel z-test of a render against a reference image with its per-sample variance,
// as its render tests apply it (mitsuba3 src/render/tests/test_renders.py, z_test and test_render).
// Header-only (used by imgcompare --ztest and tests/test_ztest.cpp); written from the description
// there, not copied.
//
// Null hypothesis per value: the rendered mean m of N samples (N = spp) has expectation r, the
// reference. The reference file also stores v, the variance of ONE sample (a moment integrator's
// E[x^2] - E[x]^2 of its long render), so the standard error of m is sqrt(v / N) and
//     z = |m - r| * sqrt(N / max(v, 1e-4)),   p = 2 (1 - Phi(z)) = erfc(z / sqrt 2)   (two-sided).
// The reference's own error is neglected (its spp, 32000 by default, is far above N).
// Values are tested in CIE XYZ: Mitsuba's references are written as RGB = xyz_to_srgb(XYZ) of an
// XYZ mean and an XYZ variance, and the test converts the render, the reference and the variance
// file back to XYZ (Bitmap::convert, the matrix below). (The "RGB" of a variance file is not a
// variance: it can be negative; its XYZ is the per-channel variance of the samples' XYZ.)
// Multiple testing: alpha = 1 - (1 - significance)^(1 / pixels) (Sidak over the pixel count, not
// the 3 x pixels values; significance 0.01), a value fails when p <= alpha (also when p is NaN),
// and the image passes when (passing values) / 3 >= 0.9975 x pixels, i.e. when at most
// 0.75% of the pixel count (0.25% of the values) fail.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>

#include "core/image.h"
#include "core/metrics.h"

namespace lt::ztest {

constexpr double kSignificance = 0.01;      // test_renders.py: significance_level
constexpr double kVarianceFloor = 1e-4;     // z_test: reference_var = max(reference_var, 1e-4)
constexpr double kPassFraction = 0.9975;    // test_render: count(success) / 3 >= 0.9975 * pixel_count
constexpr long kSampleBudget = 2000000;     // test_render: spp = 2e6 // pixel_count

// The spp test_renders.py renders an image of `pixels` pixels with (integer division).
inline long mitsubaSpp(long pixels) { return pixels > 0 ? kSampleBudget / pixels : 0; }

// Sidak's per-test level for `tests` independent tests at family-wise level `significance`:
// 1 - (1 - significance)^(1/tests), evaluated as -expm1(log1p(-significance) / tests) (no
// cancellation for large counts).
inline double sidakLevel(double significance, double tests) {
    return -std::expm1(std::log1p(-significance) / tests);
}

// Two-sided p-value of a standard normal statistic: 2 (1 - Phi(|z|)) = erfc(|z| / sqrt 2).
inline double twoSidedPValue(double z) { return std::erfc(std::abs(z) / std::sqrt(2.0)); }

// Mitsuba's Bitmap::convert from RGB to XYZ (linear Rec. 709 / sRGB primaries, D65).
inline void rgbToXyz(const Color& c, double out[3]) {
    const double r = c.x, g = c.y, b = c.z;
    out[0] = 0.412453 * r + 0.357580 * g + 0.180423 * b;
    out[1] = 0.212671 * r + 0.715160 * g + 0.072169 * b;
    out[2] = 0.019334 * r + 0.119193 * g + 0.950227 * b;
}

struct Settings {
    long spp = 0;                          // N, the sample count of the image under test (> 0)
    double significance = kSignificance;   // family-wise level before the Sidak correction
};

struct Result {
    size_t pixels = 0;           // tested pixels (the crop's, or the image's)
    size_t values = 0;           // 3 x pixels
    size_t failingValues = 0;    // p <= alpha or p not a number
    size_t failingPixels = 0;    // pixels with at least one failing value
    size_t nonFiniteValues = 0;  // values of the image under test that are NaN or infinite (they fail)
    double alpha = 0;            // Sidak level
    double allowedFailingValues = 0;  // 3 x pixels x (1 - 0.9975): the most failing values that pass
    double minPValue = 1;        // over the finite values
    double maxZ = 0;
    int minX = -1, minY = -1, minChannel = -1;  // where the smallest p-value is (image coordinates)
    double minImage = 0, minReference = 0, minVariance = 0;  // that value in A, the reference, the variance (after the floor)
    bool pass = false;
};

// The z-test of `img` (mean of settings.spp samples) against `ref` with per-sample variance
// `var`, over `crop` if given. Throws std::invalid_argument on a size mismatch or spp < 1.
// `pvalues`, if given, receives the p-value of every value (X, Y, Z in the R, G, B channels; 0 for
// a non-finite value of img), of the crop's size.
inline Result run(const Image& img, const Image& ref, const Image& var, const Settings& s,
                  const CropRect* crop = nullptr, Image* pvalues = nullptr) {
    if (img.width != ref.width || img.height != ref.height || var.width != ref.width || var.height != ref.height)
        throw std::invalid_argument("z-test: the image, the reference and the variance differ in size");
    if (s.spp < 1) throw std::invalid_argument("z-test: the sample count must be at least 1");
    if (!(s.significance > 0.0 && s.significance < 1.0))
        throw std::invalid_argument("z-test: the significance must lie in (0, 1)");
    const CropRect all{0, 0, img.width, img.height};
    const CropRect& r = crop ? *crop : all;
    Result res;
    res.pixels = size_t(r.w) * size_t(r.h);
    res.values = 3 * res.pixels;
    if (res.pixels == 0) throw std::invalid_argument("z-test: no pixels to test");
    res.alpha = sidakLevel(s.significance, double(res.pixels));
    res.allowedFailingValues = double(res.values) - 3.0 * kPassFraction * double(res.pixels);
    if (pvalues) *pvalues = Image(r.w, r.h);
    const double n = double(s.spp);
    size_t passing = 0;
    for (int y = r.y; y < r.y + r.h; ++y)
        for (int x = r.x; x < r.x + r.w; ++x) {
            double a[3], b[3], v[3];
            rgbToXyz(img.at(x, y), a);
            rgbToXyz(ref.at(x, y), b);
            rgbToXyz(var.at(x, y), v);
            bool pixelFails = false;
            for (int c = 0; c < 3; ++c) {
                const double vv = std::max(v[c], kVarianceFloor);  // callers reject non-finite variances
                const double z = std::abs(a[c] - b[c]) * std::sqrt(n / vv);
                const double p = std::isfinite(a[c]) ? twoSidedPValue(z) : std::numeric_limits<double>::quiet_NaN();
                if (pvalues) (*pvalues).at(x - r.x, y - r.y)[c] = std::isfinite(p) ? float(p) : 0.f;
                if (!std::isfinite(a[c])) ++res.nonFiniteValues;
                if (p > res.alpha) {
                    ++passing;
                } else {
                    ++res.failingValues;
                    pixelFails = true;
                }
                if (std::isfinite(p) && (res.minChannel < 0 || p < res.minPValue)) {
                    res.minPValue = p;
                    res.minX = x, res.minY = y, res.minChannel = c;
                    res.minImage = a[c], res.minReference = b[c], res.minVariance = vv;
                }
                if (std::isfinite(z)) res.maxZ = std::fmax(res.maxZ, z);
            }
            if (pixelFails) ++res.failingPixels;
        }
    res.pass = double(passing) / 3.0 >= kPassFraction * double(res.pixels);
    return res;
}

}  // namespace lt::ztest
