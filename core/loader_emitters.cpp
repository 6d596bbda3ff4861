// Emitters of the Mitsuba XML loader: area emitters (inside shapes, or declared with an id and
// referenced), point, spot (with a projected texture), directional, constant, envmap and projector
// (core/lights.h, core/textured_lights.cpp). Internal to core/loader.cpp.
#include "core/loader_emitters.h"

#include <fmt/format.h>

#include <cmath>
#include "core/envmap.h"
#include "core/lights.h"
#include "core/loader.h"

namespace lt::loader {

using xml::joinList;

namespace {

const std::vector<std::string> kEmitterTypes = {"area (inside a shape)", "point", "spot", "directional", "constant",
                                                "envmap", "projector"};

// Refuses the textures an emitter of this type has no use for, naming the first.
void noTexturesOn(const std::map<std::string, const Elem*>& textures, const std::string& type) {
    if (!textures.empty())
        xml::fail(*textures.begin()->second,
                  fmt::format("{} emitter: parameter '{}' cannot be a texture (textures: area 'radiance', spot "
                              "'texture', projector 'irradiance')", type, textures.begin()->first));
}

// Mitsuba 3's `sampling_weight` of every emitter (render/emitter.cpp, default 1): the light's
// choice among the scene's lights scales with it (core/scene.cpp, lightSelectionWeights).
float samplingWeight(Props& p) {
    const float w = p.getFloat("sampling_weight", 1.f);
    if (!(std::isfinite(w) && w >= 0.f))
        p.failAt("sampling_weight", fmt::format("must be finite and >= 0 (got {})", w));
    return w;
}

}  // namespace

Emitters::Emitters(const xml::Document& doc, Materials& materials, std::vector<EmitterDesc>& emitters,
                   std::vector<std::string>& warnings)
    : doc_(doc), materials_(materials), emitters_(emitters), warnings_(warnings) {}

void Emitters::warn(const Elem& e, const std::string& msg) {
    warnings_.push_back(fmt::format("{}: {}: {}", e.where(), e.describe(), msg));
}

EmitterDesc Emitters::areaDesc(const Elem& e) {
    Props p(e);
    EmitterDesc d;
    d.type = EmitterType::Area;
    d.source = e.where();
    // radiance: a value or a texture of the surface's uv (core/textured_lights.cpp)
    std::map<std::string, const Elem*> textures = materials_.textureParams(p);
    d.texture = emitterTexture(textures, "radiance");
    if (!d.texture) d.value = nonNegColor(p, "radiance", Color(1.f));
    noTexturesOn(textures, "area");
    d.samplingWeight = samplingWeight(p);
    noObjects(p, "textures are not supported");
    p.finish();
    return d;
}

TexturePtr Emitters::emitterTexture(std::map<std::string, const Elem*>& textures, const std::string& name) {
    auto it = textures.find(name);
    if (it == textures.end()) return nullptr;
    TexturePtr tex = materials_.texture(*it->second);
    textures.erase(it);
    return tex;
}

// Mitsuba 3's projector (src/emitters/projector.cpp): irradiance (a texture or a value, required),
// scale, to_world (a rotation and a translation), and the perspective camera's fov, focal_length,
// fov_axis, the fov converted to the horizontal one with the irradiance image's aspect.
void Emitters::projector(const Elem& e, Props& p, std::map<std::string, const Elem*>& textures, EmitterDesc& d) {
    d.type = EmitterType::Projector;
    d.texture = emitterTexture(textures, "irradiance");
    if (!d.texture) {
        if (!p.has("irradiance")) xml::fail(e, "parameter 'irradiance' is required for a projector emitter");
        d.value = nonNegColor(p, "irradiance", Color(1.f));
    }
    d.scale = p.getFloat("scale", 1.f);
    if (!(std::isfinite(d.scale) && d.scale >= 0.f))
        p.failAt("scale", fmt::format("must be finite and >= 0 (got {})", d.scale));
    d.toWorld = p.getTransform("to_world");
    if (!isOrthonormal(d.toWorld))
        p.failAt("to_world", "must be a rotation and a translation (no scale or shear), as a camera's");
    d.position = transformPoint(d.toWorld, Vec3(0.f));
    const glm::ivec2 res = d.texture ? d.texture->resolution() : glm::ivec2(1);
    const float aspect = float(res.x) / float(res.y);
    if (p.has("fov") && p.has("focal_length")) p.failAt("fov", "give either fov or focal_length");
    float fov = 0.f;
    FovAxis axis = FovAxis::X;
    if (p.has("fov")) {
        fov = p.getFloat("fov", 45.f);
        if (!(fov > 0.f && fov < 180.f)) p.failAt("fov", fmt::format("must be in (0, 180) degrees (got {})", fov));
        const std::string a = xml::lower(p.getString("fov_axis", "x"));
        static const std::pair<const char*, FovAxis> axes[] = {{"x", FovAxis::X}, {"y", FovAxis::Y},
            {"smaller", FovAxis::Smaller}, {"larger", FovAxis::Larger}, {"diagonal", FovAxis::Diagonal}};
        bool found = false;
        for (auto& [n, v] : axes)
            if (a == n) axis = v, found = true;
        if (!found) p.failAt("fov_axis", fmt::format("unknown value '{}' (supported: x, y, smaller, larger, diagonal)", a));
    } else {  // 35 mm film equivalent focal length (default 50mm), along the diagonal
        fov = focalLengthFovDeg(p);
        axis = FovAxis::Diagonal;
    }
    d.fovXDeg = horizontalFovDeg(fov, axis, aspect);
    if (!(d.fovXDeg > 0.f && d.fovXDeg < 180.f))
        p.failAt(p.has("fov") ? "fov" : "focal_length",
                 fmt::format("the horizontal field of view must be in (0, 180) degrees (got {})", d.fovXDeg));
}

void Emitters::topEmitter(const Elem& e) {
    std::string t = e.type();
    if (t == "area") {
        if (!e.attr("id"))
            xml::fail(e, "an area emitter must be inside a <shape> (or have an id and be referenced by shapes)");
        areaDesc(e);  // checks it now
        declaredAreas.push_back(&e);
        return;
    }
    if (!isIn({"point", "spot", "directional", "constant", "envmap", "projector"}, t))
        xml::fail(e, fmt::format("unsupported emitter type '{}' (supported: {})", t, joinList(kEmitterTypes)));
    if (t == "constant" || t == "envmap")  // a ray leaving the scene sees one light (core/scene.cpp)
        for (const EmitterDesc& o : emitters_)
            if (o.type == EmitterType::Constant || o.type == EmitterType::Envmap)
                xml::fail(e, fmt::format("only one environment emitter (constant or envmap) per scene, as in "
                                         "Mitsuba 3 (the other one: {})", o.source));
    Props p(e);
    EmitterDesc d;
    d.source = e.where();
    std::map<std::string, const Elem*> textures = materials_.textureParams(p);
    if (t == "spot") {  // Mitsuba: intensity is not spatially varying, texture is projected (spot.cpp)
        if (auto it = textures.find("intensity"); it != textures.end())
            xml::fail(*it->second, "spot: parameter 'intensity' cannot be a texture (as in Mitsuba 3: use 'texture')");
        d.texture = emitterTexture(textures, "texture");
    }
    if (t == "projector") {
        projector(e, p, textures, d);
    } else if (t == "point" || t == "spot") {
        d.type = t == "point" ? EmitterType::Point : EmitterType::Spot;
        d.value = nonNegColor(p, "intensity", Color(1.f));
        Mat4 m = p.getTransform("to_world");
        if (t == "point" && p.has("position")) {
            if (p.has("to_world")) p.failAt("position", "give either position or to_world");
            d.position = p.getPoint("position", Vec3(0.f));
        } else {
            d.position = transformPoint(m, Vec3(0.f));
        }
        if (t == "spot") {
            d.cutoffAngleDeg = p.getFloat("cutoff_angle", 20.f);
            if (!(d.cutoffAngleDeg > 0.f && d.cutoffAngleDeg <= 90.f))
                p.failAt("cutoff_angle", fmt::format("must be in (0, 90] degrees (got {})", d.cutoffAngleDeg));
            d.beamWidthDeg = p.getFloat("beam_width", 0.75f * d.cutoffAngleDeg);
            p.requirePositive("beam_width", d.beamWidthDeg);
            if (d.beamWidthDeg > d.cutoffAngleDeg) {
                warn(e, "beam_width > cutoff_angle: clamped to cutoff_angle");
                d.beamWidthDeg = d.cutoffAngleDeg;
            }
            Vec3 dir = transformVector(m, Vec3(0, 0, 1));
            if (!(glm::length(dir) > 0.f)) p.failAt("to_world", "the transform maps +Z to zero");
            d.direction = glm::normalize(dir);
            d.toWorld = m;
            if (d.texture && !isOrthonormal(m))
                p.failAt("to_world", "with a texture, must be a rotation and a translation (no scale or shear)");
        }
    } else if (t == "directional") {
        d.type = EmitterType::Directional;
        d.value = nonNegColor(p, "irradiance", Color(1.f));
        Mat4 m = p.getTransform("to_world");
        Vec3 dir = transformVector(m, Vec3(0, 0, 1));
        if (p.has("direction")) {
            if (p.has("to_world")) p.failAt("direction", "give either direction or to_world");
            dir = p.getPoint("direction", Vec3(0, 0, 1));
        }
        if (!(glm::length(dir) > 0.f)) p.failAt(p.has("direction") ? "direction" : "to_world", "zero direction");
        d.direction = glm::normalize(dir);
    } else if (t == "envmap") {
        // Mitsuba 3's envmap (core/envmap.h): filename, scale, to_world, mis_compensation
        // (its `bitmap` and `data` exist only through its Python/C++ API).
        d.type = EmitterType::Envmap;
        if (!p.has("filename")) xml::fail(e, "parameter 'filename' is required for an envmap emitter");
        const std::string filename = p.getString("filename", "");
        std::string tried;
        d.filename = xml::resolveFile(doc_, e, filename, tried);
        if (d.filename.empty())
            p.failAt("filename", fmt::format("environment map '{}' not found (looked for: {})", filename, tried));
        d.scale = p.getFloat("scale", 1.f);
        if (!(std::isfinite(d.scale) && d.scale >= 0.f))
            p.failAt("scale", fmt::format("must be finite and >= 0 (got {})", d.scale));
        d.toWorld = p.getTransform("to_world");
        if (!isOrthonormal(d.toWorld))
            p.failAt("to_world", "must be a rotation (Mitsuba applies it to unit directions: no scale or shear; "
                                 "a translation is ignored)");
        if (p.getBool("mis_compensation", false))
            warn(e, "mis_compensation is ignored: the map is sampled in proportion to its luminance times "
                    "sin(theta), as with mis_compensation false");
    } else {
        d.type = EmitterType::Constant;
        d.value = nonNegColor(p, "radiance", Color(1.f));
    }
    noTexturesOn(textures, t);
    d.samplingWeight = samplingWeight(p);
    noObjects(p, "textures and nested plugins are not supported");
    p.finish();
    if (d.type == EmitterType::Envmap) {  // (read once the parameters are known to be valid)
        try {
            d.envmap = loadEnvironmentMap(d.filename, d.toWorld, d.scale);
        } catch (const ImageError& ex) {
            p.failAt("filename", ex.what());
        } catch (const EnvmapError& ex) {
            p.failAt("filename", ex.what());
        }
    }
    emitters_.push_back(d);
}

}  // namespace lt::loader
