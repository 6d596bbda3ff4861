#include "core/metrics.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <tuple>

namespace lt {

namespace {

std::string sizeStr(const Image& im) { return std::to_string(im.width) + "x" + std::to_string(im.height); }

std::string sizeMismatch(const std::string& path, const Image& got, int width, int height) {
    return path + ": size " + sizeStr(got) + " differs from the image's " + std::to_string(width) + "x" +
           std::to_string(height);
}

std::string fmtValue(float v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", double(v));
    return buf;
}

// Validates the inputs and returns the region to compare.
CropRect checkInputs(const Image& img, const Image& ref, const CropRect* crop) {
    if (img.width != ref.width || img.height != ref.height)
        throw std::invalid_argument("image size mismatch: image is " + sizeStr(img) + ", reference is " + sizeStr(ref));
    for (const Image* im : {&img, &ref})
        if (im->pixels.size() != size_t(std::max(im->width, 0)) * size_t(std::max(im->height, 0)))
            throw std::invalid_argument("inconsistent image: " + sizeStr(*im) + " but " +
                                        std::to_string(im->pixels.size()) + " pixels stored");
    if (img.width <= 0 || img.height <= 0) throw std::invalid_argument("cannot compare empty images (" + sizeStr(img) + ")");
    CropRect r{0, 0, img.width, img.height};
    if (crop) {
        r = *crop;
        if (r.w <= 0 || r.h <= 0 || r.x < 0 || r.y < 0 || int64_t(r.x) + r.w > img.width || int64_t(r.y) + r.h > img.height)
            throw std::invalid_argument("crop rectangle x=" + std::to_string(r.x) + ",y=" + std::to_string(r.y) +
                                        ",w=" + std::to_string(r.w) + ",h=" + std::to_string(r.h) +
                                        " is empty or not inside the " + sizeStr(img) + " image");
    }
    for (auto [im, what] : {std::pair{&img, "image"}, std::pair{&ref, "reference"}})
        if (auto p = findNonFinite(*im, &r)) {
            const Color& c = im->at(p->first, p->second);
            throw std::invalid_argument(std::string(what) + ": non-finite value at pixel (" + std::to_string(p->first) +
                                        ", " + std::to_string(p->second) + "): (" + fmtValue(c.x) + ", " +
                                        fmtValue(c.y) + ", " + fmtValue(c.z) + ")");
        }
    return r;
}

}  // namespace

const char* metricName(Metric m) {
    switch (m) {
        case Metric::Mean: return "mean";
        case Metric::Mse: return "mse";
        case Metric::RelMse: return "relmse";
        case Metric::RmsRelErr: return "rmsre";
        case Metric::Mape: return "mape";
    }
    return "?";
}

std::optional<Metric> parseMetric(std::string_view name) {
    std::string s(name);
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    for (Metric m : {Metric::Mean, Metric::Mse, Metric::RelMse, Metric::RmsRelErr, Metric::Mape})
        if (s == metricName(m)) return m;
    return std::nullopt;
}

std::optional<std::pair<int, int>> findNonFinite(const Image& img, const CropRect* crop) {
    CropRect r = crop ? *crop : CropRect{0, 0, img.width, img.height};
    for (int y = r.y; y < r.y + r.h; ++y)
        for (int x = r.x; x < r.x + r.w; ++x)
            if (!isFinite(img.at(x, y))) return std::pair{x, y};
    return std::nullopt;
}

namespace {

// The metrics over the rectangle r, leaving out the pixels whose `excluded` entry (row-major over
// the whole image) is true.
ErrorMetrics metricsOver(const Image& img, const Image& ref, const CropRect& r, const std::vector<bool>* excluded) {
    // Per-row partial sums keep the double accumulation accurate for large images.
    double sumA = 0, sumB = 0, sumSq = 0, sumRel = 0, sumRe = 0, sumApe = 0;
    size_t pixels = 0;
    for (int y = r.y; y < r.y + r.h; ++y) {
        double rowA = 0, rowB = 0, rowSq = 0, rowRel = 0, rowRe = 0, rowApe = 0;
        for (int x = r.x; x < r.x + r.w; ++x) {
            if (excluded && (*excluded)[size_t(y) * img.width + x]) continue;
            ++pixels;
            const Color& ca = img.at(x, y);
            const Color& cb = ref.at(x, y);
            for (int c = 0; c < 3; ++c) {
                double a = ca[c], b = cb[c];
                rowA += a;
                rowB += b;
                rowSq += sqrErrTerm(a, b);
                rowRel += relMseTerm(a, b);
                rowRe += rmsRelErrTerm(a, b);
                rowApe += mapeTerm(a, b);
            }
        }
        sumA += rowA; sumB += rowB; sumSq += rowSq; sumRel += rowRel; sumRe += rowRe; sumApe += rowApe;
    }
    ErrorMetrics m;
    m.pixels = pixels;
    if (pixels == 0) return m;
    const double n = 3.0 * double(m.pixels);
    m.meanImage = sumA / n;
    m.meanReference = sumB / n;
    m.mse = sumSq / n;
    m.relMse = sumRel / n;
    m.rmsRelErr = std::sqrt(sumRe / n);
    m.mape = sumApe / n;
    return m;
}

}  // namespace

ErrorMetrics computeMetrics(const Image& img, const Image& ref, const CropRect* crop) {
    return metricsOver(img, ref, checkInputs(img, ref, crop), nullptr);
}

ErrorMetrics computeMetrics(const Image& img, const Image& ref, const std::vector<bool>& excluded) {
    const CropRect r = checkInputs(img, ref, nullptr);
    if (excluded.size() != size_t(img.width) * size_t(img.height))
        throw std::invalid_argument("computeMetrics: the exclusion mask has " + std::to_string(excluded.size()) +
                                    " entries for a " + std::to_string(img.width) + "x" + std::to_string(img.height) +
                                    " image");
    return metricsOver(img, ref, r, &excluded);
}

Image errorMap(const Image& img, const Image& ref, Metric metric, const CropRect* crop) {
    const CropRect r = checkInputs(img, ref, crop);
    Image out(r.w, r.h);
    for (int y = 0; y < r.h; ++y)
        for (int x = 0; x < r.w; ++x) {
            const Color& ca = img.at(r.x + x, r.y + y);
            const Color& cb = ref.at(r.x + x, r.y + y);
            Color& o = out.at(x, y);
            for (int c = 0; c < 3; ++c) {
                double a = ca[c], b = cb[c], v = 0;
                switch (metric) {
                    case Metric::Mean: v = a - b; break;
                    case Metric::Mse: v = sqrErrTerm(a, b); break;
                    case Metric::RelMse: v = relMseTerm(a, b); break;
                    case Metric::RmsRelErr: v = rmsRelErrTerm(a, b); break;
                    case Metric::Mape: v = mapeTerm(a, b); break;
                }
                o[c] = float(v);
            }
        }
    return out;
}

}  // namespace lt

