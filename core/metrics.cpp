#include "core/metrics.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace lt {

namespace {

std::string sizeStr(const Image& im) { return std::to_string(im.width) + "x" + std::to_string(im.height); }

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

ErrorMetrics computeMetrics(const Image& img, const Image& ref, const CropRect* crop) {
    const CropRect r = checkInputs(img, ref, crop);
    // Per-row partial sums keep the double accumulation accurate for large images.
    double sumA = 0, sumB = 0, sumSq = 0, sumRel = 0, sumRe = 0, sumApe = 0;
    for (int y = r.y; y < r.y + r.h; ++y) {
        double rowA = 0, rowB = 0, rowSq = 0, rowRel = 0, rowRe = 0, rowApe = 0;
        for (int x = r.x; x < r.x + r.w; ++x) {
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
    m.pixels = size_t(r.w) * size_t(r.h);
    const double n = 3.0 * double(m.pixels);
    m.meanImage = sumA / n;
    m.meanReference = sumB / n;
    m.mse = sumSq / n;
    m.relMse = sumRel / n;
    m.rmsRelErr = std::sqrt(sumRe / n);
    m.mape = sumApe / n;
    return m;
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
