// Materials of the Mitsuba XML loader (textures and BSDFs) and the helpers the loader's parts
// share. Internal to core/loader.cpp and core/loader_materials.cpp.
#pragma once
#include <map>
#include <set>
#include <string>
#include <vector>
#include "bsdf/bsdf.h"
#include "core/loader_xml.h"
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

class Materials {
public:
    Materials(const xml::Document& doc, std::vector<std::string>& warnings);

    // A plugin's texture parameters: its nested <texture name="..."> elements and <ref name="..."
    // id="..."> to textures declared elsewhere, by parameter name; the other nested plugins are
    // left in p.objects.
    std::map<std::string, const Elem*> textureParams(Props& p);
    TexturePtr texture(const Elem& e);
    BxdfPtr bxdf(const Elem& e);

private:
    void warn(const Elem& e, const std::string& msg);
    BxdfPtr buildBsdf(const Elem& e);
    BxdfPtr buildPlastic(const Elem& e, Props& p, bool rough, TexturePtr diffTex);

    const xml::Document& doc_;
    std::vector<std::string>& warnings_;
    std::map<const Elem*, TexturePtr> textures_;
    std::map<const Elem*, BxdfPtr> bxdfs_;
    std::set<const Elem*> building_;
};

}  // namespace lt::loader
