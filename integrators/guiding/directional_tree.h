// The directional half of Mueller et al. 2017's SD-tree ("Practical Path Guiding", Sec. 3.3): a
// quadtree over the cylindrical equal-area square of the sphere, whose leaves hold energies and
// whose density is piecewise constant. Used twice per spatial leaf (sd_tree.h): one tree is
// sampled while the next one is built from the records of the running iteration.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>
#include "core/math.h"
#include "integrators/guiding/serial.h"

namespace lt::guiding {

// The equal-area map (Mueller 2017, Sec. 3.3): a world direction with polar angle theta about +z
// and azimuth phi in [0, 2 pi) goes to s = ((cos theta + 1) / 2, phi / (2 pi)) in [0,1)^2, so a
// region's solid angle is 4 pi times its area in the square.
Vec2 directionToSquare(const Vec3& d);
Vec3 squareToDirection(const Vec2& s);

class DirectionalTree {
public:
    // The root alone (four leaves), no energy (density uniform, 1 / (4 pi)).
    DirectionalTree();

    // --- sampling (read-only; many threads at once) ---
    // Whether the tree holds energy (a tree with none is not sampled: the guide is off there).
    bool trained() const;
    // The density of d in solid angle: the leaf's share of the tree's energy over the leaf's solid
    // angle (4 pi / 4^(d+1) for a quadrant of a node at depth d); 1 / (4 pi) for an untrained tree.
    SolidAnglePdf pdf(const Vec3& d) const;
    // A direction with density pdf(d), from u in [0,1)^2 (descends by the children's energies,
    // reusing u; then uniform in the leaf's square). A quadrant without energy is never chosen,
    // and the direction maps back into the chosen leaf (pdf(d) > 0 for a trained tree).
    Vec3 sample(Vec2 u, SolidAnglePdf* pdf = nullptr) const;  // (pdf: the density of the direction drawn)

    // --- building (one thread per tree, between passes) ---
    // Adds `value` (finite, >= 0; others are ignored) to the leaf containing s and to every node
    // above it.
    void record(const Vec2& s, float value);
    // The side length in the square of the leaf containing s (2^-(d+1) for a quadrant of a node at depth d), for the
    // stochastic box filter of the records.
    float leafSize(const Vec2& s) const;
    // The sum of the recorded values.
    double energy() const;
    // Rath et al. 2020 Eq. 28: each leaf's energy E becomes sqrt(E * solid angle of the leaf) and
    // the inner nodes the sums of their children (the variance-aware target's sampling weights).
    void squareRootLeaves();
    // PPG's rebuild (Mueller 2017, Sec. 5.3): a new structure from this tree's energies, with all
    // energies zero. A node is split into four while its share of the root's energy exceeds
    // splitFraction and its depth is below maxDepth; a leaf of this tree that must split is
    // refined further as if its energy were spread evenly over its quadrants. An untrained tree
    // gives a single leaf. Depth convention: a quadrant of a node at depth d splits only when
    // d + 1 < maxDepth, so depth() < maxDepth and no leaf is smaller than 2^-maxDepth (maxDepth
    // is capped at kMaxDepth). splitFraction must be > 0 (0 splits every lit leaf to maxDepth).
    DirectionalTree refined(float splitFraction, int maxDepth) const;

    // Leaves of 2^-22 hold a few float positions of the square (directionToSquare's resolution).
    static constexpr int kMaxDepth = 22;

    size_t nodeCount() const { return nodes_.size(); }
    size_t leafCount() const;  // leaf quadrants: 3 nodeCount() + 1
    int depth() const;  // of the deepest node (0: the root alone)
    size_t bytes() const { return sizeof(*this) + nodes_.size() * sizeof(Node); }  // (vectors kept shrunk)

    // Checkpoints (serial.h): the nodes as they are.
    void save(ByteWriter& w) const;
    void load(ByteReader& r);

private:
    // Node 0 is the root. A node covers a square of the map and holds its four quadrants'
    // energies; quadrant q (x half q & 1, y half q >> 1) is a leaf where child[q] is 0, else the
    // index of the node that splits it. The root alone is depth 0 (four leaves of 1/4 the square).
    struct Node {
        std::array<float, 4> energy{};
        std::array<uint32_t, 4> child{};
    };
    // Children always follow their parent in nodes_ (squareRootLeaves sweeps backwards).
    std::vector<Node> nodes_;

    double rootTotal() const;                 // the root's four energies, summed in double
    std::vector<uint8_t> nodeDepths() const;  // depth of every node
};

}  // namespace lt::guiding
