// Emitters of the Mitsuba XML loader (core/loader_emitters.cpp). Internal to core/loader.cpp.
#pragma once
#include <map>
#include <string>
#include <vector>
#include "core/loader_materials.h"
#include "core/scene_desc.h"

namespace lt::loader {

class Emitters {
public:
    // emitters: the scene's list, which topEmitter appends to (and reads: one environment only).
    Emitters(const xml::Document& doc, Materials& materials, std::vector<EmitterDesc>& emitters,
             std::vector<std::string>& warnings);

    // An <emitter type="area"> (inside a shape, or declared with an id and referenced).
    EmitterDesc areaDesc(const Elem& e);
    // An <emitter> at the top level: appended to the scene's emitters, or, for an area emitter with
    // an id, checked and kept in declaredAreas until a shape refers to it.
    void topEmitter(const Elem& e);

    std::vector<const Elem*> declaredAreas;

private:
    void warn(const Elem& e, const std::string& msg);
    // The texture given for `name`, taken out of `textures` (null if none).
    TexturePtr emitterTexture(std::map<std::string, const Elem*>& textures, const std::string& name);
    void projector(const Elem& e, Props& p, std::map<std::string, const Elem*>& textures, EmitterDesc& d);

    const xml::Document& doc_;
    Materials& materials_;
    std::vector<EmitterDesc>& emitters_;
    std::vector<std::string>& warnings_;
};

}  // namespace lt::loader
