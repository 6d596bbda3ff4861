#include "core/film.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace lt {

namespace {
constexpr int kGaussianBins = 4096;
}

Film::Film(int width, int height, FilterType filter, float gaussianStddev)
    : width_(width), height_(height), filter_(filter), sum_(size_t(width) * height),
      count_(size_t(width) * height, 0u), splat_(size_t(width) * height) {
    if (filter_ != FilterType::Gaussian) return;
    // Mitsuba's gaussian rfilter: radius 4 stddev, the value at the radius subtracted so that it
    // falls to 0 there. Its CDF by the trapezoid rule on a fine grid (the density is smooth).
    const double s = gaussianStddev, r = 4.0 * s, a = -1.0 / (2.0 * s * s), bias = std::exp(a * r * r);
    gaussianRadius_ = float(r);
    auto f = [&](double x) { return std::max(0.0, std::exp(a * x * x) - bias); };
    std::vector<double> cdf(kGaussianBins + 1, 0.0);
    const double h = 2.0 * r / kGaussianBins;
    for (int i = 0; i < kGaussianBins; ++i) cdf[i + 1] = cdf[i] + 0.5 * h * (f(-r + i * h) + f(-r + (i + 1) * h));
    gaussianCdf_.resize(cdf.size());
    for (size_t i = 0; i < cdf.size(); ++i) gaussianCdf_[i] = float(cdf[i] / cdf.back());
}

// The offset whose CDF is u, linear between the table's points.
float Film::sampleGaussian(float u) const {
    const auto it = std::upper_bound(gaussianCdf_.begin(), gaussianCdf_.end(), u);
    const int i = std::clamp(int(it - gaussianCdf_.begin()) - 1, 0, kGaussianBins - 1);
    const float c0 = gaussianCdf_[size_t(i)], c1 = gaussianCdf_[size_t(i) + 1];
    const float t = c1 > c0 ? std::clamp((u - c0) / (c1 - c0), 0.f, 1.f) : 0.5f;
    return gaussianRadius_ * (-1.f + 2.f * (float(i) + t) / float(kGaussianBins));
}

static float sampleTent(float u) {  // density 1 - |x| on [-1, 1]
    if (u < 0.5f) return -1.f + std::sqrt(2.f * u);
    return 1.f - std::sqrt(2.f - 2.f * u);
}

Vec2 Film::samplePixelOffset(const Vec2& u) const {
    if (filter_ == FilterType::Tent) return Vec2(0.5f + sampleTent(u.x), 0.5f + sampleTent(u.y));
    if (filter_ == FilterType::Gaussian) return Vec2(0.5f + sampleGaussian(u.x), 0.5f + sampleGaussian(u.y));
    return u;
}

bool Film::addSample(int x, int y, const Color& c) {
    if (!valid(c)) {
        ++invalid_;
        return false;
    }
    sum_[size_t(y) * width_ + x].add(c);
    return true;
}

bool Film::splat(SplatBuffer& buf, const Vec2& raster, const Color& c, uint16_t strategyS, bool regularised,
                 bool singular) {
    if (!valid(c)) {
        ++invalid_;
        return false;
    }
    int x = std::clamp(int(raster.x), 0, width_ - 1), y = std::clamp(int(raster.y), 0, height_ - 1);
    buf.splats.push_back({uint32_t(size_t(y) * width_ + x), c, strategyS, regularised, singular});
    return true;
}

// Layout: the camera sums, the sample counts, the splat sums (native byte order, as the sums are
// held), then the invalid count.
std::string Film::state() const {
    const size_t n = sum_.size();
    std::string out;
    out.resize(stateBytes());
    char* p = out.data();
    std::memcpy(p, sum_.data(), n * sizeof(ExactColorSum)), p += n * sizeof(ExactColorSum);
    std::memcpy(p, count_.data(), n * sizeof(uint32_t)), p += n * sizeof(uint32_t);
    std::memcpy(p, splat_.data(), n * sizeof(ExactColorSum)), p += n * sizeof(ExactColorSum);
    const uint64_t invalid = invalid_.load();
    std::memcpy(p, &invalid, sizeof invalid);
    return out;
}

void Film::checkStateSize(const std::string& bytes) const {
    if (bytes.size() != stateBytes())
        throw std::runtime_error("the saved film is not one of " + std::to_string(width_) + "x" +
                                 std::to_string(height_) + " (" + std::to_string(bytes.size()) + " bytes, expected " +
                                 std::to_string(stateBytes()) + ")");
}

void Film::restore(const std::string& bytes) {
    checkStateSize(bytes);
    const size_t n = sum_.size();
    const char* p = bytes.data();
    std::memcpy(sum_.data(), p, n * sizeof(ExactColorSum)), p += n * sizeof(ExactColorSum);
    std::memcpy(count_.data(), p, n * sizeof(uint32_t)), p += n * sizeof(uint32_t);
    std::memcpy(splat_.data(), p, n * sizeof(ExactColorSum)), p += n * sizeof(ExactColorSum);
    uint64_t invalid = 0;
    std::memcpy(&invalid, p, sizeof invalid);
    invalid_ = invalid;
}

void Film::addState(const std::string& bytes) {
    checkStateSize(bytes);
    const size_t n = sum_.size();
    const char* p = bytes.data();
    auto addSums = [&](std::vector<ExactColorSum>& sums) {
        for (size_t i = 0; i < n; ++i, p += sizeof(ExactColorSum)) {
            ExactColorSum s;
            std::memcpy(&s, p, sizeof s);
            sums[i].add(s);
        }
    };
    addSums(sum_);
    for (size_t i = 0; i < n; ++i, p += sizeof(uint32_t)) {
        uint32_t c;
        std::memcpy(&c, p, sizeof c);
        count_[i] += c;
    }
    addSums(splat_);
    uint64_t invalid = 0;
    std::memcpy(&invalid, p, sizeof invalid);
    invalid_ += invalid;
}

void Film::mergeSplats(const SplatBuffer& buf) {
    for (const auto& s : buf.splats) splat_[s.pixel].add(s.value);
}

Image Film::develop(uint64_t splatPasses) const {
    Image img(width_, height_);
    double inv = splatPasses > 0 ? 1.0 / double(splatPasses) : 0.0;
    for (size_t i = 0; i < sum_.size(); ++i) {
        glm::dvec3 v = count_[i] > 0 ? sum_[i].value() / double(count_[i]) : glm::dvec3(0.0);
        v += splat_[i].value() * inv;
        img.pixels[i] = Color(v);
    }
    return img;
}

}  // namespace lt
