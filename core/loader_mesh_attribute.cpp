// The loader's part of Mitsuba's mesh_attribute texture (core/mesh_attribute.h): the texture
// element, and the material built per mesh whose texture reads that mesh's attribute.
#include <fmt/format.h>

#include "core/loader_materials.h"

namespace lt::loader {

bool usesMeshAttribute(const xml::Document& doc, const Elem& e) {
    // (depth-limited: a reference cycle is the material builder's error to report)
    auto walk = [&](auto&& self, const Elem& x, int depth) -> bool {
        if (depth > 32) return false;
        const Elem& t = deref(doc, x);
        if (t.tag == "texture" && t.type() == "mesh_attribute") return true;
        if (t.tag != "bsdf" && t.tag != "texture") return false;
        for (const auto& c : t.children)
            if ((c->tag == "bsdf" || c->tag == "texture" || c->tag == "ref") && self(self, *c, depth + 1)) return true;
        return false;
    };
    return walk(walk, e, 0);
}

TexturePtr Materials::meshAttributeTexture(Props& p) {
    if (!p.has("name")) xml::fail(p.owner, "parameter 'name' is required for a mesh_attribute texture");
    const std::string name = p.getString("name", "");
    if (name.rfind("vertex_", 0) != 0 && name.rfind("face_", 0) != 0)
        p.failAt("name", fmt::format("must start with 'vertex_' or 'face_' (got '{}')", name));
    const float scale = p.getFloat("scale", 1.f);
    if (!(std::isfinite(scale) && scale >= 0.f))
        p.failAt("scale", fmt::format("must be finite and >= 0 (got {})", scale));
    if (!shape_) return makeMeshAttributeTexture({name, 1, {}}, {}, scale);  // (checked only: bound per mesh)
    std::vector<std::string> names;
    for (const MeshAttribute& a : *shape_->attributes) {
        if (a.name == name) return makeMeshAttributeTexture(a, *shape_->indices, scale);
        names.push_back(a.name);
    }
    p.failAt("name", fmt::format("{} has no attribute '{}' (its attributes: {})", shape_->what, name,
                                 names.empty() ? std::string("none") : xml::joinList(names)));
}

BxdfPtr Materials::bxdfForShape(const Elem& e, const ShapeAttributes& shape) {
    auto textures = std::move(textures_);
    auto bxdfs = std::move(bxdfs_);
    textures_.clear();
    bxdfs_.clear();
    shape_ = &shape;
    BxdfPtr b;
    try {
        b = bxdf(e);
    } catch (...) {
        shape_ = nullptr;
        textures_ = std::move(textures);
        bxdfs_ = std::move(bxdfs);
        throw;
    }
    shape_ = nullptr;
    textures_ = std::move(textures);
    bxdfs_ = std::move(bxdfs);
    return b;
}

}  // namespace lt::loader
