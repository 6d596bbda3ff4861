// Named IORs (the table of Mitsuba's documentation) and RGB conductor presets. The conductor
// values are measured spectral complex IORs (eta, k) reduced to linear RGB, the same numbers
// Mitsuba uses in its RGB variants (e.g. Cu eta = (0.200438, 0.924033, 1.10221)).
#include "bsdf/ior.h"

#include <algorithm>
#include <cctype>

namespace lt {

namespace {

struct NamedIor {
    const char* name;
    float ior;
};

constexpr NamedIor kIors[] = {
    {"vacuum", 1.0f},
    {"helium", 1.000036f},
    {"hydrogen", 1.000132f},
    {"air", 1.000277f},
    {"carbon dioxide", 1.00045f},
    {"water", 1.3330f},
    {"acetone", 1.36f},
    {"ethanol", 1.361f},
    {"carbon tetrachloride", 1.461f},
    {"glycerol", 1.4729f},
    {"benzene", 1.501f},
    {"silicone oil", 1.52045f},
    {"bromine", 1.661f},
    {"water ice", 1.31f},
    {"fused quartz", 1.458f},
    {"pyrex", 1.470f},
    {"acrylic glass", 1.49f},
    {"polypropylene", 1.49f},
    {"bk7", 1.5046f},
    {"sodium chloride", 1.544f},
    {"amber", 1.55f},
    {"pet", 1.5750f},
    {"diamond", 2.419f},
};

struct NamedConductor {
    const char* name;
    ConductorIor ior;
};

const NamedConductor kConductors[] = {
    // Mitsuba's "none": eta = 0, k = 1 gives a Fresnel reflectance of exactly 1.
    {"none", {Color(0.f), Color(1.f)}},
    {"a-C", {Color(2.94410f, 2.22715f, 1.96817f), Color(0.887433f, 0.799322f, 0.815286f)}},
    {"Ag", {Color(0.155265f, 0.116723f, 0.138381f), Color(4.82834f, 3.12225f, 2.14695f)}},
    {"Al", {Color(1.65746f, 0.880369f, 0.521229f), Color(9.22387f, 6.26952f, 4.83700f)}},
    {"Au", {Color(0.143119f, 0.374957f, 1.44248f), Color(3.98316f, 2.38572f, 1.60322f)}},
    {"Be", {Color(4.18506f, 3.18506f, 2.78409f), Color(3.83544f, 3.01013f, 2.86901f)}},
    {"Cr", {Color(4.36968f, 2.91670f, 1.65470f), Color(5.20643f, 4.23136f, 3.75495f)}},
    {"Cu", {Color(0.200438f, 0.924033f, 1.10221f), Color(3.91295f, 2.45285f, 2.14219f)}},
    {"Hg", {Color(2.39893f, 1.44003f, 0.909551f), Color(6.32763f, 4.37194f, 3.42179f)}},
    {"Ir", {Color(3.08641f, 2.08219f, 1.61789f), Color(5.59215f, 4.06718f, 3.26726f)}},
    {"K", {Color(0.0640493f, 0.0464101f, 0.0381842f), Color(2.10422f, 1.34894f, 0.913211f)}},
    {"Li", {Color(0.265787f, 0.195610f, 0.220920f), Color(3.54017f, 2.31113f, 1.66859f)}},
    {"Mo", {Color(4.48370f, 3.52546f, 2.77608f), Color(4.11113f, 3.42087f, 3.15060f)}},
    {"Rh", {Color(2.58580f, 1.86019f, 1.55443f), Color(6.78229f, 4.70295f, 3.97609f)}},
    {"TiN", {Color(1.64847f, 1.15045f, 1.37978f), Color(3.36846f, 1.94349f, 1.10201f)}},
    {"W", {Color(4.37070f, 3.30030f, 2.99827f), Color(3.50068f, 2.60487f, 2.27319f)}},
};

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return s;
}

}  // namespace

std::optional<float> namedIor(const std::string& name) {
    const std::string n = lower(name);
    for (const auto& e : kIors)
        if (n == e.name) return e.ior;
    return std::nullopt;
}

std::vector<std::string> namedIorList() {
    std::vector<std::string> r;
    for (const auto& e : kIors) r.emplace_back(e.name);
    return r;
}

// Conductor names are matched case-insensitively ("Cu", "cu").
std::optional<ConductorIor> conductorPreset(const std::string& name) {
    const std::string n = lower(name);
    for (const auto& e : kConductors)
        if (n == lower(e.name)) return e.ior;
    return std::nullopt;
}

std::vector<std::string> conductorPresetList() {
    std::vector<std::string> r;
    for (const auto& e : kConductors) r.emplace_back(e.name);
    return r;
}

}  // namespace lt
