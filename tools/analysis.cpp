// Shared code of the analysis tools; see analysis.h.
#include "tools/analysis.h"
#include "tools/parse_number.h"
#include "bsdf/roughness_bound.h"
#include "core/loader.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <unistd.h>

namespace fs = std::filesystem;

namespace lt::analysis {

// ---------------------------------------------------------------------------------------------
// Run configurations

namespace {

// The value of a flag option (--hide-emitters, --reg-opsr-consistent): given alone, or =true, =1.
bool flagValue(const std::string& val) { return val.empty() || val == "true" || val == "1"; }

// Splits on white space; single or double quotes group words ("--label 'PT bsdf'").
std::vector<std::string> tokenize(const std::string& s) {
    std::vector<std::string> out;
    std::string cur;
    bool have = false;
    char quote = 0;
    for (char c : s) {
        if (quote) {
            if (c == quote) quote = 0;
            else cur += c;
        } else if (c == '\'' || c == '"') {
            quote = c;
            have = true;
        } else if (std::isspace((unsigned char)c)) {
            if (have) out.push_back(cur), cur.clear(), have = false;
        } else {
            cur += c;
            have = true;
        }
    }
    if (quote) throw std::invalid_argument("unbalanced quote in configuration '" + s + "'");
    if (have) out.push_back(cur);
    return out;
}

double toDouble(const std::string& opt, const std::string& v) {
    double d = 0.0;
    if (!parseFiniteNumber(v, d)) throw std::invalid_argument(fmt::format("{} expects a number, got '{}'", opt, v));
    return d;
}

int toInt(const std::string& opt, const std::string& v) {
    double d = toDouble(opt, v);
    if (d != std::floor(d) || std::abs(d) > 1e9) throw std::invalid_argument(fmt::format("{} expects an integer, got '{}'", opt, v));
    return int(d);
}

// val if it is one of `names`, else an error naming the configuration, the option and the names.
const std::string& oneOf(const std::string& spec, const std::string& opt, const std::string& val,
                         const std::vector<std::string>& names) {
    if (std::find(names.begin(), names.end(), val) == names.end())
        throw std::invalid_argument(
            fmt::format("configuration '{}': {} is one of {} (got '{}')", spec, opt, fmt::join(names, ", "), val));
    return val;
}

}  // namespace

void parseSweep(const std::string& spec, std::string& option, std::vector<double>& values) {
    const size_t eq = spec.find('=');
    if (eq == std::string::npos)
        throw std::invalid_argument(fmt::format("'{}' is not OPTION=V1,V2,... (no '=')", spec));
    option = spec.substr(0, eq);
    while (!option.empty() && option[0] == '-') option.erase(0, 1);
    if (option.empty() || !std::all_of(option.begin(), option.end(), [](char ch) {
            return std::isalnum(static_cast<unsigned char>(ch)) || ch == '-';
        }))
        throw std::invalid_argument(fmt::format("'{}': the option before '=' must be a word such as reg-tau", spec));
    values.clear();
    std::stringstream list(spec.substr(eq + 1));
    for (std::string item; std::getline(list, item, ',');) {
        double v = 0.0;
        if (!parseFiniteNumber(item, v) || !(v > 0.0))
            throw std::invalid_argument(
                fmt::format("'{}': value '{}' is not a finite number > 0 (the values are plotted on a log axis)", spec, item));
        values.push_back(v);
    }
    if (values.empty()) throw std::invalid_argument(fmt::format("'{}': no values after '='", spec));
    std::sort(values.begin(), values.end());
    if (std::adjacent_find(values.begin(), values.end()) != values.end())
        throw std::invalid_argument(fmt::format("'{}': a value is given twice", spec));
}

RunConfig parseConfig(const std::string& spec) {
    std::vector<std::string> w = tokenize(spec);
    if (w.empty()) throw std::invalid_argument("empty configuration");
    RunConfig c;
    c.spec = spec;
    c.label = spec;
    if (w[0].starts_with("-")) throw std::invalid_argument("configuration '" + spec + "' must start with an integrator name");
    c.integrator = integratorForSceneType(w[0]);
    for (size_t i = 1; i < w.size(); ++i) {
        std::string opt = w[i];
        if (!opt.starts_with("--") || opt.size() < 3)
            throw std::invalid_argument(fmt::format("configuration '{}': expected an option --name, got '{}'", spec, opt));
        std::string val;
        auto eq = opt.find('=');
        if (eq != std::string::npos) {
            val = opt.substr(eq + 1);
            opt = opt.substr(0, eq);
        } else if (opt != "--hide-emitters" && opt != "--reg-opsr-consistent" && opt != "--reg-opsr-always-sample") {  // (flags)
            if (i + 1 >= w.size()) throw std::invalid_argument(fmt::format("configuration '{}': {} needs a value", spec, opt));
            val = w[++i];
        }
        if (opt == "--pt-strategy") {
            if (val != "mis" && val != "nee" && val != "bsdf")
                throw std::invalid_argument(fmt::format("configuration '{}': --pt-strategy is mis, nee or bsdf", spec));
            c.ptStrategy = val;
        } else if (opt == "--max-depth") {
            c.maxDepth = toInt(opt, val);
            if (*c.maxDepth < -1) throw std::invalid_argument("--max-depth must be >= -1");
        } else if (opt == "--rr-depth") {
            c.rrDepth = toInt(opt, val);
            if (*c.rrDepth < 1) throw std::invalid_argument("--rr-depth must be >= 1");
        } else if (opt == "--hide-emitters") {
            c.hideEmitters = flagValue(val);
        } else if (opt == "--radius") {
            c.radius = toDouble(opt, val);
        } else if (opt == "--radius-alpha" || opt == "--alpha") {
            c.radiusAlpha = toDouble(opt, val);
        } else if (opt == "--reg") {
            c.regularizer = oneOf(spec, opt, val, kRegularizerNames);
        } else if (opt == "--reg-tau") {
            c.regTau = toDouble(opt, val);
            if (!(*c.regTau > kMinTau))
                throw std::invalid_argument(fmt::format("configuration '{}': --reg-tau must exceed 1/(2 pi)", spec));
        } else if (opt == "--reg-schedule") {
            c.regSchedule = oneOf(spec, opt, val, kRegScheduleNames);
        } else if (opt == "--reg-mis") {
            c.regMis = oneOf(spec, opt, val, kRegMisNames);
        } else if (opt == "--reg-quality") {
            c.regQuality = oneOf(spec, opt, val, {"on", "off"}) == "on";
        } else if (opt == "--reg-diffusion") {
            c.regDiffusion = oneOf(spec, opt, val, {"on", "off"}) == "on";
        } else if (opt == "--reg-specular") {
            c.regSpecular = oneOf(spec, opt, val, kRegSpecularNames);
        } else if (opt == "--reg-bound") {
            c.regBound = oneOf(spec, opt, val, kRegBoundNames);
        } else if (opt == "--reg-energy") {
            c.regEnergy = oneOf(spec, opt, val, kRegEnergyNames);
        } else if (opt == "--reg-r0") {
            c.regR0 = toDouble(opt, val);
            if (!(*c.regR0 > 0.0) || !std::isfinite(*c.regR0))
                throw std::invalid_argument(fmt::format("configuration '{}': --reg-r0 must be a positive length", spec));
        } else if (opt == "--reg-lambda") {
            c.regLambda = toDouble(opt, val);
            if (!(*c.regLambda >= 0.0 && *c.regLambda < 0.5))
                throw std::invalid_argument(fmt::format("configuration '{}': --reg-lambda must be in [0, 0.5)", spec));
        } else if (opt == "--reg-opsr-gamma") {
            c.regOpsrGamma = toDouble(opt, val);
            if (!(*c.regOpsrGamma >= 0.0 && *c.regOpsrGamma <= 1.0))
                throw std::invalid_argument(fmt::format("configuration '{}': --reg-opsr-gamma must be in [0, 1]", spec));
        } else if (opt == "--reg-opsr-table") {
            if (val.empty()) throw std::invalid_argument(fmt::format("configuration '{}': --reg-opsr-table needs FILE[:SET]", spec));
            c.regOpsrTable = val;
        } else if (opt == "--reg-opsr-consistent") {
            c.regOpsrConsistent = flagValue(val);
        } else if (opt == "--reg-opsr-always-sample") {
            c.regOpsrAlwaysSample = flagValue(val);
        } else if (opt == "--reg-tail-rr") {
            c.regTailRr = toDouble(opt, val);
            if (!(*c.regTailRr >= 0.0 && *c.regTailRr <= kMaxRegTailRr))
                throw std::invalid_argument(
                    fmt::format("configuration '{}': --reg-tail-rr must be in [0, {:g}]", spec, kMaxRegTailRr));
        } else if (opt == "--guiding") {
            c.guiding = oneOf(spec, opt, val, {"off", "radiance", "variance"});
        } else if (opt == "--guiding-bsdf-fraction") {
            c.guidingBsdfFraction = val == "learned" ? -1.0 : toDouble(opt, val);
            if (!(*c.guidingBsdfFraction == -1.0 || (*c.guidingBsdfFraction > 0.0 && *c.guidingBsdfFraction <= 1.0)))
                throw std::invalid_argument(
                    fmt::format("configuration '{}': --guiding-bsdf-fraction must be in (0, 1] or 'learned'", spec));
        } else if (opt == "--guiding-combine") {
            c.guidingCombine = oneOf(spec, opt, val, {"inverse-variance", "last"});
        } else if (opt == "--guiding-spatial-threshold") {
            c.guidingSpatialThreshold = toDouble(opt, val);
            if (!(*c.guidingSpatialThreshold >= 1.0 && *c.guidingSpatialThreshold <= 1e12))
                throw std::invalid_argument(
                    fmt::format("configuration '{}': --guiding-spatial-threshold must be in [1, 1e12]", spec));
        } else if (opt == "--guiding-max-mb") {
            c.guidingMaxMb = toDouble(opt, val);
            if (!(*c.guidingMaxMb > 0.0 && *c.guidingMaxMb <= 1e6))
                throw std::invalid_argument(fmt::format("configuration '{}': --guiding-max-mb must be in (0, 1e6]", spec));
        } else if (opt == "--label") {
            if (val.empty()) throw std::invalid_argument("--label needs a non-empty name");
            c.label = val;
        } else {
            c.extra[opt.substr(2)] = val;
        }
    }
    return c;
}

std::vector<RunConfig> readConfigFile(const std::string& path) {
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(readFile(path));
    } catch (const nlohmann::json::exception& e) {
        throw std::invalid_argument(fmt::format("{}: not valid JSON: {}", path, e.what()));
    }
    if (j.is_object() && j.contains("configs")) j = j["configs"];
    if (!j.is_array()) throw std::invalid_argument(path + ": expected a list of configurations or {\"configs\": [...]}");
    std::vector<RunConfig> out;
    for (const auto& e : j) {
        if (e.is_string()) {
            out.push_back(parseConfig(e.get<std::string>()));
        } else if (e.is_object() && e.contains("config") && e["config"].is_string()) {
            RunConfig c = parseConfig(e["config"].get<std::string>());
            if (e.contains("label")) c.label = e["label"].get<std::string>();
            out.push_back(c);
        } else {
            throw std::invalid_argument(path + ": each configuration is a string or {\"config\": ..., \"label\": ...}");
        }
    }
    return out;
}

