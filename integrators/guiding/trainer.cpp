#include "integrators/guiding/trainer.h"
#include <algorithm>
#include <cmath>

namespace lt::guiding {

Trainer::Trainer(const GuidingSettings& settings, const Vec3& center, float halfSide, int width, int height,
                 uint64_t totalPasses, double timeLimit, uint64_t seed)
    : settings_(settings),
      tree_(center, halfSide, settings.tree, settings.fixedFraction),
      width_(width),
      height_(height),
      totalPasses_(totalPasses),
      timeLimit_(timeLimit),
      seed_(seed),
      start_(std::chrono::steady_clock::now()),
      sum_(size_t(width) * height, glm::dvec3(0.0)),
      sumSq_(size_t(width) * height, 0.0) {}

double Trainer::elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

WalkGuide Trainer::walkGuide() const {
    WalkGuide g;
    g.tree = &tree_;
    g.learnedFraction = settings_.learnedFraction;
    g.fixedFraction = settings_.fixedFraction;
    return g;
}

void Trainer::beginPass(uint32_t pass) {
    if (pass == 0) {
        start_ = std::chrono::steady_clock::now();
        // Iteration 0 (one pass, unguided: no tree has learned yet) trains where the budget has
        // room for it in its first half.
        training_ = totalPasses_ > 0 ? 2 <= totalPasses_ : timeLimit_ > 0.0;
        iterationLength_ = training_ ? 1 : 0;
        return;
    }
    if (iterationLength_ > 0 && pass == iterationStart_ + iterationLength_) endIteration();
}

void Trainer::endIteration() {
    const int k = iteration_;
    const double now = elapsed(), took = now - iterationStartTime_;
    if (training_) {
        tree_.endIteration(k, settings_.target == Target::Variance);
        trainingPasses_ += iterationLength_;
    }
    done_.push_back(current());
    // Rath's pixel estimate: the iterations so far, combined as the final image will be.
    const Image estimate = develop();
    double mean = 0.0;
    for (const Color& c : estimate.pixels) mean += (c.x + c.y + c.z) / 3.0;
    mean /= double(std::max<size_t>(1, estimate.pixels.size()));
    const float floor = std::max(float(0.01 * mean), 1e-20f);
    pixelEstimate_.assign(size_t(width_) * height_, 1.f);
    for (int y = 0; y < height_; ++y)
        for (int x = 0; x < width_; ++x) {
            double s = 0.0;
            int n = 0;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const int xx = x + dx, yy = y + dy;
                    if (xx < 0 || yy < 0 || xx >= width_ || yy >= height_) continue;
                    const Color& c = estimate.at(xx, yy);
                    s += (c.x + c.y + c.z) / 3.0;
                    ++n;
                }
            pixelEstimate_[size_t(y) * width_ + x] = std::max(float(s / n), floor);
        }
    std::fill(sum_.begin(), sum_.end(), glm::dvec3(0.0));
    std::fill(sumSq_.begin(), sumSq_.end(), 0.0);
    passesInIteration_ = 0;
    ++iteration_;
    iterationStart_ += iterationLength_;
    iterationStartTime_ = now;
    // The next iteration trains if it ends within the first half of the budget (its length
    // doubles, so does its time); else it is the final one and takes the rest.
    const uint64_t next = uint64_t(1) << std::min(iteration_, 40);
    if (!training_) {
        iterationLength_ = 0;
    } else if (totalPasses_ > 0) {
        training_ = 2 * (iterationStart_ + next) <= totalPasses_;
        iterationLength_ = training_ ? next : 0;
    } else {
        training_ = 2 * (now + 2.0 * took) <= timeLimit_;
        iterationLength_ = training_ ? next : 0;
    }
}

void Trainer::endPass(uint32_t) {
    ++passesInIteration_;
    if (!training_) {
        for (auto& b : buffers_) b.clear();
        return;
    }
    // Pixel order, then walk order within the pixel: a stable sort of the concatenation (each
    // pixel's records come from one sample, so from one buffer, in walk order).
    std::vector<std::pair<uint32_t, Record>> all;
    size_t n = 0;
    for (const auto& b : buffers_) n += b.size();
    all.reserve(n);
    for (auto& b : buffers_) {
        all.insert(all.end(), b.begin(), b.end());
        b.clear();
    }
    std::stable_sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<Record> records;
    records.reserve(all.size());
    for (const auto& r : all) records.push_back(r.second);
    tree_.addRecords({&records}, seed_ ^ (uint64_t(iterationStart_ + passesInIteration_) * 0x9e3779b97f4a7c15ull),
                     settings_.learnedFraction);
}

void Trainer::addSample(uint32_t pixel, const Color& c) {
    sum_[pixel] += glm::dvec3(c);
    const double m = (double(c.x) + c.y + c.z) / 3.0;
    sumSq_[pixel] += m * m;
}

