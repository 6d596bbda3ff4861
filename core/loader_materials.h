// Materials of the Mitsuba XML loader (textures and BSDFs) and the helpers the loader's parts
// share. Internal to core/loader.cpp and core/loader_materials.cpp.
#pragma once
#include <map>
#include <set>
#include <string>
#include <vector>
#include "bsdf/bsdf.h"
#include "core/loader_xml.h"
#include "core/mesh_attribute.h"
#include "core/opacity.h"
#include "core/texture/texture.h"

namespace lt::loader {

using xml::Elem;
using xml::Props;

bool isIn(const std::vector<std::string>& v, const std::string& s);
// The element a <ref id="..."> names (e itself if it is not a <ref>).
const Elem& deref(const xml::Document& doc, const Elem& e);
// Throws naming the first nested plugin, if any: `what` says why none is expected.
void noObjects(const Props& p, const char* what);
Color nonNegColor(Props& p, const std::string& name, const Color& def);
// Mitsuba's focal_length (35 mm film equivalent: "50mm" or a number, default 50) as the field of
// view along the film's diagonal, in degrees (perspective and thin-lens sensors, projector).
float focalLengthFovDeg(Props& p);
// Does the bsdf (or texture) e read a mesh_attribute texture, at any depth?
bool usesMeshAttribute(const xml::Document& doc, const Elem& e);

class Materials {
public:
    Materials(const xml::Document& doc, std::vector<std::string>& warnings);

    // A plugin's texture parameters: its nested <texture name="..."> elements and <ref name="..."
    // id="..."> to textures declared elsewhere, by parameter name; the other nested plugins are
    // left in p.objects.
    std::map<std::string, const Elem*> textureParams(Props& p);
    TexturePtr texture(const Elem& e);
    BxdfPtr bxdf(const Elem& e);
    // The material e for one mesh whose mesh_attribute textures read that mesh's attributes
    // (core/loader_mesh_attribute.cpp): built anew, apart from the shared caches.
    struct ShapeAttributes {
        const MeshAttributes* attributes = nullptr;
        const std::vector<uint32_t>* indices = nullptr;
        std::string what;  // the shape, for messages
    };
    BxdfPtr bxdfForShape(const Elem& e, const ShapeAttributes& shape);
    // The opacity of a shape whose bsdf is element e (built by bxdf first): a mask's, also through a
    // twosided, normalmap or bumpmap around one; opaque otherwise (core/loader_mask.cpp).
    Opacity opacity(const Elem& e) const;

private:
    void warn(const Elem& e, const std::string& msg);
    BxdfPtr buildBsdf(const Elem& e);
    BxdfPtr buildPlastic(const Elem& e, Props& p, bool rough, TexturePtr diffTex, TexturePtr specTex = nullptr);
    TexturePtr paramTexture(const std::map<std::string, const Elem*>& textures, const std::string& name,
                            const std::string& alias = "");
    BxdfPtr buildRoughDiffuse(Props& p, const std::map<std::string, const Elem*>& textures);
    TexturePtr meshAttributeTexture(Props& p);
    const ShapeAttributes* shape_ = nullptr;  // bxdfForShape's mesh, while it builds
    // thindielectric, null, polarizer, pplastic and blendbsdf (issue 46)
    BxdfPtr buildThinSheet(const Elem& e, Props& p, const std::string& type);
    BxdfPtr buildPolarizedPlastic(const Elem& e, Props& p);
    BxdfPtr buildBlend(const Elem& e, Props& p);
    BxdfPtr buildPerturbation(const Elem& e, Props& p);
    // mask (core/loader_mask.cpp): the nested model, its opacity in opacities_; inheritOpacity
    // passes a nested mask's opacity to a wrapper around it or refuses the wrapper.
    BxdfPtr buildMask(const Elem& e, Props& p);
    void inheritOpacity(const Elem& e);

    const xml::Document& doc_;
    std::vector<std::string>& warnings_;
    std::map<const Elem*, TexturePtr> textures_;
    std::map<const Elem*, BxdfPtr> bxdfs_;
    std::map<const Elem*, Opacity> opacities_;  // masked bsdf elements only
    std::set<const Elem*> building_;
};

}  // namespace lt::loader