std::vector<RunConfig> gatherConfigs(const std::vector<std::string>& specs, const std::string& file) {
    std::vector<RunConfig> out;
    for (const auto& s : specs) out.push_back(parseConfig(s));
    if (!file.empty())
        for (auto& c : readConfigFile(file)) out.push_back(c);
    if (out.empty()) throw std::invalid_argument("no configuration given (--config \"pt\" or --configs FILE.json)");
    std::set<std::string> labels, slugs;
    for (const auto& c : out) {
        if (!labels.insert(c.label).second) throw std::invalid_argument("two configurations have the label '" + c.label + "'");
        if (!slugs.insert(slug(c.label)).second)
            throw std::invalid_argument("two configurations have the same file name '" + slug(c.label) + "'; use --label");
        if (!integratorAvailable(c.integrator))
            throw std::invalid_argument(fmt::format("configuration '{}': integrator '{}' is not available (available: {})",
                                                    c.spec, c.integrator, supportedIntegrators()));
        SceneDesc dummy;
        makeSettings(dummy, c, 0, 0);  // throws for options this build cannot take
    }
    return out;
}

const Scene& ScenesByIntegrator::operator()(const std::string& integrator) {
    const LightSelection rule = lightSelectionFor(integrator);
    std::unique_ptr<Scene>& s = scenes_[rule];
    if (!s) {
        SceneDesc d = desc_;
        d.lightSelection = rule;
        s = std::make_unique<Scene>(d);
    }
    return *s;
}

