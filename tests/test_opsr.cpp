// OPSR (integrators/transport/opsr.h): the accumulated roughness (Eqs. 11, 13, 14), the bins and
// table look-ups, the attenuation file, and the path tracer with it.
#include <catch2/catch.hpp>
#include <algorithm>
#include <bit>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include "core/loader.h"
#include "core/metrics.h"
#include "integrators/integrator.h"
#include "integrators/transport/opsr.h"
#include "process.h"
#include "regularizer_paths.h"
#include "scene_builders.h"

using namespace lt;
using namespace lt::test;

namespace {

// A table whose window of k vertices has the constant factor 0.1 k (hand arithmetic).
std::shared_ptr<opsr::AttenuationTable> constantTable() {
    auto t = std::make_shared<opsr::AttenuationTable>();
    for (int k = 2; k <= opsr::kMaxWindow; ++k) t->tables[k].assign(size_t(std::pow(opsr::kQ, k)), 0.1f * float(k));
    return t;
}

// The roughness whose continuous bin coordinate (2^sqrt(a) - 1)(Q + 1) is c.
float roughnessAt(double c) {
    const double s = std::log2(1.0 + c / double(opsr::kQ + 1));
    return float(s * s);
}

// The mean of the regularised contributions (strategy images' regularised.exr) of the path tracer
// with OPSR at gamma 0.03 on a 32^2 scene (512 spp, max depth 8), with --pt-strategy `strategy`
// and, where `always`, a regularised sample at every vertex (--reg-opsr-always-sample).
double regularisedMean(const Scene& scene, const std::filesystem::path& dir, const std::string& strategy, bool always,
                       uint64_t seed) {
    RenderSettings s = settingsFor("pt", 512);
    s.maxDepth = 8;
    s.seed = seed;
    s.ptStrategy = strategy;
    s.regularizer = "opsr";
    s.regOpsrGamma = 0.03;
    s.regOpsrAlwaysSample = always;
    const std::string name = strategy + (always ? "always" : "walk") + std::to_string(seed);
    s.strategyImages = (dir / name).string();
    RenderStats st;
    renderImage(scene, s, st);
    CHECK(st.regularisedContributions > 1000);
    return cropMean(readImage((dir / name / "regularised.exr").string()), 32, 0, 0, 32, 32);
}

}  // namespace

TEST_CASE("OPSR's bins from their edges are the formula's for every float", "[opsr]") {
    // roughnessBin reads the edges; the formula (binByFormula) is non-decreasing over (0, 1), so the
    // two agree everywhere, which this checks for every float from 0 to 1 and a few beyond (about
    // 1.07e9 values, 6 s at -O2). It fails where an edge is one float off or the formula is not
    // monotone under this build's exp2 and sqrt.
    uint32_t bad = 0;
    const uint32_t one = std::bit_cast<uint32_t>(1.f);
    for (uint32_t u = 0; u <= one + 4; ++u) {
        const float a = std::bit_cast<float>(u);
        bad += opsr::roughnessBin(a) != opsr::binByFormula(a);
    }
    CHECK(bad == 0);
    for (const float a : {-1.f, -0.f, 2.f, 1e30f, std::numeric_limits<float>::infinity()})
        CHECK(opsr::roughnessBin(a) == opsr::binByFormula(a));
}

