#include "integrators/guiding/trainer.h"
#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

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
      sum_(size_t(width) * height),
      sumSq_(size_t(width) * height) {}

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
        if (started_) return;
        started_ = true;
        start_ = std::chrono::steady_clock::now();
        // Iteration 0 (one pass, unguided: no tree has learned yet) trains where the budget has
        // room for it in its first half.
        training_ = totalPasses_ > 0 ? 2 <= totalPasses_ : timeLimit_ > 0.0;
        iterationLength_ = training_ ? 1 : 0;
        return;
    }
    if (iterationLength_ > 0 && pass == iterationStart_ + iterationLength_) endIteration();
}

bool Trainer::schedulesTraining(double now, double took) const {
    // The next iteration trains if it ends within the first half of the budget (its length
    // doubles, so does its time); else it is the final one and takes the rest.
    if (!training_) return false;
    if (totalPasses_ > 0) return 2 * (iterationStart_ + iterationLength_ + (uint64_t(1) << std::min(iteration_ + 1, 40))) <= totalPasses_;
    return 2 * (now + 2.0 * took) <= timeLimit_;
}

bool Trainer::nextIterationTrains() const {
    const double now = elapsed();
    return schedulesTraining(now, now - iterationStartTime_);
}

void Trainer::decideNextIteration(bool trains) {
    if (totalPasses_ > 0 && trains != schedulesTraining(0.0, 0.0))
        throw std::invalid_argument("guiding: with a pass budget the training schedule is fixed by it, not decided");
    decidedNext_ = trains;
}

void Trainer::endIteration() {
    const int k = iteration_;
    const double now = elapsed(), took = now - iterationStartTime_;
    const bool nextTrains = decidedNext_ ? *decidedNext_ && training_ : schedulesTraining(now, took);
    decidedNext_.reset();
    if (defer_ && training_) {
        // Every pass's records applied and every rank's sums added (the sequence in trainer.h).
        if (nextRecordPass_ != iterationStart_ + iterationLength_ || !deferred_.empty() || !pending_.empty())
            throw std::logic_error("guiding: a training iteration ended before every pass's records were applied");
        if (passesInIteration_ != iterationLength_)
            throw std::logic_error("guiding: a training iteration ended without every pass's sums");
    }
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
    std::fill(sum_.begin(), sum_.end(), ExactColorSum{});
    std::fill(sumSq_.begin(), sumSq_.end(), ExactDoubleSum{});
    passesInIteration_ = 0;
    ++iteration_;
    iterationStart_ += iterationLength_;
    iterationStartTime_ = now;
    training_ = nextTrains;
    iterationLength_ = training_ ? uint64_t(1) << std::min(iteration_, 40) : 0;
    nextRecordPass_ = iterationStart_;
}

void Trainer::endPass(uint32_t pass) {
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
    if (defer_) {
        if (!deferred_.emplace(pass, std::move(records)).second)
            throw std::logic_error("guiding: pass " + std::to_string(pass) + " ended twice");
        return;
    }
    applyPass(pass, records);
}

void Trainer::applyPass(uint64_t pass, const std::vector<Record>& records) {
    // The seed is a function of the pass index alone (pass + 1: what the single process's count
    // iterationStart + passesInIteration has always been there), so whichever rank rendered the
    // pass, its filters draw the same numbers.
    tree_.addRecords({&records}, seed_ ^ ((pass + 1) * 0x9e3779b97f4a7c15ull), settings_.learnedFraction);
    nextRecordPass_ = pass + 1;
}

namespace {

constexpr uint32_t kDeferredMagic = 0x47524543;  // "CERG": a rank's kept passes
constexpr uint32_t kSumsMagic = 0x474d5553;      // "SUMG": a rank's iteration sums
// A record's bytes: p, d, value, product, bsdfPdf, guidePdf, mixturePdf (11 floats) and learnFraction.
constexpr size_t kRecordBytes = 11 * sizeof(float) + 1;

void putRecord(std::string& out, const Record& r) {
    const float f[11] = {r.p.x, r.p.y, r.p.z, r.d.x, r.d.y, r.d.z, r.value, r.product, r.bsdfPdf, r.guidePdf, r.mixturePdf};
    out.append(reinterpret_cast<const char*>(f), sizeof(f));
    out.push_back(char(r.learnFraction ? 1 : 0));
}

Record getRecord(const char* p) {
    float f[11];
    std::memcpy(f, p, sizeof(f));
    Record r;
    r.p = Vec3(f[0], f[1], f[2]);
    r.d = Vec3(f[3], f[4], f[5]);
    r.value = f[6];
    r.product = f[7];
    r.bsdfPdf = f[8];
    r.guidePdf = f[9];
    r.mixturePdf = f[10];
    r.learnFraction = p[sizeof(f)] != 0;
    return r;
}

}  // namespace

std::string Trainer::takeDeferred() {
    ByteWriter w;
    w.put(kDeferredMagic);
    w.put(uint64_t(deferred_.size()));
    size_t bytes = w.out.size();
    for (const auto& [pass, records] : deferred_) bytes += 2 * sizeof(uint64_t) + records.size() * kRecordBytes;
    w.out.reserve(bytes);
    for (const auto& [pass, records] : deferred_) {
        w.put(uint64_t(pass));
        w.put(uint64_t(records.size()));
        for (const Record& r : records) putRecord(w.out, r);
    }
    deferred_.clear();
    return std::move(w.out);
}