// ---- Concentration of the error ---------------------------------------------------------------

namespace lt {

std::vector<double> pixelRelMseErrors(const Image& img, const Image& ref, const CropRect* crop) {
    const CropRect r = checkInputs(img, ref, crop);
    std::vector<double> e;
    e.reserve(size_t(r.w) * size_t(r.h));
    for (int y = r.y; y < r.y + r.h; ++y)
        for (int x = r.x; x < r.x + r.w; ++x) {
            const Color& ca = img.at(x, y);
            const Color& cb = ref.at(x, y);
            e.push_back(relMseTerm(ca.x, cb.x) + relMseTerm(ca.y, cb.y) + relMseTerm(ca.z, cb.z));
        }
    return e;
}

size_t topPixelCount(size_t n, double fraction) {
    if (!(fraction > 0.0 && fraction <= 1.0))
        throw std::invalid_argument("top fraction must be in (0, 1], got " + fmtValue(float(fraction)));
    const double x = fraction * double(n), whole = std::round(x);
    const double k = std::abs(x - whole) <= 1e-9 * std::max(1.0, x) ? whole : std::ceil(x);
    return std::clamp<size_t>(size_t(k), std::min<size_t>(n, 1), n);
}

double topShare(std::vector<double> errors, double fraction) {
    const size_t k = topPixelCount(errors.size(), fraction);
    double total = 0;
    for (double e : errors) total += e;
    if (total == 0.0) return 0.0;
    std::nth_element(errors.begin(), errors.begin() + std::ptrdiff_t(k) - 1, errors.end(), std::greater<>());
    double top = 0;
    for (size_t i = 0; i < k; ++i) top += errors[i];
    return top / total;
}

double relMseTopShare(const Image& img, const Image& ref, double fraction, const CropRect* crop) {
    return topShare(pixelRelMseErrors(img, ref, crop), fraction);
}

std::vector<size_t> worstIndices(const std::vector<double>& errors, size_t k) {
    k = std::min(k, errors.size());
    std::vector<size_t> idx(errors.size());
    for (size_t i = 0; i < idx.size(); ++i) idx[i] = i;
    std::partial_sort(idx.begin(), idx.begin() + std::ptrdiff_t(k), idx.end(),
                      [&](size_t a, size_t b) { return errors[a] != errors[b] ? errors[a] > errors[b] : a < b; });
    idx.resize(k);
    return idx;
}

// ---- Technique attribution --------------------------------------------------------------------

std::string StrategyId::name() const {
    return merge ? "merge_s" + std::to_string(s) : "s" + std::to_string(s) + "_t" + std::to_string(t);
}

namespace {

// Reads a non-negative decimal without sign or leading zeros from the front of v.
std::optional<int> takeNumber(std::string_view& v) {
    size_t n = 0;
    while (n < v.size() && n < 6 && std::isdigit((unsigned char)v[n])) ++n;
    if (n == 0 || (n > 1 && v[0] == '0')) return std::nullopt;
    int x = 0;
    for (size_t i = 0; i < n; ++i) x = x * 10 + (v[i] - '0');
    v.remove_prefix(n);
    return x;
}

bool takePrefix(std::string_view& v, std::string_view p) {
    if (v.substr(0, p.size()) != p) return false;
    v.remove_prefix(p.size());
    return true;
}

// Sums `value(strategy image, pixel)` into one TechniqueShare per strategy, with shares, largest
// first, zeros dropped.
std::vector<TechniqueShare> rankTechniques(const std::vector<StrategyImage>& strategies, const std::vector<double>& values) {
    double total = 0;
    for (double v : values) total += v;
    std::vector<TechniqueShare> out;
    for (size_t i = 0; i < strategies.size(); ++i)
        if (values[i] != 0.0) out.push_back({strategies[i].id.name(), values[i], total != 0.0 ? values[i] / total : 0.0});
    std::stable_sort(out.begin(), out.end(), [](const TechniqueShare& a, const TechniqueShare& b) { return a.value > b.value; });
    return out;
}

}  // namespace

std::optional<StrategyId> parseStrategyFileName(std::string_view v) {
    if (!v.ends_with(".exr")) return std::nullopt;
    v.remove_suffix(4);
    StrategyId id;
    id.merge = takePrefix(v, "merge_");
    if (!takePrefix(v, "s")) return std::nullopt;
    auto s = takeNumber(v);
    if (!s) return std::nullopt;
    id.s = *s;
    if (!id.merge) {
        if (!takePrefix(v, "_t")) return std::nullopt;
        auto t = takeNumber(v);
        if (!t) return std::nullopt;
        id.t = *t;
    }
    if (!v.empty()) return std::nullopt;
    return id;
}

std::vector<StrategyImage> readStrategyImages(const std::string& dir, int width, int height) {
    namespace fs = std::filesystem;
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) throw std::runtime_error(dir + ": not a directory (expected render --strategy-images output)");
    std::vector<StrategyImage> out;
    for (const auto& e : fs::directory_iterator(dir)) {
        auto id = parseStrategyFileName(e.path().filename().string());
        if (id) out.push_back({*id, e.path().string(), {}});
    }
    if (out.empty())
        throw std::runtime_error(dir + ": no strategy images (s{s}_t{t}.exr, merge_s{s}.exr, as written by render --strategy-images)");
    std::sort(out.begin(), out.end(), [](const StrategyImage& a, const StrategyImage& b) { return a.id < b.id; });
    for (StrategyImage& si : out) {
        si.image = readImage(si.path);  // ImageError: "<path>: <what>"
        if (si.image.width != width || si.image.height != height)
            throw std::runtime_error(sizeMismatch(si.path, si.image, width, height));
    }
    return out;
}

