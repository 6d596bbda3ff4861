// Statistics for render-comparison tests: Student-t quantiles, Sidak correction, region means.
#pragma once
#include <cmath>
#include <vector>
#include "core/image.h"

namespace lt::test {

// Two-sided critical value of Student's t with `df` degrees of freedom at significance alpha.
// The CDF is integrated numerically (Simpson) and inverted by bisection: slow but exact enough.
inline double studentTCritical(double alpha, double df) {
    auto pdf = [df](double x) {
        return std::exp(std::lgamma((df + 1) / 2) - std::lgamma(df / 2)) / std::sqrt(df * M_PI) *
               std::pow(1 + x * x / df, -(df + 1) / 2);
    };
    auto tail = [&](double x) {  // P(T > x) = 1/2 - int_0^x pdf
        const int n = 2000;
        double h = x / n, s = pdf(0) + pdf(x);
        for (int i = 1; i < n; ++i) s += pdf(i * h) * (i % 2 ? 4 : 2);
        return 0.5 - s * h / 3;
    };
    double lo = 0, hi = 100;
    for (int it = 0; it < 80; ++it) {
        double mid = 0.5 * (lo + hi);
        if (2 * tail(mid) > alpha) lo = mid; else hi = mid;
    }
    return 0.5 * (lo + hi);
}

// Per-test significance so that m independent tests have family-wise significance alpha.
inline double sidak(double alpha, int m) { return 1.0 - std::pow(1.0 - alpha, 1.0 / m); }

// Mean luminance-free (channel-averaged) value of each block of an image.
inline std::vector<double> blockMeans(const Image& img, int blocksX, int blocksY) {
    std::vector<double> m(size_t(blocksX) * blocksY, 0.0);
    std::vector<int> n(m.size(), 0);
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            size_t b = size_t(y * blocksY / img.height) * blocksX + size_t(x * blocksX / img.width);
            const Color& c = img.at(x, y);
            m[b] += (double(c.x) + c.y + c.z) / 3.0;
            n[b]++;
        }
    for (size_t i = 0; i < m.size(); ++i) m[i] /= std::max(n[i], 1);
    return m;
}

struct SampleStats {
    double mean = 0, var = 0;  // var = sample variance of the K values
    int k = 0;
};
inline SampleStats sampleStats(const std::vector<double>& v) {
    SampleStats s;
    s.k = int(v.size());
    for (double x : v) s.mean += x;
    s.mean /= s.k;
    for (double x : v) s.var += (x - s.mean) * (x - s.mean);
    s.var /= std::max(s.k - 1, 1);
    return s;
}

// Welch's t statistic and degrees of freedom for two sets of independent estimates.
inline double welchT(const SampleStats& a, const SampleStats& b, double& df) {
    double va = a.var / a.k, vb = b.var / b.k;
    double se2 = va + vb;
    df = se2 * se2 / (va * va / (a.k - 1) + vb * vb / (b.k - 1) + 1e-300);
    return se2 > 0 ? (a.mean - b.mean) / std::sqrt(se2) : (a.mean == b.mean ? 0.0 : INFINITY);
}

}  // namespace lt::test
