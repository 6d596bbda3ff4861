// Mitsuba 3's per-pixel z-test (tools/ztest.h, imgcompare --ztest): its statistic, its Sidak level,
// the variance floor, the 0.9975 pass rule, and the command line's exit codes.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <string>

#include "core/image.h"
#include "process.h"
#include "tools/ztest.h"

using namespace lt;

namespace {

// A w x h reference with values in [0.2, 1.2) and a grey per-sample variance v.
struct Fixture {
    Image ref, var;
    Fixture(int w, int h, float v) : ref(w, h), var(w, h, Color(v)) {
        std::mt19937 rng(7);
        std::uniform_real_distribution<float> u(0.2f, 1.2f);
        for (Color& c : ref.pixels) c = Color(u(rng), u(rng), u(rng));
    }
};

// Shifts pixel (x, y) of img by k standard errors of the Y channel (grey shift d: XYZ moves by d
// times the matrix's row sums, Y by exactly d; the grey variance v gives var(Y) = v).
void shiftPixel(Image& img, int x, int y, double k, double v, long spp) {
    img.at(x, y) += Color(float(k * std::sqrt(v / double(spp))));
}

}  // namespace

TEST_CASE("ztest: the Sidak level is one minus 0.99 to the power one over the pixel count", "[ztest]") {
    CHECK(ztest::sidakLevel(0.01, 1.0) == Approx(0.01).epsilon(1e-12));
    for (double n : {2.0, 64.0, 48.0 * 48.0, 512.0 * 64.0, 1e6}) {
        INFO("pixels " << n);
        // The formula as written, in long double (its cancellation costs digits at large n).
        const long double ln = n;
        CHECK(ztest::sidakLevel(0.01, n) == Approx(double(1.0L - std::pow(0.99L, 1.0L / ln))).epsilon(1e-9));
        CHECK(ztest::sidakLevel(0.05, n) == Approx(double(1.0L - std::pow(0.95L, 1.0L / ln))).epsilon(1e-9));
    }
    // 48 x 48, the size of most of Mitsuba's test scenes: alpha = 4.362e-6 (|z| > 4.59 fails).
    CHECK(ztest::sidakLevel(0.01, 2304.0) == Approx(4.3621e-6).epsilon(1e-4));
    // The run reports the level of its pixel count.
    Fixture f(8, 4, 0.01f);
    ztest::Settings s;
    s.spp = 16;
    CHECK(ztest::run(f.ref, f.ref, f.var, s).alpha == Approx(1.0 - std::pow(0.99, 1.0 / 32.0)).epsilon(1e-12));
    // Mitsuba's sample budget: spp = 2e6 // pixels.
    CHECK(ztest::mitsubaSpp(48 * 48) == 868);
    CHECK(ztest::mitsubaSpp(512 * 64) == 61);
}

TEST_CASE("ztest: the two-sided p-value of a standard normal statistic", "[ztest]") {
    CHECK(ztest::twoSidedPValue(0.0) == Approx(1.0));
    CHECK(ztest::twoSidedPValue(1.959963984540054) == Approx(0.05).epsilon(1e-9));
    CHECK(ztest::twoSidedPValue(-2.5758293035489) == Approx(0.01).epsilon(1e-9));
    CHECK(ztest::twoSidedPValue(10.0) == Approx(1.5239706e-23).epsilon(1e-6));
}

TEST_CASE("ztest: an image equal to its reference passes", "[ztest]") {
    Fixture f(16, 16, 0.02f);
    ztest::Settings s;
    s.spp = 100;
    ztest::Result r = ztest::run(f.ref, f.ref, f.var, s);
    CHECK(r.pass);
    CHECK(r.pixels == 256);
    CHECK(r.values == 768);
    CHECK(r.failingValues == 0);
    CHECK(r.failingPixels == 0);
    CHECK(r.minPValue == 1.0);
    CHECK(r.maxZ == 0.0);
}

TEST_CASE("ztest: a pixel 10 standard errors off fails and one 2 off does not", "[ztest]") {
    const double v = 0.04;
    const long spp = 64;
    ztest::Settings s;
    s.spp = spp;
    SECTION("8 x 8: one failing value is more than 0.25% of the values, the image fails") {
        Fixture f(8, 8, float(v));
        Image img = f.ref;
        shiftPixel(img, 3, 5, 10.0, v, spp);
        ztest::Result r = ztest::run(img, f.ref, f.var, s);
        CHECK_FALSE(r.pass);
        CHECK(r.failingPixels == 1);
        CHECK(r.failingValues == 3);  // X, Y and Z all move by about 10 standard errors
        CHECK(r.minX == 3);
        CHECK(r.minY == 5);
        CHECK(r.maxZ == Approx(10.0 * std::sqrt(1.088754)).epsilon(1e-4));  // Z: row sum 1.088754
        CHECK(r.minPValue < r.alpha);

        Image small = f.ref;
        shiftPixel(small, 3, 5, 2.0, v, spp);
        ztest::Result ok = ztest::run(small, f.ref, f.var, s);
        CHECK(ok.pass);
        CHECK(ok.failingValues == 0);
        CHECK(ok.minPValue > ok.alpha);
    }
    SECTION("32 x 32: one failing pixel is within the 0.25% Mitsuba tolerates") {
        Fixture f(32, 32, float(v));
        Image img = f.ref;
        shiftPixel(img, 0, 31, 10.0, v, spp);
        ztest::Result r = ztest::run(img, f.ref, f.var, s);
        CHECK(r.failingPixels == 1);
        CHECK(r.allowedFailingValues == Approx(3 * 1024 * 0.0025));
        CHECK(r.pass);
        // ... but not 3 pixels (9 values > 7.68).
        shiftPixel(img, 10, 10, 10.0, v, spp);
        shiftPixel(img, 20, 10, -10.0, v, spp);
        CHECK_FALSE(ztest::run(img, f.ref, f.var, s).pass);
    }
    SECTION("a whole image 1 standard error off everywhere fails only when many pixels exceed the level") {
        Fixture f(16, 16, float(v));
        Image img = f.ref;
        for (int y = 0; y < 16; ++y)
            for (int x = 0; x < 16; ++x) shiftPixel(img, x, y, 1.0, v, spp);
        CHECK(ztest::run(img, f.ref, f.var, s).pass);  // a per-pixel test: a bias of 1 SE is invisible to it
    }
}

