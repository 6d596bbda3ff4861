// Spectra to linear sRGB (core/spectrum.h, Mitsuba 3's spectrum_list_to_srgb and the RGB
// variants' rules): flat spectra, narrow lines against integrals computed here from CIE values
// typed in by hand, the blackbody against the Planckian locus of Kim et al. 2002, the .spd
// reader, and the loader: <spectrum value>, <spectrum filename>, <blackbody> and their errors
// (file, line, parameter).
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>

#include "bsdf/bsdf.h"
#include "core/loader.h"
#include "core/spectrum.h"
#include "process.h"

using namespace lt;
namespace fs = std::filesystem;

namespace {

namespace cie {
constexpr int kCieSamples = 95;
#include "core/cie_tables.inc"
}  // namespace cie

// The exact integral of ybar over 360-830 nm (trapezoids on the 5 nm table, which is linear
// between its samples): the normalisation of the independent integrals below.
double ybarIntegral() {
    double sum = 0.0;
    for (int i = 0; i + 1 < cie::kCieSamples; ++i) sum += 2.5 * (cie::kCieTable[i][2] + cie::kCieTable[i + 1][2]);
    return sum;
}

// Midpoint rule with 0.01 nm steps of f over [lo, hi]: converged far below the tolerances used.
DVec3 integrate(double lo, double hi, const std::function<DVec3(double)>& f) {
    const int n = int(std::lround((hi - lo) / 0.01));
    DVec3 s(0.0);
    for (int i = 0; i < n; ++i) s += f(lo + (i + 0.5) * (hi - lo) / n);
    return s * ((hi - lo) / n);
}

// Piecewise-linear through (w0 + 5 i, v[i]).
double lerp5(double w0, const std::vector<double>& v, double w) {
    const double t = (w - w0) / 5.0;
    const int i = std::clamp(int(t), 0, int(v.size()) - 2);
    return v[i] + (t - i) * (v[i + 1] - v[i]);
}

DVec3 toSrgb(const DVec3& xyz) {  // Rec. 709 / sRGB primaries, D65 white (as Mitsuba's xyz_to_srgb)
    return DVec3(3.240479 * xyz.x - 1.537150 * xyz.y - 0.498535 * xyz.z,
                 -0.969256 * xyz.x + 1.875991 * xyz.y + 0.041556 * xyz.z,
                 0.055648 * xyz.x - 0.204043 * xyz.y + 1.057311 * xyz.z);
}
DVec3 toXyz(const Color& c) {  // its inverse (Mitsuba's srgb_to_xyz)
    return DVec3(0.412453 * c.x + 0.357580 * c.y + 0.180423 * c.z, 0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z,
                 0.019334 * c.x + 0.119193 * c.y + 0.950227 * c.z);
}

void checkNear(const Color& got, const DVec3& want, double tol) {
    INFO("got " << got.x << " " << got.y << " " << got.z << ", want " << want.x << " " << want.y << " " << want.z);
    for (int i = 0; i < 3; ++i) CHECK(std::abs(got[i] - want[i]) <= tol);
}

SampledSpectrum spectrum(std::vector<double> wl, std::vector<double> v) { return {std::move(wl), std::move(v), {}}; }

// Kim et al. 2002's cubic fit of the Planckian locus (CIE 1931 xy), 1667-25000 K.
std::pair<double, double> planckianLocus(double t) {
    const double x = t <= 4000 ? -0.2661239e9 / (t * t * t) - 0.2343589e6 / (t * t) + 0.8776956e3 / t + 0.179910
                               : -3.0258469e9 / (t * t * t) + 2.1070379e6 / (t * t) + 0.2226347e3 / t + 0.240390;
    const double y = t <= 2222   ? -1.1063814 * x * x * x - 1.34811020 * x * x + 2.18555832 * x - 0.20219683
                     : t <= 4000 ? -0.9549476 * x * x * x - 1.37418593 * x * x + 2.09137015 * x - 0.16748867
                                 : 3.0817580 * x * x * x - 5.87338670 * x * x + 3.75112997 * x - 0.37001483;
    return {x, y};
}

fs::path tempDir() {
    static lt::test::TempDir t("lt_test_spectrum");
    return t.dir;
}

std::string write(const std::string& name, const std::string& text) {
    fs::path p = tempDir() / name;
    fs::create_directories(p.parent_path());
    std::ofstream(p) << text;
    return p.string();
}

// A scene file with `body` from line 2 on.
std::string sceneFile(const std::string& body, const std::string& name = "spectrum.xml") {
    return write(name, "<scene version=\"3.0.0\">\n" + body + "\n</scene>\n");
}

std::string errorOf(const std::string& body) {
    try {
        loadScene(sceneFile(body, "bad.xml"));
    } catch (const SceneError& e) {
        return e.what();
    }
    return "";
}

Color diffuseAlbedo(const BxdfPtr& b) {  // f * pi at normal incidence both ways
    return b->eval(Vec3(0, 0, 1), Vec3(0, 0, 1), TransportMode::Radiance).f * kPi;
}

}  // namespace

