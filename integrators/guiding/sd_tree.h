// Mueller et al. 2017's SD-tree ("Practical Path Guiding", Sec. 3): a binary tree over the scene's
// bounding cube, split at the midpoint with the axis cycling x, y, z, whose every leaf holds a
// directional distribution (directional_tree.h) and the BSDF sampling fraction of the
// one-sample mixture (Rath et al. 2020, Sec. 5.2). Between iterations the records of the last one
// rebuild it: learned densities are swapped in, crowded leaves split, the trees being built are
// refined. Deterministic: records are applied in the order given, per spatial leaf.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>
#include "core/math.h"
#include "integrators/guiding/directional_tree.h"
#include "integrators/guiding/serial.h"

namespace lt::guiding {

struct TreeSettings {
    // A leaf splits when the records of iteration k that fell into it exceed
    // spatialThreshold * sqrt(2^k) (Mueller 2017, Sec. 5.2; 4000 is the 2019 notes' value for one
    // sample per pixel per pass, which is how our passes run).
    float spatialThreshold = 4000.f;
    float splitFraction = 0.01f;  // directional split (rho of Mueller 2017, Sec. 5.3)
    int maxDirectionalDepth = 20;
    size_t maxBytes = size_t(512) << 20;  // cap on bytes(): no spatial split beyond it
    // Learned BSDF fraction (Mueller et al. 2019's Adam on the KL divergence, weighted as Rath
    // 2020 Eq. 27): alpha = minFraction + (1 - minFraction) * sigmoid(theta), theta starting at 0.
    float minFraction = 0.1f;
    float learningRate = 0.01f;
    float l2 = 0.01f;  // regularisation of theta (pulls alpha towards the middle)
};

// What a camera-walk vertex left for the next iteration (filled by the integrator).
struct Record {
    Vec3 p;                 // the vertex position
    Vec3 d;                 // the sampled unit direction (world)
    float value = 0.f;      // recorded into the directional tree (the target's sample weight)
    // For the learned fraction (valid where `learnFraction`): the sample's integrand f cos L_i
    // (a scalar, already weighted by Rath's relative pixel contribution, Eq. 27), the three
    // densities of the sampled direction (BSDF, guide, mixture the walk sampled with) and the
    // fraction alpha it was sampled with.
    float product = 0.f;
    float bsdfPdf = 0.f, guidePdf = 0.f, mixturePdf = 0.f;
    bool learnFraction = false;
};

// A spatial leaf as the walks read it during a pass.
struct GuideLeaf {
    DirectionalTree sampling;   // sampled this iteration (learned from the last)
    DirectionalTree building;   // receives this iteration's records
    float bsdfFraction = 0.5f;  // alpha of the mixture at this leaf (fixed or learned; updated per pass)
    // The alpha the walks sample with: bsdfFraction as the running iteration started (endIteration
    // copies it), so every pass of an iteration samples with the same tree and MPI ranks may render
    // an iteration's passes in parallel (trainer.h).
    float samplingFraction = 0.5f;
    // Adam's state of the learned fraction.
    float theta = 0.f, adamM = 0.f, adamV = 0.f;
    uint64_t adamSteps = 0;
    uint64_t records = 0;  // records of the running iteration (drives the spatial split)
};

class SDTree {
public:
    // Over the cube centred at `center` with half side `halfSide` (points outside are clamped in).
    SDTree(const Vec3& center, float halfSide, const TreeSettings& settings, float fixedFraction);

    // The leaf containing p (read-only during a pass; never null).
    const GuideLeaf& leaf(const Vec3& p) const;
    // The extent (full side lengths) of the leaf containing p, for the stochastic spatial filter.
    Vec3 leafSize(const Vec3& p) const;

    // Applies one pass's records (in the order given: tile order, then walk order; deterministic
    // whatever the thread count). Stochastic box filters (Mueller 2017 Sec. 5.4 offers box,
    // stochastic and nearest; stochastic is the box filter in expectation at the cost of one
    // look-up per record): each record's position is jittered uniformly over a box the size of the
    // leaf it falls in and its direction over a square the size of the building tree's leaf it
    // falls in, with random numbers from `seed` and the record's index (counted across the
    // batches). When `learnFraction`, each leaf then takes one Adam step per record of it with
    // `learnFraction` set, in order, the gradient taken at the current theta (bsdfFraction is
    // updated from theta after the leaf's records; the walks read samplingFraction). Leaves
    // are processed in parallel (each by one thread). Every record counts in `records`.
    void addRecords(const std::vector<const std::vector<Record>*>& batches, uint64_t seed, bool learnFraction);

    // Ends training iteration k (0-based): every leaf's building tree becomes its sampling tree
    // (with squareRootLeaves() first when `varianceTarget`), leaves with more than
    // spatialThreshold * sqrt(2^k) records split (children copy both trees and the fraction
    // state, record counts halved, a child splitting again while above the threshold, down to
    // depth 48), a split being skipped where it would take bytes() over maxBytes, and the
    // building trees are rebuilt by DirectionalTree::refined from the energy just learned (the
    // new sampling tree's). Every leaf's samplingFraction becomes its bsdfFraction. Record counts
    // are then reset to 0. The cap holds for bytes() after
    // the call if it held for the refined trees before the splits.
    void endIteration(int k, bool varianceTarget);

    size_t nodeCount() const;   // spatial nodes (inner + leaves)
    size_t leafCount() const;   // spatial leaves
    size_t directionalNodes() const;  // over all leaves' sampling and building trees
    size_t bytes() const;  // the nodes, the leaves and every leaf's trees (their bytes()); vectors kept shrunk
    const TreeSettings& settings() const { return settings_; }
    // Leaves in a fixed order (depth-first, child 0 first), with each one's bounds, for dumps.
    struct LeafView { Vec3 lo, hi; const GuideLeaf* leaf; };
    std::vector<LeafView> leaves() const;

    // Checkpoints (serial.h): the whole tree, leaves and learning state included. load() throws
    // std::runtime_error where the bytes are not a tree over this cube with these settings.
    void save(ByteWriter& w) const;
    void load(ByteReader& r);

private:
    struct Node {
        uint32_t child[2] = {0, 0};  // 0: a leaf
        uint32_t leaf = 0;           // index into leaves_ where a leaf
        uint8_t axis = 0;            // the axis it splits (or would split) along
        uint8_t depth = 0;           // root 0
        uint8_t unused[2] = {0, 0};  // (the padding, zeroed: save() copies nodes as they are, so a state's bytes are deterministic)
    };
    // The leaf node containing p (clamped into the cube) and its bounds; children are appended
    // after their parent in nodes_.
    uint32_t findNode(const Vec3& p, Vec3& lo, Vec3& hi) const;
    TreeSettings settings_;
    Vec3 lo_, hi_;
    std::vector<Node> nodes_;
    std::vector<std::unique_ptr<GuideLeaf>> leaves_;
};

}  // namespace lt::guiding
