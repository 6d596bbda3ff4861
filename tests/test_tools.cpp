// The speed-against-error tools end to end (docs/tools.md): convergence (slope of relMSE against
// spp for an unbiased method, the CSV columns, the plots), biasvar (PT unbiased by a z-test; VCM
// and PPM biased with a bias that falls), reference + merge (sample-weighted merging, scene hash,
// caching), report (well-formed XHTML, optional headless-chromium screenshot) and a bench smoke run.
// Every test renders tiny images (16x16 or 32x32) with fixed seeds.
#include <catch2/catch.hpp>
#include "process.h"
#include <stb/stb_image.h>
#include <sys/wait.h>
#include <unistd.h>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <nlohmann/json.hpp>
#include <pugixml.hpp>
#include "core/image.h"
#include "core/metrics.h"
#include "tools/analysis.h"

namespace fs = std::filesystem;
using lt::test::Run;
using lt::test::sh;
using nlohmann::json;

namespace {

std::string tool(const std::string& name) { return std::string(LT_TOOLS_DIR) + "/" + name; }
std::string scene(const std::string& name) { return std::string(LT_SOURCE_DIR) + "/scenes/" + name; }

fs::path tempDir(const std::string& name) { return lt::test::tempDir("lt_tools", name); }

json readJson(const fs::path& p) { return json::parse(lt::analysis::readFile(p.string())); }

bool isPng(const fs::path& p) {
    if (!fs::exists(p) || fs::file_size(p) < 100) return false;
    std::string s = lt::analysis::readFile(p.string());
    return s.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0;
}

// The cornell box, tiny and shallow, and its PT reference rendered by the `reference` tool.
fs::path makeReference(const fs::path& dir, int res, int spp, const std::string& extra = "",
                       const std::string& sceneFile = "cornell-box.xml") {
    fs::path ref = dir / "ref.exr";
    Run r = sh(tool("reference") + " " + scene(sceneFile) + " -D res=" + std::to_string(res) +
               " -D max_depth=4 --spp " + std::to_string(spp) + " --chunks 2 -o " + ref.string() + " " + extra);
    INFO(r.output);
    REQUIRE(r.code == 0);
    return ref;
}

}  // namespace

TEST_CASE("convergence: PT relMSE falls as spp^-1, the CSV has the documented columns, the plots exist", "[tools][convergence]") {
    fs::path dir = tempDir("conv");
    // Reference: 4096 spp. Checkpoints go to 64 spp, so the reference's own noise adds at most
    // 64/4096 = 1.6% to the last relMSE (a slope change below 0.01).
    fs::path ref = makeReference(dir, 32, 4096);
    Run r = sh(tool("convergence") + " " + scene("cornell-box.xml") + " -D res=32 -D max_depth=4 -r " + ref.string() +
               " -c pt -c 'pt --pt-strategy bsdf --label PT-bsdf' --spp 64 --seed 1 -o " + (dir / "conv").string());
    INFO(r.output);
    REQUIRE(r.code == 0);
    json j = readJson(dir / "conv/convergence.json");
    REQUIRE(j["configs"].size() == 2);
    // Tolerance: over seeds 1..30 this setup gave slopes with mean -0.99 and standard deviation 0.04
    // (min -1.07, max -0.91); +-0.15 is about 4 standard deviations, while a wrong reference, a
    // biased estimator or a sqrt(N) error law lands far outside (checked below).
    double slope = j["configs"][0]["slope_spp"].get<double>();
    CHECK(j["configs"][0]["label"] == "pt");
    CHECK(slope == Approx(-1.0).margin(0.15));
    CHECK(j["configs"][1]["label"] == "PT-bsdf");
    CHECK(j["configs"][1]["slope_spp"].get<double>() < -0.5);

    // CSV: the documented columns; the last row of each configuration is its final image's error.
    std::ifstream csv(dir / "conv/convergence.csv");
    std::string line;
    REQUIRE(std::getline(csv, line));
    CHECK(line == "config,spp,seconds,mse,relmse,rmsre,mape");
    std::map<std::string, std::vector<std::vector<std::string>>> rows;
    while (std::getline(csv, line)) {
        auto f = lt::analysis::splitCsvLine(line);
        REQUIRE(f.size() == 7);
        rows[f[0]].push_back(f);
    }
    REQUIRE(rows.size() == 2);
    std::vector<std::string> spps;
    for (const auto& f : rows["pt"]) spps.push_back(f[1]);
    for (const char* s : {"1", "2", "4", "8", "16", "32", "64"})
        CHECK(std::find(spps.begin(), spps.end(), s) != spps.end());
    double prevSeconds = 0;
    for (const auto& f : rows["pt"]) {
        CHECK(std::stod(f[2]) >= prevSeconds);
        prevSeconds = std::stod(f[2]);
    }
    lt::Image img = lt::readImage((dir / "conv/images/pt.exr").string());
    lt::ErrorMetrics m = lt::computeMetrics(img, lt::readImage(ref.string()));
    CHECK(rows["pt"].back()[1] == "64");
    CHECK(std::stod(rows["pt"].back()[4]) == Approx(m.relMse).epsilon(1e-6));
    CHECK(std::stod(rows["pt"].back()[5]) == Approx(m.rmsRelErr).epsilon(1e-6));
    CHECK(std::stod(rows["pt"].back()[3]) == Approx(m.mse).epsilon(1e-6));
    CHECK(std::stod(rows["pt"].back()[6]) == Approx(m.mape).epsilon(1e-6));

    if (lt::analysis::gnuplotAvailable()) {
        CHECK(isPng(dir / "conv/convergence.png"));
        std::string svg = lt::analysis::readFile((dir / "conv/convergence.svg").string());
        CHECK(svg.find("<svg") != std::string::npos);
        CHECK(svg.find("slope") != std::string::npos);            // slopes in the legend
        CHECK(svg.find("samples per pixel") != std::string::npos);  // labelled axes
        CHECK(svg.find("render time [s]") != std::string::npos);
    } else {
        WARN("SKIPPED the plot checks: gnuplot is not installed (Debian package gnuplot-nox)");
    }
    CHECK(fs::file_size(dir / "conv/convergence.gp") > 0);

    // The check can fail: against the reference of a different scene (max_depth 2 instead of 4)
    // the error stops falling and the slope flattens.
    Run bad = sh(tool("convergence") + " " + scene("cornell-box.xml") + " -D res=32 -D max_depth=2 -r " + ref.string() +
                 " -c pt --spp 64 --seed 1 --no-images -o " + (dir / "bad").string());
    REQUIRE(bad.code == 0);
    CHECK(readJson(dir / "bad/convergence.json")["configs"][0]["slope_spp"].get<double>() > -0.6);

    // Bad input: a reference of the wrong size is refused with exit code 2.
    Run size = sh(tool("convergence") + " " + scene("cornell-box.xml") + " -D res=16 -r " + ref.string() + " -c pt --spp 2 -o " +
                  (dir / "x").string());
    CHECK(size.code == 2);
    CHECK(size.output.find("32x32") != std::string::npos);
    Run cfg = sh(tool("convergence") + " " + scene("cornell-box.xml") + " -D res=32 -r " + ref.string() + " -c 'nope' -o " +
                 (dir / "x").string());
    CHECK(cfg.code == 1);
    CHECK(cfg.output.find("nope") != std::string::npos);
    fs::remove_all(dir);
}