TEST_CASE("spectrum: a flat reflectance is grey and flat emission is Mitsuba's pinkish white", "[spectrum]") {
    // D65-weighted flat 0.5: Y is 0.5 up to Mitsuba's D65 normalisation constant, 0.11% above the
    // 5 nm table's own integral; the table's D65 white and the matrix's white agree to 1e-4.
    const Color grey = spectrumToLinearSrgb(spectrum({360, 830}, {0.5, 0.5}), SpectrumKind::Reflectance);
    for (int i = 0; i < 3; ++i) CHECK((grey[i] > 0.4990f && grey[i] <= 0.5f));
    CHECK(std::abs(grey.x - grey.y) < 1e-4f);
    CHECK(std::abs(grey.z - grey.y) < 1e-4f);
    // The rule's Y constant is its own sum of ybar: a flat 1 has Y = 1.
    CHECK(spectrumToXyz(spectrum({360, 830}, {1, 1}), false).y == Approx(1.0).epsilon(1e-5));
    // Flat emission is equal-energy white, not D65: the uniform value's xyz_to_srgb(1, 1, 1).
    const Color e = spectrumToLinearSrgb(spectrum({360, 830}, {2, 2}), SpectrumKind::Emission);
    const Color u = uniformSpectrumToLinearSrgb(2.0, SpectrumKind::Emission);
    checkNear(u, DVec3(2 * 1.204794, 2 * 0.948291, 2 * 0.908916), 1e-5);
    checkNear(e, DVec3(u), 2e-3);
    CHECK(uniformSpectrumToLinearSrgb(0.3, SpectrumKind::Reflectance) == Color(0.3f));
    // Zero outside the given range (not extended): 400-700 nm only loses the tails' luminance.
    const double part = spectrumToXyz(spectrum({400, 700}, {0.5, 0.5}), true).y;
    const double full = spectrumToXyz(spectrum({360, 830}, {0.5, 0.5}), true).y;
    CHECK(part < full);
    CHECK(part > 0.99 * full);
}