TEST_CASE("ztest: the variance is floored at 1e-4 and tested in XYZ", "[ztest]") {
    ztest::Settings s;
    s.spp = 100;  // standard error with the floor: sqrt(1e-4 / 100) = 1e-3
    Image ref(4, 4, Color(0.5f)), zero(4, 4, Color(0.f));
    Image img = ref;
    img.at(1, 1) += Color(0.002f);  // 2 floor standard errors: passes although the variance is 0
    CHECK(ztest::run(img, ref, zero, s).failingValues == 0);
    img.at(1, 1) += Color(0.008f);  // 10: fails
    CHECK(ztest::run(img, ref, zero, s).failingValues == 3);
    // A variance file's RGB is xyz_to_srgb of the XYZ variance and may be negative: converted back
    // it is the XYZ variance. RGB (-0.1, 0.3, -0.05) gives X = 0.0249, Y = 0.1862, Z = -0.0133 (floor).
    Image var(4, 4, Color(-0.1f, 0.3f, -0.05f));
    double xyz[3];
    ztest::rgbToXyz(var.at(0, 0), xyz);
    CHECK(xyz[0] == Approx(0.412453 * -0.1 + 0.357580 * 0.3 + 0.180423 * -0.05));
    CHECK(xyz[1] == Approx(0.212671 * -0.1 + 0.715160 * 0.3 + 0.072169 * -0.05));
    CHECK(xyz[2] == Approx(0.019334 * -0.1 + 0.119193 * 0.3 + 0.950227 * -0.05));
}

TEST_CASE("ztest: a NaN in the image under test fails its values", "[ztest]") {
    Fixture f(4, 4, 0.01f);
    Image img = f.ref;
    img.at(2, 2).y = std::nanf("");
    ztest::Settings s;
    s.spp = 10;
    Image p;
    ztest::Result r = ztest::run(img, f.ref, f.var, s, nullptr, &p);
    CHECK(r.nonFiniteValues == 3);  // G enters X, Y and Z
    CHECK(p.at(2, 2) == Color(0.f));  // the p-value map stays finite (the image writers refuse NaN)
    CHECK(r.failingValues == 3);
    CHECK_FALSE(r.pass);
}

TEST_CASE("ztest: imgcompare --ztest exits 0 on pass and 3 on reject", "[ztest][cli]") {
    test::TempDir dir("lt_ztest");
    const double v = 0.04;
    const long spp = 64;
    Fixture f(8, 8, float(v));
    Image shifted = f.ref;
    shiftPixel(shifted, 4, 4, 10.0, v, spp);
    writeExr(f.ref, dir.file("ref.exr"));
    writeExr(f.var, dir.file("var.exr"));
    writeExr(shifted, dir.file("shifted.exr"));
    const std::string bin = std::string("'") + LT_IMGCOMPARE_BIN + "' ";
    auto run = [&](const std::string& a, const std::string& extra) {
        return test::sh(bin + dir.file(a) + " " + dir.file("ref.exr") + " --ztest --ref-var " + dir.file("var.exr") +
                        " --spp " + std::to_string(spp) + " " + extra);
    };
    test::Run same = run("ref.exr", "");
    INFO(same.output);
    CHECK(same.code == 0);
    CHECK(same.output.find("ztest_result: pass") != std::string::npos);
    CHECK(same.output.find("ztest_failing_values: 0") != std::string::npos);

    test::Run bad = run("shifted.exr", "--pvalue-map " + dir.file("p.exr"));
    INFO(bad.output);
    CHECK(bad.code == 3);
    CHECK(bad.output.find("ztest_result: fail") != std::string::npos);
    CHECK(bad.output.find("ztest_failing_pixels: 1") != std::string::npos);
    CHECK(bad.output.find("ztest_min_pvalue_at: pixel (4, 4)") != std::string::npos);
    Image p = readImage(dir.file("p.exr"));
    CHECK(p.at(4, 4).y < 1e-20f);
    CHECK(p.at(0, 0).y == 1.0f);

    test::Run json = run("shifted.exr", "--json");
    CHECK(json.code == 3);
    CHECK(json.output.find("\"ztest_pass\": false") != std::string::npos);

    // Usage errors: exit 1.
    CHECK(test::sh(bin + dir.file("ref.exr") + " " + dir.file("ref.exr") + " --ztest").code == 1);
    CHECK(test::sh(bin + dir.file("ref.exr") + " " + dir.file("ref.exr") + " --spp 4").code == 1);
    CHECK(run("ref.exr", "--significance 1.5").code == 1);
    CHECK(run("ref.exr", "--metric mse").code == 1);
    CHECK(run("ref.exr", "--error-map " + dir.file("e.exr")).code == 1);
    CHECK(run("ref.exr", "--strategies " + dir.file("s")).code == 1);
    // A missing variance file: exit 2.
    CHECK(test::sh(bin + dir.file("ref.exr") + " " + dir.file("ref.exr") + " --ztest --spp 4 --ref-var " +
                   dir.file("missing.exr"))
              .code == 2);
}