TEST_CASE("biasvar: the PT bias^2 is indistinguishable from zero and a wrong depth is detected", "[tools][biasvar]") {
    fs::path dir = tempDir("bvpt");
    // 16 runs x 8 spp = 128 samples per pixel per level against a 4096-spp reference: the
    // reference's variance adds var/4096 to E[bias2_hat], at most 0.35 standard errors here.
    fs::path ref = makeReference(dir, 16, 4096);
    Run r = sh(tool("biasvar") + " " + scene("cornell-box.xml") + " -D res=16 -D max_depth=4 -r " + ref.string() +
               " -c pt -k 16 --spp 2 --spp 8 -o " + (dir / "bv").string());
    INFO(r.output);
    REQUIRE(r.code == 0);
    json j = readJson(dir / "bv/biasvar.json");
    REQUIRE(j["configs"].size() == 1);
    REQUIRE(j["configs"][0]["levels"].size() == 2);
    // Two-sided z-test of H0: bias^2 = 0 at significance 0.001 per test (|z| < 3.29); 4 tests, so
    // the family-wise false-alarm rate is below 0.4% (and the seeds are fixed).
    for (const auto& lvl : j["configs"][0]["levels"]) {
        for (const char* kind : {"absolute", "relative"}) {
            INFO("spp " << lvl["spp"] << " " << kind << ": " << lvl[kind].dump());
            CHECK(std::abs(lvl[kind]["bias2_z"].get<double>()) < 3.29);
            CHECK(lvl[kind]["check_ok"].get<bool>());
            CHECK(lvl[kind]["identity_rel_diff"].get<double>() < 1e-5);
            CHECK(lvl[kind]["variance"].get<double>() > 0);
        }
    }
    // Variance of one render falls as 1/spp: 4x the spp, about a quarter of the variance.
    double v2 = j["configs"][0]["levels"][0]["relative"]["variance"], v8 = j["configs"][0]["levels"][1]["relative"]["variance"];
    CHECK(v2 / v8 == Approx(4.0).epsilon(0.35));
    for (const char* f : {"mean.exr", "variance.exr", "bias2.exr", "mse.exr", "variance.png", "bias2.png"})
        CHECK(fs::exists(dir / "bv/pt/spp8" / f));
    lt::Image var = lt::readImage((dir / "bv/pt/spp8/variance.exr").string());
    CHECK(var.width == 16);
    if (lt::analysis::gnuplotAvailable()) CHECK(isPng(dir / "bv/biasvar.png"));

    // The test has power: paths cut at 2 segments (direct light only) against the 4-segment
    // reference are biased, and the z-test says so at every spp.
    Run b = sh(tool("biasvar") + " " + scene("cornell-box.xml") + " -D res=16 -D max_depth=2 -r " + ref.string() +
               " -c pt -k 16 --spp 2 --spp 8 -o " + (dir / "bv2").string());
    REQUIRE(b.code == 0);
    for (const auto& lvl : readJson(dir / "bv2/biasvar.json")["configs"][0]["levels"]) {
        CHECK(lvl["relative"]["bias2_z"].get<double>() > 3.29);
        CHECK(lvl["relative"]["biased"].get<bool>());
    }
    fs::remove_all(dir);
}