TEST_CASE("spectrum: narrow lines match integrals of hand-typed CIE values", "[spectrum]") {
    const double norm = 1.0 / ybarIntegral();
    CHECK(ybarIntegral() == Approx(106.857).epsilon(1e-5));
    SECTION("an emission line at 600 nm: orange with blue clamped to 0") {
        // CIE 1931 xbar, ybar, zbar at 590, 595, 600, 605, 610 nm.
        const std::vector<double> xb{1.0263, 1.0567, 1.0622, 1.0456, 1.0026}, yb{0.757, 0.6949, 0.631, 0.5668, 0.503},
            zb{0.0011, 0.001, 0.0008, 0.0006, 0.00034};
        const DVec3 xyz = integrate(590, 610, [&](double w) {
            const double tri = 1.0 - std::abs(w - 600) / 10.0;
            return DVec3(lerp5(590, xb, w), lerp5(590, yb, w), lerp5(590, zb, w)) * (tri * norm);
        });
        const SampledSpectrum s = spectrum({590, 600, 610}, {0, 1, 0});
        const DVec3 got = spectrumToXyz(s, false);
        for (int i = 0; i < 3; ++i) CHECK(got[i] == Approx(xyz[i]).epsilon(1e-3));
        DVec3 rgb = toSrgb(xyz);
        REQUIRE(rgb.z < 0.0);
        rgb.z = 0.0;
        const Color c = spectrumToLinearSrgb(s, SpectrumKind::Emission);
        checkNear(c, rgb, 1e-3 * rgb.x);
        CHECK(c.z == 0.f);
    }
    SECTION("a reflectance line at 450 nm: weighted by D65 with green clamped to 0") {
        const std::vector<double> xb{0.34828, 0.34806, 0.3362, 0.3187, 0.2908}, yb{0.023, 0.0298, 0.038, 0.048, 0.06},
            zb{1.74706, 1.7826, 1.77211, 1.7441, 1.6692}, d65{104.865, 110.936, 117.008, 117.41, 117.812};
        const double d65Norm = 1.0 / 98.99741751876255;  // Mitsuba's MI_CIE_D65_NORMALIZATION
        const DVec3 xyz = integrate(440, 460, [&](double w) {
            const double tri = 1.0 - std::abs(w - 450) / 10.0;
            return DVec3(lerp5(440, xb, w), lerp5(440, yb, w), lerp5(440, zb, w)) *
                   (tri * lerp5(440, d65, w) * d65Norm * norm);
        });
        const SampledSpectrum s = spectrum({440, 450, 460}, {0, 1, 0});
        const DVec3 got = spectrumToXyz(s, true);
        for (int i = 0; i < 3; ++i) CHECK(got[i] == Approx(xyz[i]).epsilon(1e-3));
        DVec3 rgb = toSrgb(xyz);
        REQUIRE(rgb.y < 0.0);
        rgb.y = 0.0;
        const Color c = spectrumToLinearSrgb(s, SpectrumKind::Reflectance);
        checkNear(c, rgb, 1e-3 * rgb.z);
        CHECK(c.y == 0.f);
    }
    SECTION("a reflectance is clamped to 1 and an unbounded spectrum is not") {
        const SampledSpectrum s = spectrum({360, 830}, {3, 3});
        CHECK(spectrumToLinearSrgb(s, SpectrumKind::Reflectance) == Color(1.f));
        const Color u = spectrumToLinearSrgb(s, SpectrumKind::Unbounded);
        for (int i = 0; i < 3; ++i) CHECK(u[i] == Approx(3 * 0.9989).epsilon(1e-3));
    }
}

TEST_CASE("spectrum: the blackbody follows the Planckian locus in absolute units", "[spectrum]") {
    for (double t : {3000.0, 6500.0, 10000.0}) {
        INFO("T = " << t);
        const Color c = blackbodyToLinearSrgb(t);
        REQUIRE(c.z > 0.f);  // nothing clamped: the inverse matrix gives back XYZ
        const DVec3 xyz = toXyz(c);
        const auto [x, y] = planckianLocus(t);
        CHECK(xyz.x / (xyz.x + xyz.y + xyz.z) == Approx(x).margin(1e-3));
        CHECK(xyz.y / (xyz.x + xyz.y + xyz.z) == Approx(y).margin(1e-3));
        // Y in W m^-2 sr^-1 (per unit of the normalised ybar): Planck's law integrated here.
        const double norm = 1.0 / ybarIntegral();
        const DVec3 ref = integrate(360, 830, [&](double w) {
            const double h = 6.62607004e-34, cl = 2.99792458e8, k = 1.38064852e-23, l = w * 1e-9;
            const double planck = 2 * h * cl * cl / (std::pow(l, 5) * (std::exp(h * cl / (l * k * t)) - 1)) * 1e-9;
            const int i = std::clamp(int((w - 360) / 5), 0, cie::kCieSamples - 2);
            const double f = (w - 360) / 5 - i;
            return DVec3(0, (1 - f) * cie::kCieTable[i][2] + f * cie::kCieTable[i + 1][2], 0) * (planck * norm);
        });
        CHECK(xyz.y == Approx(ref.y).epsilon(2e-3));
    }
    // 6500 K is close to D65: after dividing by Y, every channel within 5% of 1.
    const Color c = blackbodyToLinearSrgb(6500.0);
    const double y = toXyz(c).y;
    CHECK(y == Approx(4.21e4).epsilon(0.01));
    for (int i = 0; i < 3; ++i) CHECK(std::abs(c[i] / y - 1.0) < 0.05);
    // Cold bodies are red and their blue clamps to 0; a very cold one is black, not NaN.
    const Color cold = blackbodyToLinearSrgb(1000.0);
    CHECK(cold.x > 0.f);
    CHECK(cold.z == 0.f);
    CHECK(blackbodyToLinearSrgb(1.0) == Color(0.f));
}