TEST_CASE("OPSR bins, window indices and Eq. 11 by hand", "[opsr]") {
    // bin(a) = min(floor((2^sqrt(a) - 1) 5), 3): edges at a = 0.0692, 0.2357, 0.4600.
    CHECK(opsr::roughnessBin(0.f) == 0);
    CHECK(opsr::roughnessBin(0.05f) == 0);  // (2^0.2236 - 1) 5 = 0.838
    CHECK(opsr::roughnessBin(0.1f) == 1);   // (2^0.3162 - 1) 5 = 1.225
    CHECK(opsr::roughnessBin(0.3f) == 2);   // (2^0.5477 - 1) 5 = 2.309
    CHECK(opsr::roughnessBin(0.5f) == 3);   // (2^0.7071 - 1) 5 = 3.163
    CHECK(opsr::roughnessBin(1.f) == 3);    // 5, clamped
    CHECK(opsr::roughnessBin(2.f) == 3);    // (roughness clamped to 1)
    CHECK(opsr::binCoordinate(0.1f) == Approx(1.2254).epsilon(1e-3));
    CHECK(opsr::binCoordinate(1.f) == 3.f);
    CHECK(opsr::binCoordinate(0.f) == 0.f);
    CHECK(opsr::binCoordinate(-0.5f) == 0.f);
    CHECK(opsr::roughnessBin(-0.5f) == 0);
    // Just inside (0, 1), the formula itself (0 and 1 are answered without it): the same bins.
    CHECK(opsr::roughnessBin(std::nextafter(0.f, 1.f)) == 0);
    CHECK(opsr::roughnessBin(std::nextafter(1.f, 0.f)) == 3);
    CHECK(opsr::binCoordinate(std::nextafter(1.f, 0.f)) == 3.f);
    CHECK(opsr::binCoordinate(std::nextafter(0.f, 1.f)) == Approx(0.f).margin(1e-6));
    // The edges are the formula's: kBinEdges[i] is the least float of bin i + 1.
    for (int i = 0; i < opsr::kQ - 1; ++i) {
        CHECK(opsr::binByFormula(opsr::kBinEdges[i]) == i + 1);
        CHECK(opsr::binByFormula(std::nextafter(opsr::kBinEdges[i], 0.f)) == i);
    }
    // index = sum_j 4^j bin(a_j), a_0 the oldest vertex.
    const float diffuseThenSmooth[2] = {1.f, 0.f}, smoothThenDiffuse[2] = {0.f, 1.f};
    CHECK(opsr::windowIndex(diffuseThenSmooth, 2) == 3);
    CHECK(opsr::windowIndex(smoothThenDiffuse, 2) == 12);
    const float five[5] = {0.1f, 0.3f, 1.f, 0.f, 0.1f};  // bins 1, 2, 3, 0, 1
    CHECK(opsr::windowIndex(five, 5) == 1 + 2 * 4 + 3 * 16 + 0 * 64 + 1 * 256);
    // Eq. 11: 1 - (1 - a_last) prod (1 - gamma a_i).
    opsr::Attenuation c;
    c.gamma = 0.01f;
    CHECK(opsr::accumulatedRoughness(diffuseThenSmooth, 2, c) == Approx(0.01));
    c.gamma = 0.2f;
    const float three[3] = {1.f, 0.5f, 0.1f};
    CHECK(opsr::accumulatedRoughness(three, 3, c) == Approx(1.0 - 0.8 * 0.9 * 0.9));
    const float one[1] = {0.3f};
    CHECK(opsr::accumulatedRoughness(one, 1, c) == 0.3f);  // Eq. 6: one vertex keeps its own
    c.gamma = 0.f;
    CHECK(opsr::accumulatedRoughness(three, 3, c) == Approx(0.1));  // gamma 0: no regularisation
}

TEST_CASE("OPSR Eq. 11 is monotone in gamma and in every roughness of the path", "[opsr]") {
    std::mt19937 gen(7);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    opsr::Attenuation att;
    int checks = 0;
    for (int trial = 0; trial < 2000; ++trial) {
        const int count = 1 + trial % 9;
        float a[9];
        for (int i = 0; i < count; ++i) a[i] = u(gen);
        const float g0 = u(gen), g1 = std::min(1.f, g0 + 0.25f * u(gen));
        att.gamma = g0;
        const float base = opsr::accumulatedRoughness(a, count, att);
        att.gamma = g1;
        CHECK(opsr::accumulatedRoughness(a, count, att) >= base);
        CHECK(base >= a[count - 1]);  // alpha' >= alpha (Eq. 7)
        att.gamma = g0;
        const int i = trial % count;
        const float old = a[i];
        a[i] = std::min(1.f, old + 0.3f * u(gen));
        CHECK(opsr::accumulatedRoughness(a, count, att) >= base);
        a[i] = old;
        ++checks;
    }
    CHECK(checks == 2000);
}

