// report: one self-contained HTML page (well-formed XHTML syntax, images embedded as base64 data
// URIs; no server, no scripts) comparing the configurations of one scene, from the output folder
// of `convergence` (final images, CSV, plot) and optionally of `biasvar` runs: tonemapped images,
// zoomed crops (--crop), relMSE error maps in false colour, the plots and a table of time, spp,
// samples/s, relMSE, RMS-RE, MAPE, bias^2 and variance. See docs/tools.md.
// Exit codes: 0 success, 1 bad command line, 2 an input cannot be read, 3 output not written.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <unistd.h>
#include <filesystem>
#include "tools/analysis.h"
#include "tools/cli_checks.h"

using namespace lt;
using namespace lt::analysis;
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string esc(const std::string& s) {
    std::string r;
    for (char c : s) {
        switch (c) {
            case '&': r += "&amp;"; break;
            case '<': r += "&lt;"; break;
            case '>': r += "&gt;"; break;
            case '"': r += "&quot;"; break;
            case '\'': r += "&#39;"; break;
            default: r += c;
        }
    }
    return r;
}

std::string num(const json& v, const char* fmtStr = "{:.4g}") {
    if (!v.is_number()) return "&#8211;";
    return fmt::format(fmt::runtime(fmtStr), v.get<double>());
}

// Stores images as PNG files: embedded (data URI) or linked (files in a folder next to the page).
class ImageSink {
public:
    ImageSink(bool link, fs::path dir, std::string prefix) : link_(link), dir_(std::move(dir)), prefix_(std::move(prefix)) {
        fs::create_directories(dir_);
    }
    ~ImageSink() {
        std::error_code ec;
        if (!link_) fs::remove_all(dir_, ec);
    }
    // Returns the src attribute value.
    std::string png(const Image& img, const std::string& name, float exposure = 0.f) {
        fs::path p = dir_ / (name + ".png");
        writePng(img, p.string(), exposure);
        return file(p.string());
    }
    std::string file(const std::string& path) {
        std::string ext = fs::path(path).extension().string();
        if (link_) {
            fs::path dst = dir_ / fs::path(path).filename();
            if (fs::absolute(dst) != fs::absolute(path)) {
                dst = dir_ / (std::to_string(counter_++) + "_" + fs::path(path).filename().string());
                fs::copy_file(path, dst, fs::copy_options::overwrite_existing);
            }
            return prefix_ + "/" + dst.filename().string();
        }
        std::string mime = ext == ".svg" ? "image/svg+xml" : "image/png";
        return "data:" + mime + ";base64," + base64(readFile(path));
    }

private:
    bool link_;
    fs::path dir_;
    std::string prefix_;
    int counter_ = 0;
};

