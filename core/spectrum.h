// Spectra in an RGB renderer: sampled spectra (Mitsuba's <spectrum value="400:0.1, 500:0.5"> and
// .spd files) and Planck's blackbody, converted to linear sRGB (Rec. 709 primaries, D65 white) the
// way Mitsuba 3's RGB variants do it (src/core/spectrum.cpp spectrum_list_to_srgb,
// src/core/properties.cpp Properties::get_texture_impl):
//  - the piecewise-linear spectrum, zero outside its first and last wavelength, is integrated
//    against the CIE 1931 2-degree matching functions (360-830 nm, 5 nm table, linear
//    interpolation) by Mitsuba's 1000-point rule, normalised so that a constant 1 has Y = 1;
//  - a reflectance (and an unbounded quantity such as a conductor's eta, k) is weighted by the
//    CIE D65 illuminant first, so that a flat spectrum maps to the sRGB white; emission is not;
//  - XYZ -> linear sRGB with Mitsuba's xyz_to_srgb matrix, then a reflectance is clamped to
//    [0, 1], anything else to >= 0.
#pragma once
#include <optional>
#include <string>
#include <string_view>
#include <vector>
#include "core/math.h"

namespace lt {

// What a spectrum describes decides its conversion (see above).
enum class SpectrumKind {
    Reflectance,  // D65-weighted, clamped to [0, 1]
    Unbounded,    // D65-weighted, clamped to >= 0 (Mitsuba: eta, k, int_ior, ext_ior, sigma_t)
    Emission,     // not weighted, clamped to >= 0 (a colour given directly inside an <emitter>)
};

// The domain of the CIE tables, nm.
inline constexpr double kCieMinNm = 360.0, kCieMaxNm = 830.0;

struct SampledSpectrum {
    std::vector<double> wavelengths;  // nm
    std::vector<double> values;
    std::vector<int> lines;           // line of each sample in its file (empty for inline values)
};

// "400:0.1, 500:0.5 600:0.9" (pairs separated by commas and/or white space). nullopt and `error`
// set when a token is not a wavelength:value pair of numbers.
std::optional<SampledSpectrum> parseSpectrumPairs(std::string_view text, std::string& error);

// Mitsuba's .spd text: one "wavelength value" pair per line (white space or a comma between),
// '#' starts a comment to the end of the line, blank lines are skipped. `error` names the line.
std::optional<SampledSpectrum> parseSpectrumFileText(std::string_view text, std::string& error);
std::optional<SampledSpectrum> readSpectrumFile(const std::string& path, std::string& error);

// "" when the spectrum is usable, else why not: fewer than two samples, a wavelength not finite,
// not > 0 or not increasing (Mitsuba 3: strictly increasing), a value NaN, infinite or negative,
// or no overlap with 360-830 nm (it would be black: usually micrometres instead of nanometres).
std::string checkSpectrum(const SampledSpectrum& s);

// CIE XYZ of the spectrum (Y = 1 for a constant 1, and for a constant-1 reflectance under the
// normalised D65 when `d65`), Mitsuba's integration rule.
DVec3 spectrumToXyz(const SampledSpectrum& s, bool d65);
// Mitsuba's xyz_to_srgb (linear Rec. 709), unclamped.
DVec3 xyzToLinearSrgb(const DVec3& xyz);
// The full conversion, clamped as the kind asks. `s` must pass checkSpectrum.
Color spectrumToLinearSrgb(const SampledSpectrum& s, SpectrumKind kind);
// A uniform <spectrum value="v">: v as grey, except emission, which Mitsuba 3's RGB variants turn
// into v * xyz_to_srgb(1, 1, 1) (an equal-energy spectrum is pinkish in sRGB; the value a flat
// sampled emission spectrum gets, so both spellings agree).
Color uniformSpectrumToLinearSrgb(double v, SpectrumKind kind);

// Planck's law: spectral radiance of a black body, W m^-2 sr^-1 nm^-1 (Mitsuba's blackbody
// plugin's units and constants, src/spectra/blackbody.cpp).
double planckRadiance(double wavelengthNm, double kelvin);
// Planck's spectrum converted as emission (no D65, clamped to >= 0), in absolute units: 6500 K
// gives about 4.2e4 in Y. kelvin must be > 0.
Color blackbodyToLinearSrgb(double kelvin);

}  // namespace lt
