// The flat light-subpath store of one iteration (BPT, LT, VCM, PPM): path j's vertices are
// vertices[offset[j] .. offset[j] + count[j]). Filled in parallel by fixed chunks of paths and
// concatenated in chunk order, so its contents do not depend on the thread schedule. Reused
// across iterations (capacity is kept). Alongside the vertices it keeps their MIS densities in a
// compact array, so that a merge can gather a light subpath's pdfs without touching its vertices.
#pragma once
#include <vector>
#include "core/path.h"

namespace lt {

struct VertexPdfs {
    float fwd = 0.f, rev = 0.f;  // pdfFwd, pdfRev (area measure)
    bool delta = false;
};

class LightPathStore {
public:
    void clear() { vertices_.clear(); pdfs_.clear(); offset_.clear(); count_.clear(); }
    size_t paths() const { return offset_.size(); }
    const PathVertex* path(size_t j) const { return vertices_.data() + offset_[j]; }
    int length(size_t j) const { return int(count_[j]); }
    const std::vector<PathVertex>& vertices() const { return vertices_; }
    const std::vector<VertexPdfs>& pdfs() const { return pdfs_; }

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
        for (const PathVertex& v : c.vertices) pdfs_.push_back({v.pdfFwd.value, v.pdfRev.value, v.delta});
    }

private:
    std::vector<PathVertex> vertices_;
    std::vector<VertexPdfs> pdfs_;
    std::vector<uint32_t> offset_, count_;
};

// What a merge needs of a light vertex y[i] (i >= 1) and of its predecessor y[i-1], stored
// contiguously in cell order so a range query reads consecutive memory.
struct Photon {
    Vec3 p{0.f};
    uint32_t vertex = 0;      // index of y[i] in the store; y[0] is at vertex - depth
    Vec3 wo{0.f};             // towards y[i-1]
    float pdfFwd = 0.f;       // area density of y[i] under the light walk
    Vec3 ng{0.f};
    uint16_t depth = 0;       // i
    uint8_t lightHittable = 0, prevInfinite = 0;
    Color beta{0.f};
    Vec3 prevP{0.f}, prevNg{0.f};  // y[i-1]; prevNg is zero when y[i-1] is not on a surface
    float prevPdfFwd = 0.f;        // pL[i-1]
    uint8_t prevDelta = 0;
    double misLight = 0.0;         // lightPrefixSum of y[i-1]
};

// Uniform hash grid over light vertices for range queries (vertex merging). Cells of size 2r;
// a query visits the 8 cells overlapping the query ball. Built sequentially by counting sort
// (deterministic), queried concurrently.
class HashGrid {
public:
    // Inserts the light vertices a merge can use: after at least one segment, on a surface,
    // not sampled through a delta lobe.
    void build(const LightPathStore& store, float radius, const MisConfig& cfg);
    template <class F>
    void query(const Vec3& p, F&& f) const {
        if (cellStarts_.empty()) return;
        Vec3 g = (p - lo_) * invCell_ - Vec3(0.5f);
        glm::ivec3 c0(std::floor(g.x), std::floor(g.y), std::floor(g.z));
        float r2 = radius_ * radius_;
        // The query is bound by memory latency: issue the 8 cells' loads before using any.
        uint32_t h[8];
        for (int c = 0; c < 8; ++c) {
            h[c] = cellHash(c0 + glm::ivec3(c & 1, (c >> 1) & 1, c >> 2));
            __builtin_prefetch(&cellStarts_[h[c]]);
        }
        uint32_t begin[8], end[8];
        for (int c = 0; c < 8; ++c) {
            begin[c] = cellStarts_[h[c]];
            end[c] = cellStarts_[h[c] + 1];
            if (begin[c] < end[c]) __builtin_prefetch(&photons_[begin[c]]);
        }
        for (int c = 0; c < 8; ++c)
            for (uint32_t k = begin[c]; k < end[c]; ++k) {
                Vec3 d = photons_[k].p - p;
                if (glm::dot(d, d) <= r2) f(photons_[k]);
            }
    }
    float radius() const { return radius_; }
    size_t size() const { return photons_.size(); }

private:
    static uint32_t cellHashMod(const glm::ivec3& c, size_t tableSize) {
        uint32_t x = uint32_t(c.x) * 73856093u, y = uint32_t(c.y) * 19349663u, z = uint32_t(c.z) * 83492791u;
        return (x ^ y ^ z) % uint32_t(tableSize);
    }
    uint32_t cellHash(const glm::ivec3& c) const { return cellHashMod(c, cellStarts_.size() - 1); }
    std::vector<uint32_t> cellStarts_;
    std::vector<Photon> photons_;
    std::vector<Photon> items_;                   // scratch, kept across iterations
    std::vector<uint32_t> cellOf_, fill_;         // scratch
    Vec3 lo_{0.f};
    float invCell_ = 1.f, radius_ = 0.f;
};

}  // namespace lt
