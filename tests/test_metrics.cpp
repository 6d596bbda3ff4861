// Error metrics (core/metrics.h) against hand-computed values, and the imgcompare tool.
#include <catch2/catch.hpp>
#include <fstream>
#include "process.h"

#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/image.h"
#include "core/metrics.h"

using namespace lt;
namespace fs = std::filesystem;
using Catch::Matchers::Contains;

namespace {

struct TempDir : lt::test::TempDir {
    TempDir() : lt::test::TempDir("lt_test_metrics") {}
};

// 2x2 grey images (all three channels equal, so per-value averages equal per-pixel ones):
//   A (image)      B (reference)
//   1  2           1  1
//   3  0           1  0
Image imageA() {
    Image a(2, 2);
    a.at(0, 0) = Color(1.f); a.at(1, 0) = Color(2.f);
    a.at(0, 1) = Color(3.f); a.at(1, 1) = Color(0.f);
    return a;
}
Image imageB() {
    Image b(2, 2);
    b.at(0, 0) = Color(1.f); b.at(1, 0) = Color(1.f);
    b.at(0, 1) = Color(1.f); b.at(1, 1) = Color(0.f);
    return b;
}
// Hand-computed for A vs B (differences 0, 1, 2, 0):
//   meanImage     = (1+2+3+0)/4 = 1.5,   meanReference = (1+1+1+0)/4 = 0.75
//   MSE           = (0 + 1 + 4 + 0)/4 = 1.25
//   relMSE        = (0 + 1/1.01 + 4/1.01 + 0/(0+0.01))/4 = 5/4.04 = 1.2376237623762376
//   RMS RE        = sqrt((0 + 1/1.5^2 + 2^2/2^2 + 0 [a+b == 0])/4) = sqrt((4/9 + 1)/4) = sqrt(13/36)
//                 = sqrt(13)/6 = 0.6009252125773316
//   MAPE          = (0 + 1/1.01 + 2/1.01 + 0)/4 = 3/4.04 = 0.7425742574257426
constexpr double kMeanA = 1.5, kMeanB = 0.75, kMse = 1.25, kRelMse = 5.0 / 4.04, kMape = 3.0 / 4.04;
const double kRmsRe = std::sqrt(13.0) / 6.0;

// Runs the imgcompare binary with the given arguments; stdout and stderr are captured together.
lt::test::Run runImgcompare(const std::string& args) { return lt::test::sh(std::string("'") + LT_IMGCOMPARE_BIN + "' " + args); }

// Parses "name: value" lines.
std::map<std::string, double> parseLines(const std::string& out) {
    std::map<std::string, double> m;
    std::istringstream in(out);
    std::string line;
    while (std::getline(in, line)) {
        size_t colon = line.find(": ");
        if (colon == std::string::npos) continue;
        m[line.substr(0, colon)] = std::stod(line.substr(colon + 2));
    }
    return m;
}

std::string q(const std::string& s) { return "'" + s + "'"; }

}  // namespace

TEST_CASE("Metrics match hand-computed values on a 2x2 image", "[metrics]") {
    ErrorMetrics m = computeMetrics(imageA(), imageB());
    CHECK(m.pixels == 4);
    // All inputs are small integers, so double accumulation is exact up to the final division
    // and sqrt: 1e-14 relative leaves room only for rounding.
    CHECK(m.meanImage == Approx(kMeanA).epsilon(1e-14));
    CHECK(m.meanReference == Approx(kMeanB).epsilon(1e-14));
    CHECK(m.mse == Approx(kMse).epsilon(1e-14));
    CHECK(m.relMse == Approx(kRelMse).epsilon(1e-14));
    CHECK(m.rmsRelErr == Approx(kRmsRe).epsilon(1e-14));
    CHECK(m.mape == Approx(kMape).epsilon(1e-14));

    // Identical images: every error is 0, the means are equal.
    ErrorMetrics z = computeMetrics(imageA(), imageA());
    CHECK(z.mse == 0.0);
    CHECK(z.relMse == 0.0);
    CHECK(z.rmsRelErr == 0.0);
    CHECK(z.mape == 0.0);
    CHECK(z.meanImage == z.meanReference);
}

TEST_CASE("Metrics average over the three channels", "[metrics]") {
    // One pixel, A = (1, 2, 3), B = (1, 1, 1): differences 0, 1, 2.
    Image a(1, 1, Color(1.f, 2.f, 3.f)), b(1, 1, Color(1.f));
    ErrorMetrics m = computeMetrics(a, b);
    CHECK(m.pixels == 1);
    CHECK(m.meanImage == Approx(2.0).epsilon(1e-14));                // (1+2+3)/3
    CHECK(m.mse == Approx(5.0 / 3.0).epsilon(1e-14));                // (0+1+4)/3
    CHECK(m.relMse == Approx(5.0 / 1.01 / 3.0).epsilon(1e-14));      // (0+1+4)/(1+0.01)/3
    CHECK(m.rmsRelErr == Approx(std::sqrt((1.0 / 2.25 + 1.0) / 3.0)).epsilon(1e-14));  // 1/1.5^2, 2^2/2^2
    CHECK(m.mape == Approx(3.0 / 1.01 / 3.0).epsilon(1e-14));        // (0+1+2)/1.01/3
}

