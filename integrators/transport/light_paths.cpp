#include "integrators/transport/light_paths.h"
#include "integrators/transport/jg19.h"
#include "integrators/transport/kd13.h"
#include "integrators/transport/opsr.h"
#include <tbb/parallel_for.h>

namespace lt {

void LightPathStore::assign(std::span<const Chunk> chunks) {
    // Where each chunk's vertices and paths go.
    std::vector<size_t> vertexBase(chunks.size() + 1, 0), pathBase(chunks.size() + 1, 0);
    for (size_t c = 0; c < chunks.size(); ++c) {
        vertexBase[c + 1] = vertexBase[c] + chunks[c].vertices.size();
        pathBase[c + 1] = pathBase[c] + chunks[c].counts.size();
    }
    vertices_.resize(vertexBase.back());
    pdfs_.resize(vertexBase.back());
    offset_.resize(pathBase.back());
    count_.resize(pathBase.back());
    tbb::parallel_for(size_t(0), chunks.size(), [&](size_t c) {
        const Chunk& chunk = chunks[c];
        std::copy(chunk.vertices.begin(), chunk.vertices.end(), vertices_.data() + vertexBase[c]);
        for (size_t k = 0; k < chunk.vertices.size(); ++k)
            pdfs_[vertexBase[c] + k] = VertexPdfs::of(chunk.vertices[k]);
        size_t off = vertexBase[c];
        for (size_t j = 0; j < chunk.counts.size(); ++j) {
            offset_[pathBase[c] + j] = uint32_t(off);
            count_[pathBase[c] + j] = chunk.counts[j];
            off += chunk.counts[j];
        }
    });
}

template <class Reg>
void HashGrid::build(const LightPathStore& store, float radius, const MisConfig& cfg, const Reg& reg) {
    radius_ = radius;
    cellStarts_.clear();
    photons_.resize(0);
    positions_.resize(0);
    const auto& v = store.vertices();
    const auto& pdfs = store.pdfs();
    const size_t nv = v.size();
    // Cell coordinates are relative to the origin (any fixed origin works; negative cells hash too).
    lo_ = Vec3(0.f);
    invCell_ = 1.f / (2.f * radius);
    const size_t tableSize = std::max<size_t>(nv, 1024);
    // (1) In parallel: one photon record (or none) per light vertex, and its cell.
    items_.resize(nv);
    cellOf_.resize(nv);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 8192), [&](const tbb::blocked_range<size_t>& r) {
        // The light-side MIS prefix is recursive along each path: restart it at the range's path.
        size_t k0 = r.begin() - v[r.begin()].depth;
        double prefix = 0.0;
        for (size_t k = k0; k < r.end(); ++k) {
            const PathVertex& y = v[k];
            const PathVertex& y0 = v[k - y.depth];
            const bool hittable = y0.light && y0.light->isHittable();
            const double prevPrefix = prefix;
            prefix = lightPrefixSum(pdfs.data() + (k - y.depth), y.depth, hittable, cfg, y.depth > 0 ? prefix : 0.0);
            if (k < r.begin()) continue;
            if (y.depth < 1 || y.kind != VertexKind::Surface || !reg.mergeable(y)) {
                cellOf_[k] = UINT32_MAX;
                continue;
            }
            items_[k].set(uint32_t(k), y, v[k - 1], hittable, prevPrefix);
            Vec3 g = (y.p - lo_) * invCell_;
            cellOf_[k] = cellHashMod(glm::ivec3(std::floor(g.x), std::floor(g.y), std::floor(g.z)), tableSize);
        }
    });
    // (2) Counting sort by cell, sequential and in vertex order: deterministic.
    cellStarts_.assign(tableSize + 1, 0u);
    size_t count = 0;
    for (size_t k = 0; k < nv; ++k)
        if (cellOf_[k] != UINT32_MAX) ++cellStarts_[cellOf_[k] + 1], ++count;
    if (count == 0) {
        cellStarts_.clear();
        return;
    }
    for (size_t c = 1; c < cellStarts_.size(); ++c) cellStarts_[c] += cellStarts_[c - 1];
    photons_.resize(count);
    fill_.assign(cellStarts_.begin(), cellStarts_.end() - 1);
    positions_.resize(count);
    for (size_t k = 0; k < nv; ++k) {
        if (cellOf_[k] == UINT32_MAX) continue;
        const uint32_t dst = fill_[cellOf_[k]]++;
        photons_[dst] = items_[k];
        positions_[dst] = glm::vec4(v[k].p, 0.f);
    }
}

template void HashGrid::build(const LightPathStore&, float, const MisConfig&, const reg::None&);
template void HashGrid::build(const LightPathStore&, float, const MisConfig&, const reg::Jg19&);
template void HashGrid::build(const LightPathStore&, float, const MisConfig&, const reg::Kd13&);
template void HashGrid::build(const LightPathStore&, float, const MisConfig&, const reg::Opsr&);

}  // namespace lt
