// Spectra to linear sRGB as Mitsuba 3's RGB variants do. See spectrum.h.
#include "core/spectrum.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace lt {

namespace {

constexpr int kCieSamples = 95;
#include "core/cie_tables.inc"

// Mitsuba 3's normalisations (include/mitsuba/core/spectrum.h MI_CIE_Y_NORMALIZATION,
// MI_CIE_D65_NORMALIZATION): the first makes a constant 1 integrate to Y = 1 under the rule below.
constexpr double kYNormalization = 1.0 / 106.7502593994140625;
constexpr double kD65Normalization = 1.0 / 98.99741751876255;
// spectrum_list_to_srgb's rule: 1000 samples from 360 to 830 nm inclusive, each weighted 470/1000 nm.
constexpr int kSteps = 1000;

struct CieSample {
    DVec3 xyz;
    double d65;  // normalised
};

// Linear interpolation in the 5 nm tables (Mitsuba's cie1931_xyz and cie_d65), w in [360, 830].
CieSample cieAt(double w) {
    const double t = (w - kCieMinNm) * ((kCieSamples - 1) / (kCieMaxNm - kCieMinNm));
    const int i0 = std::clamp(int(t), 0, kCieSamples - 2);
    const double f = t - i0;
    auto lerp = [&](int c) { return (1.0 - f) * kCieTable[i0][c] + f * kCieTable[i0 + 1][c]; };
    return {DVec3(lerp(1), lerp(2), lerp(3)), lerp(4) * kD65Normalization};
}

// XYZ of value(w) over [lo, hi] (zero elsewhere), optionally weighted by D65.
template <class F>
DVec3 integrateXyz(double lo, double hi, bool d65, F&& value) {
    DVec3 xyz(0.0);
    for (int i = 0; i < kSteps; ++i) {
        const double w = kCieMinNm + (i / double(kSteps - 1)) * (kCieMaxNm - kCieMinNm);
        if (w < lo || w > hi) continue;
        const CieSample c = cieAt(w);
        xyz += c.xyz * (value(w) * (d65 ? c.d65 : 1.0));
    }
    return xyz * ((kCieMaxNm - kCieMinNm) * kYNormalization / kSteps);
}

Color clampFor(const DVec3& rgb, SpectrumKind kind) {
    const double hi = kind == SpectrumKind::Reflectance ? 1.0 : HUGE_VAL;
    return Color(float(std::clamp(rgb.x, 0.0, hi)), float(std::clamp(rgb.y, 0.0, hi)), float(std::clamp(rgb.z, 0.0, hi)));
}

// The whole string as one number (strtod syntax: "nan" and "inf" parse and checkSpectrum refuses them).
bool parseNumber(const std::string& s, double& out) {
    if (s.empty()) return false;
    char* end = nullptr;
    errno = 0;
    out = std::strtod(s.c_str(), &end);
    return end == s.c_str() + s.size();
}

std::vector<std::string> splitTokens(std::string_view text) {
    std::vector<std::string> out;
    std::string cur;
    for (char c : text) {
        if (c == ',' || std::isspace((unsigned char)c)) {
            if (!cur.empty()) out.push_back(std::move(cur));
            cur.clear();
        } else {
            cur += c;
        }
    }
    if (!cur.empty()) out.push_back(std::move(cur));
    return out;
}

std::string excerpt(std::string_view s) {
    return s.size() <= 60 ? std::string(s) : std::string(s.substr(0, 57)) + "...";
}

}  // namespace

std::optional<SampledSpectrum> parseSpectrumPairs(std::string_view text, std::string& error) {
    SampledSpectrum s;
    for (const std::string& tok : splitTokens(text)) {
        const size_t colon = tok.find(':');
        double w = 0.0, v = 0.0;
        if (colon == std::string::npos || tok.find(':', colon + 1) != std::string::npos ||
            !parseNumber(tok.substr(0, colon), w) || !parseNumber(tok.substr(colon + 1), v)) {
            error = fmt::format("'{}' is not a wavelength:value pair of numbers", excerpt(tok));
            return std::nullopt;
        }
        s.wavelengths.push_back(w);
        s.values.push_back(v);
    }
    return s;
}