TEST_CASE("relMSE, RMS-RE and MAPE with zero reference values behave as documented", "[metrics]") {
    // A = (0.1, 0, 0), B = (0, 0, 0).
    Image a(1, 1, Color(0.1f, 0.f, 0.f)), b(1, 1, Color(0.f));
    ErrorMetrics m = computeMetrics(a, b);
    const double a0 = double(0.1f);
    // relMSE: a0^2 / (0 + eps) for the red value, 0 for the two 0-vs-0 values.
    CHECK(m.relMse == Approx(a0 * a0 / kRelMseEpsilon / 3.0).epsilon(1e-12));
    CHECK(m.relMse == Approx(1.0 / 3.0).epsilon(1e-6));  // 0.1^2/0.01 = 1
    // RMS RE: (a-0)^2/((a+0)/2)^2 = 4 for any a != 0 (the maximal relative error, 2); the two pairs
    // with a+b == 0 contribute 0, so RMS RE = sqrt(4/3). Finite, no epsilon involved.
    CHECK(std::isfinite(m.rmsRelErr));
    CHECK(m.rmsRelErr == Approx(std::sqrt(4.0 / 3.0)).epsilon(1e-14));
    // MAPE: 0.1/(0 + 0.01) = 10 for the red value.
    CHECK(m.mape == Approx(a0 / kMapeEpsilon / 3.0).epsilon(1e-12));

    // All-zero images: every metric is exactly 0 (no 0/0).
    ErrorMetrics z = computeMetrics(Image(2, 2), Image(2, 2));
    CHECK(z.relMse == 0.0);
    CHECK(z.rmsRelErr == 0.0);
    CHECK(z.mape == 0.0);

    // a = -b != 0 also has a + b == 0: documented to contribute 0 to RMS RE.
    ErrorMetrics opp = computeMetrics(Image(1, 1, Color(-1.f)), Image(1, 1, Color(1.f)));
    CHECK(opp.rmsRelErr == 0.0);
    CHECK(opp.mse == Approx(4.0).epsilon(1e-14));

    // The constants are the documented ones.
    CHECK(kRelMseEpsilon == 1e-2);
    CHECK(kMapeEpsilon == 1e-2);
}

TEST_CASE("RMS RE is symmetric and scale invariant, relMSE uses the reference", "[metrics]") {
    Image a = imageA(), b = imageB();
    ErrorMetrics ab = computeMetrics(a, b), ba = computeMetrics(b, a);
    CHECK(ab.rmsRelErr == Approx(ba.rmsRelErr).epsilon(1e-14));
    CHECK(ab.mse == Approx(ba.mse).epsilon(1e-14));
    // relMSE normalises by b only, so swapping changes it: B vs A gives
    // (0 + 1/(4+0.01) + 4/(9+0.01) + 0)/4.
    CHECK(ba.relMse == Approx((1.0 / 4.01 + 4.0 / 9.01) / 4.0).epsilon(1e-14));
    // Scaling both images by 1000 leaves RMS RE unchanged (no epsilon in the JG19 definition).
    Image a2 = a, b2 = b;
    for (auto& c : a2.pixels) c *= 1000.f;
    for (auto& c : b2.pixels) c *= 1000.f;
    CHECK(computeMetrics(a2, b2).rmsRelErr == Approx(kRmsRe).epsilon(1e-12));
}

TEST_CASE("An exclusion mask leaves pixels out of the metrics", "[metrics]") {
    // 3x3, reference all 1; the image differs at (1,1) = 4 and (2,0) = 0.
    Image ref(3, 3, Color(1.f)), img(3, 3, Color(1.f));
    img.at(1, 1) = Color(4.f);
    img.at(2, 0) = Color(0.f);
    std::vector<bool> excluded(9, false);
    CHECK(computeMetrics(img, ref, excluded).mse == Approx(10.0 / 9.0).epsilon(1e-14));  // none: as without
    excluded[1 * 3 + 1] = true;  // the centre out: (1 over 8 pixels)
    ErrorMetrics m = computeMetrics(img, ref, excluded);
    CHECK(m.pixels == 8);
    CHECK(m.mse == Approx(1.0 / 8.0).epsilon(1e-14));
    CHECK(m.meanImage == Approx(7.0 / 8.0).epsilon(1e-14));
    excluded[0 * 3 + 2] = true;  // and (2,0): no error left
    CHECK(computeMetrics(img, ref, excluded).relMse == 0.0);
    // Everything out: no pixels, zeros.
    ErrorMetrics none = computeMetrics(img, ref, std::vector<bool>(9, true));
    CHECK(none.pixels == 0);
    CHECK(none.relMse == 0.0);
    // A mask of the wrong size, or a NaN inside the image: errors.
    CHECK_THROWS_AS(computeMetrics(img, ref, std::vector<bool>(8, false)), std::invalid_argument);
    img.at(0, 2) = Color(std::numeric_limits<float>::quiet_NaN());
    CHECK_THROWS_AS(computeMetrics(img, ref, std::vector<bool>(9, false)), std::invalid_argument);
}

