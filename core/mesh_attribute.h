// Mitsuba 3's mesh_attribute texture (src/textures/mesh_attribute.cpp, Mesh::eval_attribute): a
// per-vertex attribute interpolated with the hit's barycentrics, or a per-face one, times `scale`.
// Attributes come from PLY files (core/mesh_io.h: Mitsuba's naming, "vertex_color",
// "face_weight", ...), with 1 or 3 channels (1: a grey value).
//
// Textures are looked up by uv (core/texture/texture.h); an attribute needs the primitive and the
// barycentrics instead. A mesh whose material reads an attribute (MeshDesc::attributeKey) carries,
// in the uv slot of its hits, the key (primitive, b1, b2) packed into the two floats' 64 bits (a
// 24-bit primitive index, 20 bits per barycentric: steps of 1e-6, below float rounding of the
// colours): no interface between the hit and the texture changes. The loader builds such a
// material for that mesh alone, its texture bound to the mesh's attribute and triangles.
#pragma once
#include <cstring>
#include <memory>
#include <string>
#include <vector>
#include "core/math.h"
#include "core/texture/texture.h"

namespace lt {

struct MeshAttribute {
    std::string name;           // "vertex_<x>" or "face_<x>"
    int channels = 1;           // 1 or 3
    std::vector<float> values;  // channels per vertex or per triangle (a polygon's value on each of its triangles)
    bool face() const { return name.rfind("face_", 0) == 0; }
};
using MeshAttributes = std::vector<MeshAttribute>;

// The largest triangle count a mesh whose material reads an attribute may have (the key's 24 bits).
inline constexpr uint32_t kMaxAttributeTriangles = 1u << 24;

inline Vec2 attributeKey(uint32_t prim, float b1, float b2) {
    auto q = [](float b) { return uint64_t(std::clamp(b, 0.f, 1.f) * float((1u << 20) - 1) + 0.5f); };
    const uint64_t k = uint64_t(prim & 0xFFFFFFu) | (q(b1) << 24) | (q(b2) << 44);
    const uint32_t w[2] = {uint32_t(k), uint32_t(k >> 32)};
    Vec2 uv;
    std::memcpy(&uv.x, &w[0], 4);
    std::memcpy(&uv.y, &w[1], 4);
    return uv;
}
inline void decodeAttributeKey(const Vec2& uv, uint32_t& prim, float& b1, float& b2) {
    uint32_t w[2];
    std::memcpy(&w[0], &uv.x, 4);
    std::memcpy(&w[1], &uv.y, 4);
    const uint64_t k = uint64_t(w[0]) | (uint64_t(w[1]) << 32);
    prim = uint32_t(k & 0xFFFFFFu);
    b1 = float((k >> 24) & 0xFFFFFu) / float((1u << 20) - 1);
    b2 = float((k >> 44) & 0xFFFFFu) / float((1u << 20) - 1);
}

// The texture of attribute `a` of a mesh with triangles `indices` (3 per triangle), times scale.
TexturePtr makeMeshAttributeTexture(const MeshAttribute& a, std::vector<uint32_t> indices, float scale);

}  // namespace lt
