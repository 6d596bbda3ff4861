// imgcompare: error metrics between an image A and a reference B.
//   imgcompare A B [--metric all|mse|relmse|rmsre|mape|mean] [--crop x,y,w,h]
//                  [--error-map out.exr] [--json]
// Exit codes: 0 success, 1 usage error (bad flag/value, crop outside the image),
//             2 unreadable image, size mismatch, non-finite pixel, or error map not writable.
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

using namespace lt;

namespace {

constexpr int kExitUsage = 1;
constexpr int kExitImage = 2;

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

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{
        "imgcompare: error metrics between an image A and a reference image B.\n"
        "Images: .exr, .pfm, .hdr (same size). Each of the 3 colour channels of each pixel is one value;\n"
        "metrics average over all values (double precision). Output: one 'name: value' line per metric."};
    app.get_formatter()->column_width(34);
    std::string pathA, pathB, metricStr = "all", cropStr, errorMapPath;
    bool json = false;
    app.add_option("A", pathA, "Image to evaluate (.exr, .pfm, .hdr)")->required()->type_name("FILE");
    app.add_option("B", pathB, "Reference image (.exr, .pfm, .hdr), same size as A")->required()->type_name("FILE");
    app.add_option("--metric", metricStr,
                   "Metric to report: all (default), mse, relmse, rmsre, mape, or mean (mean of A and of B)")
        ->check(CLI::IsMember({"all", "mse", "relmse", "rmsre", "mape", "mean"}, CLI::ignore_case))
        ->type_name("NAME");
    app.add_option("--crop", cropStr,
                   "Compare only the rectangle x,y,w,h (pixels; x,y = top-left corner, row 0 at the top); "
                   "must lie inside the images")
        ->type_name("x,y,w,h");
    app.add_option("--error-map", errorMapPath,
                   "Write the per-pixel, per-channel term of the chosen metric (relmse when --metric all; "
                   "signed difference A-B for mean) to this file (.exr, .pfm, .hdr, .png); cropped if --crop")
        ->type_name("FILE");
    app.add_flag("--json", json, "Print the results as one JSON object instead of 'name: value' lines");
    app.footer(fmt::format(
        "Metrics (a = value of A, b = value of B, n = 3 * pixels):\n"
        "  mean   : (1/n) sum a  and  (1/n) sum b   (printed as mean_image, mean_reference)\n"
        "  mse    : (1/n) sum (a-b)^2\n"
        "  relmse : (1/n) sum (a-b)^2 / (b^2 + eps),  eps = {}\n"
        "  rmsre  : sqrt((1/n) sum (a-b)^2 / ((a+b)/2)^2)   (RMS of relative error, Jendersie & Grosch 2019);\n"
        "           a value pair with a+b == 0 contributes 0\n"
        "  mape   : (1/n) sum |a-b| / (|b| + eps),  eps = {}\n"
        "Exit codes: 0 success; 1 usage error (bad flag or value, crop outside the image);\n"
        "            2 unreadable image, size mismatch, non-finite pixel, error map not writable.",
        kRelMseEpsilon, kMapeEpsilon));

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        int rc = app.exit(e);  // prints help or the parse error
        return rc == 0 ? 0 : kExitUsage;
    }

    std::transform(metricStr.begin(), metricStr.end(), metricStr.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    const bool all = metricStr == "all";
    const Metric mapMetric = all ? Metric::RelMse : *parseMetric(metricStr);

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
    for (auto [img, path] : {std::pair{&a, &pathA}, std::pair{&b, &pathB}})
        if (auto p = findNonFinite(*img, cropPtr)) {
            const Color& c = img->at(p->first, p->second);
            return error(kExitImage, fmt::format("{}: non-finite value at pixel ({}, {}): ({}, {}, {})", *path, p->first,
                                                 p->second, c.x, c.y, c.z));
        }

    ErrorMetrics m;
    try {
        m = computeMetrics(a, b, cropPtr);
    } catch (const std::exception& e) {
        return error(kExitImage, fmt::format("{} vs {}: {}", pathA, pathB, e.what()));
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

    if (json) {
        std::string out = fmt::format("{{\"image\": {}, \"reference\": {}, ", jsonString(pathA), jsonString(pathB));
        if (crop) out += fmt::format("\"crop\": [{}, {}, {}, {}], ", crop->x, crop->y, crop->w, crop->h);
        out += fmt::format("\"pixels\": {}", m.pixels);
        for (auto& [name, v] : rows) out += fmt::format(", \"{}\": {}", name, v);
        fmt::print("{}}}\n", out);
    } else {
        if (all) fmt::print("pixels: {}\n", m.pixels);
        for (auto& [name, v] : rows) fmt::print("{}: {}\n", name, v);
    }
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
