// render: renders a Mitsuba-XML scene to EXR (+ an sRGB PNG beside it).
// Exit codes: 0 success; 1 bad command line; 2 bad scene (file, line, parameter named);
// 3 output could not be written; 4 other runtime failure.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <fmt/ranges.h>
#include <csignal>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <unistd.h>
#include <map>
#include <sstream>
#include <nlohmann/json.hpp>
#include "bsdf/energy_compensation.h"
#include "bsdf/roughness_bound.h"
#include "core/image.h"
#include "core/loader.h"
#include "integrators/distributed/cluster.h"
#include "integrators/integrator.h"
#include "tools/analysis.h"
#include "tools/cli_checks.h"

using namespace lt;
namespace fs = std::filesystem;

static std::string formatRate(double v) {
    if (v >= 1e9) return fmt::format("{:.2f} G", v / 1e9);
    if (v >= 1e6) return fmt::format("{:.2f} M", v / 1e6);
    if (v >= 1e3) return fmt::format("{:.2f} k", v / 1e3);
    return fmt::format("{:.1f} ", v);
}

// SIGINT and SIGTERM: the first stops the render after the pass in flight (the image of the
// completed passes is written, exit code 5); a second one exits at once (128 + the signal).
std::atomic<bool> gStop{false};
std::atomic<int> gSignals{0};
extern "C" void onStopSignal(int sig) {
    if (gSignals.fetch_add(1, std::memory_order_relaxed) > 0) _exit(128 + sig);
    gStop.store(true, std::memory_order_relaxed);
    static const char msg[] = "\nrender: stopping after the pass in flight (a second signal quits at once)\n";
    const ssize_t ignored = write(STDERR_FILENO, msg, sizeof msg - 1);
    (void)ignored;
}
void installStopHandlers() {
    static_assert(std::atomic<bool>::is_always_lock_free && std::atomic<int>::is_always_lock_free,
                  "the signal handler uses them");
    struct sigaction sa {};
    sa.sa_handler = onStopSignal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
}

// ---- Checkpoints: a text header (magic, key, passes, film bytes), then the film's state ----------
// (2: the key holds the regulariser's settings as they apply, regularizerSettings; a version-1
// checkpoint's key could not match, and is refused by its magic instead; 4: the film's exact sums,
// core/exact_sum.h)
constexpr const char* kCheckpointMagic = "lighttransport checkpoint 4";

// The regulariser's settings as the integrator uses them: the defaults resolved, and only the
// chosen regulariser's (none: its name alone). The stats JSON reports them; the checkpoint key
// hashes them, so that a render resumed with a default written out (--reg-tail-rr 0.1,
// --reg-opsr-gamma 0.01) or with another regulariser's option is the same render, and one with
// any value that changes the image is another. `asUsed`: the values the integrator reads as
// floats rounded as it rounds them (the key); else as given (the stats JSON).
nlohmann::json regularizerSettings(const RenderSettings& s, bool asUsed) {
    auto value = [&](double v) { return asUsed ? double(float(v)) : v; };
    nlohmann::json j;
    j["regularizer"] = s.regularizer;
    const bool jg19 = s.regularizer == "jg19", both = s.regularizer == "jg19,opsr", opsr = both || s.regularizer == "opsr";
    if (jg19 || both) {
        j["reg_tau0"] = s.regTau > 0.0 ? s.regTau : regTauDefault(s.integrator);
        j["reg_schedule"] = s.regSchedule;
        j["reg_bound"] = s.regBound;
    }
    if (jg19 || opsr) j["reg_energy"] = s.regEnergy;
    if (jg19) {
        j["reg_mis"] = s.regMis;
        j["reg_quality"] = s.regQuality;
        j["reg_diffusion"] = regDiffusionOf(s);
        j["reg_specular"] = s.regSpecular;
    }
    if (s.regularizer == "kd13") {
        j["reg_r0"] = s.regR0;  // (<= 0: the default, 1% of the geometry's bounding radius)
        j["reg_lambda"] = s.regLambda;  // (< 0: the defaults, 1/6 and 1/12)
    }
    if (opsr) {
        if (!s.regOpsrTable.empty()) j["reg_opsr_table"] = s.regOpsrTable;
        else j["reg_opsr_gamma"] = value(s.regOpsrGamma >= 0.0 ? s.regOpsrGamma : double(opsr::kDefaultGamma));
        j["reg_opsr_consistent"] = s.regOpsrConsistent;
        j["reg_opsr_always_sample"] = s.regOpsrAlwaysSample;
        if (s.regOpsrConsistent) j["reg_lambda"] = s.regLambda;  // (< 0: the default, 1/6)
    }
    if (s.regularizer != "none")
        j["reg_tail_rr"] = value(s.regTailRr >= 0.0 ? s.regTailRr : reg::kDefaultTailThreshold);
    return j;
}

