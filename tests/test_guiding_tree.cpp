// Path guiding's trees (integrators/guiding/directional_tree.h, sd_tree.h): the equal-area map,
// the directional quadtree's density against its sampler, its refinement, the spatial tree's
// look-up, splits and memory cap, determinism of the record pass, and the learned BSDF fraction.
#include <catch2/catch.hpp>

#include <tbb/global_control.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <unordered_map>
#include <vector>

#include "chi2.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "integrators/guiding/directional_tree.h"
#include "integrators/guiding/sd_tree.h"

using namespace lt;
using namespace lt::guiding;

namespace {

constexpr double kFourPi = 12.566370614359172954;

// A direction uniform on the sphere from three normals (independent of the map under test).
Vec3 gaussianDirection(Rng& rng) {
    auto normal = [&rng] {
        const double u1 = 1.0 - double(rng.uniform()), u2 = rng.uniform();
        return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
    };
    glm::dvec3 v;
    do v = glm::dvec3(normal(), normal(), normal());
    while (glm::length(v) < 1e-6);
    return Vec3(glm::normalize(v));
}

double angleBetween(const Vec3& a, const Vec3& b) {
    const glm::dvec3 x(a), y(b);
    return std::atan2(glm::length(glm::cross(x, y)), glm::dot(x, y));
}

// A square of the map: lower corner and side (dyadic).
struct Cell {
    Vec2 lo;
    float size;
};

// The tree's leaves, found through leafSize alone, each cut into cells no larger than maxCell: a
// dyadic square lies inside one leaf exactly when the leaf containing its centre is at least as
// large (leaves are dyadic squares too).
void cells(const DirectionalTree& t, Vec2 lo, float size, float maxCell, std::vector<Cell>& out) {
    if (size <= maxCell && t.leafSize(lo + 0.5f * size) >= size) {
        out.push_back({lo, size});
        return;
    }
    const float h = 0.5f * size;
    for (int q = 0; q < 4; ++q) cells(t, lo + Vec2(float(q & 1), float(q >> 1)) * h, h, maxCell, out);
}
std::vector<Cell> cells(const DirectionalTree& t, float maxCell) {
    std::vector<Cell> out;
    cells(t, Vec2(0.f), 1.f, maxCell, out);
    return out;
}

uint64_t cellKey(const Vec2& lo, float size) {
    const uint64_t level = uint64_t(-std::ilogb(size));
    return (level << 48) | (uint64_t(lo.x / size) << 24) | uint64_t(lo.y / size);
}

// The probability of a cell: pdf constant over a leaf, times the cell's solid angle.
double cellProbability(const DirectionalTree& t, const Cell& c) {
    return double(t.pdf(squareToDirection(c.lo + 0.5f * c.size)).value) * kFourPi * double(c.size) * c.size;
}

// The pdf's integral over the sphere, exactly (per leaf).
double leafIntegral(const DirectionalTree& t) {
    double sum = 0.0;
    for (const Cell& c : cells(t, 1.f)) sum += cellProbability(t, c);
    return sum;
}

// The pdf's integral by the midpoint rule on an n x n grid of the square (exact when no leaf is
// smaller than 1/n).
double gridIntegral(const DirectionalTree& t, int n) {
    double sum = 0.0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            sum += t.pdf(squareToDirection(Vec2((float(i) + 0.5f) / float(n), (float(j) + 0.5f) / float(n)))).value;
    return sum * kFourPi / (double(n) * n);
}

struct Chi2Outcome {
    double stat = 0, pValue = 0;
    int dof = 0;
    long long inZeroCells = 0, zeroPdf = 0, unbinned = 0;
};

// Pearson's chi-square of n samples against pdf over the leaves cut into cells of at most 1/64 of
// the square (so a coarse tree is still tested within its leaves). Expected counts are exact
// (the pdf is constant per leaf); cells expecting < 5 are pooled; the p-value comes from the
// regularised incomplete gamma (tests/chi2.h).
Chi2Outcome chiSquare(const DirectionalTree& t, int n, uint64_t seed) {
    const float maxCell = 1.f / 64.f;
    const std::vector<Cell> cs = cells(t, maxCell);
    std::unordered_map<uint64_t, size_t> index;
    std::vector<double> expected(cs.size()), observed(cs.size(), 0.0);
    for (size_t i = 0; i < cs.size(); ++i) {
        index[cellKey(cs[i].lo, cs[i].size)] = i;
        expected[i] = n * cellProbability(t, cs[i]);
    }
    Chi2Outcome r;
    Rng rng(seed, 3);
    for (int k = 0; k < n; ++k) {
        const Vec3 d = t.sample(rng.uniform2());
        if (!(t.pdf(d).value > 0.f)) ++r.zeroPdf;
        const Vec2 s = directionToSquare(d);
        const float size = std::min(t.leafSize(s), maxCell);
        const Vec2 lo(std::floor(s.x / size) * size, std::floor(s.y / size) * size);
        auto it = index.find(cellKey(lo, size));
        if (it == index.end()) { ++r.unbinned; continue; }
        observed[it->second] += 1.0;
        if (expected[it->second] == 0.0) ++r.inZeroCells;
    }
    double poolE = 0, poolO = 0;
    int bins = 0;
    for (size_t i = 0; i < cs.size(); ++i) {
        if (expected[i] < 5.0) { poolE += expected[i]; poolO += observed[i]; continue; }
        r.stat += (observed[i] - expected[i]) * (observed[i] - expected[i]) / expected[i];
        ++bins;
    }
    if (poolE > 0.0) {
        r.stat += (poolO - poolE) * (poolO - poolE) / poolE;
        ++bins;
    }
    r.dof = std::max(bins - 1, 1);
    r.pValue = chi2::chi2SurvivalProbability(r.stat, r.dof);
    return r;
}

// A point of the square near c with a Gaussian spread sigma (clamped in).
Vec2 clusterPoint(Rng& rng, const Vec2& c, float sigma) {
    const double u1 = 1.0 - double(rng.uniform()), u2 = rng.uniform();
    const double r = std::sqrt(-2.0 * std::log(u1)) * sigma;
    const Vec2 p = c + Vec2(float(r * std::cos(6.283185307179586 * u2)), float(r * std::sin(6.283185307179586 * u2)));
    return glm::clamp(p, Vec2(0.f), Vec2(0.999f));
}

// Trees for the density tests.
DirectionalTree hotTree() {
    // Two points take all the energy; each round of refinement deepens the tree around them.
    const Vec2 hot(0.3141f, 0.7182f), warm(0.8123f, 0.1234f);
    DirectionalTree t;
    for (int round = 0; round < 6; ++round) {
        t.record(hot, 1.f);
        t.record(warm, 0.3f);
        t = t.refined(0.01f, 20);
    }
    t.record(hot, 1.f);
    t.record(warm, 0.3f);
    return t;
}
DirectionalTree randomTree() {
    // Random weights at points from a uniform background and two clusters (sigma 0.02 and
    // 0.002), refined three times with maxDepth 10 (no leaf below 1/1024).
    Rng rng(17, 1);
    DirectionalTree t;
    auto fill = [&] {
        for (int i = 0; i < 100000; ++i) {
            const float pick = rng.uniform();
            const Vec2 s = pick < 0.4f ? rng.uniform2()
                         : pick < 0.8f ? clusterPoint(rng, Vec2(0.25f, 0.6f), 0.02f)
                                       : clusterPoint(rng, Vec2(0.7f, 0.3f), 0.002f);
            t.record(s, rng.uniform());
        }
    };
    for (int round = 0; round < 3; ++round) {
        fill();
        t = t.refined(0.01f, 10);
    }
    fill();
    return t;
}

}  // namespace

