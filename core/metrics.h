// Error metrics between a rendered image and a reference (used by imgcompare and the tests).
//
// All metrics treat every colour channel of every pixel as one value: with a_i the image value,
// b_i the reference value and n = 3 * pixels, each metric is an average over the n values,
// accumulated in double precision:
//   mean       = (1/n) sum a_i   (meanImage)   and (1/n) sum b_i   (meanReference)
//   MSE        = (1/n) sum (a_i - b_i)^2
//   relMSE     = (1/n) sum (a_i - b_i)^2 / (b_i^2 + eps),  eps = kRelMseEpsilon = 1e-2
//                (the common convention: normalised by the reference b only)
//   RMS RE     = sqrt( (1/n) sum (a_i - b_i)^2 / ((a_i + b_i)/2)^2 )
//                exactly the "RMS of relative residuals" of Jendersie & Grosch 2019, section 4;
//                a pair with a_i + b_i == 0 contributes 0 (for a_i = b_i = 0 the residual is 0; the
//                definition is otherwise undefined there). No epsilon.
//   MAPE       = (1/n) sum |a_i - b_i| / (|b_i| + eps),    eps = kMapeEpsilon = 1e-2
#pragma once
#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include "core/image.h"

namespace lt {

inline constexpr double kRelMseEpsilon = 1e-2;
inline constexpr double kMapeEpsilon = 1e-2;

// Pixel rectangle [x, x+w) x [y, y+h), y = 0 is the top row. Must lie inside the image, w, h > 0.
struct CropRect {
    int x, y, w, h;
};

struct ErrorMetrics {
    double meanImage = 0, meanReference = 0, mse = 0, relMse = 0, rmsRelErr = 0, mape = 0;
    size_t pixels = 0;  // number of pixels compared (each contributes 3 values)
};

enum class Metric { Mean, Mse, RelMse, RmsRelErr, Mape };
// "mean", "mse", "relmse", "rmsre", "mape"
const char* metricName(Metric m);
std::optional<Metric> parseMetric(std::string_view name);  // case-insensitive; nullopt if unknown

// Per-value terms whose average over all values gives the metric.
inline double sqrErrTerm(double a, double b) { return (a - b) * (a - b); }
inline double relMseTerm(double a, double b) { return (a - b) * (a - b) / (b * b + kRelMseEpsilon); }
inline double rmsRelErrTerm(double a, double b) {  // squared; RMS RE = sqrt(mean of these)
    double s = a + b;
    if (s == 0.0) return 0.0;
    double m = 0.5 * s;
    return (a - b) * (a - b) / (m * m);
}
inline double mapeTerm(double a, double b) { return std::abs(a - b) / (std::abs(b) + kMapeEpsilon); }

// img is the image under test, ref the reference. crop (optional) restricts the comparison.
// Throws std::invalid_argument on: different sizes (message gives both sizes), empty images,
// a crop rectangle that is empty or not inside the image, a non-finite value in either image
// inside the compared region (message names the image and the pixel).
ErrorMetrics computeMetrics(const Image& img, const Image& ref, const CropRect* crop = nullptr);

// Per-pixel, per-channel map of the metric's term (size of the crop, or of the whole image):
//   Mse: (a-b)^2, RelMse: relMseTerm, RmsRelErr: rmsRelErrTerm (the squared relative residual, so
//   the map's mean is RMS-RE^2), Mape: mapeTerm, Mean: the signed difference a - b.
// The mean of the map over all values equals the metric (MSE, relMSE, MAPE, meanImage-meanReference).
// Same checks and exceptions as computeMetrics.
Image errorMap(const Image& img, const Image& ref, Metric m, const CropRect* crop = nullptr);

// First pixel (in row-major order) inside crop (or the image) with a non-finite channel.
std::optional<std::pair<int, int>> findNonFinite(const Image& img, const CropRect* crop = nullptr);

}  // namespace lt