TEST_CASE("OPSR tables: nearest-bin and recursive accumulation for paths of 1 to 9 vertices, by hand", "[opsr]") {
    opsr::Attenuation att;
    att.table = constantTable();  // tables[k] = 0.1 k
    const float h = 0.5f;         // bin 3 (top) for the earlier vertices; the last one smooth (bin 0)
    // 1 vertex: its own roughness.
    const float p1[1] = {0.f};
    CHECK(opsr::accumulatedRoughness(p1, 1, att) == 0.f);
    // 2 vertices, tables[2] = 0.2: 1 - (1 - 0.2 * 0.5)(1 - 0) = 0.1.
    const float p2[2] = {h, 0.f};
    CHECK(opsr::accumulatedRoughness(p2, 2, att) == Approx(0.1));
    // 5 vertices, tables[5] = 0.5: 1 - 0.75^4 = 0.68359375.
    const float p5[5] = {h, h, h, h, 0.f};
    CHECK(opsr::accumulatedRoughness(p5, 5, att) == Approx(0.68359375));
    // 6 vertices (Eq. 14): the first five collapse with tables[5]: v = 1 - 0.75^4 (1 - 0.5) =
    // 0.841796875; then the window (v, 0) with tables[2] = 0.2: 1 - (1 - 0.2 v) = 0.168359375.
    const float p6[6] = {h, h, h, h, h, 0.f};
    CHECK(opsr::accumulatedRoughness(p6, 6, att) == Approx(0.168359375));
    // 9 vertices: v as above, then the window (v, 0.5, 0.5, 0.5, 0) of five with 0.5:
    // 1 - (1 - 0.5 v)(0.75)^3 = 1 - 0.5791015625 * 0.421875 = 0.7556915283.
    const float p9[9] = {h, h, h, h, h, h, h, h, 0.f};
    CHECK(opsr::accumulatedRoughness(p9, 9, att) == Approx(0.7556915283));
    // 10 vertices: two collapses (windows at 0 and 4: v, v2 = 1 - (1 - 0.5 v) 0.75^3 (1 - 0.5)),
    // then (v2, 0) with 0.2.
    const double v = 0.841796875, v2 = 1.0 - (1.0 - 0.5 * v) * 0.421875 * 0.5;
    const float p10[10] = {h, h, h, h, h, h, h, h, h, 0.f};
    CHECK(opsr::accumulatedRoughness(p10, 10, att) == Approx(0.2 * v2));
    // The top-bin rule: a last vertex in bin 3 keeps its roughness.
    const float top[3] = {1.f, 1.f, 0.6f};
    CHECK(opsr::accumulatedRoughness(top, 3, att) == 0.6f);

    // The index is read: a table that is 0 but at one class.
    auto one = std::make_shared<opsr::AttenuationTable>();
    for (int k = 2; k <= opsr::kMaxWindow; ++k) one->tables[k].assign(size_t(std::pow(opsr::kQ, k)), 0.f);
    one->tables[2][3] = 0.05f;   // (diffuse, smooth): index 3 + 4 * 0
    one->tables[3][15] = 0.25f;  // (diffuse, diffuse, smooth): 3 + 4 * 3
    att.table = one;
    const float ds[2] = {1.f, 0.f}, gs[2] = {0.1f, 0.f}, dds[3] = {1.f, 1.f, 0.f}, dgs[3] = {1.f, 0.1f, 0.f};
    CHECK(opsr::accumulatedRoughness(ds, 2, att) == Approx(0.05));
    CHECK(opsr::accumulatedRoughness(gs, 2, att) == 0.f);
    CHECK(opsr::accumulatedRoughness(dds, 3, att) == Approx(1.0 - 0.75 * 0.75));
    CHECK(opsr::accumulatedRoughness(dgs, 3, att) == 0.f);
    // 7 vertices: the first window (1, 1, 1, 1, 0.1) has bins (3, 3, 3, 3, 1), index
    // 3 + 12 + 48 + 192 + 256 = 511; with 0.5 there its virtual roughness is
    // 1 - 0.5^4 (1 - 0.1) = 0.94375 (bin 3); then (v, 1, 0) is index 3 + 12 = 15: 0.25.
    one->tables[5][511] = 0.5f;
    const float p7[7] = {1.f, 1.f, 1.f, 1.f, 0.1f, 1.f, 0.f};
    const double v7 = 1.0 - 0.0625 * 0.9;
    CHECK(opsr::accumulatedRoughness(p7, 7, att) == Approx(1.0 - (1.0 - 0.25 * v7) * 0.75));
}

TEST_CASE("OPSR interp sets: multilinear look-ups between bin centres, by hand", "[opsr]") {
    auto t = std::make_shared<opsr::AttenuationTable>();
    t->interpolated = true;
    for (int k = 2; k <= opsr::kMaxWindow; ++k) {
        t->tables[k].resize(size_t(std::pow(opsr::kQ, k)));
        for (size_t i = 0; i < t->tables[k].size(); ++i) t->tables[k][i] = float(i) / float(t->tables[k].size() - 1);
    }
    opsr::Attenuation att;
    att.table = t;
    // a0 at coordinate 1.0 (half-way between the centres 0.5 and 1.5), a1 = 0 (coordinate 0,
    // below the first centre: clamped to node 0): gamma = (t[0] + t[1]) / 2 = 1/30.
    const float a0 = roughnessAt(1.0);
    const float w1[2] = {a0, 0.f};
    CHECK(opsr::accumulatedRoughness(w1, 2, att) == Approx(a0 / 30.0).epsilon(1e-3));
    // a1 at coordinate 2.0 (between nodes 1 and 2 of its axis): the four corners (0|1, 1|2),
    // gamma = (t[4] + t[5] + t[8] + t[9]) / 4 = 26 / 60; g = 1 - (1 - gamma a0)(1 - a1).
    const float a1 = roughnessAt(2.0);
    const float w2[2] = {a0, a1};
    CHECK(opsr::accumulatedRoughness(w2, 2, att) == Approx(1.0 - (1.0 - 26.0 / 60.0 * a0) * (1.0 - a1)).epsilon(1e-3));
    // At a bin centre the look-up is the nearest-bin entry: coordinates 2.5 and 0.5 -> bins (2, 0),
    // index 2: gamma = 2 / 15.
    const float c25 = roughnessAt(2.5), c05 = roughnessAt(0.5);
    const float w3[2] = {c25, c05};
    CHECK(opsr::windowFactor(*t, w3, 2) == Approx(2.0 / 15.0).epsilon(1e-3));
    t->interpolated = false;
    CHECK(opsr::windowFactor(*t, w3, 2) == Approx(2.0 / 15.0));
    t->interpolated = true;
    // Three vertices, one of them between two centres: coordinates (0.5, 1.0, 0.5) -> nodes
    // 0, 0|1, 0: (t3[0] + t3[4]) / 2 = 2 / 63.
    const float w4[3] = {c05, a0, c05};
    CHECK(opsr::windowFactor(*t, w4, 3) == Approx(2.0 / 63.0).epsilon(1e-3));
}