TEST_CASE("equal-area map round trips and preserves area", "[guiding]") {
    Rng rng(1, 0);
    std::vector<Vec3> dirs = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {-1, 0, 0}, {-1, -0.f, 0}, {0, -1, 0}, {0, 1, 0},
                              glm::normalize(Vec3(1, -1e-7f, 0)), glm::normalize(Vec3(1e-4f, 0, 1)),
                              glm::normalize(Vec3(0, -1e-4f, -1)), glm::normalize(Vec3(-1e-7f, -1e-7f, 1)),
                              glm::normalize(Vec3(0.5f, -1e-6f, -0.3f))};
    for (int i = 0; i < 200000; ++i) dirs.push_back(gaussianDirection(rng));
    // Tolerances: a float direction fixes z to 6e-8, so near a pole theta is known only to
    // sqrt(2 * 6e-8) ~ 3.5e-4 (bound 1e-3); away from the poles (|z| < 0.999, sin theta > 0.044)
    // the map's double evaluation leaves ~1e-7 / sin theta (bound 1e-5).
    double worst = 0, worstAway = 0;
    int outside = 0;
    for (const Vec3& d : dirs) {
        const Vec2 s = directionToSquare(d);
        if (!(s.x >= 0.f && s.x < 1.f && s.y >= 0.f && s.y < 1.f)) ++outside;
        const double a = angleBetween(d, squareToDirection(s));
        worst = std::max(worst, a);
        if (std::abs(d.z) < 0.999f) worstAway = std::max(worstAway, a);
    }
    INFO("worst round-trip angle " << worst << ", away from the poles " << worstAway);
    CHECK(outside == 0);
    CHECK(worst < 1e-3);
    CHECK(worstAway < 1e-5);

    // Square -> direction -> square, including the borders (s = 0 and the float below 1); s.y
    // compared around the circle and only off the poles (where phi is undefined). Bound 1e-6:
    // ~16 floats of the square, well above the rounding of one float direction.
    double worstS = 0;
    const float below1 = 0x1.fffffep-1f;
    const float edge[] = {0.f, 1e-6f, 0.25f, 0.5f, 0.75f, 1.f - 1e-6f, below1};
    std::vector<Vec2> ss;
    for (float x : edge)
        for (float y : edge) ss.emplace_back(x, y);
    for (int i = 0; i < 100000; ++i) ss.push_back(rng.uniform2());
    for (const Vec2& s : ss) {
        const Vec3 d = squareToDirection(s);
        CHECK(std::abs(glm::length(glm::dvec3(d)) - 1.0) < 1e-6);
        const Vec2 t = directionToSquare(d);
        double e = std::abs(double(t.x) - s.x);
        if (s.x > 1e-7f && s.x < 1.f - 1e-7f) {
            const double dy = std::abs(double(t.y) - s.y);
            e = std::max(e, std::min(dy, 1.0 - dy));
        }
        worstS = std::max(worstS, e);
    }
    INFO("worst square round trip " << worstS);
    CHECK(worstS < 1e-6);

    // Uniform s gives uniform directions: mean d = 0 (sd 1/sqrt(3N) per component) and mean z^2 =
    // mean x^2 = 1/3 (sd sqrt(4/45 / N)); 5 sd bounds (two-sided level 6e-7 each).
    const int n = 1000000;
    glm::dvec3 mean(0.0), meanSq(0.0);
    for (int i = 0; i < n; ++i) {
        const glm::dvec3 d(squareToDirection(rng.uniform2()));
        mean += d;
        meanSq += d * d;
    }
    mean /= double(n);
    meanSq /= double(n);
    const double sdMean = std::sqrt(1.0 / 3.0 / n), sdSq = std::sqrt(4.0 / 45.0 / n);
    INFO("mean " << mean.x << " " << mean.y << " " << mean.z << ", mean squares " << meanSq.x << " " << meanSq.z);
    CHECK(std::abs(mean.x) < 5 * sdMean);
    CHECK(std::abs(mean.y) < 5 * sdMean);
    CHECK(std::abs(mean.z) < 5 * sdMean);
    CHECK(std::abs(meanSq.z - 1.0 / 3.0) < 5 * sdSq);
    CHECK(std::abs(meanSq.x - 1.0 / 3.0) < 5 * sdSq);
}

