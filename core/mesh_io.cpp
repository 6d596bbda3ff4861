// Mesh file readers: OBJ (through tinyobjloader), PLY and Mitsuba .serialized (our own readers).
#include "core/mesh_io.h"

#include <fmt/format.h>
#include <tiny_obj_loader.h>
#include <zlib.h>

#include <bit>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unordered_map>

namespace lt {

namespace {

std::string readAll(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) throw MeshError(fmt::format("{}: file not found", path));
    std::ifstream in(path, std::ios::binary);
    if (!in) throw MeshError(fmt::format("{}: cannot open the file", path));
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// OBJ

namespace {
struct ObjKey {
    int v, n, t;
    bool operator==(const ObjKey& o) const { return v == o.v && n == o.n && t == o.t; }
};
struct ObjKeyHash {
    size_t operator()(const ObjKey& k) const {
        uint64_t h = uint64_t(uint32_t(k.v)) * 0x9E3779B97F4A7C15ull;
        h ^= (uint64_t(uint32_t(k.n)) + 0x632BE59BD9B4E019ull + (h << 6) + (h >> 2));
        h ^= (uint64_t(uint32_t(k.t)) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2));
        return size_t(h);
    }
};
}  // namespace

namespace {

// What tinyobjloader (Debian's 2.0) is given of an OBJ file. Two of its parsers have undefined
// behaviour on bad input (found by fuzz_obj, tests/fuzz/README.md): a skin-weight line `vw` with a
// joint id of 1e32, inf or NaN casts that float to int, and a number whose exponent has ten
// digits overflows an int while it is read. We use neither skin weights nor such numbers: `vw`
// lines are blanked (the line count stays, for its messages), and a number with an exponent of
// more than three digits (beyond float's range either way) is refused here, naming the line.
std::string objTextForParser(const std::string& path, std::string text) {
    size_t line = 1;
    for (size_t i = 0; i < text.size();) {
        const size_t end = std::min(text.find('\n', i), text.size());
        size_t k = i;
        while (k < end && (text[k] == ' ' || text[k] == '\t')) ++k;
        if (end - k >= 3 && text[k] == 'v' && text[k + 1] == 'w' && (text[k + 2] == ' ' || text[k + 2] == '\t'))
            std::fill(text.begin() + long(k), text.begin() + long(end), ' ');
        // Numeric tokens: a digit (after an optional sign or point) and an exponent.
        for (size_t j = k; j < end; ++j) {
            if (text[j] != 'e' && text[j] != 'E') continue;
            if (j == i || !(std::isdigit((unsigned char)text[j - 1]) || text[j - 1] == '.')) continue;
            size_t d = j + 1;
            if (d < end && (text[d] == '+' || text[d] == '-')) ++d;
            size_t digits = 0;
            while (d + digits < end && std::isdigit((unsigned char)text[d + digits])) ++digits;
            if (digits > 3)
                throw MeshError(fmt::format("{}:{}: a number with the exponent '{}' is out of range", path, line,
                                            text.substr(j, d + digits - j)));
        }
        i = end + 1;
        ++line;
    }
    return text;
}

}  // namespace

MeshDesc readObj(const std::string& path, bool flipV) {
    const std::string text = objTextForParser(path, readAll(path));
    tinyobj::ObjReaderConfig cfg;
    cfg.triangulate = true;
    cfg.vertex_color = false;
    tinyobj::ObjReader reader;
    // Parsed from memory, with no material library: the materials are not used, and a `mtllib`
    // line then opens no file (a FIFO or /dev/zero named there would block or never end).
    if (!reader.ParseFromString(text, "", cfg))
        throw MeshError(fmt::format("{}: cannot read the OBJ file: {}", path, reader.Error()));
    const tinyobj::attrib_t& at = reader.GetAttrib();
    size_t nv = at.vertices.size() / 3, nn = at.normals.size() / 3, nt = at.texcoords.size() / 2;

    MeshDesc m;
    m.name = path;
    bool allNormals = true, anyUv = false;
    for (const auto& sh : reader.GetShapes())
        for (const auto& idx : sh.mesh.indices) {
            allNormals = allNormals && idx.normal_index >= 0;
            anyUv = anyUv || idx.texcoord_index >= 0;
        }
    std::unordered_map<ObjKey, uint32_t, ObjKeyHash> remap;
    std::vector<Vec3> normals;
    for (const auto& sh : reader.GetShapes()) {
        size_t off = 0;
        for (size_t f = 0; f < sh.mesh.num_face_vertices.size(); ++f) {
            size_t fv = sh.mesh.num_face_vertices[f];
            if (fv != 3) throw MeshError(fmt::format("{}: face {} of '{}' has {} vertices after triangulation",
                                                     path, f + 1, sh.name, fv));
            for (size_t k = 0; k < 3; ++k) {
                const tinyobj::index_t& idx = sh.mesh.indices[off + k];
                if (idx.vertex_index < 0 || size_t(idx.vertex_index) >= nv)
                    throw MeshError(fmt::format("{}: face {} of '{}' refers to vertex {} (the file has {})", path,
                                                f + 1, sh.name, idx.vertex_index + 1, nv));
                if (idx.normal_index >= 0 && size_t(idx.normal_index) >= nn)
                    throw MeshError(fmt::format("{}: face {}: normal index {} out of range ({} normals)", path, f + 1,
                                                idx.normal_index + 1, nn));
                if (idx.texcoord_index >= 0 && size_t(idx.texcoord_index) >= nt)
                    throw MeshError(fmt::format("{}: face {}: texture coordinate index {} out of range ({})", path,
                                                f + 1, idx.texcoord_index + 1, nt));
                ObjKey key{idx.vertex_index, allNormals ? idx.normal_index : -1, idx.texcoord_index};
                auto it = remap.find(key);
                uint32_t vi;
                if (it == remap.end()) {
                    vi = uint32_t(m.positions.size());
                    remap.emplace(key, vi);
                    m.positions.emplace_back(at.vertices[3 * idx.vertex_index], at.vertices[3 * idx.vertex_index + 1],
                                             at.vertices[3 * idx.vertex_index + 2]);
                    if (allNormals)
                        normals.emplace_back(at.normals[3 * idx.normal_index], at.normals[3 * idx.normal_index + 1],
                                             at.normals[3 * idx.normal_index + 2]);
                    if (anyUv) {
                        Vec2 uv(0.f);
                        if (idx.texcoord_index >= 0)
                            uv = Vec2(at.texcoords[2 * idx.texcoord_index], at.texcoords[2 * idx.texcoord_index + 1]);
                        if (flipV) uv.y = 1.f - uv.y;
                        m.uvs.push_back(uv);
                    }
                } else {
                    vi = it->second;
                }
                m.indices.push_back(vi);
            }
            off += fv;
        }
    }
    if (allNormals && !m.positions.empty()) m.normals = std::move(normals);
    return m;
}

// ---------------------------------------------------------------------------------------------
// PLY

namespace {

enum class PlyType { I8, U8, I16, U16, I32, U32, F32, F64 };

size_t plySize(PlyType t) {
    switch (t) {
        case PlyType::I8: case PlyType::U8: return 1;
        case PlyType::I16: case PlyType::U16: return 2;
        case PlyType::I32: case PlyType::U32: case PlyType::F32: return 4;
        case PlyType::F64: return 8;
    }
    return 1;
}

bool plyTypeFromName(const std::string& n, PlyType& t) {
    static const std::pair<const char*, PlyType> table[] = {
        {"char", PlyType::I8},    {"int8", PlyType::I8},     {"uchar", PlyType::U8},    {"uint8", PlyType::U8},
        {"short", PlyType::I16},  {"int16", PlyType::I16},   {"ushort", PlyType::U16},  {"uint16", PlyType::U16},
        {"int", PlyType::I32},    {"int32", PlyType::I32},   {"uint", PlyType::U32},    {"uint32", PlyType::U32},
        {"float", PlyType::F32},  {"float32", PlyType::F32}, {"double", PlyType::F64},  {"float64", PlyType::F64}};
    for (auto& [name, type] : table)
        if (n == name) {
            t = type;
            return true;
        }
    return false;
}

struct PlyProp {
    std::string name;
    PlyType type = PlyType::F32;
    bool isList = false;
    PlyType countType = PlyType::U8;
};
struct PlyElement {
    std::string name;
    size_t count = 0;
    std::vector<PlyProp> props;
};

enum class PlyFormat { Ascii, BinaryLE, BinaryBE };

class PlyData {
public:
    PlyData(const std::string& path, const std::string& data, size_t pos, PlyFormat fmt)
        : path_(path), d_(data), pos_(pos), fmt_(fmt) {}

