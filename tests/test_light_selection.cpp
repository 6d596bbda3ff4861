// The choice between lights (core/scene.cpp, lightSelectionWeights): uniform over the lights
// that emit, each weighted by Mitsuba 3's `sampling_weight` (render/emitter.cpp, scene.cpp's
// emitter distribution), shared by next-event estimation and the light walks.
#include <catch2/catch.hpp>
#include <algorithm>
#include <string>
#include <vector>
#include "core/loader.h"
#include "core/scene.h"
#include "integrators/integrator.h"
#include "process.h"
#include "render_compare.h"
#include "scene_builders.h"

using namespace lt;
using namespace lt::test;

namespace {

EmitterDesc pointLight(const Vec3& p, float intensity, float weight) {
    EmitterDesc e;
    e.type = EmitterType::Point;
    e.position = p;
    e.value = Color(intensity);
    e.samplingWeight = weight;
    return e;
}

// A floor under three point lights of very different power, a black point light and an area
// light (a quad facing down), with hand-picked sampling weights.
SceneDesc manyLights() {
    SceneDesc d;
    d.bsdfs.push_back(makeDiffuse(Color(0.5f)));
    d.meshes.push_back(quad(Vec3(-2, 0, -2), Vec3(0, 0, 4), Vec3(4, 0, 0), 0));  // floor, normal +y
    d.emitters.push_back(pointLight(Vec3(-1, 1, 0), 1.f, 1.f));
    d.emitters.push_back(pointLight(Vec3(0, 1, 0), 40.f, 2.f));
    d.emitters.push_back(pointLight(Vec3(1, 1, 0), 0.01f, 0.f));
    d.emitters.push_back(pointLight(Vec3(1, 1, 1), 0.f, 3.f));  // black: never chosen
    EmitterDesc area;
    area.type = EmitterType::Area;
    area.value = Color(5.f);
    area.samplingWeight = 0.5f;
    d.emitters.push_back(area);
    d.meshes.push_back(quad(Vec3(-0.5f, 2, -0.5f), Vec3(1, 0, 0), Vec3(0, 0, 1), 0, 4));  // normal -y
    d.camera = lookAt(Vec3(0, 3, 3), Vec3(0, 0, 0), Vec3(0, 1, 0), 50.f, 8, 8);
    return d;
}

std::string loadError(const TempDir& dir, const std::string& body) {
    try {
        loadScene(dir.write("weights.xml", "<scene version=\"3.0.0\">\n" + body + "\n</scene>\n"));
    } catch (const SceneError& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST_CASE("light selection: probabilities are sampling_weight over the sum of the emitting lights'", "[lightsel]") {
    const Scene scene(manyLights());
    const auto& L = scene.lights();
    REQUIRE(L.size() == 5);
    // Weights 1, 2, 0, (black: none), 0.5 -> sum 3.5; the powers (1 : 40 : 0.01 W/sr, 5 x 1 m^2)
    // play no part.
    const float expected[5] = {1.f / 3.5f, 2.f / 3.5f, 0.f, 0.f, 0.5f / 3.5f};
    for (size_t i = 0; i < L.size(); ++i) {
        INFO("light " << i);
        CHECK(scene.lightDistribution().probability(i) == Approx(expected[i]).margin(1e-6));
        // What the emitter hit's MIS reads: the same, but a tiny stand-in for 0 (core/scene.cpp).
        if (expected[i] > 0.f) CHECK(scene.lightSelectionProb(&L[i]) == scene.lightDistribution().probability(i));
        else CHECK(scene.lightSelectionProb(&L[i]) < 1e-11f);
    }
    // What is sampled agrees with what is read back: the frequencies over a fine grid of u.
    const int n = 70000;
    int count[5] = {};
    for (int k = 0; k < n; ++k) ++count[scene.lightDistribution().sample((k + 0.5f) / n)];
    for (int i = 0; i < 5; ++i) CHECK(double(count[i]) / n == Approx(expected[i]).margin(1e-4));
}

// The other two rules (core/scene_desc.h, LightSelection): in proportion to power, and half power,
// half uniform over the emitting lights; each times sampling_weight and normalised. The powers are
// the scene's own (Light::power); here they differ by up to 4000x, so a rule mixed up with another
// misses by far more than the margin. And which rule each integrator takes (render, the tools).
TEST_CASE("light selection: power and the mixture weigh the lights' power and sampling_weight", "[lightsel]") {
    SceneDesc d = manyLights();
    const Scene base(d);
    const auto& L = base.lights();
    std::vector<double> power, weight;
    double powerSum = 0.0, lit = 0.0;
    for (size_t i = 0; i < L.size(); ++i) {
        power.push_back(std::max(0.0, double(L[i].power(base))));
        weight.push_back(d.emitters[i].samplingWeight);
        powerSum += power.back();
        lit += power.back() > 0.0;
    }
    REQUIRE(lit == 4.0);  // (the black light emits nothing)
    for (const LightSelection rule : {LightSelection::Power, LightSelection::Mixture}) {
        d.lightSelection = rule;
        const Scene scene(d);
        std::vector<double> expected;
        double sum = 0.0;
        for (size_t i = 0; i < L.size(); ++i) {
            const double share = power[i] / powerSum;
            const double w = power[i] > 0.0 ? (rule == LightSelection::Power ? share : 0.5 * share + 0.5 / lit) : 0.0;
            expected.push_back(w * weight[i]);
            sum += expected.back();
        }
        for (size_t i = 0; i < L.size(); ++i) {
            INFO("rule " << int(rule) << " light " << i);
            CHECK(scene.lightDistribution().probability(i) == Approx(expected[i] / sum).epsilon(1e-4).margin(1e-7));
        }
    }
    CHECK(lightSelectionFor("pt") == LightSelection::Uniform);
    for (const char* integrator : {"bpt", "vcm", "lt", "ppm"}) CHECK(lightSelectionFor(integrator) == LightSelection::Mixture);
}

TEST_CASE("light selection: the loader reads sampling_weight on area and top-level emitters", "[lightsel]") {
    TempDir dir("lt_test_lightsel");
    const std::string xml =
        "<scene version=\"3.0.0\">\n"
        "<shape type=\"rectangle\"><emitter type=\"area\"><float name=\"sampling_weight\" value=\"0.25\"/>"
        "</emitter></shape>\n"
        "<emitter type=\"point\"><float name=\"sampling_weight\" value=\"3\"/></emitter>\n"
        "<emitter type=\"spot\"><float name=\"sampling_weight\" value=\"0\"/></emitter>\n"
        "<emitter type=\"constant\"/>\n"
        "</scene>\n";
    const SceneDesc d = loadScene(dir.write("weights.xml", xml));
    REQUIRE(d.emitters.size() == 4);
    // (both places the loader reads it: an area emitter in its shape, a top-level emitter of any
    // other type; the order of the two kinds in the list is the loader's business)
    std::vector<float> w;
    for (const EmitterDesc& e : d.emitters) w.push_back(e.samplingWeight);
    std::sort(w.begin(), w.end());
    CHECK(w == std::vector<float>{0.f, 0.25f, 1.f, 3.f});
}

TEST_CASE("light selection: a bad sampling_weight is an error naming file line and parameter", "[lightsel]") {
    TempDir dir("lt_test_lightsel");
    for (const std::string v : {"-1", "nan", "inf"}) {
        INFO("sampling_weight " << v);
        const std::string msg =
            loadError(dir, "<emitter type=\"point\">\n<float name=\"sampling_weight\" value=\"" + v + "\"/>\n</emitter>");
        CHECK(msg.find("weights.xml:3:") != std::string::npos);
        CHECK(msg.find("sampling_weight") != std::string::npos);
        if (v == "-1") CHECK(msg.find(">= 0") != std::string::npos);
        INFO("message: " << msg);
    }
    const std::string area = loadError(
        dir, "<shape type=\"rectangle\">\n<emitter type=\"area\">\n<float name=\"sampling_weight\" value=\"-2\"/>\n"
             "</emitter>\n</shape>");
    CHECK(area.find("weights.xml:4:") != std::string::npos);
    CHECK(area.find("sampling_weight") != std::string::npos);
    // Every weight 0: no light can be chosen (Mitsuba's emitter distribution has no mass either).
    SceneDesc d = manyLights();
    for (EmitterDesc& e : d.emitters) e.samplingWeight = 0.f;
    CHECK_THROWS_WITH(Scene(d), Catch::Contains("sampling_weight 0"));
}

// An area light of weight 0 is never chosen by next-event estimation (nor starts a light walk),
// yet the image where a walk can hit it keeps its mean: the emitter hit's MIS weight becomes 1.
// K = 8 renders per configuration (seeds 1000..1007), 4 x 4 block means compared by Welch's t at
// family-wise significance 1e-3 per integrator (Sidak over the 16 blocks): a correct
// implementation fails about one run in a thousand, and the seeds are fixed. A biased one (the
// emitter hit weighted below 1 because the MIS reads a density of 0 as 1, which happens if
// lightSelectionProb returns 0 for this light) moves 13 to 15 of the 16 blocks, the worst by 7.6
// (PT) to 22 (BPT) critical values.
TEST_CASE("light selection: sampling_weight 0 keeps PT BPT and VCM unbiased", "[lightsel]") {
    SceneDesc d = cornellBox(16, makeDiffuse(Color(0.5f)));
    d.emitters.push_back(pointLight(Vec3(-0.5f, 0.5f, 0.2f), 1.f, 1.f));  // so that one weight is > 0
    d.integrator.maxDepth = 4;
    SceneDesc zero = d;
    zero.emitters[0].samplingWeight = 0.f;  // the ceiling light: reached only by hitting it
    {
        const Scene s(zero);
        REQUIRE(s.lightDistribution().probability(0) == 0.f);
        for (int k = 0; k < 1000; ++k) CHECK(s.lightDistribution().sample((k + 0.5f) / 1000) == 1);
    }
    for (const char* integ : {"pt", "bpt", "vcm"}) {
        INFO("integrator " << integ);
        RenderSettings rs;
        rs.integrator = integ;
        rs.spp = 16;
        rs.threads = 1;
        const auto a = blockStats(d, rs, 8, 4);
        const auto b = blockStats(zero, rs, 8, 4);
        double worst = 0;
        const int differing = differingBlocks(a, b, 1e-3, &worst);
        INFO("worst |t| / critical " << worst);
        CHECK(differing == 0);
        // The weight-0 light's image is noisier (emitter hits only), so the two are not the same
        // render: the test compares two different estimators of one image.
        double va = 0, vb = 0;
        for (size_t i = 0; i < a.size(); ++i) va += a[i].var, vb += b[i].var;
        CHECK(vb > va);
    }
}