TEST_CASE("directional pdf integrates to one", "[guiding]") {
    const DirectionalTree uniform;
    const DirectionalTree hot = hotTree();
    const DirectionalTree random = randomTree();
    DirectionalTree rooted = random;
    rooted.squareRootLeaves();
    REQUIRE(!uniform.trained());
    REQUIRE(hot.trained());
    REQUIRE(hot.depth() >= 15);
    REQUIRE(random.depth() >= 6);
    REQUIRE(rooted.trained());
    // The sums are of float densities (relative error ~1e-7 each): bound 1e-5.
    CHECK(std::abs(leafIntegral(uniform) - 1.0) < 1e-5);
    CHECK(std::abs(leafIntegral(hot) - 1.0) < 1e-5);
    CHECK(std::abs(leafIntegral(random) - 1.0) < 1e-5);
    CHECK(std::abs(leafIntegral(rooted) - 1.0) < 1e-5);
    // The same by the midpoint rule on 1024^2 cells, exact where no leaf is smaller than 1/1024.
    CHECK(std::abs(gridIntegral(uniform, 1024) - 1.0) < 1e-5);
    CHECK(std::abs(gridIntegral(random, 1024) - 1.0) < 1e-5);
    CHECK(std::abs(gridIntegral(rooted, 1024) - 1.0) < 1e-5);
    // The square root changes the density (it flattens it).
    CHECK(rooted.pdf(squareToDirection(Vec2(0.7f, 0.3f))).value < random.pdf(squareToDirection(Vec2(0.7f, 0.3f))).value);
}