Trainer::Iteration Trainer::current() const {
    Iteration it;
    it.passes = passesInIteration_;
    it.image = Image(width_, height_);
    if (it.passes == 0) return it;
    const double n = double(it.passes);
    double var = 0.0;
    for (size_t i = 0; i < sum_.size(); ++i) {
        const glm::dvec3 mean = sum_[i] / n;
        it.image.pixels[i] = Color(mean);
        if (it.passes >= 2) {
            const double m = (mean.x + mean.y + mean.z) / 3.0;
            var += std::max(0.0, (sumSq_[i] - n * m * m) / (n - 1.0)) / n;
        }
    }
    it.variance = it.passes >= 2 ? var / double(sum_.size()) : 0.0;
    return it;
}

Image Trainer::develop() const {
    const Iteration running = passesInIteration_ > 0 ? current() : Iteration{};
    std::vector<const Iteration*> its;
    for (const Iteration& it : done_) its.push_back(&it);
    if (running.passes > 0) its.push_back(&running);
    if (its.empty()) return Image(width_, height_);
    if (settings_.combine == Combine::Last) return its.back()->image;
    // Inverse-variance weights (Mueller 2019); an iteration of one pass has no variance estimate
    // and a zero estimate means a black image: both count as weighing like their passes would
    // at the least variance seen per pass.
    double bestPerPass = 0.0;  // the least variance * passes: the best estimate of one pass's variance
    for (const Iteration* it : its)
        if (it->passes >= 2 && it->variance > 0.0) {
            const double v = it->variance * double(it->passes);
            bestPerPass = bestPerPass > 0.0 ? std::min(bestPerPass, v) : v;
        }
    std::vector<double> w(its.size());
    double total = 0.0;
    for (size_t i = 0; i < its.size(); ++i) {
        const Iteration& it = *its[i];
        if (it.passes == 0) continue;
        const double var = it.passes >= 2 && it.variance > 0.0 ? it.variance
                           : bestPerPass > 0.0                 ? bestPerPass / double(it.passes)
                                                               : 1.0 / double(it.passes);
        w[i] = 1.0 / var;
        total += w[i];
    }
    Image out(width_, height_);
    for (size_t i = 0; i < its.size(); ++i) {
        if (!(w[i] > 0.0)) continue;
        const float wi = float(w[i] / total);
        for (size_t p = 0; p < out.pixels.size(); ++p) out.pixels[p] += its[i]->image.pixels[p] * wi;
    }
    return out;
}

std::string Trainer::state() const {
    ByteWriter w;
    w.put(uint32_t(0x47554944));  // "GUID"
    w.put(int32_t(width_));
    w.put(int32_t(height_));
    w.put(totalPasses_);
    w.put(int32_t(iteration_));
    w.put(uint8_t(training_));
    w.put(iterationStart_);
    w.put(iterationLength_);
    w.put(trainingPasses_);
    w.put(passesInIteration_);
    w.putVector(sum_);
    w.putVector(sumSq_);
    w.put(uint64_t(done_.size()));
    for (const Iteration& it : done_) {
        w.putVector(it.image.pixels);
        w.put(it.variance);
        w.put(it.passes);
    }
    w.putVector(pixelEstimate_);
    tree_.save(w);
    return std::move(w.out);
}

void Trainer::restore(const std::string& bytes) {
    ByteReader r(bytes);
    if (r.get<uint32_t>() != 0x47554944) throw std::runtime_error("not a guiding state");
    const int w = r.get<int32_t>(), h = r.get<int32_t>();
    if (w != width_ || h != height_) throw std::runtime_error("the guiding state is of another image size");
    if (r.get<uint64_t>() != totalPasses_)
        throw std::runtime_error("the guiding state is of a render to another sample count (its training schedule "
                                 "depends on --spp): resume it with the --spp it was started with");
    iteration_ = r.get<int32_t>();
    training_ = r.get<uint8_t>() != 0;
    iterationStart_ = r.get<uint64_t>();
    iterationLength_ = r.get<uint64_t>();
    trainingPasses_ = r.get<uint64_t>();
    passesInIteration_ = r.get<uint64_t>();
    sum_ = r.getVector<glm::dvec3>();
    sumSq_ = r.getVector<double>();
    const size_t pixels = size_t(width_) * height_;
    if (sum_.size() != pixels || sumSq_.size() != pixels) throw std::runtime_error("the guiding state is damaged");
    done_.clear();
    const uint64_t n = r.get<uint64_t>();
    for (uint64_t i = 0; i < n; ++i) {
        Iteration it;
        it.image = Image(width_, height_);
        it.image.pixels = r.getVector<Color>();
        if (it.image.pixels.size() != pixels) throw std::runtime_error("the guiding state is damaged");
        it.variance = r.get<double>();
        it.passes = r.get<uint64_t>();
        done_.push_back(std::move(it));
    }
    pixelEstimate_ = r.getVector<float>();
    if (!pixelEstimate_.empty() && pixelEstimate_.size() != pixels) throw std::runtime_error("the guiding state is damaged");
    tree_.load(r);
    if (r.p != r.end) throw std::runtime_error("the guiding state has trailing bytes");
}

}  // namespace lt::guiding
