// Named indices of refraction (dielectrics) and conductor presets (complex IOR as RGB).
#pragma once
#include <optional>
#include <string>
#include <vector>
#include "core/math.h"

namespace lt {

// vacuum, air, water, bk7, fused quartz, acrylic glass, diamond, amber, ... (Mitsuba names).
std::optional<float> namedIor(const std::string& name);
std::vector<std::string> namedIorList();

struct ConductorIor {
    Color eta, k;
};
// "none" (a perfect mirror: eta = 0, k = 1 convention of Mitsuba -> reflectance 1), Au, Ag, Cu, Al, ...
std::optional<ConductorIor> conductorPreset(const std::string& name);
std::vector<std::string> conductorPresetList();

}  // namespace lt
