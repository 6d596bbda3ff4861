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
#include <compare>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
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
// Over the pixels whose entry of `excluded` (row-major, one per pixel) is false; pixels = their
// number (0: all other fields 0). Throws as above, and for a mask of another size.
ErrorMetrics computeMetrics(const Image& img, const Image& ref, const std::vector<bool>& excluded);

// Per-pixel, per-channel map of the metric's term (size of the crop, or of the whole image):
//   Mse: (a-b)^2, RelMse: relMseTerm, RmsRelErr: rmsRelErrTerm (the squared relative residual, so
//   the map's mean is RMS-RE^2), Mape: mapeTerm, Mean: the signed difference a - b.
// The mean of the map over all values equals the metric (MSE, relMSE, MAPE, meanImage-meanReference).
// Same checks and exceptions as computeMetrics.
Image errorMap(const Image& img, const Image& ref, Metric m, const CropRect* crop = nullptr);

// First pixel (in row-major order) inside crop (or the image) with a non-finite channel.
std::optional<std::pair<int, int>> findNonFinite(const Image& img, const CropRect* crop = nullptr);

// ---- Concentration of the error: the share carried by the worst pixels ------------------------
// The per-pixel error is the sum of the relMseTerm of the pixel's three channels (so the mean of
// these over all pixels, divided by 3, is relMSE). Pixels are ranked by it, largest first.

// Per-pixel relMSE error e_p = sum over c of relMseTerm(a_c, b_c), row-major over the crop (or
// the image): index i is the pixel (crop.x + i % crop.w, crop.y + i / crop.w).
// Same checks and exceptions as computeMetrics.
std::vector<double> pixelRelMseErrors(const Image& img, const Image& ref, const CropRect* crop = nullptr);

// How many pixels the worst `fraction` of n pixels is: ceil(fraction * n), at least 1 and at most
// n; a product within 1e-9 of a whole number counts as that number (7% of 100 pixels is 7, although
// 0.07 * 100 is 7.000000000000001 in doubles); 0 for n = 0.
// Throws std::invalid_argument unless 0 < fraction <= 1.
size_t topPixelCount(size_t n, double fraction);

// Share of the total carried by the k = topPixelCount(errors.size(), fraction) largest entries:
// (sum of the k largest e_p) / (sum of all e_p), in [k/n, 1] for non-negative errors (uniform
// error gives k/n, e.g. 0.01; one pixel carrying all the error gives 1). 0 when the total is 0
// (the images are equal: there is no error to concentrate). Throws like topPixelCount.
double topShare(std::vector<double> errors, double fraction = 0.01);

// topShare(pixelRelMseErrors(img, ref, crop), fraction): the share of the relMSE carried by the
// worst 1% of pixels by default ("relmse_top1_share" in imgcompare, "top-1% share" in bench).
// A high share (close to 1) means the error is in a few fireflies, a share near `fraction` means
// it is spread evenly.
double relMseTopShare(const Image& img, const Image& ref, double fraction = 0.01, const CropRect* crop = nullptr);

// Indices of the k largest entries of errors (k clamped to errors.size()), largest first; ties in
// index order, so the result is deterministic.
std::vector<size_t> worstIndices(const std::vector<double>& errors, size_t k);

// ---- Technique attribution from per-strategy images (render --strategy-images DIR) --------------
// render writes one image per technique: "s{s}_t{t}.exr" for connections with s light and t camera
// vertices (t = 1 is light tracing) and "merge_s{s}.exr" for merges with s light vertices; their
// sum is the rendered image.

struct StrategyId {
    bool merge = false;
    int s = 0, t = 0;              // t is 0 for merges
    std::string name() const;      // "s2_t3" or "merge_s4" (the file name without ".exr")
    auto operator<=>(const StrategyId&) const = default;  // connections first, then by s, t
};
// "s2_t3.exr" -> {false, 2, 3}, "merge_s4.exr" -> {true, 4, 0}; any other name (other
// extensions, signs, leading zeros, trailing text) -> nullopt.
std::optional<StrategyId> parseStrategyFileName(std::string_view fileName);

struct StrategyImage {
    StrategyId id;
    std::string path;
    Image image;
};
// Reads every strategy image in dir (files whose names parseStrategyFileName accepts; other
// files are ignored), sorted by StrategyId. Throws std::runtime_error naming the path when dir is
// not a directory or holds no strategy image, when a file cannot be read (the ImageError message
// names it), or when a file is not width x height (the message names the file and both sizes).
std::vector<StrategyImage> readStrategyImages(const std::string& dir, int width, int height);

// The value attributed at a pixel is the mean of its three channels (R + G + B) / 3, the same
// weighting the metrics give the channels.
inline double channelMean(const Color& c) { return (double(c.x) + double(c.y) + double(c.z)) / 3.0; }

struct TechniqueShare {
    std::string name;    // StrategyId::name()
    double value = 0;    // summed channel mean of this technique's image (over the pixel or pixel set)
    double share = 0;    // value / sum of all techniques' values (0 when that sum is 0)
};

struct PixelAttribution {
    int x = 0, y = 0;          // image coordinates (row 0 at the top), also with a crop
    double error = 0;          // per-pixel relMSE error (pixelRelMseErrors)
    double image = 0, reference = 0;  // channel means of A and of the reference
    double strategies = 0;     // channel mean of the sum of the strategy images (= image when DIR
                               // was written by the render of A)
    std::vector<TechniqueShare> techniques;  // techniques with a non-zero value, largest first
};

struct Attribution {
    std::vector<PixelAttribution> worst;   // the worstK pixels by error, largest first
    size_t topPixels = 0;                  // topPixelCount(pixels compared, fraction)
    std::vector<TechniqueShare> topTechniques;  // over those top pixels: each technique's share of
                                                // their summed value, largest first (non-zero only)
    // sum_p |S_p - A_p| / sum_p |A_p| over the compared pixels (channel means; S = sum of the
    // strategy images): ~1e-8 when DIR belongs to A, large when it was written by another render.
    double strategySumRelDiff = 0;
};

// Ranks the pixels of img against ref by pixelRelMseErrors (inside crop), lists the worstK of them
// with each technique's share of the pixel's value, and the techniques' shares of the summed value
// of the worst `fraction` of pixels. Same checks and exceptions as computeMetrics and
// topPixelCount; also std::invalid_argument naming the file when a strategy image is not img's
// size (readStrategyImages checks that too) or has a non-finite value inside the crop.
Attribution attributeWorstPixels(const Image& img, const Image& ref, const std::vector<StrategyImage>& strategies,
                                 size_t worstK, double fraction = 0.01, const CropRect* crop = nullptr);

}  // namespace lt
