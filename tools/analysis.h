// Shared code of the speed-against-error tools (convergence, biasvar, reference, merge, report,
// bench): run configurations ("pt --pt-strategy bsdf") and their mapping to RenderSettings,
// log-log fits, CSV fields, plots drawn by gnuplot (PNG + SVG), scene hashing (SHA-256 of the
// scene file, its includes and its mesh files), false-colour maps and small helpers.
#pragma once
#include <cstdint>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>
#include "core/image.h"
#include "core/metrics.h"
#include "core/scene_desc.h"
#include "integrators/integrator.h"

namespace lt::analysis {

// ---- Run configurations -------------------------------------------------------------------
// A configuration is an integrator name followed by options, as one string:
//   "pt"  "pt --pt-strategy bsdf"  "vcm --radius 0.01 --radius-alpha 0.75"  "bpt --max-depth 8 --label BPT"
// Options (as in `render`): --pt-strategy mis|nee|bsdf, --max-depth D, --rr-depth D, --hide-emitters,
// --radius R, --radius-alpha A (or --alpha; initial radius and radius reduction of VCM/PPM),
// --reg none|jg19|kd13|opsr, --reg-tau T, --reg-schedule consistent|fixed, --reg-mis regularised|sampling,
// --reg-quality on|off, --reg-diffusion on|off, --reg-specular ggx|cone, --reg-bound tight|published,
// --reg-energy compensate|none, --reg-r0 R, --reg-lambda L,
// --reg-opsr-gamma G, --reg-opsr-table FILE[:SET], --reg-opsr-consistent (path-space regularisation, as render), --label NAME (the name in legends, tables and the CSV; default: the whole string). Any other
// `--name value` is an error naming it. Mitsuba integrator
// names (path, bdpt, ptracer) are accepted for pt, bpt, lt.
struct RunConfig {
    std::string spec;        // as given
    std::string label;       // unique among the configurations of one run
    std::string integrator;  // renderer name (pt, bpt, vcm, lt, ppm, ...)
    std::optional<std::string> ptStrategy;
    std::optional<int> maxDepth, rrDepth;
    std::optional<bool> hideEmitters;
    std::optional<double> radius, radiusAlpha;
    // Regularisation, as render's --reg, --reg-tau, --reg-schedule, --reg-mis, --reg-quality,
    // --reg-diffusion, --reg-specular, --reg-r0, --reg-lambda, --reg-opsr-gamma, --reg-opsr-table,
    // --reg-opsr-consistent, --reg-opsr-always-sample, --reg-tail-rr.
    std::optional<std::string> regularizer, regSchedule, regMis, regSpecular, regBound, regEnergy;
    std::optional<double> regTau, regR0, regLambda, regOpsrGamma, regTailRr;
    std::optional<std::string> regOpsrTable;
    std::optional<bool> regOpsrConsistent, regOpsrAlwaysSample;
    std::optional<bool> regQuality, regDiffusion;
    // Path guiding, as render's --guiding, --guiding-bsdf-fraction (a number or 'learned': < 0),
    // --guiding-combine, --guiding-spatial-threshold, --guiding-max-mb.
    std::optional<std::string> guiding, guidingCombine;
    std::optional<double> guidingBsdfFraction, guidingSpatialThreshold, guidingMaxMb;
    std::map<std::string, std::string> extra;
};

// Throws std::invalid_argument with a message naming the offending word.
RunConfig parseConfig(const std::string& spec);
// A sweep "OPTION=V1,V2,..." (biasvar --sweep): the option without its leading "--" (a word of
// letters, digits and '-') and its values, each a finite number > 0 (they are plotted on a log
// axis), sorted, distinct. Throws std::invalid_argument naming the part that is wrong.
void parseSweep(const std::string& spec, std::string& option, std::vector<double>& values);
// JSON file: either ["pt", "pt --pt-strategy bsdf"] or {"configs": [...]} whose entries are
// strings or objects {"config": "pt --pt-strategy bsdf", "label": "PT (BSDF only)"}.
std::vector<RunConfig> readConfigFile(const std::string& path);
// Command-line specs then the file's; checks the labels are unique and each integrator exists.
std::vector<RunConfig> gatherConfigs(const std::vector<std::string>& specs, const std::string& file);

// Settings from the scene (max depth, rr depth, hide emitters, radius) overridden by the config.
RenderSettings makeSettings(const SceneDesc& desc, const RunConfig& cfg, int threads, uint64_t seed);

// The scene as `render` builds it for an integrator (its light selection: lightSelectionFor), built
// once per selection rule and kept: the tools that run several integrators on one scene.
class ScenesByIntegrator {
public:
    explicit ScenesByIntegrator(const SceneDesc& desc) : desc_(desc) {}
    const Scene& operator()(const std::string& integrator);

private:
    const SceneDesc& desc_;
    std::map<LightSelection, std::unique_ptr<Scene>> scenes_;
};
// Names that makeIntegrator accepts (split from supportedIntegrators()).
std::vector<std::string> availableIntegrators();
bool integratorAvailable(const std::string& name);
// File-name-safe version of a label ("pt --pt-strategy bsdf" -> "pt_pt-strategy_bsdf").
std::string slug(const std::string& label);

// "x,y,w,h". Throws std::invalid_argument.
CropRect parseCropRect(const std::string& s);

// ---- Statistics ----------------------------------------------------------------------------
struct LineFit {
    double slope = 0.0, intercept = 0.0;  // log10 y = intercept + slope * log10 x
    int points = 0;                       // points used (x > 0, y > 0, finite); < 2: no fit
    bool valid() const { return points >= 2; }
};
// Least-squares line through (log10 x, log10 y), skipping non-positive or non-finite points.
LineFit fitLogLog(const std::vector<double>& x, const std::vector<double>& y);

// Per-pixel statistics of K images (independent renders) against a reference, per channel:
//   mean_i = (1/K) sum_k x_ik,  var_i = 1/(K-1) sum_k (x_ik - mean_i)^2   (variance of ONE render)
//   bias2_i = (mean_i - ref_i)^2 - var_i / K    (unbiased for bias^2: E[(mean-ref)^2] = bias^2 + var/K;
//                                               may be negative; reference noise is neglected)
//   mse_i = (1/K) sum_k (x_ik - ref_i)^2       (= bias2_i + (K-1)/K var_i + var_i/K = bias2_i + var_i
//                                               exactly, for these estimators)
// Accumulated as running sums of d = x - ref (memory independent of K).
struct ErrorAccumulator {
    int width = 0, height = 0;
    uint64_t runs = 0;
    std::vector<double> sum, sumSq;  // of x - ref, per channel value
    ErrorAccumulator() = default;
    ErrorAccumulator(int w, int h) : width(w), height(h), sum(size_t(w) * h * 3, 0.0), sumSq(size_t(w) * h * 3, 0.0) {}
    void add(const Image& img, const Image& ref);  // throws on a size mismatch
    void merge(const ErrorAccumulator& o);
};
struct PixelStats {
    Image mean, variance, bias2, mse;
};
PixelStats pixelStats(const ErrorAccumulator& acc, const Image& ref);  // needs acc.runs >= 2

// Image-wide figures (averages over all channel values) with standard errors over pixels (the
// pixels are independent; the 3 channels of a pixel are summed first, as they are correlated).
struct ImageFigures {
    double bias2 = 0, bias2StdErr = 0;  // z = bias2 / bias2StdErr tests H0: unbiased
    double variance = 0, varianceStdErr = 0;
    double mse = 0, mseStdErr = 0;      // mean over runs of each run's MSE
    size_t pixels = 0;
};
// With `ref`, every value's terms are divided by (ref^2 + 0.01) first, as in relMSE (relative
// figures: relMSE = relative bias^2 + relative variance).
// With a crop: over the pixels of that rectangle only (it must lie inside the image).
ImageFigures imageFigures(const PixelStats& s, const Image* ref = nullptr, const CropRect* crop = nullptr);

// ---- CSV -----------------------------------------------------------------------------------
// Quotes a field if it contains a comma, a quote or a line break (RFC 4180).
std::string csvField(const std::string& s);
// Splits one CSV line (RFC 4180 quoting, no embedded line breaks).
std::vector<std::string> splitCsvLine(const std::string& line);

// ---- Plots (gnuplot) ----------------------------------------------------------------------
struct Curve {
    std::string title;
    std::vector<double> x, y;
    int color = -1;       // index into a fixed palette; -1 = next colour
    bool dashed = false;  // a dashed line without points (e.g. a noise floor)
    bool dotted = false;  // a dotted line without points
    int pointType = 7;    // gnuplot point type of a solid curve (7 circle, 5 square, 9 triangle)
};
struct Panel {
    std::string title, xlabel, ylabel;
    bool logx = true, logy = true;
    std::vector<Curve> curves;
};
struct PlotFiles {
    std::string png, svg, script, data;
    bool ok = false;      // PNG and SVG written by gnuplot
    std::string message;  // why not, when !ok
};
// Writes base.dat and base.gp and runs gnuplot (found in PATH, or $LT_GNUPLOT), which writes
// base.png and base.svg: the panels side by side. Points with non-positive values on a log axis
// are left out. Never throws for a missing gnuplot: returns ok = false with the reason.
PlotFiles plot(const std::string& base, const std::vector<Panel>& panels, int panelWidth = 560,
               int height = 420);
bool gnuplotAvailable();

// ---- Scene hashing -------------------------------------------------------------------------
std::string sha256Hex(const std::string& bytes);
struct SceneHash {
    std::string sha256;  // over the defines and every file's relative path and SHA-256
    std::vector<std::pair<std::string, std::string>> files;  // (path, SHA-256), scene first
};
// The scene file, the files it includes (recursively, as the loader resolves them) and the mesh
// files its shapes read, plus the -D defines. Throws on a missing scene file.
SceneHash hashScene(const std::string& scenePath, const std::map<std::string, std::string>& defines);

// ---- Tool start-up (biasvar, convergence, reference) ----------------------------------------
// Each returns 0, or the tool's exit code after printing "<tool>: error: ..." to stderr:
// 1 for the command line (defines, run configurations), 2 for the scene or the reference.
int parseRunInputs(const char* tool, const std::vector<std::string>& defineList,
                   const std::vector<std::string>& specs, const std::string& configFile,
                   std::map<std::string, std::string>& defines, std::vector<RunConfig>& configs);
// Loads the scene (printing its warnings) and, when hash is given, hashes it.
int loadRunScene(const char* tool, const std::string& scenePath, const std::map<std::string, std::string>& defines,
                 SceneDesc& desc, SceneHash* hash);
// Reads a reference image; it must have the scene's size and finite values.
int loadReference(const char* tool, const std::string& refPath, const SceneDesc& desc, Image& ref);

// ---- Images --------------------------------------------------------------------------------
// sum_i w_i img_i / sum_i w_i, in double precision. Sizes must agree (throws otherwise).
Image weightedAverage(const std::vector<Image>& imgs, const std::vector<double>& weights);
// Viridis false colour of a scalar map (the mean of the three channels), logarithmic over
// `decades` decades below vmax (values <= vmax * 10^-decades are dark blue). The result is
// linear RGB such that writePng shows the viridis colours.
Image falseColour(const Image& map, double vmax, double decades = 3.0);
// The q-quantile (0..1) of all channel values (ignores non-finite values; 0 for an empty image).
double quantile(const Image& img, double q);
// Exposure (EV) for writePng so that the 99th percentile of the channel values maps to 0.9.
float autoExposure(const Image& img);
// Copy of a rectangle, enlarged `scale` times by pixel replication.
Image cropZoom(const Image& img, const CropRect& r, int scale);

// ---- Misc ----------------------------------------------------------------------------------
std::string base64(const std::string& bytes);
// Runs args[0] (a path, or a name looked up in PATH) with the arguments and waits. stdout and
// stderr go to logPath, or stay the caller's when logPath is empty. Returns the exit status, 127
// if the program could not be started, 128 + n if killed by signal n.
int runProgram(const std::vector<std::string>& args, const std::string& logPath = "");
// The folder of the running executable (/proc/self/exe), to find the sibling tools.
std::string executableDir();
std::string readFile(const std::string& path);  // throws std::runtime_error naming the file
void writeTextFile(const std::string& path, const std::string& text);  // throws; creates folders
std::string commandLine(int argc, char** argv);  // shell-quoted where needed
std::string nowUtc();                           // "2024-05-01T12:34:56Z"
nlohmann::json metricsJson(const ErrorMetrics& m);

}  // namespace lt::analysis