TEST_CASE("biasvar --sweep: one row per configuration, value and spp, and a wider bandwidth trades variance for bias", "[tools][biasvar][sweep]") {
    // PT+OPSR on the GGX box with the gold block at alpha 0.01 (16^2, max depth 4; reference: PT
    // without a regulariser, 4096 spp), gamma 0.05 and 0.5, 8 runs at 4 and 16 spp. gamma 0.5
    // blurs the block's highlight and the light it throws (the OPSR consistency test measures
    // -8% in the lit crop) and removes most of its variance: measured relative bias^2 -0.0020 and
    // 0.0079 (4 spp), -0.0011 and 0.0058 (16 spp); variance 0.21 and 0.033, 0.046 and 0.0089.
    // Checks: at both budgets gamma 0.5 has the larger bias^2 and under half the variance (a
    // sweep that mixed up its values or ran one value twice fails), and each row's MSE is its
    // bias^2 + variance (the estimators' identity).
    fs::path dir = tempDir("bvsweep");
    fs::path ref = makeReference(dir, 16, 4096, "-c pt -D alpha=0.01", "cornell-box-ggx.xml");
    Run r = sh(tool("biasvar") + " " + scene("cornell-box-ggx.xml") + " -D res=16 -D alpha=0.01 -D max_depth=4 -r " +
               ref.string() + " -c \"pt --reg opsr\" --sweep reg-opsr-gamma=0.5,0.05 -k 8 --spp 4,16 -o " +
               (dir / "bv").string());
    INFO(r.output);
    REQUIRE(r.code == 0);
    json j = readJson(dir / "bv/biasvar.json");
    CHECK(j["sweep"]["option"] == "reg-opsr-gamma");
    CHECK(j["sweep"]["values"].size() == 2);
    REQUIRE(j["configs"].size() == 2);
    CHECK(j["configs"][0]["label"] == "pt --reg opsr reg-opsr-gamma=0.05");
    std::ifstream csv(dir / "bv/sweep.csv");
    std::string line;
    std::getline(csv, line);
    CHECK(line == "config,option,value,spp,bias2,variance,mse");
    std::map<std::pair<double, int>, std::array<double, 3>> rows;  // (gamma, spp) -> bias2, variance, mse
    while (std::getline(csv, line)) {
        std::stringstream ss(line.substr(line.rfind('"') + 2));  // after the quoted label and its comma
        std::string option, cell;
        std::getline(ss, option, ',');
        CHECK(option == "reg-opsr-gamma");
        std::vector<double> v;
        while (std::getline(ss, cell, ',')) v.push_back(std::stod(cell));
        REQUIRE(v.size() == 5);
        rows[{v[0], int(v[1])}] = {v[2], v[3], v[4]};
        CHECK(v[4] == Approx(v[2] + v[3]).epsilon(1e-5));
    }
    REQUIRE(rows.size() == 4);
    for (int spp : {4, 16}) {
        const auto& narrow = rows.at({0.05, spp});
        const auto& wide = rows.at({0.5, spp});
        INFO("spp " << spp << ": bias2 " << narrow[0] << " / " << wide[0] << ", variance " << narrow[1] << " / " << wide[1]);
        CHECK(wide[0] > narrow[0]);
        CHECK(wide[1] < 0.5 * narrow[1]);
    }
    if (lt::analysis::gnuplotAvailable()) CHECK(isPng(dir / "bv/sweep.png"));
    // --crop: the figures over the rectangle only, i.e. the mean of the whole MSE map (written
    // uncropped) over its pixels; a crop outside the image is refused.
    Run c = sh(tool("biasvar") + " " + scene("cornell-box-ggx.xml") + " -D res=16 -D alpha=0.01 -D max_depth=4 -r " +
               ref.string() + " -c pt -k 4 --spp 4 --crop 2,3,5,6 -o " + (dir / "crop").string());
    INFO(c.output);
    REQUIRE(c.code == 0);
    json jc = readJson(dir / "crop/biasvar.json");
    CHECK(jc["crop"] == json::array({2, 3, 5, 6}));
    lt::Image mse = lt::readImage((dir / "crop/pt/spp4/mse.exr").string());
    double sum = 0.0;
    for (int yy = 3; yy < 9; ++yy)
        for (int xx = 2; xx < 7; ++xx)
            for (int k = 0; k < 3; ++k) sum += mse.pixels[size_t(yy) * 16 + xx][k];
    CHECK(jc["configs"][0]["levels"][0]["absolute"]["mse"].get<double>() == Approx(sum / 90.0).epsilon(1e-5));
    Run outside = sh(tool("biasvar") + " " + scene("cornell-box-ggx.xml") + " -D res=16 -r " + ref.string() +
                     " -c pt -k 4 --crop 10,10,8,8 -o " + (dir / "crop2").string());
    CHECK(outside.code == 1);
    CHECK(outside.output.find("not inside") != std::string::npos);
    // Bad sweeps: exit 1, naming the part that is wrong.
    for (const auto& [sweep, named] : std::vector<std::pair<std::string, std::string>>{
             {"reg-tau", "no '='"}, {"reg-tau=0,3", "value '0'"}, {"reg-tau=3,x", "value 'x'"}, {"reg-tau=3,3", "twice"},
             {"nope=1", "--nope"}}) {
        Run b = sh(tool("biasvar") + " " + scene("cornell-box.xml") + " -D res=8 -r " + ref.string() +
                   " -c \"pt --reg jg19\" --sweep " + sweep + " -k 4 -o " + (dir / "bad").string());
        INFO(sweep << ": " << b.output);
        CHECK(b.code == 1);
        CHECK(b.output.find(named) != std::string::npos);
    }
    fs::remove_all(dir);
}

TEST_CASE("biasvar: VCM and PPM have a positive bias^2 that falls with spp", "[tools][biasvar]") {
    std::vector<std::string> names;
    for (const char* n : {"ppm", "vcm"})
        if (lt::analysis::integratorAvailable(n)) names.push_back(n);
    if (names.empty()) {
        WARN("SKIPPED: neither ppm nor vcm is available in this build (supported: " << lt::supportedIntegrators() << ")");
        return;
    }
    fs::path dir = tempDir("bvvcm");
    fs::path ref = makeReference(dir, 32, 2048);
    // A large initial radius (0.4 in a room of size 2) and fast reduction (alpha 0.5: r_i = r_0 i^-1/4)
    // make the bias clear at 1 spp and visibly smaller at 64 spp.
    std::string cmd = tool("biasvar") + " " + scene("cornell-box.xml") + " -D res=32 -D max_depth=4 -r " + ref.string() +
                      " -k 12 --spp 1 --spp 8 --spp 64 -o " + (dir / "bv").string();
    for (const auto& n : names) cmd += " -c '" + n + " --radius 0.4 --radius-alpha 0.5'";
    Run r = sh(cmd);
    INFO(r.output);
    REQUIRE(r.code == 0);
    json j = readJson(dir / "bv/biasvar.json");
    REQUIRE(j["configs"].size() == names.size());
    for (const auto& c : j["configs"]) {
        INFO(c["label"]);
        const json& lo = c["levels"].front()["relative"];
        const json& hi = c["levels"].back()["relative"];
        // Biased at 1 spp (one-sided z > 3.29) ...
        CHECK(lo["bias2_z"].get<double>() > 3.29);
        // ... and the bias falls: the drop from 1 to 64 spp is more than 3 standard errors (the
        // levels are nested renders, positively correlated, so this is conservative).
        double drop = lo["bias2"].get<double>() - hi["bias2"].get<double>();
        double se = std::hypot(lo["bias2_stderr"].get<double>(), hi["bias2_stderr"].get<double>());
        CHECK(drop > 3 * se);
        CHECK(hi["bias2"].get<double>() > 0);
    }
    fs::remove_all(dir);
}