TEST_CASE("Crop restricts the compared region", "[metrics]") {
    // 3x3, reference all 1; the image differs only at the centre (1,1) = 4 and at (2,0) = 0.
    Image ref(3, 3, Color(1.f)), img(3, 3, Color(1.f));
    img.at(1, 1) = Color(4.f);
    img.at(2, 0) = Color(0.f);
    CropRect centre{1, 1, 1, 1};
    ErrorMetrics c = computeMetrics(img, ref, &centre);
    CHECK(c.pixels == 1);
    CHECK(c.mse == Approx(9.0).epsilon(1e-14));  // (4-1)^2
    CHECK(c.meanImage == Approx(4.0).epsilon(1e-14));
    CropRect topRight{1, 0, 2, 1};  // pixels (1,0) and (2,0): differences 0 and 1
    ErrorMetrics t = computeMetrics(img, ref, &topRight);
    CHECK(t.pixels == 2);
    CHECK(t.mse == Approx(0.5).epsilon(1e-14));
    CropRect corner{0, 2, 1, 1};
    CHECK(computeMetrics(img, ref, &corner).mse == 0.0);
    // Whole image: (9 + 1)/9.
    CHECK(computeMetrics(img, ref).mse == Approx(10.0 / 9.0).epsilon(1e-14));

    // A non-finite pixel outside the crop does not matter; inside it throws.
    img.at(0, 2) = Color(std::numeric_limits<float>::quiet_NaN());
    CHECK_NOTHROW(computeMetrics(img, ref, &centre));
    CHECK_THROWS_AS(computeMetrics(img, ref, &corner), std::invalid_argument);

    // Crops that are empty or leave the image throw.
    for (CropRect bad : {CropRect{0, 0, 0, 1}, CropRect{-1, 0, 1, 1}, CropRect{2, 0, 2, 1}, CropRect{0, 1, 1, 3}}) {
        INFO("crop " << bad.x << "," << bad.y << "," << bad.w << "," << bad.h);
        CHECK_THROWS_AS(computeMetrics(ref, ref, &bad), std::invalid_argument);
    }
}

TEST_CASE("Size mismatch and non-finite pixels throw", "[metrics]") {
    Image a(2, 2), b(3, 2);
    CHECK_THROWS_AS(computeMetrics(a, b), std::invalid_argument);
    CHECK_THROWS_WITH(computeMetrics(a, b), Contains("2x2") && Contains("3x2"));
    CHECK_THROWS_WITH(errorMap(a, b, Metric::Mse), Contains("2x2") && Contains("3x2"));
    CHECK_THROWS_AS(computeMetrics(Image(), Image()), std::invalid_argument);

    Image nan(2, 2), ref(2, 2);
    nan.at(1, 0).y = std::numeric_limits<float>::quiet_NaN();
    CHECK_THROWS_WITH(computeMetrics(nan, ref), Contains("image") && Contains("(1, 0)"));
    Image inf(2, 2);
    inf.at(0, 1).z = std::numeric_limits<float>::infinity();
    CHECK_THROWS_WITH(computeMetrics(ref, inf), Contains("reference") && Contains("(0, 1)"));
}

TEST_CASE("Error maps hold the per-value terms", "[metrics]") {
    Image a = imageA(), b = imageB();
    ErrorMetrics m = computeMetrics(a, b);
    auto mapMean = [](const Image& im) {
        double s = 0;
        for (const Color& c : im.pixels) s += double(c.x) + c.y + c.z;
        return s / (3.0 * double(im.pixels.size()));
    };
    // Map values are stored as float, so their means agree with the metric to float precision.
    CHECK(mapMean(errorMap(a, b, Metric::Mse)) == Approx(m.mse).epsilon(1e-6));
    CHECK(mapMean(errorMap(a, b, Metric::RelMse)) == Approx(m.relMse).epsilon(1e-6));
    CHECK(mapMean(errorMap(a, b, Metric::Mape)) == Approx(m.mape).epsilon(1e-6));
    CHECK(std::sqrt(mapMean(errorMap(a, b, Metric::RmsRelErr))) == Approx(m.rmsRelErr).epsilon(1e-6));
    CHECK(mapMean(errorMap(a, b, Metric::Mean)) == Approx(m.meanImage - m.meanReference).epsilon(1e-6));
    // Individual entries: pixel (0,1) has a = 3, b = 1.
    CHECK(errorMap(a, b, Metric::Mse).at(0, 1).x == 4.f);
    CHECK(errorMap(a, b, Metric::Mean).at(0, 1).y == 2.f);
    CHECK(errorMap(a, b, Metric::RmsRelErr).at(0, 1).z == 1.f);  // 2^2 / 2^2
    CHECK(errorMap(a, b, Metric::RmsRelErr).at(1, 1).x == 0.f);  // 0 vs 0
    // Cropped map has the crop's size and content.
    CropRect crop{1, 0, 1, 2};
    Image cm = errorMap(a, b, Metric::Mse, &crop);
    CHECK(cm.width == 1);
    CHECK(cm.height == 2);
    CHECK(cm.at(0, 0).x == 1.f);  // (2-1)^2
    CHECK(cm.at(0, 1).x == 0.f);  // (0-0)^2

    CHECK(parseMetric("RelMSE") == Metric::RelMse);
    CHECK(parseMetric("rmsre") == Metric::RmsRelErr);
    CHECK_FALSE(parseMetric("psnr").has_value());
    CHECK(std::string(metricName(Metric::Mape)) == "mape");
}

TEST_CASE("Double accumulation stays accurate on a large image", "[metrics]") {
    // 1000x1000x3 values with constant difference d = 0.1f - 0.2f. A float accumulator would drift by
    // ~1e-3 relative after 3e6 additions; double summation of per-row sums stays at ~1e-12.
    Image a(1000, 1000, Color(0.1f)), b(1000, 1000, Color(0.2f));
    const double d = double(0.1f) - double(0.2f);
    ErrorMetrics m = computeMetrics(a, b);
    CHECK(m.pixels == 1000000);
    CHECK(m.mse == Approx(d * d).epsilon(1e-10));
    CHECK(m.meanImage == Approx(double(0.1f)).epsilon(1e-10));
    CHECK(m.relMse == Approx(d * d / (double(0.2f) * double(0.2f) + 0.01)).epsilon(1e-10));
}

// ---- Concentration of the error (relmse_top1_share) ------------------------------------------

