// Training path guiding in iterations (Mueller et al. 2017, Sec. 5.1): iteration k renders 2^k
// passes and learns from the one before; training stops where the next iteration would take the
// render past half its budget (of passes with --spp, of time with --time), and the final
// iteration renders the rest without recording. The image combines the iterations (Mueller
// 2019: weighted by inverse variance, or the last alone). Records are gathered per thread and
// applied in pixel order, so trees and images do not depend on the thread count.
#pragma once
#include <chrono>
#include <cstdint>
#include <vector>
#include <tbb/enumerable_thread_specific.h>
#include "core/image.h"
#include "integrators/guiding/walk_guide.h"

namespace lt::guiding {

enum class Target { Radiance, Variance };  // PPG's incident radiance; Rath's Eq. 21 ("full")
enum class Combine { InverseVariance, Last };

struct GuidingSettings {
    Target target = Target::Variance;
    bool learnedFraction = false;
    float fixedFraction = 0.5f;
    Combine combine = Combine::InverseVariance;
    TreeSettings tree;
};

class Trainer {
public:
    // `totalPasses` 0: a time budget of `timeLimit` seconds (then `timeLimit` > 0).
    Trainer(const GuidingSettings& settings, const Vec3& center, float halfSide, int width, int height,
            uint64_t totalPasses, double timeLimit, uint64_t seed);

    // Before pass `pass` (0, 1, 2, ...): where an iteration ends, the tree learns from it and the
    // next one starts.
    void beginPass(uint32_t pass);
    // After the pass's tiles: applies its records (training iterations only).
    void endPass(uint32_t pass);
    bool training() const { return training_; }
    const GuidingSettings& settings() const { return settings_; }
    const SDTree& tree() const { return tree_; }
    WalkGuide walkGuide() const;

    // Rath's pixel estimate I~ of `pixel` (mean of RGB; the iterations so far, box-filtered over
    // 3x3 pixels, floored at 1% of the image's mean; 1 before the first iteration ends).
    float pixelEstimate(uint32_t pixel) const { return pixelEstimate_.empty() ? 1.f : pixelEstimate_[pixel]; }
    // The calling thread's record buffer for this pass (pixel, record).
    std::vector<std::pair<uint32_t, Record>>& buffer() { return buffers_.local(); }
    // A valid camera sample of `pixel` in this pass (one per pixel per pass).
    void addSample(uint32_t pixel, const Color& c);

    // The combined image of the passes so far.
    Image develop() const;
    int iterations() const { return iteration_ + 1; }
    // Checkpoints (between passes): the tree, the schedule, the iterations' images and sums and
    // the pixel estimate. restore() throws std::runtime_error where the bytes are not a state of
    // this render (another image size, cube or sample count: the schedule depends on --spp).
    std::string state() const;
    void restore(const std::string& bytes);
    uint64_t trainingPasses() const { return trainingPasses_; }

private:
    struct Iteration {
        Image image;
        double variance = 0.0;  // mean over pixels of the variance of the iteration's pixel mean
        uint64_t passes = 0;
    };
    void endIteration();
    Iteration current() const;
    double elapsed() const;

    GuidingSettings settings_;
    SDTree tree_;
    int width_, height_;
    uint64_t totalPasses_;
    double timeLimit_;
    uint64_t seed_;
    std::chrono::steady_clock::time_point start_;
    int iteration_ = 0;
    bool training_ = false;
    uint64_t iterationStart_ = 0, iterationLength_ = 0;  // passes (length 0: until the budget ends)
    double iterationStartTime_ = 0.0;
    uint64_t trainingPasses_ = 0;
    // The running iteration's per-pixel sums: RGB, and the square of the channel mean.
    std::vector<glm::dvec3> sum_;
    std::vector<double> sumSq_;
    uint64_t passesInIteration_ = 0;
    std::vector<Iteration> done_;
    std::vector<float> pixelEstimate_;
    tbb::enumerable_thread_specific<std::vector<std::pair<uint32_t, Record>>> buffers_;
};

}  // namespace lt::guiding
