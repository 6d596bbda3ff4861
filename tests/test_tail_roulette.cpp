// The regulariser's tail roulette (integrators/transport/regularizer.h (9), --reg-tail-rr): the
// routine by hand, and renders with and without it.
#include <catch2/catch.hpp>
#include <cmath>
#include "core/loader.h"
#include "integrators/integrator.h"
#include "integrators/transport/path.h"
#include "regularizer_paths.h"

using namespace lt;
using namespace lt::test;

TEST_CASE("Tail roulette keeps a connection with probability pi f over T and divides by it", "[regularizer]") {
    Technique tech;
    tech.s = 2;
    tech.t = 3;
    const Color contrib0(0.5f, 0.25f, 0.125f);
    const float T = 0.4f;
    // f with pi f = 0.1 at the camera end: q = 0.1 / 0.4 = 0.25.
    const Color f(0.1f / kPi);
    const Color diffuse(1.f / kPi);  // a white Lambertian: pi f = 1 >= T, kept
    // Every one of `trials` streams keeps the connection, its contribution unchanged.
    auto keptUnchanged = [&](float threshold, const Color& fCamera, const Color& fLight, int trials) {
        for (int i = 0; i < trials; ++i) {
            Color c = contrib0;
            CHECK(detail::tailRoulette(threshold, tech, fCamera, fLight, Rng::forSample(1, uint32_t(i), 0), c));
            CHECK(c == contrib0);
        }
    };
    SECTION("Ends the request did not make are never culled") { keptUnchanged(T, f, f, 100); }
    SECTION("Threshold 0 keeps everything unchanged") {
        tech.ratioCamera = kInf;
        keptUnchanged(0.f, f, f, 1);
    }
    SECTION("A probability that underflows (or under 1e-30) keeps the connection as it is") {
        tech.ratioCamera = kInf;
        keptUnchanged(1e6f, Color(1e-45f), diffuse, 1);
        keptUnchanged(1e6f, Color(1e-25f), diffuse, 1);  // (q ~ 3e-31: 1 / q would near FLT_MAX)
    }
    SECTION("A value at or above the threshold is kept as it is") {
        tech.ratioCamera = tech.ratioLight = kInf;
        keptUnchanged(T, diffuse, diffuse, 100);
    }
    SECTION("One regularised end: kept with q = 0.25 and divided by it") {
        // 20,000 trials: the kept fraction's standard deviation is sqrt(0.25 0.75 / 20000) = 0.0031;
        // the margin 0.01 is 3.3 of them (two-sided, about 1e-3).
        tech.ratioCamera = kInf;
        int kept = 0;
        const int n = 20000;
        for (int i = 0; i < n; ++i) {
            Color c = contrib0;
            if (detail::tailRoulette(T, tech, f, diffuse, Rng::forSample(7, uint32_t(i), 0), c)) {
                ++kept;
                CHECK(c.x == Approx(contrib0.x * 4.f).epsilon(1e-6));
                CHECK(c.z == Approx(contrib0.z * 4.f).epsilon(1e-6));
            }
        }
        CHECK(double(kept) / n == Approx(0.25).margin(0.01));
    }
    SECTION("Two regularised ends: q is the product, and the same stream gives the same answer") {
        tech.ratioCamera = tech.ratioLight = kInf;
        int kept = 0;
        const int n = 20000;
        for (int i = 0; i < n; ++i) {
            Color c = contrib0;
            const Rng rng = Rng::forSample(9, uint32_t(i), 0);
            const bool k = detail::tailRoulette(T, tech, f, Color(0.2f / kPi), rng, c);  // q = 0.25 * 0.5
            Color again = contrib0;
            CHECK(detail::tailRoulette(T, tech, f, Color(0.2f / kPi), rng, again) == k);
            if (k) {
                ++kept;
                CHECK(c.y == Approx(contrib0.y * 8.f).epsilon(1e-6));
            }
        }
        // sd sqrt(0.125 0.875 / 20000) = 0.0023; margin 3.3 of them.
        CHECK(double(kept) / n == Approx(0.125).margin(0.0077));
    }
}

