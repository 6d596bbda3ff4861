// reference: a long render split into independent chunks (seeds seed, seed+1, ...), rendered in
// this process one after the other, each stored as REF.chunks/chunk<i>.exr + .json so an
// interrupted run resumes (finished chunks with matching settings are reused), then merged
// sample-count weighted into REF.exr (+ .png). REF.json records the command, the settings, the
// chunks and the scene hash (SHA-256 over the scene file, its includes and its mesh files).
// When REF.json already matches the scene hash and the settings, nothing is rendered.
// Under mpirun every chunk is rendered by all the ranks together (render's machinery,
// integrators/distributed/cluster.h: the same image as one process); rank 0 decides which chunks
// are reused and writes every file.
// Exit codes: 0 success (or up to date), 1 bad command line, 2 bad scene, 3 output not written,
// 4 rendering failed.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <filesystem>
#include "core/loader.h"
#include "core/scene.h"
#include "integrators/distributed/cluster.h"
#include "tools/analysis.h"
#include "tools/cli_checks.h"

using namespace lt;
using namespace lt::analysis;
namespace fs = std::filesystem;

static int run(int argc, char** argv, const dist::Session& session) {
    // Rank 0's answer on every rank (the files it reads decide; the others follow it).
    dist::Cluster* cluster = session.cluster();
    auto agree = [&](bool rootValue) { return cluster ? cluster->max(session.root() && rootValue) != 0 : rootValue; };
    CLI::App app{"reference: long render in independent chunks, merged, with a JSON sidecar (command, scene hash)"};
    std::string scenePath, out, spec = "pt";
    std::vector<std::string> defineList;
    int spp = 0, chunks = 0, threads = 0;
    double timeTotal = 0;
    uint64_t seed = 0x5EED0000ull;
    bool force = false, clean = false, check = false;
    app.add_option("scene", scenePath, "Scene file (Mitsuba 3 XML)")->required();
    app.add_option("-o,--output", out, "Reference image (.exr); REF.png, REF.json and the folder REF.chunks/ go beside it")
        ->required();
    app.add_option("-c,--config", spec, "Configuration (integrator and options), default \"pt\"");
    auto* sppOpt = app.add_option("--spp", spp, "Total samples per pixel (default 1024 unless --time)")->check(lt::cli::positive());
    app.add_option("--time", timeTotal, "Total render time in seconds instead of --spp (split evenly over the chunks)")
        ->check(lt::cli::positive())
        ->excludes(sppOpt);
    app.add_option("--chunks", chunks, "Independent chunks (default: 8, at most spp)")->check(lt::cli::positive());
    app.add_option("--seed", seed, "Seed of chunk 0; chunk i uses seed + i (default 0x5EED0000, apart from the seeds "
                                   "the other tools use by default)");
    app.add_option("--threads", threads, "Worker threads (0 = all cores)")->check(lt::cli::nonNegative("0 = all cores"));
    app.add_option("-D", defineList, "Override a <default> of the scene: -D name=value")->take_all()->allow_extra_args(false);
    app.add_flag("--force", force, "Render even if REF.json says the reference is up to date (chunks are re-rendered too)");
    app.add_flag("--clean", clean, "Delete REF.chunks/ after merging");
    app.add_flag("--check", check, "Only check whether REF.json matches the scene and settings (exit 0 yes, 5 no)");
    app.footer("Exit codes: 0 success or up to date, 1 bad command line, 2 bad scene, 3 output not written, "
               "4 rendering failed, 5 (--check) stale or missing.");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 1;
    }
    if (spp == 0 && timeTotal == 0) spp = 1024;
    if (chunks == 0) chunks = spp > 0 ? std::min(8, spp) : 8;
    if (spp > 0 && chunks > spp) {
        fmt::print(stderr, "reference: error: more chunks ({}) than spp ({})\n", chunks, spp);
        return 1;
    }
    if (fs::path(out).extension() != ".exr") {
        fmt::print(stderr, "reference: error: --output must end in .exr\n");
        return 1;
    }
    std::map<std::string, std::string> defines;
    std::vector<RunConfig> configs;
    if (int rc = parseRunInputs("reference", defineList, {spec}, "", defines, configs)) return rc;
    const RunConfig cfg = configs.front();
    SceneDesc desc;
    SceneHash hash;
    if (int rc = loadRunScene("reference", scenePath, defines, desc, &hash)) return rc;

    // What makes a reference (or a chunk) reusable.
    nlohmann::json key = {{"scene_sha256", hash.sha256}, {"config", cfg.spec}, {"spp", spp}, {"time", timeTotal},
                          {"chunks", chunks}, {"seed", seed}, {"width", desc.camera.width}, {"height", desc.camera.height}};
    fs::path outPath(out), side = fs::path(out).replace_extension(".json");
    fs::path chunkDir = fs::path(out).replace_extension(".chunks");
    auto matches = [&](const fs::path& json, const nlohmann::json& k) {
        try {
            if (!fs::exists(json)) return false;
            nlohmann::json j = nlohmann::json::parse(readFile(json.string()));
            return j.contains("key") && j["key"] == k;
        } catch (...) {
            return false;
        }
    };
    const bool upToDate = agree(matches(side, key) && fs::exists(outPath));
    if (check) {
        fmt::print("reference: {} is {}\n", out, upToDate ? "up to date" : "stale or missing");
        return upToDate ? 0 : 5;
    }
    if (upToDate && !force) {
        fmt::print("reference: {} is up to date (scene {} unchanged, same settings); use --force to render again\n", out,
                   hash.sha256.substr(0, 12));
        return 0;
    }

    std::vector<Image> imgs;
    std::vector<double> weights;
    nlohmann::json jchunks = nlohmann::json::array();
    double seconds = 0;
    uint64_t totalSpp = 0;
    try {
        if (session.root()) fs::create_directories(chunkDir);
        std::unique_ptr<Scene> scene;
        for (int i = 0; i < chunks; ++i) {
            uint64_t s = seed + uint64_t(i);
            int n = spp > 0 ? spp / chunks + (i < spp % chunks ? 1 : 0) : 0;
            nlohmann::json ckey = {{"scene_sha256", hash.sha256}, {"config", cfg.spec}, {"spp", n},
                                   {"time", timeTotal / chunks}, {"seed", s}};
            fs::path cimg = chunkDir / fmt::format("chunk{}.exr", i), cjson = chunkDir / fmt::format("chunk{}.json", i);
            nlohmann::json cj;
            if (agree(!force && matches(cjson, ckey) && fs::exists(cimg))) {
                if (!session.root()) continue;
                cj = nlohmann::json::parse(readFile(cjson.string()));
                imgs.push_back(readImage(cimg.string()));
                fmt::print(stderr, "reference: chunk {}/{} reused\n", i + 1, chunks);
            } else {
                if (!scene) {  // (the integrator's light selection, as render)
                    SceneDesc d = desc;
                    d.lightSelection = lightSelectionFor(cfg.integrator);
                    scene = std::make_unique<Scene>(d);
                }
                RenderSettings rs = makeSettings(desc, cfg, threads, s);
                rs.cluster = cluster;
                rs.spp = n;
                rs.timeLimit = spp > 0 ? 0.0 : timeTotal / chunks;
                RenderStats st;
                fmt::print(stderr, "reference: chunk {}/{} (seed {}) ...\n", i + 1, chunks, s);
                Image img = renderImage(*scene, rs, st);
                if (!session.root()) continue;
                writeExr(img, cimg.string());
                cj = {{"key", ckey}, {"scene", fs::absolute(scenePath).string()}, {"scene_sha256", hash.sha256},
                      {"integrator", cfg.integrator}, {"spp", st.spp}, {"seconds", st.seconds}, {"seed", s},
                      {"samples", st.samples}, {"invalid_samples", st.invalidSamples}};
                writeTextFile(cjson.string(), cj.dump(2) + "\n");
                imgs.push_back(std::move(img));
            }
            weights.push_back(cj["spp"].get<double>());
            totalSpp += cj["spp"].get<uint64_t>();
            seconds += cj["seconds"].get<double>();
            jchunks.push_back({{"file", fs::relative(cimg, outPath.parent_path().empty() ? fs::path(".") : outPath.parent_path()).string()},
                               {"seed", s}, {"spp", cj["spp"]}, {"seconds", cj["seconds"]}});
        }
    } catch (const ImageError& e) {
        fmt::print(stderr, "reference: error: {}\n", e.what());
        return 3;
    } catch (const std::exception& e) {
        fmt::print(stderr, "reference: error: rendering failed: {}\n", e.what());
        return 4;
    }

    if (!session.root()) return 0;
    Image merged = weightedAverage(imgs, weights);
    nlohmann::json j;
    j["tool"] = "reference";
    j["command"] = commandLine(argc, argv);
    j["cwd"] = fs::current_path().string();
    j["date"] = nowUtc();
    j["scene"] = fs::absolute(scenePath).string();
    j["scene_sha256"] = hash.sha256;
    j["scene_files"] = nlohmann::json::array();
    for (const auto& [f, h] : hash.files) j["scene_files"].push_back({{"path", fs::absolute(f).string()}, {"sha256", h}});
    j["defines"] = defines;
    j["config"] = cfg.spec;
    j["integrator"] = cfg.integrator;
    j["spp"] = totalSpp;
    j["seconds"] = seconds;
    j["width"] = merged.width;
    j["height"] = merged.height;
    j["seed"] = seed;
    j["chunks"] = jchunks;
    j["key"] = key;
    try {
        if (outPath.has_parent_path()) fs::create_directories(outPath.parent_path());
        writeExr(merged, out);
        writePng(merged, fs::path(out).replace_extension(".png").string());
        writeTextFile(side.string(), j.dump(2) + "\n");
        if (clean) fs::remove_all(chunkDir);
    } catch (const std::exception& e) {
        fmt::print(stderr, "reference: error: could not write '{}': {}\n", out, e.what());
        return 3;
    }
    fmt::print("reference: {} spp in {} chunks, {:.1f} s -> {} (scene sha256 {})\n", totalSpp, chunks, seconds, out,
               hash.sha256.substr(0, 16));
    return 0;
}

int main(int argc, char** argv) {
    dist::Session session(argc, argv);
    return session.run([&] { return run(argc, argv, session); });
}
