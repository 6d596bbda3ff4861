// Path guiding's training shared by several MPI ranks (integrators/guiding/trainer.h, issue 48),
// without MPI: one Trainer fed passes 0..N-1 as the single process feeds them, against 2 and 3
// Trainers in deferred mode that each render a disjoint set of the passes and exchange records
// (takeDeferred / applyDeferred) and iteration sums (takeIterationSums / addIterationSums) at
// the iteration ends, as the render loop will. The trees, schedules, pixel estimates and images
// (Trainer::state() bytes, develop()) must be the single trainer's bit for bit at every iteration
// boundary and at the end, with the fixed and the learned BSDF fraction. Also the exact double
// sum the sums of squares use, a mid-iteration checkpoint resumed by one process, rank 0's
// decisions under a time budget, and the misuse the deferred mode refuses.
#include <catch2/catch.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <vector>

#include "core/rng.h"
#include "core/sampling.h"
#include "integrators/guiding/exact_double_sum.h"
#include "integrators/guiding/trainer.h"

using namespace lt;
using namespace lt::guiding;

namespace {

constexpr int kW = 16, kH = 12;
constexpr uint64_t kSeed = 77;

GuidingSettings settingsOf(bool learned) {
    GuidingSettings g;
    g.target = Target::Variance;
    g.learnedFraction = learned;
    g.fixedFraction = 0.5f;
    g.tree.spatialThreshold = 40.f;  // ~400 records a pass: the tree splits from the first iteration on
    return g;
}

std::unique_ptr<Trainer> makeTrainer(bool learned, uint64_t totalPasses, double timeLimit = 0.0) {
    return std::make_unique<Trainer>(settingsOf(learned), Vec3(0.f), 1.f, kW, kH, totalPasses, timeLimit, kSeed);
}

// One pass of a synthetic render: every pixel's camera sample (a few skipped, as the film rejects
// invalid ones) and, while training, 0-3 records per pixel made the way the path tracer makes
// them: the leaf's guide decides (WalkGuide, so the alpha sampled with is the leaf's
// samplingFraction), the densities are the guide's and a cosine "BSDF", the product is weighted
// by the pixel estimate. Random numbers per (pixel, pass), so any process renders a pass alike.
void renderPass(Trainer& t, uint32_t pass) {
    t.beginPass(pass);
    WalkGuide guide = t.walkGuide();
    for (uint32_t pixel = 0; pixel < uint32_t(kW * kH); ++pixel) {
        Rng rng = Rng::forSample(kSeed, pixel, pass);
        const float base = 0.2f + 0.1f * float(pixel % 7);
        Color c(base * rng.uniform(), base * rng.uniform(), base * rng.uniform());
        if (rng.uniform() < 0.02f) c *= 300.f;  // a firefly
        if (rng.uniform() >= 0.03f) t.addSample(pixel, c);
        if (!t.training()) continue;
        const int n = int(rng.uniform() * 4.f);
        for (int j = 0; j < n; ++j) {
            Record r;
            // Two clusters of points (one crowded, so it splits) and a spread.
            const float k = rng.uniform();
            const Vec3 u(rng.uniform(), rng.uniform(), rng.uniform());
            r.p = k < 0.5f ? Vec3(-0.5f) + 0.2f * u : k < 0.8f ? Vec3(0.4f, 0.1f, -0.3f) + 0.3f * u : 2.f * u - Vec3(1.f);
            const bool guided = guide.decide(0, r.p, 1.f, false);
            const Vec2 v = rng.uniform2();
            const float alpha = guided ? guide.alpha[0] : 1.f;
            if (guided && rng.uniform() >= alpha) r.d = squareToDirection(v);
            else r.d = sampleCosineHemisphere(v);
            r.bsdfPdf = std::max(r.d.z, 0.f) * kInvPi;
            r.guidePdf = guided ? guide.leaf[0]->sampling.pdf(r.d).value : 0.25f * kInvPi;
            r.mixturePdf = guided ? guide.mix(0, r.bsdfPdf, r.guidePdf) : r.bsdfPdf;
            if (!(r.mixturePdf > 0.f)) continue;
            const float f = (1.f + 3.f * std::max(r.d.x, 0.f)) * r.bsdfPdf;  // a lobe towards +x
            r.product = f / t.pixelEstimate(pixel);
            r.value = r.product / r.mixturePdf;
            r.learnFraction = guided;
            t.buffer().emplace_back(pixel, r);
        }
    }
    t.endPass(pass);
}

// (bytes compared as a bool, so that a failure does not print them)
bool sameBytes(const std::string& a, const std::string& b) {
    if (a == b) return true;
    size_t i = 0;
    while (i < a.size() && i < b.size() && a[i] == b[i]) ++i;
    UNSCOPED_INFO("states of " << a.size() << " and " << b.size() << " bytes, first difference at byte " << i);
    return false;
}

bool sameImage(const Image& a, const Image& b) {
    return a.pixels.size() == b.pixels.size() &&
           std::memcmp(a.pixels.data(), b.pixels.data(), a.pixels.size() * sizeof(Color)) == 0;
}

bool samePixelEstimates(const Trainer& a, const Trainer& b) {
    for (uint32_t i = 0; i < uint32_t(kW * kH); ++i)
        if (std::bit_cast<uint32_t>(a.pixelEstimate(i)) != std::bit_cast<uint32_t>(b.pixelEstimate(i))) return false;
    return true;
}

// What the single process has after each iteration boundary (after beginPass of the boundary)
// and at the end: state() bytes and develop().
struct Trace {
    std::vector<uint64_t> boundaries;
    std::vector<std::string> states;
    std::string finalState;
    Image image;
    int iterations = 0;
};

Trace runSingle(bool learned, uint64_t total) {
    auto t = makeTrainer(learned, total);
    Trace out;
    for (uint32_t pass = 0; pass < total; ++pass) {
        if (pass > 0 && pass == t->iterationEnd()) {
            t->beginPass(pass);
            out.boundaries.push_back(pass);
            out.states.push_back(t->state());
        }
        renderPass(*t, pass);
    }
    out.finalState = t->state();
    out.image = t->develop();
    out.iterations = t->iterations();
    return out;
}

// Which rank renders a pass (on demand: uneven shares, every rank some of each longer iteration).
int ownerOf(uint32_t pass, int ranks) {
    if (ranks == 2) return int(pass % 2);
    return int((pass * 2654435761u >> 7) % uint32_t(ranks));
}

enum class Exchange { PerIteration, Streaming };

// The sums of every rank onto rank 0 (the others' taken), then, where `broadcast`, rank 0's total
// added by every other rank.
void gatherSums(std::vector<std::unique_ptr<Trainer>>& r, bool broadcast) {
    for (size_t i = r.size() - 1; i >= 1; --i) r[0]->addIterationSums(r[i]->takeIterationSums());  // any order
    if (!broadcast) return;
    const std::string total = r[0]->iterationSums();
    for (size_t i = 1; i < r.size(); ++i) r[i]->addIterationSums(total);
}

// Every rank's kept records to every rank (each receives the parts in its own order).
void exchangeRecords(std::vector<std::unique_ptr<Trainer>>& r) {
    std::vector<std::string> parts;
    for (auto& t : r) parts.push_back(t->takeDeferred());
    for (size_t i = 0; i < r.size(); ++i) {
        std::vector<std::string> mine = parts;
        std::rotate(mine.begin(), mine.begin() + long(i), mine.end());
        r[i]->applyDeferred(mine);
    }
}

struct RanksRun {
    std::vector<std::string> states;  // every rank's, at each of the single trace's boundaries
    std::string finalState;
    Image image;
    std::string checkpoint;  // rank 0's state at `checkpointAt` (0: none)
    bool estimatesAgree = true;
};

// The call sequence of trainer.h's comment, ranks simulated in one process. PerIteration: the
// records are exchanged at iteration ends; Streaming: after every pass, each rank receiving the
// parts that are "in flight" late and out of order (they wait in applyDeferred until contiguous).
RanksRun runRanks(bool learned, uint64_t total, int ranks, Exchange exchange, uint64_t checkpointAt) {
    std::vector<std::unique_ptr<Trainer>> r;
    for (int i = 0; i < ranks; ++i) {
        r.push_back(makeTrainer(learned, total));
        r.back()->deferRecords(true);
        r.back()->beginPass(0);
    }
    RanksRun out;
    std::vector<std::string> late;  // (streaming) parts delivered one pass late
    uint64_t pass = 0;
    while (pass < total) {
        const uint64_t end = std::min(total, r[0]->iterationEnd());
        for (uint64_t p = pass; p < end; ++p) {
            if (p == checkpointAt) {
                // A checkpoint inside the iteration: every pass < p done; records to every rank,
                // sums onto rank 0, whose state is the single process's after p passes.
                exchangeRecords(r);
                if (exchange == Exchange::Streaming) {
                    for (auto& t : r) t->applyDeferred(late);
                    late.clear();
                }
                gatherSums(r, false);
                out.checkpoint = r[0]->state();
            }
            Trainer& t = *r[size_t(ownerOf(uint32_t(p), ranks))];
            renderPass(t, uint32_t(p));
            if (exchange == Exchange::Streaming) {
                // This pass's part reaches the ranks one pass late; the previous one arrives now
                // (a later pass before an earlier one: it waits).
                std::vector<std::string> now = {t.takeDeferred()};
                if (p % 3 == 1) std::swap(now, late);
                for (auto& x : r) x->applyDeferred(now);
            }
        }
        if (end == total) break;
        // The iteration ends: records, sums, (with --spp no decision), beginPass(end) everywhere.
        exchangeRecords(r);
        if (exchange == Exchange::Streaming) {
            for (auto& t : r) t->applyDeferred(late);
            late.clear();
        }
        gatherSums(r, true);
        for (auto& t : r) t->beginPass(uint32_t(end));
        for (auto& t : r) {
            out.states.push_back(t->state());
            out.estimatesAgree = out.estimatesAgree && samePixelEstimates(*t, *r[0]);
        }
        pass = end;
    }
    gatherSums(r, false);  // the final iteration's sums, for rank 0's image
    out.finalState = r[0]->state();
    out.image = r[0]->develop();
    return out;
}

}  // namespace