RenderSettings makeSettings(const SceneDesc& desc, const RunConfig& c, int threads, uint64_t seed) {
    RenderSettings s;
    s.integrator = c.integrator;
    s.threads = threads;
    s.seed = seed;
    s.quiet = true;
    s.maxDepth = desc.integrator.maxDepth;
    s.rrDepth = desc.integrator.rrDepth;
    s.hideEmitters = desc.integrator.hideEmitters;
    if (desc.integrator.radius > 0) s.radius = desc.integrator.radius;
    s.radiusAlpha = desc.integrator.radiusAlpha;
    if (c.ptStrategy) s.ptStrategy = *c.ptStrategy;
    if (c.maxDepth) s.maxDepth = *c.maxDepth;
    if (c.rrDepth) s.rrDepth = *c.rrDepth;
    if (c.hideEmitters) s.hideEmitters = *c.hideEmitters;
    if (c.radius) s.radius = float(*c.radius);
    if (c.radiusAlpha) s.radiusAlpha = float(*c.radiusAlpha);
    s.regularizer = c.regularizer.value_or(desc.integrator.regularizer);
    s.regTau = c.regTau.value_or(desc.integrator.regTau);
    s.regSchedule = c.regSchedule.value_or(desc.integrator.regSchedule);
    s.regMis = c.regMis.value_or(desc.integrator.regMis);
    s.regQuality = c.regQuality.value_or(desc.integrator.regQuality);
    s.regDiffusion = c.regDiffusion ? c.regDiffusion : desc.integrator.regDiffusion;
    s.regSpecular = c.regSpecular.value_or(desc.integrator.regSpecular);
    s.regBound = c.regBound.value_or(desc.integrator.regBound);
    s.regEnergy = c.regEnergy.value_or(desc.integrator.regEnergy);
    s.regR0 = c.regR0.value_or(desc.integrator.regR0);
    s.regLambda = c.regLambda.value_or(desc.integrator.regLambda);
    s.regOpsrGamma = c.regOpsrGamma.value_or(desc.integrator.regOpsrGamma);
    s.regOpsrTable = c.regOpsrTable.value_or(desc.integrator.regOpsrTable);
    s.regOpsrConsistent = c.regOpsrConsistent.value_or(desc.integrator.regOpsrConsistent);
    s.regOpsrAlwaysSample = c.regOpsrAlwaysSample.value_or(desc.integrator.regOpsrAlwaysSample);
    s.regTailRr = c.regTailRr.value_or(desc.integrator.regTailRr);
    s.guiding = c.guiding.value_or(desc.integrator.guiding);
    s.guidingBsdfFraction = c.guidingBsdfFraction.value_or(desc.integrator.guidingBsdfFraction);
    if (c.guidingCombine) s.guidingCombine = *c.guidingCombine;
    if (c.guidingSpatialThreshold) s.guidingSpatialThreshold = *c.guidingSpatialThreshold;
    if (c.guidingMaxMb) s.guidingMaxMb = *c.guidingMaxMb;
    if (!c.extra.empty())  // RenderSettings has no free-form options: the first unknown one is named
        throw std::invalid_argument(fmt::format("configuration '{}': unknown option --{} (known: --pt-strategy, "
                                                    "--max-depth, --rr-depth, --hide-emitters, --radius, --radius-alpha, --reg, --reg-tau, "
                                                    "--reg-schedule, --reg-mis, --reg-quality, --reg-diffusion, --reg-specular, --reg-bound, --reg-energy, --reg-r0, --reg-lambda, "
                                                    "--reg-opsr-gamma, --reg-opsr-table, --reg-opsr-consistent, --reg-opsr-always-sample, --reg-tail-rr, "
                                                    "--guiding, --guiding-bsdf-fraction, --guiding-combine, "
                                                    "--guiding-spatial-threshold, --guiding-max-mb, --label)",
                                                    c.spec, c.extra.begin()->first));
    return s;
}

