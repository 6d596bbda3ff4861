// imgcompare: error metrics between an image A and a reference B.
//   imgcompare A B [--metric all|mse|relmse|rmsre|mape|mean|top1] [--top-fraction F] [--crop x,y,w,h]
//                  [--error-map out.exr] [--strategies DIR [--worst K]] [--json]
//   imgcompare A REF --ztest --ref-var VAR --spp N [--significance S] [--pvalue-map FILE] [--crop x,y,w,h] [--json]
// --strategies attributes the worst pixels to the techniques whose images (render --strategy-images)
// make up A there (core/metrics.h: attributeWorstPixels).
// --ztest applies Mitsuba 3's per-pixel z-test of its render tests (tools/ztest.h) instead of the metrics.
// Exit codes: 0 success (with --ztest: the test passes), 1 usage error (bad flag/value, crop outside
//             the image), 2 unreadable image, size mismatch, non-finite pixel, error map not writable,
//               or a strategy image that cannot be read, has another size or a non-finite pixel,
//             3 (--ztest) the z-test rejects A.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <exception>
#include <optional>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/metrics.h"
#include "tools/cli_checks.h"
#include "tools/ztest.h"

using namespace lt;

namespace {

constexpr int kExitUsage = 1;
constexpr int kExitImage = 2;
constexpr int kExitZTestFails = 3;

std::optional<CropRect> parseCrop(const std::string& s) {
    std::vector<long> v;
    size_t pos = 0;
    while (pos <= s.size()) {
        size_t comma = s.find(',', pos);
        std::string tok = s.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
        if (tok.empty()) return std::nullopt;
        size_t used = 0;
        long x;
        try {
            x = std::stol(tok, &used);
        } catch (const std::exception&) {
            return std::nullopt;
        }
        if (used != tok.size() || x < -(1L << 30) || x > (1L << 30)) return std::nullopt;
        v.push_back(x);
        if (comma == std::string::npos) break;
        pos = comma + 1;
    }
    if (v.size() != 4) return std::nullopt;
    return CropRect{int(v[0]), int(v[1]), int(v[2]), int(v[3])};
}

std::string jsonString(const std::string& s) {
    std::string out = "\"";
    for (unsigned char c : s) {
        if (c == '"' || c == '\\') out += char('\\'), out += char(c);
        else if (c < 0x20) out += fmt::format("\\u{:04x}", unsigned(c));
        else out += char(c);
    }
    return out + "\"";
}

int error(int code, const std::string& msg) {
    fmt::print(stderr, "imgcompare: error: {}\n", msg);
    return code;
}

std::string percent(double share) { return fmt::format("{:.1f}%", 100.0 * share); }

// "92.1% s0_t10, 5.0% merge_s3, rest 2.9%": the first `most` techniques and the rest.
std::string shareList(const std::vector<TechniqueShare>& ts, size_t most) {
    if (ts.empty()) return "no technique contributes";
    std::string out;
    double rest = 1.0;
    for (size_t i = 0; i < std::min(most, ts.size()); ++i) {
        out += fmt::format("{}{} {}", i ? ", " : "", percent(ts[i].share), ts[i].name);
        rest -= ts[i].share;
    }
    if (ts.size() > most) out += ", rest " + percent(std::max(rest, 0.0));
    return out;
}

std::string jsonTechniques(const std::vector<TechniqueShare>& ts) {
    std::string out = "[";
    for (size_t i = 0; i < ts.size(); ++i)
        out += fmt::format("{}{{\"name\": {}, \"value\": {}, \"share\": {}}}", i ? ", " : "", jsonString(ts[i].name),
                           ts[i].value, ts[i].share);
    return out + "]";
}

// --ztest: reads the variance, runs tools/ztest.h, prints the result; exit 0 pass, 3 reject.
int runZTest(const Image& a, const Image& b, const std::string& pathA, const std::string& pathB,
             const std::string& pathVar, long spp, double significance, const CropRect* crop,
             const std::string& pvalueMapPath, bool json) {
    Image var;
    try {
        var = readImage(pathVar);
    } catch (const std::exception& e) {
        return error(kExitImage, e.what());
    }
    if (var.width != b.width || var.height != b.height)
        return error(kExitImage, fmt::format("size mismatch: variance {} is {}x{} but reference {} is {}x{}", pathVar,
                                             var.width, var.height, pathB, b.width, b.height));
    // A's non-finite values fail the test (as in Mitsuba); the reference's and the variance's are errors.
    for (auto [img, path] : {std::pair{&b, &pathB}, std::pair{static_cast<const Image*>(&var), &pathVar}})
        if (auto p = findNonFinite(*img, crop)) {
            const Color& c = img->at(p->first, p->second);
            return error(kExitImage, fmt::format("{}: non-finite value at pixel ({}, {}): ({}, {}, {})", *path, p->first,
                                                 p->second, c.x, c.y, c.z));
        }
    ztest::Settings settings;
    settings.spp = spp;
    settings.significance = significance;
    Image pvalues;
    ztest::Result r;
    try {
        r = ztest::run(a, b, var, settings, crop, pvalueMapPath.empty() ? nullptr : &pvalues);
    } catch (const std::exception& e) {
        return error(kExitUsage, e.what());
    }
    const std::string channel = r.minChannel >= 0 ? std::string(1, "XYZ"[r.minChannel]) : "-";
    std::vector<std::pair<std::string, std::string>> rows = {
        {"ztest_result", r.pass ? "pass" : "fail"},
        {"ztest_pixels", fmt::format("{}", r.pixels)},
        {"ztest_spp", fmt::format("{}", spp)},
        {"ztest_significance", fmt::format("{}", significance)},
        {"ztest_sidak_level", fmt::format("{}", r.alpha)},
        {"ztest_failing_values", fmt::format("{}", r.failingValues)},
        {"ztest_failing_pixels", fmt::format("{}", r.failingPixels)},
        {"ztest_allowed_failing_values", fmt::format("{}", r.allowedFailingValues)},
        {"ztest_nonfinite_values", fmt::format("{}", r.nonFiniteValues)},
        {"ztest_min_pvalue", fmt::format("{}", r.minPValue)},
        {"ztest_max_z", fmt::format("{}", r.maxZ)},
    };
    if (json) {
        std::string out = fmt::format("{{\"image\": {}, \"reference\": {}, \"variance\": {}, \"ztest_pass\": {}",
                                      jsonString(pathA), jsonString(pathB), jsonString(pathVar), r.pass);
        for (size_t i = 1; i < rows.size(); ++i) out += fmt::format(", \"{}\": {}", rows[i].first, rows[i].second);
        out += fmt::format(", \"ztest_min_pvalue_at\": {{\"x\": {}, \"y\": {}, \"channel\": \"{}\", \"image\": {}, "
                           "\"reference\": {}, \"variance\": {}}}}}",
                           r.minX, r.minY, channel, r.minImage, r.minReference, r.minVariance);
        fmt::print("{}\n", out);
    } else {
        for (auto& [name, v] : rows) fmt::print("{}: {}\n", name, v);
        fmt::print("ztest_min_pvalue_at: pixel ({}, {}) channel {} image {} reference {} variance {}\n", r.minX,
                   r.minY, channel, r.minImage, r.minReference, r.minVariance);
    }
    std::fflush(stdout);
    if (!pvalueMapPath.empty()) {
        try {
            writeImage(pvalues, pvalueMapPath);
        } catch (const std::exception& e) {
            return error(kExitImage, e.what());
        }
    }
    return r.pass ? 0 : kExitZTestFails;
}

constexpr size_t kPixelTechniques = 3;  // techniques named per worst pixel (then "rest")
constexpr size_t kTopTechniques = 5;    // techniques named for the worst fraction of pixels

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{
        "imgcompare: error metrics between an image A and a reference image B.\n"
        "Images: .exr, .pfm, .hdr (same size). Each of the 3 colour channels of each pixel is one value;\n"
        "metrics average over all values (double precision). Output: one 'name: value' line per metric."};
    app.get_formatter()->column_width(34);
    std::string pathA, pathB, metricStr = "all", cropStr, errorMapPath, strategiesDir;
    bool json = false, ztestMode = false;
    std::string refVarPath, pvalueMapPath;
    long ztestSpp = 0;
    double significance = ztest::kSignificance;
    double topFraction = 0.01;
    size_t worstK = 5;
    app.add_option("A", pathA, "Image to evaluate (.exr, .pfm, .hdr)")->required()->type_name("FILE");
    app.add_option("B", pathB, "Reference image (.exr, .pfm, .hdr), same size as A")->required()->type_name("FILE");
    app.add_option("--metric", metricStr,
                   "Metric to report: all (default), mse, relmse, rmsre, mape, mean (mean of A and of B), or top1 "
                   "(relmse_top1_share: the share of the relMSE carried by the worst --top-fraction of pixels)")
        ->check(CLI::IsMember({"all", "mse", "relmse", "rmsre", "mape", "mean", "top1"}, CLI::ignore_case))
        ->type_name("NAME");
    app.add_option("--crop", cropStr,
                   "Compare only the rectangle x,y,w,h (pixels; x,y = top-left corner, row 0 at the top); "
                   "must lie inside the images")
        ->type_name("x,y,w,h");
    app.add_option("--error-map", errorMapPath,
                   "Write the per-pixel, per-channel term of the chosen metric (relmse when --metric all or top1; "
                   "signed difference A-B for mean) to this file (.exr, .pfm, .hdr, .png); cropped if --crop")
        ->type_name("FILE");
    app.add_option("--top-fraction", topFraction,
                   "Fraction of the pixels that counts as the worst, for relmse_top1_share and the technique shares "
                   "of --strategies: ceil(F * pixels) pixels, F in (0, 1] (default 0.01)")
        ->type_name("F");
    CLI::Option* strategiesOpt = app.add_option("--strategies", strategiesDir,
                   "Folder written by render --strategy-images for image A (s{s}_t{t}.exr, merge_s{s}.exr): list "
                   "the --worst pixels with the techniques that make up A there, and each technique's share of the "
                   "worst --top-fraction of pixels")
        ->type_name("DIR");
    app.add_option("--worst", worstK, "With --strategies: how many of the worst pixels to list (default 5)")
        ->check(lt::cli::positive())
        ->needs(strategiesOpt)
        ->type_name("K");
    app.add_flag("--json", json, "Print the results as one JSON object instead of 'name: value' lines");
    CLI::Option* ztestOpt = app.add_flag(
        "--ztest", ztestMode,
        "Instead of the metrics: Mitsuba 3's per-pixel z-test of A (the mean of --spp samples) against the "
        "reference B with the per-sample variance --ref-var (below); exit 0 when it passes, 3 when it rejects A");
    app.add_option("--ref-var", refVarPath,
                   "With --ztest: the reference's per-sample variance image (Mitsuba's *_ref_rgb_var.exr), B's size")
        ->needs(ztestOpt)
        ->type_name("FILE");
    app.add_option("--spp", ztestSpp, "With --ztest: the samples per pixel of A")
        ->check(lt::cli::positive())
        ->needs(ztestOpt)
        ->type_name("N");
    app.add_option("--significance", significance,
                   "With --ztest: the family-wise significance level before the Sidak correction (default 0.01, "
                   "Mitsuba's); in (0, 1)")
        ->check(CLI::Validator(
            [](std::string& v) -> std::string {
                double x = 0;
                return lt::parseFiniteNumber(v, x) && x > 0 && x < 1
                           ? std::string()
                           : fmt::format("must be a number in (0, 1) (got '{}')", v);
            },
            "(0, 1)"))
        ->needs(ztestOpt)
        ->type_name("S");
    app.add_option("--pvalue-map", pvalueMapPath,
                   "With --ztest: write every value's p-value (X, Y, Z in the R, G, B channels; cropped if --crop) "
                   "to this file (.exr, .pfm)")
        ->needs(ztestOpt)
        ->type_name("FILE");
    ztestOpt->excludes(strategiesOpt);  // --metric, --top-fraction, --error-map: refused after parsing
    app.footer(fmt::format(
        "Metrics (a = value of A, b = value of B, n = 3 * pixels):\n"
        "  mean   : (1/n) sum a  and  (1/n) sum b   (printed as mean_image, mean_reference)\n"
        "  mse    : (1/n) sum (a-b)^2\n"
        "  relmse : (1/n) sum (a-b)^2 / (b^2 + eps),  eps = {}\n"
        "  rmsre  : sqrt((1/n) sum (a-b)^2 / ((a+b)/2)^2)   (RMS of relative error, Jendersie & Grosch 2019);\n"
        "           a value pair with a+b == 0 contributes 0\n"
        "  mape   : (1/n) sum |a-b| / (|b| + eps),  eps = {}\n"
        "  top1   : per pixel e = the sum of the relmse terms of its 3 channels; relmse_top1_share =\n"
        "           (sum of e over the ceil(F * pixels) largest) / (sum of e over all pixels), F = --top-fraction;\n"
        "           0 when A equals B. Uniform error gives F, one bad pixel gives 1.\n"
        "--strategies DIR: the pixels with the largest e, with their value (mean of R, G, B) in A, in B and\n"
        "  in the sum of the strategy images, and each technique's share of that sum; then each technique's\n"
        "  share of the summed value of the worst F of pixels. strategy_sum_rel_diff = sum |S - A| / sum |A|\n"
        "  (S = the strategy images' sum) says whether DIR belongs to A (~1e-8) or to another render.\n"
        "--ztest (Mitsuba 3's src/render/tests/test_renders.py): A, B and the variance V (of one sample)\n"
        "  are converted from RGB to CIE XYZ; per value z = |a - b| sqrt(N / max(v, {})), N = --spp, and\n"
        "  p = 2 (1 - Phi(z)); a value fails when p <= alpha = 1 - (1 - S)^(1/pixels) (Sidak over the\n"
        "  pixels, S = --significance); A passes when (passing values)/3 >= {} x pixels. Mitsuba renders\n"
        "  N = {} // pixels samples. Prints ztest_* lines: result, failing values and pixels, the\n"
        "  smallest p-value and where, alpha.\n"
        "Exit codes: 0 success (--ztest: the test passes); 1 usage error (bad flag or value, crop outside\n"
        "            the image); 2 unreadable image, size mismatch, non-finite pixel (in A: not with\n"
        "            --ztest, where such a value fails), error map not writable, strategy folder or image\n"
        "            unreadable, of another size or non-finite; 3 (--ztest) the z-test rejects A.",
        kRelMseEpsilon, kMapeEpsilon, ztest::kVarianceFloor, ztest::kPassFraction, ztest::kSampleBudget));

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        int rc = app.exit(e);  // prints help or the parse error
        return rc == 0 ? 0 : kExitUsage;
    }

    std::transform(metricStr.begin(), metricStr.end(), metricStr.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    const bool all = metricStr == "all";
    const Metric mapMetric = all || metricStr == "top1" ? Metric::RelMse : *parseMetric(metricStr);
    if (!(topFraction > 0.0 && topFraction <= 1.0))
        return error(kExitUsage, fmt::format("--top-fraction must be in (0, 1], got {}", topFraction));

    if (ztestMode && (refVarPath.empty() || ztestSpp <= 0))
        return error(kExitUsage, "--ztest needs --ref-var FILE and --spp N");
    if (ztestMode)
        for (const char* metricOnly : {"--metric", "--top-fraction", "--error-map"})
            if (app.count(metricOnly))
                return error(kExitUsage, fmt::format("{} does not apply to --ztest (use --pvalue-map for a map)", metricOnly));

    std::optional<CropRect> crop;
    if (!cropStr.empty()) {
        crop = parseCrop(cropStr);
        if (!crop) return error(kExitUsage, fmt::format("--crop: expected x,y,w,h (four integers), got '{}'", cropStr));
    }

    Image a, b;
    try {
        a = readImage(pathA);
        b = readImage(pathB);
    } catch (const std::exception& e) {
        return error(kExitImage, e.what());
    }
    if (a.width != b.width || a.height != b.height)
        return error(kExitImage, fmt::format("size mismatch: {} is {}x{} but reference {} is {}x{}", pathA, a.width,
                                             a.height, pathB, b.width, b.height));
    if (crop) {
        const CropRect& r = *crop;
        if (r.w <= 0 || r.h <= 0 || r.x < 0 || r.y < 0 || int64_t(r.x) + r.w > a.width || int64_t(r.y) + r.h > a.height)
            return error(kExitUsage, fmt::format("--crop {} is empty or not inside the {}x{} images ({}, {})", cropStr,
                                                 a.width, a.height, pathA, pathB));
    }
    const CropRect* cropPtr = crop ? &*crop : nullptr;
    if (ztestMode) return runZTest(a, b, pathA, pathB, refVarPath, ztestSpp, significance, cropPtr, pvalueMapPath, json);
    for (auto [img, path] : {std::pair{&a, &pathA}, std::pair{&b, &pathB}})
        if (auto p = findNonFinite(*img, cropPtr)) {
            const Color& c = img->at(p->first, p->second);
            return error(kExitImage, fmt::format("{}: non-finite value at pixel ({}, {}): ({}, {}, {})", *path, p->first,
                                                 p->second, c.x, c.y, c.z));
        }

    ErrorMetrics m;
    double top1 = 0;
    std::optional<Attribution> attribution;
    size_t strategyCount = 0;
    try {
        m = computeMetrics(a, b, cropPtr);
        top1 = relMseTopShare(a, b, topFraction, cropPtr);
    } catch (const std::exception& e) {
        return error(kExitImage, fmt::format("{} vs {}: {}", pathA, pathB, e.what()));
    }
    if (!strategiesDir.empty()) {
        try {
            std::vector<StrategyImage> strategies = readStrategyImages(strategiesDir, a.width, a.height);
            strategyCount = strategies.size();
            attribution = attributeWorstPixels(a, b, strategies, worstK, topFraction, cropPtr);
        } catch (const std::exception& e) {
            return error(kExitImage, fmt::format("--strategies: {}", e.what()));
        }
    }

    // (name, value) pairs in output order; values printed in shortest round-trip form.
    std::vector<std::pair<std::string, double>> rows;
    auto want = [&](const char* name) { return all || metricStr == name; };
    if (want("mean")) {
        rows.emplace_back("mean_image", m.meanImage);
        rows.emplace_back("mean_reference", m.meanReference);
    }
    if (want("mse")) rows.emplace_back("mse", m.mse);
    if (want("relmse")) {
        rows.emplace_back("relmse", m.relMse);
        rows.emplace_back("relmse_eps", kRelMseEpsilon);
    }
    if (want("rmsre")) rows.emplace_back("rmsre", m.rmsRelErr);
    if (want("mape")) {
        rows.emplace_back("mape", m.mape);
        rows.emplace_back("mape_eps", kMapeEpsilon);
    }
    if (want("top1")) {
        rows.emplace_back("relmse_top1_share", top1);
        rows.emplace_back("top_fraction", topFraction);
        rows.emplace_back("top_pixels", double(topPixelCount(m.pixels, topFraction)));
    }

    if (json) {
        std::string out = fmt::format("{{\"image\": {}, \"reference\": {}, ", jsonString(pathA), jsonString(pathB));
        if (crop) out += fmt::format("\"crop\": [{}, {}, {}, {}], ", crop->x, crop->y, crop->w, crop->h);
        out += fmt::format("\"pixels\": {}", m.pixels);
        for (auto& [name, v] : rows) out += fmt::format(", \"{}\": {}", name, v);
        if (attribution) {
            const Attribution& at = *attribution;
            out += fmt::format(", \"strategies\": {{\"dir\": {}, \"images\": {}, \"value\": \"channel_mean\", "
                               "\"strategy_sum_rel_diff\": {}, \"worst\": [",
                               jsonString(strategiesDir), strategyCount, at.strategySumRelDiff);
            for (size_t i = 0; i < at.worst.size(); ++i) {
                const PixelAttribution& p = at.worst[i];
                out += fmt::format("{}{{\"x\": {}, \"y\": {}, \"error\": {}, \"image\": {}, \"reference\": {}, "
                                   "\"strategies\": {}, \"techniques\": {}}}",
                                   i ? ", " : "", p.x, p.y, p.error, p.image, p.reference, p.strategies,
                                   jsonTechniques(p.techniques));
            }
            out += fmt::format("], \"top_fraction\": {}, \"top_pixels\": {}, \"top_techniques\": {}}}", topFraction,
                               at.topPixels, jsonTechniques(at.topTechniques));
        }
        fmt::print("{}}}\n", out);
    } else {
        if (all) fmt::print("pixels: {}\n", m.pixels);
        for (auto& [name, v] : rows) fmt::print("{}: {}\n", name, v);
        if (attribution) {
            const Attribution& at = *attribution;
            fmt::print("strategies: {} ({} images; value = mean of R, G, B; pixels ranked by the sum of their "
                       "channels' relmse terms)\n",
                       strategiesDir, strategyCount);
            fmt::print("strategy_sum_rel_diff: {}\n", at.strategySumRelDiff);
            for (size_t i = 0; i < at.worst.size(); ++i) {
                const PixelAttribution& p = at.worst[i];
                fmt::print("worst {}: pixel ({}, {}) error {:.4g} image {:.4g} reference {:.4g} strategies {:.4g}: {}\n",
                           i + 1, p.x, p.y, p.error, p.image, p.reference, p.strategies,
                           shareList(p.techniques, kPixelTechniques));
            }
            fmt::print("worst {:g}% of pixels ({} pixel{}): {}\n", 100.0 * topFraction, at.topPixels,
                       at.topPixels == 1 ? "" : "s", shareList(at.topTechniques, kTopTechniques));
        }
    }
    if (attribution && attribution->strategySumRelDiff > 1e-3)
        fmt::print(stderr,
                   "imgcompare: warning: the strategy images in {} differ from {} by {:.3g} (strategy_sum_rel_diff): "
                   "a file is missing or they belong to another render; shares are of their sum, not of A\n",
                   strategiesDir, pathA, attribution->strategySumRelDiff);
    std::fflush(stdout);

    if (!errorMapPath.empty()) {
        try {
            writeImage(errorMap(a, b, mapMetric, cropPtr), errorMapPath);
        } catch (const std::exception& e) {
            return error(kExitImage, e.what());
        }
    }
    return 0;
}