const char* kStyle = R"(
body { font-family: sans-serif; margin: 1.5em; color: #222; background: #fff; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 1.6em; border-bottom: 1px solid #ccc; }
table.metrics { border-collapse: collapse; font-size: 0.9em; }
table.metrics th, table.metrics td { border: 1px solid #bbb; padding: 0.25em 0.6em; text-align: right; }
table.metrics th { background: #eee; } table.metrics td.name { text-align: left; font-family: monospace; }
.grid { display: flex; flex-wrap: wrap; gap: 12px; align-items: flex-start; }
figure { margin: 0; } figcaption { font-size: 0.8em; max-width: 260px; overflow-wrap: anywhere; }
img.px { image-rendering: pixelated; display: block; border: 1px solid #999; }
.frame { position: relative; display: inline-block; }
.crop { position: absolute; border: 2px solid #ff2; box-sizing: border-box; }
.crop span { position: absolute; left: 1px; top: 0; font-size: 10px; color: #ff2; }
img.plot { max-width: 100%; height: auto; border: 1px solid #ddd; }
p.note, dl { font-size: 0.85em; color: #444; } code { font-size: 0.95em; }
)";

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"report: self-contained HTML page comparing the configurations of one scene"};
    std::string convDir, out, title, exposureStr = "auto";
    std::vector<std::string> biasDirs, cropStrs;
    int zoom = 0;
    bool link = false;
    app.add_option("--convergence", convDir, "Output folder of `convergence` (convergence.json, images/)")->required();
    app.add_option("--biasvar", biasDirs, "Output folder of `biasvar` (repeatable; matched to configurations by label)")
        ->allow_extra_args(false);
    app.add_option("--crop", cropStrs, "Zoomed crop x,y,w,h in pixels (row 0 at the top; repeatable)")->allow_extra_args(false);
    app.add_option("--zoom", zoom, "Crop magnification (default: crops shown about 192 px wide)")->check(lt::cli::range(1, 64));
    app.add_option("--exposure", exposureStr, "Exposure in EV for all images, or auto (from the reference; default)");
    app.add_option("--title", title, "Page title (default: the scene name)");
    app.add_option("-o,--output", out, "HTML file (default <convergence folder>/report.html)");
    app.add_flag("--link", link, "Write the PNGs into <page>_files/ and link them instead of embedding them");
    app.footer("Exit codes: 0 success, 1 bad command line, 2 unreadable input, 3 output not written.");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 1;
    }
    auto fail = [](int code, const std::string& msg) {
        fmt::print(stderr, "report: error: {}\n", msg);
        return code;
    };
    if (out.empty()) out = (fs::path(convDir) / "report.html").string();

    json conv;
    Image ref;
    std::vector<CropRect> crops;
    try {
        for (const auto& c : cropStrs) crops.push_back(parseCropRect(c));
    } catch (const std::exception& e) {
        return fail(1, e.what());
    }
    std::vector<json> bias;
    try {
        conv = json::parse(readFile((fs::path(convDir) / "convergence.json").string()));
        ref = readImage(conv["reference"].get<std::string>());
        for (const auto& d : biasDirs) bias.push_back(json::parse(readFile((fs::path(d) / "biasvar.json").string())));
    } catch (const std::exception& e) {
        return fail(2, e.what());
    }
    for (const CropRect& c : crops)
        if (c.x + c.w > ref.width || c.y + c.h > ref.height)
            return fail(1, fmt::format("crop {},{},{},{} is not inside the {}x{} image", c.x, c.y, c.w, c.h, ref.width, ref.height));
    float exposure = 0.f;
    if (exposureStr == "auto") {
        exposure = autoExposure(ref);
    } else {
        try {
            exposure = std::stof(exposureStr);
        } catch (const std::exception&) {
            return fail(1, "--exposure expects a number or auto");
        }
    }
    std::string sceneName = fs::path(conv["scene"].get<std::string>()).stem().string();
    if (title.empty()) title = "Comparison: " + sceneName;

    fs::path outPath = fs::absolute(out);
    std::string stem = outPath.stem().string();
    fs::path filesDir = link ? outPath.parent_path() / (stem + "_files")
                             : fs::temp_directory_path() / fmt::format("lt_report_{}_{}", ::getpid(), stem);
    std::string h;
    try {
        ImageSink sink(link, filesDir, stem + "_files");
        struct Entry {
            json cfg;
            Image img;
            std::string label;
        };
        std::vector<Entry> entries;
        for (const auto& c : conv["configs"]) {
            if (!c.contains("image")) continue;
            entries.push_back({c, readImage((fs::path(convDir) / c["image"].get<std::string>()).string()), c["label"]});
        }
        const int dispW = std::max(ref.width, std::min(384, ref.width * std::max(1, 256 / std::max(1, ref.width))));
        auto imgTag = [&](const std::string& src, int w, const std::string& alt) {
            return fmt::format("<img class=\"px\" src=\"{}\" width=\"{}\" alt=\"{}\" />", src, w, esc(alt));
        };

        h += "<!DOCTYPE html>\n<html xmlns=\"http://www.w3.org/1999/xhtml\" lang=\"en\">\n<head>\n<meta charset=\"utf-8\" />\n";
        h += "<title>" + esc(title) + "</title>\n<style>" + std::string(kStyle) + "</style>\n</head>\n<body>\n";
        h += "<h1>" + esc(title) + "</h1>\n<dl>\n";
        h += "<dt>Scene</dt><dd><code>" + esc(conv["scene"].get<std::string>()) + "</code> (SHA-256 <code>" +
             esc(conv.value("scene_sha256", std::string("?"))) + "</code>)</dd>\n";
        h += fmt::format("<dt>Image</dt><dd>{} x {} pixels; every image shown at {:+.2f} EV (sRGB)</dd>\n", ref.width,
                         ref.height, exposure);
        std::string refInfo;
        fs::path refSide = fs::path(conv["reference"].get<std::string>()).replace_extension(".json");
        if (fs::exists(refSide)) {
            try {
                json rj = json::parse(readFile(refSide.string()));
                refInfo = fmt::format(" ({} spp with <code>{}</code>)", num(rj.value("spp", json()), "{:.0f}"),
                                      esc(rj.value("config", rj.value("integrator", std::string("?")))));
            } catch (...) {
            }
        }
        h += "<dt>Reference</dt><dd><code>" + esc(conv["reference"].get<std::string>()) + "</code>" + refInfo + "</dd>\n";
        h += "<dt>Convergence command</dt><dd><code>" + esc(conv.value("command", std::string())) + "</code></dd>\n";
        h += "<dt>Report generated</dt><dd>" + esc(nowUtc()) + "</dd>\n</dl>\n";

        // Table.
        h += "<h2>Figures</h2>\n<table class=\"metrics\">\n<tr><th>configuration</th><th>time [s]</th><th>spp</th>"
             "<th>samples/s</th><th>relMSE</th><th>RMS-RE</th><th>MAPE</th><th>bias&#178; (rel.)</th>"
             "<th>variance (rel.)</th><th>bias/var at</th><th>slope vs spp</th><th>slope vs time</th></tr>\n";
        for (const Entry& e : entries) {
            const json& m = e.cfg["metrics"];
            json lvl;
            int runs = 0;
            for (const auto& b : bias)
                for (const auto& bc : b["configs"])
                    if (bc["label"] == e.label && !bc["levels"].empty()) lvl = bc["levels"].back(), runs = b["runs"].get<int>();
            std::string b2 = "&#8211;", var = "&#8211;", at = "&#8211;";
            if (!lvl.is_null()) {
                const json& r = lvl["relative"];
                b2 = fmt::format("{} &#177; {}", num(r["bias2"]), num(r["bias2_stderr"], "{:.2g}"));
                if (r.value("biased", false)) b2 += " *";
                var = fmt::format("{} &#177; {}", num(r["variance"]), num(r["variance_stderr"], "{:.2g}"));
                at = fmt::format("{} spp, {} runs", lvl["spp"].get<uint64_t>(), runs);
            }
            h += fmt::format("<tr><td class=\"name\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>"
                             "<td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                             esc(e.label), num(e.cfg["seconds"], "{:.3f}"), num(e.cfg["spp"], "{:.0f}"),
                             num(e.cfg["samples_per_second"], "{:.3g}"), num(m["relmse"]), num(m["rmsre"]), num(m["mape"]),
                             b2, var, at, num(e.cfg["slope_spp"], "{:.2f}"), num(e.cfg["slope_time"], "{:.2f}"));
        }
        h += "</table>\n<p class=\"note\">relMSE = mean (a-b)&#178;/(b&#178;+0.01); RMS-RE = JG19 RMS of relative residuals; "
             "MAPE = mean |a-b|/(|b|+0.01), against the reference b. bias&#178; and variance (from <code>biasvar</code>) "
             "are divided by (b&#178;+0.01) like relMSE, so relMSE &#8776; bias&#178; + variance at equal spp; "
             "bias&#178; = (mean-b)&#178; - var/K, &#177; one standard error; * marks a bias significant at the "
             "biasvar run's |z| threshold.</p>\n";

        // Images with the crop rectangles.
        auto framed = [&](const std::string& src, const std::string& alt) {
            std::string s = "<div class=\"frame\">" + imgTag(src, dispW, alt);
            for (size_t i = 0; i < crops.size(); ++i) {
                const CropRect& c = crops[i];
                s += fmt::format("<div class=\"crop\" style=\"left:{:.3f}%;top:{:.3f}%;width:{:.3f}%;height:{:.3f}%\">"
                                 "<span>{}</span></div>",
                                 100.0 * c.x / ref.width, 100.0 * c.y / ref.height, 100.0 * c.w / ref.width,
                                 100.0 * c.h / ref.height, i + 1);
            }
            return s + "</div>";
        };
        h += "<h2>Images</h2>\n<div class=\"grid\">\n";
        h += "<figure>" + framed(sink.png(ref, "reference", exposure), "reference") + "<figcaption>reference</figcaption></figure>\n";
        for (size_t i = 0; i < entries.size(); ++i)
            h += "<figure>" + framed(sink.png(entries[i].img, fmt::format("img{}", i), exposure), entries[i].label) +
                 "<figcaption>" + esc(entries[i].label) + "</figcaption></figure>\n";
        h += "</div>\n";

        // Crops.
        for (size_t ci = 0; ci < crops.size(); ++ci) {
            const CropRect& c = crops[ci];
            int z = zoom > 0 ? zoom : std::max(1, 192 / std::max(c.w, c.h));
            h += fmt::format("<h2>Crop {}: x {}, y {}, {} x {} px (x{})</h2>\n<div class=\"grid\">\n", ci + 1, c.x, c.y, c.w, c.h, z);
            h += "<figure>" + imgTag(sink.png(cropZoom(ref, c, z), fmt::format("crop{}_ref", ci), exposure), c.w * z, "reference") +
                 "<figcaption>reference</figcaption></figure>\n";
            for (size_t i = 0; i < entries.size(); ++i) {
                ErrorMetrics m = computeMetrics(entries[i].img, ref, &c);
                h += "<figure>" +
                     imgTag(sink.png(cropZoom(entries[i].img, c, z), fmt::format("crop{}_{}", ci, i), exposure), c.w * z,
                            entries[i].label) +
                     fmt::format("<figcaption>{}<br />relMSE {:.4g}</figcaption></figure>\n", esc(entries[i].label), m.relMse);
            }
            h += "</div>\n";
        }

        // Error maps, one colour scale for all.
        if (!entries.empty()) {
            std::vector<Image> maps;
            double vmax = 1e-30;
            for (const Entry& e : entries) {
                maps.push_back(errorMap(e.img, ref, Metric::RelMse));
                vmax = std::max(vmax, quantile(maps.back(), 0.99));
            }
            h += fmt::format("<h2>relMSE error maps</h2>\n<p class=\"note\">Per pixel (a-b)&#178;/(b&#178;+0.01) averaged "
                             "over the channels, viridis on a log scale from {:.3g} (dark) to {:.3g} (yellow; the 99th "
                             "percentile over all maps).</p>\n<div class=\"grid\">\n", vmax * 1e-3, vmax);
            for (size_t i = 0; i < entries.size(); ++i)
                h += "<figure>" + imgTag(sink.png(falseColour(maps[i], vmax), fmt::format("err{}", i)), dispW, entries[i].label) +
                     "<figcaption>" + esc(entries[i].label) + "</figcaption></figure>\n";
            h += "</div>\n";
        }

        // Plots.
        auto plotImg = [&](const fs::path& dir, const json& j) {
            for (const char* k : {"plot_svg", "plot_png"})
                if (j.contains(k) && j[k].is_string() && fs::exists(dir / j[k].get<std::string>()))
                    return "<img class=\"plot\" src=\"" + sink.file((dir / j[k].get<std::string>()).string()) + "\" width=\"" +
                           std::to_string(j.value("plot_width", 1000)) + "\" alt=\"plot\" />";
            return std::string("<p class=\"note\">(no plot: gnuplot was not available)</p>");
        };
        h += "<h2>Convergence</h2>\n" + plotImg(convDir, conv) + "\n";
        for (size_t bi = 0; bi < bias.size(); ++bi) {
            const json& b = bias[bi];
            h += fmt::format("<h2>Bias and variance ({} runs)</h2>\n", b["runs"].get<int>());
            if (b.contains("plot_png")) h += plotImg(biasDirs[bi], b) + "\n";
            if (b.contains("sweep")) {
                // biasvar --sweep: MSE against the bandwidth, and the command that made it.
                const json& sw = b["sweep"];
                h += fmt::format("<h3>MSE against {}</h3>\n", esc(sw["option"].get<std::string>()));
                json plotFiles = {{"plot_svg", sw.value("plot_svg", json())}, {"plot_png", sw.value("plot_png", json())},
                                  {"plot_width", b.value("plot_width", 760)}};
                h += plotImg(biasDirs[bi], plotFiles) + "\n";
                h += "<p class=\"note\">Command: <code>" + esc(b.value("command", std::string())) + "</code></p>\n";
            }
            h += "<div class=\"grid\">\n";
            for (const auto& bc : b["configs"]) {
                if (bc["levels"].empty()) continue;
                const json& lvl = bc["levels"].back();
                fs::path d = fs::path(biasDirs[bi]) / lvl["dir"].get<std::string>();
                for (const char* map : {"variance", "bias2"}) {
                    fs::path p = d / (std::string(map) + ".png");
                    if (!fs::exists(p)) continue;
                    h += "<figure>" + imgTag(sink.file(p.string()), dispW, map) +
                         fmt::format("<figcaption>{}: {} at {} spp (false colour, log scale)</figcaption></figure>\n",
                                     esc(bc["label"].get<std::string>()), map == std::string("bias2") ? "bias&#178;" : map,
                                     lvl["spp"].get<uint64_t>());
                }
            }
            h += "</div>\n";
        }
        h += "</body>\n</html>\n";
    } catch (const std::exception& e) {
        return fail(2, e.what());
    }
    try {
        writeTextFile(out, h);
    } catch (const std::exception& e) {
        return fail(3, e.what());
    }
    fmt::print("report: wrote {}\n", out);
    return 0;
}
