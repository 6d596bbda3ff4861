// Mueller et al. 2017's SD-tree (Sec. 3, 5.2, 5.4) with the learned BSDF fraction of Mueller
// et al. 2019 / Rath et al. 2020 (Sec. 5.2). See sd_tree.h.
#include "integrators/guiding/sd_tree.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/rng.h"

namespace lt::guiding {

namespace {

constexpr int kMaxSpatialDepth = 48;  // below this a float cube can no longer be halved usefully
constexpr float kBelowOne = 0x1.fffffep-1f;
// Random-number domains of a record's two filters (Rng::forSample(seed, record index, 0, domain)).
constexpr uint64_t kSpatialFilterDomain = 0x5ba7;
constexpr uint64_t kDirectionalFilterDomain = 0xd12e;

Vec3 clampInto(const Vec3& p, const Vec3& lo, const Vec3& hi) {
    // fmin/fmax: a NaN coordinate goes to the bound.
    return Vec3(std::fmin(std::fmax(p.x, lo.x), hi.x), std::fmin(std::fmax(p.y, lo.y), hi.y),
                std::fmin(std::fmax(p.z, lo.z), hi.z));
}

// Heap and inline bytes of one leaf (its trees' bytes() include their inline part).
// floor(u 2^16) for u in [0, 1] (1 and above give 2^16 - 1): the first 16 binary digits of u.
uint64_t unitBits16(float u) { return uint64_t(std::min(u, kBelowOne) * 65536.f); }

// The 16 low bits of x spread to every third bit (bit i to bit 3i).
uint64_t spread3(uint64_t x) {
    x &= 0xffff;
    x = (x | (x << 16)) & 0xff0000ff;
    x = (x | (x << 8)) & 0xf00f00f00f;
    x = (x | (x << 4)) & 0x0c30c30c30c3;
    x = (x | (x << 2)) & 0x249249249249;
    return x;
}

size_t leafBytes(const GuideLeaf& l) {
    return sizeof(GuideLeaf) - 2 * sizeof(DirectionalTree) + l.sampling.bytes() + l.building.bytes();
}

double sigmoid(double x) { return 1.0 / (1.0 + std::exp(-x)); }

// alpha = minFraction + (1 - minFraction) sigmoid(theta).
float fractionOf(double theta, double minFraction) { return float(minFraction + (1.0 - minFraction) * sigmoid(theta)); }

// One Adam step on theta for one record (Mueller et al. 2019's KL gradient; the record's product
// already carries Rath's weight f / I~, Eq. 27). The KL divergence D(p_zv || p_eff) has, for one
// direction drawn with density p_mix, the gradient estimate
//   dD/dalpha = -(f / p_mix) (p_bsdf - p_guide) / p_eff,  p_eff = alpha p_bsdf + (1 - alpha) p_guide,
// at the current alpha(theta); dalpha/dtheta = (1 - minFraction) s (1 - s), s = sigmoid(theta);
// plus the l2 term l2 theta. Returns false (state untouched) for a record it cannot use.
bool adamStep(GuideLeaf& leaf, const Record& r, const TreeSettings& st) {
    const double f = r.product, pb = r.bsdfPdf, pg = r.guidePdf, pm = r.mixturePdf;
    if (!std::isfinite(f) || !std::isfinite(pb) || !std::isfinite(pg) || !std::isfinite(pm)) return false;
    if (!(pm > 0.0) || f < 0.0 || pb < 0.0 || pg < 0.0) return false;
    const double minF = st.minFraction, theta = leaf.theta;
    const double s = sigmoid(theta);
    const double alpha = minF + (1.0 - minF) * s;
    const double pEff = alpha * pb + (1.0 - alpha) * pg;
    if (!(pEff > 0.0)) return false;
    const double dAlpha = -(f / pm) * (pb - pg) / pEff;
    double g = dAlpha * (1.0 - minF) * s * (1.0 - s) + double(st.l2) * theta;
    if (!std::isfinite(g)) return false;
    // Adam's moments are stored in float: |g| <= 1e15 keeps v (~g^2) finite. Adam's step is
    // invariant to the gradient's scale, so this only tames outliers beyond it.
    g = std::clamp(g, -1e15, 1e15);
    constexpr double beta1 = 0.9, beta2 = 0.999, eps = 1e-8;
    leaf.adamSteps += 1;
    const double m = beta1 * leaf.adamM + (1.0 - beta1) * g;
    const double v = beta2 * leaf.adamV + (1.0 - beta2) * g * g;
    const double t = double(leaf.adamSteps);
    const double mHat = m / (1.0 - std::pow(beta1, t)), vHat = v / (1.0 - std::pow(beta2, t));
    leaf.adamM = float(m);
    leaf.adamV = float(v);
    leaf.theta = float(std::clamp(theta - double(st.learningRate) * mHat / (std::sqrt(vHat) + eps), -20.0, 20.0));
    return true;
}

}  // namespace

SDTree::SDTree(const Vec3& center, float halfSide, const TreeSettings& settings, float fixedFraction)
    : settings_(settings), lo_(center - Vec3(halfSide)), hi_(center + Vec3(halfSide)) {
    nodes_.emplace_back();
    leaves_.push_back(std::make_unique<GuideLeaf>());
    leaves_[0]->bsdfFraction = leaves_[0]->samplingFraction = fixedFraction;
}

uint32_t SDTree::findNode(const Vec3& p, Vec3& lo, Vec3& hi) const {
    lo = lo_;
    hi = hi_;
    const Vec3 q = clampInto(p, lo_, hi_);
    uint32_t n = 0;
    while (nodes_[n].child[0]) {
        const int a = nodes_[n].axis;
        const float mid = 0.5f * (lo[a] + hi[a]);
        if (q[a] < mid) {
            hi[a] = mid;
            n = nodes_[n].child[0];
        } else {
            lo[a] = mid;
            n = nodes_[n].child[1];
        }
    }
    return n;
}

const GuideLeaf& SDTree::leaf(const Vec3& p) const {
    // The descent of findNode in the cube's unit coordinates: the axis at depth d is d mod 3 and a
    // coordinate is halved once per 3 levels, so the branch taken at depth d is bit d of the
    // Morton code of the coordinates' 16-bit binary expansions (kMaxSpatialDepth = 3 * 16), read
    // from the top. One key per look-up; each level is then a shift and a node load.
    static_assert(kMaxSpatialDepth == 3 * 16);
    const Vec3 u = (clampInto(p, lo_, hi_) - lo_) / (hi_ - lo_);
    const uint64_t key = (spread3(unitBits16(u.x)) << 2) | (spread3(unitBits16(u.y)) << 1) | spread3(unitBits16(u.z));
    uint32_t n = 0;
    for (int shift = kMaxSpatialDepth - 1; nodes_[n].child[0]; --shift) n = nodes_[n].child[(key >> shift) & 1];
    return *leaves_[nodes_[n].leaf];
}

Vec3 SDTree::leafSize(const Vec3& p) const {
    Vec3 lo, hi;
    findNode(p, lo, hi);
    return hi - lo;
}

void SDTree::addRecords(const std::vector<const std::vector<Record>*>& batches, uint64_t seed, bool learnFraction) {
    std::vector<const Record*> records;
    for (const std::vector<Record>* b : batches)
        if (b)
            for (const Record& r : *b) records.push_back(&r);
    const size_t n = records.size();
    if (n == 0) return;

    // Spatial filter: each record's position jittered over a box the size of its leaf (the
    // index i counts records across batches; each record has its own stream, so this is
    // independent of the partition).
    std::vector<uint32_t> leafOf(n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t i = range.begin(); i != range.end(); ++i) {
            Rng rng = Rng::forSample(seed, i, 0, kSpatialFilterDomain);
            Vec3 lo, hi;
            const Vec3 p = records[i]->p;
            findNode(p, lo, hi);
            const float ux = rng.uniform(), uy = rng.uniform(), uz = rng.uniform();
            const Vec3 jittered = p + (Vec3(ux, uy, uz) - Vec3(0.5f)) * (hi - lo);
            leafOf[i] = nodes_[findNode(jittered, lo, hi)].leaf;
        }
    });

    // Records grouped by leaf, in their given order (counting sort).
    std::vector<size_t> start(leaves_.size() + 1, 0);
    for (uint32_t l : leafOf) ++start[l + 1];
    for (size_t l = 0; l < leaves_.size(); ++l) start[l + 1] += start[l];
    std::vector<uint32_t> order(n);
    {
        std::vector<size_t> cursor(start.begin(), start.end() - 1);
        for (size_t i = 0; i < n; ++i) order[cursor[leafOf[i]]++] = uint32_t(i);
    }
    std::vector<uint32_t> active;
    for (size_t l = 0; l < leaves_.size(); ++l)
        if (start[l + 1] > start[l]) active.push_back(uint32_t(l));

    // Per leaf, in record order: directional filter (the record's direction jittered over a
    // square the size of the building tree's leaf there, phi wrapping around), record, Adam.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, active.size(), 1), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t a = range.begin(); a != range.end(); ++a) {
            const uint32_t l = active[a];
            GuideLeaf& leaf = *leaves_[l];
            bool stepped = false;
            for (size_t j = start[l]; j < start[l + 1]; ++j) {
                const size_t i = order[j];
                const Record& r = *records[i];
                leaf.records += 1;
                if (std::isfinite(r.d.x) && std::isfinite(r.d.y) && std::isfinite(r.d.z)) {
                    Rng rng = Rng::forSample(seed, i, 0, kDirectionalFilterDomain);
                    const Vec2 s = directionToSquare(r.d);
                    const float size = leaf.building.leafSize(s);
                    const float ux = rng.uniform(), uy = rng.uniform();
                    float x = s.x + (ux - 0.5f) * size, y = s.y + (uy - 0.5f) * size;
                    y -= std::floor(y);  // phi is periodic; cos theta is clamped (in record)
                    leaf.building.record(Vec2(x, y), r.value);
                }
                if (learnFraction && r.learnFraction) stepped |= adamStep(leaf, r, settings_);
            }
            if (stepped) leaf.bsdfFraction = fractionOf(leaf.theta, settings_.minFraction);
        }
    });
}