// JG19's consistent schedule (Eq. 16: tau_N grows with the iteration index N) against the fixed
// one, with biasvar, on the GGX Cornell box (gold box, alpha 0.1), BPT, tau_0 = 30 (the default),
// 32 x 32, maximum depth 4, K = 12 independent renders per configuration at 4, 32 and 512 spp
// (nested levels), against an unregularised BPT reference of 4096 spp. The quality heuristic is
// off: with it this scene is not regularised at all (BPT samples the box's reflections well,
// tests/test_jg19.cpp), and the schedule is the same either way. Measured (Eq. 12 weights,
// jg19.h (3)): consistent bias^2 0.0036, 0.0024, 0.0013 (falls; z 5.0 from 4 and 3.8 from 32 spp),
// fixed 0.0040, 0.0037, 0.0036 (plateau, z 0.7), at 512 spp consistent below fixed by z 5.4.
// (With the earlier, inverted weights the bias was twice this, and 256 spp sufficed; with these
// the step from 32 to 256 spp was 2.9 standard errors, hence 512.) Checks, each at 3 standard
// errors (one-sided normal tail 1.3e-3; the levels are nested renders, positively correlated, so
// differences are conservative): both biased at 4 spp (z > 3.29); the consistent bias falls from
// 4 to 512 and from 32 to 512 spp; the fixed one does not fall (4 to 512 within 3 standard
// errors); at 512 spp the consistent bias is below the fixed one. A schedule that silently stayed
// fixed fails the second and third checks.
TEST_CASE("biasvar: JG19's consistent schedule makes the bias fall, the fixed one plateaus", "[tools][biasvar][jg19]") {
    fs::path dir = tempDir("bvjg19");
    const std::string sceneFile = "cornell-box-ggx.xml";
    fs::path ref = makeReference(dir, 32, 4096, "-c bpt", sceneFile);
    Run r = sh(tool("biasvar") + " " + scene(sceneFile) + " -D res=32 -D max_depth=4 -r " + ref.string() +
               " -k 12 --spp 4 --spp 32 --spp 512 -o " + (dir / "bv").string() +
               " -c 'bpt --reg jg19 --reg-quality off --label consistent'"
               " -c 'bpt --reg jg19 --reg-quality off --reg-schedule fixed --label fixed'");
    INFO(r.output);
    REQUIRE(r.code == 0);
    json j = readJson(dir / "bv/biasvar.json");
    REQUIRE(j["configs"].size() == 2);
    auto level = [&](int config, int i) { return j["configs"][config]["levels"][i]["relative"]; };
    auto b2 = [&](int c, int i) { return level(c, i)["bias2"].get<double>(); };
    auto se = [&](int c, int i) { return level(c, i)["bias2_stderr"].get<double>(); };
    REQUIRE(j["configs"][0]["label"] == "consistent");
    for (int c = 0; c < 2; ++c) {
        INFO(j["configs"][c]["label"] << ": bias^2 " << b2(c, 0) << ", " << b2(c, 1) << ", " << b2(c, 2));
        CHECK(level(c, 0)["bias2_z"].get<double>() > 3.29);
    }
    INFO("consistent " << b2(0, 0) << ", " << b2(0, 1) << ", " << b2(0, 2) << "; fixed " << b2(1, 0) << ", "
                       << b2(1, 1) << ", " << b2(1, 2));
    CHECK(b2(0, 0) - b2(0, 2) > 3 * std::hypot(se(0, 0), se(0, 2)));  // measured: 5.0 standard errors
    CHECK(b2(0, 1) - b2(0, 2) > 3 * std::hypot(se(0, 1), se(0, 2)));  // 3.8 (4 to 32 spp: not checked)
    CHECK(std::abs(b2(1, 0) - b2(1, 2)) < 3 * std::hypot(se(1, 0), se(1, 2)));
    CHECK(b2(1, 2) - b2(0, 2) > 3 * std::hypot(se(1, 2), se(0, 2)));
    fs::remove_all(dir);
}

TEST_CASE("merge: sample-weighted average from sidecars, and reference: chunks, hash, caching", "[tools][merge]") {
    fs::path dir = tempDir("merge");
    std::string base = std::string(LT_RENDER_BIN) + " " + scene("cornell-box.xml") + " -D res=16 -D max_depth=4 --quiet ";
    struct R { const char* name; int spp; int seed; };
    for (R x : {R{"a", 3, 11}, R{"b", 5, 12}, R{"c", 8, 13}}) {
        std::string p = (dir / x.name).string();
        Run r = sh(base + "--spp " + std::to_string(x.spp) + " --seed " + std::to_string(x.seed) + " -o " + p + ".exr --stats-json " + p + ".json");
        REQUIRE(r.code == 0);
    }
    Run m = sh(tool("merge") + " -o " + (dir / "m.exr").string() + " " + (dir / "a.exr").string() + " " + (dir / "b.exr").string());
    INFO(m.output);
    REQUIRE(m.code == 0);
    lt::Image a = lt::readImage((dir / "a.exr").string()), b = lt::readImage((dir / "b.exr").string());
    lt::Image merged = lt::readImage((dir / "m.exr").string());
    double maxRel = 0;
    for (size_t i = 0; i < a.pixels.size(); ++i)
        for (int c = 0; c < 3; ++c) {
            double want = (3.0 * a.pixels[i][c] + 5.0 * b.pixels[i][c]) / 8.0;
            maxRel = std::max(maxRel, std::abs(merged.pixels[i][c] - want) / std::max(1e-6, std::abs(want)));
        }
    CHECK(maxRel < 1e-6);
    json mj = readJson(dir / "m.json");
    CHECK(mj["spp"].get<double>() == 8);
    CHECK(mj["inputs"][0]["weight"].get<double>() == Approx(3.0 / 8.0));
    CHECK(fs::exists(dir / "m.png"));
    // Weights from --spp override the sidecars.
    REQUIRE(sh(tool("merge") + " -o " + (dir / "m2.exr").string() + " --spp 1 --spp 1 " + (dir / "a.exr").string() + " " +
               (dir / "b.exr").string()).code == 0);
    lt::Image m2 = lt::readImage((dir / "m2.exr").string());
    CHECK(m2.pixels[37].y == Approx(0.5f * (a.pixels[37].y + b.pixels[37].y)).epsilon(1e-6));
    // Inputs with the same seed are not independent: refused.
    Run same = sh(tool("merge") + " -o " + (dir / "m3.exr").string() + " " + (dir / "a.exr").string() + " " + (dir / "a.exr").string());
    CHECK(same.code == 1);
    CHECK(same.output.find("seed") != std::string::npos);
    // The merged halves (3 + 5 spp) are as good as the 8-spp render: same error against the
    // 8-spp render's expectation up to noise (both are 8-spp estimates).
    fs::path ref = makeReference(dir, 16, 1024, "--seed 99");
    lt::Image refImg = lt::readImage(ref.string()), c8 = lt::readImage((dir / "c.exr").string());
    double e1 = lt::computeMetrics(merged, refImg).relMse, e2 = lt::computeMetrics(c8, refImg).relMse;
    CHECK(e1 / e2 == Approx(1.0).margin(0.5));

    // reference: the merged image is the spp-weighted mean of its chunks, each an ordinary render
    // with seed + i; the sidecar records the command and the scene hash.
    fs::path rdir = dir / "r";
    fs::create_directories(rdir);
    Run rr = sh(tool("reference") + " " + scene("cornell-box.xml") + " -D res=16 -D max_depth=4 --spp 10 --chunks 2 --seed 500 -o " + (rdir / "ref.exr").string());
    INFO(rr.output);
    REQUIRE(rr.code == 0);
    json rj = readJson(rdir / "ref.json");
    CHECK(rj["spp"] == 10);
    CHECK(rj["scene_sha256"].get<std::string>().size() == 64);
    CHECK(rj["command"].get<std::string>().find("--spp 10") != std::string::npos);
    CHECK(rj["scene_files"].size() == 3);  // the scene and its two included fragments
    CHECK(rj["chunks"][1]["seed"] == 501);
    REQUIRE(sh(base + "--spp 5 --seed 500 -o " + (rdir / "c0.exr").string()).code == 0);
    lt::Image c0 = lt::readImage((rdir / "c0.exr").string()), ch0 = lt::readImage((rdir / "ref.chunks/chunk0.exr").string());
    lt::Image ch1 = lt::readImage((rdir / "ref.chunks/chunk1.exr").string()), full = lt::readImage((rdir / "ref.exr").string());
    for (size_t i = 0; i < c0.pixels.size(); i += 7) {
        CHECK(ch0.pixels[i].x == c0.pixels[i].x);
        CHECK(full.pixels[i].z == Approx(0.5 * (ch0.pixels[i].z + ch1.pixels[i].z)).epsilon(1e-6));
    }
    Run again = sh(tool("reference") + " " + scene("cornell-box.xml") + " -D res=16 -D max_depth=4 --spp 10 --chunks 2 --seed 500 -o " + (rdir / "ref.exr").string());
    CHECK(again.output.find("up to date") != std::string::npos);
    // The hash covers included files: a changed fragment makes the reference stale.
    fs::path sc = dir / "scene";
    fs::create_directories(sc / "fragments");
    for (const char* f : {"cornell-box.xml", "fragments/cornell-room.xml", "fragments/cornell-light.xml"})
        fs::copy_file(scene(f), sc / f);
    std::string rcmd = tool("reference") + " " + (sc / "cornell-box.xml").string() + " -D res=16 --spp 2 --chunks 2 -o " + (sc / "ref.exr").string();
    REQUIRE(sh(rcmd).code == 0);
    CHECK(sh(rcmd + " --check").code == 0);
    { std::ofstream(sc / "fragments/cornell-light.xml", std::ios::app) << "<!-- changed -->\n"; }
    CHECK(sh(rcmd + " --check").code == 5);
    fs::remove_all(dir);
}

