// Internal to the scene loader (core/loader.cpp): the XML tree after <include>, <default>, <path>
// and $-substitution, and typed access to the properties of one plugin element, with errors that
// name the file, the line, the element and the parameter.
#pragma once
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
#include "core/loader.h"
#include "core/math.h"

namespace lt::xml {

struct Document;

// One XML file that was read (the scene or an included fragment).
struct Source {
    std::string path;             // as opened
    std::string dir;              // its directory
    bool legacy = false;          // <scene version="0.x">: Mitsuba 0.6 defaults
    const Document* doc = nullptr;  // the document that owns it (files named in properties resolve through it)
    std::vector<size_t> lineStarts;
    int lineOf(ptrdiff_t offset) const;  // 1-based
};

struct Elem {
    std::string tag;  // lower case
    std::vector<std::pair<std::string, std::string>> attrs;  // after $-substitution
    std::vector<std::unique_ptr<Elem>> children;             // includes spliced in
    const Source* src = nullptr;
    int line = 0;

    const std::string* attr(std::string_view name) const;
    std::string type() const;      // value of type="..." (lower case) or ""
    std::string where() const;     // "file:line"
    std::string describe() const;  // <bsdf type="diffuse" id="x">
};

// "file:line: <elem ...>: msg" / "file:line: <elem ...> parameter 'p': msg".
[[noreturn]] void fail(const Elem& e, const std::string& msg);
[[noreturn]] void failParam(const Elem& owner, const Elem* at, const std::string& param, const std::string& msg);

struct Document {
    std::vector<std::unique_ptr<Source>> sources;
    std::unique_ptr<Elem> root;
    std::map<std::string, const Elem*> ids;  // every id="..." at any depth
    std::vector<std::string> searchDirs;     // from <path value>
    std::string mainDir;
    std::vector<std::string> warnings;

    Document() = default;
    // Moves every member and points the sources' `doc` at the new owner (a member added above
    // must be added to the move too).
    Document(Document&& o) noexcept;
    Document& operator=(Document&& o) noexcept;
    Document(const Document&) = delete;
    Document& operator=(const Document&) = delete;
};

// Reads the file and its includes; applies <default> (overridden by `defines`) and $name.
Document parseDocument(const std::string& path, const std::map<std::string, std::string>& defines);

// Finds a file named by the scene: relative to the referring file's directory, the main scene
// directory, then the <path> directories. Returns "" when not found; `tried` lists the candidates.
std::string resolveFile(const Document& doc, const Elem& from, const std::string& name, std::string& tried);

std::string toSnake(std::string_view s);  // camelCase (Mitsuba 0.6) -> snake_case
std::string lower(std::string_view s);
std::string joinList(const std::vector<std::string>& v);  // "a, b, c"

// Parses a list of numbers separated by commas and/or white space. nullopt if malformed.
std::optional<std::vector<double>> parseNumbers(std::string_view s);

// Parses the <transform> element: translate, rotate, scale, matrix, lookat in document order,
// each new one left-multiplied.
Mat4 parseTransform(const Elem& owner, const Elem& t, const std::string& param);

// Typed access to the properties of one plugin element (<float>, <integer>, <boolean>, <string>,
// <rgb>, <srgb>, <spectrum>, <blackbody>, <point>, <vector>, <transform>). Parameter names are
// normalised to snake_case. Every name asked for (get*/has) counts as supported; finish() throws
// for the rest.
class Props {
public:
    explicit Props(const Elem& owner);

    bool has(const std::string& name);
    float getFloat(const std::string& name, float def);
    int getInt(const std::string& name, int def);
    bool getBool(const std::string& name, bool def);
    std::string getString(const std::string& name, const std::string& def);
    // <rgb>, <srgb>, <float>, <spectrum value|filename> and <blackbody> (Mitsuba 0.6's tag:
    // temperature in kelvin, optional "K" suffix, and scale) as linear sRGB, spectra converted as
    // Mitsuba 3's RGB variants do (core/spectrum.h): as emission when the owner is an <emitter>,
    // unbounded for eta, k, int_ior, ext_ior, sigma_t, as a reflectance otherwise. A spectrum
    // file is found as the scene's other files (resolveFile).
    Color getColor(const std::string& name, const Color& def);
    Vec3 getPoint(const std::string& name, const Vec3& def);  // <point>/<vector>
    Mat4 getTransform(const std::string& name, const Mat4& def = Mat4(1.f));
    // True if the parameter is given as <string> (e.g. int_ior="bk7" rather than a number).
    bool isString(const std::string& name);

    // Checks; they throw naming the parameter.
    void requireNonNegative(const std::string& name, float v);
    void requireNonNegative(const std::string& name, const Color& c);
    void requirePositive(const std::string& name, float v);
    [[noreturn]] void failAt(const std::string& name, const std::string& msg) const;

    // Accepts and ignores the listed parameters (warning in `warnings` if non-null and present).
    void ignore(const std::vector<std::string>& names, std::vector<std::string>* warnings = nullptr);
    // Throws for any parameter not asked for, listing the supported ones.
    void finish();

    // Child plugin elements (bsdf, emitter, ref, sampler, film, rfilter, ...), in document order.
    std::vector<const Elem*> objects;
    const Elem& owner;

private:
    const Elem* find(const std::string& name);
    std::map<std::string, const Elem*> params_;
    std::vector<std::string> asked_;
};

}  // namespace lt::xml