void SDTree::endIteration(int k, bool varianceTarget) {
    // Learned densities swapped in and the next building trees refined from them (the
    // square-rooted ones for the variance-aware target). A child of a split copies both trees,
    // so refining before the splits gives what refining after them would.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, leaves_.size(), 1), [&](const tbb::blocked_range<size_t>& range) {
        for (size_t l = range.begin(); l != range.end(); ++l) {
            GuideLeaf& leaf = *leaves_[l];
            leaf.sampling = std::move(leaf.building);
            leaf.samplingFraction = leaf.bsdfFraction;
            if (varianceTarget) leaf.sampling.squareRootLeaves();
            leaf.building = leaf.sampling.refined(settings_.splitFraction, settings_.maxDirectionalDepth);
        }
    });

    // The cap holds for the directional trees too: where the rebuilt trees do not fit, they are
    // rebuilt coarser, the split fraction doubled until they do (at 1 or more, roots alone).
    float fraction = settings_.splitFraction;
    for (int round = 0; bytes() > settings_.maxBytes && fraction < 1.f && round < 40; ++round) {
        fraction = std::min(1.f, 2.f * fraction);
        tbb::parallel_for(tbb::blocked_range<size_t>(0, leaves_.size(), 1), [&](const tbb::blocked_range<size_t>& range) {
            for (size_t l = range.begin(); l != range.end(); ++l) {
                GuideLeaf& leaf = *leaves_[l];
                leaf.building = leaf.sampling.refined(fraction, settings_.maxDirectionalDepth);
            }
        });
    }

    // Spatial splits (Mueller 2017 Sec. 5.2): nodes in index order; children are appended and
    // so visited later in the same sweep, and split again while still crowded.
    const double threshold = double(settings_.spatialThreshold) * std::sqrt(std::ldexp(1.0, std::clamp(k, 0, 1000)));
    size_t total = bytes();  // grows by each split's share (vectors are shrunk below)
    for (size_t n = 0; n < nodes_.size(); ++n) {
        if (nodes_[n].child[0] || nodes_[n].depth >= kMaxSpatialDepth) continue;
        const uint32_t l = nodes_[n].leaf;
        if (!(double(leaves_[l]->records) > threshold)) continue;
        auto copy = std::make_unique<GuideLeaf>(*leaves_[l]);
        const size_t added = 2 * sizeof(Node) + sizeof(std::unique_ptr<GuideLeaf>) + leafBytes(*copy);
        if (total + added > settings_.maxBytes) continue;
        total += added;
        leaves_[l]->records /= 2;
        copy->records = leaves_[l]->records;
        Node c0, c1;
        c0.axis = c1.axis = uint8_t((nodes_[n].axis + 1) % 3);
        c0.depth = c1.depth = uint8_t(nodes_[n].depth + 1);
        c0.leaf = l;
        c1.leaf = uint32_t(leaves_.size());
        leaves_.push_back(std::move(copy));
        nodes_[n].child[0] = uint32_t(nodes_.size());
        nodes_[n].child[1] = uint32_t(nodes_.size() + 1);
        nodes_.push_back(c0);
        nodes_.push_back(c1);
    }
    nodes_.shrink_to_fit();
    leaves_.shrink_to_fit();
    for (auto& leaf : leaves_) leaf->records = 0;
}

