// Render-comparison helpers shared by the integrator tests: a scene rendered quietly, the image
// mean, and K renders' block means compared by Welch's t (Sidak over the blocks).
#pragma once
#include <algorithm>
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

// K independent renders (seeds 1..K) -> per-block sample statistics.
inline std::vector<SampleStats> blockStats(const SceneDesc& d, RenderSettings s, int k, int blocks) {
    std::vector<std::vector<double>> perBlock(size_t(blocks) * blocks);
    for (int i = 0; i < k; ++i) {
        s.seed = 1000 + i;
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

}  // namespace lt::test
