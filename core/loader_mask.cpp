// Mitsuba 3's `mask` BSDF in the XML loader: `opacity` (a value or a texture, default 0.5) and one
// nested bsdf. The material of the shape is the nested model; the opacity goes to the shape
// (MeshDesc::opacity, SphereDesc::opacity), where the intersection applies it (core/opacity.h).
#include <fmt/format.h>

#include "core/loader_materials.h"

namespace lt::loader {

namespace {
// Wrappers of one nested bsdf through which a mask's opacity reaches the shape unchanged.
const std::vector<std::string> kMaskWrappers = {"twosided", "normalmap", "bumpmap"};
}  // namespace

Opacity Materials::opacity(const Elem& e) const {
    const auto it = opacities_.find(&e);
    return it == opacities_.end() ? Opacity{} : it->second;
}

BxdfPtr Materials::buildMask(const Elem& e, Props& p) {
    const Elem* nested = nullptr;
    std::vector<const Elem*> rest;
    for (const Elem* o : p.objects) {
        const Elem& target = deref(doc_, *o);
        if (target.tag != "bsdf") {
            rest.push_back(o);
            continue;
        }
        if (nested) xml::fail(*o, "mask takes one nested bsdf (a second one here; as Mitsuba 3)");
        nested = &target;
    }
    p.objects = rest;
    const std::map<std::string, const Elem*> textures = textureParams(p);
    noObjects(p, "a mask takes one nested bsdf and an opacity texture");
    for (const auto& [name, t] : textures)
        if (name != "opacity")
            xml::fail(*t, fmt::format("mask does not take a texture for '{}' (textured parameter: opacity)", name));
    if (!nested) xml::fail(e, "mask needs one nested <bsdf> (the material of the opaque part)");
    if (nested->type() == "mask") xml::fail(*nested, "a mask inside a mask is not supported: give one opacity");
    Opacity op;
    if (const auto it = textures.find("opacity"); it != textures.end()) {
        op.texture = texture(*it->second);  // (its scalar, clamped to [0, 1] as Mitsuba clamps it)
    } else {
        // A value (<float>, or a colour's scalar as Mitsuba's eval_1 takes it): in [0, 1].
        const Color c = p.getColor("opacity", Color(0.5f));
        op.value = scalarOf(c);
        if (!(op.value >= 0.f && op.value <= 1.f))
            p.failAt("opacity", fmt::format("must be in [0, 1] (got {})", op.value));
    }
    p.finish();
    BxdfPtr inner = bxdf(*nested);
    opacities_[&e] = op;
    return inner;
}

void Materials::inheritOpacity(const Elem& e) {
    if (e.type() == "mask") return;
    for (const auto& c : e.children) {
        if (c->tag != "bsdf" && c->tag != "ref") continue;
        const Elem& target = deref(doc_, *c);
        const auto it = opacities_.find(&target);
        if (target.tag != "bsdf" || it == opacities_.end()) continue;
        if (!isIn(kMaskWrappers, e.type()))
            xml::fail(*c, fmt::format("a mask inside a {} bsdf is not supported (a mask may be the shape's bsdf, or "
                                      "inside {})", e.type(), xml::joinList(kMaskWrappers)));
        opacities_[&e] = it->second;
    }
}

}  // namespace lt::loader
