// XML layer of the scene loader: files, includes, defaults, $-substitution, typed properties,
// transforms. See loader_xml.h.
#include "core/loader_xml.h"
#include "core/spectrum.h"

#include <fmt/format.h>
#include <pugixml.hpp>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <glm/gtc/matrix_transform.hpp>
#include <sstream>

namespace fs = std::filesystem;

namespace lt::xml {

// ---------------------------------------------------------------------------------------------
// Small helpers

int Source::lineOf(ptrdiff_t offset) const {
    if (offset < 0) return 0;
    auto it = std::upper_bound(lineStarts.begin(), lineStarts.end(), size_t(offset));
    return int(it - lineStarts.begin());
}

const std::string* Elem::attr(std::string_view name) const {
    for (auto& [k, v] : attrs)
        if (k == name) return &v;
    return nullptr;
}

std::string Elem::type() const {
    const std::string* t = attr("type");
    return t ? lower(*t) : std::string();
}

std::string Elem::where() const { return fmt::format("{}:{}", src ? src->path : "?", line); }

std::string Elem::describe() const {
    std::string s = "<" + tag;
    for (const char* a : {"type", "id", "name"})
        if (const std::string* v = attr(a)) s += fmt::format(" {}=\"{}\"", a, *v);
    return s + ">";
}

void fail(const Elem& e, const std::string& msg) {
    throw SceneError(fmt::format("{}: {}: {}", e.where(), e.describe(), msg));
}

void failParam(const Elem& owner, const Elem* at, const std::string& param, const std::string& msg) {
    const Elem& loc = at ? *at : owner;
    throw SceneError(fmt::format("{}: {} parameter '{}': {}", loc.where(), owner.describe(), param, msg));
}

std::string lower(std::string_view s) {
    std::string r(s);
    for (char& c : r) c = char(std::tolower((unsigned char)c));
    return r;
}

std::string toSnake(std::string_view s) {
    std::string r;
    for (size_t i = 0; i < s.size(); ++i) {
        char c = s[i];
        if (std::isupper((unsigned char)c)) {
            bool prevLowerOrDigit = i > 0 && (std::islower((unsigned char)s[i - 1]) || std::isdigit((unsigned char)s[i - 1]));
            if (prevLowerOrDigit) r += '_';
            r += char(std::tolower((unsigned char)c));
        } else {
            r += c;
        }
    }
    return r;
}

std::string joinList(const std::vector<std::string>& v) {
    std::string r;
    for (size_t i = 0; i < v.size(); ++i) r += (i ? ", " : "") + v[i];
    return r;
}

std::optional<std::vector<double>> parseNumbers(std::string_view s) {
    std::vector<double> out;
    std::string buf(s);
    const char* p = buf.c_str();
    while (true) {
        while (*p && (std::isspace((unsigned char)*p) || *p == ',')) ++p;
        if (!*p) break;
        char* end = nullptr;
        errno = 0;
        double v = std::strtod(p, &end);
        if (end == p) return std::nullopt;
        if (*end && !std::isspace((unsigned char)*end) && *end != ',') return std::nullopt;
        out.push_back(v);
        p = end;
    }
    return out;
}

namespace {

void checkAttrs(const Elem& e, std::initializer_list<const char*> allowed) {
    for (auto& [k, v] : e.attrs) {
        bool ok = false;
        for (const char* a : allowed) ok = ok || k == a;
        if (!ok) {
            std::vector<std::string> names;
            for (const char* a : allowed) names.push_back(a);
            fail(e, fmt::format("unexpected attribute '{}' (allowed: {})", k, joinList(names)));
        }
    }
}

const std::vector<std::string> kPropertyTags = {"float", "integer", "boolean", "string", "rgb", "srgb",
                                                "spectrum", "blackbody", "point", "vector", "transform"};
const std::vector<std::string> kObjectTags = {"bsdf", "emitter", "shape", "ref", "sampler", "film", "rfilter",
                                              "integrator", "sensor", "texture", "medium", "phase", "volume"};

bool isIn(const std::vector<std::string>& v, const std::string& s) { return std::find(v.begin(), v.end(), s) != v.end(); }

// ---------------------------------------------------------------------------------------------
// Reading files, includes, defaults, substitution

struct Reader {
    Document& doc;
    std::map<std::string, std::string> params;
    std::set<std::string> cliNames, usedNames;
    std::vector<std::string> includeStack;  // canonical paths