namespace {

// 100x100 images against a reference of 0 (relMseTerm(a, 0) = a^2 / 0.01): every pixel has
// per-pixel error e (all channels equal), except the pixels in `hot`, whose error is hotFactor x e.
std::pair<Image, Image> errorImages(float a, const std::vector<std::pair<int, int>>& hot, double hotFactor) {
    Image img(100, 100, Color(a)), ref(100, 100, Color(0.f));
    for (auto [x, y] : hot) img.at(x, y) = Color(float(double(a) * std::sqrt(hotFactor)));
    return {img, ref};
}

}  // namespace

TEST_CASE("Per-pixel relMSE errors sum the three channel terms and average to relMSE", "[metrics][top1]") {
    Image a(2, 1), b(2, 1, Color(1.f));
    a.at(0, 0) = Color(1.f, 2.f, 3.f);  // terms 0, 1/1.01, 4/1.01
    a.at(1, 0) = Color(1.f);            // 0
    std::vector<double> e = pixelRelMseErrors(a, b);
    REQUIRE(e.size() == 2);
    CHECK(e[0] == Approx(5.0 / 1.01).epsilon(1e-14));
    CHECK(e[1] == 0.0);
    CHECK((e[0] + e[1]) / 6.0 == Approx(computeMetrics(a, b).relMse).epsilon(1e-14));
    // Row-major over the crop: index 0 of a crop starting at x = 1 is pixel (1, 0).
    CropRect crop{1, 0, 1, 1};
    CHECK(pixelRelMseErrors(a, b, &crop) == std::vector<double>{0.0});
    CHECK_THROWS_AS(pixelRelMseErrors(a, Image(3, 1)), std::invalid_argument);
}

TEST_CASE("Top-1% share: hand-computed cases", "[metrics][top1]") {
    SECTION("100 of 10000 pixels with 10x the error: 1000 / (9900 + 1000)") {
        std::vector<std::pair<int, int>> hot;
        for (int i = 0; i < 100; ++i) hot.push_back({(i * 37) % 100, (i * 53 + 7) % 100});  // 100 distinct pixels
        auto [img, ref] = errorImages(0.25f, hot, 10.0);
        // float(0.25 * sqrt(10))^2 is 10 x 0.25^2 to float precision.
        CHECK(relMseTopShare(img, ref) == Approx(1000.0 / 10900.0).epsilon(1e-6));
        // Same on the per-pixel errors directly (exact values): 1000 / 10900 to rounding.
        std::vector<double> e(10000, 1.0);
        for (int i = 0; i < 100; ++i) e[size_t(i) * 97] = 10.0;
        CHECK(topShare(e) == Approx(1000.0 / 10900.0).epsilon(1e-12));
        // The worst 2% are those 100 plus 100 ordinary pixels: 1100 / 10900.
        CHECK(topShare(e, 0.02) == Approx(1100.0 / 10900.0).epsilon(1e-12));
    }
    SECTION("one pixel carries all the error: 1") {
        auto [img, ref] = errorImages(0.f, {}, 1.0);
        img.at(42, 17) = Color(3.f, 0.f, 1.f);
        CHECK(relMseTopShare(img, ref) == 1.0);
        CHECK(relMseTopShare(img, ref, 1e-4) == 1.0);  // even the single worst pixel (ceil(1) = 1)
    }
    SECTION("uniform error: 0.01, and the fraction itself for any fraction") {
        auto [img, ref] = errorImages(0.5f, {}, 1.0);
        CHECK(relMseTopShare(img, ref) == Approx(0.01).epsilon(1e-12));
        CHECK(relMseTopShare(img, ref, 0.25) == Approx(0.25).epsilon(1e-12));
        CHECK(relMseTopShare(img, ref, 1.0) == Approx(1.0).epsilon(1e-12));
    }
    SECTION("equal images: 0 (no error to concentrate)") {
        CHECK(relMseTopShare(imageA(), imageA()) == 0.0);
    }
    SECTION("crop: only the pixels inside count") {
        auto [img, ref] = errorImages(0.5f, {{10, 10}}, 1e6);
        CropRect withHot{0, 0, 50, 20}, withoutHot{50, 50, 50, 20};  // 1000 pixels each: top 10
        CHECK(relMseTopShare(img, ref, 0.01, &withHot) == Approx((1e6 + 9.0) / (1e6 + 999.0)).epsilon(1e-6));
        CHECK(relMseTopShare(img, ref, 0.01, &withoutHot) == Approx(0.01).epsilon(1e-12));
    }
}

TEST_CASE("Top pixel count is ceil(fraction * pixels), at least 1", "[metrics][top1]") {
    CHECK(topPixelCount(10000, 0.01) == 100);
    CHECK(topPixelCount(300, 0.01) == 3);
    CHECK(topPixelCount(100, 0.07) == 7);     // 0.07 * 100 = 7.000000000000001 in doubles: not 8
    CHECK(topPixelCount(101, 0.01) == 2);     // ceil(1.01)
    CHECK(topPixelCount(50, 0.01) == 1);      // ceil(0.5)
    CHECK(topPixelCount(1, 0.01) == 1);
    CHECK(topPixelCount(7, 1.0) == 7);
    CHECK(topPixelCount(0, 0.5) == 0);
    for (double bad : {0.0, -0.1, 1.5, std::numeric_limits<double>::quiet_NaN()})
        CHECK_THROWS_AS(topPixelCount(10, bad), std::invalid_argument);
    CHECK_THROWS_AS(topShare({1.0, 2.0}, 0.0), std::invalid_argument);
}

