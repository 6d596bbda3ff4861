// The directional quadtree of Mueller et al. 2017 (Sec. 3.3, 5.3) and Rath et al. 2020's
// square-rooted leaves (Eq. 28). See directional_tree.h.
#include "integrators/guiding/directional_tree.h"

#include <algorithm>
#include <cmath>

namespace lt::guiding {

namespace {

constexpr float kOneBelow = 0x1.fffffep-1f;  // the largest float below 1
constexpr double kOneBelowD = 0x1.fffffffffffffp-1;
constexpr double kFourPiD = 12.5663706143591729539;

// Into [0, 1) (NaN goes to 0), so every point of the square has a leaf.
float unitClamp(float x) { return std::fmin(std::fmax(x, 0.f), kOneBelow); }
Vec2 unitClamp(const Vec2& s) { return Vec2(unitClamp(s.x), unitClamp(s.y)); }

// The quadrant of a node containing p (local coordinates of the node's square, in [0,1)^2);
// p becomes the local coordinate in that quadrant. Exact in float: 2p is exact and, for
// 2p in [1, 2), so is 2p - 1 (Sterbenz), so the descent agrees with absolute coordinates.
int descend(Vec2& p) {
    const int qx = p.x >= 0.5f, qy = p.y >= 0.5f;
    p = Vec2(2.f * p.x - float(qx), 2.f * p.y - float(qy));
    return qx | (qy << 1);
}

// Chooses the lower (0) or upper (1) half with probability share / 1 - share and rescales u to
// [0, 1) within the chosen half (share 0: always 1; share 1: always 0 as u < 1).
int pick(double& u, double share) {
    int half;
    if (u < share) {
        u = u / share;
        half = 0;
    } else {
        u = (u - share) / (1.0 - share);
        half = 1;
    }
    u = std::clamp(u, 0.0, kOneBelowD);
    return half;
}

}  // namespace

// The map in float: a round trip is good to a few floats of the square, which only the deepest
// leaves (2^-20, about 16 floats wide) notice; sample() keeps its directions inside those.
Vec2 directionToSquare(const Vec3& d) {
    const float cosTheta = std::clamp(d.z, -1.f, 1.f);
    float phi = std::atan2(d.y, d.x);
    if (phi < 0.f) phi += 2.f * kPi;
    return unitClamp(Vec2((cosTheta + 1.f) * 0.5f, phi * (0.5f * kInvPi)));
}

Vec3 squareToDirection(const Vec2& s) {
    const float x = std::clamp(s.x, 0.f, 1.f), y = std::clamp(s.y, 0.f, 1.f);
    const float cosTheta = 2.f * x - 1.f;
    const float sinTheta = 2.f * std::sqrt(x * (1.f - x));  // sqrt(1 - cos^2) without cancellation
    const float phi = 2.f * kPi * y;
    return Vec3(sinTheta * std::cos(phi), sinTheta * std::sin(phi), cosTheta);
}

DirectionalTree::DirectionalTree() : nodes_(1) {}

double DirectionalTree::rootTotal() const {
    const Node& r = nodes_[0];
    return double(r.energy[0]) + double(r.energy[1]) + double(r.energy[2]) + double(r.energy[3]);
}

bool DirectionalTree::trained() const {
    const double t = rootTotal();
    return t > 0.0 && std::isfinite(t);
}

double DirectionalTree::energy() const { return rootTotal(); }

size_t DirectionalTree::leafCount() const { return 3 * nodes_.size() + 1; }

std::vector<uint8_t> DirectionalTree::nodeDepths() const {
    // Children always follow their parent in nodes_ (the constructor and refined build so).
    std::vector<uint8_t> depth(nodes_.size(), 0);
    for (size_t i = 0; i < nodes_.size(); ++i)
        for (uint32_t c : nodes_[i].child)
            if (c) depth[c] = uint8_t(depth[i] + 1);
    return depth;
}

int DirectionalTree::depth() const {
    const std::vector<uint8_t> d = nodeDepths();
    return int(*std::max_element(d.begin(), d.end()));
}

// Product over the path of 4 e_q / (node total): the density in the square relative to the
// uniform one, i.e. (leaf's share) / (leaf's area) when the sums agree; the same factors
// sample() descends with. Over 4 pi for solid angle.
SolidAnglePdf DirectionalTree::pdf(const Vec3& d) const {
    if (!trained()) return SolidAnglePdf(float(1.0 / kFourPiD));
    Vec2 p = directionToSquare(d);
    double density = 1.0;
    uint32_t n = 0;
    for (;;) {
        const Node& node = nodes_[n];
        const int q = descend(p);
        const double total = double(node.energy[0]) + double(node.energy[1]) + double(node.energy[2]) + double(node.energy[3]);
        // A node without energy lies below a zero quadrant (never reached by sample()); it is
        // treated as uniform in both functions.
        if (total > 0.0) {
            density *= 4.0 * double(node.energy[q]) / total;
            if (density == 0.0) return SolidAnglePdf(0.f);
        }
        if (!node.child[q]) break;
        n = node.child[q];
    }
    return SolidAnglePdf(float(density / kFourPiD));
}

Vec3 DirectionalTree::sample(Vec2 u, SolidAnglePdf* pdfOut) const {
    u = unitClamp(u);
    if (!trained()) {
        if (pdfOut) *pdfOut = SolidAnglePdf(float(1.0 / kFourPiD));
        return squareToDirection(u);
    }
    // u is rescaled in double: at depth 20 a float would keep a few bits only.
    double ux = u.x, uy = u.y;
    float lox = 0.f, loy = 0.f, size = 1.f;  // the chosen square (dyadic: sums are exact)
    double density = 1.0;                     // as pdf() computes it along the same descent
    uint32_t n = 0;
    for (;;) {
        const Node& node = nodes_[n];
        const double e[4] = {node.energy[0], node.energy[1], node.energy[2], node.energy[3]};
        int qx, qy;
        const double left = e[0] + e[2], right = e[1] + e[3];
        if (left + right > 0.0) {
            // x half by its share, then y half within it: a zero quadrant is never chosen.
            qx = pick(ux, left / (left + right));
            const double lower = e[qx], upper = e[qx + 2];
            qy = pick(uy, lower / (lower + upper));
        } else {
            qx = pick(ux, 0.5);
            qy = pick(uy, 0.5);
        }
        size *= 0.5f;
        lox += float(qx) * size;
        loy += float(qy) * size;
        const int q = qx | (qy << 1);
        if (left + right > 0.0) density *= 4.0 * e[q] / (left + right);
        if (!node.child[q]) break;
        n = node.child[q];
    }
    if (pdfOut) *pdfOut = SolidAnglePdf(float(density / kFourPiD));
    // Uniform in the leaf's square [lo, lo + size).
    const Vec2 lo(lox, loy), hi(lox + size, loy + size);
    const Vec2 top(std::nextafter(hi.x, 0.f), std::nextafter(hi.y, 0.f));
    Vec2 s = glm::clamp(Vec2(float(lox + ux * size), float(loy + uy * size)), lo, top);
    Vec3 d = squareToDirection(s);
    // The float direction may map back into a neighbouring leaf (a few floats of the square
    // off), whose density may be 0: pull s halfway to the leaf's centre until d maps back into
    // the leaf, so pdf(d) is the chosen leaf's. The moved mass is within float rounding of the
    // leaf's border.
    // (Above 2^-12 a leaf is 4096 floats wide: no direction strays, and the check is skipped.)
    const Vec2 centre = lo + 0.5f * size;
    for (int i = 0; i < 8 && size < 0x1p-12f; ++i) {
        const Vec2 t = directionToSquare(d);
        if (t.x >= lo.x && t.x < hi.x && t.y >= lo.y && t.y < hi.y) break;
        s = centre + 0.5f * (s - centre);
        d = squareToDirection(s);
    }
    return d;
}

void DirectionalTree::record(const Vec2& s, float value) {
    if (!(value > 0.f) || !std::isfinite(value)) return;  // 0 adds nothing
    Vec2 p = unitClamp(s);
    uint32_t n = 0;
    for (;;) {
        Node& node = nodes_[n];
        const int q = descend(p);
        node.energy[q] += value;
        if (!node.child[q]) return;
        n = node.child[q];
    }
}

float DirectionalTree::leafSize(const Vec2& s) const {
    Vec2 p = unitClamp(s);
    uint32_t n = 0;
    int depth = 0;
    for (;;) {
        const int q = descend(p);
        if (!nodes_[n].child[q]) return std::ldexp(1.f, -(depth + 1));
        n = nodes_[n].child[q];
        ++depth;
    }
}

// Children follow their parents in nodes_, so a reverse sweep sees every child before its
// parent. Leaf quadrant of a node at depth d: solid angle 4 pi 4^-(d+1).
void DirectionalTree::squareRootLeaves() {
    const std::vector<uint8_t> depth = nodeDepths();
    for (size_t i = nodes_.size(); i-- > 0;) {
        Node& node = nodes_[i];
        const double solidAngle = kFourPiD * std::ldexp(1.0, -2 * (int(depth[i]) + 1));
        for (int q = 0; q < 4; ++q) {
            if (node.child[q]) {
                const Node& c = nodes_[node.child[q]];
                node.energy[q] = float(double(c.energy[0]) + double(c.energy[1]) + double(c.energy[2]) + double(c.energy[3]));
            } else {
                node.energy[q] = float(std::sqrt(double(node.energy[q]) * solidAngle));
            }
        }
    }
}

// Depth convention: the quadrant of a node at depth d splits (making a node of depth d + 1) when
// d + 1 < maxDepth, so depth() < maxDepth and leaves are no smaller than 2^-maxDepth.
DirectionalTree DirectionalTree::refined(float splitFraction, int maxDepth) const {
    DirectionalTree out;
    if (!trained()) return out;
    const double total = rootTotal();
    const double fraction = splitFraction;
    const int depthLimit = std::min(maxDepth, kMaxDepth);
    // dst: a node of `out` at `depth`; src: the node of this tree covering the same square, or -1
    // below a leaf of this tree, whose quadrants then hold `even` each (its energy spread evenly).
    auto build = [&](auto&& self, uint32_t dst, int64_t src, double even, int depth) -> void {
        if (depth + 1 >= depthLimit) return;
        for (int q = 0; q < 4; ++q) {
            const double e = src >= 0 ? double(nodes_[size_t(src)].energy[q]) : even;
            if (!(e > 0.0 && e / total > fraction)) continue;
            const uint32_t c = uint32_t(out.nodes_.size());
            out.nodes_.emplace_back();
            out.nodes_[dst].child[q] = c;
            const int64_t srcChild = src >= 0 && nodes_[size_t(src)].child[q] ? int64_t(nodes_[size_t(src)].child[q]) : -1;
            self(self, c, srcChild, 0.25 * e, depth + 1);
        }
    };
    build(build, 0, 0, 0.0, 0);
    out.nodes_.shrink_to_fit();  // (the memory bytes() counts, and SDTree's cap reads)
    return out;
}

void DirectionalTree::save(ByteWriter& w) const { w.putVector(nodes_); }

void DirectionalTree::load(ByteReader& r) {
    std::vector<Node> nodes = r.getVector<Node>();
    if (nodes.empty()) throw std::runtime_error("the guiding state holds a directional tree without a root");
    for (const Node& n : nodes)
        for (uint32_t c : n.child)
            if (c >= nodes.size()) throw std::runtime_error("the guiding state holds a damaged directional tree");
    nodes_ = std::move(nodes);
}

}  // namespace lt::guiding