std::optional<SampledSpectrum> parseSpectrumFileText(std::string_view text, std::string& error) {
    SampledSpectrum s;
    int lineNo = 0;
    size_t pos = 0;
    while (pos < text.size()) {
        size_t eol = text.find('\n', pos);
        if (eol == std::string_view::npos) eol = text.size();
        std::string_view line = text.substr(pos, eol - pos);
        pos = eol + 1;
        ++lineNo;
        if (size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
        const std::vector<std::string> tok = splitTokens(line);
        if (tok.empty()) continue;
        double w = 0.0, v = 0.0;
        if (tok.size() != 2 || !parseNumber(tok[0], w) || !parseNumber(tok[1], v)) {
            error = fmt::format("line {}: expected two numbers 'wavelength value', got '{}'", lineNo, excerpt(line));
            return std::nullopt;
        }
        s.wavelengths.push_back(w);
        s.values.push_back(v);
        s.lines.push_back(lineNo);
    }
    return s;
}

std::optional<SampledSpectrum> readSpectrumFile(const std::string& path, std::string& error) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream ss;
    if (in) ss << in.rdbuf();
    if (!in || in.bad()) {
        error = "the file cannot be read";
        return std::nullopt;
    }
    return parseSpectrumFileText(ss.str(), error);
}

std::string checkSpectrum(const SampledSpectrum& s) {
    const size_t n = s.wavelengths.size();
    if (n != s.values.size()) return "as many wavelengths as values are needed";
    if (n < 2) return fmt::format("at least two wavelength:value samples are needed (got {})", n);
    auto at = [&](size_t i) {
        return s.lines.empty() ? fmt::format("sample {} ({} nm)", i + 1, s.wavelengths[i])
                               : fmt::format("line {} ({} nm)", s.lines[i], s.wavelengths[i]);
    };
    for (size_t i = 0; i < n; ++i) {
        const double w = s.wavelengths[i], v = s.values[i];
        if (!std::isfinite(w) || !(w > 0.0))
            return fmt::format("{}: the wavelength must be a finite number of nanometres > 0", at(i));
        if (i > 0 && !(w > s.wavelengths[i - 1]))
            return fmt::format("{}: wavelengths must increase (it follows {} nm)", at(i), s.wavelengths[i - 1]);
        if (!std::isfinite(v)) return fmt::format("{}: the value {} is not finite", at(i), v);
        if (v < 0.0) return fmt::format("{}: the value {} is negative", at(i), v);
    }
    if (s.wavelengths.back() < kCieMinNm || s.wavelengths.front() > kCieMaxNm)
        return fmt::format("the wavelengths ({} to {}) miss the visible range 360-830 nm of the CIE matching "
                           "functions, so the colour would be black (wavelengths are in nanometres)",
                           s.wavelengths.front(), s.wavelengths.back());
    return "";
}

DVec3 spectrumToXyz(const SampledSpectrum& s, bool d65) {
    const std::vector<double>& wl = s.wavelengths;
    const std::vector<double>& val = s.values;
    return integrateXyz(wl.front(), wl.back(), d65, [&](double w) {
        // The interval [wl[i], wl[i+1]] holding w (Mitsuba's math::find_interval).
        const size_t i = std::min(size_t(std::upper_bound(wl.begin(), wl.end(), w) - wl.begin()), wl.size() - 1) - 1;
        const double t = (w - wl[i]) / (wl[i + 1] - wl[i]);
        return (1.0 - t) * val[i] + t * val[i + 1];
    });
}

DVec3 xyzToLinearSrgb(const DVec3& xyz) {
    return DVec3(3.240479 * xyz.x - 1.537150 * xyz.y - 0.498535 * xyz.z,
                 -0.969256 * xyz.x + 1.875991 * xyz.y + 0.041556 * xyz.z,
                 0.055648 * xyz.x - 0.204043 * xyz.y + 1.057311 * xyz.z);
}

Color spectrumToLinearSrgb(const SampledSpectrum& s, SpectrumKind kind) {
    return clampFor(xyzToLinearSrgb(spectrumToXyz(s, kind != SpectrumKind::Emission)), kind);
}

Color uniformSpectrumToLinearSrgb(double v, SpectrumKind kind) {
    if (kind != SpectrumKind::Emission) return Color(float(v));
    return Color(xyzToLinearSrgb(DVec3(1.0)) * v);
}

double planckRadiance(double wavelengthNm, double kelvin) {
    // CODATA 2014 values, as Mitsuba's blackbody plugin.
    constexpr double c = 2.99792458e+8, h = 6.62607004e-34, k = 1.38064852e-23;
    const double lambda = wavelengthNm * 1e-9;  // m
    const double perMetre = 2.0 * h * c * c / (std::pow(lambda, 5.0) * std::expm1(h * c / (k * lambda * kelvin)));
    return perMetre * 1e-9;  // per nm
}

Color blackbodyToLinearSrgb(double kelvin) {
    const DVec3 xyz = integrateXyz(kCieMinNm, kCieMaxNm, false, [&](double w) { return planckRadiance(w, kelvin); });
    return clampFor(xyzToLinearSrgb(xyz), SpectrumKind::Emission);
}

}  // namespace lt