namespace {

// Well-formedness of an XHTML page with pugixml; returns the error or "".
std::string xmlError(const std::string& text, pugi::xml_document& doc) {
    pugi::xml_parse_result res = doc.load_string(text.c_str(), pugi::parse_default | pugi::parse_doctype);
    return res ? std::string() : std::string(res.description()) + " at offset " + std::to_string(res.offset);
}

}  // namespace

TEST_CASE("report: a well-formed self-contained page with table, images, crops, maps and plots", "[tools][report]") {
    pugi::xml_document broken;
    REQUIRE_FALSE(xmlError("<html><body><p>unclosed</body></html>", broken).empty());  // the check can fail

    fs::path dir = tempDir("report");
    fs::path ref = makeReference(dir, 16, 1024);
    std::string common = scene("cornell-box.xml") + " -D res=16 -D max_depth=4 -r " + ref.string() + " -c pt -c 'pt --pt-strategy nee'";
    REQUIRE(sh(tool("convergence") + " " + common + " --spp 16 -o " + (dir / "conv").string()).code == 0);
    REQUIRE(sh(tool("biasvar") + " " + common + " -k 4 --spp 2 --spp 4 -o " + (dir / "bv").string()).code == 0);
    fs::path html = dir / "page.html";
    Run r = sh(tool("report") + " --convergence " + (dir / "conv").string() + " --biasvar " + (dir / "bv").string() +
               " --crop 2,2,6,6 --crop 8,0,8,4 -o " + html.string());
    INFO(r.output);
    REQUIRE(r.code == 0);
    std::string text = lt::analysis::readFile(html.string());
    pugi::xml_document doc;
    std::string err = xmlError(text, doc);
    INFO(err);
    REQUIRE(err.empty());
    pugi::xml_node root = doc.child("html");
    REQUIRE(root);
    CHECK(root.child("head").child("title"));
    pugi::xml_node body = root.child("body");
    REQUIRE(body);
    // The table: a header and one row per configuration with the listed columns.
    pugi::xml_node table = body.find_node([](pugi::xml_node n) { return std::string(n.name()) == "table"; });
    REQUIRE(table);
    std::vector<pugi::xml_node> trs;
    for (auto tr : table.children("tr")) trs.push_back(tr);
    REQUIRE(trs.size() == 3);
    std::string head;
    for (auto th : trs[0].children("th")) head += std::string(th.text().get()) + "|";
    for (const char* col : {"time [s]", "spp", "relMSE", "RMS-RE", "MAPE", "bias", "variance"})
        CHECK(head.find(col) != std::string::npos);
    CHECK(std::string(trs[1].first_child().text().get()) == "pt");
    // bias and variance were filled in from biasvar (not a dash).
    std::vector<std::string> cells;
    for (auto td : trs[1].children("td")) cells.push_back(td.text().get());
    CHECK(cells[7].find("\u00b1") != std::string::npos);
    // Images: reference + 2 renders, 2 crops x 3, 2 error maps, 2 plots, 2 x 2 bias/variance maps;
    // all embedded as data URIs (self-contained).
    int imgs = 0, dataUris = 0;
    for (auto n : body.select_nodes("//img")) {
        ++imgs;
        std::string src = n.node().attribute("src").value();
        if (src.rfind("data:image/png;base64,", 0) == 0 || src.rfind("data:image/svg+xml;base64,", 0) == 0) ++dataUris;
    }
    CHECK(imgs == 3 + 6 + 2 + (lt::analysis::gnuplotAvailable() ? 2 : 0) + 4);
    CHECK(dataUris == imgs);
    CHECK(text.find("file://") == std::string::npos);
    CHECK(text.find("http://") == text.find("http://www.w3.org/1999/xhtml"));  // nothing fetched from the net

    // A bad crop is refused.
    CHECK(sh(tool("report") + " --convergence " + (dir / "conv").string() + " --crop 10,10,10,10 -o " + (dir / "x.html").string()).code == 1);

    // A biasvar sweep beside it: its plot of MSE against the bandwidth, and the command, on the page.
    REQUIRE(sh(tool("biasvar") + " " + scene("cornell-box.xml") + " -D res=16 -D max_depth=4 -r " + ref.string() +
               " -c 'pt --reg jg19 --reg-schedule fixed' --sweep reg-tau=3,30 -k 4 --spp 2 -o " + (dir / "sweep").string())
                .code == 0);
    Run sw = sh(tool("report") + " --convergence " + (dir / "conv").string() + " --biasvar " + (dir / "sweep").string() +
                " -o " + (dir / "sweep.html").string());
    REQUIRE(sw.code == 0);
    const std::string swText = lt::analysis::readFile((dir / "sweep.html").string());
    pugi::xml_document swDoc;
    CHECK(xmlError(swText, swDoc).empty());
    CHECK(swText.find("MSE against reg-tau") != std::string::npos);
    CHECK(swText.find("--sweep reg-tau=3,30") != std::string::npos);
    if (lt::analysis::gnuplotAvailable()) CHECK(swText.find("data:image/svg+xml;base64,") != std::string::npos);

    // Rendered by a browser, where one is installed (not required).
    if (!fs::exists("/usr/bin/chromium")) {
        WARN("SKIPPED the screenshot: /usr/bin/chromium is not installed");
        fs::remove_all(dir);
        return;
    }
    fs::path profile = dir / "chromium-profile", shot = dir / "shot.png";
    Run c = sh("timeout 120 /usr/bin/chromium --headless --no-sandbox --disable-gpu --disable-background-networking "
               "--disable-component-update --disable-sync --no-first-run --user-data-dir=" + profile.string() +
               " --screenshot=" + shot.string() + " --window-size=1200,900 file://" + html.string());
    INFO(c.output);
    REQUIRE(isPng(shot));
    int w = 0, h = 0, n = 0;
    unsigned char* px = stbi_load(shot.string().c_str(), &w, &h, &n, 3);
    REQUIRE(px);
    CHECK(w == 1200);
    // Not a blank page: the pixels vary.
    double sum = 0, sq = 0;
    for (int i = 0; i < w * h * 3; ++i) sum += px[i], sq += double(px[i]) * px[i];
    stbi_image_free(px);
    double mean = sum / (w * h * 3), var = sq / (w * h * 3) - mean * mean;
    CHECK(var > 100.0);
    fs::remove_all(dir);
}