std::string checkpointKeyOf(const std::string& scenePath, const std::map<std::string, std::string>& defines,
                            const RenderSettings& s) {
    const std::string settings =
        fmt::format("integrator {}\nseed {}\nmax_depth {}\nrr_depth {}\nhide_emitters {}\npt_strategy {}\nradius {}\n"
                    "radius_alpha {}\nregulariser {}\nguiding {} {} {} {} {}\nlight_selection {}\n",
                    s.integrator, s.seed, s.maxDepth, s.rrDepth, s.hideEmitters, s.ptStrategy, s.radius,
                    s.radiusAlpha, regularizerSettings(s, true).dump(), s.guiding, s.guidingBsdfFraction,
                    s.guidingCombine, s.guidingSpatialThreshold, s.guidingMaxMb, s.lightSelection);
    return analysis::sha256Hex(analysis::hashScene(scenePath, defines).sha256 + "\n" + settings);
}

// The integrator's state (path guiding's trainer; often empty) follows the film's bytes.
void writeCheckpoint(const std::string& path, const std::string& key, uint64_t passes, const Film& film,
                     const std::string& integratorState) {
    const std::string state = film.state();
    analysis::writeTextFile(path, fmt::format("{}\nkey {}\npasses {}\nbytes {}\nintegrator_bytes {}\n", kCheckpointMagic,
                                              key, passes, state.size(), integratorState.size()) +
                                      state + integratorState);
}

// Reads a checkpoint written with `key`; throws naming what is wrong (another scene, integrator
// or settings; not a checkpoint; truncated).
void readCheckpoint(const std::string& path, const std::string& key, uint64_t& passes, std::string& film,
                    std::string& integratorState) {
    const std::string all = analysis::readFile(path);
    std::istringstream in(all);
    std::string magic, word, fileKey;
    size_t bytes = 0;
    std::getline(in, magic);
    if (magic != kCheckpointMagic)
        throw std::runtime_error(magic.rfind("lighttransport checkpoint ", 0) == 0
                                     ? "a checkpoint of another version of this renderer ('" + magic + "')"
                                     : "not a checkpoint of this renderer");
    if (!(in >> word >> fileKey) || word != "key") throw std::runtime_error("malformed header (key)");
    if (!(in >> word >> passes) || word != "passes") throw std::runtime_error("malformed header (passes)");
    if (!(in >> word >> bytes) || word != "bytes") throw std::runtime_error("malformed header (bytes)");
    size_t integratorBytes = 0;
    if (!(in >> word >> integratorBytes) || word != "integrator_bytes")
        throw std::runtime_error("malformed header (integrator_bytes)");
    in.get();  // the newline
    if (fileKey != key)
        throw std::runtime_error("it is from another scene, integrator or settings (key " + fileKey.substr(0, 12) +
                                 ", this render's " + key.substr(0, 12) + ")");
    const size_t at = size_t(in.tellg());
    if (all.size() != at + bytes + integratorBytes) throw std::runtime_error("truncated or damaged (film size)");
    film = all.substr(at, bytes);
    integratorState = all.substr(at + bytes);
}

// Why the file `out` could not be written, or "" where it can: its folder is created where missing,
// and a probe file is written in it and removed (the file itself is not touched).
std::string whyNotWritable(const fs::path& out) {
    if (fs::is_directory(out)) return "it is a folder";
    fs::path dir = out.parent_path();
    if (dir.empty()) dir = ".";
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) return fmt::format("cannot create the folder '{}': {}", dir.string(), ec.message());
    const fs::path probe = dir / fmt::format(".{}.{}.probe", out.filename().string(), ::getpid());
    bool ok = false;
    {
        std::ofstream f(probe);
        ok = f && (f << "probe") && f.flush();
    }
    fs::remove(probe, ec);
    return ok ? std::string() : fmt::format("cannot write in the folder '{}'", dir.string());
}

// What tau_0 and tau_N mean for a user (issue 45): the alpha that glass (eta 1.5, its refraction
// lobe) and a mirror take under JG19's consistent schedule with the default bound (tight,
// compensated), computed by the renderer's own functions.
std::string regTauTable() {
    std::string out = "alpha of smooth glass (eta 1.5) / a mirror under tau_N (tight bound, compensated):";
    const LobeCompensation glass(1.5f, true), mirror(1.f, false);  // (built once: a few ms each)
    for (double tau0 : {30.0, 1000.0}) {
        out += fmt::format(" tau_0 {}:", tau0);
        for (uint64_t n : {uint64_t(1), uint64_t(256), uint64_t(65536)}) {
            const float tau = float(consistentTau(tau0, n));
            out += fmt::format(" N={} {:.3f}/{:.3f}{}", n, glass.alphaFor(tau, true, BoundForm::Tight),
                               mirror.alphaFor(tau, false, BoundForm::Tight), n == 65536 ? ";" : ",");
        }
    }
    return out;
}