std::vector<std::string> availableIntegrators() {
    std::vector<std::string> out;
    std::string cur;
    for (char ch : supportedIntegrators() + " ") {
        if (std::isalnum((unsigned char)ch) || ch == '_' || ch == '-') {
            cur += ch;
        } else if (!cur.empty()) {
            out.push_back(cur);
            cur.clear();
        }
    }
    return out;
}

bool integratorAvailable(const std::string& name) {
    auto v = availableIntegrators();
    return std::find(v.begin(), v.end(), name) != v.end();
}

std::string slug(const std::string& label) {
    std::string s;
    for (char ch : label) {
        if (std::isalnum((unsigned char)ch) || ch == '-' || ch == '.') s += ch;
        else if (!s.empty() && s.back() != '_') s += '_';
    }
    while (!s.empty() && (s.back() == '_' || s.back() == '.')) s.pop_back();
    while (!s.empty() && (s.front() == '-' || s.front() == '.' || s.front() == '_')) s.erase(s.begin());
    return s.empty() ? "config" : s;
}

CropRect parseCropRect(const std::string& s) {
    std::vector<int> v;
    std::stringstream ss(s);
    std::string tok;
    while (std::getline(ss, tok, ',')) v.push_back(toInt("--crop", tok));
    if (v.size() != 4 || v[2] <= 0 || v[3] <= 0 || v[0] < 0 || v[1] < 0)
        throw std::invalid_argument("--crop expects x,y,w,h with x,y >= 0 and w,h > 0, got '" + s + "'");
    return CropRect{v[0], v[1], v[2], v[3]};
}