TEST_CASE("exact double sums are order-independent and correctly rounded", "[guiding][ranks]") {
    // Exact where a double sum rounds: 2^53 + 1 + 1 (a double sum gives 2^53).
    ExactDoubleSum a;
    for (double x : {0x1p53, 1.0, 1.0}) a.add(x);
    CHECK(a.value() == 0x1p53 + 2.0);
    // Ties to even, and a sticky bit far below (2^-40) breaking the tie.
    ExactDoubleSum tie, up;
    tie.add(0x1p53);
    tie.add(1.0);
    up = tie;
    up.add(0x1p-40);
    CHECK(tie.value() == 0x1p53);
    CHECK(up.value() == 0x1p53 + 2.0);
    // Below 2^-96 nothing is added; the largest representable summand is.
    ExactDoubleSum tiny;
    tiny.add(1e-40);
    CHECK(tiny.value() == 0.0);
    ExactDoubleSum big;
    big.add(0x1.fffffffffffffp123);
    big.add(0.5);
    CHECK(big.value() == 0x1.fffffffffffffp123);
    // Random squares over 20 decades: any order and any split give the same bits, and the value
    // is within 1e-15 of a compensated (Neumaier) sum.
    Rng rng(5, 0);
    std::vector<double> xs(4000);
    for (double& x : xs) {
        const double m = std::ldexp(double(rng.uniform()) + 0.5, int(rng.uniform() * 64.f) - 32);
        x = m * m;
    }
    ExactDoubleSum forward, backward, left, right;
    for (double x : xs) forward.add(x);
    for (size_t i = xs.size(); i-- > 0;) backward.add(xs[i]);
    for (size_t i = 0; i < xs.size(); ++i) (i % 3 ? left : right).add(xs[i]);
    left.add(right);
    CHECK(forward == backward);
    CHECK(forward == left);
    double s = 0.0, c = 0.0;
    for (double x : xs) {
        const double t = s + x;
        c += std::abs(s) >= std::abs(x) ? (s - t) + x : (x - t) + s;
        s = t;
    }
    CHECK(std::abs(forward.value() - (s + c)) <= 1e-15 * (s + c));
}

