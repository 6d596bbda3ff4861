// bench: renders the hard-case suite (scenes/hard/*.xml) and scenes/cornell-box*.xml with every
// available integrator, and PT, BPT and VCM with each regulariser, at equal time and writes
// BENCHMARKS.md: per scene and configuration the render time, spp, samples/s, relMSE, RMS-RE,
// MAPE, the top-1% share (of the relMSE, carried by the worst 1% of pixels), the bias of the image
// mean, the regularised share of contributions and the relMSE outside the pixels only a
// regulariser renders (singularMask) against a reference; a summary of each regulariser's error
// over the same integrator's without it; and the machine (nproc, CPU model, memory). References
// are rendered once by the `reference` tool (next to this binary) and cached under out/bench/refs/
// (re-rendered when the scene or the settings change).
// Run from the repository root (or give --root). See docs/tools.md.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <unistd.h>
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>
#include "core/loader.h"
#include "core/scene.h"
#include "tools/analysis.h"
#include "tools/cli_checks.h"

using namespace lt;
using namespace lt::analysis;
namespace fs = std::filesystem;

namespace {

// The line after which an existing BENCHMARKS.md's sections are kept (see the end of main).
constexpr const char* kKeepMarker = "<!-- bench keeps what follows";

std::string firstMatch(const std::string& file, const std::string& key) {
    std::ifstream f(file);
    std::string line;
    while (std::getline(f, line))
        if (line.rfind(key, 0) == 0) {
            auto c = line.find_first_of(":=");
            std::string v = c == std::string::npos ? line : line.substr(c + 1);
            v.erase(0, v.find_first_not_of(" \t\""));
            while (!v.empty() && (v.back() == '"' || std::isspace((unsigned char)v.back()))) v.pop_back();
            return v;
        }
    return "unknown";
}

std::string machine(int threads) {
    std::string mem = firstMatch("/proc/meminfo", "MemTotal");
    double gib = 0;
    try {
        gib = std::stod(mem) / (1024.0 * 1024.0);
    } catch (...) {
    }
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return fmt::format("| | |\n|---|---|\n| CPU | {} |\n| nproc | {} (threads used: {}) |\n| memory | {:.1f} GiB |\n"
                       "| OS | {} |\n| compiler | {} |\n",
                       firstMatch("/proc/cpuinfo", "model name"), n, threads > 0 ? std::to_string(threads) : "all", gib,
                       firstMatch("/etc/os-release", "PRETTY_NAME"),
#ifdef __VERSION__
                       std::string("g++/clang ") + __VERSION__
#else
                       "unknown"
#endif
    );
}

// The pixels where paths no unregularised technique can produce (singularPath: a point light seen
// through glass) carry more than 1% of the pixel's value in a 256 spp render, with strategy
// images (singular.exr), of any regularised configuration. Each technique regularises a vertex of
// its own on such a path, so the blurred light lands in different pixels (VCM's light tracing
// blurs a mirror near the camera, PT's next-event estimation the glass), and a sparse halo of
// light-tracing splats is missed at fewer samples. Empty where there are none. An unregularised
// reference lacks those paths: the bench reports the error outside them beside the whole image's,
// for every configuration alike.
std::vector<bool> singularMask(ScenesByIntegrator& sceneFor, const SceneDesc& desc, const std::vector<RunConfig>& configs,
                               int threads, const fs::path& dir) {
    std::vector<bool> mask;
    fs::remove_all(dir);  // (singular.exr of an earlier run)
    for (const RunConfig& cfg : configs) {
        if (!cfg.regularizer || *cfg.regularizer == "none") continue;
        RenderSettings s = makeSettings(desc, cfg, threads, 1);
        s.spp = 256;
        s.timeLimit = 0.0;
        s.strategyImages = (dir / slug(cfg.label)).string();
        RenderStats st;
        const Image img = renderImage(sceneFor(cfg.integrator), s, st);
        const fs::path part = dir / slug(cfg.label) / "singular.exr";
        if (!fs::exists(part)) continue;
        const Image sing = readImage(part.string());
        if (mask.empty()) mask.assign(img.pixels.size(), false);
        for (size_t i = 0; i < mask.size(); ++i)
            if (luminance(sing.pixels[i]) > 0.01f * luminance(img.pixels[i])) mask[i] = true;
    }
    if (std::find(mask.begin(), mask.end(), true) == mask.end()) return {};
    return mask;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"bench: every available integrator at equal time on the hard-case suite and the Cornell boxes"};
    std::string root = ".", outDir = "out/bench", md = "BENCHMARKS.md", refConfig = "auto", integratorList, regularizerList;
    std::vector<std::string> scenes;
    int res = 64, threads = 0;
    double seconds = 3, refTime = 20;
    app.add_option("--root", root, "Repository root (default: current folder)");
    app.add_option("--scenes", scenes, "Scenes (default: scenes/hard/*.xml and scenes/cornell-box*.xml)");
    app.add_option("--integrators", integratorList,
                   "Comma-separated configurations, as the analysis tools' (default: every available integrator)");
    app.add_option("--regularizers", regularizerList,
                   "Comma-separated regularisers to run PT, BPT and VCM with besides none (default: all; 'none': "
                   "only the unregularised ones)");
    std::string opsrTable = "auto";
    app.add_option("--opsr-table", opsrTable,
                   "OPSR's reference attenuation file: with the opsr column, PT, BPT and VCM also run with its 'low' set "
                   "(column opsrlow). Default auto: ../shared/data/opsr/opsr-reference-attenuation.json beside the root, "
                   "where it exists; 'none': no such column");
    CLI::Option* timeOpt = app.add_option("--time", seconds, "Render time per scene and integrator in seconds (default 3)")
                               ->check(lt::cli::positive());
    int fixedSpp = 0;
    app.add_option("--spp", fixedSpp,
                   "Render every configuration with this many samples per pixel instead of for --time seconds "
                   "(equal spp: each column but time and samples/s is then the same in every run with the same "
                   "references, for the fixed seed)")
        ->check(lt::cli::positive())
        ->excludes(timeOpt);
    app.add_option("--res", res, "Image width and height, through -D res=N (default 64)")->check(lt::cli::range(8, 4096));
    app.add_option("--ref-time", refTime, "Render time of each reference in seconds (default 20)")->check(lt::cli::positive());
    app.add_option("--ref-config", refConfig, "Configuration of the references (default auto: vcm, else bpt, else pt)");
    app.add_option("--threads", threads, "Worker threads (0 = all cores)")->check(lt::cli::nonNegative("0 = all cores"));
    app.add_option("--out-dir", outDir, "Images and cached references (default out/bench)");
    app.add_option("-o,--output", md, "Markdown report (default BENCHMARKS.md)");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 1;
    }
    auto start = std::chrono::steady_clock::now();
    if (scenes.empty()) {
        for (const char* dir : {"scenes/hard", "scenes"}) {
            std::vector<std::string> found;
            for (const auto& e : fs::directory_iterator(fs::path(root) / dir)) {
                std::string n = e.path().filename().string();
                if (e.path().extension() != ".xml") continue;
                if (std::string(dir) == "scenes" && n.rfind("cornell-box", 0) != 0) continue;
                found.push_back(e.path().lexically_normal().string());
            }
            std::sort(found.begin(), found.end());
            scenes.insert(scenes.end(), found.begin(), found.end());
        }
    }
    auto splitList = [](const std::string& list) {
        std::vector<std::string> out;
        std::stringstream ss(list);
        for (std::string t; std::getline(ss, t, ',');)
            if (!t.empty()) out.push_back(t);
        return out;
    };
    std::vector<std::string> specs = integratorList.empty() ? availableIntegrators() : splitList(integratorList);
    // The regulariser columns: each regulariser's name and its options; JG19 also with its smooth
    // lobes as cones ("jg19cone": --reg jg19 --reg-specular cone).
    std::vector<std::string> regularizers;
    std::map<std::string, std::string> regularizerArgs;
    for (const std::string& r : regularizerList.empty() ? kRegularizerNames : splitList(regularizerList)) {
        if (std::find(kRegularizerNames.begin(), kRegularizerNames.end(), r) == kRegularizerNames.end()) {
            fmt::print(stderr, "bench: error: --regularizers: unknown regulariser '{}'\n", r);
            return 1;
        }
        if (r == "none" || r.find(',') != std::string::npos) continue;  // (combinations: not a column)
        regularizers.push_back(r);
        regularizerArgs[r] = "--reg " + r;
        if (r == "jg19") {
            regularizers.push_back("jg19cone");
            regularizerArgs["jg19cone"] = "--reg jg19 --reg-specular cone";
        }
        if (r == "opsr") {
            // OPSR's 'low' set (the paper's least aggressive learnt set) where the file is there.
            std::string table = opsrTable;
            if (table == "auto") {
                const fs::path guess = fs::path(root) / ".." / "shared" / "data" / "opsr" / "opsr-reference-attenuation.json";
                table = fs::exists(guess) ? fs::absolute(guess).lexically_normal().string() : "none";
            }
            if (table != "none") {
                if (!fs::exists(table)) {
                    fmt::print(stderr, "bench: error: --opsr-table: no file '{}'\n", table);
                    return 1;
                }
                regularizers.push_back("opsrlow");
                regularizerArgs["opsrlow"] = "--reg opsr --reg-opsr-table " + table + ":low";
            }
        }
    }
    // Each regulariser with PT, BPT and VCM where they run unregularised, labelled "pt+jg19" (OPSR
    // with its default, the constant gamma 0.01).
    auto integratorsOf = [](const std::string&) { return std::vector<std::string>{"pt", "bpt", "vcm"}; };
    for (const std::string& r : regularizers)
        for (const std::string& integ : integratorsOf(r))
            if (std::find(specs.begin(), specs.end(), integ) != specs.end())
                specs.push_back(fmt::format("{} {} --label {}+{}", integ, regularizerArgs[r], integ, r));
    std::vector<RunConfig> configs;
    try {
        configs = gatherConfigs(specs, "");
    } catch (const std::exception& e) {
        fmt::print(stderr, "bench: error: {}\n", e.what());
        return 1;
    }
    // For the summary: (scene, label) -> relMSE, RMS-RE, relMSE outside the singular pixels (-1: no mask).
    struct Result {
        double relMse, rmsRelErr, relMseOutside;
    };
    std::map<std::pair<std::string, std::string>, Result> results;
    if (refConfig == "auto") {
        refConfig = integratorAvailable("vcm") ? "vcm" : integratorAvailable("bpt") ? "bpt" : "pt";
    }
    std::string refTool = (fs::path(executableDir()) / "reference").string();
    const std::map<std::string, std::string> defines = {{"res", std::to_string(res)}};

    std::string body;
    int failures = 0;
    for (const std::string& scenePath : scenes) {
        std::string stem = fs::path(scenePath).stem().string();
        fmt::print("bench: {}\n", scenePath);
        fs::path ref = fs::path(outDir) / "refs" / (stem + ".exr");
        int rc = runProgram({refTool, scenePath, "-o", ref.string(), "-D", "res=" + std::to_string(res), "-c", refConfig,
                             "--time", fmt::format("{}", refTime), "--chunks", "2", "--threads", std::to_string(threads)});
        body += fmt::format("\n## {}\n\n", scenePath);
        {
            std::ifstream f(scenePath);
            std::string line;
            std::getline(f, line);
            if (line.rfind("<!--", 0) == 0) body += "_" + line.substr(4) + " ..._\n\n";
        }
        Image refImg;
        nlohmann::json refJson;
        try {
            if (rc != 0) throw std::runtime_error(fmt::format("reference tool exited with {}", rc));
            refImg = readImage(ref.string());
            refJson = nlohmann::json::parse(readFile(fs::path(ref).replace_extension(".json").string()));
        } catch (const std::exception& e) {
            body += fmt::format("Reference failed: {}\n", e.what());
            ++failures;
            continue;
        }
        body += fmt::format("Reference: `{}`, {} spp in {:.0f} s ({}x{}, scene SHA-256 `{}`).\n\n",
                            refJson.value("config", refConfig), refJson.value("spp", 0), refJson.value("seconds", 0.0), res,
                            res, refJson.value("scene_sha256", std::string("?")).substr(0, 16));
        SceneDesc desc;
        try {
            desc = loadScene(scenePath, defines);
        } catch (const std::exception& e) {
            body += fmt::format("Scene failed to load: {}\n", e.what());
            ++failures;
            continue;
        }
        ScenesByIntegrator sceneFor(desc);  // (each integrator's light selection, as render)
        std::vector<bool> singular;
        try {
            singular = singularMask(sceneFor, desc, configs, threads, fs::path(outDir) / stem / "singular-mask");
        } catch (const std::exception& e) {
            body += fmt::format("Singular mask failed: {}\n\n", e.what());
            ++failures;
        }
        if (!singular.empty())
            body += fmt::format("Paths no unregularised technique can produce (`singular.exr`, e.g. a point light seen "
                                "through glass) make up more than 1% of {} of the {} pixels in a 256 spp render of one or more "
                                "of the regularised configurations; the reference lacks them. `relMSE outside` leaves those "
                                "pixels out.\n\n",
                                std::count(singular.begin(), singular.end(), true), singular.size());
        body += "| configuration | time [s] | spp | samples/s | relMSE | RMS-RE | MAPE | top-1% share | mean bias | "
                "regularised | relMSE outside | bias outside |\n"
                "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
        for (const RunConfig& cfg : configs) {
            const std::string& integ = cfg.label;
            try {
                RenderSettings s = makeSettings(desc, cfg, threads, 1);
                s.spp = fixedSpp;  // (0: until the time limit)
                s.timeLimit = fixedSpp > 0 ? 0.0 : seconds;
                RenderStats st;
                Image img = renderImage(sceneFor(cfg.integrator), s, st);
                ErrorMetrics m = computeMetrics(img, refImg);
                fs::path o = fs::path(outDir) / stem / (slug(integ) + ".exr");
                fs::create_directories(o.parent_path());
                writeExr(img, o.string());
                writePng(img, fs::path(o).replace_extension(".png").string());
                double sps = st.seconds > 0 ? double(st.samples) / st.seconds : 0.0;
                const std::string bias =
                    m.meanReference > 0.0 ? fmt::format("{:+.2f}%", 100.0 * (m.meanImage / m.meanReference - 1.0)) : "-";
                const std::string share =
                    s.regularizer == "none" || st.contributions == 0
                        ? "-"
                        : fmt::format("{:.1f}%", 100.0 * double(st.regularisedContributions) / double(st.contributions));
                // (outside the singular pixels: the image mean's bias where the reference has the paths)
                const ErrorMetrics out = singular.empty() ? ErrorMetrics{} : computeMetrics(img, refImg, singular);
                const double outside = singular.empty() ? -1.0 : out.relMse;
                const std::string biasOutside =
                    singular.empty() || !(out.meanReference > 0.0)
                        ? "-"
                        : fmt::format("{:+.2f}%", 100.0 * (out.meanImage / out.meanReference - 1.0));
                body += fmt::format("| {} | {:.2f} | {} | {:.3g} | {:.4g} | {:.4g} | {:.4g} | {:.3f} | {} | {} | {} | {} |\n",
                                    integ, st.seconds, st.spp, sps, m.relMse, m.rmsRelErr, m.mape,
                                    relMseTopShare(img, refImg), bias, share,
                                    outside < 0.0 ? std::string("-") : fmt::format("{:.4g}", outside), biasOutside);
                results[{scenePath, integ}] = {m.relMse, m.rmsRelErr, outside};
                fmt::print("  {}: {} spp in {:.2f} s, relMSE {:.4g}\n", integ, st.spp, st.seconds, m.relMse);
            } catch (const std::exception& e) {
                body += fmt::format("| {} | failed: {} | | | | | | | | | | |\n", integ, e.what());
                ++failures;
            }
        }
    }
    // Each regulariser against no regulariser, same integrator, same time: ratios below 1 are the
    // regulariser's gain (its bias included: the reference is unregularised).
    if (!regularizers.empty()) {
        body += fmt::format("\n## Regularisation at equal {0}\n\nError with the regulariser over the same integrator's "
                            "without it, same {0} and reference (below 1: the regulariser wins; its bias is part of its "
                            "error). relMSE ratio / RMS-RE ratio, and where a scene has singular pixels (above) [the "
                            "relMSE ratio outside them]. ",
                            fixedSpp > 0 ? "spp" : "time");
        if (fixedSpp == 0)
            body += "Each figure is one timed run: where the machine is shared, the spp of a configuration varies between "
                    "runs (see the tables), and so does its relMSE, about in inverse proportion. ";
        body += "jg19cone: JG19 with its smooth "
                "lobes as KD13's cones (`--reg jg19 --reg-specular cone`). opsr: OPSR with its constant gamma 0.01; opsrlow: "
                "OPSR with the 'low' set of the authors' reference attenuation file (where it is found).\n\n| scene |";
        std::string rule = "|---|";
        for (const std::string& r : regularizers)
            for (const std::string& integ : integratorsOf(r)) {
                body += fmt::format(" {}+{} |", integ, r);
                rule += "---:|";
            }
        body += "\n" + rule + "\n";
        for (const std::string& scenePath : scenes) {
            body += fmt::format("| {} |", fs::path(scenePath).stem().string());
            for (const std::string& r : regularizers)
                for (const std::string& integ : integratorsOf(r)) {
                    auto a = results.find({scenePath, fmt::format("{}+{}", integ, r)}), b = results.find({scenePath, integ});
                    if (a == results.end() || b == results.end() || !(b->second.relMse > 0.0) ||
                        !(b->second.rmsRelErr > 0.0)) {
                        body += " - |";
                        continue;
                    }
                    const Result &x = a->second, &y = b->second;
                    body += fmt::format(" {:.3g} / {:.3g}", x.relMse / y.relMse, x.rmsRelErr / y.rmsRelErr);
                    if (x.relMseOutside >= 0.0 && y.relMseOutside > 0.0)
                        body += fmt::format(" [{:.3g}]", x.relMseOutside / y.relMseOutside);
                    body += " |";
                }
            body += "\n";
        }
    }
    double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::string head = "# Benchmarks\n\nWritten by `bench` (tools/bench.cpp; `bash scripts/bench.sh`). Every integrator renders "
                       "each scene " +
                       (fixedSpp > 0 ? fmt::format("with the same number of samples per pixel ({}; --spp)", fixedSpp)
                                     : std::string("for the same wall-clock time (excluding scene loading)")) +
                       ", all at " +
                       fmt::format("{}x{} pixels, seed 1; errors are against the reference named under each scene. ", res, res) +
                       "relMSE = mean (a-b)^2/(b^2+0.01), RMS-RE = the RMS of relative residuals of Jendersie & Grosch "
                       "2019, MAPE = mean |a-b|/(|b|+0.01), top-1% share = the share of the relMSE carried by the worst 1% "
                       "of pixels (per pixel the sum of its three channels' terms; 0.01 when the error is spread evenly, "
                       "near 1 when it is in a few fireflies) (core/metrics.h), mean bias = the image mean's relative "
                       "difference from the reference's, regularised = the share of the contributions whose technique was "
                       "regularised (`pt+jg19`: PT with `--reg jg19` and its defaults). A reference rendered by an integrator that "
                       "cannot sample some paths of a scene (see the comment at the top of each scene; e.g. PT and point "
                       "lights behind glass) misses them, and so do the figures against it.\n\n";
    head += fmt::format("Date: {}. Command: `{}`. Total time {:.0f} s.\n\n## Machine\n\n{}", nowUtc(), commandLine(argc, argv),
                        total, machine(threads));
    // Sections written by hand or by other runs (e.g. OPSR's reference sets at equal time) follow a
    // marker line in the existing file; they are kept, after the new tables.
    std::string kept;
    if (fs::exists(md)) {
        const std::string old = readFile(md);
        const size_t at = old.find(kKeepMarker);
        if (at != std::string::npos) kept = "\n" + old.substr(at);
    }
    try {
        writeTextFile(md, head + body + kept);
    } catch (const std::exception& e) {
        fmt::print(stderr, "bench: error: {}\n", e.what());
        return 3;
    }
    fmt::print("bench: wrote {} in {:.0f} s ({} failures)\n", md, total, failures);
    return failures ? 4 : 0;
}