TEST_CASE("OPSR attenuation file: the reference loads, a truncated or corrupt copy is rejected naming file and field", "[opsr][file]") {
    const auto dir = tempDir("lt_opsr", "tables");
    if (!std::filesystem::exists(kOpsrReferenceFile)) {
        WARN("skipped: " << kOpsrReferenceFile << " is not there (a clone without ../shared/data/opsr)");
        return;
    }
    const nlohmann::json j = nlohmann::json::parse(readText(kOpsrReferenceFile));
    for (const char* set : {"low", "moderate", "strong", "aggressive", "interp_low", "interp_moderate"}) {
        INFO(set);
        const auto t = opsr::loadAttenuationTable(kOpsrReferenceFile, set);
        CHECK(t->interpolated == (std::string(set).find("interp") == 0));
        for (int k = 2; k <= 5; ++k) {
            const auto& arr = j["sets"][set]["tables"][std::to_string(k)];
            REQUIRE(t->tables[k].size() == arr.size());
            for (size_t i = 0; i < arr.size(); ++i) CHECK(t->tables[k][i] == float(arr[i].get<double>()));
        }
    }
    CHECK(splitOpsrTableSpec("a/b.json:moderate") == std::make_pair(std::string("a/b.json"), std::string("moderate")));
    CHECK(splitOpsrTableSpec("a/b.json") == std::make_pair(std::string("a/b.json"), std::string("low")));
    auto rejects = [&](const std::string& name, const std::string& text, const std::string& set,
                       const std::vector<std::string>& mentions) {
        const std::string path = (dir / name).string();
        std::ofstream(path) << text;
        INFO(name);
        try {
            opsr::loadAttenuationTable(path, set);
            FAIL("accepted");
        } catch (const std::runtime_error& e) {
            const std::string msg = e.what();
            INFO(msg);
            CHECK(msg.find(path) != std::string::npos);
            for (const auto& m : mentions) CHECK(msg.find(m) != std::string::npos);
        }
    };
    const std::string full = readText(kOpsrReferenceFile);
    rejects("truncated.json", full.substr(0, full.size() / 2), "low", {"malformed JSON", "line"});
    nlohmann::json shortTable = j;
    shortTable["sets"]["low"]["tables"]["3"].erase(63);
    rejects("short.json", shortTable.dump(), "low", {"sets.low.tables.3", "64"});
    nlohmann::json nan = j;
    nan["sets"]["moderate"]["tables"]["4"][17] = std::nan("");  // (written by nlohmann as null)
    rejects("nan.json", nan.dump(), "moderate", {"sets.moderate.tables.4[17]", "finite"});
    nlohmann::json nanText = j;
    nanText["sets"]["low"]["tables"]["2"][5] = "NaN";
    rejects("nan-text.json", nanText.dump(), "low", {"sets.low.tables.2[5]"});
    nlohmann::json big = j;
    big["sets"]["low"]["tables"]["5"][1000] = 1.5;
    rejects("range.json", big.dump(), "low", {"sets.low.tables.5[1000]", "[0, 1]"});
    rejects("set.json", full, "medium", {"sets.medium", "low", "interp_moderate"});
    rejects("missing.json", "{\"sets\": {\"low\": {\"tables\": {\"2\": []}}}}", "low", {"sets.low.tables.2", "16"});
    std::filesystem::remove_all(dir);
}

