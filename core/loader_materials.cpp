// Materials of the Mitsuba XML loader: <texture> and <bsdf> elements (declared inline, at the top
// level, or referenced) built into textures (core/texture/) and BxDFs (the factories of
// bsdf/bsdf.h), each built once per element. Internal to core/loader.cpp.
#include "core/loader_materials.h"

#include <fmt/format.h>

#include <algorithm>
#include <functional>
#include "bsdf/ior.h"
#include "bsdf/normal_perturbation.h"
#include "bsdf/principled.h"
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

float focalLengthFovDeg(Props& p) {
    float f = 50.f;
    if (p.isString("focal_length")) {
        std::string s = p.getString("focal_length", "50mm");
        if (s.size() > 2 && s.substr(s.size() - 2) == "mm") s.resize(s.size() - 2);
        auto n = xml::parseNumbers(s);
        if (!n || n->size() != 1) p.failAt("focal_length", "expected a length like \"50mm\"");
        f = float((*n)[0]);
    } else {
        f = p.getFloat("focal_length", 50.f);
    }
    p.requirePositive("focal_length", f);
    return glm::degrees(2.f * std::atan(std::sqrt(36.f * 36.f + 24.f * 24.f) / (2.f * f)));
}

namespace {

const std::vector<std::string> kBsdfTypes = {"diffuse", "conductor", "roughconductor", "dielectric", "roughdielectric",
                                             "plastic", "roughplastic", "twosided", "normalmap", "bumpmap",
                                             "thindielectric", "null", "polarizer", "pplastic", "blendbsdf", "mask",
                                             "roughdiffuse", "principled", "principledthin"};

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

// (textures: the plugin's textured parameters, which count as given)
void roughness(Props& p, MicrofacetType& dist, float& au, float& av, MaskingModel& masking,
               const std::map<std::string, const Elem*>& textures = {}) {
    std::string d = xml::lower(p.getString("distribution", "beckmann"));
    if (d == "ggx") dist = MicrofacetType::GGX;
    else if (d == "beckmann") dist = MicrofacetType::Beckmann;
    else p.failAt("distribution", fmt::format("unknown distribution '{}' (supported: ggx, beckmann)", d));
    bool hasA = p.has("alpha") || textures.count("alpha"), hasU = p.has("alpha_u") || textures.count("alpha_u"),
         hasV = p.has("alpha_v") || textures.count("alpha_v");
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

// The parameters each plugin takes as a texture (Mitsuba 3's plugins; roughdiffuse Mitsuba 0.6's).
// roughplastic's alpha is a number in Mitsuba 3 (its coating's tables are precomputed for it).
std::vector<std::string> texturableParams(const std::string& t) {
    if (t == "diffuse") return {"reflectance"};
    if (t == "roughdiffuse") return {"reflectance", "alpha"};
    if (t == "plastic" || t == "roughplastic") return {"diffuse_reflectance", "specular_reflectance"};
    if (t == "conductor") return {"eta", "k", "specular_reflectance"};
    if (t == "roughconductor") return {"alpha", "alpha_u", "alpha_v", "eta", "k", "specular_reflectance"};
    if (t == "dielectric") return {"specular_reflectance", "specular_transmittance"};
    if (t == "roughdielectric") return {"alpha", "alpha_u", "alpha_v", "specular_reflectance", "specular_transmittance"};
    if (t == "principled")
        return {"base_color", "roughness", "anisotropic", "metallic", "spec_trans", "spec_tint",
                "sheen",      "sheen_tint", "flatness", "clearcoat", "clearcoat_gloss"};
    if (t == "principledthin")
        return {"base_color", "roughness", "anisotropic", "spec_trans", "spec_tint",
                "sheen",      "sheen_tint", "flatness", "diff_trans", "eta"};
    return {};
}

}  // namespace

// A textured BSDF parameter: the texture given for `name` (or for `alias`, e.g. alpha for alpha_u),
// null where it is a value; a texture that can be negative is refused at its element, naming the
// parameter (the value checks of nonNegColor and requireNonNegative, over the texture's range).
TexturePtr Materials::paramTexture(const std::map<std::string, const Elem*>& textures, const std::string& name,
                                   const std::string& alias) {
    auto it = textures.find(name);
    if (it == textures.end() && !alias.empty()) it = textures.find(alias);
    if (it == textures.end()) return nullptr;
    TexturePtr tex = texture(*it->second);
    const Color lo = tex->minValue();
    if (!(std::min({lo.x, lo.y, lo.z}) >= 0.f))
        xml::fail(*it->second, fmt::format("the texture for '{}' has negative values (smallest {}, {}, {}): must be >= 0",
                                           it->first, lo.x, lo.y, lo.z));
    return tex;
}

namespace {

// Mitsuba 3's principled (bsdf/principled.cpp): its parameters, names and defaults. Every
// parameter but eta, specular and the sampling rates may be a texture (tex: the texture given
// for a name, null for a value; scalar textures must stay in [0, 1]). The documented ranges are
// enforced: [0, 1] for the weights and specular, eta > 0, rates >= 0; eta and specular together
// are refused (as Mitsuba). Where spec_trans is given (and not 0), eta 1 becomes 1.001 and
// specular 0 becomes 1e-3, as Mitsuba does (no refraction without an interface).
BxdfPtr buildPrincipled(Props& p, const std::map<std::string, const Elem*>& textures,
                        const std::function<TexturePtr(const std::string&)>& tex) {
    PrincipledParams q;
    PrincipledTextures t;
    auto unit = [&](const char* name, float def, float& v, TexturePtr& slot) {
        if (auto it = textures.find(name); it != textures.end()) {
            slot = tex(name);
            const float hi = scalarOf(slot->maxValue());
            if (!(hi <= 1.f))
                xml::fail(*it->second, fmt::format("the texture for '{}' reaches {}: must be in [0, 1]", name, hi));
            return;
        }
        v = p.getFloat(name, def);
        if (!(v >= 0.f && v <= 1.f)) p.failAt(name, fmt::format("must be in [0, 1] (got {})", v));
    };
    if (textures.count("base_color")) t.baseColor = tex("base_color");
    else q.baseColor = nonNegColor(p, "base_color", Color(0.5f));
    unit("roughness", 0.5f, q.roughness, t.roughness);
    unit("anisotropic", 0.f, q.anisotropic, t.anisotropic);
    unit("metallic", 0.f, q.metallic, t.metallic);
    unit("spec_trans", 0.f, q.specTrans, t.specTrans);
    unit("spec_tint", 0.f, q.specTint, t.specTint);
    unit("sheen", 0.f, q.sheen, t.sheen);
    unit("sheen_tint", 0.f, q.sheenTint, t.sheenTint);
    unit("flatness", 0.f, q.flatness, t.flatness);
    unit("clearcoat", 0.f, q.clearcoat, t.clearcoat);
    unit("clearcoat_gloss", 0.f, q.clearcoatGloss, t.clearcoatGloss);
    // (Mitsuba's get_flag: a lobe is on when its parameter is a texture or a non-zero value)
    const bool hasSpecTrans = t.specTrans || q.specTrans != 0.f;
    if (p.has("eta") && p.has("specular")) p.failAt("specular", "give either eta or specular (as in Mitsuba 3)");
    if (p.has("eta")) {
        q.eta = p.getFloat("eta", 1.5f);
        if (!(q.eta > 0.f) || !std::isfinite(q.eta)) p.failAt("eta", fmt::format("must be positive (got {})", q.eta));
        if (hasSpecTrans && q.eta == 1.f) q.eta = 1.001f;
    } else {
        float specular = p.getFloat("specular", 0.5f);
        if (!(specular >= 0.f && specular <= 1.f)) p.failAt("specular", fmt::format("must be in [0, 1] (got {})", specular));
        if (hasSpecTrans && specular == 0.f) specular = 1e-3f;
        q.eta = 2.f / (1.f - std::sqrt(0.08f * specular)) - 1.f;
    }
    auto rate = [&](const char* name, float& v) {
        v = p.getFloat(name, 1.f);
        if (!(v >= 0.f) || !std::isfinite(v)) p.failAt(name, fmt::format("must be >= 0 and finite (got {})", v));
    };
    rate("diffuse_reflectance_sampling_rate", q.diffuseRate);
    rate("main_specular_sampling_rate", q.specularRate);
    rate("clearcoat_sampling_rate", q.clearcoatRate);
    p.finish();
    return makePrincipled(q, t);
}

// Mitsuba 3's principledthin (bsdf/principled_thin.cpp): principled's weights in [0, 1], diff_trans in
// [0, 2] (Mitsuba's range), eta (1.5) positive, each a value or a texture; four sampling rates >= 0.
BxdfPtr buildPrincipledThin(Props& p, const std::map<std::string, const Elem*>& textures,
                            const std::function<TexturePtr(const std::string&)>& tex) {
    PrincipledThinParams q;
    PrincipledThinTextures t;
    auto ranged = [&](const char* name, float def, float hiBound, float& v, TexturePtr& slot) {
        if (auto it = textures.find(name); it != textures.end()) {
            slot = tex(name);
            const float hi = scalarOf(slot->maxValue());
            if (!(hi <= hiBound))
                xml::fail(*it->second, fmt::format("the texture for '{}' reaches {}: must be in [0, {}]", name, hi, hiBound));
            return;
        }
        v = p.getFloat(name, def);
        if (!(v >= 0.f && v <= hiBound)) p.failAt(name, fmt::format("must be in [0, {}] (got {})", hiBound, v));
    };
    if (textures.count("base_color")) t.baseColor = tex("base_color");
    else q.baseColor = nonNegColor(p, "base_color", Color(0.5f));
    ranged("roughness", 0.5f, 1.f, q.roughness, t.roughness);
    ranged("anisotropic", 0.f, 1.f, q.anisotropic, t.anisotropic);
    ranged("spec_trans", 0.f, 1.f, q.specTrans, t.specTrans);
    ranged("spec_tint", 0.f, 1.f, q.specTint, t.specTint);
    ranged("sheen", 0.f, 1.f, q.sheen, t.sheen);
    ranged("sheen_tint", 0.f, 1.f, q.sheenTint, t.sheenTint);
    ranged("flatness", 0.f, 1.f, q.flatness, t.flatness);
    float diffTrans = 0.f;
    ranged("diff_trans", 0.f, 2.f, diffTrans, t.diffTrans);
    q.diffTrans = 0.5f * diffTrans;
    if (auto it = textures.find("eta"); it != textures.end()) {
        t.eta = tex("eta");
        const float lo = scalarOf(t.eta->minValue());
        if (!(lo > 0.f)) xml::fail(*it->second, fmt::format("the texture for 'eta' reaches {}: must be positive", lo));
    } else {
        q.eta = p.getFloat("eta", 1.5f);
        if (!(q.eta > 0.f) || !std::isfinite(q.eta)) p.failAt("eta", fmt::format("must be positive (got {})", q.eta));
    }
    auto rate = [&](const char* name, float& v) {
        v = p.getFloat(name, 1.f);
        if (!(v >= 0.f) || !std::isfinite(v)) p.failAt(name, fmt::format("must be >= 0 and finite (got {})", v));
    };
    rate("specular_reflectance_sampling_rate", q.specReflRate);
    rate("specular_transmittance_sampling_rate", q.specTransRate);
    rate("diffuse_reflectance_sampling_rate", q.diffReflRate);
    rate("diffuse_transmittance_sampling_rate", q.diffTransRate);
    p.finish();
    return makePrincipledThin(q, t);
}

}  // namespace

// Oren and Nayar's rough diffuse model with Mitsuba 0.6's roughdiffuse parameters (reflectance,
// alpha, use_fast_approx; 0.6's diffuseReflectance and useFastApprox spellings map to these).
BxdfPtr Materials::buildRoughDiffuse(Props& p, const std::map<std::string, const Elem*>& textures) {
    TexturePtr rTex = paramTexture(textures, "reflectance"), aTex = paramTexture(textures, "alpha");
    if (p.has("diffuse_reflectance") && p.has("reflectance")) p.failAt("diffuse_reflectance", "give reflectance only");
    const Color r = nonNegColor(p, p.has("diffuse_reflectance") ? "diffuse_reflectance" : "reflectance", Color(0.5f));
    const float alpha = p.getFloat("alpha", 0.2f);
    p.requireNonNegative("alpha", alpha);
    const bool fast = p.getBool("use_fast_approx", false);
    p.finish();
    return makeRoughDiffuse(r, alpha, fast, std::move(rTex), std::move(aTex));
}

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
        // Mitsuba's storage precision (variant: the variant's floats; fp16: half floats): this
        // renderer keeps 32-bit floats either way.
        const std::string format = xml::lower(p.getString("format", "variant"));
        if (format != "variant" && format != "fp16")
            p.failAt("format", fmt::format("unknown format '{}' (supported: variant, fp16)", format));
        try {
            tex = makeBitmap(loadTextureImage(path, raw),
                             filter == "nearest" ? TextureFilter::Nearest : TextureFilter::Bilinear,
                             wrap == "mirror" ? TextureWrap::Mirror : wrap == "clamp" ? TextureWrap::Clamp : TextureWrap::Repeat,
                             toUv, filename);
        } catch (const ImageError& err) {
            p.failAt("filename", err.what());
        }
    } else if (t == "rawconstant") {
        // A <float> or a <vector> (the value as is: a normal map's identity is (0.5, 0.5, 1)).
        const Elem* v = nullptr;
        for (const auto& c : e.children)
            if (const std::string* n = c->attr("name"); n && *n == "value") v = c.get();
        if (!v) xml::fail(e, "parameter 'value' is required for a rawconstant texture (a float or a 3D vector)");
        Color c(0.f);
        if (v->tag == "vector" || v->tag == "point") c = p.getPoint("value", Vec3(0.f));
        else if (v->tag == "float") c = Color(p.getFloat("value", 0.f));
        else p.failAt("value", fmt::format("expected <float> or <vector>, got <{}>", v->tag));
        if (!isFinite(c)) p.failAt("value", "must be finite");
        tex = makeConstantTexture(c);
    } else if (t == "mesh_attribute") {
        tex = meshAttributeTexture(p);  // (core/loader_mesh_attribute.cpp)
    } else {
        xml::fail(e, fmt::format("unsupported texture type '{}' (supported: bitmap, checkerboard, rawconstant, "
                                 "mesh_attribute)", t));
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
        inheritOpacity(e);
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
BxdfPtr Materials::buildPlastic(const Elem& e, Props& p, bool rough, TexturePtr diffTex, TexturePtr specTex) {
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
    if (specTex)
        return makeTexturedPlastic(rough, dist, alpha, intIor / extIor, std::move(diffTex), diffR, std::move(specTex), specR,
                                   nonlinear);
    if (diffTex) return makeTexturedPlastic(rough, dist, alpha, intIor / extIor, std::move(diffTex), specR, nonlinear);
    if (rough) return makeRoughPlastic(dist, alpha, intIor / extIor, diffR, specR, nonlinear);
    return makePlastic(intIor / extIor, diffR, specR, nonlinear);
}

// Mitsuba 3's normalmap (texture parameter `normalmap`) and bumpmap (one nested texture of any
// name, `scale`) around one nested BSDF (bsdf/normal_perturbation.h).
BxdfPtr Materials::buildPerturbation(const Elem& e, Props& p) {
    const std::string t = e.type();
    const Elem* nested = nullptr;
    const Elem* tex = nullptr;
    std::vector<const Elem*> rest;
    for (const Elem* o : p.objects) {
        const Elem& target = deref(doc_, *o);
        if (target.tag == "bsdf") {
            if (nested) xml::fail(*o, fmt::format("{} takes one nested bsdf (a second one here)", t));
            nested = &target;
        } else if (target.tag == "texture" && t == "bumpmap") {
            if (tex) xml::fail(*o, "bumpmap takes one nested texture (a second one here)");
            tex = &target;
        } else {
            rest.push_back(o);
        }
    }
    p.objects = rest;
    const std::map<std::string, const Elem*> textures = textureParams(p);
    noObjects(p, "a normalmap or bumpmap takes one texture and one bsdf");
    if (!nested) xml::fail(e, fmt::format("{} needs one nested <bsdf> (the BSDF it perturbs)", t));
    if (nested->type() == "normalmap" || nested->type() == "bumpmap")
        xml::fail(*nested, fmt::format("a {} inside a {} is not supported", nested->type(), t));
    const bool flip = p.getBool("flip_invalid_normals", true);
    const bool shadowing = p.getBool("use_shadowing_function", true);
    if (t == "normalmap") {
        noTexturesBut(p, textures, {"normalmap"});
        const auto it = textures.find("normalmap");
        if (it == textures.end()) xml::fail(e, "normalmap needs a texture named 'normalmap' (<texture name=\"normalmap\" ...>)");
        tex = it->second;
    } else {
        if (!tex) xml::fail(e, "bumpmap needs one nested <texture> (the height field)");
    }
    float scale = 1.f;
    if (t == "bumpmap") {
        scale = p.getFloat("scale", 1.f);
        if (!std::isfinite(scale)) p.failAt("scale", "must be finite");
    }
    p.finish();
    TexturePtr texture = this->texture(*tex);
    BxdfPtr inner = bxdf(*nested);
    return t == "normalmap" ? makeNormalMap(std::move(texture), std::move(inner), flip, shadowing)
                            : makeBumpMap(std::move(texture), scale, std::move(inner), flip, shadowing);
}

// Mitsuba 3's thindielectric (int_ior, ext_ior, specular_reflectance, specular_transmittance), null
// (no parameters) and polarizer as its rgb variants render it (transmittance; theta and polarizing
// change nothing there): bsdf/thin_dielectric.cpp.
BxdfPtr Materials::buildThinSheet(const Elem& e, Props& p, const std::string& type) {
    if (type == "null") {
        p.finish();
        return makeNull();
    }
    if (type == "polarizer") {
        const Color t = nonNegColor(p, "transmittance", Color(1.f));
        for (const char* n : {"theta", "polarizing"})
            if (p.has(n)) warn(e, fmt::format("polarizer: '{}' changes nothing without polarisation (Mitsuba's rgb variants)", n));
        p.finish();
        return makePolarizer(t);
    }
    const float intIor = ior(p, "int_ior", 1.5046f), extIor = ior(p, "ext_ior", 1.000277f);
    const Color specR = nonNegColor(p, "specular_reflectance", Color(1.f));
    const Color specT = nonNegColor(p, "specular_transmittance", Color(1.f));
    p.finish();
    return makeThinDielectric(intIor / extIor, specR, specT);
}

// Mitsuba 3's pplastic in its rgb variants: diffuse_reflectance (0.5), specular_reflectance (1),
// int_ior (polypropylene), ext_ior (air), distribution (beckmann), alpha or alpha_u and alpha_v
// (0.1), sample_visible; Smith masking only (bsdf/pplastic.cpp).
BxdfPtr Materials::buildPolarizedPlastic(const Elem& e, Props& p) {
    (void)e;
    MicrofacetType dist = MicrofacetType::Beckmann;
    float au = 0.1f, av = 0.1f;
    MaskingModel masking = MaskingModel::Smith;
    roughness(p, dist, au, av, masking);
    if (masking != MaskingModel::Smith) p.failAt("masking", "pplastic supports the Smith masking only");
    const Color diffR = nonNegColor(p, "diffuse_reflectance", Color(0.5f));
    const Color specR = nonNegColor(p, "specular_reflectance", Color(1.f));
    const float intIor = ior(p, "int_ior", 1.49f), extIor = ior(p, "ext_ior", 1.000277f);
    if (intIor == extIor)
        p.failAt("int_ior", "the interior and exterior indices of refraction must differ (as in Mitsuba 3)");
    p.finish();
    return makePolarizedPlastic(dist, au, av, intIor / extIor, diffR, specR);
}

// Mitsuba 3's blendbsdf: `weight` (0.5; a float in [0, 1] or a texture) and exactly two nested
// BSDFs, ordered as Mitsuba orders a plugin's objects: by name, unnamed ones as "_arg_<k>" in
// document order, numeric suffixes compared as numbers. Weight 0 is the first, 1 the second.
BxdfPtr Materials::buildBlend(const Elem& e, Props& p) {
    const std::map<std::string, const Elem*> textures = textureParams(p);
    noTexturesBut(p, textures, {"weight"});
    struct Nested {
        std::string key;
        const Elem* elem;  // the nested element as written (a <ref> or a <bsdf>)
    };
    std::vector<Nested> nested;
    int unnamed = 0;
    for (const Elem* o : p.objects) {
        const Elem& target = deref(doc_, *o);
        if (target.tag != "bsdf") xml::fail(*o, "blendbsdf takes two nested <bsdf> and a weight");
        if (nested.size() == 2) xml::fail(*o, "blendbsdf takes exactly two nested BSDFs (a third one here)");
        const std::string* name = o->attr("name");
        nested.push_back({name && !name->empty() ? *name : "_arg_" + std::to_string(unnamed++), o});
    }
    if (nested.size() != 2)
        xml::fail(e, fmt::format("blendbsdf needs two nested BSDFs (got {})", nested.size()));
    // (Mitsuba's Properties key order: the common prefix skipped, numbers compared as numbers)
    auto before = [](const std::string& a, const std::string& b) {
        size_t i = 0;
        while (i < a.size() && i < b.size() && a[i] == b[i]) ++i;
        const std::string ra = a.substr(i), rb = b.substr(i);
        const bool na = !ra.empty() && std::all_of(ra.begin(), ra.end(), ::isdigit);
        const bool nb = !rb.empty() && std::all_of(rb.begin(), rb.end(), ::isdigit);
        if (na && nb && ra.size() < 10 && rb.size() < 10) return std::stol(ra) < std::stol(rb);
        return ra < rb;
    };
    if (before(nested[1].key, nested[0].key)) std::swap(nested[0], nested[1]);
    TexturePtr weightTex;
    float weight = 0.5f;
    if (const auto it = textures.find("weight"); it != textures.end()) {
        weightTex = texture(*it->second);
    } else {
        weight = p.getFloat("weight", 0.5f);
        if (!(weight >= 0.f && weight <= 1.f)) p.failAt("weight", fmt::format("must be in [0, 1] (got {})", weight));
    }
    p.finish();
    return makeBlend(bxdf(deref(doc_, *nested[0].elem)), bxdf(deref(doc_, *nested[1].elem)), weight, std::move(weightTex));
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
        if (inner.type() == "normalmap" || inner.type() == "bumpmap")
            xml::fail(*p.objects[0], fmt::format("twosided around a {} is not supported: put the twosided inside it",
                                                 inner.type()));
        p.finish();
        return makeTwoSided(bxdf(inner));
    }
    if (t == "normalmap" || t == "bumpmap") return buildPerturbation(e, p);
    if (t == "blendbsdf") return buildBlend(e, p);
    if (t == "mask") return buildMask(e, p);
    const std::map<std::string, const Elem*> textures = textureParams(p);
    noObjects(p, "nested plugins other than textures are not supported here");
    noTexturesBut(p, textures, texturableParams(t));
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
        return buildPlastic(e, p, t == "roughplastic", it != textures.end() ? texture(*it->second) : nullptr,
                            paramTexture(textures, "specular_reflectance"));
    }
    if (t == "thindielectric" || t == "null" || t == "polarizer") return buildThinSheet(e, p, t);
    if (t == "pplastic") return buildPolarizedPlastic(e, p);
    if (t == "roughdiffuse") return buildRoughDiffuse(p, textures);
    if (t == "principled")
        return buildPrincipled(p, textures, [&](const std::string& n) { return paramTexture(textures, n); });
    if (t == "principledthin")
        return buildPrincipledThin(p, textures, [&](const std::string& n) { return paramTexture(textures, n); });
    bool rough = t.rfind("rough", 0) == 0;
    MicrofacetType dist = MicrofacetType::Beckmann;
    float au = 0.f, av = 0.f;
    MaskingModel masking = MaskingModel::Smith;
    if (rough) roughness(p, dist, au, av, masking, textures);
    Color specR = nonNegColor(p, "specular_reflectance", Color(1.f));
    if (t == "conductor" || t == "roughconductor") {
        bool hasEta = p.has("eta") || textures.count("eta"), hasK = p.has("k") || textures.count("k"),
             hasMat = p.has("material");
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
        if (!textures.empty()) {
            const ConductorTextures tex{paramTexture(textures, "alpha_u", "alpha"), paramTexture(textures, "alpha_v", "alpha"),
                                        paramTexture(textures, "eta"), paramTexture(textures, "k"),
                                        paramTexture(textures, "specular_reflectance"), ext};
            return makeTexturedConductor(rough, dist, au, av, c.eta, c.k, specR, masking, tex);
        }
        if (rough) return makeRoughConductor(dist, au, av, c.eta, c.k, specR, masking);
        return makeConductor(c.eta, c.k, specR);
    }
    float intIor = ior(p, "int_ior", 1.5046f), extIor = ior(p, "ext_ior", 1.000277f);
    Color specT = nonNegColor(p, "specular_transmittance", Color(1.f));
    p.finish();
    if (!textures.empty())
        return makeTexturedDielectric(rough, dist, au, av, intIor / extIor, specR, specT, masking,
                                      {paramTexture(textures, "alpha_u", "alpha"), paramTexture(textures, "alpha_v", "alpha"),
                                       paramTexture(textures, "specular_reflectance"),
                                       paramTexture(textures, "specular_transmittance")});
    if (rough) return makeRoughDielectric(dist, au, av, intIor / extIor, specR, specT, masking);
    return makeDielectric(intIor / extIor, specR, specT);
}

}  // namespace lt::loader
