#include "core/light_paths.h"

namespace lt {

void HashGrid::build(const std::vector<PathVertex>& vertices, const std::vector<uint32_t>& items, float radius) {
    vertices_ = &vertices;
    radius_ = radius;
    cellStarts_.clear();
    sorted_.clear();
    sortedPos_.clear();
    if (items.empty()) return;
    lo_ = Vec3(kInf);
    for (uint32_t i : items) lo_ = glm::min(lo_, vertices[i].p);
    invCell_ = 1.f / (2.f * radius);
    size_t tableSize = std::max<size_t>(items.size(), 1024);
    cellStarts_.assign(tableSize + 1, 0u);
    std::vector<uint32_t> cellOf(items.size());
    for (size_t k = 0; k < items.size(); ++k) {
        Vec3 g = (vertices[items[k]].p - lo_) * invCell_;
        cellOf[k] = cellHash(glm::ivec3(std::floor(g.x), std::floor(g.y), std::floor(g.z)));
        ++cellStarts_[cellOf[k] + 1];
    }
    for (size_t c = 1; c < cellStarts_.size(); ++c) cellStarts_[c] += cellStarts_[c - 1];
    sorted_.resize(items.size());
    std::vector<uint32_t> fill(cellStarts_.begin(), cellStarts_.end() - 1);
    for (size_t k = 0; k < items.size(); ++k) sorted_[fill[cellOf[k]]++] = items[k];
    sortedPos_.resize(sorted_.size());
    for (size_t k = 0; k < sorted_.size(); ++k) sortedPos_[k] = vertices[sorted_[k]].p;
}

}  // namespace lt