// ---------------------------------------------------------------------------------------------
// Statistics

LineFit fitLogLog(const std::vector<double>& x, const std::vector<double>& y) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int n = 0;
    for (size_t i = 0; i < std::min(x.size(), y.size()); ++i) {
        if (!(x[i] > 0) || !(y[i] > 0) || !std::isfinite(x[i]) || !std::isfinite(y[i])) continue;
        double lx = std::log10(x[i]), ly = std::log10(y[i]);
        sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly;
        ++n;
    }
    LineFit f;
    double den = n * sxx - sx * sx;
    if (n < 2 || !(std::abs(den) > 1e-300)) return f;
    f.points = n;
    f.slope = (n * sxy - sx * sy) / den;
    f.intercept = (sy - f.slope * sx) / n;
    return f;
}

void ErrorAccumulator::add(const Image& img, const Image& ref) {
    if (img.width != width || img.height != height || ref.width != width || ref.height != height)
        throw std::invalid_argument(fmt::format("image size {}x{} differs from the reference's {}x{}", img.width,
                                                img.height, ref.width, ref.height));
    for (size_t p = 0; p < img.pixels.size(); ++p)
        for (int c = 0; c < 3; ++c) {
            double d = double(img.pixels[p][c]) - double(ref.pixels[p][c]);
            sum[3 * p + c] += d;
            sumSq[3 * p + c] += d * d;
        }
    ++runs;
}

void ErrorAccumulator::merge(const ErrorAccumulator& o) {
    if (o.width != width || o.height != height) throw std::invalid_argument("ErrorAccumulator::merge: sizes differ");
    for (size_t i = 0; i < sum.size(); ++i) sum[i] += o.sum[i], sumSq[i] += o.sumSq[i];
    runs += o.runs;
}