size_t SDTree::nodeCount() const { return nodes_.size(); }
size_t SDTree::leafCount() const { return leaves_.size(); }

size_t SDTree::directionalNodes() const {
    size_t n = 0;
    for (const auto& l : leaves_) n += l->sampling.nodeCount() + l->building.nodeCount();
    return n;
}

size_t SDTree::bytes() const {
    size_t b = sizeof(*this) + nodes_.size() * sizeof(Node) + leaves_.size() * sizeof(std::unique_ptr<GuideLeaf>);
    for (const auto& l : leaves_) b += leafBytes(*l);
    return b;
}

std::vector<SDTree::LeafView> SDTree::leaves() const {
    std::vector<LeafView> out;
    out.reserve(leaves_.size());
    struct Item { uint32_t node; Vec3 lo, hi; };
    std::vector<Item> stack{{0, lo_, hi_}};
    while (!stack.empty()) {
        const Item it = stack.back();
        stack.pop_back();
        const Node& node = nodes_[it.node];
        if (!node.child[0]) {
            out.push_back({it.lo, it.hi, leaves_[node.leaf].get()});
            continue;
        }
        const int a = node.axis;
        const float mid = 0.5f * (it.lo[a] + it.hi[a]);  // as in findNode
        Item c0 = {node.child[0], it.lo, it.hi}, c1 = {node.child[1], it.lo, it.hi};
        c0.hi[a] = mid;
        c1.lo[a] = mid;
        stack.push_back(c1);  // child 0 first
        stack.push_back(c0);
    }
    return out;
}