TEST_CASE("OPSR with gamma 0 renders bit-identically to no regulariser", "[opsr][render]") {
    // The box with a glossy conductor panel, a glass sphere and a mirror ball, lit by an area light
    // and by a point light in the glass sphere: gamma = 0 adds no roughness (g = the vertex's own),
    // so nothing is regularised, though OPSR's connections at smooth vertices run (and are
    // refused), and BPT and VCM compute per-technique factors on paths with a glossy vertex (all 1).
    // PT, BPT and VCM must not change by a single bit.
    Scene scene(mixedSceneWithPointInGlass(40));
    checkBitIdenticalToNone(
        scene,
        [](RenderSettings& s) {
            s.regularizer = "opsr";
            s.regOpsrGamma = 0.0;
        },
        [](const RenderStats&) {});
    // and with gamma > 0 they do regularise there
    for (const char* integrator : {"pt", "bpt", "vcm"}) {
        RenderSettings reg = settingsFor(integrator, 16);
        reg.regularizer = "opsr";
        reg.regOpsrGamma = 0.2;
        RenderStats c;
        renderImage(scene, reg, c);
        INFO(integrator);
        CHECK(c.regularisedContributions > 100);
    }
}

TEST_CASE("OPSR in the path tracer: next-event estimation and the regularised BSDF sample estimate one integrand", "[opsr][render][mis]") {
    // scenes/cornell-box-ggx.xml with a near-specular gold box (alpha 0.01), gamma 0.03: the light
    // reflected by the box onto the walls (camera, diffuse, gold, light) is regularised at the gold
    // vertex (g = 1 - 0.99 * 0.97 = 0.040). With --pt-strategy mis it is estimated by next-event
    // estimation and the regularised BSDF sample, weighted by their own densities; with bsdf by the
    // regularised BSDF sample alone. Both estimate the same regularised integrand, so the images of
    // the regularised contributions (regularised.exr) must agree. Measured (32^2, 512 spp): per
    // seed (4-8) the two differ by -3.7% to +2.5%; over seeds 4-6 by under 1%. Tolerance 5% on the
    // sum over seeds 4-6 (about 3 standard deviations of the difference). Next-event estimation
    // weighted against the material's own (alpha 0.01) density instead of the regularised one (a
    // bug this test caught) put 24% more light on these paths. (A narrow lobe is the sensitive
    // case: with gamma 0.3 that bug moved these paths by under 1%.)
    SceneDesc desc = loadScene(std::string(LT_SOURCE_DIR) + "/scenes/cornell-box-ggx.xml", {{"res", "32"}, {"alpha", "0.01"}});
    Scene scene(desc);
    const auto dir = tempDir("lt_opsr", "mis");
    double mis = 0.0, bsdf = 0.0;
    for (uint64_t seed : {4, 5, 6})
        mis += regularisedMean(scene, dir, "mis", false, seed), bsdf += regularisedMean(scene, dir, "bsdf", false, seed);
    INFO("mis " << mis / 3 << ", bsdf " << bsdf / 3);
    CHECK(mis > 0.0);
    CHECK(std::abs(mis / bsdf - 1.0) < 0.05);
    std::filesystem::remove_all(dir);
}

TEST_CASE("OPSR in the path tracer: the walk's own sample stands for the regularised one where it covers it", "[opsr][render][mis]") {
    // opsr.h (4): at a glossy vertex whose request raises a GGX alpha at most twice
    // (Bxdf::requestRatioBound <= 4), the emitter-hit technique is the walk's own sample with its
    // value scaled by rho_hat / rho, not a regularised sample of its own. scenes/cornell-box-ggx.xml
    // with the gold box at alpha 0.032 and gamma 0.03: after one diffuse vertex g = 1 - 0.97^2 =
    // 0.059 (bound 3.6, (g / alpha)^2 times the energy compensation's K 1.07: the walk's sample),
    // after two g = 0.087 (bound 8.2: a sample of its own), so both forms run in one render. Three estimates of the same regularised integrand must
    // agree: --pt-strategy mis with the walk's sample, mis with a regularised sample at every
    // vertex (--reg-opsr-always-sample, the reference's form), and bsdf with the walk's sample.
    // The measure is the mean of the image of the regularised contributions (regularised.exr),
    // summed over seeds 4-9 (32^2, 512 spp).
    // - mis against always-sample: the same walks (same seeds), so their difference is small:
    //   per seed 1.1% standard deviation (seeds 4-11), 0.45% for the sum of six. Measured -0.7%.
    //   Tolerance 1.5% (3.3 standard deviations).
    // - mis against bsdf: independent noise, 4.5% per seed, 1.8% for six. Measured +0.9%.
    //   Tolerance 6% (3.3 standard deviations).
    //   (The figures at alpha 0.03 uncompensated; at 0.032 compensated: -0.6% and +0.9%.)
    // Mutations this catches (tried): the walk's hits at their plain value (hitRatio left at 1)
    // move mis against always-sample by +11.7%; next-event estimation weighed against the
    // regularised density where the walk's sample is the technique, by -2.9%.
    SceneDesc desc = loadScene(std::string(LT_SOURCE_DIR) + "/scenes/cornell-box-ggx.xml", {{"res", "32"}, {"alpha", "0.032"}});
    Scene scene(desc);
    const auto dir = tempDir("lt_opsr", "walk");
    double mis = 0.0, bsdf = 0.0, always = 0.0;
    for (uint64_t seed = 4; seed <= 9; ++seed) {
        mis += regularisedMean(scene, dir, "mis", false, seed);
        bsdf += regularisedMean(scene, dir, "bsdf", false, seed);
        always += regularisedMean(scene, dir, "mis", true, seed);
    }
    INFO("mis " << mis / 6 << ", bsdf " << bsdf / 6 << ", always-sample " << always / 6);
    CHECK(mis > 0.0);
    CHECK(std::abs(mis / always - 1.0) < 0.015);
    CHECK(std::abs(mis / bsdf - 1.0) < 0.06);
    // (and the two forms did run: a sample of its own at every vertex draws other numbers)
    CHECK(mis != always);
    std::filesystem::remove_all(dir);
}

