#include "core/light_paths.h"

namespace lt {

void HashGrid::build(const LightPathStore& store, float radius, const MisConfig& cfg) {
    radius_ = radius;
    cellStarts_.clear();
    photons_.clear();
    const auto& v = store.vertices();
    const auto& pdfs = store.pdfs();
    std::vector<Photon>& items = items_;
    items.clear();
    double prefix = 0.0;  // lightPrefixSum of the previous vertex of the same path
    for (uint32_t k = 0; k < v.size(); ++k) {
        const PathVertex& y = v[k];
        const PathVertex& y0 = v[k - y.depth];
        const bool hittable = y0.light && y0.light->isHittable();
        const double prevPrefix = prefix;
        prefix = lightPrefixSum(pdfs.data() + (k - y.depth), y.depth, hittable, cfg, y.depth > 0 ? prefix : 0.0);
        if (y.depth < 1 || y.kind != VertexKind::Surface || !y.connectible()) continue;
        const PathVertex& prev = v[k - 1];
        Photon ph;
        ph.p = y.p;
        ph.vertex = k;
        ph.wo = y.wo;
        ph.pdfFwd = y.pdfFwd.value;
        ph.ng = y.ng;
        ph.depth = y.depth;
        ph.lightHittable = hittable;
        ph.prevPdfFwd = prev.pdfFwd.value;
        ph.prevDelta = prev.delta;
        ph.misLight = prevPrefix;
        ph.prevInfinite = prev.infinite;
        ph.beta = y.beta;
        ph.prevP = prev.p;
        ph.prevNg = prev.onSurface() ? prev.ng : Vec3(0.f);
        items.push_back(ph);
    }
    if (items.empty()) return;
    lo_ = Vec3(kInf);
    for (const Photon& ph : items) lo_ = glm::min(lo_, ph.p);
    invCell_ = 1.f / (2.f * radius);
    size_t tableSize = std::max<size_t>(items.size(), 1024);
    cellStarts_.assign(tableSize + 1, 0u);
    std::vector<uint32_t>& cellOf = cellOf_;
    cellOf.resize(items.size());
    for (size_t k = 0; k < items.size(); ++k) {
        Vec3 g = (items[k].p - lo_) * invCell_;
        cellOf[k] = cellHash(glm::ivec3(std::floor(g.x), std::floor(g.y), std::floor(g.z)));
        ++cellStarts_[cellOf[k] + 1];
    }
    for (size_t c = 1; c < cellStarts_.size(); ++c) cellStarts_[c] += cellStarts_[c - 1];
    photons_.resize(items.size());
    std::vector<uint32_t>& fill = fill_;
    fill.assign(cellStarts_.begin(), cellStarts_.end() - 1);
    for (size_t k = 0; k < items.size(); ++k) photons_[fill[cellOf[k]]++] = items[k];
}

}  // namespace lt
