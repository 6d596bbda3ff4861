// Per-technique images for debugging and for the regularisers' diagnostics (--strategy-images):
// connections (s, t) as s{s}_t{t}.exr (s = 0: the emitter hit; t = 1: light tracing), merges by
// the number of light vertices s = i + 1 as merge_s{s}.exr, and under a regulariser
// regularised.exr, the part of the image whose own technique evaluated a regularised BSDF, and
// singular.exr, the part no unregularised technique can produce (singularPath, path.h: a point
// light seen through glass), which an unregularised reference lacks. Each technique's image is
// its MIS-weighted contribution, so those sum to the render (PT, BPT, VCM, LT, PPM alike). The
// sums are exact (core/exact_sum.h): the images do not depend on the order of the additions, so
// on neither the thread count nor the MPI ranks.
#pragma once
#include <cstdint>
#include <mutex>
#include <string>
#include <vector>
#include "core/exact_sum.h"
#include "core/math.h"

namespace lt {

namespace dist {
class Cluster;
}

class StrategyImages {
public:
    // maxLen: the longest subpath in vertices after the endpoint (s and t up to maxLen + 1).
    StrategyImages(int width, int height, int maxLen);
    // Thread-safe (a lock per call: a debugging aid, simplicity over speed). A contribution the
    // exact sums cannot hold (negative, NaN, 2^62 or more: Film::addSample refuses such samples)
    // is left out.
    void add(bool isMerge, int s, int t, uint32_t pixel, const Color& c, bool regularised, bool singular);
    // Several ranks: this process's sums as bytes, zeroed here; addState adds such bytes (throws
    // std::runtime_error for the sums of another image size or depth).
    std::string takeState();
    void addState(const std::string& bytes);
    // The images divided by `passes` (the samples per pixel), into `dir` (created).
    void write(const std::string& dir, uint64_t passes) const;

private:
    int w_, h_, maxLen_;
    std::mutex m_;
    using Sums = std::vector<ExactColorSum>;  // (empty: nothing added yet)
    std::vector<Sums*> all();                 // every image, in a fixed order
    std::vector<Sums> conn_, merge_;
    Sums regularised_, singular_;
};

// Several ranks (Integrator::shareSegment, before a checkpoint or the render's end): every rank's
// images added into rank 0's; the other ranks' are zeroed (collective).
void gatherOnRoot(StrategyImages& images, dist::Cluster& cluster);

}  // namespace lt
