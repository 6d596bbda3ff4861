// convergence: error against time and against spp for a list of configurations of one scene.
// Each configuration renders progressively in this process; at geometric checkpoints of spp
// (1, 2, 4, 8, ...) and of render time (t0, 2 t0, 4 t0, ...) the film is developed and compared
// with the reference (the time spent comparing is excluded from the render time). Writes a CSV,
// a log-log plot (PNG + SVG, drawn by gnuplot) with the fitted slopes in the legend, the final
// image of each configuration and a JSON summary (read by `report`). See docs/tools.md.
// Exit codes: 0 success, 1 bad command line, 2 bad scene or reference, 3 output not written,
// 4 rendering failed.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <filesystem>
#include <fstream>
#include "core/loader.h"
#include "core/scene.h"
#include "tools/analysis.h"
#include "tools/cli_checks.h"

using namespace lt;
using namespace lt::analysis;
namespace fs = std::filesystem;

namespace {

struct Row {
    uint64_t spp;
    double seconds;
    ErrorMetrics m;
};

double metricOf(const ErrorMetrics& m, const std::string& name) {
    if (name == "mse") return m.mse;
    if (name == "rmsre") return m.rmsRelErr;
    if (name == "mape") return m.mape;
    return m.relMse;
}

std::string metricLabel(const std::string& name) {
    if (name == "mse") return "MSE";
    if (name == "rmsre") return "RMS-RE (JG19)";
    if (name == "mape") return "MAPE";
    return "relMSE";
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"convergence: error against time and spp for configurations of one scene (CSV + gnuplot plot)"};
    std::string scenePath, refPath, outDir, configFile, metric = "relmse";
    std::vector<std::string> specs, defineList;
    int spp = 0, threads = 0, fitMinSpp = 1;
    double timeLimit = 0, timeBase = 0.01;
    uint64_t seed = 1;
    bool noImages = false;
    app.add_option("scene", scenePath, "Scene file (Mitsuba 3 XML)")->required();
    app.add_option("-r,--reference", refPath, "Reference image (.exr/.pfm/.hdr) of the same size")->required();
    app.add_option("-c,--config", specs, "Configuration, e.g. \"pt\" or \"pt --pt-strategy bsdf\" (repeatable)")->allow_extra_args(false);
    app.add_option("--configs", configFile, "JSON file with configurations (list of strings or {config, label})");
    app.add_option("--spp", spp, "Render each configuration to this spp (default 256 unless --time)")->check(lt::cli::positive());
    app.add_option("--time", timeLimit, "Render each configuration for this many seconds (with --spp: whichever comes first)")
        ->check(lt::cli::positive());
    app.add_option("--time-base", timeBase, "First time checkpoint in seconds; then x2 (default 0.01)")->check(lt::cli::positive());
    app.add_option("--threads", threads, "Worker threads (0 = all cores)")->check(lt::cli::nonNegative("0 = all cores"));
    app.add_option("--seed", seed, "Random seed (the same for every configuration; default 1)");
    app.add_option("-D", defineList, "Override a <default> of the scene: -D name=value")->take_all()->allow_extra_args(false);
    app.add_option("-o,--output-dir", outDir, "Output folder (default out/convergence/<scene name>)");
    app.add_option("--metric", metric, "Metric plotted: relmse (default), rmsre, mape, mse (the CSV has all)")
        ->check(CLI::IsMember({"relmse", "rmsre", "mape", "mse"}));
    app.add_option("--fit-min-spp", fitMinSpp, "Fit the log-log slope to checkpoints with at least this spp (default 1)")
        ->check(lt::cli::positive());
    app.add_flag("--no-images", noImages, "Do not write the final image of each configuration");
    app.footer("Outputs in the folder: convergence.csv (config,spp,seconds,mse,relmse,rmsre,mape), convergence.png/.svg "
               "(+ .gp script and .dat data), images/<config>.exr/.png, convergence.json.\n"
               "Exit codes: 0 success, 1 bad command line, 2 bad scene or reference, 3 output not written, 4 render failed.");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 1;
    }
    if (spp == 0 && timeLimit == 0) spp = 256;

    std::vector<RunConfig> configs;
    std::map<std::string, std::string> defines;
    if (int rc = parseRunInputs("convergence", defineList, specs, configFile, defines, configs)) return rc;
    if (outDir.empty()) outDir = (fs::path("out/convergence") / fs::path(scenePath).stem()).string();

    SceneDesc desc;
    Image ref;
    SceneHash hash;
    if (int rc = loadRunScene("convergence", scenePath, defines, desc, &hash)) return rc;
    if (int rc = loadReference("convergence", refPath, desc, ref)) return rc;

    std::map<std::string, std::vector<Row>> rows;
    nlohmann::json summary;
    summary["tool"] = "convergence";
    summary["command"] = commandLine(argc, argv);
    summary["date"] = nowUtc();
    summary["scene"] = fs::absolute(scenePath).string();
    summary["scene_sha256"] = hash.sha256;
    summary["defines"] = defines;
    summary["reference"] = fs::absolute(refPath).string();
    summary["width"] = ref.width;
    summary["height"] = ref.height;
    summary["seed"] = seed;
    summary["metric"] = metric;
    summary["configs"] = nlohmann::json::array();
    try {
        fs::create_directories(fs::path(outDir) / "images");
    } catch (const std::exception& e) {
        fmt::print(stderr, "convergence: error: cannot create '{}': {}\n", outDir, e.what());
        return 3;
    }

    try {
        ScenesByIntegrator sceneFor(desc);  // (each integrator's light selection, as render)
        for (const RunConfig& cfg : configs) {
            RenderSettings s = makeSettings(desc, cfg, threads, seed);
            s.spp = spp;
            s.timeLimit = timeLimit;
            std::vector<Row>& r = rows[cfg.label];
            double nextTime = timeBase;
            auto record = [&](uint64_t n, double secs, const Image& img) {
                if (!r.empty() && r.back().spp == n) return;
                r.push_back(Row{n, secs, computeMetrics(img, ref)});
            };
            auto cb = [&](const Progress& p) {
                bool pow2 = (p.passesDone & (p.passesDone - 1)) == 0;
                bool timeCk = p.seconds >= nextTime;
                if (!pow2 && !timeCk) return;
                while (nextTime <= p.seconds) nextTime *= 2;
                record(p.passesDone, p.seconds, developSoFar(p));
            };
            fmt::print(stderr, "convergence: {} ...\n", cfg.label);
            RenderStats stats;
            Image img = renderImage(sceneFor(cfg.integrator), s, stats, cb);
            record(stats.spp, stats.seconds, img);
            if (!r.empty()) r.back().seconds = stats.seconds;

            std::vector<double> xs, xt, y;
            for (const Row& row : r)
                if (row.spp >= uint64_t(fitMinSpp)) {
                    xs.push_back(double(row.spp));
                    xt.push_back(row.seconds);
                    y.push_back(metricOf(row.m, metric));
                }
            LineFit fs_ = fitLogLog(xs, y), ft = fitLogLog(xt, y);
            std::string base = slug(cfg.label);
            nlohmann::json jc;
            jc["label"] = cfg.label;
            jc["spec"] = cfg.spec;
            jc["slug"] = base;
            jc["integrator"] = cfg.integrator;
            jc["spp"] = stats.spp;
            jc["seconds"] = stats.seconds;
            jc["samples_per_second"] = stats.seconds > 0 ? double(stats.samples) / stats.seconds : 0.0;
            jc["invalid_samples"] = stats.invalidSamples;
            jc["metrics"] = metricsJson(r.back().m);
            jc["slope_spp"] = fs_.valid() ? nlohmann::json(fs_.slope) : nlohmann::json(nullptr);
            jc["slope_time"] = ft.valid() ? nlohmann::json(ft.slope) : nlohmann::json(nullptr);
            jc["fit_points"] = fs_.points;
            if (!noImages) {
                std::string exr = (fs::path(outDir) / "images" / (base + ".exr")).string();
                writeExr(img, exr);
                writePng(img, (fs::path(outDir) / "images" / (base + ".png")).string());
                jc["image"] = "images/" + base + ".exr";
            }
            summary["configs"].push_back(jc);
            fmt::print("{}: {} spp, {:.3f} s, {} {:.4g}, slope vs spp {:.3f}, vs time {:.3f}\n", cfg.label, stats.spp,
                       stats.seconds, metric, metricOf(r.back().m, metric), fs_.valid() ? fs_.slope : NAN,
                       ft.valid() ? ft.slope : NAN);
        }
    } catch (const ImageError& e) {
        fmt::print(stderr, "convergence: error: {}\n", e.what());
        return 3;
    } catch (const std::exception& e) {
        fmt::print(stderr, "convergence: error: rendering failed: {}\n", e.what());
        return 4;
    }

    // CSV, plot and summary.
    try {
        std::string csv = "config,spp,seconds,mse,relmse,rmsre,mape\n";
        for (const RunConfig& cfg : configs)
            for (const Row& row : rows[cfg.label])
                csv += fmt::format("{},{},{:.6g},{:.9g},{:.9g},{:.9g},{:.9g}\n", csvField(cfg.label), row.spp, row.seconds,
                                   row.m.mse, row.m.relMse, row.m.rmsRelErr, row.m.mape);
        writeTextFile((fs::path(outDir) / "convergence.csv").string(), csv);

        Panel pt{"", "render time [s]", metricLabel(metric) + " (dimensionless)", true, true, {}};
        Panel ps{"", "samples per pixel [spp]", metricLabel(metric) + " (dimensionless)", true, true, {}};
        if (metric == "mse") pt.ylabel = ps.ylabel = "MSE [radiance^2]";
        pt.title = metricLabel(metric) + " against time";
        ps.title = metricLabel(metric) + " against spp";
        size_t k = 0;
        for (const auto& jc : summary["configs"]) {
            const auto& r = rows[jc["label"].get<std::string>()];
            Curve ct, cs;
            for (const Row& row : r) {
                ct.x.push_back(row.seconds), ct.y.push_back(metricOf(row.m, metric));
                cs.x.push_back(double(row.spp)), cs.y.push_back(metricOf(row.m, metric));
            }
            auto slopeText = [](const nlohmann::json& v) { return v.is_null() ? std::string("n/a") : fmt::format("{:.2f}", v.get<double>()); };
            ct.title = fmt::format("{} (slope {})", jc["label"].get<std::string>(), slopeText(jc["slope_time"]));
            cs.title = fmt::format("{} (slope {})", jc["label"].get<std::string>(), slopeText(jc["slope_spp"]));
            ct.color = cs.color = int(k++);
            pt.curves.push_back(ct);
            ps.curves.push_back(cs);
        }
        int height = 420 + (configs.size() > 4 ? 80 : 0);
        PlotFiles pf = plot((fs::path(outDir) / "convergence").string(), {pt, ps}, 560, height);
        summary["plot_width"] = 2 * 560;
        if (!pf.ok) fmt::print(stderr, "convergence: warning: no plot: {}\n", pf.message);
        summary["csv"] = "convergence.csv";
        summary["plot_png"] = pf.ok ? nlohmann::json("convergence.png") : nlohmann::json(nullptr);
        summary["plot_svg"] = pf.ok ? nlohmann::json("convergence.svg") : nlohmann::json(nullptr);
        summary["fit_min_spp"] = fitMinSpp;
        writeTextFile((fs::path(outDir) / "convergence.json").string(), summary.dump(2) + "\n");
    } catch (const std::exception& e) {
        fmt::print(stderr, "convergence: error: {}\n", e.what());
        return 3;
    }
    fmt::print("convergence: wrote {}/convergence.csv, .png, .svg, .json\n", outDir);
    return 0;
}
