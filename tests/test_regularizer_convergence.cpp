// Regularisation that converges (issue 45): with the tight bound and energy-compensated lobes, the
// regularised path tracer lights the room of scenes/cornell-box-point-in-glass.xml (a point light
// inside a smooth glass sphere: every light path leaves through the glass, and the path tracer
// can only reach the light by a regularised connection at the glass) at the brightness of a
// converged VCM render; with the published bound and no compensation it does not.
//
// Measure: the mean over the room, every pixel outside the sphere's own image (the pixels whose
// camera ray meets the sphere: a render of the sphere alone as an emitter), against the committed
// reference scenes/refs/cornell-box-point-in-glass.exr (VCM, 5,278 spp at 64^2; its room mean has a
// standard error under 0.1%, a tenth of the noise below).
// Thresholds: 3% is the issue's. The renders' own noise: over independent seeds the room mean of
// the regularised path tracer at 1,024 spp spread with a standard deviation of 1.7% (heavy
// tails: a camera path reaches the light only after a bounce finds the sphere), so 4,096 spp gives
// about 0.85%; the measured bias at these budgets is about -1% (seeds 1 and 2: 0.990, 0.992), so
// the fixed seed below passes with about 2.3 standard deviations to spare. The uncompensated
// published bound is at 0.65 (35% low: about 40 standard deviations at its 256 spp), so its
// check (below 0.90) cannot pass by noise.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <string>

#include "core/image.h"
#include "core/loader.h"
#include "integrators/integrator.h"

using namespace lt;
namespace fs = std::filesystem;

namespace {

constexpr int kRes = 64;

// The sphere's image: its pixels are > 0 in a render of the sphere alone as an area emitter.
Image sphereMask(const fs::path& dir) {
    fs::create_directories(dir);
    const fs::path xml = dir / "mask.xml";
    std::ofstream(xml) << "<scene version=\"3.0.0\">\n"
                          "  <include filename=\"" << LT_SOURCE_DIR << "/scenes/fragments/cornell-room.xml\"/>\n"
                          "  <shape type=\"sphere\"><point name=\"center\" value=\"0, 1, 0\"/>"
                          "<float name=\"radius\" value=\"0.3\"/>"
                          "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>\n"
                          "</scene>\n";
    const Scene scene(loadScene(xml.string(), {{"res", std::to_string(kRes)}}));
    RenderSettings s;
    s.integrator = "pt";
    s.spp = 4;
    s.maxDepth = 1;
    s.quiet = true;
    RenderStats st;
    return renderImage(scene, s, st);
}

// The room mean of img over that of ref (pixels where mask is 0).
double roomRatio(const Image& img, const Image& ref, const Image& mask) {
    double a = 0.0, b = 0.0;
    for (size_t i = 0; i < img.pixels.size(); ++i) {
        const Color m = mask.pixels[i];
        if (m.x + m.y + m.z > 0.f) continue;
        a += double(img.pixels[i].x) + img.pixels[i].y + img.pixels[i].z;
        b += double(ref.pixels[i].x) + ref.pixels[i].y + ref.pixels[i].z;
    }
    return a / b;
}

double render(const Scene& scene, const std::string& reg, int spp, const std::function<void(RenderSettings&)>& more,
              const Image& ref, const Image& mask) {
    RenderSettings s;
    s.integrator = "pt";
    s.regularizer = reg;
    s.spp = spp;
    s.seed = 1;
    s.quiet = true;
    more(s);
    RenderStats st;
    return roomRatio(renderImage(scene, s, st), ref, mask);
}

}  // namespace

TEST_CASE("Regularised PT lights the room around a glass sphere within 3% of VCM, and the published uncompensated bound does not", "[regularizer][render][convergence]") {
    const fs::path dir = fs::temp_directory_path() / "lt_test_regularizer_convergence";
    const Image mask = sphereMask(dir);
    const Image ref = readImage(std::string(LT_SOURCE_DIR) + "/scenes/refs/cornell-box-point-in-glass.exr");
    const Scene scene(loadScene(std::string(LT_SOURCE_DIR) + "/scenes/cornell-box-point-in-glass.xml",
                                {{"res", std::to_string(kRes)}}));
    REQUIRE(ref.width == kRes);
    int room = 0;
    for (const Color& m : mask.pixels) room += m.x + m.y + m.z > 0.f ? 0 : 1;
    REQUIRE(room > kRes * kRes / 2);  // (the sphere covers about 6% of the frame)
    REQUIRE(room < kRes * kRes);

    const double jg19 = render(scene, "jg19", 4096, [](RenderSettings&) {}, ref, mask);
    INFO("PT --reg jg19 (tight, compensated), 4096 spp: room mean / VCM = " << jg19);
    CHECK(jg19 == Approx(1.0).margin(0.03));

    const double published = render(scene, "jg19", 256, [](RenderSettings& s) {
        s.regBound = "published";
        s.regEnergy = "none";
    }, ref, mask);
    INFO("PT --reg jg19 --reg-bound published --reg-energy none, 256 spp: " << published);
    CHECK(published < 0.90);  // (measured 0.65)

    const std::string table = std::string(LT_SHARED_DIR) + "/data/opsr/opsr-reference-attenuation.json";
    if (!fs::exists(table)) {
        WARN("skipped OPSR 'moderate': " << table << " is absent");
        return;
    }
    const double opsr = render(scene, "opsr", 4096, [&](RenderSettings& s) { s.regOpsrTable = table + ":moderate"; },
                               ref, mask);
    INFO("PT --reg opsr 'moderate' (compensated), 4096 spp: " << opsr);
    CHECK(opsr == Approx(1.0).margin(0.03));
}
