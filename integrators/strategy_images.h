// Per-technique images for debugging and for the regularisers' diagnostics (--strategy-images):
// connections (s, t) as s{s}_t{t}.exr (s = 0: the emitter hit; t = 1: light tracing), merges by
// the number of light vertices s = i + 1 as merge_s{s}.exr, and under a regulariser
// regularised.exr, the part of the image whose own technique evaluated a regularised BSDF, and
// singular.exr, the part no unregularised technique can produce (singularPath, path.h: a point
// light seen through glass), which an unregularised reference lacks. Each technique's image is
// its MIS-weighted contribution, so those sum to the render (PT, BPT, VCM, LT, PPM alike).
#pragma once
#include <cstdint>
#include <mutex>
#include <string>
#include <vector>
#include "core/math.h"

namespace lt {

class StrategyImages {
public:
    // maxLen: the longest subpath in vertices after the endpoint (s and t up to maxLen + 1).
    StrategyImages(int width, int height, int maxLen);
    // Thread-safe (a lock per call: a debugging aid, simplicity over speed).
    void add(bool isMerge, int s, int t, uint32_t pixel, const Color& c, bool regularised, bool singular);
    // The images divided by `passes` (the samples per pixel), into `dir` (created).
    void write(const std::string& dir, uint64_t passes) const;

private:
    int w_, h_, maxLen_;
    std::mutex m_;
    std::vector<std::vector<glm::dvec3>> conn_, merge_;
    std::vector<glm::dvec3> regularised_, singular_;
};

}  // namespace lt