TEST_CASE("OPSR 'low' renders the point light in glass that plain PT cannot, with less error at equal spp", "[opsr][render]") {
    // scenes/cornell-box-point-in-glass.xml: the room is lit only by a point light inside a smooth
    // glass sphere; plain PT renders it black (it can neither hit the point nor connect through the
    // glass). With the reference 'low' set, next-event estimation at the glass after a diffuse
    // bounce gets the class (diffuse, smooth)'s roughness, so PT renders the room. The error is
    // measured against VCM (1024 spp) over the pixels outside the worst 1%: the set's factor for
    // that class is 0.005, an alpha 0.005 lobe at the glass that next-event estimation to a point
    // meets rarely, so a few pixels carry huge samples (measured with imgcompare at 64^2, 256 spp:
    // relMSE 950 and 3080 over two seeds, 99.9% of it in the worst 1%; outside them 0.52 against
    // plain PT's 0.91). Here (32^2, 256 spp, the per-pixel error summed over the channels): 1.65
    // against 2.76; checked under 0.8 times plain PT's. The image mean: 0.85 against VCM's 0.80
    // here, 0.80 and 1.31 at 64^2 (heavy-tailed: checked to within a factor 2). Needs the
    // reference file (skipped without it).
    if (!std::filesystem::exists(kOpsrReferenceFile)) {
        WARN("skipped: " << kOpsrReferenceFile << " is not there");
        return;
    }
    SceneDesc desc = loadScene(std::string(LT_SOURCE_DIR) + "/scenes/cornell-box-point-in-glass.xml", {{"res", "32"}});
    Scene scene(desc);
    RenderSettings v = settingsFor("vcm", 1024);
    v.maxDepth = 8;
    RenderSettings p = settingsFor("pt", 256);
    p.maxDepth = 8;
    RenderSettings o = p;
    o.regularizer = "opsr";
    o.regOpsrTable = kOpsrReferenceFile + ":low";
    RenderStats a, b, c;
    const Image ref = renderImage(scene, v, a), plain = renderImage(scene, p, b), reg = renderImage(scene, o, c);
    auto trimmedRelMse = [&](const Image& img) {
        std::vector<double> e = pixelRelMseErrors(img, ref);
        std::sort(e.begin(), e.end());
        const size_t keep = e.size() - topPixelCount(e.size(), 0.01);
        double sum = 0.0;
        for (size_t i = 0; i < keep; ++i) sum += e[i];
        return sum / double(keep);
    };
    const double refMean = cropMean(ref, 32, 0, 0, 32, 32), regMean = cropMean(reg, 32, 0, 0, 32, 32);
    const double ePlain = trimmedRelMse(plain), eReg = trimmedRelMse(reg);
    INFO("VCM mean " << refMean << ", PT " << cropMean(plain, 32, 0, 0, 32, 32) << ", PT+OPSR low " << regMean
                     << "; relMSE outside the worst 1%: PT " << ePlain << ", PT+OPSR " << eReg);
    CHECK(cropMean(plain, 32, 0, 0, 32, 32) == 0.0);
    CHECK(regMean > 0.5 * refMean);
    CHECK(regMean < 2.0 * refMean);
    CHECK(eReg < 0.8 * ePlain);
    CHECK(c.regularisedContributions > 1000);
}