TEST_CASE("bench: a one-scene smoke run writes the markdown table and the machine", "[tools][bench]") {
    fs::path dir = tempDir("bench");
    Run r = sh(tool("bench") + " --scenes " + scene("cornell-box.xml") + " --integrators pt --time 0.2 --ref-time 0.5 "
               "--res 16 --opsr-table none --out-dir " + (dir / "out").string() + " -o " + (dir / "B.md").string());
    INFO(r.output);
    REQUIRE(r.code == 0);
    std::string md = lt::analysis::readFile((dir / "B.md").string());
    CHECK(md.find("| configuration | time [s] | spp | samples/s | relMSE | RMS-RE | MAPE | top-1% share | mean bias | "
                  "regularised | relMSE outside | bias outside |") != std::string::npos);
    // time, spp, samples/s, relMSE, RMS-RE, MAPE, the top-1% share in [0, 1] with three decimals,
    // the mean's bias in percent, the regularised share (none without a regulariser) and the
    // relMSE outside the singular pixels (none here: an area light).
    const std::string metrics = R"( \| [0-9.]+ \| [0-9]+ \| [0-9.e+]+ \| [0-9.e+-]+ \| [0-9.e+-]+ \| [0-9.e+-]+ \| )"
                                R"([01]\.[0-9]{3} \| [+-][0-9]+\.[0-9]{2}% \| )";
    CHECK(std::regex_search(md, std::regex(R"(\| pt)" + metrics + R"(- \| - \| - \|\n)")));
    // PT with each regulariser beside it (default --regularizers: all), and the summary of its
    // error over PT's.
    CHECK(std::regex_search(md, std::regex(R"(\| pt\+jg19)" + metrics + R"([0-9.]+% \| - \| - \|\n)")));
    CHECK(md.find("Paths no unregularised technique can produce") == std::string::npos);
    // (Every regulariser: JG19, JG19 with cones, KD13 and OPSR, each with PT, BPT and VCM.)
    CHECK(std::regex_search(md, std::regex(R"(## Regularisation at equal time[^]*\| scene \| pt\+jg19 \| bpt\+jg19 \| )"
                                           R"(vcm\+jg19 \| pt\+jg19cone \| bpt\+jg19cone \| vcm\+jg19cone \| )"
                                           R"(pt\+kd13 \| bpt\+kd13 \| vcm\+kd13 \| pt\+opsr \| bpt\+opsr \| vcm\+opsr \|\n)"
                                           R"(\|---\|(---:\|){12}\n\| cornell-box \| [0-9.e+-]+ / )"
                                           R"([0-9.e+-]+ \| - \| - \| [0-9.e+-]+ / [0-9.e+-]+ \| - \| - \| )"
                                           R"([0-9.e+-]+ / [0-9.e+-]+ \| - \| - \| [0-9.e+-]+ / [0-9.e+-]+ \| - \| - \|\n)")));
    // A point light in a glass ball: the light seen through the glass is singular (only JG19's
    // connections at the glass render it, the VCM reference has none of it). Its pixels are named
    // and left out of the last column, for every configuration, and the summary gives that ratio.
    Run g = sh(tool("bench") + " --scenes " + scene("cornell-box-point-in-glass.xml") + " --integrators pt,bpt --time 0.2 "
               "--ref-time 0.5 --res 16 --out-dir " + (dir / "out").string() + " -o " + (dir / "G.md").string());
    INFO(g.output);
    REQUIRE(g.code == 0);
    const std::string gmd = lt::analysis::readFile((dir / "G.md").string());
    std::smatch count;
    REQUIRE(std::regex_search(gmd, count, std::regex(R"(make up more than 1% of ([0-9]+) of the 256 pixels)")));
    CHECK(std::stoi(count[1]) > 0);
    CHECK(std::stoi(count[1]) < 256);
    // (and the image mean's bias outside them, in percent)
    CHECK(std::regex_search(gmd, std::regex(R"(\| bpt)" + metrics + R"(- \| [0-9.e+-]+ \| [+-][0-9]+\.[0-9]{2}% \|\n)")));
    CHECK(std::regex_search(gmd, std::regex(R"(\| pt\+jg19)" + metrics + R"([0-9.]+% \| [0-9.e+-]+ \| [+-][0-9]+\.[0-9]{2}% \|\n)")));
    CHECK(std::regex_search(gmd, std::regex(R"(\| cornell-box-point-in-glass \| [0-9.e+-]+ / [0-9.e+-]+ \[[0-9.e+-]+\] )"
                                            R"(\| [0-9.e+-]+ / [0-9.e+-]+ \[[0-9.e+-]+\] \| - \|)")));
    CHECK(md.find("nproc") != std::string::npos);
    CHECK(md.find("memory") != std::string::npos);
    CHECK(fs::exists(dir / "out/refs/cornell-box.json"));
    // --regularizers none: the unregularised runs alone; an unknown name is an error.
    r = sh(tool("bench") + " --scenes " + scene("cornell-box.xml") + " --integrators pt --regularizers none --time 0.1 "
           "--ref-time 0.5 --res 16 --out-dir " + (dir / "out").string() + " -o " + (dir / "C.md").string());
    REQUIRE(r.code == 0);
    md = lt::analysis::readFile((dir / "C.md").string());
    CHECK(md.find("| pt |") != std::string::npos);
    CHECK(md.find("| pt+jg19") == std::string::npos);
    CHECK(md.find("## Regularisation at equal time") == std::string::npos);
    r = sh(tool("bench") + " --scenes " + scene("cornell-box.xml") + " --regularizers kd99 -o " + (dir / "D.md").string());
    CHECK(r.code == 1);
    CHECK(r.output.find("unknown regulariser 'kd99'") != std::string::npos);
    CHECK_FALSE(fs::exists(dir / "D.md"));
    // An OPSR attenuation file (here a table of 0.5 everywhere, set 'low'): the opsrlow column
    // beside opsr, PT with that set; a file that is not there is an error.
    json table;
    for (int k = 2; k <= 5; ++k) table["sets"]["low"]["tables"][std::to_string(k)] = std::vector<double>(size_t(std::pow(4, k)), 0.5);
    std::ofstream(dir / "att.json") << table.dump();
    r = sh(tool("bench") + " --scenes " + scene("cornell-box.xml") + " --integrators pt --regularizers opsr --time 0.1 "
           "--ref-time 0.5 --res 16 --opsr-table " + (dir / "att.json").string() + " --out-dir " + (dir / "out").string() +
           " -o " + (dir / "E.md").string());
    INFO(r.output);
    REQUIRE(r.code == 0);
    md = lt::analysis::readFile((dir / "E.md").string());
    CHECK(std::regex_search(md, std::regex(R"(\| pt\+opsrlow)" + metrics)));
    CHECK(md.find("| scene | pt+opsr | bpt+opsr | vcm+opsr | pt+opsrlow | bpt+opsrlow | vcm+opsrlow |") != std::string::npos);
    // Sections after the keep marker in an existing file survive a rewrite, after the new tables.
    std::ofstream(dir / "K.md") << "# old\n| stale table |\n<!-- bench keeps what follows this line -->\n## Kept section\n";
    r = sh(tool("bench") + " --scenes " + scene("cornell-box.xml") + " --integrators pt --regularizers none --time 0.1 "
           "--ref-time 0.5 --res 16 --out-dir " + (dir / "out").string() + " -o " + (dir / "K.md").string());
    REQUIRE(r.code == 0);
    md = lt::analysis::readFile((dir / "K.md").string());
    CHECK(md.find("| stale table |") == std::string::npos);
    CHECK(md.find("## Kept section") != std::string::npos);
    CHECK(md.find("## Kept section") > md.find("| pt |"));
    r = sh(tool("bench") + " --scenes " + scene("cornell-box.xml") + " --opsr-table /no/such.json -o " + (dir / "F.md").string());
    CHECK(r.code == 1);
    CHECK(r.output.find("/no/such.json") != std::string::npos);
    fs::remove_all(dir);
}

