#include "core/mesh_attribute.h"

#include <fmt/format.h>

namespace lt {

namespace {

class MeshAttributeTexture final : public Texture {
public:
    MeshAttributeTexture(const MeshAttribute& a, std::vector<uint32_t> indices, float scale)
        : name_(a.name), face_(a.face()), indices_(std::move(indices)), scale_(scale) {
        const size_t n = a.values.size() / size_t(a.channels);
        values_.reserve(n);
        for (size_t i = 0; i < n; ++i)
            values_.push_back(a.channels == 3 ? Color(a.values[3 * i], a.values[3 * i + 1], a.values[3 * i + 2])
                                              : Color(a.values[i]));
        Color lo(kInf), hi(-kInf), sum(0.f);
        for (const Color& c : values_) lo = glm::min(lo, c), hi = glm::max(hi, c), sum += c;
        if (values_.empty()) lo = hi = Color(0.f);
        // (a value outside [lo, hi] cannot be interpolated: the bounds are the extremes)
        min_ = scale_ * lo, max_ = scale_ * hi;
        mean_ = values_.empty() ? Color(0.f) : scale_ * sum / float(values_.size());
    }
    Color eval(const Vec2& key) const override {
        uint32_t prim;
        float b1, b2;
        decodeAttributeKey(key, prim, b1, b2);
        if (face_) return prim < values_.size() ? scale_ * values_[prim] : Color(0.f);
        if (size_t(3) * prim + 2 >= indices_.size()) return Color(0.f);
        const uint32_t* t = &indices_[size_t(3) * prim];
        const float b0 = std::max(0.f, 1.f - b1 - b2);
        return scale_ * (b0 * values_[t[0]] + b1 * values_[t[1]] + b2 * values_[t[2]]);
    }
    Color maxValue() const override { return max_; }
    Color minValue() const override { return min_; }
    Color meanValue() const override { return mean_; }
    std::string name() const override { return fmt::format("mesh_attribute({})", name_); }

private:
    std::string name_;
    bool face_;
    std::vector<Color> values_;
    std::vector<uint32_t> indices_;
    float scale_;
    Color min_{0.f}, max_{0.f}, mean_{0.f};
};

}  // namespace

TexturePtr makeMeshAttributeTexture(const MeshAttribute& a, std::vector<uint32_t> indices, float scale) {
    return std::make_shared<MeshAttributeTexture>(a, std::move(indices), scale);
}

}  // namespace lt