TEST_CASE("directional sampling matches the pdf (chi-square)", "[guiding]") {
    const DirectionalTree uniform;
    const DirectionalTree hot = hotTree();
    const DirectionalTree random = randomTree();
    DirectionalTree rooted = random;
    rooted.squareRootLeaves();
    // Each tree at level 1e-3 (family-wise about 4e-3 for the four); 200000 samples resolve
    // a density error of a few percent in the 4096 cells of 1/64.
    const DirectionalTree* trees[] = {&uniform, &hot, &random, &rooted};
    const char* names[] = {"uniform", "hot", "random", "square-rooted"};
    for (int i = 0; i < 4; ++i) {
        const Chi2Outcome r = chiSquare(*trees[i], 200000, 100 + i);
        INFO(names[i] << ": chi2 " << r.stat << " dof " << r.dof << " p " << r.pValue << " samples in zero cells "
                      << r.inZeroCells << " with pdf 0 " << r.zeroPdf << " unbinned " << r.unbinned);
        CHECK(r.pValue > 1e-3);
        CHECK(r.inZeroCells == 0);
        CHECK(r.zeroPdf == 0);
        CHECK(r.unbinned == 0);
    }

    // Energy only where s.x < 0.5: the other half has pdf 0 and is never sampled.
    Rng rng(5, 0);
    DirectionalTree half;
    for (int round = 0; round < 3; ++round) {
        for (int i = 0; i < 10000; ++i) {
            const Vec2 s = rng.uniform2();
            half.record(Vec2(0.5f * s.x, s.y), 1.f + rng.uniform());
        }
        if (round < 2) half = half.refined(0.01f, 20);
    }
    int wrongHalf = 0, zero = 0;
    for (int i = 0; i < 100000; ++i) {
        const Vec3 d = half.sample(rng.uniform2());
        if (directionToSquare(d).x >= 0.5f) ++wrongHalf;
        if (!(half.pdf(d).value > 0.f)) ++zero;
    }
    CHECK(wrongHalf == 0);
    CHECK(zero == 0);
    CHECK(half.pdf(squareToDirection(Vec2(0.75f, 0.5f))).value == 0.f);
    // u at the top of [0, 1) does not escape into the empty half either.
    CHECK(directionToSquare(half.sample(Vec2(0x1.fffffep-1f))).x < 0.5f);
}