TEST_CASE("spectrum: spd text parsing and checks name the line", "[spectrum]") {
    std::string err;
    auto s = parseSpectrumFileText("# measured\r\n400 0.1\r\n\n  500\t0.5 # peak\n600, 0.25\n", err);
    REQUIRE(s);
    CHECK(s->wavelengths == std::vector<double>{400, 500, 600});
    CHECK(s->values == std::vector<double>{0.1, 0.5, 0.25});
    CHECK(s->lines == std::vector<int>{2, 4, 5});
    CHECK(checkSpectrum(*s).empty());
    CHECK_FALSE(parseSpectrumFileText("400 0.1\n500 0.2 0.3\n", err));
    CHECK(err.find("line 2") != std::string::npos);
    CHECK_FALSE(parseSpectrumFileText("400 0.1\n500 abc\n", err));
    CHECK(err.find("line 2") != std::string::npos);
    CHECK(checkSpectrum(*parseSpectrumFileText("400 0.1\n\n500 0.2\n450 0.3\n", err)).find("line 4") != std::string::npos);
    CHECK(checkSpectrum(*parseSpectrumFileText("400 0.1\n500 -0.2\n", err)).find("negative") != std::string::npos);
    CHECK(checkSpectrum(*parseSpectrumFileText("400 nan\n500 0.2\n", err)).find("not finite") != std::string::npos);
    CHECK(checkSpectrum(*parseSpectrumFileText("400 0.1\n", err)).find("at least two") != std::string::npos);
    CHECK(checkSpectrum(*parseSpectrumFileText("0.4 0.1\n0.7 0.1\n", err)).find("nanometres") != std::string::npos);
    auto p = parseSpectrumPairs("400:0.1, 500:0.5 600:0.9", err);
    REQUIRE(p);
    CHECK(p->values == std::vector<double>{0.1, 0.5, 0.9});
    CHECK_FALSE(parseSpectrumPairs("400:0.1, 500", err));
    CHECK(err.find("'500'") != std::string::npos);
    CHECK(checkSpectrum(*parseSpectrumPairs("500:0.1, 500:0.2", err)).find("increase") != std::string::npos);
    CHECK_FALSE(readSpectrumFile((tempDir() / "nothing.spd").string(), err));
}

