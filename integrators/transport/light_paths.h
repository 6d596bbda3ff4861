// The light-subpath store of one iteration (BPT, LT, VCM, PPM): W x H paths in fixed chunks of
// kChunkPaths, each chunk filled by one task with its paths in order, so the contents do not
// depend on the thread schedule. Reused across iterations (capacity is kept). Alongside the
// vertices it can keep their MIS densities in a compact array, so that a merge can gather a light
// subpath's pdfs without touching its vertices.
#pragma once
#include <vector>
#include "core/huge_pages.h"
#include "integrators/transport/path.h"

namespace lt {

// A light vertex's densities (names: see the top of path.h), apart from the vertex, and its BSDF's
// continuation probability (the factor the gathers put on its predecessor's fromCamera: survival).
struct VertexPdfs {
    float fromLight = 0.f, fromCamera = 0.f;
    float continuation = 1.f;
    bool delta = false;
    static VertexPdfs of(const PathVertex& v) {
        return {v.fromLight.value, v.fromCamera.value, v.bxdf ? v.bxdf->continuation() : 1.f, v.delta};
    }
};

class LightPathStore {
public:
    // Path j is built by chunk j / kChunkPaths, which one thread fills with its paths in order.
    static constexpr size_t kChunkPaths = 1024;

    // The paths of one chunk, where the walks write them: each walk goes straight into the chunk's
    // storage (no copy into a flat array afterwards: on SmallVCM's point-light box that copy and
    // the first touch of its pages were about 8% of BPT's and VCM's time).
    class Chunk {
    public:
        // Room for a walk of up to kMaxPathVertices vertices after the chunk's paths; commit(n)
        // keeps its first n as the chunk's next path (the pointer is valid until the next call).
        PathVertex* next() {
            vertices_.reserve(vertices_.size() + size_t(kMaxPathVertices));
            return vertices_.data() + vertices_.size();
        }
        void commit(int n) {
            start_.push_back(uint32_t(vertices_.size()));
            count_.push_back(uint32_t(n));
            const size_t begin = vertices_.size();
            vertices_.resize(begin + size_t(n));
            if (withPdfs_) {
                pdfs_.reserve(vertices_.size());  // (kept in step with the vertices)
                pdfs_.resize(vertices_.size());
                for (size_t k = begin; k < vertices_.size(); ++k) pdfs_[k] = VertexPdfs::of(vertices_[k]);
            }
        }
        // Empty, capacity kept; withPdfs: also keep the compact densities (merges read them).
        void clear(bool withPdfs) {
            vertices_.resize(0);
            pdfs_.resize(0);
            start_.clear();
            count_.clear();
            withPdfs_ = withPdfs;
        }
        size_t paths() const { return start_.size(); }
        size_t size() const { return vertices_.size(); }  // vertices
        const PathVertex* vertices() const { return vertices_.data(); }
        const VertexPdfs* pdfs() const { return pdfs_.data(); }  // null unless clear(true)
        uint32_t start(size_t local) const { return start_[local]; }
        int length(size_t local) const { return int(count_[local]); }

    private:
        HugeArray<PathVertex> vertices_;
        HugeArray<VertexPdfs> pdfs_;
        std::vector<uint32_t> start_, count_;  // per path: its first vertex in vertices_, its length
        bool withPdfs_ = false;
    };

    // The store of an iteration of nPaths paths, every chunk empty (capacity kept from the last).
    void begin(size_t nPaths, bool withPdfs) {
        paths_ = nPaths;
        chunks_.resize((nPaths + kChunkPaths - 1) / kChunkPaths);
        for (Chunk& c : chunks_) c.clear(withPdfs);
    }
    size_t chunks() const { return chunks_.size(); }
    Chunk& chunk(size_t c) { return chunks_[c]; }
    const Chunk& chunk(size_t c) const { return chunks_[c]; }

