// The one parser of a number given as text by the tools (options, configurations, sweeps).
#pragma once
#include <cmath>
#include <stdexcept>
#include <string>

namespace lt {

// The whole of s as a finite number in v; false for anything else (empty, trailing characters,
// NaN, Inf, out of range).
inline bool parseFiniteNumber(const std::string& s, double& v) {
    size_t used = 0;
    try {
        v = std::stod(s, &used);
    } catch (const std::exception&) {
        return false;
    }
    return !s.empty() && used == s.size() && std::isfinite(v);
}

}  // namespace lt
