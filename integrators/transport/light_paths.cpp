#include "integrators/transport/light_paths.h"
#include "integrators/transport/jg19.h"
#include "integrators/transport/kd13.h"
#include "integrators/transport/opsr.h"
#include <tbb/parallel_for.h>

namespace lt {

template <class Reg>
void HashGrid::build(const LightPathStore& store, float radius, const MisConfig& cfg, const Reg& reg) {
    radius_ = radius;
    cellStarts_.clear();
    photons_.resize(0);
    positions_.resize(0);
    // Vertex k of the iteration: chunk c's vertices follow those of the chunks before it (base).
    std::vector<size_t> base(store.chunks() + 1, 0);
    for (size_t c = 0; c < store.chunks(); ++c) base[c + 1] = base[c] + store.chunk(c).size();
    const size_t nv = base.back();
    // Cell coordinates are relative to the origin (any fixed origin works; negative cells hash too).
    lo_ = Vec3(0.f);
    invCell_ = 1.f / (2.f * radius);
    const size_t tableSize = std::max<size_t>(nv, 1024);
    // (1) In parallel, a chunk at a time: one photon record (or none) per light vertex, and its cell.
    items_.resize(nv);
    itemPos_.resize(nv);
    cellOf_.resize(nv);
    tbb::parallel_for(size_t(0), store.chunks(), [&](size_t c) {
        const LightPathStore::Chunk& chunk = store.chunk(c);
        for (size_t local = 0; local < chunk.paths(); ++local) {
            const size_t first = chunk.start(local);
            const PathVertex* y = chunk.vertices() + first;
            const VertexPdfs* pdfs = chunk.pdfs() + first;
            const uint32_t pathIndex = uint32_t(c * LightPathStore::kChunkPaths + local);
            const bool hittable = y[0].light && y[0].light->isHittable();
            double prefix = 0.0;  // the light-side MIS prefix, recursive along the path
            for (int i = 0; i < chunk.length(local); ++i) {
                const size_t k = base[c] + first + size_t(i);
                const double prevPrefix = prefix;
                prefix = lightPrefixSum(pdfs, i, hittable, cfg, i > 0 ? prefix : 0.0);
                const PathVertex& v = y[i];
                if (i < 1 || v.kind != VertexKind::Surface || !reg.mergeable(v)) {
                    cellOf_[k] = UINT32_MAX;
                    continue;
                }
                items_[k].set(pathIndex, v, y[i - 1], hittable, prevPrefix);
                itemPos_[k] = glm::vec4(v.p, 0.f);
                Vec3 g = (v.p - lo_) * invCell_;
                cellOf_[k] = cellHashMod(glm::ivec3(std::floor(g.x), std::floor(g.y), std::floor(g.z)), tableSize);
            }
        }
    });
    // (2) Counting sort by cell, sequential and in vertex order: deterministic. Only the vertex
    // indices move in the sequential pass (the records follow in parallel): cellStarts_[c] counts
    // cell c, the running sum makes it the end of c, and the scatter, in reverse vertex order,
    // moves each end down to the cell's start, keeping vertex order within a cell.
    cellStarts_.assign(tableSize + 1, 0u);
    size_t count = 0;
    for (size_t k = 0; k < nv; ++k)
        if (cellOf_[k] != UINT32_MAX) ++cellStarts_[cellOf_[k]], ++count;
    if (count == 0) {
        cellStarts_.clear();
        return;
    }
    for (size_t c = 1; c < tableSize; ++c) cellStarts_[c] += cellStarts_[c - 1];
    cellStarts_[tableSize] = uint32_t(count);
    order_.resize(count);
    for (size_t k = nv; k-- > 0;)
        if (cellOf_[k] != UINT32_MAX) order_[--cellStarts_[cellOf_[k]]] = uint32_t(k);
    // (3) In parallel: the records and positions in cell order.
    photons_.resize(count);
    positions_.resize(count);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 16384), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t d = r.begin(); d < r.end(); ++d) {
            photons_[d] = items_[order_[d]];
            positions_[d] = itemPos_[order_[d]];
        }
    });
}

template void HashGrid::build(const LightPathStore&, float, const MisConfig&, const reg::None&);
template void HashGrid::build(const LightPathStore&, float, const MisConfig&, const reg::Jg19&);
template void HashGrid::build(const LightPathStore&, float, const MisConfig&, const reg::Kd13&);
template void HashGrid::build(const LightPathStore&, float, const MisConfig&, const reg::Opsr&);

}  // namespace lt