    size_t paths() const { return paths_; }
    const PathVertex* path(size_t j) const {
        const Chunk& c = chunks_[j / kChunkPaths];
        return c.vertices() + c.start(j % kChunkPaths);
    }
    const VertexPdfs* pdfs(size_t j) const {  // (begin(n, true) only)
        const Chunk& c = chunks_[j / kChunkPaths];
        return c.pdfs() + c.start(j % kChunkPaths);
    }
    int length(size_t j) const { return chunks_[j / kChunkPaths].length(j % kChunkPaths); }

private:
    std::vector<Chunk> chunks_;
    size_t paths_ = 0;
};

// What a merge needs of a light vertex y[i] (i >= 1) and of its predecessor y[i-1], stored
// contiguously in cell order so a range query reads consecutive memory.
// (Its position is in the grid's compact position array, the only place the query reads it.)
struct Photon {
    uint32_t path = 0;        // the light subpath (its index in the store) of which this is y[i]
    Vec3 wo{0.f};             // towards y[i-1]
    float fromLight = 0.f;    // pL of y[i] (names: see the top of path.h)
    Vec3 ng{0.f};
    uint16_t depth = 0;       // i
    uint8_t lightHittable = 0, prevInfinite = 0;
    Color beta{0.f};
    Vec3 prevP{0.f}, prevNg{0.f};  // y[i-1]; prevNg is zero when y[i-1] is not on a surface
    float prevFromLight = 0.f;     // pL of y[i-1]
    uint8_t prevDelta = 0;
    double misLight = 0.0;         // lightPrefixSum of y[i-1]