void Trainer::applyDeferred(const std::vector<std::string>& parts) {
    // Read and check everything first, so that bad input changes nothing.
    std::map<uint64_t, std::vector<Record>> in;
    const uint64_t end = iterationLength_ > 0 ? iterationStart_ + iterationLength_ : 0;
    for (const std::string& part : parts) {
        ByteReader r(part);
        if (r.get<uint32_t>() != kDeferredMagic) throw std::runtime_error("guiding: not the records of a rank");
        const uint64_t n = r.get<uint64_t>();
        for (uint64_t i = 0; i < n; ++i) {
            const uint64_t pass = r.get<uint64_t>(), count = r.get<uint64_t>();
            if (count > uint64_t(r.end - r.p) / kRecordBytes) throw std::runtime_error("guiding: the records are truncated");
            if (!training_ || pass < nextRecordPass_ || pass >= end)
                throw std::logic_error("guiding: records of pass " + std::to_string(pass) +
                                       ", which is not a pass of the running training iteration still to apply");
            if (pending_.count(pass) || in.count(pass))
                throw std::logic_error("guiding: the records of pass " + std::to_string(pass) + " were given twice");
            std::vector<Record>& v = in[pass];
            v.reserve(count);
            for (uint64_t j = 0; j < count; ++j, r.p += kRecordBytes) v.push_back(getRecord(r.p));
        }
        if (r.p != r.end) throw std::runtime_error("guiding: the records have trailing bytes");
    }
    pending_.merge(in);
    // In pass order, as far as the passes are contiguous.
    for (auto it = pending_.begin(); it != pending_.end() && it->first == nextRecordPass_; it = pending_.erase(it))
        applyPass(it->first, it->second);
}

namespace {

struct SumsHeader {
    uint32_t magic;
    int32_t width, height, iteration;
    uint64_t passes;
};

}  // namespace

std::string Trainer::iterationSums() const {
    ByteWriter w;
    w.put(SumsHeader{kSumsMagic, int32_t(width_), int32_t(height_), int32_t(iteration_), passesInIteration_});
    w.putVector(sum_);
    w.putVector(sumSq_);
    return std::move(w.out);
}

std::string Trainer::takeIterationSums() {
    std::string out = iterationSums();
    std::fill(sum_.begin(), sum_.end(), ExactColorSum{});
    std::fill(sumSq_.begin(), sumSq_.end(), ExactDoubleSum{});
    passesInIteration_ = 0;
    return out;
}

void Trainer::addIterationSums(const std::string& bytes) {
    ByteReader r(bytes);
    const SumsHeader h = r.get<SumsHeader>();
    if (h.magic != kSumsMagic) throw std::runtime_error("guiding: not the iteration sums of a rank");
    if (h.width != width_ || h.height != height_) throw std::runtime_error("guiding: iteration sums of another image size");
    if (h.iteration != iteration_) throw std::runtime_error("guiding: iteration sums of another iteration");
    const std::vector<ExactColorSum> sum = r.getVector<ExactColorSum>();
    const std::vector<ExactDoubleSum> sumSq = r.getVector<ExactDoubleSum>();
    if (sum.size() != sum_.size() || sumSq.size() != sumSq_.size() || r.p != r.end)
        throw std::runtime_error("guiding: the iteration sums are damaged");
    for (size_t i = 0; i < sum_.size(); ++i) {
        sum_[i].add(sum[i]);
        sumSq_[i].add(sumSq[i]);
    }
    passesInIteration_ += h.passes;
}

void Trainer::addSample(uint32_t pixel, const Color& c) {
    // (The film accepts only samples its exact sums hold; the same bound holds here.)
    if (!ExactColorSum::representable(c)) return;
    sum_[pixel].add(c);
    const double m = (double(c.x) + c.y + c.z) / 3.0;
    sumSq_[pixel].add(m * m);
}

Trainer::Iteration Trainer::current() const {
    Iteration it;
    it.passes = passesInIteration_;
    it.image = Image(width_, height_);
    if (it.passes == 0) return it;
    const double n = double(it.passes);
    double var = 0.0;
    for (size_t i = 0; i < sum_.size(); ++i) {
        const glm::dvec3 mean = sum_[i].value() / n;
        it.image.pixels[i] = Color(mean);
        if (it.passes >= 2) {
            const double m = (mean.x + mean.y + mean.z) / 3.0;
            var += std::max(0.0, (sumSq_[i].value() - n * m * m) / (n - 1.0)) / n;
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

namespace {
constexpr uint32_t kStateMagic = 0x32495547;     // "GUI2": exact sums, sampling fractions
constexpr uint32_t kOldStateMagic = 0x47554944;  // the state before them
}  // namespace

std::string Trainer::state() const {
    if (!deferred_.empty() || !pending_.empty())
        throw std::logic_error("guiding: a state with records kept back (apply every rank's records first)");
    ByteWriter w;
    w.put(kStateMagic);
    w.put(int32_t(width_));
    w.put(int32_t(height_));
    w.put(totalPasses_);
    w.put(int32_t(iteration_));
    w.put(uint8_t(training_));
    w.put(iterationStart_);
    w.put(iterationLength_);
    w.put(trainingPasses_);
    w.put(passesInIteration_);
    w.put(nextRecordPass_);
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
    const uint32_t magic = r.get<uint32_t>();
    if (magic == kOldStateMagic)
        throw std::runtime_error("the guiding state is of an earlier version of this program: start the render again");
    if (magic != kStateMagic) throw std::runtime_error("not a guiding state");
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
    nextRecordPass_ = r.get<uint64_t>();
    sum_ = r.getVector<ExactColorSum>();
    sumSq_ = r.getVector<ExactDoubleSum>();
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
    started_ = true;
    deferred_.clear();
    pending_.clear();
    decidedNext_.reset();
}

}  // namespace lt::guiding