TEST_CASE("spectrum: the loader converts spectral reflectances files and blackbodies", "[spectrum][loader]") {
    write("spectra/flat.spd", "# flat 0.5\n360 0.5\n830 0.5\n");
    write("spectra/eta.spd", "400 2.0\n700 2.0\n");
    const std::string path = sceneFile(R"(    <shape type="rectangle"><bsdf type="diffuse"><spectrum name="reflectance" value="400:0.5, 700:0.5"/></bsdf></shape>
    <shape type="rectangle"><bsdf type="diffuse"><spectrum name="reflectance" filename="spectra/flat.spd"/></bsdf></shape>
    <shape type="rectangle"><bsdf type="conductor"><spectrum name="eta" filename="spectra/eta.spd"/><spectrum name="k" value="400:0, 700:0"/></bsdf></shape>
    <emitter type="point"><spectrum name="intensity" value="400:0, 500:8, 600:15.6, 700:18.4"/></emitter>
    <emitter type="point"><spectrum name="intensity" value="3"/></emitter>
    <emitter type="point"><blackbody name="intensity" temperature="6500K" scale="1e-4"/></emitter>
    <emitter type="point"><blackbody name="intensity" temperature="3000"/></emitter>)");
    const SceneDesc s = loadScene(path);
    REQUIRE(s.meshes.size() == 3);
    REQUIRE(s.emitters.size() == 4);
    const Color inline400700 = diffuseAlbedo(s.bsdfs[s.meshes[0].bsdf]);
    checkNear(inline400700, DVec3(spectrumToLinearSrgb(spectrum({400, 700}, {0.5, 0.5}), SpectrumKind::Reflectance)), 1e-5);
    CHECK(inline400700.y == Approx(0.5).epsilon(0.01));
    checkNear(diffuseAlbedo(s.bsdfs[s.meshes[1].bsdf]), DVec3(0.4994), 3e-4);  // the flat grey of the first test
    // eta is unbounded (D65-weighted, not clamped to 1); 400-700 nm keeps about 99% of Y.
    const Color eta = spectrumToLinearSrgb(spectrum({400, 700}, {2, 2}), SpectrumKind::Unbounded);
    CHECK(eta.y > 1.9f);
    // (the same conductor through makeConductor: the eval of both at a few directions)
    const BxdfPtr want = makeConductor(eta, Color(0.f), Color(1.f));
    const Vec3 wo = glm::normalize(Vec3(0.3f, 0.1f, 0.9f));
    BsdfSample a, b;
    REQUIRE(s.bsdfs[s.meshes[2].bsdf]->sample(wo, 0.5f, Vec2(0.3f, 0.6f), TransportMode::Radiance, a));
    REQUIRE(want->sample(wo, 0.5f, Vec2(0.3f, 0.6f), TransportMode::Radiance, b));
    checkNear(a.weight, DVec3(b.weight), 1e-5);
    // Emission: not D65-weighted, only negatives clamped.
    checkNear(s.emitters[0].value,
              DVec3(spectrumToLinearSrgb(spectrum({400, 500, 600, 700}, {0, 8, 15.6, 18.4}), SpectrumKind::Emission)), 1e-4);
    checkNear(s.emitters[0].value, DVec3(20.711, 10.855, 2.771), 5e-3);
    checkNear(s.emitters[1].value, DVec3(3 * 1.204794, 3 * 0.948291, 3 * 0.908916), 1e-4);
    checkNear(s.emitters[2].value, DVec3(blackbodyToLinearSrgb(6500.0)) * 1e-4, 1e-4);
    checkNear(s.emitters[3].value, DVec3(blackbodyToLinearSrgb(3000.0)), 1e-3);
    // A Mitsuba 0.6 scene keeps a uniform emission spectrum grey, as 0.6 did.
    const SceneDesc old = loadScene(write("legacy.xml", R"(<scene version="0.6.0">
        <emitter type="point"><spectrum name="intensity" value="3"/></emitter></scene>)"));
    REQUIRE(old.emitters.size() == 1);
    CHECK(old.emitters[0].value == Color(3.f));
}

TEST_CASE("spectrum: loader errors name the file and line and parameter", "[spectrum][loader]") {
    write("bad.spd", "400 0.1\n500 0.2\n600 x\n");
    write("down.spd", "400 0.1\n500 0.2\n450 0.2\n");
    struct Case {
        std::string body, param;
        std::vector<std::string> words;
    };
    const std::vector<Case> cases = {
        {R"(<bsdf type="diffuse" id="a">
            <spectrum name="reflectance" filename="missing.spd"/></bsdf>)", "reflectance", {"missing.spd", "not found"}},
        {R"(<bsdf type="diffuse" id="a">
            <spectrum name="reflectance" filename="bad.spd"/></bsdf>)", "reflectance", {"bad.spd", "line 3"}},
        {R"(<bsdf type="diffuse" id="a">
            <spectrum name="reflectance" filename="down.spd"/></bsdf>)", "reflectance", {"down.spd", "line 3", "increase"}},
        {R"(<bsdf type="diffuse" id="a">
            <spectrum name="reflectance" value="400:0.1, 300:0.2"/></bsdf>)", "reflectance", {"increase"}},
        {R"(<bsdf type="diffuse" id="a">
            <spectrum name="reflectance" value="400:nan, 500:0.2"/></bsdf>)", "reflectance", {"not finite"}},
        {R"(<bsdf type="diffuse" id="a">
            <spectrum name="reflectance" value="400:0.1, 500:-0.2"/></bsdf>)", "reflectance", {"negative"}},
        {R"(<bsdf type="diffuse" id="a">
            <spectrum name="reflectance" value="400:0.1 500"/></bsdf>)", "reflectance", {"wavelength:value"}},
        {R"(<bsdf type="diffuse" id="a">
            <spectrum name="reflectance" value="0.1" filename="bad.spd"/></bsdf>)", "reflectance", {"not both"}},
        {R"(<emitter type="point">
            <blackbody name="intensity" temperature="0K"/></emitter>)", "intensity", {"temperature", "> 0"}},
        {R"(<emitter type="point">
            <blackbody name="intensity" temperature="-300"/></emitter>)", "intensity", {"temperature", "> 0"}},
        {R"(<emitter type="point">
            <blackbody name="intensity" temperature="hot"/></emitter>)", "intensity", {"temperature", "hot"}},
        {R"(<emitter type="point">
            <blackbody name="intensity" temperature="5000" scale="-1"/></emitter>)", "intensity", {"scale"}},
        {R"(<emitter type="point">
            <blackbody name="intensity"/></emitter>)", "intensity", {"temperature"}},
        {R"(<emitter type="point">
            <spectrum type="blackbody" name="intensity"><float name="temperature" value="5000"/></spectrum></emitter>)",
         "intensity", {"blackbody", "<blackbody temperature"}},
    };
    for (const Case& c : cases) {
        const std::string msg = errorOf(c.body);
        INFO(c.body << "\n-> " << msg);
        REQUIRE_FALSE(msg.empty());
        CHECK(msg.find("bad.xml:3:") != std::string::npos);  // the property's line
        CHECK(msg.find("'" + c.param + "'") != std::string::npos);
        for (const std::string& w : c.words) CHECK(msg.find(w) != std::string::npos);
    }
    // An unknown attribute on <blackbody> is refused like any other.
    const std::string msg = errorOf(R"(<emitter type="point">
            <blackbody name="intensity" temperature="5000" multiplier="2"/></emitter>)");
    CHECK(msg.find("bad.xml:3:") != std::string::npos);
    CHECK(msg.find("multiplier") != std::string::npos);
}