    // The one initialiser: the photon of light vertex y = y[i] of light subpath pathIndex
    // (i = y.depth >= 1) and its predecessor prev, written in place (the grid's batches are
    // reused across iterations).
    void set(uint32_t pathIndex, const PathVertex& y, const PathVertex& prev, bool hittable, double prevPrefix) {
        path = pathIndex;
        wo = y.wo;
        fromLight = y.fromLight.value;
        ng = y.ng;
        depth = y.depth;
        lightHittable = hittable;
        prevInfinite = prev.infinite;
        beta = y.beta;
        prevP = prev.p;
        prevNg = prev.onSurface() ? prev.ng : Vec3(0.f);
        prevFromLight = prev.fromLight.value;
        prevDelta = prev.delta;
        misLight = prevPrefix;
    }
};

// Uniform hash grid over light vertices for range queries (vertex merging). Cells of size 2r;
// a query visits the 8 cells overlapping the query ball. Built sequentially by counting sort
// (deterministic), queried concurrently.
class HashGrid {
public:
    // Inserts the light vertices a merge can use: after at least one segment, on a surface, where
    // the regulariser lets a merge gather (reg.mergeable: without one, not a delta vertex; under
    // JG19 also the smooth ones its request makes rough). Instantiated for the renderer's
    // policies in light_paths.cpp.
    // In three steps, so that a light path's photon records are made while its vertices are still
    // in cache (by the task that walked it): begin() before the walks, with one batch per chunk of
    // the store; add() for each light path, in order within its batch (batches concurrently);
    // finish() sorts the records by cell. The grid is the same whatever the thread schedule.
    void begin(size_t batches, float radius);
    template <class Reg>
    void add(size_t batch, uint32_t pathIndex, const PathVertex* y, const VertexPdfs* pdfs, int n,
             const MisConfig& cfg, const Reg& reg);
    void finish();
    // All three over a filled store (built with its densities).
    template <class Reg>
    void build(const LightPathStore& store, float radius, const MisConfig& cfg, const Reg& reg);
    void build(const LightPathStore& store, float radius, const MisConfig& cfg) { build(store, radius, cfg, reg::kNone); }
    // A query in three stages, so that a caller can issue the memory loads of a query early and
    // do other work (connections) while they arrive: the query is bound by memory latency
    // (random cells of a table of one entry per light vertex, photon records in DRAM).
    struct Cells {
        uint32_t hash[8];
        uint32_t begin[8], end[8];
    };
    // Stage 1: the 8 cells overlapping the ball around p; prefetches their table entries.
    void locate(const Vec3& p, Cells& cells) const {
        if (cellStarts_.empty()) return;
        Vec3 g = (p - lo_) * invCell_ - Vec3(0.5f);
        const glm::ivec3 c0 = cellOf(g);
        // cellHash of c0 + (c & 1, (c >> 1) & 1, c >> 2), its products taken once per coordinate.
        const uint32_t hx[2] = {hashX(c0.x), hashX(c0.x + 1)}, hy[2] = {hashY(c0.y), hashY(c0.y + 1)},
                       hz[2] = {hashZ(c0.z), hashZ(c0.z + 1)};
        const size_t tableSize = cellStarts_.size() - 1;
        for (int c = 0; c < 8; ++c) {
            cells.hash[c] = mapHash(mix(hx[c & 1] ^ hy[(c >> 1) & 1] ^ hz[c >> 2]), tableSize);
            __builtin_prefetch(&cellStarts_[cells.hash[c]]);
        }
    }
    // Stage 2: reads the cells' photon ranges; prefetches their positions (the compact array).
    void fetch(Cells& cells) const {
        if (cellStarts_.empty()) return;
        for (int c = 0; c < 8; ++c) {
            cells.begin[c] = cellStarts_[cells.hash[c]];
            cells.end[c] = cellStarts_[cells.hash[c] + 1];
            if (cells.begin[c] == cells.end[c]) continue;
            // Two of the 8 cells may hash to the same entry: scan it once (a photon must not be
            // merged twice; the brute-force comparison test found this). (An empty entry needs
            // no check: about half of them, for a query on a surface.)
            for (int j = 0; j < c; ++j)
                if (cells.hash[j] == cells.hash[c]) cells.end[c] = cells.begin[c];
            // Four positions per cache line; at most four lines per cell.
            for (uint32_t k = cells.begin[c]; k < cells.end[c] && k < cells.begin[c] + 16; k += 4)
                __builtin_prefetch(&positions_[k]);
        }
    }
    // Stage 3: calls f for every photon within the radius of p. Positions are tested first and
    // the records of those inside prefetched together, then f is called on them in order.
    template <class F>
    void scan(const Vec3& p, const Cells& cells, F&& f) const {
        if (cellStarts_.empty()) return;
        const float r2 = radius_ * radius_;
        uint32_t inside[64];
        int n = 0;
        auto flush = [&] {
            for (int j = 0; j < n; ++j) f(photons_[inside[j]]);
            n = 0;
        };
        for (int c = 0; c < 8; ++c)
            for (uint32_t k = cells.begin[c]; k < cells.end[c]; ++k) {
                Vec3 d = Vec3(positions_[k]) - p;
                if (glm::dot(d, d) <= r2) {
                    __builtin_prefetch(&photons_[k]);
                    __builtin_prefetch(reinterpret_cast<const char*>(&photons_[k]) + 64);
                    inside[n++] = k;
                    if (n == 64) flush();
                }
            }
        flush();
    }
    // All three stages at once.
    template <class F>
    void query(const Vec3& p, F&& f) const {
        Cells cells;
        locate(p, cells);
        fetch(cells);
        scan(p, cells, f);
    }
    float radius() const { return radius_; }
    size_t size() const { return photons_.size(); }

private:
    // Teschner et al.'s hash, mixed (murmur3 finaliser) and mapped to [0, tableSize) by a
    // multiply-shift instead of a modulo (eight integer divisions per query were measurable).
    // The integer cell of grid coordinates g: floor, without std::floor's call-free but long
    // sequence on SSE2 (the same integers for |g| < 2^31).
    static int floorToInt(float x) {
        const int i = int(x);
        return float(i) > x ? i - 1 : i;
    }
    static glm::ivec3 cellOf(const Vec3& g) { return {floorToInt(g.x), floorToInt(g.y), floorToInt(g.z)}; }
    static uint32_t hashX(int x) { return uint32_t(x) * 73856093u; }
    static uint32_t hashY(int y) { return uint32_t(y) * 19349663u; }
    static uint32_t hashZ(int z) { return uint32_t(z) * 83492791u; }
    static uint32_t mix(uint32_t h) {
        h ^= h >> 16;
        h *= 0x85ebca6bu;
        h ^= h >> 13;
        h *= 0xc2b2ae35u;
        h ^= h >> 16;
        return h;
    }
    static uint32_t cellHash32(const glm::ivec3& c) { return mix(hashX(c.x) ^ hashY(c.y) ^ hashZ(c.z)); }
    static uint32_t mapHash(uint32_t h, size_t tableSize) { return uint32_t((uint64_t(h) * uint64_t(tableSize)) >> 32); }
    // The records one batch (a chunk of light paths) made, in path and vertex order, with their
    // positions and cells' 32-bit hashes (mapped to the table at finish(), whose size is set by
    // the number of light vertices of all batches).
    struct Batch {
        HugeArray<Photon> items;
        HugeArray<glm::vec4> positions;
        HugeArray<uint32_t> hashes;
        HugeArray<uint32_t> places;  // (finish) each record's place in cell order
        size_t vertices = 0;  // light vertices seen, merge-usable or not
    };
    HugeVector<uint32_t> cellStarts_;
    HugeArray<Photon> photons_;
    HugeArray<glm::vec4> positions_;             // position of photons_[k] (16 bytes), same order
    std::vector<Batch> batches_;                 // kept across iterations
    Vec3 lo_{0.f};
    float invCell_ = 1.f, radius_ = 0.f;
};

}  // namespace lt