TEST_CASE("Worst indices are the largest entries, largest first, ties in index order", "[metrics][top1]") {
    std::vector<double> e{1, 5, 3, 5, 0, 4};
    CHECK(worstIndices(e, 3) == std::vector<size_t>{1, 3, 5});
    CHECK(worstIndices(e, 1) == std::vector<size_t>{1});
    CHECK(worstIndices(e, 99).size() == e.size());
    CHECK(worstIndices(e, 99).back() == 4);
}

// ---- Technique attribution ---------------------------------------------------------------------

TEST_CASE("Strategy image names are parsed as render writes them", "[metrics][strategies]") {
    auto conn = parseStrategyFileName("s0_t10.exr");
    REQUIRE(conn);
    CHECK_FALSE(conn->merge);
    CHECK(conn->s == 0);
    CHECK(conn->t == 10);
    CHECK(conn->name() == "s0_t10");
    auto merge = parseStrategyFileName("merge_s3.exr");
    REQUIRE(merge);
    CHECK(merge->merge);
    CHECK(merge->s == 3);
    CHECK(merge->name() == "merge_s3");
    CHECK(parseStrategyFileName("s12_t1.exr")->name() == "s12_t1");
    for (const char* bad : {"s1_t2.png", "s01_t2.exr", "s1_t02.exr", "merge_s3_t1.exr", "s1.exr", "s-1_t2.exr",
                            "s1_t2.exr.bak", "merge_s.exr", "s_t1.exr", "S1_T2.exr", "image.exr", "s1_t2x.exr", ""})
        CHECK_FALSE(parseStrategyFileName(bad).has_value());
    // Order: connections by (s, t), then merges.
    CHECK(*parseStrategyFileName("s1_t9.exr") < *parseStrategyFileName("s2_t1.exr"));
    CHECK(*parseStrategyFileName("s9_t9.exr") < *parseStrategyFileName("merge_s1.exr"));
}

namespace {

// A 10x10 render made of three techniques, against a flat reference of 0.7:
//   s1_t2    : 0.5 everywhere
//   merge_s3 : 0.2 everywhere
//   s0_t10   : a firefly at (3, 4): (60, 30, 0) (channel mean 30), and (3, 0, 0) at (8, 1) (mean 1)
// The image is their sum: 0.7 except (3, 4) = (60.7, 30.7, 0.7) and (8, 1) = (3.7, 0.7, 0.7).
struct FireflyScene {
    Image s1t2{10, 10, Color(0.5f)}, merge3{10, 10, Color(0.2f)}, s0t10{10, 10, Color(0.f)};
    Image image{10, 10}, reference{10, 10, Color(0.7f)};
    FireflyScene() {
        s0t10.at(3, 4) = Color(60.f, 30.f, 0.f);
        s0t10.at(8, 1) = Color(3.f, 0.f, 0.f);
        for (size_t i = 0; i < image.pixels.size(); ++i) image.pixels[i] = s1t2.pixels[i] + merge3.pixels[i] + s0t10.pixels[i];
    }
    void write(const std::string& dir) const {
        fs::create_directories(dir);
        writeExr(s1t2, dir + "/s1_t2.exr");
        writeExr(merge3, dir + "/merge_s3.exr");
        writeExr(s0t10, dir + "/s0_t10.exr");
        writeExr(image, dir + "/image.exr");  // not a strategy image: ignored
    }
};

}  // namespace

TEST_CASE("Attribution names the technique that makes up the worst pixels", "[metrics][strategies]") {
    TempDir tmp;
    FireflyScene sc;
    sc.write(tmp.file("strat"));
    std::vector<StrategyImage> st = readStrategyImages(tmp.file("strat"), 10, 10);
    REQUIRE(st.size() == 3);
    CHECK(st[0].id.name() == "s0_t10");  // sorted: connections by (s, t), then merges
    CHECK(st[1].id.name() == "s1_t2");
    CHECK(st[2].id.name() == "merge_s3");

    Attribution at = attributeWorstPixels(sc.image, sc.reference, st, 2);
    REQUIRE(at.worst.size() == 2);
    const PixelAttribution& w = at.worst[0];
    CHECK(w.x == 3);
    CHECK(w.y == 4);
    const Color& hot = sc.image.at(3, 4);
    CHECK(w.error == Approx(relMseTerm(hot.x, 0.7f) + relMseTerm(hot.y, 0.7f) + relMseTerm(hot.z, 0.7f)).epsilon(1e-12));
    CHECK(w.error > 3000.0);  // (60^2 + 30^2) / 0.5
    CHECK(w.image == Approx(30.7).epsilon(1e-6));      // (60.7 + 30.7 + 0.7) / 3
    CHECK(w.reference == Approx(0.7).epsilon(1e-6));
    CHECK(w.strategies == Approx(w.image).epsilon(1e-6));
    REQUIRE(w.techniques.size() == 3);
    CHECK(w.techniques[0].name == "s0_t10");
    CHECK(w.techniques[0].share == Approx(30.0 / 30.7).epsilon(1e-6));
    CHECK(w.techniques[1].name == "s1_t2");
    CHECK(w.techniques[1].share == Approx(0.5 / 30.7).epsilon(1e-6));
    CHECK(w.techniques[2].name == "merge_s3");
    CHECK(w.techniques[2].share == Approx(0.2 / 30.7).epsilon(1e-6));
    const PixelAttribution& w2 = at.worst[1];
    CHECK(w2.x == 8);
    CHECK(w2.y == 1);
    CHECK(w2.techniques[0].name == "s0_t10");
    CHECK(w2.techniques[0].share == Approx(1.0 / 1.7).epsilon(1e-6));

    // Worst 1% of 100 pixels = 1 pixel: the firefly. Worst 2% = both hot pixels:
    // s0_t10 31 of 31 + 2 x 0.7 = 32.4.
    CHECK(at.topPixels == 1);
    REQUIRE(at.topTechniques.size() == 3);
    CHECK(at.topTechniques[0].name == "s0_t10");
    CHECK(at.topTechniques[0].share == Approx(30.0 / 30.7).epsilon(1e-6));
    Attribution at2 = attributeWorstPixels(sc.image, sc.reference, st, 1, 0.02);
    CHECK(at2.topPixels == 2);
    CHECK(at2.topTechniques[0].share == Approx(31.0 / 32.4).epsilon(1e-6));
    CHECK(at2.topTechniques[1].name == "s1_t2");
    CHECK(at2.topTechniques[1].value == Approx(1.0).epsilon(1e-6));
    CHECK(at.strategySumRelDiff < 1e-6);

    // A crop without the firefly: the worst pixel is the other hot one, in image coordinates.
    CropRect crop{5, 0, 5, 5};
    Attribution ac = attributeWorstPixels(sc.image, sc.reference, st, 1, 0.01, &crop);
    CHECK(ac.worst.at(0).x == 8);
    CHECK(ac.worst.at(0).y == 1);

    // Without one technique the strategies no longer sum to the image, and the check says so.
    std::vector<StrategyImage> partial(st.begin() + 1, st.end());
    CHECK(attributeWorstPixels(sc.image, sc.reference, partial, 1).strategySumRelDiff > 0.1);
    // A pixel where no technique contributes has no techniques (and no division by zero).
    Image zero(10, 10);
    Attribution az = attributeWorstPixels(zero, sc.reference, {StrategyImage{{}, "s0_t2.exr", Image(10, 10)}}, 1);
    CHECK(az.worst.at(0).techniques.empty());

    // A strategy image with a NaN inside the compared region is an error naming it; outside the
    // crop it does not matter.
    std::vector<StrategyImage> withNan = st;
    withNan[1].image.at(0, 9).y = std::numeric_limits<float>::quiet_NaN();
    CHECK_THROWS_WITH(attributeWorstPixels(sc.image, sc.reference, withNan, 1),
                      Contains(withNan[1].path) && Contains("non-finite value at pixel (0, 9)"));
    CHECK(attributeWorstPixels(sc.image, sc.reference, withNan, 1, 0.01, &crop).worst.at(0).x == 8);
}

