#include "integrators/transport/light_paths.h"
#include "integrators/transport/jg19.h"
#include "integrators/transport/kd13.h"
#include "integrators/transport/opsr.h"
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <algorithm>

namespace lt {

void HashGrid::begin(size_t batches, float radius) {
    radius_ = radius;
    // Cell coordinates are relative to the origin (any fixed origin works; negative cells hash too).
    lo_ = Vec3(0.f);
    invCell_ = 1.f / (2.f * radius);
    batches_.resize(batches);
    for (Batch& b : batches_) {
        b.items.resize(0);
        b.positions.resize(0);
        b.hashes.resize(0);
        b.vertices = 0;
    }
}

template <class Reg>
void HashGrid::add(size_t batch, uint32_t pathIndex, const PathVertex* y, const VertexPdfs* pdfs, int n,
                   const MisConfig& cfg, const Reg& reg) {
    Batch& b = batches_[batch];
    b.vertices += size_t(n);
    size_t k = b.items.size();  // (room for every vertex of the path; the size set at the end)
    b.items.reserve(k + size_t(n));
    b.positions.reserve(k + size_t(n));
    b.hashes.reserve(k + size_t(n));
    const bool hittable = n > 0 && y[0].light && y[0].light->isHittable();
    double prefix = 0.0;  // the light-side MIS prefix, recursive along the path
    for (int i = 0; i < n; ++i) {
        const double prevPrefix = prefix;
        prefix = lightPrefixSum(pdfs, i, hittable, cfg, i > 0 ? prefix : 0.0);
        const PathVertex& v = y[i];
        if (i < 1 || v.kind != VertexKind::Surface || !reg.mergeable(v)) continue;
        b.items.data()[k].set(pathIndex, v, y[i - 1], hittable, prevPrefix);
        b.positions.data()[k] = glm::vec4(v.p, 0.f);
        const Vec3 g = (v.p - lo_) * invCell_;
        b.hashes.data()[k] = cellHash32(cellOf(g));
        ++k;
    }
    b.items.resize(k);
    b.positions.resize(k);
    b.hashes.resize(k);
}

void HashGrid::finish() {
    cellStarts_.clear();
    photons_.resize(0);
    positions_.resize(0);
    size_t nv = 0, count = 0;  // light vertices, and records
    for (const Batch& b : batches_) nv += b.vertices, count += b.items.size();
    if (count == 0) return;
    const size_t tableSize = std::max<size_t>(nv, 1024);
    // Counting sort by cell, in batch, path and vertex order within a cell: deterministic. The
    // cells are split into ranges, one task each (the same result for any number of ranges): a
    // task counts its cells' records (cellStarts_[c] counts cell c), the ranges' totals give each
    // range its first place, the running sum makes each entry the end of its cell, and a pass over
    // the records in reverse order moves each end down to its cell's start, giving every record
    // of the range its place.
    tbb::parallel_for(size_t(0), batches_.size(), [&](size_t c) {
        Batch& b = batches_[c];
        for (size_t k = 0; k < b.items.size(); ++k) b.hashes[k] = mapHash(b.hashes[k], tableSize);
        b.places.resize(b.items.size());
    });
    cellStarts_.assign(tableSize + 1, 0u);
    const size_t ranges = size_t(std::clamp(tbb::this_task_arena::max_concurrency(), 1, 64));
    auto rangeBegin = [&](size_t r) { return uint32_t(tableSize * r / ranges); };
    std::vector<size_t> rangeFirst(ranges + 1, 0);
    tbb::parallel_for(size_t(0), ranges, [&](size_t r) {
        const uint32_t lo = rangeBegin(r), hi = rangeBegin(r + 1);
        size_t n = 0;
        for (const Batch& b : batches_)
            for (size_t k = 0; k < b.items.size(); ++k)
                if (b.hashes[k] >= lo && b.hashes[k] < hi) ++cellStarts_[b.hashes[k]], ++n;
        rangeFirst[r + 1] = n;
    });
    for (size_t r = 0; r < ranges; ++r) rangeFirst[r + 1] += rangeFirst[r];
    tbb::parallel_for(size_t(0), ranges, [&](size_t r) {
        const uint32_t lo = rangeBegin(r), hi = rangeBegin(r + 1);
        uint32_t end = uint32_t(rangeFirst[r]);
        for (uint32_t c = lo; c < hi; ++c) cellStarts_[c] = end += cellStarts_[c];
        for (size_t c = batches_.size(); c-- > 0;) {
            Batch& b = batches_[c];
            for (size_t k = b.items.size(); k-- > 0;)
                if (b.hashes[k] >= lo && b.hashes[k] < hi) b.places[k] = --cellStarts_[b.hashes[k]];
        }
    });
    cellStarts_[tableSize] = uint32_t(count);
    // In parallel: the records and positions to their places.
    photons_.resize(count);
    positions_.resize(count);
    tbb::parallel_for(size_t(0), batches_.size(), [&](size_t c) {
        const Batch& b = batches_[c];
        for (size_t k = 0; k < b.items.size(); ++k) {
            photons_[b.places[k]] = b.items[k];
            positions_[b.places[k]] = b.positions[k];
        }
    });
}

template <class Reg>
void HashGrid::build(const LightPathStore& store, float radius, const MisConfig& cfg, const Reg& reg) {
    begin(store.chunks(), radius);
    tbb::parallel_for(size_t(0), store.chunks(), [&](size_t c) {
        for (size_t local = 0; local < store.chunk(c).paths(); ++local) {
            const size_t j = c * LightPathStore::kChunkPaths + local;
            add(c, uint32_t(j), store.path(j), store.pdfs(j), store.length(j), cfg, reg);
        }
    });
    finish();
}

#define LT_INSTANTIATE_GRID(Reg)                                                                        \
    template void HashGrid::add(size_t, uint32_t, const PathVertex*, const VertexPdfs*, int, const MisConfig&, \
                                const Reg&);                                                            \
    template void HashGrid::build(const LightPathStore&, float, const MisConfig&, const Reg&);
LT_INSTANTIATE_GRID(reg::None)
LT_INSTANTIATE_GRID(reg::Jg19)
LT_INSTANTIATE_GRID(reg::Kd13)
LT_INSTANTIATE_GRID(reg::Opsr)

}  // namespace lt