Attribution attributeWorstPixels(const Image& img, const Image& ref, const std::vector<StrategyImage>& strategies,
                                 size_t worstK, double fraction, const CropRect* crop) {
    const CropRect r = checkInputs(img, ref, crop);
    for (const StrategyImage& si : strategies) {
        if (si.image.width != img.width || si.image.height != img.height || si.image.pixels.size() != img.pixels.size())
            throw std::invalid_argument(sizeMismatch(si.path, si.image, img.width, img.height));
        if (auto p = findNonFinite(si.image, &r))
            throw std::invalid_argument(si.path + ": non-finite value at pixel (" + std::to_string(p->first) + ", " +
                                        std::to_string(p->second) + ")");
    }
    const std::vector<double> errors = pixelRelMseErrors(img, ref, &r);
    auto position = [&](size_t i) { return std::pair{r.x + int(i % size_t(r.w)), r.y + int(i / size_t(r.w))}; };
    // Per-technique channel means summed over a set of pixels.
    auto techniqueValues = [&](const std::vector<size_t>& pixels) {
        std::vector<double> v(strategies.size(), 0.0);
        for (size_t j = 0; j < strategies.size(); ++j)
            for (size_t i : pixels) {
                auto [x, y] = position(i);
                v[j] += channelMean(strategies[j].image.at(x, y));
            }
        return v;
    };

    Attribution out;
    for (size_t i : worstIndices(errors, worstK)) {
        PixelAttribution p;
        std::tie(p.x, p.y) = position(i);
        p.error = errors[i];
        p.image = channelMean(img.at(p.x, p.y));
        p.reference = channelMean(ref.at(p.x, p.y));
        std::vector<double> v = techniqueValues({i});
        for (double x : v) p.strategies += x;
        p.techniques = rankTechniques(strategies, v);
        out.worst.push_back(std::move(p));
    }
    out.topPixels = topPixelCount(errors.size(), fraction);
    out.topTechniques = rankTechniques(strategies, techniqueValues(worstIndices(errors, out.topPixels)));

    double diff = 0, norm = 0;
    for (int y = r.y; y < r.y + r.h; ++y)
        for (int x = r.x; x < r.x + r.w; ++x) {
            double s = 0;
            for (const StrategyImage& si : strategies) s += channelMean(si.image.at(x, y));
            const double a = channelMean(img.at(x, y));
            diff += std::abs(s - a);
            norm += std::abs(a);
        }
    out.strategySumRelDiff = norm > 0 ? diff / norm : (diff > 0 ? 1.0 : 0.0);
    return out;
}

}  // namespace lt