TEST_CASE("Reading strategy images: missing folder, no images, unreadable or wrongly sized file", "[metrics][strategies]") {
    TempDir tmp;
    const std::string dir = tmp.file("strat");
    CHECK_THROWS_WITH(readStrategyImages(dir, 10, 10), Contains(dir) && Contains("not a directory"));
    fs::create_directories(dir);
    writeExr(Image(10, 10), dir + "/beauty.exr");
    CHECK_THROWS_WITH(readStrategyImages(dir, 10, 10), Contains(dir) && Contains("no strategy images"));
    FireflyScene().write(dir);
    writeExr(Image(10, 12), dir + "/s2_t2.exr");
    CHECK_THROWS_WITH(readStrategyImages(dir, 10, 10), Contains(dir + "/s2_t2.exr") && Contains("10x12") && Contains("10x10"));
    {
        std::FILE* f = std::fopen((dir + "/s2_t2.exr").c_str(), "wb");
        REQUIRE(f);
        std::fputs("not an exr", f);
        std::fclose(f);
    }
    CHECK_THROWS_WITH(readStrategyImages(dir, 10, 10), Contains(dir + "/s2_t2.exr"));
}

TEST_CASE("imgcompare prints the metrics and uses the documented exit codes", "[metrics][imgcompare]") {
    TempDir tmp;
    const std::string a = tmp.file("a.exr"), b = tmp.file("b.exr");
    writeExr(imageA(), a);
    writeExr(imageB(), b);

    SECTION("all metrics") {
        lt::test::Run r = runImgcompare(q(a) + " " + q(b));
        INFO(r.output);
        REQUIRE(r.code == 0);
        auto v = parseLines(r.output);
        // The tool prints shortest round-trip decimals, so parsing gives the double back exactly.
        CHECK(v.at("pixels") == 4);
        CHECK(v.at("mean_image") == Approx(kMeanA).epsilon(1e-14));
        CHECK(v.at("mean_reference") == Approx(kMeanB).epsilon(1e-14));
        CHECK(v.at("mse") == Approx(kMse).epsilon(1e-14));
        CHECK(v.at("relmse") == Approx(kRelMse).epsilon(1e-14));
        CHECK(v.at("relmse_eps") == 0.01);
        CHECK(v.at("rmsre") == Approx(kRmsRe).epsilon(1e-14));
        CHECK(v.at("mape") == Approx(kMape).epsilon(1e-14));
        CHECK(v.at("mape_eps") == 0.01);
        // Per-pixel errors 0, 3/1.01, 12/1.01, 0; the worst ceil(1% of 4) = 1 pixel carries 12/15.
        CHECK(v.at("relmse_top1_share") == Approx(0.8).epsilon(1e-14));
        CHECK(v.at("top_fraction") == 0.01);
        CHECK(v.at("top_pixels") == 1);
    }
    SECTION("top-1% share alone, and with another fraction") {
        lt::test::Run r = runImgcompare(q(a) + " " + q(b) + " --metric top1");
        INFO(r.output);
        REQUIRE(r.code == 0);
        auto v = parseLines(r.output);
        CHECK(v.size() == 3);
        CHECK(v.at("relmse_top1_share") == Approx(0.8).epsilon(1e-14));
        r = runImgcompare(q(a) + " " + q(b) + " --metric TOP1 --top-fraction 0.5");
        REQUIRE(r.code == 0);
        v = parseLines(r.output);
        CHECK(v.at("relmse_top1_share") == 1.0);  // the two pixels with error carry all of it
        CHECK(v.at("top_fraction") == 0.5);
        CHECK(v.at("top_pixels") == 2);
        // --metric mse prints no share.
        CHECK(runImgcompare(q(a) + " " + q(b) + " --metric mse").output.find("top1") == std::string::npos);
    }
    SECTION("single metric") {
        lt::test::Run r = runImgcompare(q(a) + " " + q(b) + " --metric mse");
        INFO(r.output);
        REQUIRE(r.code == 0);
        CHECK(r.output == "mse: 1.25\n");
        r = runImgcompare(q(a) + " " + q(b) + " --metric RMSRE");
        REQUIRE(r.code == 0);
        auto v = parseLines(r.output);
        CHECK(v.size() == 1);
        CHECK(v.at("rmsre") == Approx(kRmsRe).epsilon(1e-14));
        // Swapping A and B changes relMSE (normalised by the reference B): (1/4.01 + 4/9.01)/4.
        r = runImgcompare(q(b) + " " + q(a) + " --metric relmse");
        REQUIRE(r.code == 0);
        CHECK(parseLines(r.output).at("relmse") == Approx((1.0 / 4.01 + 4.0 / 9.01) / 4.0).epsilon(1e-14));
    }
    SECTION("crop") {
        // Only pixel (1,0): a = 2, b = 1.
        lt::test::Run r = runImgcompare(q(a) + " " + q(b) + " --crop 1,0,1,1");
        INFO(r.output);
        REQUIRE(r.code == 0);
        auto v = parseLines(r.output);
        CHECK(v.at("pixels") == 1);
        CHECK(v.at("mse") == 1.0);
        CHECK(v.at("rmsre") == Approx(std::sqrt(1.0 / 2.25)).epsilon(1e-14));
    }
    SECTION("json") {
        lt::test::Run r = runImgcompare(q(a) + " " + q(b) + " --json");
        INFO(r.output);
        REQUIRE(r.code == 0);
        CHECK_THAT(r.output, Contains("\"mse\": 1.25") && Contains("\"pixels\": 4") &&
                                 Contains("\"relmse_eps\": 0.01") && Contains("\"rmsre\": ") &&
                                 Contains("\"relmse_top1_share\": 0.8") && Contains("\"top_pixels\": 1"));
        CHECK(r.output.front() == '{');
        CHECK(r.output.substr(r.output.size() - 2) == "}\n");
    }
    SECTION("error map") {
        const std::string map = tmp.file("map.exr");
        lt::test::Run r = runImgcompare(q(a) + " " + q(b) + " --error-map " + q(map));
        INFO(r.output);
        REQUIRE(r.code == 0);
        Image got = readImage(map), want = errorMap(imageA(), imageB(), Metric::RelMse);  // default: relmse
        REQUIRE(got.width == 2);
        REQUIRE(got.height == 2);
        CHECK(got.pixels == want.pixels);
        const std::string mseMap = tmp.file("mse.pfm");
        r = runImgcompare(q(a) + " " + q(b) + " --metric mse --error-map " + q(mseMap));
        REQUIRE(r.code == 0);
        CHECK(readImage(mseMap).at(0, 1) == Color(4.f));
    }
    SECTION("image errors exit with 2 and name the file") {
        const std::string missing = tmp.file("missing.exr");
        lt::test::Run r = runImgcompare(q(a) + " " + q(missing));
        CHECK(r.code == 2);
        CHECK_THAT(r.output, Contains(missing));
        r = runImgcompare(q(missing) + " " + q(b));
        CHECK(r.code == 2);
        CHECK_THAT(r.output, Contains(missing));

        const std::string big = tmp.file("big.exr");
        writeExr(Image(3, 2), big);
        r = runImgcompare(q(a) + " " + q(big));
        CHECK(r.code == 2);
        CHECK_THAT(r.output, Contains(a) && Contains(big) && Contains("2x2") && Contains("3x2"));

        // A file with a NaN pixel, written by hand: our writers refuse non-finite values.
        const std::string nan = tmp.file("nan.pfm");
        Image n = imageA();
        n.at(1, 1).x = std::numeric_limits<float>::quiet_NaN();
        {
            std::ofstream f(nan, std::ios::binary);
            f << "PF\n" << n.width << ' ' << n.height << "\n-1.0\n";  // little endian, rows bottom-to-top
            for (int y = n.height - 1; y >= 0; --y)
                f.write(reinterpret_cast<const char*>(&n.at(0, y)), std::streamsize(sizeof(Color) * size_t(n.width)));
        }
        r = runImgcompare(q(nan) + " " + q(b));
        CHECK(r.code == 2);
        CHECK_THAT(r.output, Contains(nan) && Contains("(1, 1)"));

        r = runImgcompare(q(a) + " " + q(b) + " --error-map " + q(tmp.file("no/dir/map.exr")));
        CHECK(r.code == 2);
    }
    SECTION("usage errors exit with 1") {
        CHECK(runImgcompare(q(a) + " " + q(b) + " --bogus").code == 1);
        CHECK(runImgcompare(q(a) + " " + q(b) + " --metric psnr").code == 1);
        CHECK(runImgcompare(q(a)).code == 1);
        CHECK(runImgcompare(q(a) + " " + q(b) + " --crop 1,2,3").code == 1);
        CHECK(runImgcompare(q(a) + " " + q(b) + " --crop a,b,c,d").code == 1);
        CHECK(runImgcompare(q(a) + " " + q(b) + " --crop 1,1,2,2").code == 1);  // outside 2x2
        for (const char* bad : {"--top-fraction 0", "--top-fraction 1.5", "--top-fraction -0.1", "--top-fraction x",
                                "--strategies . --worst 0", "--strategies . --worst -2",
                                "--worst 3"}) {  // --worst needs --strategies
            lt::test::Run r = runImgcompare(q(a) + " " + q(b) + " " + bad);
            INFO(bad << ": " << r.output);
            CHECK(r.code == 1);
        }
    }
    SECTION("help documents every flag") {
        lt::test::Run r = runImgcompare("--help");
        INFO(r.output);
        CHECK(r.code == 0);
        for (const char* s : {"--metric", "--crop", "--error-map", "--json", "relmse", "rmsre", "mape", "eps = 0.01",
                              "top1", "relmse_top1_share", "--top-fraction", "--strategies", "--worst", "mean of R, G, B"})
            CHECK_THAT(r.output, Contains(s));
    }
}