TEST_CASE("bench --spp and biasvar give the same numbers and plots in every run, but for the timing", "[tools][bench][biasvar]") {
    // Issue 16: the tables and plots are deterministic for a fixed seed except for the timing.
    // bench at equal time cannot be (its spp follow the clock), so bench --spp renders every
    // configuration with the same spp: two runs with the same (cached) reference must agree on
    // every cell but time and samples/s, on the point light in glass with KD13's and JG19's
    // configurations (the regularised paths, their singular mask and the summary included).
    fs::path dir = tempDir("determinism");
    auto bench = [&](const std::string& out) {
        Run r = sh(tool("bench") + " --scenes " + scene("cornell-box-point-in-glass.xml") +
                   " --integrators pt,bpt --regularizers jg19,kd13 --spp 4 --ref-time 0.5 --res 16 --threads 2 "
                   "--opsr-table none --out-dir " + (dir / "out").string() + " -o " + (dir / out).string());
        INFO(r.output);
        REQUIRE(r.code == 0);
        // Without the timing: the Date line (date and total time) and the time and samples/s cells.
        std::stringstream in(lt::analysis::readFile((dir / out).string()));
        std::string kept, line;
        while (std::getline(in, line)) {
            if (line.rfind("Date:", 0) == 0) continue;
            std::smatch m;
            if (std::regex_match(line, m, std::regex(R"((\| [a-z0-9+]+ \|) [0-9.]+ (\| [0-9]+ \|) [0-9.e+]+ (\|.*))")))
                line = m[1].str() + " T " + m[2].str() + " S " + m[3].str();
            kept += line + "\n";
        }
        return kept;
    };
    const std::string a = bench("A.md"), b = bench("B.md");
    CHECK(a == b);
    CHECK(a.find("with the same number of samples per pixel (4; --spp)") != std::string::npos);
    CHECK(a.find("## Regularisation at equal spp") != std::string::npos);
    CHECK(std::regex_search(a, std::regex(R"(\| pt\+kd13 \| T \| 4 \| S \| [0-9.e+-]+ \|)")));
    CHECK(std::regex_search(a, std::regex(R"(\| bpt\+jg19 \| T \| 4 \| S \| [0-9.e+-]+ \|)")));
    Run both = sh(tool("bench") + " --spp 4 --time 1 -o " + (dir / "C.md").string());
    CHECK(both.code != 0);
    CHECK(both.output.find("excludes") != std::string::npos);

    // biasvar (fixed budgets, 4 runs of seeds 1..4): its JSON but for the date and the seconds per
    // run, and its plots, byte for byte (a second run into the same folder: the command is the same).
    fs::path ref = makeReference(dir, 8, 64);
    const std::string cmd = tool("biasvar") + " " + scene("cornell-box.xml") + " -D res=8 -D max_depth=4 -r " +
                            ref.string() + " -c pt -c \"pt --reg jg19\" -k 4 --spp 2,4 -o " + (dir / "bv").string();
    auto biasvar = [&](std::string& png, std::string& svg) {
        Run r = sh(cmd);
        INFO(r.output);
        REQUIRE(r.code == 0);
        json j = readJson(dir / "bv/biasvar.json");
        j.erase("date");
        for (auto& c : j["configs"])
            for (auto& l : c["levels"]) l.erase("seconds_per_run");
        if (lt::analysis::gnuplotAvailable()) {
            png = lt::analysis::readFile((dir / "bv/biasvar.png").string());
            svg = lt::analysis::readFile((dir / "bv/biasvar.svg").string());
        }
        return j.dump();
    };
    std::string png1, svg1, png2, svg2;
    const std::string j1 = biasvar(png1, svg1), j2 = biasvar(png2, svg2);
    CHECK(j1 == j2);
    CHECK(png1 == png2);
    CHECK(svg1 == svg2);
    if (lt::analysis::gnuplotAvailable()) CHECK(png1.size() > 100);
    fs::remove_all(dir);
}

