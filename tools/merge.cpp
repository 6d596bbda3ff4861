// merge: sample-count weighted average of renders of the same scene (independent seeds), e.g.
// the chunks of a long reference render. Weights are the spp of each input, read from its JSON
// sidecar (render --stats-json, or the sidecar written by reference/merge) or given with --spp.
// Writes OUT.exr, OUT.png and OUT.json (total spp, inputs, weights, seeds, scene hash if known).
// Exit codes: 0 success, 1 bad command line or inconsistent inputs, 2 an input cannot be read,
// 3 output not written.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <filesystem>
#include <set>
#include "tools/analysis.h"
#include "tools/cli_checks.h"

using namespace lt;
using namespace lt::analysis;
namespace fs = std::filesystem;

namespace {

// OUT.json for OUT.exr; for an input also IN.exr.json and IN.stats.json.
std::string findSidecar(const std::string& img) {
    fs::path p(img);
    for (fs::path c : {fs::path(p).replace_extension(".json"), fs::path(img + ".json"),
                       fs::path(p).replace_extension(".stats.json")}) {
        std::error_code ec;
        if (fs::is_regular_file(c, ec)) return c.string();
    }
    return "";
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"merge: sample-count weighted average of EXR renders of the same scene"};
    std::string out;
    std::vector<std::string> inputs, stats;
    std::vector<double> spps;
    bool allowSameSeed = false;
    app.add_option("-o,--output", out, "Merged image (.exr or .pfm); a .png and a .json sidecar are written beside it")
        ->required();
    app.add_option("inputs", inputs, "Input images (.exr/.pfm/.hdr)")->required();
    app.add_option("--spp", spps, "Sample counts of the inputs, in order (instead of the JSON sidecars)")
        ->allow_extra_args(false)
        ->check(lt::cli::positive());
    app.add_option("--stats", stats, "JSON sidecars of the inputs, in order (default: IN.json, IN.exr.json or "
                                     "IN.stats.json beside each input)")
        ->allow_extra_args(false);
    app.add_flag("--allow-same-seed", allowSameSeed, "Accept inputs rendered with the same seed (their noise is identical)");
    app.footer("Exit codes: 0 success, 1 bad command line or inconsistent inputs, 2 unreadable input, 3 output not written.");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 1;
    }
    auto fail = [](int code, const std::string& msg) {
        fmt::print(stderr, "merge: error: {}\n", msg);
        return code;
    };
    if (!spps.empty() && spps.size() != inputs.size())
        return fail(1, fmt::format("{} --spp values for {} inputs", spps.size(), inputs.size()));
    if (!stats.empty() && stats.size() != inputs.size())
        return fail(1, fmt::format("{} --stats files for {} inputs", stats.size(), inputs.size()));
    std::string ext = fs::path(out).extension().string();
    if (ext != ".exr" && ext != ".pfm") return fail(1, "--output must end in .exr or .pfm");

    std::vector<Image> imgs;
    std::vector<double> weights;
    nlohmann::json jin = nlohmann::json::array();
    std::set<uint64_t> seeds;
    std::set<std::string> hashes, scenes;
    double seconds = 0;
    bool secondsKnown = true;
    for (size_t i = 0; i < inputs.size(); ++i) {
        try {
            imgs.push_back(readImage(inputs[i]));
        } catch (const std::exception& e) {
            return fail(2, e.what());
        }
        if (auto bad = findNonFinite(imgs.back()))
            return fail(2, fmt::format("{}: non-finite value at pixel ({}, {})", inputs[i], bad->first, bad->second));
        nlohmann::json side, entry = {{"path", fs::absolute(inputs[i]).string()}};
        std::string sidePath = !stats.empty() ? stats[i] : findSidecar(inputs[i]);
        if (!sidePath.empty()) {
            try {
                side = nlohmann::json::parse(readFile(sidePath));
            } catch (const std::exception& e) {
                return fail(2, fmt::format("{}: {}", sidePath, e.what()));
            }
            entry["sidecar"] = fs::absolute(sidePath).string();
        }
        double w = 0;
        if (!spps.empty()) {
            w = spps[i];
        } else if (side.contains("spp") && side["spp"].is_number() && side["spp"].get<double>() > 0) {
            w = side["spp"].get<double>();
        } else {
            return fail(1, fmt::format("no sample count for {}: give --spp, or a JSON sidecar with \"spp\" "
                                       "(render -o X.exr --stats-json X.json)", inputs[i]));
        }
        entry["spp"] = w;
        if (side.contains("seed")) {
            uint64_t s = side["seed"].get<uint64_t>();
            entry["seed"] = s;
            if (!seeds.insert(s).second && !allowSameSeed)
                return fail(1, fmt::format("{} was rendered with seed {} like an earlier input: the renders are not "
                                           "independent (use different --seed values, or --allow-same-seed)", inputs[i], s));
        }
        if (side.contains("seconds")) seconds += side["seconds"].get<double>();
        else secondsKnown = false;
        if (side.contains("scene_sha256")) hashes.insert(side["scene_sha256"].get<std::string>());
        if (side.contains("scene")) scenes.insert(side["scene"].get<std::string>());
        weights.push_back(w);
        jin.push_back(entry);
    }
    if (hashes.size() > 1) return fail(1, "the inputs come from different scenes (their scene_sha256 differ)");
    Image merged;
    try {
        merged = weightedAverage(imgs, weights);
    } catch (const std::exception& e) {
        return fail(1, e.what());
    }
    double total = 0;
    for (double w : weights) total += w;
    for (size_t i = 0; i < jin.size(); ++i) jin[i]["weight"] = weights[i] / total;

    nlohmann::json j;
    j["tool"] = "merge";
    j["command"] = commandLine(argc, argv);
    j["date"] = nowUtc();
    j["spp"] = total;
    if (secondsKnown) j["seconds"] = seconds;
    j["width"] = merged.width;
    j["height"] = merged.height;
    if (hashes.size() == 1) j["scene_sha256"] = *hashes.begin();
    if (scenes.size() == 1) j["scene"] = *scenes.begin();
    j["inputs"] = jin;
    try {
        fs::path op(out);
        if (op.has_parent_path()) fs::create_directories(op.parent_path());
        writeImage(merged, out);
        writePng(merged, fs::path(out).replace_extension(".png").string());
        writeTextFile(fs::path(out).replace_extension(".json").string(), j.dump(2) + "\n");
    } catch (const std::exception& e) {
        return fail(3, fmt::format("could not write '{}': {}", out, e.what()));
    }
    fmt::print("merge: {} inputs, {} spp in total -> {}\n", inputs.size(), total, out);
    return 0;
}