TEST_CASE("OPSR consistent offset: the bias falls with N, and not with a fixed offset", "[opsr][render][consistency]") {
    // cornell-box-ggx.xml with the gold box at alpha 0.01 and gamma 0.5: next-event estimation at
    // the box after a diffuse bounce takes g = 1 - 0.99 * 0.5 = 0.505, which blurs and darkens the
    // light the box throws on the ceiling and the left wall (the crop: the upper-left 16 x 10
    // pixels). The bias is measured against the same integrator without OPSR and with the same
    // seed (the walks are the same, so most of their noise cancels). Consistent offset, lambda
    // 0.45: g_N = 0.01 + 0.495 N^-0.45, whose mean share over passes 1..N is about N^-0.45 / 0.55:
    // 0.28 at 64 spp, 0.08 at 1024.
    // PT, measured (32^2, seeds 4-6): fixed -8.3%, -7.6%, -7.4% at 1024 spp; consistent -0.9%,
    // -3.4%, -3.2% at 64 spp and -0.5%, -0.05%, -0.2% at 1024 spp.
    // BPT (its connections at the box take the camera side's 0.505 or the light side's 0.01, and
    // Eq. 12 leans towards the smaller integrand, so its bias is smaller), measured (seeds 4, 5):
    // fixed -1.27%, -1.27%; consistent +0.19%, +0.21% at 64 spp and +0.10%, +0.10% at 1024 spp,
    // +0.13% (mean of the two) at 512, the late renders (for time).
    // Checks (means of seeds 4 and 5): the fixed bias below -5% (PT) or -0.8% (BPT); the consistent
    // bias late (1024 spp PT, 512 BPT) under a quarter of it and under the consistent bias at 64 spp.
    // (Uncompensated lobes, --reg-energy none: what is measured is the schedule; the compensation
    // keeps the widened lobe's albedo and leaves the blur, PT fixed -3.9%, BPT -0.1%.)
    SceneDesc desc = loadScene(std::string(LT_SOURCE_DIR) + "/scenes/cornell-box-ggx.xml", {{"res", "32"}, {"alpha", "0.01"}});
    Scene scene(desc);
    auto crop = [](const Image& img) { return cropMean(img, 32, 0, 0, 16, 10); };
    struct Case {
        std::string integrator;
        double fixedBelow;
        int late;  // spp of the late renders
    };
    for (const Case& c : {Case{"pt", -0.05, 1024}, Case{"bpt", -0.008, 512}}) {
        const std::string& integrator = c.integrator;
        auto bias = [&](int spp, bool consistent, uint64_t seed) {
            RenderSettings p = settingsFor(integrator, spp);
            p.maxDepth = 8;
            p.seed = seed;
            RenderSettings o = p;
            o.regularizer = "opsr";
            o.regOpsrGamma = 0.5;
            o.regOpsrConsistent = consistent;
            o.regLambda = consistent ? 0.45 : -1.0;
            o.regEnergy = "none";
            RenderStats a, b;
            const double plain = crop(renderImage(scene, p, a));
            return crop(renderImage(scene, o, b)) / plain - 1.0;
        };
        const double fixed = (bias(c.late, false, 4) + bias(c.late, false, 5)) / 2;
        const double early = (bias(64, true, 4) + bias(64, true, 5)) / 2;
        const double late = (bias(c.late, true, 4) + bias(c.late, true, 5)) / 2;
        INFO(integrator << " bias: fixed " << fixed << ", consistent at 64 spp " << early << ", at " << c.late
                        << " spp " << late);
        CHECK(fixed < c.fixedBelow);
        CHECK(std::abs(late) < 0.25 * std::abs(fixed));
        CHECK(std::abs(late) < std::abs(early));
    }
}

