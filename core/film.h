// Film: per-pixel accumulation of camera samples (box filter over the pixel; the tent and
// Gaussian filters are realised by filter importance sampling of the pixel offset, so every sample
// stays in its own pixel's sum), plus a deterministic splat path for light tracing, which splats
// into the pixel it lands in (a box filter: with tent or Gaussian, light tracing's image is the
// box-filtered one). The sums are exact (core/exact_sum.h): the same samples added in any order,
// by any threads or MPI ranks, give the same bits. Invalid samples (NaN, Inf, negative, or
// >= 2^62, beyond what the exact sum holds) are rejected and counted, never accumulated.
#pragma once
#include <atomic>
#include <string>
#include <vector>
#include "core/exact_sum.h"
#include "core/image.h"
#include "core/scene_desc.h"

namespace lt {

// Splats collected by one fixed chunk of work; merged into the film in chunk order, so the
// result does not depend on which thread ran which chunk.
struct SplatBuffer {
    // strategyS: light vertices, regularised: the technique evaluated a regularised BSDF,
    // singular: no unregularised technique can produce the path (debug images)
    struct Splat { uint32_t pixel; Color value; uint16_t strategyS; bool regularised, singular; };
    std::vector<Splat> splats;
    void clear() { splats.clear(); }
};

class Film {
public:
    // What the film keeps of a pixel (two exact RGB sums and a sample count), and the most pixels
    // a scene may ask for (8192 x 8192, 6.7 GB of film; the loader refuses more before allocating).
    static constexpr size_t kBytesPerPixel = 2 * sizeof(ExactColorSum) + sizeof(uint32_t);
    static constexpr int64_t kMaxPixels = int64_t(1) << 26;

    Film(int width, int height, FilterType filter, float gaussianStddev = 0.5f);
    int width() const { return width_; }
    int height() const { return height_; }

    // Offset in pixel units of a camera sample inside/around its pixel, from u in [0,1)^2.
    // Box: u itself. Tent (radius 1 px): x = 0.5 + tent(u). Gaussian: x = 0.5 + a sample of
    // Mitsuba's gaussian, exp(-x^2 / (2 s^2)) - exp(-r^2 / (2 s^2)) on [-r, r], r = 4 s, per axis
    // (a tabulated inverse CDF).
    Vec2 samplePixelOffset(const Vec2& u) const;

    // Thread-safe as long as no two threads write the same pixel (tiles are disjoint).
    // Returns false (and counts) for a NaN/Inf/negative sample or one >= 2^62.
    bool addSample(int x, int y, const Color& c);
    // Sample counts are kept per pixel (a pixel may get more samples in --time mode).
    void addSampleCount(int x, int y, uint32_t n) { count_[size_t(y) * width_ + x] += n; }

    // Thread-safe: records a light-tracing splat into the caller's buffer (rejects invalid values).
    bool splat(SplatBuffer& buf, const Vec2& raster, const Color& c, uint16_t strategyS = 0, bool regularised = false,
               bool singular = false);
    // Merge buffers (call in a fixed order). Splats are summed and divided by the number of
    // splat passes given to develop().
    void mergeSplats(const SplatBuffer& buf);

    // Camera-sample average + splat sum / splatPasses.
    Image develop(uint64_t splatPasses) const;

    uint64_t invalidSamples() const { return invalid_.load(); }
    void countInvalid(uint64_t n = 1) { invalid_ += n; }

    // The accumulated state (sums, counts, splats, invalid count) as bytes, for checkpoints, and
    // back: restore() throws std::runtime_error when the bytes are not a film of this size.
    std::string state() const;
    void restore(const std::string& bytes);
    // Adds another film's state (same size, else std::runtime_error) to this one, exactly: films
    // that rendered disjoint sets of passes add up to the bytes of one film that rendered them all.
    void addState(const std::string& bytes);

private:
    bool valid(const Color& c) const { return ExactColorSum::representable(c); }
    size_t stateBytes() const { return sum_.size() * kBytesPerPixel + sizeof(uint64_t); }
    void checkStateSize(const std::string& bytes) const;
    int width_, height_;
    FilterType filter_;
    std::vector<float> gaussianCdf_;  // the Gaussian's CDF at kGaussianBins + 1 equal steps over [-r, r]
    float gaussianRadius_ = 0.f;
    float sampleGaussian(float u) const;
    std::vector<ExactColorSum> sum_;  // camera samples
    std::vector<uint32_t> count_;
    std::vector<ExactColorSum> splat_;  // light-tracing splats
    std::atomic<uint64_t> invalid_{0};
};

}  // namespace lt