void SDTree::save(ByteWriter& w) const {
    w.put(lo_);
    w.put(hi_);
    w.putVector(nodes_);
    w.put(uint64_t(leaves_.size()));
    for (const auto& l : leaves_) {
        l->sampling.save(w);
        l->building.save(w);
        w.put(l->bsdfFraction);
        w.put(l->samplingFraction);
        w.put(l->theta);
        w.put(l->adamM);
        w.put(l->adamV);
        w.put(l->adamSteps);
        w.put(l->records);
    }
}

void SDTree::load(ByteReader& r) {
    const Vec3 lo = r.get<Vec3>(), hi = r.get<Vec3>();
    if (lo != lo_ || hi != hi_) throw std::runtime_error("the guiding state is of a tree over another cube");
    std::vector<Node> nodes = r.getVector<Node>();
    const uint64_t n = r.get<uint64_t>();
    if (nodes.empty() || n > nodes.size()) throw std::runtime_error("the guiding state holds a damaged spatial tree");
    std::vector<std::unique_ptr<GuideLeaf>> leaves;
    for (uint64_t i = 0; i < n; ++i) {
        auto l = std::make_unique<GuideLeaf>();
        l->sampling.load(r);
        l->building.load(r);
        l->bsdfFraction = r.get<float>();
        l->samplingFraction = r.get<float>();
        l->theta = r.get<float>();
        l->adamM = r.get<float>();
        l->adamV = r.get<float>();
        l->adamSteps = r.get<uint64_t>();
        l->records = r.get<uint64_t>();
        leaves.push_back(std::move(l));
    }
    for (const Node& node : nodes)
        if (node.child[0] >= nodes.size() || node.child[1] >= nodes.size() || (!node.child[0] && node.leaf >= n))
            throw std::runtime_error("the guiding state holds a damaged spatial tree");
    nodes_ = std::move(nodes);
    leaves_ = std::move(leaves);
}

}  // namespace lt::guiding