TEST_CASE("refined splits where the energy is and respects maxDepth", "[guiding]") {
    // One point with all the energy, splitFraction 0.01: its root quadrant (share 1) splits, its
    // virtual quadrants (1/4, 1/16, 1/64 > 0.01) split again, 1/256 does not: depth 4 and
    // 1 + 1 + 4 + 16 + 64 nodes, in a single rebuild.
    const Vec2 s0(0.3f, 0.8f);
    DirectionalTree one;
    one.record(s0, 2.f);
    const DirectionalTree r1 = one.refined(0.01f, 20);
    CHECK(r1.depth() == 4);
    CHECK(r1.nodeCount() == 86);
    // maxDepth 3: nodes at depth < 3 only.
    const DirectionalTree r3 = one.refined(0.01f, 3);
    CHECK(r3.depth() == 2);
    CHECK(r3.nodeCount() == 6);
    CHECK(one.refined(0.01f, 1).nodeCount() == 1);
    // Untrained (or empty) in, root alone out.
    CHECK(DirectionalTree().refined(0.01f, 20).nodeCount() == 1);

    // Concentrated energy (90% at s0, 10% spread uniformly), refined round after round: the
    // tree deepens at s0 up to maxDepth (leaf 2^-20) and stays coarse elsewhere.
    Rng rng(9, 0);
    DirectionalTree t;
    int lastDepth = 0;
    for (int round = 0; round < 7; ++round) {
        for (int i = 0; i < 1000; ++i) t.record(rng.uniform2(), 0.001f);
        t.record(s0, 9.f);
        const DirectionalTree next = t.refined(0.01f, 20);
        CHECK(next.energy() == 0.0);
        CHECK(!next.trained());
        CHECK(next.pdf(Vec3(0, 0, 1)).value == Approx(1.0 / kFourPi));
        CHECK(next.depth() < 20);
        CHECK(next.depth() >= std::min(lastDepth + 1, 19));
        lastDepth = next.depth();
        t = next;
    }
    CHECK(t.depth() == 19);
    CHECK(t.leafSize(s0) == std::ldexp(1.f, -20));
    const Vec2 far(0.8f, 0.2f);
    CHECK(t.leafSize(far) >= 1.f / 16.f);
    INFO("nodes " << t.nodeCount());
    CHECK(t.nodeCount() < 500);

    // record ignores negative and non-finite values.
    DirectionalTree z;
    z.record(s0, -1.f);
    z.record(s0, std::nanf(""));
    z.record(s0, kInf);
    CHECK(!z.trained());
    CHECK(z.energy() == 0.0);
}