    double read(PlyType t, const char* what) {
        if (fmt_ == PlyFormat::Ascii) {
            while (pos_ < d_.size() && std::isspace((unsigned char)d_[pos_])) ++pos_;
            if (pos_ >= d_.size()) throw MeshError(fmt::format("{}: unexpected end of file while reading {}", path_, what));
            const char* s = d_.c_str() + pos_;
            char* end = nullptr;
            double v = std::strtod(s, &end);
            if (end == s || (*end && !std::isspace((unsigned char)*end)))
                throw MeshError(fmt::format("{}: malformed number while reading {} (byte {})", path_, what, pos_));
            pos_ += size_t(end - s);
            return v;
        }
        size_t n = plySize(t);
        if (pos_ + n > d_.size()) throw MeshError(fmt::format("{}: unexpected end of file while reading {}", path_, what));
        unsigned char b[8];
        std::memcpy(b, d_.data() + pos_, n);
        pos_ += n;
        bool swap = (fmt_ == PlyFormat::BinaryBE) != (std::endian::native == std::endian::big);
        if (swap) std::reverse(b, b + n);
        switch (t) {
            case PlyType::I8: { int8_t v; std::memcpy(&v, b, 1); return v; }
            case PlyType::U8: { uint8_t v; std::memcpy(&v, b, 1); return v; }
            case PlyType::I16: { int16_t v; std::memcpy(&v, b, 2); return v; }
            case PlyType::U16: { uint16_t v; std::memcpy(&v, b, 2); return v; }
            case PlyType::I32: { int32_t v; std::memcpy(&v, b, 4); return v; }
            case PlyType::U32: { uint32_t v; std::memcpy(&v, b, 4); return v; }
            case PlyType::F32: { float v; std::memcpy(&v, b, 4); return v; }
            case PlyType::F64: { double v; std::memcpy(&v, b, 8); return v; }
        }
        return 0;
    }
    size_t remaining() const { return d_.size() - pos_; }
    bool ascii() const { return fmt_ == PlyFormat::Ascii; }
    // A list's length: a whole number in [0, 1e6] (a float count type is allowed, as the format
    // says nothing against it; NaN, a fraction or a count of 1e30 is refused before it is cast).
    long long listCount(PlyType t, const char* what, const std::string& element, size_t row) {
        const double c = read(t, what);
        if (!(c >= 0.0 && c <= 1e6) || c != std::floor(c))
            throw MeshError(fmt::format("{}: entry {} of element '{}' has an invalid list length {}", path_, row,
                                        element, c));
        return (long long)c;
    }

private:
    const std::string& path_;
    const std::string& d_;
    size_t pos_;
    PlyFormat fmt_;
};

// Mitsuba's attribute groups of a PLY element (ply.h, find_other_fields): which properties form
// which attribute, by the rules of readPly's comment. `reserved`: the element's own properties.
struct PlyAttributeGroup {
    std::string name;
    std::vector<int> props;
};
std::vector<PlyAttributeGroup> plyAttributeGroups(const PlyElement& el, const std::string& type,
                                                  const std::vector<std::string>& reserved) {
    std::vector<PlyAttributeGroup> out;
    auto find = [&](const char* n) {
        for (int i = 0; i < int(el.props.size()); ++i)
            if (!el.props[i].isList && el.props[i].name == n) return i;
        return -1;
    };
    std::vector<std::string> skip = reserved;
    const int r = find("r") >= 0 ? find("r") : find("red"), g = find("g") >= 0 ? find("g") : find("green"),
              b = find("b") >= 0 ? find("b") : find("blue");
    if (r >= 0 && g >= 0 && b >= 0) out.push_back({type + "color", {r, g, b}});
    for (const char* n : {"r", "g", "b", "a", "red", "green", "blue", "alpha"}) skip.push_back(n);
    static const char* kPostfixes[4] = {"xr01", "yg12", "zb23", "wa34"};  // [level][category]
    std::vector<std::string> seen;
    PlyAttributeGroup cur;
    std::string prefix;
    int category = -1;
    auto flush = [&] {
        if (category >= 0 && (cur.props.size() == 1 || cur.props.size() == 3)) {
            cur.name = type + prefix + (category == 1 ? "_color" : "");
            out.push_back(cur);
            seen.push_back(prefix);
        }
        cur = {};
        category = -1;
    };
    for (int i = 0; i < int(el.props.size()); ++i) {
        const PlyProp& p = el.props[i];
        if (p.isList || std::find(skip.begin(), skip.end(), p.name) != skip.end()) continue;
        const size_t us = p.name.find_last_of('_');
        if (us == std::string::npos || us + 2 != p.name.size()) {
            flush();
            continue;
        }
        const std::string pre = p.name.substr(0, us);
        const char post = p.name.back();
        if (category >= 0 && pre != prefix) flush();
        if (category < 0) {
            if (std::find(seen.begin(), seen.end(), pre) != seen.end()) continue;
            const char* c = std::strchr(kPostfixes[0], post);
            if (!c || !post) continue;
            category = int(c - kPostfixes[0]);
            prefix = pre;
        } else if (cur.props.size() >= 4 || post != kPostfixes[cur.props.size()][category]) {
            cur.props.clear();  // an invalid sequence: the attribute is ignored
            category = -1;
            continue;
        }
        cur.props.push_back(i);
    }
    flush();
    return out;
}

// A property's value as an attribute: integers normalised to [0, 1] and sRGB-decoded (Mitsuba's
// ENormalized | EGamma flags on integer PLY fields).
float plyAttributeValue(PlyType t, double v) {
    double mx = 0.0;
    switch (t) {
        case PlyType::F32: case PlyType::F64: return float(v);
        case PlyType::I8: mx = 127.0; break;
        case PlyType::U8: mx = 255.0; break;
        case PlyType::I16: mx = 32767.0; break;
        case PlyType::U16: mx = 65535.0; break;
        case PlyType::I32: mx = 2147483647.0; break;
        case PlyType::U32: mx = 4294967295.0; break;
    }
    const double x = std::clamp(v / mx, 0.0, 1.0);
    return float(x <= 0.04045 ? x / 12.92 : std::pow((x + 0.055) / 1.055, 2.4));
}

}  // namespace

MeshDesc readPly(const std::string& path, MeshAttributes* attributes) {
    std::string data = readAll(path);
    // ---- header
    size_t pos = 0;
    auto nextLine = [&](std::string& line) {
        if (pos >= data.size()) return false;
        size_t e = data.find('\n', pos);
        if (e == std::string::npos) e = data.size();
        line = data.substr(pos, e - pos);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        pos = std::min(data.size(), e + 1);
        return true;
    };
    std::string line;
    if (!nextLine(line) || line != "ply") throw MeshError(fmt::format("{}: not a PLY file (no 'ply' magic line)", path));
    PlyFormat format = PlyFormat::Ascii;
    bool haveFormat = false, ended = false;
    std::vector<PlyElement> elems;
    int lineNo = 1;
    while (nextLine(line)) {
        ++lineNo;
        std::istringstream ls(line);
        std::string kw;
        ls >> kw;
        if (kw.empty() || kw == "comment" || kw == "obj_info") continue;
        if (kw == "end_header") {
            ended = true;
            break;
        }
        if (kw == "format") {
            std::string f, ver;
            ls >> f >> ver;
            if (f == "ascii") format = PlyFormat::Ascii;
            else if (f == "binary_little_endian") format = PlyFormat::BinaryLE;
            else if (f == "binary_big_endian") format = PlyFormat::BinaryBE;
            else throw MeshError(fmt::format("{}:{}: unknown PLY format '{}' (supported: ascii, binary_little_endian, "
                                             "binary_big_endian)", path, lineNo, f));
            haveFormat = true;
        } else if (kw == "element") {
            PlyElement el;
            long long count = -1;
            ls >> el.name >> count;
            if (el.name.empty() || count < 0 || ls.fail())
                throw MeshError(fmt::format("{}:{}: malformed element line '{}'", path, lineNo, line));
            el.count = size_t(count);
            elems.push_back(el);
        } else if (kw == "property") {
            if (elems.empty()) throw MeshError(fmt::format("{}:{}: property before any element", path, lineNo));
            PlyProp p;
            std::string t;
            ls >> t;
            if (t == "list") {
                std::string ct, it;
                ls >> ct >> it >> p.name;
                p.isList = true;
                if (!plyTypeFromName(ct, p.countType) || !plyTypeFromName(it, p.type) || p.name.empty())
                    throw MeshError(fmt::format("{}:{}: malformed list property '{}'", path, lineNo, line));
            } else {
                ls >> p.name;
                if (!plyTypeFromName(t, p.type) || p.name.empty())
                    throw MeshError(fmt::format("{}:{}: unknown property type in '{}' (supported: char, uchar, short, "
                                                "ushort, int, uint, float, double and int8..float64)", path, lineNo, line));
            }
            elems.back().props.push_back(p);
        } else {
            throw MeshError(fmt::format("{}:{}: unexpected header line '{}'", path, lineNo, line));
        }
    }
    if (!ended) throw MeshError(fmt::format("{}: the PLY header has no end_header", path));
    if (!haveFormat) throw MeshError(fmt::format("{}: the PLY header has no format line", path));

    // ---- body
    PlyData in(path, data, pos, format);
    MeshDesc m;
    m.name = path;
    bool haveVertices = false;
    for (const PlyElement& el : elems) {
        size_t minRow = 0;
        for (auto& p : el.props) minRow += in.ascii() ? 2 : (p.isList ? plySize(p.countType) : plySize(p.type));
        if (minRow > 0 && el.count > in.remaining() / minRow + 1)
            throw MeshError(fmt::format("{}: element '{}' declares {} entries but the file is too short", path,
                                        el.name, el.count));
        if (el.name == "vertex") {
            haveVertices = true;
            int ix[3] = {-1, -1, -1}, in_[3] = {-1, -1, -1}, iuv[2] = {-1, -1};
            static const char* uvNames[][2] = {{"u", "v"}, {"s", "t"}, {"texture_u", "texture_v"}, {"texture_s", "texture_t"}};
            for (int i = 0; i < int(el.props.size()); ++i) {
                const std::string& n = el.props[i].name;
                if (el.props[i].isList) continue;
                for (int k = 0; k < 3; ++k) {
                    if (n == std::string(1, char('x' + k))) ix[k] = i;
                    if (n == std::string("n") + char('x' + k)) in_[k] = i;
                }
                for (auto& uvn : uvNames)
                    for (int k = 0; k < 2; ++k)
                        if (n == uvn[k] && iuv[k] < 0) iuv[k] = i;
            }
            if (ix[0] < 0 || ix[1] < 0 || ix[2] < 0)
                throw MeshError(fmt::format("{}: the vertex element has no x, y, z properties", path));
            bool hasN = in_[0] >= 0 && in_[1] >= 0 && in_[2] >= 0, hasUv = iuv[0] >= 0 && iuv[1] >= 0;
            std::vector<std::string> reserved = {"x", "y", "z", "nx", "ny", "nz"};
            for (int k = 0; k < 2; ++k)
                if (hasUv) reserved.push_back(el.props[size_t(iuv[k])].name);
            const std::vector<PlyAttributeGroup> groups =
                attributes ? plyAttributeGroups(el, "vertex_", reserved) : std::vector<PlyAttributeGroup>{};
            const size_t firstAttr = attributes ? attributes->size() : 0;
            for (const PlyAttributeGroup& g : groups) attributes->push_back({g.name, int(g.props.size()), {}});
            m.positions.reserve(el.count);
            std::vector<double> row(el.props.size());
            for (size_t v = 0; v < el.count; ++v) {
                for (size_t i = 0; i < el.props.size(); ++i) {
                    const PlyProp& p = el.props[i];
                    if (p.isList) {
                        const long long c = in.listCount(p.countType, "a vertex list count", el.name, v);
                        for (long long k = 0; k < c; ++k) in.read(p.type, "a vertex list");
                    } else {
                        row[i] = in.read(p.type, "vertex data");
                    }
                }
                m.positions.emplace_back(row[ix[0]], row[ix[1]], row[ix[2]]);
                if (hasN) m.normals.emplace_back(row[in_[0]], row[in_[1]], row[in_[2]]);
                if (hasUv) m.uvs.emplace_back(row[iuv[0]], row[iuv[1]]);
                for (size_t k = 0; k < groups.size(); ++k)
                    for (int pi : groups[k].props)
                        (*attributes)[firstAttr + k].values.push_back(plyAttributeValue(el.props[size_t(pi)].type, row[size_t(pi)]));
            }
        } else if (el.name == "face") {
            int li = -1;
            for (int i = 0; i < int(el.props.size()); ++i)
                if (el.props[i].isList && (el.props[i].name == "vertex_indices" || el.props[i].name == "vertex_index"))
                    li = i;
            if (li < 0 && el.count > 0)
                throw MeshError(fmt::format("{}: the face element has no list property vertex_indices", path));
            const std::vector<PlyAttributeGroup> groups =
                attributes ? plyAttributeGroups(el, "face_", {}) : std::vector<PlyAttributeGroup>{};
            const size_t firstAttr = attributes ? attributes->size() : 0;
            for (const PlyAttributeGroup& g : groups) attributes->push_back({g.name, int(g.props.size()), {}});
            std::vector<double> poly, row(el.props.size());
            for (size_t f = 0; f < el.count; ++f) {
                size_t trianglesBefore = m.indices.size() / 3;
                for (size_t i = 0; i < el.props.size(); ++i) {
                    const PlyProp& p = el.props[i];
                    if (!p.isList) {
                        row[i] = in.read(p.type, "face data");
                        continue;
                    }
                    const long long c = in.listCount(p.countType, "a face vertex count", el.name, f);
                    poly.clear();
                    for (long long k = 0; k < c; ++k) poly.push_back(in.read(p.type, "face indices"));
                    if (int(i) != li) continue;
                    if (poly.size() < 3)
                        throw MeshError(fmt::format("{}: face {} has {} vertices (at least 3 needed)", path, f, poly.size()));
                    for (double idx : poly)
                        if (!(idx >= 0) || idx > 4294967295.0 || idx != std::floor(idx))
                            throw MeshError(fmt::format("{}: face {} has an invalid vertex index {}", path, f, idx));
                    for (size_t k = 1; k + 1 < poly.size(); ++k) {
                        m.indices.push_back(uint32_t(poly[0]));
                        m.indices.push_back(uint32_t(poly[k]));
                        m.indices.push_back(uint32_t(poly[k + 1]));
                    }
                }
                // A face's attributes on each of its triangles (the fan above).
                for (size_t t = trianglesBefore; t < m.indices.size() / 3; ++t)
                    for (size_t k = 0; k < groups.size(); ++k)
                        for (int pi : groups[k].props)
                            (*attributes)[firstAttr + k].values.push_back(
                                plyAttributeValue(el.props[size_t(pi)].type, row[size_t(pi)]));
            }
        } else {
            // (An element without properties has rows of nothing: a count of 2^60 is not a loop.)
            for (size_t r = 0; r < el.count && !el.props.empty(); ++r)
                for (const PlyProp& p : el.props) {
                    if (p.isList) {
                        const long long c = in.listCount(p.countType, el.name.c_str(), el.name, r);
                        for (long long k = 0; k < c; ++k) in.read(p.type, el.name.c_str());
                    } else {
                        in.read(p.type, el.name.c_str());
                    }
                }
        }
    }
    if (!haveVertices) throw MeshError(fmt::format("{}: the PLY file has no vertex element", path));
    return m;
}

// ---------------------------------------------------------------------------------------------
// Mitsuba .serialized

namespace {

class ByteReader {
public:
    ByteReader(const std::string& path, const unsigned char* p, size_t n) : path_(path), p_(p), n_(n) {}
    template <class T>
    T get(const char* what) {
        need(sizeof(T), what);
        T v;
        std::memcpy(&v, p_ + pos_, sizeof(T));
        pos_ += sizeof(T);
        if constexpr (std::endian::native == std::endian::big) {
            unsigned char* b = reinterpret_cast<unsigned char*>(&v);
            std::reverse(b, b + sizeof(T));
        }
        return v;
    }
    void need(size_t bytes, const char* what) const {
        if (bytes > n_ - pos_)
            throw MeshError(fmt::format("{}: truncated data while reading {}", path_, what));
    }
    void skip(size_t bytes, const char* what) {
        need(bytes, what);
        pos_ += bytes;
    }
    size_t remaining() const { return n_ - pos_; }

private:
    const std::string& path_;
    const unsigned char* p_;
    size_t n_, pos_ = 0;
};

std::vector<unsigned char> inflateAll(const std::string& path, const unsigned char* src, size_t n) {
    z_stream zs{};
    if (inflateInit(&zs) != Z_OK) throw MeshError(fmt::format("{}: zlib initialisation failed", path));
    std::vector<unsigned char> out;
    zs.next_in = const_cast<Bytef*>(src);
    zs.avail_in = uInt(std::min<size_t>(n, 0x7fffffff));
    int ret = Z_OK;
    while (ret != Z_STREAM_END) {
        if (out.size() > (size_t(1) << 32)) {
            inflateEnd(&zs);
            throw MeshError(fmt::format("{}: the decompressed mesh is larger than 4 GB", path));
        }
        size_t old = out.size();
        out.resize(old + (size_t(1) << 20));
        zs.next_out = out.data() + old;
        zs.avail_out = uInt(out.size() - old);
        ret = inflate(&zs, Z_NO_FLUSH);
        out.resize(out.size() - zs.avail_out);
        if (ret == Z_STREAM_END) break;
        if (ret != Z_OK) {
            std::string msg = zs.msg ? zs.msg : "";
            inflateEnd(&zs);
            throw MeshError(fmt::format("{}: corrupt or truncated compressed mesh data ({})", path,
                                        ret == Z_BUF_ERROR ? std::string("unexpected end of file") : msg));
        }
    }
    inflateEnd(&zs);
    return out;
}

}  // namespace

MeshDesc readSerialized(const std::string& path, int shapeIndex, bool* faceNormals) {
    std::string file = readAll(path);
    const auto* bytes = reinterpret_cast<const unsigned char*>(file.data());
    size_t size = file.size();
    auto u16 = [&](size_t at) { return uint16_t(bytes[at] | (bytes[at + 1] << 8)); };
    auto u32 = [&](size_t at) {
        uint32_t v = 0;
        for (int i = 3; i >= 0; --i) v = (v << 8) | bytes[at + i];
        return v;
    };
    auto u64 = [&](size_t at) {
        uint64_t v = 0;
        for (int i = 7; i >= 0; --i) v = (v << 8) | bytes[at + i];
        return v;
    };
    if (size < 4 || u16(0) != 0x041C)
        throw MeshError(fmt::format("{}: not a Mitsuba serialized mesh (header 0x041C missing)", path));
    uint16_t version = u16(2);
    if (version != 3 && version != 4)
        throw MeshError(fmt::format("{}: unsupported serialized version {} (supported: 3, 4)", path, version));
    if (shapeIndex < 0) throw MeshError(fmt::format("{}: shape_index {} is negative", path, shapeIndex));
    size_t start = 0;
    if (shapeIndex > 0) {
        if (size < 8) throw MeshError(fmt::format("{}: no end-of-file dictionary", path));
        uint32_t count = u32(size - 4);
        if (uint32_t(shapeIndex) >= count)
            throw MeshError(fmt::format("{}: shape_index {} is out of range (the file has {} meshes)", path, shapeIndex, count));
        size_t entry = version == 4 ? 8 : 4;
        if (size_t(count) * entry + 4 > size) throw MeshError(fmt::format("{}: corrupt end-of-file dictionary", path));
        size_t at = size - 4 - entry * (count - shapeIndex);
        start = version == 4 ? size_t(u64(at)) : size_t(u32(at));
        if (start > size - 4 || u16(start) != 0x041C || u16(start + 2) != version)
            throw MeshError(fmt::format("{}: corrupt dictionary entry for shape_index {}", path, shapeIndex));
    }
    std::vector<unsigned char> raw = inflateAll(path, bytes + start + 4, size - start - 4);
    ByteReader rd(path, raw.data(), raw.size());
    uint32_t flags = rd.get<uint32_t>("the flags");
    MeshDesc m;
    m.name = fmt::format("{}@{}", path, shapeIndex);
    if (version == 4) {
        std::string name;
        for (char c; (c = char(rd.get<uint8_t>("the shape name"))) != 0;) name += c;
        if (!name.empty()) m.name = name;
    }
    uint64_t nv = rd.get<uint64_t>("the vertex count"), nf = rd.get<uint64_t>("the triangle count");
    bool dbl = (flags & 0x2000) != 0;
    size_t fs = dbl ? 8 : 4;
    if (nv > 0xFFFFFFFFull) throw MeshError(fmt::format("{}: more than 2^32 vertices is not supported", path));
    // Divided, not multiplied: a declared count near 2^64 must not wrap round to a small size.
    if (nv > rd.remaining() / (3 * fs) || nf > rd.remaining() / 12)
        throw MeshError(fmt::format("{}: truncated data ({} vertices, {} triangles declared)", path, nv, nf));
    auto readF = [&](const char* what) { return dbl ? float(rd.get<double>(what)) : rd.get<float>(what); };
    m.positions.resize(nv);
    for (auto& p : m.positions)
        for (int k = 0; k < 3; ++k) p[k] = readF("vertex positions");
    if (flags & 0x0001) {
        m.normals.resize(nv);
        for (auto& n : m.normals)
            for (int k = 0; k < 3; ++k) n[k] = readF("vertex normals");
    }
    if (flags & 0x0002) {
        m.uvs.resize(nv);
        for (auto& uv : m.uvs)
            for (int k = 0; k < 2; ++k) uv[k] = readF("texture coordinates");
    }
    if (flags & 0x0008) rd.skip(nv * 3 * fs, "vertex colors");
    m.indices.resize(nf * 3);
    for (auto& i : m.indices) i = rd.get<uint32_t>("triangle indices");
    if (faceNormals) *faceNormals = (flags & 0x0010) != 0;
    return m;
}

}  // namespace lt
