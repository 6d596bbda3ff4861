// Materials of the Mitsuba XML loader: <texture> and <bsdf> elements (declared inline, at the top
// level, or referenced) built into textures (core/texture/) and BxDFs (the factories of
// bsdf/bsdf.h), each built once per element. Internal to core/loader.cpp.
#include "core/loader_materials.h"

#include <fmt/format.h>

#include <algorithm>
#include "bsdf/ior.h"
#include "core/image.h"
#include "core/loader.h"
#include "core/texture/texture_factory.h"

namespace lt::loader {

using xml::joinList;

bool isIn(const std::vector<std::string>& v, const std::string& s) { return std::find(v.begin(), v.end(), s) != v.end(); }

const Elem& deref(const xml::Document& doc, const Elem& e) {
    if (e.tag != "ref") return e;
    for (auto& [k, v] : e.attrs)
        if (k != "id" && k != "name") xml::fail(e, fmt::format("unexpected attribute '{}' (allowed: id, name)", k));
    const std::string* id = e.attr("id");
    if (!id) xml::fail(e, "a <ref> needs an id attribute");
    auto it = doc.ids.find(*id);
    if (it == doc.ids.end()) {
        std::vector<std::string> ids;
        for (auto& [k, v] : doc.ids) ids.push_back(k);
        xml::fail(e, fmt::format("unknown id '{}' (ids defined in the scene: {})", *id,
                                 ids.empty() ? std::string("none") : joinList(ids)));
    }
    return *it->second;
}

void noObjects(const Props& p, const char* what) {
    if (!p.objects.empty())
        xml::fail(*p.objects.front(), fmt::format("unsupported element inside {} ({})", p.owner.describe(), what));
}

Color nonNegColor(Props& p, const std::string& name, const Color& def) {
    Color c = p.getColor(name, def);
    p.requireNonNegative(name, c);
    return c;
}

namespace {

const std::vector<std::string> kBsdfTypes = {"diffuse", "conductor", "roughconductor", "dielectric", "roughdielectric",
                                             "plastic", "roughplastic", "twosided"};

// Refuses the textures a plugin has no use for (yet), naming the parameters that take one.
void noTexturesBut(const Props& p, const std::map<std::string, const Elem*>& textures,
                          const std::vector<std::string>& supported) {
    for (const auto& [name, e] : textures)
        if (!isIn(supported, name))
            xml::fail(*e, fmt::format("{} does not take a texture for '{}' here{}: give a value", p.owner.describe(), name,
                                      supported.empty() ? std::string()
                                                        : fmt::format(" (textured parameters: {})", joinList(supported))));
}

// 2D texture-coordinate transform of Mitsuba's to_uv (a 4x4 transform applied to (u, v, 0, 1)).
glm::mat3 uvTransform(Props& p) {
    const Mat4 m = p.getTransform("to_uv");
    return glm::mat3(Vec3(m[0].x, m[0].y, 0.f), Vec3(m[1].x, m[1].y, 0.f), Vec3(m[3].x, m[3].y, 1.f));
}

float ior(Props& p, const std::string& name, float def) {
    if (!p.has(name)) return def;
    if (p.isString(name)) {
        std::string s = p.getString(name, "");
        std::optional<float> v = namedIor(s);
        if (!v) v = namedIor(xml::lower(s));
        if (!v) p.failAt(name, fmt::format("unknown IOR name '{}' (known: {})", s, joinList(namedIorList())));
        return *v;
    }
    float v = p.getFloat(name, def);
    p.requirePositive(name, v);
    return v;
}

void roughness(Props& p, MicrofacetType& dist, float& au, float& av, MaskingModel& masking) {
    std::string d = xml::lower(p.getString("distribution", "beckmann"));
    if (d == "ggx") dist = MicrofacetType::GGX;
    else if (d == "beckmann") dist = MicrofacetType::Beckmann;
    else p.failAt("distribution", fmt::format("unknown distribution '{}' (supported: ggx, beckmann)", d));
    bool hasA = p.has("alpha"), hasU = p.has("alpha_u"), hasV = p.has("alpha_v");
    if (hasA && (hasU || hasV)) p.failAt("alpha", "give either alpha or alpha_u and alpha_v");
    if (hasU != hasV) p.failAt(hasU ? "alpha_v" : "alpha_u", "alpha_u and alpha_v must be given together");
    au = av = p.getFloat("alpha", 0.1f);
    p.requireNonNegative("alpha", au);
    if (hasU) {
        au = p.getFloat("alpha_u", 0.1f);
        av = p.getFloat("alpha_v", 0.1f);
        p.requireNonNegative("alpha_u", au);
        p.requireNonNegative("alpha_v", av);
    }
    std::string m = xml::lower(p.getString("masking", "smith"));
    if (m == "smith") masking = MaskingModel::Smith;
    else if (m == "vcavity") masking = MaskingModel::VCavity;
    else p.failAt("masking", fmt::format("unknown masking model '{}' (supported: smith, vcavity)", m));
    p.getBool("sample_visible", true);  // sampling strategy only: accepted and ignored
}

}  // namespace

Materials::Materials(const xml::Document& doc, std::vector<std::string>& warnings) : doc_(doc), warnings_(warnings) {}

void Materials::warn(const Elem& e, const std::string& msg) {
    warnings_.push_back(fmt::format("{}: {}: {}", e.where(), e.describe(), msg));
}

std::map<std::string, const Elem*> Materials::textureParams(Props& p) {
    std::map<std::string, const Elem*> out;
    std::vector<const Elem*> rest;
    for (const Elem* o : p.objects) {
        const Elem& target = deref(doc_, *o);
        if (target.tag != "texture") {
            rest.push_back(o);
            continue;
        }
        const std::string* name = o->attr("name");
        if (!name || name->empty())
            xml::fail(*o, fmt::format("a texture inside {} needs a name attribute (the parameter it gives)",
                                      p.owner.describe()));
        if (p.has(*name)) p.failAt(*name, "given both as a value and as a texture");
        if (!out.emplace(*name, &target).second) xml::fail(*o, fmt::format("texture '{}' given twice", *name));
    }
    p.objects = rest;
    return out;
}



TexturePtr Materials::texture(const Elem& e) {
    if (auto it = textures_.find(&e); it != textures_.end()) return it->second;
    const std::string t = e.type();
    Props p(e);
    TexturePtr tex;
    if (t == "checkerboard") {
        const Color c0 = nonNegColor(p, "color0", Color(0.4f)), c1 = nonNegColor(p, "color1", Color(0.2f));
        tex = makeCheckerboard(c0, c1, uvTransform(p));
    } else if (t == "bitmap") {
        if (!p.has("filename")) xml::fail(e, "parameter 'filename' is required for a bitmap texture");
        const std::string filename = p.getString("filename", "");
        std::string tried;
        const std::string path = xml::resolveFile(doc_, e, filename, tried);
        if (path.empty()) p.failAt("filename", fmt::format("image file '{}' not found (looked for: {})", filename, tried));
        const std::string filter = xml::lower(p.getString("filter_type", "bilinear"));
        if (filter != "bilinear" && filter != "nearest")
            p.failAt("filter_type", fmt::format("unknown filter '{}' (supported: bilinear, nearest)", filter));
        const std::string wrap = xml::lower(p.getString("wrap_mode", "repeat"));
        if (wrap != "repeat" && wrap != "mirror" && wrap != "clamp")
            p.failAt("wrap_mode", fmt::format("unknown wrap mode '{}' (supported: repeat, mirror, clamp)", wrap));
        const bool raw = p.getBool("raw", false);
        const glm::mat3 toUv = uvTransform(p);
        p.ignore({"accel"}, &warnings_);  // (Mitsuba: hardware texture filtering on GPUs)
        try {
            tex = makeBitmap(loadTextureImage(path, raw),
                             filter == "nearest" ? TextureFilter::Nearest : TextureFilter::Bilinear,
                             wrap == "mirror" ? TextureWrap::Mirror : wrap == "clamp" ? TextureWrap::Clamp : TextureWrap::Repeat,
                             toUv, filename);
        } catch (const ImageError& err) {
            p.failAt("filename", err.what());
        }
    } else {
        xml::fail(e, fmt::format("unsupported texture type '{}' (supported: bitmap, checkerboard)", t));
    }
    noObjects(p, "a texture has no nested plugins");
    p.finish();
    textures_[&e] = tex;
    return tex;
}

BxdfPtr Materials::bxdf(const Elem& e) {
    auto it = bxdfs_.find(&e);
    if (it != bxdfs_.end()) return it->second;
    if (building_.count(&e)) xml::fail(e, "the bsdf refers to itself (reference cycle)");
    building_.insert(&e);
    BxdfPtr b;
    try {
        b = buildBsdf(e);
    } catch (const SceneError&) {
        throw;
    } catch (const std::exception& ex) {
        xml::fail(e, fmt::format("cannot build the material: {}", ex.what()));
    }
    building_.erase(&e);
    bxdfs_[&e] = b;
    return b;
}



// Mitsuba 3's plastic and roughplastic, with its parameters and defaults (polypropylene in air,
// Beckmann alpha 0.1); roughplastic is isotropic and Smith-masked there.
BxdfPtr Materials::buildPlastic(const Elem& e, Props& p, bool rough, TexturePtr diffTex) {
    MicrofacetType dist = MicrofacetType::Beckmann;
    float alpha = 0.f;
    if (rough) {
        for (const char* n : {"alpha_u", "alpha_v"})
            if (p.has(n)) p.failAt(n, "roughplastic is isotropic (as in Mitsuba 3): give alpha");
        float av = 0.f;
        MaskingModel masking = MaskingModel::Smith;
        roughness(p, dist, alpha, av, masking);
        if (masking != MaskingModel::Smith) p.failAt("masking", "roughplastic supports the Smith masking only");
    }
    Color diffR = diffTex ? diffTex->maxValue() : nonNegColor(p, "diffuse_reflectance", Color(0.5f));
    Color specR = nonNegColor(p, "specular_reflectance", Color(1.f));
    float intIor = ior(p, "int_ior", 1.49f), extIor = ior(p, "ext_ior", 1.000277f);
    if (rough && intIor == extIor)
        p.failAt("int_ior", "the interior and exterior indices of refraction must differ (as in Mitsuba 3)");
    bool nonlinear = p.getBool("nonlinear", false);
    if (maxComp(diffR) > 1.f) {
        // (the nonlinear internal scattering R / (1 - Fdr R) diverges for R >= 1 / Fdr)
        if (nonlinear) p.failAt("diffuse_reflectance", "must be <= 1 with nonlinear true");
        warn(e, "diffuse_reflectance > 1 does not conserve energy");
    }
    p.finish();
    if (diffTex) return makeTexturedPlastic(rough, dist, alpha, intIor / extIor, std::move(diffTex), specR, nonlinear);
    if (rough) return makeRoughPlastic(dist, alpha, intIor / extIor, diffR, specR, nonlinear);
    return makePlastic(intIor / extIor, diffR, specR, nonlinear);
}

BxdfPtr Materials::buildBsdf(const Elem& e) {
    std::string t = e.type();
    if (!isIn(kBsdfTypes, t))
        xml::fail(e, fmt::format("unsupported bsdf type '{}' (supported: {})", t, joinList(kBsdfTypes)));
    Props p(e);
    if (t == "twosided") {
        if (p.objects.size() != 1)
            xml::fail(e, p.objects.empty() ? "twosided needs one nested <bsdf> (or <ref>)"
                                           : "twosided with different front and back BSDFs is not supported: give one");
        const Elem& inner = deref(doc_, *p.objects[0]);
        if (inner.tag != "bsdf") xml::fail(*p.objects[0], "twosided needs a nested <bsdf>");
        p.finish();
        return makeTwoSided(bxdf(inner));
    }
    const std::map<std::string, const Elem*> textures = textureParams(p);
    noObjects(p, "nested plugins other than textures are not supported here");
    noTexturesBut(p, textures, t == "diffuse" ? std::vector<std::string>{"reflectance"}
                               : t == "plastic" || t == "roughplastic" ? std::vector<std::string>{"diffuse_reflectance"}
                                                                       : std::vector<std::string>{});
    if (t == "diffuse") {
        if (auto it = textures.find("reflectance"); it != textures.end()) {
            p.finish();
            return makeTexturedDiffuse(texture(*it->second));
        }
        Color r = nonNegColor(p, "reflectance", Color(0.5f));
        if (maxComp(r) > 1.f) warn(e, "reflectance > 1 does not conserve energy");
        p.finish();
        return makeDiffuse(r);
    }
    if (t == "plastic" || t == "roughplastic") {
        const auto it = textures.find("diffuse_reflectance");
        return buildPlastic(e, p, t == "roughplastic", it != textures.end() ? texture(*it->second) : nullptr);
    }
    bool rough = t.rfind("rough", 0) == 0;
    MicrofacetType dist = MicrofacetType::Beckmann;
    float au = 0.f, av = 0.f;
    MaskingModel masking = MaskingModel::Smith;
    if (rough) roughness(p, dist, au, av, masking);
    Color specR = nonNegColor(p, "specular_reflectance", Color(1.f));
    if (t == "conductor" || t == "roughconductor") {
        bool hasEta = p.has("eta"), hasK = p.has("k"), hasMat = p.has("material");
        if (hasMat && (hasEta || hasK)) p.failAt("material", "give either material or eta and k");
        if (hasEta != hasK) p.failAt(hasEta ? "k" : "eta", "eta and k must be given together");
        ConductorIor c;
        if (hasEta) {
            c.eta = nonNegColor(p, "eta", Color(0.f));
            c.k = nonNegColor(p, "k", Color(1.f));
        } else {
            // Mitsuba 3's default is a perfect mirror ("none"); Mitsuba 0.6's is copper.
            std::string name = p.getString("material", e.src->legacy ? "Cu" : "none");
            std::optional<ConductorIor> preset = conductorPreset(name);
            if (!preset)
                p.failAt("material", fmt::format("unknown conductor '{}' (known: {})", name,
                                                 joinList(conductorPresetList())));
            c = *preset;
        }
        float ext = ior(p, "ext_eta", 1.f);
        c.eta /= ext;
        c.k /= ext;
        p.finish();
        if (rough) return makeRoughConductor(dist, au, av, c.eta, c.k, specR, masking);
        return makeConductor(c.eta, c.k, specR);
    }
    float intIor = ior(p, "int_ior", 1.5046f), extIor = ior(p, "ext_ior", 1.000277f);
    Color specT = nonNegColor(p, "specular_transmittance", Color(1.f));
    p.finish();
    if (rough) return makeRoughDielectric(dist, au, av, intIor / extIor, specR, specT, masking);
    return makeDielectric(intIor / extIor, specR, specT);
}

}  // namespace lt::loader