TEST_CASE("spatial tree look-up splits and memory cap", "[guiding]") {
    TreeSettings st;
    st.spatialThreshold = 100.f;
    auto recordsAt = [](const Vec3& p, int n) {
        std::vector<Record> v(static_cast<size_t>(n));
        for (Record& r : v) {
            r.p = p;
            r.d = Vec3(0, 0, 1);
            r.value = 1.f;
        }
        return v;
    };
    auto add = [](SDTree& t, const std::vector<Record>& v, uint64_t seed) { t.addRecords({&v}, seed, false); };

    // Threshold spatialThreshold * sqrt(2^k): more than it splits, not more does not.
    {
        SDTree a(Vec3(0), 1.f, st, 0.5f), b(Vec3(0), 1.f, st, 0.5f), c(Vec3(0), 1.f, st, 0.5f), d(Vec3(0), 1.f, st, 0.5f);
        add(a, recordsAt(Vec3(0.1f), 100), 1);
        add(b, recordsAt(Vec3(0.1f), 101), 1);
        add(c, recordsAt(Vec3(0.1f), 200), 1);
        add(d, recordsAt(Vec3(0.1f), 201), 1);
        CHECK(b.leaf(Vec3(0)).records == 101);
        a.endIteration(0, false);
        b.endIteration(0, false);
        c.endIteration(2, false);  // threshold 200
        d.endIteration(2, false);
        CHECK(a.leafCount() == 1);
        CHECK(b.leafCount() == 2);
        CHECK(c.leafCount() == 1);
        CHECK(d.leafCount() == 2);
        CHECK(b.leafSize(Vec3(0.5f)) == Vec3(1, 2, 2));  // split along x first
        CHECK(b.leaf(Vec3(0.5f)).records == 0);
    }
    // Of two leaves, the crowded one splits (along y, the next axis) and the other does not.
    {
        SDTree t(Vec3(0), 1.f, st, 0.5f);
        add(t, recordsAt(Vec3(0.1f), 150), 1);
        t.endIteration(0, false);
        REQUIRE(t.leafCount() == 2);
        // At the leaves' centres, so the jitter (one leaf's size) keeps the records inside.
        add(t, recordsAt(Vec3(-0.5f, 0, 0), 150), 2);
        add(t, recordsAt(Vec3(0.5f, 0, 0), 60), 3);
        CHECK(t.leaf(Vec3(-0.5f, 0, 0)).records == 150);
        CHECK(t.leaf(Vec3(0.5f, 0, 0)).records == 60);
        t.endIteration(0, false);
        CHECK(t.leafCount() == 3);
        CHECK(t.nodeCount() == 5);
        CHECK(t.leafSize(Vec3(-0.5f, 0.5f, 0)) == Vec3(1, 1, 2));
        CHECK(t.leafSize(Vec3(0.5f, 0, 0)) == Vec3(1, 2, 2));
        // Children still above the threshold split again in the same call (counts halved:
        // 1000 -> 500 -> 250 -> 125 -> 62, so 16 leaves).
        SDTree deep(Vec3(0), 1.f, st, 0.5f);
        add(deep, recordsAt(Vec3(0.1f), 1000), 1);
        deep.endIteration(0, false);
        CHECK(deep.leafCount() == 16);
    }

    // A tree split by records spread over the cube: look-ups agree with leaves().
    Rng rng(21, 0);
    std::vector<Record> spread(6000);
    for (Record& r : spread) {
        const float corner = rng.uniform() < 0.5f ? 0.5f : 1.f;  // half of them in one octant
        r.p = (Vec3(rng.uniform(), rng.uniform(), rng.uniform()) * 2.f - 1.f) * corner;
        r.d = gaussianDirection(rng);
        r.value = rng.uniform();
    }
    SDTree t(Vec3(0), 1.f, st, 0.5f);
    add(t, spread, 4);
    t.endIteration(0, false);
    const std::vector<SDTree::LeafView> views = t.leaves();
    REQUIRE(views.size() == t.leafCount());
    REQUIRE(views.size() > 20);
    double volume = 0;
    for (const auto& v : views) {
        const Vec3 c = 0.5f * (v.lo + v.hi);
        CHECK(&t.leaf(c) == v.leaf);
        CHECK(t.leafSize(c) == v.hi - v.lo);
        const Vec3 e = v.hi - v.lo;
        volume += double(e.x) * e.y * e.z;
    }
    CHECK(volume == Approx(8.0).epsilon(1e-12));
    int mismatches = 0;
    for (int i = 0; i < 20000; ++i) {
        const Vec3 p = Vec3(rng.uniform(), rng.uniform(), rng.uniform()) * 2.f - 1.f;
        const GuideLeaf* l = &t.leaf(p);
        int containing = 0;
        for (const auto& v : views)
            if (p.x >= v.lo.x && p.x < v.hi.x && p.y >= v.lo.y && p.y < v.hi.y && p.z >= v.lo.z && p.z < v.hi.z) {
                ++containing;
                if (v.leaf != l) ++mismatches;
            }
        if (containing != 1) ++mismatches;
        // Outside the cube: clamped in.
        const Vec3 outside = p * 7.f;
        if (&t.leaf(outside) != &t.leaf(glm::clamp(outside, Vec3(-1.f), Vec3(1.f)))) ++mismatches;
    }
    CHECK(mismatches == 0);

    // Memory cap. The same records into trees differing only in the cap: without splits (cap =
    // the unsplit tree's bytes) none happens; a cap a quarter of the way to the uncapped size
    // stops the splits early and holds.
    auto build = [&](size_t cap, float threshold) {
        TreeSettings s = st;
        s.maxBytes = cap;
        s.spatialThreshold = threshold;
        SDTree tree(Vec3(0), 1.f, s, 0.5f);
        tree.addRecords({&spread}, 4, false);
        tree.endIteration(0, false);
        return tree;
    };
    const SDTree unsplit = build(size_t(1) << 40, 1e30f);
    const SDTree uncapped = build(size_t(1) << 40, 100.f);
    const size_t base = unsplit.bytes(), full = uncapped.bytes();
    REQUIRE(unsplit.leafCount() == 1);
    REQUIRE(full > base);
    const SDTree none = build(base, 100.f);
    CHECK(none.leafCount() == 1);
    CHECK(none.bytes() <= base);
    const size_t cap = base + (full - base) / 4;
    const SDTree capped = build(cap, 100.f);
    INFO("bytes unsplit " << base << " uncapped " << full << " cap " << cap << " capped " << capped.bytes());
    CHECK(capped.bytes() <= cap);
    CHECK(capped.leafCount() > 1);
    CHECK(capped.leafCount() < uncapped.leafCount());
}