    static std::string canonical(const std::string& path) {
        std::error_code ec;
        fs::path c = fs::weakly_canonical(fs::path(path), ec);
        return ec ? path : c.string();
    }

    Source& addSource(const std::string& path, std::string text) {
        auto src = std::make_unique<Source>();
        src->path = path;
        src->dir = fs::path(path).parent_path().string();
        src->doc = &doc;
        src->lineStarts.push_back(0);
        for (size_t i = 0; i < text.size(); ++i)
            if (text[i] == '\n') src->lineStarts.push_back(i + 1);
        doc.sources.push_back(std::move(src));
        return *doc.sources.back();
    }

    static bool readText(const std::string& path, std::string& text) {
        std::error_code ec;
        if (!fs::is_regular_file(path, ec)) return false;
        std::ifstream in(path, std::ios::binary);
        if (!in) return false;
        std::ostringstream ss;
        ss << in.rdbuf();
        text = ss.str();
        return true;
    }

    // Parses one file; returns its <scene> root converted (children only are used by includes).
    void readFile(const std::string& path, const std::string& text, Elem& into, bool isMain) {
        includeStack.push_back(canonical(path));
        Source& src = addSource(path, text);
        pugi::xml_document xdoc;
        pugi::xml_parse_result r = xdoc.load_buffer(text.data(), text.size(), pugi::parse_default, pugi::encoding_auto);
        if (!r)
            throw SceneError(fmt::format("{}:{}: malformed XML: {} (at byte offset {})", path,
                                         src.lineOf(r.offset), r.description(), r.offset));
        pugi::xml_node root = xdoc.document_element();
        Elem tmp;
        tmp.src = &src;
        tmp.line = src.lineOf(root.offset_debug());
        tmp.tag = lower(root.name());
        if (tmp.tag != "scene") fail(tmp, "the root element must be <scene version=\"...\">");
        std::string version;
        for (pugi::xml_attribute a : root.attributes()) {
            std::string n = a.name();
            if (n == "version") version = a.value();
            else if (n.rfind("xmlns", 0) != 0) fail(tmp, fmt::format("unexpected attribute '{}' (allowed: version)", n));
        }
        if (version.empty())
            doc.warnings.push_back(fmt::format("{}: <scene> has no version attribute; assuming Mitsuba 3", tmp.where()));
        src.legacy = version.rfind("0.", 0) == 0 || version == "0";
        if (isMain) {
            into.tag = "scene";
            into.src = &src;
            into.line = tmp.line;
            into.attrs = {{"version", version}};
        }
        convertChildren(root, into, src, 0);
        includeStack.pop_back();
    }

    std::string substitute(const std::string& v, const Elem& e, const std::string& attrName) {
        std::string out;
        for (size_t i = 0; i < v.size(); ++i) {
            if (v[i] != '$') {
                out += v[i];
                continue;
            }
            size_t j = i + 1;
            while (j < v.size() && (std::isalnum((unsigned char)v[j]) || v[j] == '_')) ++j;
            if (j == i + 1) {
                out += '$';
                continue;
            }
            std::string name = v.substr(i + 1, j - i - 1);
            auto it = params.find(name);
            if (it == params.end())
                fail(e, fmt::format("attribute {}=\"{}\": undefined parameter ${} (give it a value with "
                                    "<default name=\"{}\" value=\"...\"/> or on the command line: -D {}=...)",
                                    attrName, v, name, name, name));
            usedNames.insert(name);
            out += it->second;
            i = j - 1;
        }
        return out;
    }