TEST_CASE("imgcompare --strategies on a real VCM render: the techniques make up each worst pixel", "[tools][imgcompare][strategies]") {
    fs::path dir = tempDir("strategies");
    const std::string sc = scene("cornell-box-glass-sphere.xml") + " -D res=16 --integrator vcm -q ";
    Run r = sh(std::string(LT_RENDER_BIN) + " " + sc + "--spp 4 --seed 1 --strategy-images " + (dir / "strat").string() +
               " -o " + (dir / "a.exr").string());
    INFO(r.output);
    REQUIRE(r.code == 0);
    r = sh(std::string(LT_RENDER_BIN) + " " + sc + "--spp 16 --seed 2 -o " + (dir / "b.exr").string());
    REQUIRE(r.code == 0);
    r = sh(std::string(LT_IMGCOMPARE_BIN) + " " + (dir / "a.exr").string() + " " + (dir / "b.exr").string() +
           " --strategies " + (dir / "strat").string() + " --worst 4 --json");
    REQUIRE(r.code == 0);
    json j = json::parse(r.output);
    const double share = j.at("relmse_top1_share");
    CHECK(share >= 0.01);  // ceil(1% of 256) = 3 pixels: at least 3/256 of the error, at most all
    CHECK(share <= 1.0);
    CHECK(j.at("top_pixels") == 3);
    const json& st = j.at("strategies");
    CHECK(st.at("images").get<int>() >= 3);  // VCM writes several connection and merge images
    // The strategy images are the render's own: they sum to it up to float rounding.
    CHECK(st.at("strategy_sum_rel_diff").get<double>() < 1e-5);
    REQUIRE(st.at("worst").size() == 4);
    double previous = 1e300;
    for (const json& p : st.at("worst")) {
        INFO(p.dump());
        const double value = p.at("image");
        CHECK(p.at("error").get<double>() <= previous);  // largest first
        previous = p.at("error");
        double sum = 0, shares = 0;
        for (const json& t : p.at("techniques")) {
            CHECK(std::regex_match(t.at("name").get<std::string>(), std::regex(R"(s[0-9]+_t[0-9]+|merge_s[0-9]+)")));
            sum += t.at("value").get<double>();
            shares += t.at("share").get<double>();
        }
        CHECK(sum == Approx(value).epsilon(1e-4).margin(1e-6));
        CHECK(p.at("strategies").get<double>() == Approx(value).epsilon(1e-4).margin(1e-6));
        if (value > 0) CHECK(shares == Approx(1.0).epsilon(1e-9));
    }
    double topShares = 0;
    for (const json& t : st.at("top_techniques")) topShares += t.at("share").get<double>();
    CHECK(topShares == Approx(1.0).epsilon(1e-9));
    fs::remove_all(dir);
}

// The analysis tools' configurations take render's regularisation options: values pass into the
// settings, the scene's parameters apply where the configuration is silent, bad values are errors
// naming the option.
TEST_CASE("configurations: --reg and its knobs reach the settings, bad values are refused", "[tools][jg19]") {
    using namespace lt::analysis;
    lt::SceneDesc desc;
    desc.integrator.regTau = 77.0;  // the scene's reg_tau
    const RunConfig c = parseConfig("bpt --reg jg19 --reg-schedule fixed --reg-mis sampling --reg-quality off");
    lt::RenderSettings s = makeSettings(desc, c, 1, 3);
    CHECK(s.regularizer == "jg19");
    CHECK(s.regTau == 77.0);
    CHECK(s.regSchedule == "fixed");
    CHECK(s.regMis == "sampling");
    CHECK_FALSE(s.regQuality);
    CHECK_FALSE(s.regDiffusion.has_value());  // (as the quality heuristic: off)
    s = makeSettings(desc, parseConfig("vcm --reg-tau 500 --reg-quality on --reg-diffusion off"), 1, 3);
    CHECK(s.regularizer == "none");  // the scene's
    CHECK(s.regTau == 500.0);
    CHECK(s.regQuality);
    CHECK(s.regDiffusion == false);
    s = makeSettings(desc, parseConfig("bpt --reg kd13 --reg-r0 0.02 --reg-lambda 0"), 1, 3);
    CHECK(s.regularizer == "kd13");
    CHECK(s.regR0 == 0.02);
    CHECK(s.regLambda == 0.0);
    s = makeSettings(desc, parseConfig("pt --reg jg19,opsr --reg-tau 200 --reg-opsr-gamma 0.1"), 1, 3);
    CHECK(s.regularizer == "jg19,opsr");
    CHECK(s.regTau == 200.0);
    CHECK(s.regOpsrGamma == 0.1);
    CHECK_NOTHROW(lt::makeIntegrator(s));
    s = makeSettings(desc, parseConfig("pt --reg opsr --reg-opsr-always-sample --label ref"), 1, 3);
    CHECK(s.regOpsrAlwaysSample);
    CHECK_NOTHROW(lt::makeIntegrator(s));
    s = makeSettings(desc, parseConfig("pt --reg opsr"), 1, 3);
    CHECK_FALSE(s.regOpsrAlwaysSample);
    CHECK(s.regTailRr < 0.0);  // (the default)
    s = makeSettings(desc, parseConfig("bpt --reg jg19 --reg-tail-rr 0.5"), 1, 3);
    CHECK(s.regTailRr == 0.5);
    CHECK_NOTHROW(lt::makeIntegrator(s));
    s = makeSettings(desc, parseConfig("pt --reg-tail-rr 0.5"), 1, 3);
    CHECK_THROWS_AS(lt::makeIntegrator(s), std::invalid_argument);  // (no regulariser)
    for (const char* bad : {"pt --reg kd99", "pt --reg opsr,jg19", "pt --reg-tau 0.1", "pt --reg-tau x", "pt --reg-schedule sometimes",
                            "pt --reg-mis maybe", "pt --reg-quality yes", "pt --reg-diffusion yes", "pt --reg-r0 0",
                            "pt --reg-lambda 0.5", "pt --reg-lambda -0.1", "pt --reg opsr --reg-tail-rr -1",
                            "pt --reg opsr --reg-tail-rr x"}) {
        INFO(bad);
        CHECK_THROWS_AS(parseConfig(bad), std::invalid_argument);
    }
}