namespace {

// Random records: clustered positions, random directions, values and fraction-learning fields.
std::vector<Record> randomRecords(Rng& rng, int n) {
    std::vector<Record> v(static_cast<size_t>(n));
    for (Record& r : v) {
        const Vec3 u(rng.uniform(), rng.uniform(), rng.uniform());
        r.p = rng.uniform() < 0.5f ? (u * 2.f - 1.f) : Vec3(0.3f, -0.2f, 0.5f) + 0.05f * u;
        r.d = gaussianDirection(rng);
        r.value = -std::log(1.f - rng.uniform());
        r.bsdfPdf = rng.uniform();
        r.guidePdf = rng.uniform();
        r.mixturePdf = 0.5f * (r.bsdfPdf + r.guidePdf) + 0.01f;
        r.product = rng.uniform() * r.bsdfPdf;
        r.learnFraction = rng.uniform() < 0.7f;
    }
    return v;
}

// Every number of the tree the walks read or training continues from, as bits.
std::vector<uint32_t> signature(const SDTree& t) {
    std::vector<uint32_t> sig;
    auto f = [&sig](float x) { sig.push_back(std::bit_cast<uint32_t>(x)); };
    auto d = [&sig](double x) {
        const uint64_t b = std::bit_cast<uint64_t>(x);
        sig.push_back(uint32_t(b));
        sig.push_back(uint32_t(b >> 32));
    };
    Rng rng(77, 0);
    std::vector<Vec3> dirs;
    for (int i = 0; i < 300; ++i) dirs.push_back(gaussianDirection(rng));
    sig.push_back(uint32_t(t.nodeCount()));
    for (const auto& v : t.leaves()) {
        for (int a = 0; a < 3; ++a) { f(v.lo[a]); f(v.hi[a]); }
        const GuideLeaf& l = *v.leaf;
        f(l.bsdfFraction); f(l.theta); f(l.adamM); f(l.adamV);
        sig.push_back(uint32_t(l.adamSteps));
        sig.push_back(uint32_t(l.records));
        sig.push_back(uint32_t(l.sampling.nodeCount()));
        sig.push_back(uint32_t(l.building.nodeCount()));
        d(l.sampling.energy());
        d(l.building.energy());
        for (const Vec3& w : dirs) { f(l.sampling.pdf(w).value); f(l.building.pdf(w).value); }
    }
    return sig;
}

}  // namespace

TEST_CASE("record passes are deterministic across batches and threads", "[guiding]") {
    Rng rng(31, 0);
    const std::vector<Record> passes[3] = {randomRecords(rng, 20000), randomRecords(rng, 20000), randomRecords(rng, 20000)};
    // The same records as one batch, or cut into uneven batches (one of them empty).
    auto cut = [](const std::vector<Record>& all, bool many) {
        std::vector<std::vector<Record>> out;
        if (!many) return std::vector<std::vector<Record>>{all};
        size_t i = 0, len = 1;
        while (i < all.size()) {
            const size_t n = std::min(len, all.size() - i);
            out.emplace_back(all.begin() + long(i), all.begin() + long(i + n));
            if (out.size() == 3) out.emplace_back();
            i += n;
            len = len * 3 + 7;
        }
        return out;
    };
    auto run = [&](bool many) {
        TreeSettings st;
        st.spatialThreshold = 300.f;
        SDTree t(Vec3(0), 1.f, st, 0.5f);
        for (int k = 0; k < 3; ++k) {
            const std::vector<std::vector<Record>> batches = cut(passes[k], many);
            std::vector<const std::vector<Record>*> ptrs;
            for (const auto& b : batches) ptrs.push_back(&b);
            t.addRecords(ptrs, 1000 + uint64_t(k), true);
            if (k < 2) t.endIteration(k, k == 1);  // the last pass's records stay in the building trees
        }
        return std::make_pair(t.leafCount(), signature(t));
    };
    const auto reference = run(false);
    REQUIRE(reference.first > 8);  // splits happened, so many leaves run in parallel
    CHECK(run(true) == reference);
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        CHECK(run(false) == reference);
        CHECK(run(true) == reference);
    }
    {
        tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
        CHECK(run(true) == reference);
    }
    // A different seed changes the filters' jitter (so the comparison above can fail).
    TreeSettings st;
    SDTree a(Vec3(0), 1.f, st, 0.5f), b(Vec3(0), 1.f, st, 0.5f);
    a.addRecords({&passes[0]}, 1, false);
    b.addRecords({&passes[0]}, 2, false);
    CHECK(signature(a) != signature(b));
}