TEST_CASE("imgcompare --strategies lists the worst pixels with their techniques", "[metrics][imgcompare][strategies]") {
    TempDir tmp;
    FireflyScene sc;
    const std::string dir = tmp.file("strat"), img = tmp.file("img.exr"), ref = tmp.file("ref.exr");
    sc.write(dir);
    writeExr(sc.image, img);
    writeExr(sc.reference, ref);

    SECTION("text output") {
        lt::test::Run r = runImgcompare(q(img) + " " + q(ref) + " --strategies " + q(dir) + " --worst 2");
        INFO(r.output);
        REQUIRE(r.code == 0);
        // Shares of the firefly's value 30.7: 30 (s0_t10), 0.5 (s1_t2), 0.2 (merge_s3).
        CHECK_THAT(r.output, Contains("worst 1: pixel (3, 4) ") && Contains(": 97.7% s0_t10, 1.6% s1_t2, 0.7% merge_s3\n"));
        CHECK_THAT(r.output, Contains("worst 2: pixel (8, 1) ") && Contains(": 58.8% s0_t10, 29.4% s1_t2, 11.8% merge_s3\n"));
        CHECK(r.output.find("worst 3:") == std::string::npos);
        CHECK_THAT(r.output, Contains("worst 1% of pixels (1 pixel): 97.7% s0_t10, 1.6% s1_t2, 0.7% merge_s3\n"));
        CHECK_THAT(r.output, Contains("strategies: " + dir + " (3 images; value = mean of R, G, B"));
        const size_t at = r.output.find("\nstrategy_sum_rel_diff: ");
        REQUIRE(at != std::string::npos);
        CHECK(std::stod(r.output.substr(at + 24)) < 1e-6);
        CHECK(r.output.find("warning") == std::string::npos);
        // Default --worst is 5; --top-fraction also sets the fraction of the technique shares.
        r = runImgcompare(q(img) + " " + q(ref) + " --metric mse --strategies " + q(dir) + " --top-fraction 0.02");
        REQUIRE(r.code == 0);
        CHECK_THAT(r.output, Contains("worst 5: pixel") && Contains("worst 2% of pixels (2 pixels): 95.7% s0_t10"));
        CHECK(r.output.find("worst 6:") == std::string::npos);
    }
    SECTION("json") {
        lt::test::Run r = runImgcompare(q(img) + " " + q(ref) + " --strategies " + q(dir) + " --worst 1 --json");
        INFO(r.output);
        REQUIRE(r.code == 0);
        CHECK_THAT(r.output, Contains("\"strategies\": {\"dir\": ") && Contains("\"images\": 3") &&
                                 Contains("\"value\": \"channel_mean\"") && Contains("\"x\": 3, \"y\": 4, ") &&
                                 Contains("\"techniques\": [{\"name\": \"s0_t10\", \"value\": 30, \"share\": 0.97") &&
                                 Contains("\"top_pixels\": 1, \"top_techniques\": [{\"name\": \"s0_t10\""));
        CHECK(r.output.find("\"y\": 1, ") == std::string::npos);  // --worst 1: only the firefly
    }
    SECTION("strategy images that do not sum to the image are flagged") {
        fs::remove(dir + "/s0_t10.exr");
        lt::test::Run r = runImgcompare(q(img) + " " + q(ref) + " --strategies " + q(dir));
        INFO(r.output);
        CHECK(r.code == 0);
        CHECK_THAT(r.output, Contains("warning") && Contains("strategy_sum_rel_diff"));
    }
    SECTION("a missing folder, a wrongly sized or unreadable strategy image: exit 2 naming it") {
        lt::test::Run r = runImgcompare(q(img) + " " + q(ref) + " --strategies " + q(tmp.file("nowhere")));
        CHECK(r.code == 2);
        CHECK_THAT(r.output, Contains(tmp.file("nowhere")));
        writeExr(Image(4, 4), dir + "/merge_s5.exr");
        r = runImgcompare(q(img) + " " + q(ref) + " --strategies " + q(dir));
        CHECK(r.code == 2);
        CHECK_THAT(r.output, Contains(dir + "/merge_s5.exr") && Contains("4x4"));
        {
            std::FILE* f = std::fopen((dir + "/merge_s5.exr").c_str(), "wb");
            REQUIRE(f);
            std::fputs("truncated", f);
            std::fclose(f);
        }
        r = runImgcompare(q(img) + " " + q(ref) + " --strategies " + q(dir));
        CHECK(r.code == 2);
        CHECK_THAT(r.output, Contains(dir + "/merge_s5.exr"));
    }
}