PixelStats pixelStats(const ErrorAccumulator& acc, const Image& ref) {
    if (acc.runs < 2) throw std::invalid_argument("bias/variance needs at least 2 runs");
    const double K = double(acc.runs);
    const int w = acc.width, h = acc.height;
    PixelStats s{Image(w, h), Image(w, h), Image(w, h), Image(w, h)};
    for (size_t p = 0; p < ref.pixels.size(); ++p)
        for (int c = 0; c < 3; ++c) {
            double md = acc.sum[3 * p + c] / K, q = acc.sumSq[3 * p + c];
            double var = std::max(0.0, (q - K * md * md) / (K - 1));
            s.mean.pixels[p][c] = float(ref.pixels[p][c] + md);
            s.variance.pixels[p][c] = float(var);
            s.bias2.pixels[p][c] = float(md * md - var / K);
            s.mse.pixels[p][c] = float(q / K);
        }
    return s;
}

ImageFigures imageFigures(const PixelStats& s, const Image* ref, const CropRect* crop) {
    ImageFigures f;
    const int w = s.mean.width;
    const CropRect r = crop ? *crop : CropRect{0, 0, w, s.mean.height};
    if (r.x < 0 || r.y < 0 || r.w <= 0 || r.h <= 0 || r.x + r.w > w || r.y + r.h > s.mean.height)
        throw std::invalid_argument(fmt::format("crop {},{},{},{} is not inside the {}x{} image", r.x, r.y, r.w, r.h, w,
                                                s.mean.height));
    const size_t n = size_t(r.w) * size_t(r.h);
    f.pixels = n;
    auto meanSe = [n, ref, r, w](const Image& img, double& mean, double& se) {
        double sum = 0, sq = 0;
        for (size_t i = 0; i < n; ++i) {
            const size_t p = size_t(r.y + int(i) / r.w) * size_t(w) + size_t(r.x + int(i) % r.w);
            const Color& c = img.pixels[p];
            double v = 0;
            for (int k = 0; k < 3; ++k) {
                double w = ref ? 1.0 / (double(ref->pixels[p][k]) * ref->pixels[p][k] + kRelMseEpsilon) : 1.0;
                v += w * c[k];
            }
            sum += v;
            sq += v * v;
        }
        double m = sum / double(n);
        double var = n > 1 ? std::max(0.0, (sq - double(n) * m * m) / double(n - 1)) : 0.0;
        mean = m / 3.0;
        se = std::sqrt(var / double(n)) / 3.0;
    };
    meanSe(s.bias2, f.bias2, f.bias2StdErr);
    meanSe(s.variance, f.variance, f.varianceStdErr);
    meanSe(s.mse, f.mse, f.mseStdErr);
    return f;
}

// ---------------------------------------------------------------------------------------------
// CSV

std::string csvField(const std::string& s) {
    if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
    std::string r = "\"";
    for (char c : s) r += c == '"' ? std::string("\"\"") : std::string(1, c);
    return r + "\"";
}

std::vector<std::string> splitCsvLine(const std::string& line) {
    std::vector<std::string> out;
    std::string cur;
    bool quoted = false;
    for (size_t i = 0; i < line.size(); ++i) {
        char c = line[i];
        if (quoted) {
            if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') cur += '"', ++i;
            else if (c == '"') quoted = false;
            else cur += c;
        } else if (c == '"') {
            quoted = true;
        } else if (c == ',') {
            out.push_back(cur);
            cur.clear();
        } else if (c != '\r') {
            cur += c;
        }
    }
    out.push_back(cur);
    return out;
}

// ---------------------------------------------------------------------------------------------
// Images

Image weightedAverage(const std::vector<Image>& imgs, const std::vector<double>& weights) {
    if (imgs.empty() || imgs.size() != weights.size()) throw std::invalid_argument("weightedAverage: bad arguments");
    double wsum = 0;
    for (size_t i = 0; i < imgs.size(); ++i) {
        if (imgs[i].width != imgs[0].width || imgs[i].height != imgs[0].height)
            throw std::invalid_argument(fmt::format("image {} is {}x{}, the first is {}x{}", i + 1, imgs[i].width,
                                                    imgs[i].height, imgs[0].width, imgs[0].height));
        if (!(weights[i] >= 0)) throw std::invalid_argument("negative weight");
        wsum += weights[i];
    }
    if (!(wsum > 0)) throw std::invalid_argument("the weights sum to zero");
    Image out(imgs[0].width, imgs[0].height);
    for (size_t p = 0; p < out.pixels.size(); ++p)
        for (int c = 0; c < 3; ++c) {
            double s = 0;
            for (size_t i = 0; i < imgs.size(); ++i) s += weights[i] * double(imgs[i].pixels[p][c]);
            out.pixels[p][c] = float(s / wsum);
        }
    return out;
}