TEST_CASE("two and three ranks train the single process's trees and images bit for bit", "[guiding][ranks]") {
    // 40 passes: training iterations [0 1) [1 3) [3 7) [7 15), the final one [15 40); four
    // boundaries compared, then the combined image.
    constexpr uint64_t total = 40;
    for (const bool learned : {false, true}) {
        const Trace single = runSingle(learned, total);
        REQUIRE(single.boundaries == std::vector<uint64_t>{1, 3, 7, 15});
        REQUIRE(single.iterations == 5);
        for (const int ranks : {2, 3}) {
            for (const Exchange ex : {Exchange::PerIteration, Exchange::Streaming}) {
                INFO("learned " << learned << " ranks " << ranks << " streaming " << (ex == Exchange::Streaming));
                const RanksRun run = runRanks(learned, total, ranks, ex, 0);
                REQUIRE(run.states.size() == single.states.size() * size_t(ranks));
                for (size_t b = 0; b < single.states.size(); ++b)
                    for (int i = 0; i < ranks; ++i) {
                        INFO("boundary " << single.boundaries[b] << " rank " << i);
                        CHECK(sameBytes(run.states[b * size_t(ranks) + size_t(i)], single.states[b]));
                    }
                CHECK(run.estimatesAgree);
                CHECK(sameBytes(run.finalState, single.finalState));
                CHECK(sameImage(run.image, single.image));
            }
        }
    }
}

