#include "integrators/transport/light_paths.h"
#include "integrators/transport/jg19.h"
#include "integrators/transport/kd13.h"
#include "integrators/transport/opsr.h"
#include <tbb/parallel_for.h>

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
    size_t nv = 0, count = 0;
    std::vector<size_t> base(batches_.size() + 1, 0);  // a batch's first record in the count
    for (size_t c = 0; c < batches_.size(); ++c) {
        nv += batches_[c].vertices;
        base[c + 1] = base[c] + batches_[c].items.size();
    }
    count = base.back();
    if (count == 0) return;
    const size_t tableSize = std::max<size_t>(nv, 1024);
    // Counting sort by cell, sequential and in batch, path and vertex order: deterministic.
    // cellStarts_[c] counts cell c, the running sum makes it the end of c, and the pass in reverse
    // order moves each end down to the cell's start, giving every record its place (its hash's
    // entry becomes the place), in that order within a cell.
    cellStarts_.assign(tableSize + 1, 0u);
    for (Batch& b : batches_)
        for (size_t k = 0; k < b.items.size(); ++k) b.hashes[k] = mapHash(b.hashes[k], tableSize), ++cellStarts_[b.hashes[k]];
    for (size_t c = 1; c < tableSize; ++c) cellStarts_[c] += cellStarts_[c - 1];
    cellStarts_[tableSize] = uint32_t(count);
    for (size_t c = batches_.size(); c-- > 0;)
        for (size_t k = batches_[c].items.size(); k-- > 0;) {
            uint32_t& h = batches_[c].hashes[k];
            h = --cellStarts_[h];
        }
    // In parallel: the records and positions to their places.
    photons_.resize(count);
    positions_.resize(count);
    tbb::parallel_for(size_t(0), batches_.size(), [&](size_t c) {
        const Batch& b = batches_[c];
        for (size_t k = 0; k < b.items.size(); ++k) {
            photons_[b.hashes[k]] = b.items[k];
            positions_[b.hashes[k]] = b.positions[k];
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