Image falseColour(const Image& map, double vmax, double decades) {
    Image out(map.width, map.height);
    double lmax = std::log10(vmax > 0 ? vmax : 1.0);
    auto toLinear = [](double s) { return s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4); };
    for (size_t p = 0; p < map.pixels.size(); ++p) {
        const Color& c = map.pixels[p];
        double v = (double(c.x) + c.y + c.z) / 3.0;
        double t = (std::isfinite(v) && v > 0) ? (std::log10(v) - lmax + decades) / decades : 0.0;
        t = std::clamp(t, 0.0, 1.0);
        // Viridis, polynomial fit (sRGB display values).
        const double c0[3] = {0.2777273272234177, 0.005407344544966578, 0.3340998053353061};
        const double c1[3] = {0.1050930431085774, 1.404613529898575, 1.384590162594685};
        const double c2[3] = {-0.3308618287255563, 0.214847559468213, 0.09509516302823659};
        const double c3[3] = {-4.634230498983486, -5.799100973351585, -19.33244095627987};
        const double c4[3] = {6.228269936347081, 14.17993336680509, 56.69055260068105};
        const double c5[3] = {4.776384997670288, -13.74514537774601, -65.35303263337234};
        const double c6[3] = {-5.435455855934631, 4.645852612178535, 26.3124352495832};
        for (int k = 0; k < 3; ++k) {
            double s = c0[k] + t * (c1[k] + t * (c2[k] + t * (c3[k] + t * (c4[k] + t * (c5[k] + t * c6[k])))));
            out.pixels[p][k] = float(toLinear(std::clamp(s, 0.0, 1.0)));
        }
    }
    return out;
}

double quantile(const Image& img, double q) {
    std::vector<float> v;
    v.reserve(img.pixels.size() * 3);
    for (const auto& c : img.pixels)
        for (int k = 0; k < 3; ++k)
            if (std::isfinite(c[k])) v.push_back(c[k]);
    if (v.empty()) return 0.0;
    size_t i = std::min(v.size() - 1, size_t(std::clamp(q, 0.0, 1.0) * double(v.size() - 1)));
    std::nth_element(v.begin(), v.begin() + long(i), v.end());
    return v[i];
}

float autoExposure(const Image& img) {
    double p = quantile(img, 0.99);
    if (!(p > 0)) return 0.f;
    return float(std::clamp(std::log2(0.9 / p), -20.0, 20.0));
}

Image cropZoom(const Image& img, const CropRect& r, int scale) {
    if (r.x < 0 || r.y < 0 || r.x + r.w > img.width || r.y + r.h > img.height || r.w <= 0 || r.h <= 0)
        throw std::invalid_argument(fmt::format("crop {},{},{},{} is not inside the {}x{} image", r.x, r.y, r.w, r.h,
                                                img.width, img.height));
    scale = std::max(1, scale);
    Image out(r.w * scale, r.h * scale);
    for (int y = 0; y < out.height; ++y)
        for (int x = 0; x < out.width; ++x) out.at(x, y) = img.at(r.x + x / scale, r.y + y / scale);
    return out;
}

// ---------------------------------------------------------------------------------------------
// Misc