static int run(int argc, char** argv, const dist::Session& session) {
    CLI::App app{"render: a light-transport renderer for Mitsuba 3 XML scenes"};
    std::string scenePath, output, integrator;
    int spp = 0, threads = 0, maxDepth = -2;
    double timeLimit = 0.0;
    uint64_t seed = 0;
    bool seedGiven = false, quiet = false;
    std::vector<std::string> defines;
    std::string statsJson;
    app.add_option("scene", scenePath, "Scene file (Mitsuba 3 XML)")->required();
    app.add_option("-o,--output", output, "Output image (.exr or .pfm); a .png is written beside it. "
                                          "Default: out/<scene name>.exr");
    app.add_option("--integrator", integrator, "Integrator, overrides the scene's: " + supportedIntegrators());
    std::string lightSelection = "auto";
    app.add_option("--light-selection", lightSelection,
                   "How light samples choose a light (times each emitter's sampling_weight): auto (uniform for pt, "
                   "mix for the others), uniform (Mitsuba's), power, mix (half each)")
        ->check(CLI::IsMember({"auto", "uniform", "power", "mix"}));
    auto* sppOpt = app.add_option("--spp", spp, "Samples per pixel (overrides the scene's sample_count)")
                       ->check(lt::cli::positive());
    app.add_option("--time", timeLimit, "Render for this many seconds instead of a fixed spp")
        ->check(lt::cli::positive())
        ->excludes(sppOpt);
    app.add_option("--threads", threads, "Worker threads (0 = all cores)")->check(lt::cli::nonNegative("0 = all cores"));
    auto* seedOpt = app.add_option("--seed", seed, "Random seed (overrides the scene's sampler seed)");
    app.add_option("--max-depth", maxDepth, "Maximum path length in segments (-1 = unlimited)")
        ->check(lt::cli::range(-1, 64, false, false, "-1 = unlimited"));
    app.add_option("-D", defines, "Override a <default> of the scene: -D name=value")->take_all();
    std::string ptStrategy = "mis", strategyImages;
    float radius = -1.f, radiusAlpha = -1.f;
    app.add_option("--radius", radius, "VCM/PPM initial merge radius (default: the scene's, else 0.003 x the geometry's bounding radius)")
        ->check(lt::cli::positive());
    app.add_option("--radius-alpha", radiusAlpha, "VCM/PPM radius reduction: r_i = r_0 i^((alpha-1)/2), alpha in (0,1]")
        ->check(lt::cli::range(0.0, 1.0, true, false));
    app.add_option("--strategy-images", strategyImages,
                   "Write each technique's weighted contribution (s_t.exr, merge_s.exr; under a regulariser regularised.exr and "
                   "singular.exr) to this directory");
    app.add_option("--pt-strategy", ptStrategy, "PT techniques: mis (default), nee, bsdf")
        ->check(CLI::IsMember({"mis", "nee", "bsdf"}));
    std::string regularizer, regSchedule, regMis, regQuality, regDiffusion, regSpecular, regBound, regEnergy;
    double regTau = -1.0;
    app.add_option("--reg", regularizer,
                   "Path-space regulariser: none (default), jg19 (microfacet roughness bound), kd13 (cone mollifier "
                   "of smooth vertices on paths no technique of the integrator samples; in pt next-event estimation "
                   "and, with several lights, a BSDF-sampled ray counting a point light within the cone, weighted by "
                   "MIS), opsr (accumulated roughness "
                   "at connection vertices, Weier et al. 2021: the path tracer's next-event estimation as the paper; "
                   "in bpt/vcm/lt each connection end with its own subpath's roughness, our extension, smooth "
                   "vertices only on paths no technique samples; not ppm), jg19,opsr (OPSR with JG19's bound: "
                   "alpha' = max(alpha, accumulated roughness, alpha_hat(tau_N)) at the vertices OPSR regularises, "
                   "and the bound alone where the roughness changes nothing, e.g. a point light seen through glass; "
                   "our combination: --reg-tau and --reg-schedule apply, JG19's heuristics do not); overrides the scene's")
        ->check(CLI::IsMember(kRegularizerNames));
    app.add_option("--reg-tau", regTau,
                   "JG19 bound tau_0 on the BSDF at connections and merges (default 30 for pt/bpt/lt, 1000 for "
                   "vcm/ppm; JG19 Sec. 6); must exceed 1/(2 pi). " + regTauTable())
        ->check(lt::cli::greaterThan(kMinTau, "1/(2 pi) = 0.159"));
    app.add_option("--reg-schedule", regSchedule,
                   "JG19 tau over iterations: consistent (default; Eq. 16, tau_N grows, the bias vanishes) or fixed")
        ->check(CLI::IsMember(kRegScheduleNames));
    app.add_option("--reg-mis", regMis,
                   "JG19 MIS densities: regularised (default; Eq. 13) or sampling (the naive weights, JG19 Fig. 3a)")
        ->check(CLI::IsMember(kRegMisNames));
    app.add_option("--reg-quality", regQuality,
                   "JG19 sampler quality heuristic (Eqs. 17-18): on (default; a path an unbiased technique samples "
                   "well is not regularised, the others at one connection chosen per path) or off (every technique "
                   "at its own ends: counts light twice where an unbiased technique also reaches it)")
        ->check(CLI::IsMember({"on", "off"}));
    app.add_option("--reg-diffusion", regDiffusion,
                   "JG19 path diffusion heuristic (Eqs. 19-21): the bound at a regularised vertex is tau / sigma, "
                   "sigma the angular spread along the path from the camera (BSDF bounds and surface curvature): "
                   "sharper near the camera, blurrier after rough bounces. on (default with --reg-quality on) or off; "
                   "it needs the quality heuristic")
        ->check(CLI::IsMember({"on", "off"}));
    app.add_option("--reg-specular", regSpecular,
                   "JG19 smooth metal and glass at a regularised vertex: ggx (default; a rough GGX lobe with "
                   "alpha_hat(tau')) or cone (KD13's cone mollifier with 1 / Omega = tau', JG19 Fig. 4: keeps the "
                   "delta's energy)")
        ->check(CLI::IsMember(kRegSpecularNames));
    app.add_option("--reg-bound", regBound,
                   "JG19 bound on a lobe's value (also --reg jg19,opsr): tight (default; the lobe's true supremum over "
                   "all direction pairs: GGX glass at tau 30 -> alpha 0.31 instead of 0.79, 0.39 compensated) or published (Eqs. 8-9, "
                   "to reproduce the paper)")
        ->check(CLI::IsMember(kRegBoundNames));
    app.add_option("--reg-energy", regEnergy,
                   "JG19 and OPSR: a smooth mirror or glass made rough keeps the albedo of its delta lobes "
                   "(compensate, default: F reflected and 1 - F transmitted, as the smooth surface; an isotropic "
                   "rough metal made rougher keeps its own; rough glass is not compensated) or loses what the "
                   "single-scattering rough lobe loses (none)")
        ->check(CLI::IsMember(kRegEnergyNames));
    double regR0 = -1.0, regLambda = -1.0;
    app.add_option("--reg-r0", regR0,
                   "KD13 initial radius r_0 of the cone at a smooth vertex, eps = arctan(r_N / l) over a connection of "
                   "length l (default 1% of the geometry's bounding radius; KD13 Sec. 6)")
        ->check(lt::cli::positive());
    app.add_option("--reg-lambda", regLambda,
                   "KD13 radius reduction r_N = r_0 N^-lambda, N the pass (default 1/6 for one mollified vertex, 1/12 for "
                   "two, KD13 Sec. 5.1; consistent for lambda < 1/2 with one, < 1/4 with two; 0: a fixed radius)")
        ->check(lt::cli::range(0.0, 0.5, false, true, "0: a fixed radius"));
    double regOpsrGamma = -1.0;
    std::string regOpsrTable;
    bool regOpsrConsistent = false, regOpsrAlwaysSample = false;
    app.add_option("--reg-opsr-gamma", regOpsrGamma,
                   "OPSR constant attenuation factor gamma (Eq. 11; default 0.01, the paper's naive setting; 0 renders "
                   "as --reg none)")
        ->check(lt::cli::range(0.0, 1.0));
    app.add_option("--reg-opsr-table", regOpsrTable,
                   "OPSR per-path-class attenuation factors (Eqs. 13-14) from a JSON file, FILE[:SET] (SET default "
                   "low; e.g. ../shared/data/opsr/opsr-reference-attenuation.json:moderate; 'interp' sets are looked up "
                   "multilinearly)");
    app.add_flag("--reg-opsr-consistent", regOpsrConsistent,
                 "OPSR consistent offset (Sec. 4.2): the roughness added shrinks as N^-lambda, N the pass "
                 "(lambda: --reg-lambda, default 1/6)");
    app.add_flag("--reg-opsr-always-sample", regOpsrAlwaysSample,
                 "OPSR in pt: draw the regularised BSDF sample for the emitter-hit technique at every vertex OPSR "
                 "changes, as the reference implementation (default: where the walk's own sample covers the "
                 "regularised lobe, a GGX lobe made at most twice as rough, that sample stands in, with no extra ray)");
    double regTailRr = -1.0;
    app.add_option("--reg-tail-rr", regTailRr,
                   "Every regulariser: Russian roulette on the connections only it makes (an end whose own BSDF gives "
                   "nothing there, a smooth one made rough): the shadow ray is cast with probability min(1, pi f / T), f "
                   "the regularised BSDF value there (pi f = 1 for a white Lambertian), and the contribution divided by "
                   "it; unbiased for the regularised image (default 0.1; 0 casts every one)")
        ->check(lt::cli::range(0.0, kMaxRegTailRr));
    std::string guiding, guidingFraction, guidingCombine = "inverse-variance";
    double guidingSpatialThreshold = 4000.0, guidingMaxMb = 512.0;
    app.add_option("--guiding", guiding,
                   "Path guiding of pt (integrators/guiding/): off (default), radiance (Mueller et al. 2017's "
                   "SD-tree, incident radiance) or variance (Rath et al. 2020, Eq. 21 with the MIS compensation of "
                   "Eq. 25); trains in iterations of doubling length over the first half of the budget")
        ->check(CLI::IsMember({"off", "radiance", "variance"}));
    app.add_option("--guiding-bsdf-fraction", guidingFraction,
                   "Probability of BSDF sampling in the one-sample mixture with the guide: a number in (0, 1] "
                   "(default 0.5) or 'learned' (per spatial leaf, Rath Eq. 27, kept >= 0.1)");
    app.add_option("--guiding-combine", guidingCombine,
                   "The guided image: inverse-variance (every iteration weighted by the inverse of its variance, "
                   "Mueller 2019; default) or last (the final iteration alone)")
        ->check(CLI::IsMember({"inverse-variance", "last"}));
    app.add_option("--guiding-spatial-threshold", guidingSpatialThreshold,
                   "c of the spatial split: a leaf splits when iteration k left more than c sqrt(2^k) records in it "
                   "(default 4000)")
        ->check(lt::cli::range(1.0, 1e12));
    app.add_option("--guiding-max-mb", guidingMaxMb, "Cap on the guiding trees' memory in MiB (default 512)")
        ->check(lt::cli::range(0.001, 1e6));
    std::string guidingDump;
    app.add_option("--guiding-dump", guidingDump,
                   "Write what the guide learned to this folder: leaves.png (the spatial leaves seen from the camera), "
                   "dir_X_Y.png (the directional density of the leaf at pixel X,Y of a 4x4 grid over the square "
                   "((cos theta + 1) / 2, phi / 2 pi), log scale 1e-3..1e3 of uniform) and points.txt");
    app.add_flag("-q,--quiet", quiet, "No progress bar");
    app.add_option("--stats-json", statsJson, "Write render statistics as JSON to this file");
    std::string checkpointPath, resumePath;
    double checkpointEvery = 60.0;
    app.add_option("--checkpoint", checkpointPath,
                   "Save the accumulated film and the pass count to this file (atomically) every --checkpoint-every "
                   "seconds and at the end; --resume continues from it");
    app.add_option("--checkpoint-every", checkpointEvery, "Seconds between checkpoints (default 60)")
        ->check(lt::cli::positive());
    app.add_option("--resume", resumePath,
                   "Continue a render from a checkpoint of the same scene, integrator and settings, to --spp in all "
                   "(bit for bit the image of one run straight through)");
    app.footer("Exit codes: 0 success, 1 bad command line, 2 bad scene, 3 output not written, 4 runtime error, "
               "5 interrupted (SIGINT or SIGTERM: the image of the passes done was written; a second signal quits at "
               "once with 128 + the signal).");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        int code = app.exit(e);
        return code == 0 ? 0 : 1;
    }
    seedGiven = seedOpt->count() > 0;

    std::map<std::string, std::string> defs;
    try {
        defs = parseDefines(defines);
    } catch (const std::invalid_argument& e) {
        fmt::print(stderr, "error: {}\n", e.what());
        return 1;
    }
    if (output.empty()) output = (fs::path("out") / fs::path(scenePath).stem()).string() + ".exr";
    std::string ext = fs::path(output).extension().string();
    if (ext != ".exr" && ext != ".pfm") {
        fmt::print(stderr, "error: --output must end in .exr or .pfm, got '{}'\n", output);
        return 1;
    }
    // The outputs' folders are made now (a missing one is created) and written to once, so an
    // output that cannot be written fails before the render, not after it.
    for (const std::string& file : {output, statsJson}) {
        if (file.empty()) continue;
        const std::string why = whyNotWritable(file);
        if (!why.empty()) {
            fmt::print(stderr, "error: cannot write '{}': {}\n", file, why);
            return 3;
        }
    }

    SceneDesc desc;
    try {
        desc = loadScene(scenePath, defs);
    } catch (const SceneError& e) {
        fmt::print(stderr, "error: {}\n", e.what());
        return 2;
    } catch (const std::exception& e) {
        fmt::print(stderr, "error: {}: {}\n", scenePath, e.what());
        return 2;
    }
    for (const std::string& w : desc.warnings) fmt::print(stderr, "warning: {}\n", w);

    RenderSettings settings;
    if (!integrator.empty()) {
        settings.integrator = integrator;
    } else {
        settings.integrator = integratorForSceneType(desc.integrator.type);  // the loader only yields known types
    }
    settings.spp = spp > 0 ? spp : (timeLimit > 0 ? 0 : desc.sampleCount);
    settings.timeLimit = timeLimit;
    settings.threads = threads;
    settings.seed = seedGiven ? seed : desc.seed;
    settings.maxDepth = maxDepth >= -1 ? maxDepth : desc.integrator.maxDepth;
    settings.rrDepth = desc.integrator.rrDepth;
    settings.hideEmitters = desc.integrator.hideEmitters;
    settings.quiet = quiet || !session.root();
    settings.cluster = session.cluster();
    settings.ptStrategy = ptStrategy;
    settings.lightSelection = lightSelection;
    desc.lightSelection = lightSelection == "auto"      ? lightSelectionFor(settings.integrator)
                          : lightSelection == "uniform" ? LightSelection::Uniform
                          : lightSelection == "power"   ? LightSelection::Power
                                                        : LightSelection::Mixture;
    settings.radius = radius > 0.f ? radius : desc.integrator.radius;
    settings.radiusAlpha = radiusAlpha > 0.f ? radiusAlpha : desc.integrator.radiusAlpha;
    settings.strategyImages = strategyImages;
    settings.regularizer = !regularizer.empty() ? regularizer : desc.integrator.regularizer;
    settings.regTau = regTau > 0.0 ? regTau : desc.integrator.regTau;
    settings.regSchedule = !regSchedule.empty() ? regSchedule : desc.integrator.regSchedule;
    settings.regMis = !regMis.empty() ? regMis : desc.integrator.regMis;
    settings.regQuality = !regQuality.empty() ? regQuality == "on" : desc.integrator.regQuality;
    settings.regDiffusion = !regDiffusion.empty() ? std::optional<bool>(regDiffusion == "on") : desc.integrator.regDiffusion;
    settings.regSpecular = !regSpecular.empty() ? regSpecular : desc.integrator.regSpecular;
    settings.regBound = !regBound.empty() ? regBound : desc.integrator.regBound;
    settings.regEnergy = !regEnergy.empty() ? regEnergy : desc.integrator.regEnergy;
    settings.regR0 = regR0 > 0.0 ? regR0 : desc.integrator.regR0;
    settings.regLambda = regLambda >= 0.0 ? regLambda : desc.integrator.regLambda;
    settings.regOpsrGamma = regOpsrGamma >= 0.0 ? regOpsrGamma : desc.integrator.regOpsrGamma;
    settings.regOpsrTable = !regOpsrTable.empty() ? regOpsrTable : desc.integrator.regOpsrTable;
    settings.regOpsrConsistent = regOpsrConsistent || desc.integrator.regOpsrConsistent;
    settings.regOpsrAlwaysSample = regOpsrAlwaysSample || desc.integrator.regOpsrAlwaysSample;
    settings.regTailRr = regTailRr >= 0.0 ? regTailRr : desc.integrator.regTailRr;
    settings.guiding = !guiding.empty() ? guiding : desc.integrator.guiding;
    settings.guidingBsdfFraction = desc.integrator.guidingBsdfFraction;
    if (!guidingFraction.empty()) {
        if (guidingFraction == "learned") {
            settings.guidingBsdfFraction = -1.0;
        } else {
            char* end = nullptr;
            const double f = std::strtod(guidingFraction.c_str(), &end);
            if (end == guidingFraction.c_str() || *end != '\0' || !(f > 0.0 && f <= 1.0)) {
                fmt::print(stderr, "error: --guiding-bsdf-fraction: must be a number in (0, 1] or 'learned' (got '{}')\n",
                           guidingFraction);
                return 1;
            }
            settings.guidingBsdfFraction = f;
        }
    }
    settings.guidingCombine = guidingCombine;
    settings.guidingSpatialThreshold = guidingSpatialThreshold;
    settings.guidingMaxMb = guidingMaxMb;
    settings.guidingDump = guidingDump;
    // A knob of another regulariser than the one that runs is a mistake, not a no-op.
    {
        const bool jg19Knob = regTau > 0.0 || !regSchedule.empty() || !regMis.empty() || !regQuality.empty() ||
                              !regDiffusion.empty() || !regSpecular.empty() || !regBound.empty();
        const bool combined = settings.regularizer == "jg19,opsr";  // (JG19's bound and schedule only)
        const bool opsrRuns = settings.regularizer == "opsr" || combined;
        const bool kd13Knob = regR0 > 0.0 || (regLambda >= 0.0 && !opsrRuns);
        const bool opsrKnob = regOpsrGamma >= 0.0 || !regOpsrTable.empty() || regOpsrConsistent || regOpsrAlwaysSample;
        const bool jg19Heuristic = !regMis.empty() || !regQuality.empty() || !regDiffusion.empty() || !regSpecular.empty();
        if (combined && jg19Heuristic) {
            fmt::print(stderr, "error: --reg jg19,opsr takes JG19's bound and schedule only (--reg-tau, --reg-schedule): "
                               "OPSR chooses the vertices and the MIS, so --reg-mis/-quality/-diffusion/-specular do not "
                               "apply\n");
            return 1;
        }
        const bool jg19Misplaced = jg19Knob && settings.regularizer != "jg19" && !combined;
        const bool opsrMisplaced = opsrKnob && !opsrRuns;
        if (!regEnergy.empty() && settings.regularizer != "jg19" && !opsrRuns) {
            fmt::print(stderr, "error: --reg-energy applies to --reg jg19, opsr and jg19,opsr only (this render: --reg {})\n",
                       settings.regularizer);
            return 1;
        }
        if (jg19Misplaced || opsrMisplaced || (kd13Knob && settings.regularizer != "kd13")) {
            fmt::print(stderr, "error: {} applies to --reg {} only (this render: --reg {})\n",
                       jg19Misplaced   ? "--reg-tau/-schedule/-mis/-quality/-diffusion/-specular/-bound"
                       : opsrMisplaced ? "--reg-opsr-gamma/-table/-consistent/-always-sample"
                                       : "--reg-r0/--reg-lambda",
                       jg19Misplaced ? "jg19" : opsrMisplaced ? "opsr" : "kd13", settings.regularizer);
            return 1;
        }
    }

    if (settings.regularizer == "jg19" && !settings.regQuality)
        fmt::print(stderr, "warning: --reg jg19 --reg-quality off regularises every technique at its own ends: "
                           "light that an unbiased technique also reaches through a smooth or very glossy surface is "
                           "counted twice, sharp and blurred (BPT on cornell-box-point-in-glass: +71% on the floor)\n");
    try {
        makeIntegrator(settings);  // validates the name before any work
    } catch (const std::exception& e) {
        fmt::print(stderr, "error: {}\n", e.what());
        return 1;
    }

    // Checkpoints (--checkpoint, --resume): the key is the SHA-256 of the scene (every file it reads
    // and the -D defines) and of every setting that changes the image; spp and threads do not.
    std::string checkpointKey;
    if (!checkpointPath.empty() || !resumePath.empty()) {
        if (settings.spp <= 0 || !strategyImages.empty()) {
            fmt::print(stderr, "error: --checkpoint and --resume need a sample count (--spp or the scene's), not --time, "
                               "and no --strategy-images\n");
            return 1;
        }
        try {
            checkpointKey = checkpointKeyOf(scenePath, defs, settings);
        } catch (const std::exception& e) {
            fmt::print(stderr, "error: {}: {}\n", scenePath, e.what());
            return 2;
        }
    }
    if (!resumePath.empty()) {
        try {
            // (rank 0 reads the checkpoint and holds its film; the other ranks learn its pass count)
            if (session.root())
                readCheckpoint(resumePath, checkpointKey, settings.resumePasses, settings.resumeFilm,
                               settings.resumeIntegrator);
            if (session.cluster()) settings.resumePasses = session.cluster()->max(settings.resumePasses);
        } catch (const std::exception& e) {
            fmt::print(stderr, "error: --resume {}: {}\n", resumePath, e.what());
            return 1;
        }
        if (settings.resumePasses > uint64_t(settings.spp)) {
            fmt::print(stderr, "error: --resume {}: it holds {} passes, more than the {} spp asked\n", resumePath,
                       settings.resumePasses, settings.spp);
            return 1;
        }
    }
    if (!checkpointPath.empty() && session.root()) {
        const std::string why = whyNotWritable(checkpointPath);
        if (!why.empty()) {
            fmt::print(stderr, "error: cannot write '{}': {}\n", checkpointPath, why);
            return 3;
        }
        settings.checkpointEvery = checkpointEvery;
        settings.checkpoint = [&](uint64_t passes, const Film& film, const std::string& integratorState) {
            writeCheckpoint(checkpointPath, checkpointKey, passes, film, integratorState);
        };
    }

    RenderStats stats;
    Image img;
    try {
        Scene scene(desc);
        auto progress = [&](const Progress& p) {
            if (quiet) return;
            double frac = p.passesTotal ? double(p.passesDone) / double(p.passesTotal)
                                        : std::min(1.0, p.seconds / std::max(p.timeLimit, 1e-9));
            double rate = p.seconds > 0 ? double(p.samples) / p.seconds : 0.0;
            double eta = frac > 0 ? p.seconds * (1.0 - frac) / frac : 0.0;
            int bar = 30, filled = int(frac * bar + 0.5);
            fmt::print(stderr, "\r[{}{}] {:5.1f}%  {}samples/s  ETA {:.1f}s ", std::string(filled, '#'),
                       std::string(bar - filled, ' '), 100.0 * frac, formatRate(rate), eta);
        };
        settings.stop = &gStop;
        installStopHandlers();
        img = renderImage(scene, settings, stats, progress);
        if (!quiet) fmt::print(stderr, "\n");
    } catch (const std::exception& e) {
        fmt::print(stderr, "error: rendering failed: {}\n", e.what());
        return 4;
    }
    if (stats.interrupted && stats.spp == 0) {
        fmt::print(stderr, "render: interrupted before the first pass was done: nothing written\n");
        return 5;
    }
    if (!session.root()) return stats.interrupted ? 5 : 0;  // (rank 0 writes what every rank rendered)

    try {
        fs::path out(output);
        if (out.has_parent_path()) fs::create_directories(out.parent_path());
        writeImage(img, output);
        std::string png = fs::path(output).replace_extension(".png").string();
        writePng(img, png);
    } catch (const std::exception& e) {
        fmt::print(stderr, "error: could not write '{}': {}\n", output, e.what());
        return 3;
    }

    double sps = stats.seconds > 0 ? double(stats.samples) / stats.seconds : 0.0;
    double rps = stats.seconds > 0 ? double(stats.rays) / stats.seconds : 0.0;
    fmt::print("{}: {} spp, {:.3f} s, {}samples/s, {}rays/s, {} invalid samples", settings.integrator, stats.spp,
               stats.seconds, formatRate(sps), formatRate(rps), stats.invalidSamples);
    const double regShare =
        stats.contributions ? double(stats.regularisedContributions) / double(stats.contributions) : 0.0;
    if (settings.regularizer != "none")
        fmt::print(", {}: {:.1f}% of contributions regularised, {} {:.4g}", settings.regularizer, 100.0 * regShare,
                   settings.regularizer == "kd13"   ? "r_N"
                   : settings.regularizer == "opsr" ? "offset N^-lambda"
                                                    : "tau_N",
                   stats.tau);
    if (settings.guiding != "off")
        fmt::print(", guiding {}: {} iterations, {} training spp, {} spatial leaves, {} directional nodes, {:.1f} MiB",
                   settings.guiding, stats.guidingIterations, stats.guidingTrainingSpp, stats.guidingLeaves,
                   stats.guidingDirectionalNodes, double(stats.guidingBytes) / double(1 << 20));
    if (!stats.passesPerRank.empty())
        fmt::print(", {} MPI ranks (passes {}), films added in {:.3f} s", stats.passesPerRank.size(),
                   fmt::join(stats.passesPerRank, "/"), stats.reduceSeconds);
    if (!stats.passesPerRank.empty() && settings.guiding != "off")
        fmt::print(", guiding shared in {:.3f} s", stats.guidingShareSeconds);
    if (stats.invalidRegularisation > 0)  // (never expected: each is a refused technique, reported)
        fmt::print(", {} regulariser values not a number (their techniques refused)", stats.invalidRegularisation);
    fmt::print(" -> {}\n", output);
    if (!statsJson.empty()) {
        nlohmann::json j;
        j["scene"] = scenePath;
        j["output"] = output;
        j["integrator"] = settings.integrator;
        j["width"] = img.width;
        j["height"] = img.height;
        j["spp"] = stats.spp;
        j["seconds"] = stats.seconds;
        j["samples"] = stats.samples;
        j["rays"] = stats.rays;
        j["samples_per_second"] = sps;
        j["rays_per_second"] = rps;
        j["invalid_samples"] = stats.invalidSamples;
        j["invalid_regulariser_values"] = stats.invalidRegularisation;
        j["seed"] = settings.seed;
        j["threads"] = threads;
        j["max_depth"] = settings.maxDepth;
        j["rr_depth"] = rrDepthOf(settings);
        j.update(regularizerSettings(settings, false));
        j["guiding"] = settings.guiding;
        if (settings.guiding != "off") {
            j["guiding_bsdf_fraction"] = settings.guidingBsdfFraction < 0.0 ? nlohmann::json("learned")
                                                                            : nlohmann::json(settings.guidingBsdfFraction);
            j["guiding_combine"] = settings.guidingCombine;
            j["guiding_spatial_threshold"] = settings.guidingSpatialThreshold;
            j["guiding_max_mb"] = settings.guidingMaxMb;
            j["guiding_iterations"] = stats.guidingIterations;
            j["guiding_training_spp"] = stats.guidingTrainingSpp;
            j["guiding_spatial_nodes"] = stats.guidingNodes;
            j["guiding_spatial_leaves"] = stats.guidingLeaves;
            j["guiding_directional_nodes"] = stats.guidingDirectionalNodes;
            j["guiding_bytes"] = stats.guidingBytes;
        }
        if (settings.regularizer == "jg19" || settings.regularizer == "jg19,opsr") j["reg_tau_last"] = stats.tau;
        if (settings.regularizer == "kd13") j["reg_r_last"] = stats.tau;  // r_N of one mollified vertex at the last pass
        if (settings.regularizer == "opsr") j["reg_offset_last"] = stats.tau;  // N^-lambda at the last pass (1: none)
        if (settings.regularizer != "none") {
            j["contributions"] = stats.contributions;
            j["regularised_contributions"] = stats.regularisedContributions;
            j["regularised_share"] = regShare;
        }
        if (!stats.passesPerRank.empty()) {
            j["mpi_ranks"] = stats.passesPerRank.size();
            j["mpi_passes_per_rank"] = stats.passesPerRank;
            j["mpi_reduce_seconds"] = stats.reduceSeconds;
            if (settings.guiding != "off") j["mpi_guiding_share_seconds"] = stats.guidingShareSeconds;
        }
        if (stats.interrupted) j["interrupted"] = true;
        std::ofstream f(statsJson);
        f << j.dump(2) << "\n";
        if (!f) {
            fmt::print(stderr, "error: could not write '{}'\n", statsJson);
            return 3;
        }
    }
    if (stats.interrupted) {
        fmt::print(stderr, "render: interrupted: {} holds {} spp{}\n", output, stats.spp,
                   settings.spp > 0 ? fmt::format(" of the {} asked", settings.spp) : std::string());
        return 5;
    }
    return 0;
}

int main(int argc, char** argv) {
    dist::Session session(argc, argv);
    return session.run([&] { return run(argc, argv, session); }, 5);  // (5: interrupted, the image written)
}