TEST_CASE("OPSR in a scene file: reg_opsr_table is found beside the scene, and renders", "[opsr][loader]") {
    // (reg_opsr_always_sample is read too: the path tracer's regularised sample at every vertex;
    // and reg_tail_rr, regularizer.h (9))
    // A table written here (every factor 0.5), a scene in the same folder naming it relative to
    // itself, loaded from another working directory: the loader resolves the file as it does mesh
    // files, and the render uses it (the glossy sphere after the diffuse floor is regularised).
    const auto dir = tempDir("lt_opsr", "scene");
    nlohmann::json t;
    for (int k = 2; k <= 5; ++k) t["sets"]["half"]["tables"][std::to_string(k)] = std::vector<double>(size_t(std::pow(4, k)), 0.5);
    std::ofstream(dir / "half.json") << t.dump();
    std::ofstream(dir / "scene.xml") << R"(<scene version="3.0.0">
    <integrator type="path">
        <integer name="max_depth" value="4"/>
        <string name="regularizer" value="opsr"/>
        <string name="reg_opsr_table" value="half.json:half"/>
        <boolean name="reg_opsr_always_sample" value="true"/>
        <float name="reg_tail_rr" value="0.5"/>
    </integrator>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 1, 4" target="0, 0.3, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="-90"/><scale value="5"/></transform>
        <bsdf type="diffuse"/>
    </shape>
    <shape type="sphere">
        <point name="center" value="0, 0.5, 0"/><float name="radius" value="0.5"/>
        <bsdf type="roughconductor"><float name="alpha" value="0.02"/></bsdf>
    </shape>
    <emitter type="point"><point name="position" value="0, 3, 1"/><rgb name="intensity" value="10, 10, 10"/></emitter>
</scene>
)";
    const auto cwd = std::filesystem::current_path();
    std::filesystem::current_path(std::filesystem::temp_directory_path());
    SceneDesc desc = loadScene((dir / "scene.xml").string(), {});
    std::filesystem::current_path(cwd);
    CHECK(desc.integrator.regOpsrTable == (dir / "half.json").lexically_normal().string() + ":half");
    CHECK(desc.integrator.regOpsrAlwaysSample);
    CHECK(desc.integrator.regTailRr == 0.5);
    Scene scene(desc);
    RenderSettings s = settingsFor("pt", 16);
    s.regularizer = desc.integrator.regularizer;
    s.regOpsrTable = desc.integrator.regOpsrTable;
    RenderStats st;
    renderImage(scene, s, st);
    CHECK(st.regularisedContributions > 0);
    std::filesystem::remove_all(dir);
}

TEST_CASE("OPSR 'moderate' on the rough-and-smooth glass caustics: less error than plain PT at equal spp, against the committed reference", "[opsr][render][hard]") {
    // scenes/hard/caustic-roughness.xml (the paper's setting: glass spheres of alpha 0, 0.05 and
    // 0.2 under a small area light) at 64^2 against its committed reference
    // (scenes/hard/refs/caustic-roughness.exr: VCM, 22,700 spp). Plain PT reaches the smooth
    // sphere's caustic only by BSDF-sampled rays from the floor that hit the small light through
    // the glass (fireflies: the worst 1% of pixels carry 86-88% of its relMSE); OPSR's 'moderate'
    // set makes the glass rough after the diffuse floor, so next-event estimation reaches it.
    // Measured, 256 spp, seeds 1-4: plain PT relMSE 0.0517, 0.0592, 0.0220, 0.0332 (mean 0.0415;
    // seeds 5, 6: 0.0405, 0.0366), 'moderate' 0.0187, 0.0187, 0.0185, 0.0175 (mean 0.0184), the
    // constant gamma 0.01 0.0215, 0.0392, 0.0287, 0.0169. Check: the 4-seed mean under 0.7x plain
    // PT's (measured 0.44x; plain PT's mean varies by about 25% between disjoint seed sets, so
    // 0.7 leaves that margin). KD13 changes nothing here (an area light: every path is
    // samplable): bit-identical to plain PT.
    if (!std::filesystem::exists(kOpsrReferenceFile)) {
        WARN("SKIPPED: " << kOpsrReferenceFile << " not found (the OPSR reference attenuation file)");
        return;
    }
    const std::string dir = std::string(LT_SOURCE_DIR) + "/scenes/hard/";
    const Scene scene(loadScene(dir + "caustic-roughness.xml", {{"res", "64"}}));
    const Image ref = readImage(dir + "refs/caustic-roughness.exr");
    double plain = 0.0, moderate = 0.0;
    for (uint64_t seed : {1, 2, 3, 4}) {
        RenderSettings p = settingsFor("pt", 256);
        p.maxDepth = 10;
        p.seed = seed;
        RenderSettings o = p, k = p;
        o.regularizer = "opsr";
        o.regOpsrTable = kOpsrReferenceFile + ":moderate";
        k.regularizer = "kd13";
        RenderStats a, b, c;
        const Image ip = renderImage(scene, p, a);
        const double ep = computeMetrics(ip, ref).relMse, eo = computeMetrics(renderImage(scene, o, b), ref).relMse;
        UNSCOPED_INFO("seed " << seed << ": plain PT " << ep << ", OPSR moderate " << eo);
        plain += ep / 4, moderate += eo / 4;
        CHECK(b.regularisedContributions > 0);
        if (seed == 1) CHECK(differingPixels(ip, renderImage(scene, k, c)) == 0);
    }
    INFO("relMSE means: plain PT " << plain << ", OPSR moderate " << moderate);
    CHECK(moderate < 0.7 * plain);
}
