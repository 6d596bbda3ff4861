// The flat light-subpath store of one iteration (BPT, LT, VCM, PPM): path j's vertices are
// vertices[offset[j] .. offset[j] + count[j]). Filled in parallel by fixed chunks of paths and
// concatenated in chunk order, so its contents do not depend on the thread schedule. Reused
// across iterations (capacity is kept).
#pragma once
#include <vector>
#include "core/path.h"

namespace lt {

class LightPathStore {
public:
    void clear() { vertices_.clear(); offset_.clear(); count_.clear(); }
    size_t paths() const { return offset_.size(); }
    const PathVertex* path(size_t j) const { return vertices_.data() + offset_[j]; }
    int length(size_t j) const { return int(count_[j]); }
    const std::vector<PathVertex>& vertices() const { return vertices_; }
    // Appends the paths built by one chunk of work, in order.
    struct Chunk {
        std::vector<PathVertex> vertices;
        std::vector<uint32_t> counts;
    };
    void append(const Chunk& c) {
        uint32_t off = uint32_t(vertices_.size());
        for (uint32_t n : c.counts) {
            offset_.push_back(off);
            count_.push_back(n);
            off += n;
        }
        vertices_.insert(vertices_.end(), c.vertices.begin(), c.vertices.end());
    }

private:
    std::vector<PathVertex> vertices_;
    std::vector<uint32_t> offset_, count_;
};

// Uniform hash grid over light vertices for range queries (vertex merging). Cells of size 2r;
// a query visits the 8 cells overlapping the query ball. Built sequentially by counting sort
// (deterministic), queried concurrently.
class HashGrid {
public:
    // Indices of the vertices to insert (into `store.vertices()`).
    void build(const std::vector<PathVertex>& vertices, const std::vector<uint32_t>& items, float radius);
    template <class F>
    void query(const Vec3& p, F&& f) const {
        if (cellStarts_.empty()) return;
        Vec3 g = (p - lo_) * invCell_ - Vec3(0.5f);
        glm::ivec3 c0(std::floor(g.x), std::floor(g.y), std::floor(g.z));
        float r2 = radius_ * radius_;
        for (int dz = 0; dz < 2; ++dz)
            for (int dy = 0; dy < 2; ++dy)
                for (int dx = 0; dx < 2; ++dx) {
                    uint32_t h = cellHash(c0 + glm::ivec3(dx, dy, dz));
                    for (uint32_t k = cellStarts_[h]; k < cellStarts_[h + 1]; ++k) {
                        Vec3 d = sortedPos_[k] - p;  // compact copy: the test touches no PathVertex
                        if (glm::dot(d, d) <= r2) f(sorted_[k], (*vertices_)[sorted_[k]]);
                    }
                }
    }
    float radius() const { return radius_; }

private:
    uint32_t cellHash(const glm::ivec3& c) const {
        uint32_t x = uint32_t(c.x) * 73856093u, y = uint32_t(c.y) * 19349663u, z = uint32_t(c.z) * 83492791u;
        return (x ^ y ^ z) % uint32_t(cellStarts_.size() - 1);
    }
    const std::vector<PathVertex>* vertices_ = nullptr;
    std::vector<uint32_t> cellStarts_, sorted_;
    std::vector<Vec3> sortedPos_;
    Vec3 lo_{0.f};
    float invCell_ = 1.f, radius_ = 0.f;
};

}  // namespace lt
