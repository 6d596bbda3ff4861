// Training path guiding in iterations (Mueller et al. 2017, Sec. 5.1): iteration k renders 2^k
// passes and learns from the one before; training stops where the next iteration would take the
// render past half its budget (of passes with --spp, of time with --time), and the final
// iteration renders the rest without recording. The image combines the iterations (Mueller
// 2019: weighted by inverse variance, or the last alone). Records are gathered per thread and
// applied in pixel order, so trees and images do not depend on the thread count.
//
// Several MPI ranks (issue 48). Every pass of an iteration samples with the tree (and the BSDF
// fractions, GuideLeaf::samplingFraction) of the iteration's start, so ranks may render any passes
// of one iteration in parallel. What makes the next tree the single process's: each pass's records
// are applied in pass order with a seed that is a function of the pass index (records are
// order-dependent: the stochastic filters' streams count records, Adam steps in order), and the
// iteration's per-pixel sums are exact (core/exact_sum.h, exact_double_sum.h), so ranks add their
// partial sums in any order. With deferRecords(true) endPass keeps a pass's records; the ranks
// exchange them (takeDeferred, applyDeferred) and their sums (takeIterationSums,
// addIterationSums) at the iteration's end; rank 0 decides what depends on its clock
// (nextIterationTrains, decideNextIteration). The call sequence: the comment above deferRecords.
#pragma once
#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>
#include <tbb/enumerable_thread_specific.h>
#include "core/exact_sum.h"
#include "core/image.h"
#include "integrators/guiding/exact_double_sum.h"
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

    // Before pass `pass` (0, 1, 2, ...): pass 0 starts the schedule (once: a second call does
    // nothing); pass iterationEnd() ends the running iteration (the tree learns from it, the next
    // one starts); any other pass changes nothing. So calling it twice for a pass, or for a pass
    // this process does not render, is harmless.
    void beginPass(uint32_t pass);
    // After the pass's tiles: applies its records (training iterations only; deferred: keeps them),
    // seeded by the pass index.
    void endPass(uint32_t pass);
    // The first pass of the next iteration (where beginPass ends the running one), or UINT64_MAX
    // while the running iteration is the final one (it lasts until the budget ends). Valid after
    // beginPass(0) or restore().
    uint64_t iterationEnd() const { return iterationLength_ > 0 ? iterationStart_ + iterationLength_ : UINT64_MAX; }
    bool training() const { return training_; }

    // --- Several ranks. The render loop, with N > 1 ranks, every rank with its own Trainer:
    //  1. deferRecords(true) on every rank, then beginPass(0) on every rank.
    //  2. A segment: passes [P, E), E = min(budget, iterationEnd()), handed out on demand; each
    //     rank runs beginPass(p), the tiles (buffer(), addSample), endPass(p) for its passes.
    //     (Optionally, to bound memory: takeDeferred() after each pass and applyDeferred() whatever
    //     has arrived; it applies the passes as soon as they are contiguous.)
    //  3. Where E == iterationEnd() (a training iteration ends), on every rank:
    //     a. parts = every rank's takeDeferred() (an allgather); applyDeferred(parts). (Or, as
    //        path_tracer.h does, each pass's bytes broadcast and applied in pass order.)
    //     b. the sums: the other ranks' takeIterationSums() added on rank 0 (addIterationSums, in
    //        any order or any reduction tree: the sums are exact), then rank 0's iterationSums()
    //        broadcast and added by every other rank (theirs were taken: they now hold the total).
    //        Every rank needs the total: the pixel estimate of the next iteration comes from it.
    //     c. with a time budget: rank 0's nextIterationTrains() broadcast, decideNextIteration(it)
    //        on every rank (rank 0 too). With --spp the schedule is a function of the pass count.
    //     d. beginPass(E) on every rank (whether or not it renders E).
    //  4. A checkpoint at P inside an iteration (all passes < P done): 3a on every rank, and the
    //     other ranks' takeIterationSums() added on rank 0; rank 0's state() is the single
    //     process's after P passes (resumable with any N). At the render's end (the final
    //     iteration): the other ranks' takeIterationSums() added on rank 0, which then develops.
    // The deferred checks throw std::logic_error where the sequence is broken (a pass missing or
    // given twice, an iteration ended without every pass's records or sums, a state() with
    // records kept back).
    void deferRecords(bool on) { defer_ = on; }
    // The passes kept since the last call (each with its records, sorted as endPass sorts them),
    // as bytes; they are dropped here. Empty passes are included (every pass must be applied).
    std::string takeDeferred();
    // Takes every rank's takeDeferred() bytes (in any order; its own included) and applies, in
    // pass order, every pass from the first not yet applied on for which it has the records, as
    // the single process's endPass would (same seed, order and learned-fraction steps). Passes
    // beyond a missing one wait for it. Throws std::logic_error for a pass already applied or
    // given twice, or one outside the running training iteration; std::runtime_error for bytes
    // that are not parts of this render.
    void applyDeferred(const std::vector<std::string>& parts);
    // The running iteration's sums (per-pixel RGB and squared channel mean, exact, and the pass
    // count) as bytes; take... also zeroes them here. addIterationSums adds such bytes exactly
    // (throws std::runtime_error for another image size or iteration).
    std::string iterationSums() const;
    std::string takeIterationSums();
    void addIterationSums(const std::string& bytes);
    // With a time budget: whether the next iteration trains if the running one ends now (by this
    // process's clock; rank 0's decides). decideNextIteration(t) makes the next iteration end
    // (beginPass(iterationEnd())) use t instead of the clock; with --spp the schedule decides and
    // a t that disagrees with it throws std::invalid_argument.
    bool nextIterationTrains() const;
    void decideNextIteration(bool trains);
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
    bool schedulesTraining(double now, double took) const;
    void applyPass(uint64_t pass, const std::vector<Record>& records);

    GuidingSettings settings_;
    SDTree tree_;
    int width_, height_;
    uint64_t totalPasses_;
    double timeLimit_;
    uint64_t seed_;
    std::chrono::steady_clock::time_point start_;
    int iteration_ = 0;
    bool started_ = false;
    bool training_ = false;
    uint64_t iterationStart_ = 0, iterationLength_ = 0;  // passes (length 0: until the budget ends)
    double iterationStartTime_ = 0.0;
    uint64_t trainingPasses_ = 0;
    // The running iteration's per-pixel sums (exact, so partial sums of ranks add up to the
    // bits of one sum): RGB, and the square of the channel mean (in double, as the variance
    // estimate subtracts n mean^2 from it).
    std::vector<ExactColorSum> sum_;
    std::vector<ExactDoubleSum> sumSq_;
    uint64_t passesInIteration_ = 0;
    // Records: the first pass of the training iteration whose records are not applied yet; with
    // defer_, the passes this process rendered and kept (takeDeferred) and the passes received
    // that wait for an earlier one (applyDeferred).
    bool defer_ = false;
    uint64_t nextRecordPass_ = 0;
    std::map<uint64_t, std::vector<Record>> deferred_, pending_;
    std::optional<bool> decidedNext_;  // decideNextIteration
    std::vector<Iteration> done_;
    std::vector<float> pixelEstimate_;
    tbb::enumerable_thread_specific<std::vector<std::pair<uint32_t, Record>>> buffers_;
};

}  // namespace lt::guiding