TEST_CASE("the learned fraction trains and the walks sample with the fraction of the iteration start", "[guiding][ranks]") {
    // The comparison above is only as strong as the learned fraction is active: it moved (Adam
    // stepped in many leaves) and, within an iteration, the walks' alpha stays where it began
    // while bsdfFraction follows Adam pass by pass.
    auto t = makeTrainer(true, 40);
    for (uint32_t pass = 0; pass <= 7; ++pass) renderPass(*t, pass);  // into iteration [7 15)
    const SDTree& tree = t->tree();
    size_t stepped = 0, moved = 0;
    std::vector<float> before;
    for (const auto& v : tree.leaves()) {
        stepped += v.leaf->adamSteps > 0;
        moved += v.leaf->samplingFraction != 0.5f;
        before.push_back(v.leaf->samplingFraction);
    }
    INFO(tree.leafCount() << " leaves, " << stepped << " stepped, " << moved << " sampling another alpha than 0.5");
    CHECK(stepped >= 4);
    CHECK(moved >= 4);
    renderPass(*t, 8);
    renderPass(*t, 9);  // inside iteration [7 15): no split, alphas frozen, bsdfFraction moves on
    size_t i = 0, differs = 0;
    for (const auto& v : t->tree().leaves()) {
        CHECK(v.leaf->samplingFraction == before[i++]);
        differs += v.leaf->bsdfFraction != v.leaf->samplingFraction;
    }
    CHECK(differs >= 4);
}

TEST_CASE("a checkpoint of three ranks inside an iteration is the single state and resumes alone", "[guiding][ranks]") {
    // Checkpoint at pass 10, inside the training iteration [7 15): rank 0's state after the
    // records and sums are gathered must be the single process's after 10 passes, and one
    // process restoring it and rendering on must end with the straight run's state and image.
    constexpr uint64_t total = 40;
    for (const bool learned : {false, true}) {
        INFO("learned " << learned);
        auto straight = makeTrainer(learned, total);
        std::string at10;
        for (uint32_t pass = 0; pass < total; ++pass) {
            if (pass == 10) at10 = straight->state();
            renderPass(*straight, pass);
        }
        const RanksRun run = runRanks(learned, total, 3, Exchange::Streaming, 10);
        CHECK(sameBytes(run.checkpoint, at10));
        CHECK(sameBytes(run.finalState, straight->state()));
        CHECK(sameImage(run.image, straight->develop()));
        auto resumed = makeTrainer(learned, total);
        resumed->restore(run.checkpoint);
        for (uint32_t pass = 10; pass < total; ++pass) renderPass(*resumed, pass);
        CHECK(sameBytes(resumed->state(), straight->state()));
        CHECK(sameImage(resumed->develop(), straight->develop()));
    }
}