namespace {

// Renders scene with `reg` at T = 0 and T = `threshold` (the same seed: the walks and every
// connection the roulette leaves alone are the same) and z-tests the mean of the per-pixel
// difference (the roulette's own noise only) against 0. Returns the rays of both renders.
std::pair<uint64_t, uint64_t> checkUnbiased(const Scene& scene, const std::string& integrator, const std::string& reg,
                                            double threshold, int spp) {
    RenderSettings s = settingsFor(integrator, spp);
    s.regularizer = reg;
    s.maxDepth = 8;
    s.regTailRr = 0.0;
    RenderStats a, b;
    const Image all = renderImage(scene, s, a);
    s.regTailRr = threshold;
    const Image culled = renderImage(scene, s, b);
    REQUIRE(all.pixels.size() == culled.pixels.size());
    const double n = double(all.pixels.size());
    double sum = 0.0, sum2 = 0.0, reference = 0.0;
    for (size_t i = 0; i < all.pixels.size(); ++i) {
        const Color d = culled.pixels[i] - all.pixels[i];
        const double v = double(d.x) + d.y + d.z;
        sum += v;
        sum2 += v * v;
        reference += double(all.pixels[i].x) + all.pixels[i].y + all.pixels[i].z;
    }
    const double mean = sum / n, sd = std::sqrt(std::max(0.0, sum2 / n - mean * mean));
    INFO(integrator << " --reg " << reg << " T " << threshold << ": mean difference " << mean << ", standard error "
                    << sd / std::sqrt(n) << ", image mean " << reference / n);
    // The pixels are independent samples of the difference (each its own walks and numbers):
    // two-sided z-test at 3.3 standard errors (significance about 1e-3).
    CHECK(std::abs(mean) <= 3.3 * sd / std::sqrt(n));
    CHECK(sd > 0.0);  // (the roulette ran: some pixel changed)
    return {a.rays, b.rays};
}

}  // namespace

TEST_CASE("Tail roulette leaves the regularised image unbiased and casts fewer rays", "[regularizer]") {
    // amber: a point light seen only through a glass block (L S D S E). OPSR and JG19 make the
    // glass rough for connections; at T = 20 nearly every such connection is put to the roulette
    // (pi f < 20 but near the lobe's peak), so the culled light is much of the regularised image:
    // without the division by q the mean falls by tens of standard errors (tried: see the
    // closing note of the session that added it).
    SceneDesc desc = loadScene(std::string(LT_SOURCE_DIR) + "/scenes/hard/amber.xml", {{"res", "48"}});
    Scene scene(desc);
    for (const auto& [integrator, reg] : {std::pair<std::string, std::string>{"pt", "opsr"}, {"pt", "jg19"},
                                          {"bpt", "jg19"}}) {
        const auto [all, culled] = checkUnbiased(scene, integrator, reg, 20.0, 64);
        INFO(integrator << " --reg " << reg << ": rays " << all << " -> " << culled);
        CHECK(culled < all);
    }
}

TEST_CASE("Tail roulette at threshold 0 is the render without it", "[regularizer]") {
    // T = 0 traces every connection: bit-identical to a threshold too small to cull anything.
    SceneDesc desc = loadScene(std::string(LT_SOURCE_DIR) + "/scenes/hard/amber.xml", {{"res", "24"}});
    Scene scene(desc);
    RenderSettings s = settingsFor("pt", 8);
    s.regularizer = "opsr";
    s.regTailRr = 0.0;
    RenderStats a, b, c;
    const Image zero = renderImage(scene, s, a);
    s.regTailRr = 1e-30;
    const Image tiny = renderImage(scene, s, b);
    CHECK(differingPixels(zero, tiny) == 0);
    CHECK(a.rays == b.rays);
    s.regTailRr = -1.0;  // the default, 0.1: it culls here
    const Image byDefault = renderImage(scene, s, c);
    CHECK(c.rays < a.rays);
    CHECK(differingPixels(zero, byDefault) > 0);
}
