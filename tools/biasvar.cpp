// biasvar: bias and variance of configurations from K independent renders (seeds base..base+K-1).
// Each run renders to the largest requested spp; the film is developed at every requested spp
// on the way (so the levels of one run are nested, the K runs of one level independent).
// Per level: per-pixel mean, variance (of one render) and bias^2 against the reference as EXR
// maps and false-colour PNGs, the image-wide figures with standard errors, a z-test of
// bias^2 = 0 and the check MSE = bias^2 + variance; over the levels, one gnuplot plot of
// bias^2, variance and the bias^2 noise floor against spp. See docs/tools.md.
//
// Sweep (--sweep OPTION=V1,V2,...): every configuration runs once per value with `--OPTION V`
// appended (a bandwidth: reg-tau, reg-r0, reg-opsr-gamma, radius, ...), labelled "LABEL
// OPTION=V"; besides the per-configuration outputs, sweep.csv (one row per configuration, value
// and spp: bias^2, variance, MSE) and the plot sweep.png/.svg: MSE against the value, one curve
// per configuration and spp (OPSR Fig. 7).
//
// bias^2 estimator: E[(mean - ref)^2] = bias^2 + var/K, so bias2_hat = (mean - ref)^2 - var_hat/K is
// unbiased (var_hat the unbiased sample variance of one render); it is negative about half the
// time for an unbiased method. Its standard error over pixels gives the noise floor.
// Exit codes: 0 success, 1 bad command line, 2 bad scene or reference, 3 output not written,
// 4 rendering failed.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <algorithm>
#include <filesystem>
#include <optional>
#include "core/loader.h"
#include "core/scene.h"
#include "tools/analysis.h"
#include "tools/cli_checks.h"

using namespace lt;
using namespace lt::analysis;
namespace fs = std::filesystem;