TEST_CASE("with a time budget rank 0 decides the schedule for every rank", "[guiding][ranks]") {
    // Decisions scripted as rank 0 would broadcast them (train, train, stop): the single trainer
    // given the same decisions and two ranks end with the same state and image, after iterations
    // [0 1) [1 3) [3 7) and the final one from pass 7.
    const std::vector<bool> decisions = {true, true, false};
    constexpr uint32_t passes = 12;
    auto single = makeTrainer(false, 0, 1e9);
    std::vector<std::unique_ptr<Trainer>> r;
    for (int i = 0; i < 2; ++i) {
        r.push_back(makeTrainer(false, 0, 1e9));
        r.back()->deferRecords(true);
        r.back()->beginPass(0);
    }
    size_t k = 0;
    for (uint32_t pass = 0; pass < passes; ++pass) {
        if (pass > 0 && pass == single->iterationEnd()) {
            REQUIRE(k < decisions.size());
            CHECK(r[0]->nextIterationTrains());  // (by the clock, with 1e9 s left)
            single->decideNextIteration(decisions[k]);
            exchangeRecords(r);
            gatherSums(r, true);
            for (auto& t : r) {
                t->decideNextIteration(decisions[k]);
                t->beginPass(pass);
            }
            ++k;
        }
        renderPass(*single, pass);
        renderPass(*r[ownerOf(pass, 2)], pass);
    }
    CHECK(k == 3);
    CHECK(single->iterations() == 4);
    CHECK(single->trainingPasses() == 7);
    CHECK(single->iterationEnd() == UINT64_MAX);
    gatherSums(r, false);
    CHECK(sameBytes(r[0]->state(), single->state()));
    CHECK(sameImage(r[0]->develop(), single->develop()));
    // With --spp the schedule is the budget's: a decision against it is refused.
    auto spp = makeTrainer(false, 40);
    spp->beginPass(0);
    CHECK_NOTHROW(spp->decideNextIteration(spp->nextIterationTrains()));
    CHECK_THROWS_AS(spp->decideNextIteration(!spp->nextIterationTrains()), std::invalid_argument);
}

TEST_CASE("the deferred mode refuses a broken exchange", "[guiding][ranks]") {
    auto make = [] {
        std::vector<std::unique_ptr<Trainer>> r;
        for (int i = 0; i < 2; ++i) {
            r.push_back(makeTrainer(false, 40));
            r.back()->deferRecords(true);
            r.back()->beginPass(0);
        }
        renderPass(*r[0], 0);  // iteration [0 1)
        return r;
    };
    {  // The iteration ends before its records are applied.
        auto r = make();
        gatherSums(r, true);
        CHECK_THROWS_AS(r[1]->beginPass(1), std::logic_error);
    }
    {  // ... or without the other ranks' sums (rank 1 holds none of pass 0's).
        auto r = make();
        exchangeRecords(r);
        CHECK_THROWS_AS(r[1]->beginPass(1), std::logic_error);
    }
    {  // A pass given twice, records of a pass already applied, and state() with records kept back.
        auto r = make();
        const std::string part = r[0]->takeDeferred();
        CHECK_THROWS_AS(r[1]->applyDeferred({part, part}), std::logic_error);
        r[1]->applyDeferred({part});
        CHECK_THROWS_AS(r[1]->applyDeferred({part}), std::logic_error);
        auto t = makeTrainer(false, 40);
        t->deferRecords(true);
        renderPass(*t, 0);
        CHECK_THROWS_AS(t->state(), std::logic_error);
        CHECK_THROWS_AS(t->applyDeferred({std::string("junk")}), std::runtime_error);
    }
    {  // Sums of another iteration.
        auto r = make();
        const std::string old = r[1]->iterationSums();  // (iteration 0)
        exchangeRecords(r);
        gatherSums(r, true);
        for (auto& t : r) t->beginPass(1);
        CHECK_THROWS_AS(r[0]->addIterationSums(old), std::runtime_error);
    }
}