TEST_CASE("spectrum: Mitsuba 3's spectral Cornell boxes load", "[spectrum][loader]") {
    const std::string dir = std::string(LT_SOURCE_DIR) + "/scenes/external/mitsuba3-cbox/";
    for (const char* name : {"cbox.xml", "cbox-spectral.xml"}) {
        INFO(name);
        const SceneDesc s = loadScene(dir + name);
        REQUIRE(s.meshes.size() == 8);
        REQUIRE(s.emitters.size() == 1);
        // "400:0, 500:8, 600:15.6, 700:18.4" as emission (values of the rule evaluated separately).
        checkNear(s.emitters[0].value, DVec3(20.7108, 10.8546, 2.7712), 2e-3);
        // The luminaire's flat 0.78 reflectance is grey under the D65 weighting, up to the
        // missing tails outside 400-700 nm (R and B about 0.5% below G).
        const Color light = diffuseAlbedo(s.bsdfs[s.meshes[0].bsdf]);
        checkNear(light, DVec3(light.y), 5e-3);
        CHECK(light.y == Approx(0.78).epsilon(0.01));
        const Color red = diffuseAlbedo(s.bsdfs[s.meshes[5].bsdf]);  // cbox_redwall
        CHECK(red.x > 4 * red.y);
        CHECK(red.x > 4 * red.z);
    }
}