namespace {

struct Level {
    uint64_t spp;
    ErrorAccumulator even, odd;  // runs with even / odd index (split-half check)
    double seconds = 0;          // summed over runs
};

void writeMaps(const PixelStats& ps, const fs::path& dir) {
    fs::create_directories(dir);
    writeExr(ps.mean, (dir / "mean.exr").string());
    writeExr(ps.variance, (dir / "variance.exr").string());
    writeExr(ps.bias2, (dir / "bias2.exr").string());
    writeExr(ps.mse, (dir / "mse.exr").string());
    writePng(ps.mean, (dir / "mean.png").string(), autoExposure(ps.mean));
    double vmax = std::max({quantile(ps.variance, 0.99), quantile(ps.bias2, 0.99), 1e-30});
    writePng(falseColour(ps.variance, vmax), (dir / "variance.png").string());
    writePng(falseColour(ps.bias2, vmax), (dir / "bias2.png").string());
    writePng(falseColour(ps.mse, vmax), (dir / "mse.png").string());
}

// A plot's height: 480 pixels for the axes and, with more than four curves (analysis_io.cpp puts
// the key below the plot then, two columns), 17 per row of the key, so the key never squeezes
// the axes (12 configurations: 48 curves, 24 rows).
int plotHeight(size_t curves) { return 480 + (curves > 4 ? 17 * int((curves + 1) / 2) : 0); }

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"biasvar: per-pixel mean, variance and bias^2 of configurations from K independent renders"};
    std::string scenePath, refPath, outDir, configFile;
    std::vector<std::string> specs, defineList;
    std::vector<int> sppList;
    int runs = 16, threads = 0;
    uint64_t seed = 1000;
    double zCrit = 3.29;
    bool absolutePlot = false;
    std::string sweepSpec, cropSpec;
    app.add_option("scene", scenePath, "Scene file (Mitsuba 3 XML)")->required();
    app.add_option("-r,--reference", refPath, "Reference image (.exr/.pfm/.hdr) of the same size")->required();
    app.add_option("-c,--config", specs, "Configuration, e.g. \"pt\" or \"vcm --radius 0.01\" (repeatable)")->allow_extra_args(false);
    app.add_option("--configs", configFile, "JSON file with configurations");
    app.add_option("-k,--runs", runs, "Independent renders K per configuration (>= 4; default 16)")->check(lt::cli::range(4, 100000));
    app.add_option("--spp", sppList, "Samples per pixel; repeat it (--spp 4 --spp 16) or give a list (--spp 4,16,64) "
                                     "for curves against spp (default 16)")
        ->allow_extra_args(false)
        ->delimiter(',')
        ->check(lt::cli::positive());
    app.add_option("--seed", seed, "Seed of the first run; run k uses seed + k (default 1000)");
    app.add_option("--threads", threads, "Worker threads (0 = all cores)")->check(lt::cli::nonNegative("0 = all cores"));
    app.add_option("-D", defineList, "Override a <default> of the scene: -D name=value")->take_all()->allow_extra_args(false);
    app.add_option("-o,--output-dir", outDir, "Output folder (default out/biasvar/<scene name>)");
    app.add_option("--z", zCrit, "Two-sided critical |z| for the tests (default 3.29: significance 0.001)")
        ->check(lt::cli::positive());
    app.add_option("--sweep", sweepSpec,
                   "OPTION=V1,V2,...: run every configuration once per value with --OPTION V appended (e.g. "
                   "reg-tau=10,30,100 or reg-opsr-gamma=0.01,0.1,0.5); adds sweep.csv and the plot sweep.png/.svg "
                   "(MSE against the value per configuration and spp)");
    app.add_option("--crop", cropSpec,
                   "x,y,w,h: the image-wide figures (printed, JSON, plots, sweep) over this rectangle only (pixels, "
                   "row 0 at the top), e.g. to leave out light the reference lacks; the maps stay whole");
    app.add_flag("--absolute", absolutePlot, "Plot the absolute figures (default: relative, divided by ref^2 + 0.01)");
    app.footer("Outputs: <dir>/<config>/spp<N>/{mean,variance,bias2,mse}.exr and .png (false colour, log scale), "
               "<dir>/biasvar.json, <dir>/biasvar.png/.svg (+ .gp, .dat).\n"
               "Exit codes: 0 success, 1 bad command line, 2 bad scene or reference, 3 output not written, 4 render failed.");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 1;
    }
    const bool relativePlot = !absolutePlot;
    std::optional<CropRect> crop;
    if (!cropSpec.empty()) {
        try {
            crop = parseCropRect(cropSpec);
        } catch (const std::exception& e) {
            fmt::print(stderr, "biasvar: error: --crop: {}\n", e.what());
            return 1;
        }
    }
    if (sppList.empty()) sppList = {16};
    std::sort(sppList.begin(), sppList.end());
    sppList.erase(std::unique(sppList.begin(), sppList.end()), sppList.end());

    std::vector<RunConfig> configs;
    std::map<std::string, std::string> defines;
    if (int rc = parseRunInputs("biasvar", defineList, specs, configFile, defines, configs)) return rc;
    // The sweep: each configuration once per value (sweepBase[i]: the configuration that expanded
    // configuration i comes from; its value is sweepValues[i % sweepValues.size()]).
    std::string sweepOption;
    std::vector<double> sweepValues;
    std::vector<size_t> sweepBase;
    std::vector<std::string> baseLabels;
    if (!sweepSpec.empty()) {
        try {
            parseSweep(sweepSpec, sweepOption, sweepValues);
            std::vector<RunConfig> expanded;
            for (size_t b = 0; b < configs.size(); ++b) {
                baseLabels.push_back(configs[b].label);
                for (double v : sweepValues) {
                    RunConfig c = parseConfig(fmt::format("{} --{} {}", configs[b].spec, sweepOption, v));
                    if (c.extra.count(sweepOption))
                        throw std::invalid_argument(fmt::format(
                            "--{} is not a configuration option (those of docs/tools.md: --reg-tau, --reg-r0, "
                            "--reg-lambda, --reg-opsr-gamma, --radius, ...)", sweepOption));
                    c.label = fmt::format("{} {}={}", configs[b].label, sweepOption, v);
                    expanded.push_back(c);
                    sweepBase.push_back(b);
                }
            }
            configs = expanded;
        } catch (const std::exception& e) {
            fmt::print(stderr, "biasvar: error: --sweep: {}\n", e.what());
            return 1;
        }
    }
    if (outDir.empty()) outDir = (fs::path("out/biasvar") / fs::path(scenePath).stem()).string();

    SceneDesc desc;
    Image ref;
    if (int rc = loadRunScene("biasvar", scenePath, defines, desc, nullptr)) return rc;
    if (int rc = loadReference("biasvar", refPath, desc, ref)) return rc;
    if (crop && (crop->x + crop->w > ref.width || crop->y + crop->h > ref.height)) {
        fmt::print(stderr, "biasvar: error: --crop {} is not inside the {}x{} image\n", cropSpec, ref.width, ref.height);
        return 1;
    }

    nlohmann::json summary;
    summary["tool"] = "biasvar";
    summary["command"] = commandLine(argc, argv);
    summary["date"] = nowUtc();
    summary["scene"] = fs::absolute(scenePath).string();
    summary["defines"] = defines;
    summary["reference"] = fs::absolute(refPath).string();
    summary["runs"] = runs;
    summary["first_seed"] = seed;
    summary["z_critical"] = zCrit;
    if (crop) summary["crop"] = {crop->x, crop->y, crop->w, crop->h};
    summary["bias2_estimator"] = "(mean - ref)^2 - var/K, var the unbiased sample variance of one render";
    summary["configs"] = nlohmann::json::array();
    std::vector<Panel> panels;
    bool allOk = true;
    // The plotted figures (relative or absolute, as the plot) of each configuration and level.
    struct SweepRow {
        size_t config;
        uint64_t spp;
        ImageFigures figures;
    };
    std::vector<SweepRow> sweepRows;
    try {
        ScenesByIntegrator sceneFor(desc);  // (each integrator's light selection, as render)
        for (size_t ci = 0; ci < configs.size(); ++ci) {
            const RunConfig& cfg = configs[ci];
            std::vector<Level> levels;
            for (int n : sppList) levels.push_back(Level{uint64_t(n), {ref.width, ref.height}, {ref.width, ref.height}});
            fmt::print(stderr, "biasvar: {}: {} runs to {} spp ...\n", cfg.label, runs, sppList.back());
            for (int k = 0; k < runs; ++k) {
                RenderSettings s = makeSettings(desc, cfg, threads, seed + uint64_t(k));
                s.spp = sppList.back();
                size_t next = 0;
                auto cb = [&](const Progress& p) {
                    if (next >= levels.size() || p.passesDone != levels[next].spp) return;
                    Image img = developSoFar(p);
                    if (auto bad = findNonFinite(img))
                        throw std::runtime_error(fmt::format("non-finite pixel ({}, {})", bad->first, bad->second));
                    (k % 2 ? levels[next].odd : levels[next].even).add(img, ref);
                    levels[next].seconds += p.seconds;
                    ++next;
                };
                RenderStats stats;
                renderImage(sceneFor(cfg.integrator), s, stats, cb);
            }
            nlohmann::json jc;
            jc["label"] = cfg.label;
            jc["spec"] = cfg.spec;
            jc["slug"] = slug(cfg.label);
            jc["levels"] = nlohmann::json::array();
            Curve cb2, cvar, cfloor, cmse;
            fmt::print("{} ({} runs):\n", cfg.label, runs);
            for (Level& L : levels) {
                ErrorAccumulator all = L.even;
                all.merge(L.odd);
                PixelStats ps = pixelStats(all, ref), pe = pixelStats(L.even, ref), po = pixelStats(L.odd, ref);
                fs::path dir = fs::path(outDir) / slug(cfg.label) / fmt::format("spp{}", L.spp);
                writeMaps(ps, dir);
                nlohmann::json jl = {{"spp", L.spp}, {"seconds_per_run", L.seconds / runs}, {"dir", fs::relative(dir, outDir).string()}};
                fmt::print("  spp {}:\n", L.spp);
                for (bool relative : {false, true}) {
                    const Image* w = relative ? &ref : nullptr;
                    const CropRect* c = crop ? &*crop : nullptr;
                    ImageFigures f = imageFigures(ps, w, c), fe = imageFigures(pe, w, c), fo = imageFigures(po, w, c);
                    double z = f.bias2StdErr > 0 ? f.bias2 / f.bias2StdErr : (f.bias2 > 0 ? INFINITY : 0.0);
                    // The exact identity of the estimators (a numerical check) ...
                    double identity = std::abs(f.mse - (f.bias2 + f.variance)) / std::max(f.mse, 1e-300);
                    // ... and the statistical check: MSE from the even runs against bias^2 + variance
                    // from the odd runs (independent estimates of the same expectation).
                    double splitSe = std::hypot(fe.mseStdErr, fo.mseStdErr);
                    double splitZ = splitSe > 0 ? (fe.mse - (fo.bias2 + fo.variance)) / splitSe : 0.0;
                    bool ok = identity < 1e-4 && std::abs(splitZ) < zCrit;
                    allOk = allOk && ok;
                    jl[relative ? "relative" : "absolute"] = {
                        {"bias2", f.bias2}, {"bias2_stderr", f.bias2StdErr}, {"bias2_z", z}, {"biased", z > zCrit},
                        {"variance", f.variance}, {"variance_stderr", f.varianceStdErr}, {"mse", f.mse},
                        {"mse_stderr", f.mseStdErr}, {"identity_rel_diff", identity}, {"split_half_mse", fe.mse},
                        {"split_half_bias2_plus_variance", fo.bias2 + fo.variance}, {"split_half_z", splitZ}, {"check_ok", ok}};
                    const char* name = relative ? "relative (/ (ref^2 + 0.01))" : "absolute";
                    fmt::print("    {:28} bias^2 {:.4e} +- {:.2e} (z = {:+.2f}: {}), variance {:.4e} +- {:.2e}, MSE {:.4e} +- {:.2e}\n",
                               name, f.bias2, f.bias2StdErr, z, z > zCrit ? "biased" : "consistent with 0", f.variance,
                               f.varianceStdErr, f.mse, f.mseStdErr);
                    fmt::print("    {:28} check MSE = bias^2 + variance: identity rel. diff {:.1e}; split halves {:.4e} vs "
                               "{:.4e}, z = {:+.2f} -> {}\n",
                               "", identity, fe.mse, fo.bias2 + fo.variance, splitZ, ok ? "OK" : "FAILED");
                    if (relative != relativePlot) continue;
                    sweepRows.push_back(SweepRow{ci, L.spp, f});
                    double x = double(L.spp);
                    cb2.x.push_back(x), cb2.y.push_back(f.bias2);
                    cvar.x.push_back(x), cvar.y.push_back(f.variance);
                    cfloor.x.push_back(x), cfloor.y.push_back(2 * f.bias2StdErr);
                    cmse.x.push_back(x), cmse.y.push_back(f.mse);
                }
                jc["levels"].push_back(jl);
            }
            LineFit fb = fitLogLog(cb2.x, cb2.y), fv = fitLogLog(cvar.x, cvar.y);
            auto sl = [](const LineFit& f) { return f.valid() ? fmt::format("{:.2f}", f.slope) : std::string("n/a"); };
            std::string pre = configs.size() > 1 ? cfg.label + ": " : std::string();
            cvar.title = pre + "variance (slope " + sl(fv) + ")";
            cb2.title = pre + "bias^2 (slope " + sl(fb) + ")";
            cfloor.title = pre + "bias^2 noise floor";
            cmse.title = pre + "MSE";
            // One colour per configuration; the quantity is told by the line and point style.
            cvar.color = cb2.color = cfloor.color = cmse.color = int(ci);
            cb2.pointType = 5;
            cfloor.dashed = true;
            cmse.dotted = true;
            if (panels.empty()) panels.push_back(Panel{"bias^2 (squares), variance (circles), MSE (dotted), bias^2 noise "
                                                       "floor (dashed); " + std::to_string(runs) + " runs each",
                                                       "samples per pixel [spp]",
                                                       relativePlot ? "relative: average of x / (ref^2 + 0.01) [dimensionless]"
                                                                    : "average per value [radiance^2]",
                                                       true, true, {}});
            for (Curve* c : {&cvar, &cb2, &cfloor, &cmse}) panels[0].curves.push_back(*c);
            summary["configs"].push_back(jc);
        }
    } catch (const ImageError& e) {
        fmt::print(stderr, "biasvar: error: {}\n", e.what());
        return 3;
    } catch (const std::exception& e) {
        fmt::print(stderr, "biasvar: error: {}\n", e.what());
        return 4;
    }
    try {
        if (sppList.size() > 1) {
            const int height = plotHeight(panels[0].curves.size());
            PlotFiles pf = plot((fs::path(outDir) / "biasvar").string(), panels, 760, height);
            summary["plot_width"] = 760;
            if (!pf.ok) fmt::print(stderr, "biasvar: warning: no plot: {}\n", pf.message);
            summary["plot_png"] = pf.ok ? nlohmann::json("biasvar.png") : nlohmann::json(nullptr);
            summary["plot_svg"] = pf.ok ? nlohmann::json("biasvar.svg") : nlohmann::json(nullptr);
        }
        if (!sweepValues.empty()) {
            std::string csv = "config,option,value,spp,bias2,variance,mse\n";
            Panel panel{"MSE against " + sweepOption + "; " + std::to_string(runs) + " runs each", sweepOption,
                        relativePlot ? "relative MSE: average of x / (ref^2 + 0.01) [dimensionless]"
                                     : "MSE, average per value [radiance^2]",
                        true, true, {}};
            for (size_t b = 0; b < baseLabels.size(); ++b)
                for (size_t li = 0; li < sppList.size(); ++li) {
                    Curve c;
                    c.title = (baseLabels.size() > 1 ? baseLabels[b] + ", " : std::string()) +
                              std::to_string(sppList[li]) + " spp";
                    c.color = int(b * sppList.size() + li);
                    for (const SweepRow& r : sweepRows) {
                        if (sweepBase[r.config] != b || r.spp != uint64_t(sppList[li])) continue;
                        const double v = sweepValues[r.config % sweepValues.size()];
                        c.x.push_back(v), c.y.push_back(r.figures.mse);
                        csv += fmt::format("\"{}\",{},{},{},{:.9g},{:.9g},{:.9g}\n", baseLabels[b], sweepOption, v, r.spp,
                                           r.figures.bias2, r.figures.variance, r.figures.mse);
                    }
                    panel.curves.push_back(c);
                }
            writeTextFile((fs::path(outDir) / "sweep.csv").string(), csv);
            PlotFiles pf = plot((fs::path(outDir) / "sweep").string(), {panel}, 760,
                                plotHeight(panel.curves.size()));
            if (!pf.ok) fmt::print(stderr, "biasvar: warning: no sweep plot: {}\n", pf.message);
            summary["sweep"] = {{"option", sweepOption}, {"values", sweepValues}, {"csv", "sweep.csv"},
                                {"plot_png", pf.ok ? nlohmann::json("sweep.png") : nlohmann::json(nullptr)},
                                {"plot_svg", pf.ok ? nlohmann::json("sweep.svg") : nlohmann::json(nullptr)}};
        }
        summary["all_checks_ok"] = allOk;
        writeTextFile((fs::path(outDir) / "biasvar.json").string(), summary.dump(2) + "\n");
    } catch (const std::exception& e) {
        fmt::print(stderr, "biasvar: error: {}\n", e.what());
        return 3;
    }
    fmt::print("biasvar: wrote {}/biasvar.json{}\n", outDir, sppList.size() > 1 ? " and biasvar.png/.svg" : "");
    return 0;
}
