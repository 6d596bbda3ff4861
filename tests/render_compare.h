// Render-comparison helpers shared by the integrator tests: a scene rendered quietly, the image
// mean, and K renders' block means compared by Welch's t (Sidak over the blocks).
#pragma once
#include <catch2/catch.hpp>
#include <algorithm>
#include <initializer_list>
#include <string>
#include <vector>
#include "integrators/integrator.h"
#include "stats.h"

namespace lt::test {

inline Image renderDesc(const SceneDesc& d, RenderSettings s, RenderStats* statsOut = nullptr) {
    Scene scene(d);
    RenderStats stats;
    s.quiet = true;
    Image img = renderImage(scene, s, stats);
    if (statsOut) *statsOut = stats;
    return img;
}

inline double imageMean(const Image& img) {
    double m = 0;
    for (const Color& c : img.pixels) m += (double(c.x) + c.y + c.z) / 3.0;
    return m / double(img.pixels.size());
}

// K independent renders (seeds seed0 .. seed0 + K - 1) -> per-block sample statistics.
inline std::vector<SampleStats> blockStats(const SceneDesc& d, RenderSettings s, int k, int blocks,
                                           uint64_t seed0 = 1000) {
    std::vector<std::vector<double>> perBlock(size_t(blocks) * blocks);
    for (int i = 0; i < k; ++i) {
        s.seed = seed0 + uint64_t(i);
        auto m = blockMeans(renderDesc(d, s), blocks, blocks);
        for (size_t b = 0; b < m.size(); ++b) perBlock[b].push_back(m[b]);
    }
    std::vector<SampleStats> out;
    for (auto& v : perBlock) out.push_back(sampleStats(v));
    return out;
}

// Number of blocks whose means differ at family-wise significance alpha (Sidak over all blocks).
inline int differingBlocks(const std::vector<SampleStats>& a, const std::vector<SampleStats>& b, double alpha,
                           double* worst = nullptr) {
    double perTest = sidak(alpha, int(a.size()));
    int bad = 0;
    double w = 0;
    for (size_t i = 0; i < a.size(); ++i) {
        double df;
        double t = welchT(a[i], b[i], df);
        double crit = studentTCritical(perTest, std::max(df, 1.0));
        w = std::max(w, std::abs(t) / crit);
        if (std::abs(t) > crit) ++bad;
    }
    if (worst) *worst = w;
    return bad;
}

// The agreement test of the integrator suites: PT's K renders in blocks x blocks block means (s as
// given: spp, max depth), and each of `others` ("bpt", "lt", "vcm") against them by Welch's t, no
// block differing at family-wise significance alpha per integrator (Sidak over the blocks). LT
// takes twice the samples (its image is noisier); VCM a vanishing radius, so that its merges carry
// ~no weight and its other techniques are tested. Returns PT's statistics (for a test's own check
// that a broken variant does differ).
inline std::vector<SampleStats> checkAgreesWithPt(const SceneDesc& d, RenderSettings s,
                                                  std::initializer_list<const char*> others, int k = 10,
                                                  int blocks = 4, double alpha = 0.01) {
    s.integrator = "pt";
    const auto pt = blockStats(d, s, k, blocks);
    for (const std::string integ : others) {
        RenderSettings si = s;
        si.integrator = integ;
        if (integ == "lt") si.spp = 2 * s.spp;
        if (integ == "vcm") si.radius = 1e-6f;
        double worst = 0.0;
        const int bad = differingBlocks(pt, blockStats(d, si, k, blocks), alpha, &worst);
        INFO(integ << " vs pt: " << bad << " blocks differ, worst |t|/crit " << worst);
        CHECK(bad == 0);
    }
    return pt;
}

}  // namespace lt::test