namespace {

// Passes of records at one leaf, sampled from the one-sample mixture with the leaf's current
// fraction: BSDF density cos / pi (upper hemisphere), guide uniform 1 / (4 pi). The integrand is
// proportional to the BSDF's density (bsdfMatches) or to the guide's, with integral 4 pi either
// way (unit incident radiance).
struct FractionRun {
    float final = 0, lowest = 1;
};
FractionRun learnFraction(bool bsdfMatches, float minFraction, int passes, int perPass) {
    TreeSettings st;
    st.minFraction = minFraction;
    SDTree t(Vec3(0), 1.f, st, 0.5f);
    Rng rng(bsdfMatches ? 41 : 42, 0);
    FractionRun out;
    for (int pass = 0; pass < passes; ++pass) {
        const float alpha = t.leaf(Vec3(0)).bsdfFraction;
        std::vector<Record> v(static_cast<size_t>(perPass));
        for (Record& r : v) {
            const bool bsdf = rng.uniform() < alpha;
            const Vec2 u = rng.uniform2();
            r.d = bsdf ? sampleCosineHemisphere(u) : squareToDirection(u);
            r.bsdfPdf = std::max(r.d.z, 0.f) * kInvPi;
            r.guidePdf = float(1.0 / kFourPi);
            r.mixturePdf = alpha * r.bsdfPdf + (1.f - alpha) * r.guidePdf;
            r.product = bsdfMatches ? float(kFourPi) * r.bsdfPdf : 1.f;
            r.value = r.product / r.mixturePdf;
            r.learnFraction = true;
        }
        t.addRecords({&v}, uint64_t(pass), true);
        out.lowest = std::min(out.lowest, t.leaf(Vec3(0)).bsdfFraction);
    }
    out.final = t.leaf(Vec3(0)).bsdfFraction;
    return out;
}

}  // namespace

TEST_CASE("learned BSDF fraction follows the integrand", "[guiding]") {
    // The KL divergence's minimum is alpha = 1 when the integrand is the BSDF's density and alpha
    // = 0 (clamped to minFraction) when it is the guide's; the l2 term (0.01 theta) keeps theta
    // finite, with equilibria near alpha 0.93 and 0.12 (estimated from the expected gradient).
    // Bounds 0.8 / 0.2 after 4000 steps leave room for the Adam noise (fixed seeds).
    const FractionRun up = learnFraction(true, 0.1f, 8, 500);
    const FractionRun down = learnFraction(false, 0.1f, 8, 500);
    INFO("alpha towards the BSDF " << up.final << ", towards the guide " << down.final << " (lowest " << down.lowest << ")");
    CHECK(up.final > 0.8f);
    CHECK(down.final < 0.2f);
    CHECK(up.lowest >= 0.1f);
    CHECK(down.lowest >= 0.1f);
    // A larger floor holds too.
    const FractionRun floor = learnFraction(false, 0.3f, 8, 500);
    INFO("with floor 0.3: " << floor.final << " (lowest " << floor.lowest << ")");
    CHECK(floor.lowest >= 0.3f);
    CHECK(floor.final < 0.4f);

    // Extreme gradients: theta is clamped to [-20, 20] and alpha stays >= minFraction.
    TreeSettings st;
    SDTree t(Vec3(0), 1.f, st, 0.5f);
    std::vector<Record> v(3000);
    for (Record& r : v) {
        r.d = Vec3(0, 0, -1);
        r.bsdfPdf = 0.f;
        r.guidePdf = 1.f;
        r.mixturePdf = 1e-20f;
        r.product = 1e20f;
        r.learnFraction = true;
    }
    v[5].mixturePdf = 0.f;           // skipped: not a density it was sampled with
    v[6].product = std::nanf("");  // skipped
    t.addRecords({&v}, 1, true);
    const GuideLeaf& l = t.leaf(Vec3(0));
    CHECK(l.adamSteps == 2998);
    CHECK(l.theta >= -20.f);
    CHECK(l.bsdfFraction >= st.minFraction);
    CHECK(l.bsdfFraction < st.minFraction + 0.01f);
    // Without learnFraction the fraction stays the fixed one.
    SDTree fixed(Vec3(0), 1.f, st, 0.5f);
    fixed.addRecords({&v}, 1, false);
    CHECK(fixed.leaf(Vec3(0)).bsdfFraction == 0.5f);
    CHECK(fixed.leaf(Vec3(0)).adamSteps == 0);
}