std::string base64(const std::string& in) {
    static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((in.size() + 2) / 3 * 4);
    size_t i = 0;
    for (; i + 2 < in.size(); i += 3) {
        uint32_t v = uint32_t((unsigned char)in[i]) << 16 | uint32_t((unsigned char)in[i + 1]) << 8 | (unsigned char)in[i + 2];
        out += t[v >> 18], out += t[(v >> 12) & 63], out += t[(v >> 6) & 63], out += t[v & 63];
    }
    if (i + 1 == in.size()) {
        uint32_t v = uint32_t((unsigned char)in[i]) << 16;
        out += t[v >> 18], out += t[(v >> 12) & 63], out += "==";
    } else if (i + 2 == in.size()) {
        uint32_t v = uint32_t((unsigned char)in[i]) << 16 | uint32_t((unsigned char)in[i + 1]) << 8;
        out += t[v >> 18], out += t[(v >> 12) & 63], out += t[(v >> 6) & 63], out += '=';
    }
    return out;
}

std::string readFile(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    if (!f) throw std::runtime_error(path + ": cannot open");
    std::ostringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

void writeTextFile(const std::string& path, const std::string& text) {
    fs::path p(path);
    if (p.has_parent_path()) fs::create_directories(p.parent_path());
    // Through a temporary file renamed over `path`, as the images (core/image.cpp): never a
    // half-written file, and the previous one kept where the write fails.
    const std::string tmp = path + ".tmp" + std::to_string(::getpid());
    {
        std::ofstream f(tmp, std::ios::binary);
        f << text;
        f.flush();
        if (!f) {
            std::error_code ec;
            fs::remove(tmp, ec);
            throw std::runtime_error(path + ": cannot write");
        }
    }
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) {
        fs::remove(tmp, ec);
        throw std::runtime_error(path + ": cannot replace the file");
    }
}

std::string commandLine(int argc, char** argv) {
    std::string s;
    for (int i = 0; i < argc; ++i) {
        std::string a = argv[i];
        bool plain = !a.empty() && a.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789"
                                                       "-_./=,:+@%") == std::string::npos;
        if (!plain) {
            std::string q = "'";
            for (char c : a) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
            a = q + "'";
        }
        s += (i ? " " : "") + a;
    }
    return s;
}

std::string nowUtc() {
    std::time_t t = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

nlohmann::json metricsJson(const ErrorMetrics& m) {
    return {{"mse", m.mse}, {"relmse", m.relMse}, {"rmsre", m.rmsRelErr}, {"mape", m.mape},
            {"mean_image", m.meanImage}, {"mean_reference", m.meanReference}};
}

int parseRunInputs(const char* tool, const std::vector<std::string>& defineList,
                   const std::vector<std::string>& specs, const std::string& configFile,
                   std::map<std::string, std::string>& defines, std::vector<RunConfig>& configs) {
    try {
        defines = parseDefines(defineList);
        configs = gatherConfigs(specs, configFile);
    } catch (const std::exception& e) {
        fmt::print(stderr, "{}: error: {}\n", tool, e.what());
        return 1;
    }
    return 0;
}

int loadRunScene(const char* tool, const std::string& scenePath, const std::map<std::string, std::string>& defines,
                 SceneDesc& desc, SceneHash* hash) {
    try {
        desc = loadScene(scenePath, defines);
        if (hash) *hash = hashScene(scenePath, defines);
    } catch (const std::exception& e) {
        fmt::print(stderr, "{}: error: {}\n", tool, e.what());
        return 2;
    }
    for (const auto& w : desc.warnings) fmt::print(stderr, "warning: {}\n", w);
    return 0;
}

int loadReference(const char* tool, const std::string& refPath, const SceneDesc& desc, Image& ref) {
    try {
        ref = readImage(refPath);
    } catch (const std::exception& e) {
        fmt::print(stderr, "{}: error: {}\n", tool, e.what());
        return 2;
    }
    if (ref.width != desc.camera.width || ref.height != desc.camera.height) {
        fmt::print(stderr, "{}: error: the reference is {}x{} but the scene renders {}x{} (use -D res=... or another "
                           "reference)\n", tool, ref.width, ref.height, desc.camera.width, desc.camera.height);
        return 2;
    }
    if (auto bad = findNonFinite(ref)) {
        fmt::print(stderr, "{}: error: the reference has a non-finite value at pixel ({}, {})\n", tool, bad->first,
                   bad->second);
        return 2;
    }
    return 0;
}

}  // namespace lt::analysis
