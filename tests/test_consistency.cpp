// Consistency of vertex merging on a specular-diffuse-specular scene (tests/data/sds): a point
// light inside a glass sphere, its caustic on a diffuse floor seen through a mirror. PT and BPT
// cannot sample these paths at all; VCM's and PPM's error against a converged reference must
// fall as iterations double.
#include <catch2/catch.hpp>
#include "core/loader.h"
#include "core/metrics.h"
#include "integrators/integrator.h"

using namespace lt;

namespace {

const std::string kScene = std::string(LT_SOURCE_DIR) + "/tests/data/sds/sds.xml";

// relMSE against the reference after 2^k iterations (k = 2..8), from one progressive render.
std::vector<std::pair<double, double>> errorCurve(const std::string& integrator, uint64_t seed) {
    SceneDesc d = loadScene(kScene, {{"res", "24"}});
    Scene scene(d);
    Image ref = readImage(std::string(LT_SOURCE_DIR) + "/tests/data/sds/reference.exr");
    RenderSettings s;
    s.integrator = integrator;
    s.spp = 256;
    s.seed = seed;
    s.maxDepth = d.integrator.maxDepth;
    s.radius = d.integrator.radius;
    s.quiet = true;
    std::vector<std::pair<double, double>> curve;
    RenderStats st;
    renderImage(scene, s, st, [&](const Progress& p) {
        uint64_t n = p.passesDone;
        if (n >= 4 && (n & (n - 1)) == 0)
            curve.emplace_back(double(n), computeMetrics(p.film->develop(n), ref).relMse);
    });
    return curve;
}

double slope(const std::vector<std::pair<double, double>>& c) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (auto [x, y] : c) {
        double lx = std::log(x), ly = std::log(y);
        sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly;
    }
    double n = double(c.size());
    return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

}  // namespace

TEST_CASE("VCM and PPM converge on an S-D-S scene as the radius shrinks", "[vcm][consistency]") {
    // The reference is VCM after 32768 iterations (scripts/make-sds-reference.sh). With
    // r_i = r_0 i^-1/8 (alpha = 0.75) the expected relMSE slope is about -0.75 before the
    // reference's own error (~1/128 of the error at 256 iterations by the same law) matters.
    // Thresholds: slope below -0.3 and a 4x smaller error at 256 than at 4 iterations, on each
    // of two seeds. A method whose error stalls (bias that does not shrink) has slope ~0.
    for (std::string integ : {"vcm", "ppm"})
        for (uint64_t seed : {11, 12}) {
            auto c = errorCurve(integ, seed);
            REQUIRE(c.size() == 7);
            double k = slope(c);
            INFO(integ << " seed " << seed << ": slope " << k << ", relMSE " << c.front().second << " -> "
                       << c.back().second);
            CHECK(k < -0.3);
            CHECK(c.back().second * 4 < c.front().second);
        }
}

TEST_CASE("PT and BPT cannot sample the S-D-S paths (black), VCM can", "[vcm][consistency]") {
    SceneDesc d = loadScene(kScene, {{"res", "16"}});
    Scene scene(d);
    for (std::string integ : {"pt", "bpt", "lt", "vcm"}) {
        RenderSettings s;
        s.integrator = integ;
        s.spp = 4;
        s.radius = d.integrator.radius;
        s.quiet = true;
        RenderStats st;
        Image img = renderImage(scene, s, st);
        double sum = 0;
        for (const Color& c : img.pixels) sum += c.x + c.y + c.z;
        INFO(integ);
        if (integ == "vcm") CHECK(sum > 0.0);
        else CHECK(sum == 0.0);
    }
}