    void convertChildren(const pugi::xml_node& node, Elem& parent, const Source& src, int depth) {
        if (depth > 64) fail(parent, "elements nested too deeply");
        for (pugi::xml_node c : node.children()) {
            if (c.type() == pugi::node_pcdata || c.type() == pugi::node_cdata) {
                std::string t = c.value();
                if (std::any_of(t.begin(), t.end(), [](char ch) { return !std::isspace((unsigned char)ch); }))
                    fail(parent, fmt::format("unexpected text '{}' inside the element", t.substr(0, 40)));
                continue;
            }
            if (c.type() != pugi::node_element) continue;
            auto e = std::make_unique<Elem>();
            e->src = &src;
            e->line = src.lineOf(c.offset_debug());
            e->tag = lower(c.name());
            for (pugi::xml_attribute a : c.attributes()) {
                e->attrs.emplace_back(a.name(), "");
                e->attrs.back().second = substitute(a.value(), *e, a.name());
            }
            if (e->tag == "default") {
                checkAttrs(*e, {"name", "value"});
                const std::string *n = e->attr("name"), *v = e->attr("value");
                if (!n || !v) fail(*e, "needs both attributes name and value");
                if (n->empty()) fail(*e, "empty name");
                if (cliNames.count(*n)) usedNames.insert(*n);
                params.emplace(*n, *v);  // first definition wins: command line, then earlier defaults
                continue;
            }
            if (e->tag == "path") {
                checkAttrs(*e, {"value"});
                const std::string* v = e->attr("value");
                if (!v) fail(*e, "needs the attribute value");
                fs::path p(*v);
                if (p.is_relative()) p = fs::path(src.dir) / p;
                doc.searchDirs.push_back(p.string());
                continue;
            }
            if (e->tag == "include") {
                checkAttrs(*e, {"filename"});
                const std::string* f = e->attr("filename");
                if (!f) fail(*e, "needs the attribute filename");
                std::string tried;
                std::string found = resolveFile(doc, *e, *f, tried);
                std::string text;
                if (found.empty() || !readText(found, text))
                    failParam(*e, e.get(), "filename", fmt::format("included file '{}' not found (looked for: {})", *f, tried));
                if (std::find(includeStack.begin(), includeStack.end(), canonical(found)) != includeStack.end())
                    failParam(*e, e.get(), "filename", fmt::format("include cycle: '{}' is already being read", found));
                if (includeStack.size() > 32) failParam(*e, e.get(), "filename", "includes nested too deeply");
                readFile(found, text, parent, false);
                continue;
            }
            if (const std::string* id = e->attr("id"); id && e->tag != "ref") {
                if (id->empty()) fail(*e, "empty id");
                auto [it, inserted] = doc.ids.emplace(*id, e.get());
                if (!inserted)
                    fail(*e, fmt::format("duplicate id '{}' (first defined at {})", *id, it->second->where()));
            }
            convertChildren(c, *e, src, depth + 1);
            parent.children.push_back(std::move(e));
        }
    }
};

}  // namespace

Document::Document(Document&& o) noexcept { *this = std::move(o); }

Document& Document::operator=(Document&& o) noexcept {
    sources = std::move(o.sources);
    root = std::move(o.root);
    ids = std::move(o.ids);
    searchDirs = std::move(o.searchDirs);
    mainDir = std::move(o.mainDir);
    warnings = std::move(o.warnings);
    for (auto& src : sources) src->doc = this;
    return *this;
}

std::string resolveFile(const Document& doc, const Elem& from, const std::string& name, std::string& tried) {
    std::vector<fs::path> candidates;
    fs::path p(name);
    if (p.is_absolute()) {
        candidates.push_back(p);
    } else {
        if (from.src) candidates.push_back(fs::path(from.src->dir) / p);
        candidates.push_back(fs::path(doc.mainDir) / p);
        for (auto& d : doc.searchDirs) candidates.push_back(fs::path(d) / p);
    }
    std::vector<std::string> seen;
    for (auto& c : candidates) {
        std::string s = c.lexically_normal().string();
        if (std::find(seen.begin(), seen.end(), s) != seen.end()) continue;
        seen.push_back(s);
        std::error_code ec;
        if (fs::is_regular_file(c, ec)) return s;
    }
    tried = joinList(seen);
    return "";
}

Document parseDocument(const std::string& path, const std::map<std::string, std::string>& defines) {
    Document doc;
    doc.mainDir = fs::path(path).parent_path().string();
    Reader rd{doc, {}, {}, {}, {}};
    for (auto& [k, v] : defines) {
        rd.params[k] = v;
        rd.cliNames.insert(k);
    }
    std::string text;
    if (!Reader::readText(path, text))
        throw SceneError(fmt::format("{}:0: cannot open the scene file (it does not exist or is not readable)", path));
    doc.root = std::make_unique<Elem>();
    rd.readFile(path, text, *doc.root, true);
    for (auto& n : rd.cliNames)
        if (!rd.usedNames.count(n))
            doc.warnings.push_back(fmt::format("-D {}: the scene has no <default name=\"{}\"> and never uses ${}", n, n, n));
    return doc;
}

// ---------------------------------------------------------------------------------------------
// Transforms

namespace {

Vec3 attrVec(const Elem& owner, const Elem& e, const std::string& param, const char* attrName) {
    const std::string* v = e.attr(attrName);
    if (!v) failParam(owner, &e, param, fmt::format("<{}> needs the attribute {}", e.tag, attrName));
    auto n = parseNumbers(*v);
    if (!n || n->size() != 3)
        failParam(owner, &e, param, fmt::format("<{}> {}=\"{}\": expected 3 numbers", e.tag, attrName, *v));
    Vec3 r((*n)[0], (*n)[1], (*n)[2]);
    if (!std::isfinite(r.x) || !std::isfinite(r.y) || !std::isfinite(r.z))
        failParam(owner, &e, param, fmt::format("<{}> {}=\"{}\": not a finite value", e.tag, attrName, *v));
    return r;
}

// x/y/z attributes (each optional, default `def`) or value="x y z" (or one number if allowed).
Vec3 xyzOrValue(const Elem& owner, const Elem& e, const std::string& param, float def, bool allowUniform) {
    if (const std::string* v = e.attr("value")) {
        if (e.attr("x") || e.attr("y") || e.attr("z"))
            failParam(owner, &e, param, fmt::format("<{}>: give either value or x, y, z", e.tag));
        auto n = parseNumbers(*v);
        if (n && n->size() == 1 && allowUniform) return Vec3(float((*n)[0]));
        if (!n || n->size() != 3)
            failParam(owner, &e, param, fmt::format("<{}> value=\"{}\": expected 3 numbers{}", e.tag, *v,
                                                    allowUniform ? " or 1" : ""));
        Vec3 r((*n)[0], (*n)[1], (*n)[2]);
        if (!std::isfinite(r.x) || !std::isfinite(r.y) || !std::isfinite(r.z))
            failParam(owner, &e, param, fmt::format("<{}> value=\"{}\": not a finite value", e.tag, *v));
        return r;
    }
    Vec3 r(def);
    const char* names[3] = {"x", "y", "z"};
    for (int i = 0; i < 3; ++i) {
        if (const std::string* s = e.attr(names[i])) {
            auto n = parseNumbers(*s);
            if (!n || n->size() != 1 || !std::isfinite(float((*n)[0])))
                failParam(owner, &e, param, fmt::format("<{}> {}=\"{}\": expected a number", e.tag, names[i], *s));
            r[i] = float((*n)[0]);
        }
    }
    return r;
}

}  // namespace

Mat4 parseTransform(const Elem& owner, const Elem& t, const std::string& param) {
    checkAttrs(t, {"name"});
    Mat4 m(1.f);
    for (auto& cp : t.children) {
        const Elem& c = *cp;
        Mat4 op(1.f);
        if (c.tag == "translate") {
            checkAttrs(c, {"x", "y", "z", "value"});
            op = glm::translate(Mat4(1.f), xyzOrValue(owner, c, param, 0.f, false));
        } else if (c.tag == "scale") {
            checkAttrs(c, {"x", "y", "z", "value"});
            op = glm::scale(Mat4(1.f), xyzOrValue(owner, c, param, 1.f, true));
        } else if (c.tag == "rotate") {
            checkAttrs(c, {"x", "y", "z", "value", "angle"});
            Vec3 axis = xyzOrValue(owner, c, param, 0.f, false);
            const std::string* a = c.attr("angle");
            if (!a) failParam(owner, &c, param, "<rotate> needs the attribute angle (degrees)");
            auto n = parseNumbers(*a);
            if (!n || n->size() != 1 || !std::isfinite(float((*n)[0])))
                failParam(owner, &c, param, fmt::format("<rotate> angle=\"{}\": expected a number", *a));
            if (glm::length(axis) == 0.f) failParam(owner, &c, param, "<rotate>: the axis is zero");
            op = glm::rotate(Mat4(1.f), glm::radians(float((*n)[0])), glm::normalize(axis));
        } else if (c.tag == "matrix") {
            checkAttrs(c, {"value"});
            const std::string* v = c.attr("value");
            if (!v) failParam(owner, &c, param, "<matrix> needs the attribute value (16 numbers, row-major)");
            auto n = parseNumbers(*v);
            if (!n || (n->size() != 16 && n->size() != 9))
                failParam(owner, &c, param,
                          fmt::format("<matrix> value: expected 16 numbers (row-major 4x4) or 9 (3x3), got {}",
                                      n ? std::to_string(n->size()) : std::string("malformed text")));
            int dim = n->size() == 16 ? 4 : 3;
            for (int r = 0; r < dim; ++r)
                for (int col = 0; col < dim; ++col) {
                    double x = (*n)[r * dim + col];
                    if (!std::isfinite(float(x))) failParam(owner, &c, param, "<matrix>: not a finite value");
                    op[col][r] = float(x);  // glm is column-major: op[column][row]
                }
        } else if (c.tag == "lookat") {
            checkAttrs(c, {"origin", "target", "up"});
            Vec3 o = attrVec(owner, c, param, "origin"), tg = attrVec(owner, c, param, "target");
            Vec3 d = tg - o;
            if (glm::length(d) == 0.f) failParam(owner, &c, param, "<lookat>: origin and target are the same point");
            d = glm::normalize(d);
            Vec3 up = c.attr("up") ? attrVec(owner, c, param, "up") : Frame(d).t;
            Vec3 left = glm::cross(up, d);
            if (glm::length(left) < 1e-6f * std::max(1e-30f, glm::length(up)))
                failParam(owner, &c, param, "<lookat>: up is zero or parallel to the viewing direction");
            left = glm::normalize(left);
            Vec3 newUp = glm::cross(d, left);
            op = Mat4(Vec4(left, 0.f), Vec4(newUp, 0.f), Vec4(d, 0.f), Vec4(o, 1.f));
        } else {
            failParam(owner, &c, param,
                      fmt::format("unsupported transform <{}> (supported: translate, rotate, scale, matrix, lookat)", c.tag));
        }
        m = op * m;
    }
    return m;
}

// ---------------------------------------------------------------------------------------------
// Props

Props::Props(const Elem& o) : owner(o) {
    checkAttrs(owner, {"type", "id", "name"});
    for (auto& cp : owner.children) {
        const Elem& c = *cp;
        if (isIn(kPropertyTags, c.tag)) {
            const std::string* n = c.attr("name");
            if (!n || n->empty()) fail(c, fmt::format("a <{}> property needs a name attribute", c.tag));
            std::string key = toSnake(*n);
            if (c.tag == "spectrum" && c.attr("type"))  // Mitsuba 3's spectrum plugins (blackbody, d65, ...)
                failParam(owner, &c, key,
                          fmt::format("<spectrum type=\"{}\"> plugins are not supported (Mitsuba 3's RGB variants "
                                      "do not evaluate its blackbody either): give <spectrum value=\"...\">, "
                                      "<spectrum filename=\"...\">, <rgb> or <blackbody temperature=\"...\">",
                                      *c.attr("type")));
            if (c.tag == "transform") checkAttrs(c, {"name"});
            else if (c.tag == "point" || c.tag == "vector") checkAttrs(c, {"name", "value", "x", "y", "z"});
            else if (c.tag == "spectrum") checkAttrs(c, {"name", "value", "filename"});
            else if (c.tag == "blackbody") checkAttrs(c, {"name", "temperature", "scale"});
            else checkAttrs(c, {"name", "value"});
            if (c.tag == "blackbody" && !c.attr("temperature"))
                failParam(owner, &c, key, "<blackbody> needs a temperature attribute (kelvin)");
            if (c.tag != "transform" && c.tag != "point" && c.tag != "vector" && c.tag != "spectrum" &&
                c.tag != "blackbody" && !c.attr("value"))
                failParam(owner, &c, key, fmt::format("<{}> needs a value attribute", c.tag));
            auto [it, ok] = params_.emplace(key, &c);
            if (!ok) failParam(owner, &c, key, fmt::format("given twice (first at line {})", it->second->line));
        } else if (isIn(kObjectTags, c.tag)) {
            objects.push_back(&c);
        } else {
            fail(c, fmt::format("unknown element <{}> inside {} (properties: {}; plugins: {})", c.tag,
                                owner.describe(), joinList(kPropertyTags), joinList(kObjectTags)));
        }
    }
}

const Elem* Props::find(const std::string& name) {
    if (std::find(asked_.begin(), asked_.end(), name) == asked_.end()) asked_.push_back(name);
    auto it = params_.find(name);
    return it == params_.end() ? nullptr : it->second;
}

void Props::failAt(const std::string& name, const std::string& msg) const {
    auto it = params_.find(name);
    failParam(owner, it == params_.end() ? nullptr : it->second, name, msg);
}

bool Props::has(const std::string& name) { return find(name) != nullptr; }

bool Props::isString(const std::string& name) {
    const Elem* e = find(name);
    return e && e->tag == "string";
}

namespace {
double parseScalar(const Props& p, const std::string& name, const Elem& e) {
    const std::string& v = *e.attr("value");
    auto n = parseNumbers(v);
    if (!n || n->size() != 1) p.failAt(name, fmt::format("value \"{}\" is not a number", v));
    if (!std::isfinite(float((*n)[0])))
        p.failAt(name, fmt::format("value \"{}\" is not finite (NaN, infinite or beyond the float range)", v));
    return (*n)[0];
}
}  // namespace

float Props::getFloat(const std::string& name, float def) {
    const Elem* e = find(name);
    if (!e) return def;
    if (e->tag != "float" && e->tag != "integer") failAt(name, fmt::format("expected <float>, got <{}>", e->tag));
    return float(parseScalar(*this, name, *e));
}

int Props::getInt(const std::string& name, int def) {
    const Elem* e = find(name);
    if (!e) return def;
    if (e->tag != "integer" && e->tag != "float") failAt(name, fmt::format("expected <integer>, got <{}>", e->tag));
    double v = parseScalar(*this, name, *e);
    if (v != std::floor(v) || std::abs(v) > 2147483647.0)
        failAt(name, fmt::format("value \"{}\" is not an integer", *e->attr("value")));
    return int(v);
}

bool Props::getBool(const std::string& name, bool def) {
    const Elem* e = find(name);
    if (!e) return def;
    if (e->tag != "boolean") failAt(name, fmt::format("expected <boolean>, got <{}>", e->tag));
    std::string v = lower(*e->attr("value"));
    if (v == "true" || v == "1") return true;
    if (v == "false" || v == "0") return false;
    failAt(name, fmt::format("value \"{}\" is not a boolean (true or false)", *e->attr("value")));
}

std::string Props::getString(const std::string& name, const std::string& def) {
    const Elem* e = find(name);
    if (!e) return def;
    if (e->tag != "string") failAt(name, fmt::format("expected <string>, got <{}>", e->tag));
    return *e->attr("value");
}

namespace {

// Mitsuba's parameters converted unbounded (src/core/xml.cpp is_unbounded_spectrum up to 3.6;
// 3.7's plugins ask get_unbounded_texture for eta and k).
SpectrumKind spectrumKind(const Elem& owner, const std::string& name) {
    if (owner.tag == "emitter") return SpectrumKind::Emission;
    for (const char* n : {"eta", "k", "int_ior", "ext_ior", "sigma_t"})
        if (name == n) return SpectrumKind::Unbounded;
    return SpectrumKind::Reflectance;
}

Color spectrumColor(const Props& p, const std::string& name, const Elem& e) {
    const std::string *v = e.attr("value"), *f = e.attr("filename");
    if (bool(v) == bool(f)) p.failAt(name, "<spectrum> needs either a value or a filename attribute (not both)");
    const SpectrumKind kind = spectrumKind(p.owner, name);
    SampledSpectrum s;
    std::string error;
    if (v && v->find(':') == std::string::npos) {  // uniform
        auto n = parseNumbers(*v);
        if (!n || n->size() != 1)
            p.failAt(name, fmt::format("<spectrum> value \"{}\": expected one number or wavelength:value pairs "
                                       "(\"400:0.1, 500:0.5\")", *v));
        const double u = parseScalar(p, name, e);
        // Mitsuba 0.6 (RGB build) keeps a uniform spectrum grey, emission included.
        return uniformSpectrumToLinearSrgb(u, e.src && e.src->legacy ? SpectrumKind::Reflectance : kind);
    }
    if (v) {
        auto parsed = parseSpectrumPairs(*v, error);
        if (!parsed) p.failAt(name, fmt::format("<spectrum> value: {}", error));
        s = std::move(*parsed);
    } else {
        std::string tried, path;
        if (e.src && e.src->doc) path = resolveFile(*e.src->doc, e, *f, tried);
        else if (std::error_code ec; fs::is_regular_file(*f, ec)) path = *f;
        else tried = *f;
        if (path.empty()) p.failAt(name, fmt::format("spectrum file '{}' not found (looked for: {})", *f, tried));
        auto read = readSpectrumFile(path, error);
        if (!read) p.failAt(name, fmt::format("spectrum file '{}': {}", path, error));
        s = std::move(*read);
    }
    if (std::string why = checkSpectrum(s); !why.empty())
        p.failAt(name, v ? fmt::format("<spectrum> value: {}", why) : fmt::format("spectrum file '{}': {}", *f, why));
    return spectrumToLinearSrgb(s, kind);
}

// Mitsuba 0.6's <blackbody name temperature="5000K" scale="1">: Planck's radiance in
// W m^-2 sr^-1 nm^-1 times scale, converted as emission (0.6: XYZ by the matching functions,
// negatives clamped; the same as Mitsuba 3's conversion of a sampled emission spectrum).
Color blackbodyColor(const Props& p, const std::string& name, const Elem& e) {
    std::string t = *e.attr("temperature");
    while (!t.empty() && std::isspace((unsigned char)t.back())) t.pop_back();
    if (!t.empty() && (t.back() == 'K' || t.back() == 'k')) t.pop_back();
    auto n = parseNumbers(t);
    if (!n || n->size() != 1)
        p.failAt(name, fmt::format("<blackbody> temperature \"{}\" is not a number (kelvin)", *e.attr("temperature")));
    const double kelvin = (*n)[0];
    if (!(std::isfinite(float(kelvin)) && kelvin > 0.0))
        p.failAt(name, fmt::format("<blackbody> temperature {} must be finite and > 0 kelvin", *e.attr("temperature")));
    double scale = 1.0;
    if (const std::string* sc = e.attr("scale")) {
        auto m = parseNumbers(*sc);
        if (!m || m->size() != 1 || !std::isfinite(float((*m)[0])) || (*m)[0] < 0.0)
            p.failAt(name, fmt::format("<blackbody> scale \"{}\" must be a finite number >= 0", *sc));
        scale = (*m)[0];
    }
    const Color c = Color(DVec3(blackbodyToLinearSrgb(kelvin)) * scale);
    if (!isFinite(c))
        p.failAt(name, fmt::format("<blackbody> temperature {} with scale {} overflows the float range", kelvin, scale));
    return c;
}

}  // namespace

Color Props::getColor(const std::string& name, const Color& def) {
    const Elem* e = find(name);
    if (!e) return def;
    if (e->tag == "float" || e->tag == "integer") return Color(float(parseScalar(*this, name, *e)));
    if (e->tag == "spectrum") return spectrumColor(*this, name, *e);
    if (e->tag == "blackbody") return blackbodyColor(*this, name, *e);
    if (e->tag != "rgb" && e->tag != "srgb")
        failAt(name, fmt::format("expected a color (<rgb>, <srgb>, <spectrum>, <blackbody> or <float>), got <{}>", e->tag));
    const std::string& v = *e->attr("value");
    auto n = parseNumbers(v);
    if (!n || (n->size() != 3 && n->size() != 1))
        failAt(name, fmt::format("<{}> value \"{}\": expected \"r, g, b\" (3 numbers) or one number", e->tag, v));
    Color c = n->size() == 1 ? Color(float((*n)[0])) : Color((*n)[0], (*n)[1], (*n)[2]);
    if (!isFinite(c)) failAt(name, fmt::format("value \"{}\" is not finite (NaN or infinite)", v));
    if (e->tag == "srgb")
        for (int i = 0; i < 3; ++i)
            c[i] = c[i] <= 0.04045f ? c[i] / 12.92f : std::pow((c[i] + 0.055f) / 1.055f, 2.4f);
    return c;
}

Vec3 Props::getPoint(const std::string& name, const Vec3& def) {
    const Elem* e = find(name);
    if (!e) return def;
    if (e->tag != "point" && e->tag != "vector")
        failAt(name, fmt::format("expected <point> or <vector>, got <{}>", e->tag));
    return xyzOrValue(owner, *e, name, 0.f, false);
}

Mat4 Props::getTransform(const std::string& name, const Mat4& def) {
    const Elem* e = find(name);
    if (!e) return def;
    if (e->tag != "transform") failAt(name, fmt::format("expected <transform>, got <{}>", e->tag));
    Mat4 m = parseTransform(owner, *e, name);
    for (int c = 0; c < 4; ++c)
        if (!isFinite(Vec3(m[c])) || !std::isfinite(m[c][3])) failAt(name, "the transform is not finite (overflow)");
    return m;
}

void Props::requireNonNegative(const std::string& name, float v) {
    if (!(v >= 0.f)) failAt(name, fmt::format("must be >= 0 (got {})", v));
}
void Props::requireNonNegative(const std::string& name, const Color& c) {
    if (!(c.x >= 0.f && c.y >= 0.f && c.z >= 0.f))
        failAt(name, fmt::format("negative value ({}, {}, {}): must be >= 0", c.x, c.y, c.z));
}
void Props::requirePositive(const std::string& name, float v) {
    if (!(v > 0.f)) failAt(name, fmt::format("must be > 0 (got {})", v));
}

void Props::ignore(const std::vector<std::string>& names, std::vector<std::string>* warnings) {
    for (auto& n : names) {
        const Elem* e = find(n);
        if (e && warnings)
            warnings->push_back(fmt::format("{}: {} parameter '{}' is accepted and ignored", e->where(), owner.describe(), n));
    }
}

void Props::finish() {
    for (auto& [name, e] : params_)
        if (std::find(asked_.begin(), asked_.end(), name) == asked_.end())
            failParam(owner, e, name,
                      fmt::format("unsupported parameter for {} (supported: {})", owner.describe(),
                                  asked_.empty() ? std::string("none") : joinList(asked_)));
}

}  // namespace lt::xml
