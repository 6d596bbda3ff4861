#include "bsdf/roughness_bound.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace lt {

namespace {

constexpr double kPiD = 3.14159265358979323846;
constexpr double kSqrtPiD = 1.77245385090551602730;

// sup over m of D(m) for an isotropic alpha.
double dMax(MicrofacetType type, double a) {
    const double a2 = a * a;
    if (type == MicrofacetType::GGX) return a <= 1.0 ? 1.0 / (kPiD * a2) : a2 / kPiD;
    if (a2 <= 0.5) return 1.0 / (kPiD * a2);
    return 4.0 * a2 * std::exp(1.0 / a2 - 2.0) / kPiD;  // at tan^2 = 2 alpha^2 - 1
}

// G_bar: sup of G2 / (|cos_o| |cos_i|) (Smith, separable) or 1 (V-cavity, see header).
double gBar(MicrofacetType type, MaskingModel masking, double a) {
    if (masking == MaskingModel::VCavity) return 1.0;
    double g1;  // sup_w G1(w) / |cos w|
    if (type == MicrofacetType::GGX) g1 = 2.0 / std::min(a, 2.0);
    else g1 = a <= 3.0 ? 2.0 * kSqrtPiD / a : std::max(2.0 * kSqrtPiD / a, 1.02);
    return g1 * g1;
}

// The alpha-independent factor: 1/4 for reflection, max(1,eta)^2/(1-eta)^2 for refraction.
double lobeFactor(bool transmission, double eta) {
    if (!transmission) return 0.25;
    const double d = 1.0 - eta;
    return std::max(1.0, eta * eta) / (d * d);
}

double bound(MicrofacetType type, MaskingModel masking, double a, bool transmission, double eta) {
    return lobeFactor(transmission, eta) * dMax(type, a) * gBar(type, masking, a);
}

// The tight form (header): margin * c D_max max(1, G), G the grazing branch's height over D_max,
// where it differs from the published one: Smith refraction with alpha <= 1 (Beckmann: eta or
// 1 / eta <= 4, the table's range).
constexpr double kTightMargin = 1.001;
bool tightDiffers(MicrofacetType type, MaskingModel masking, bool transmission, double eta) {
    if (!transmission || masking != MaskingModel::Smith) return false;
    return type == MicrofacetType::GGX || std::max(eta, 1.0 / eta) <= 4.0;
}

// Beckmann G over x = (alpha^2 - 0.01) / 0.99 in [0, 1] (rows) and y = (r / 0.6)^(3/4),
// r = (eta' - 1) / (eta' + 1) in [0, 0.6] for eta' = max(eta, 1 / eta) in [1, 4] (columns; denser
// towards eta' = 1, where G varies fastest); bilinear. Every node was raised until the interpolant
// is >= G at 33 x 33 samples of each cell where G >= 0.98, then rounded up; kTightMargin covers
// the rest (a check at 3 10^5 further points found none below G). Below alpha 0.1, G < 1 (header).
constexpr int kRows = 8, kCols = 7;
constexpr double kRowAlpha0 = 0.1;
constexpr float kBeckmannG[kRows][kCols] = {
    {0.0682f, 0.1385f, 0.2781f, 0.4359f, 0.6063f, 0.7909f, 0.9802f},  // alpha 0.1
    {1.0347f, 0.9339f, 0.9291f, 1.0036f, 1.1176f, 1.2575f, 1.3997f},  // alpha 0.389
    {2.0033f, 1.8694f, 1.7766f, 1.7587f, 1.7849f, 1.8411f, 1.9174f},  // alpha 0.541
    {2.9701f, 2.8225f, 2.6846f, 2.6137f, 2.5818f, 2.5774f, 2.5930f},  // alpha 0.659
    {3.9354f, 3.7804f, 3.6152f, 3.5113f, 3.4420f, 3.3976f, 3.3714f},  // alpha 0.759
    {4.8998f, 4.7401f, 4.5567f, 4.4304f, 4.3353f, 4.2635f, 4.2088f},  // alpha 0.847
    {5.8635f, 5.7007f, 5.5044f, 5.3617f, 5.2480f, 5.1564f, 5.0812f},  // alpha 0.927
    {6.8154f, 6.6505f, 6.4557f, 6.3007f, 6.1728f, 6.0663f, 5.9760f},  // alpha 1
};
// alpha^2 of row i.
double rowAlpha2(int i) {
    const double a02 = kRowAlpha0 * kRowAlpha0;
    return a02 + (1.0 - a02) * i / (kRows - 1);
}
// The table's column coordinate y (scaled to [0, kCols - 1]) of eta.
double columnOf(double eta) {
    const double e = std::max(eta, 1.0 / eta), r = (e - 1.0) / (e + 1.0);
    return std::min(std::pow(r / 0.6, 0.75), 1.0) * (kCols - 1);
}
// Row i of the table at column coordinate y (linear).
double rowAt(int i, double y) {
    const int j = std::min(int(y), kCols - 2);
    const double s = y - j;
    return (1.0 - s) * kBeckmannG[i][j] + s * kBeckmannG[i][j + 1];
}
// G(alpha, eta): 4 alpha^2 (GGX), the table (Beckmann; 0 below its first row, where G < 1).
double grazingBranch(MicrofacetType type, double a, double eta) {
    if (type == MicrofacetType::GGX) return 4.0 * a * a;
    if (a < kRowAlpha0) return 0.0;
    const double x = (a * a - rowAlpha2(0)) / (1.0 - rowAlpha2(0)) * (kRows - 1), y = columnOf(eta);
    const int i = std::min(int(x), kRows - 2);
    const double t = x - i;
    return (1.0 - t) * rowAt(i, y) + t * rowAt(i + 1, y);
}

double boundTight(MicrofacetType type, MaskingModel masking, double a, bool transmission, double eta) {
    const double published = bound(type, masking, a, transmission, eta);
    if (!tightDiffers(type, masking, transmission, eta) || a > 1.0) return published;
    // (never above the published bound, which is a bound too)
    const double g = std::max(1.0, grazingBranch(type, a, eta));
    return std::min(kTightMargin * lobeFactor(true, eta) * g / (kPiD * a * a), published);
}

// alpha_hat for the tight form where it differs: the least alpha with rho_bar(alpha') <= tau for
// every alpha' in [alpha, 1]. rho_bar <= tau <=> max(1, G(alpha)) <= k alpha^2, k = pi tau /
// (margin c). GGX (G = 4 alpha^2): alpha^2 >= 1 / k once alpha = 1 meets tau. Beckmann: G is
// linear in alpha^2 between two rows, so each interval's least alpha is closed-form; walk them
// down from alpha = 1.
double alphaTight(MicrofacetType type, double tau, double eta) {
    const double k = kPiD * tau / (kTightMargin * lobeFactor(true, eta));
    if (!(std::max(1.0, grazingBranch(type, 1.0, eta)) <= k)) return 1.0;
    const double lo2 = 1.0 / k;  // alpha^2 >= 1 / k: the normal-incidence branch
    if (type == MicrofacetType::Beckmann) {
        const double y = columnOf(eta);
        for (int i = kRows - 2; i >= 0; --i) {
            // G = p + q alpha^2 on [alpha_i, alpha_i+1], whose upper end meets tau: where k > q,
            // (k - q) alpha^2 >= p bounds alpha from below; else it holds on the whole interval.
            const double x0 = rowAlpha2(i), x1 = rowAlpha2(i + 1), g0 = rowAt(i, y), g1 = rowAt(i + 1, y);
            const double q = (g1 - g0) / (x1 - x0), p = g0 - q * x0;
            const double need = std::max(lo2, k > q ? p / (k - q) : 0.0);
            if (need > x0) return std::sqrt(need);
        }
    }
    return std::sqrt(lo2);
}

}  // namespace

float maxValueBound(MicrofacetType type, MaskingModel masking, float alpha, bool transmission, float eta,
                    BoundForm form) {
    if (!(alpha > 0.f) || (transmission && eta == 1.f)) return kInf;
    if (form == BoundForm::Tight) return float(boundTight(type, masking, alpha, transmission, eta));
    return float(bound(type, masking, alpha, transmission, eta));
}

float alphaForBound(MicrofacetType type, MaskingModel masking, float tau, bool transmission, float eta,
                    BoundForm form) {
    if (transmission && eta == 1.f) return 1.f;
    if (!(tau > 0.f)) return 1.f;
    if (std::isinf(tau)) return 0.f;
    const double c = lobeFactor(transmission, eta);
    const double t = tau;
    if (form == BoundForm::Tight && tightDiffers(type, masking, transmission, eta))
        return float(alphaTight(type, t, eta));
    // Closed form of the paper's branch, D_max = 1/(pi alpha^2):
    //   Smith: rho = c K / (pi alpha^4), K = 4 (GGX), 4 pi (Beckmann); V-cavity: c / (pi alpha^2).
    double a;
    if (masking == MaskingModel::VCavity) {
        a = std::sqrt(c / (kPiD * t));
    } else {
        const double k = type == MicrofacetType::GGX ? 4.0 : 4.0 * kPiD;
        a = std::sqrt(std::sqrt(c * k / (kPiD * t)));
    }
    const double aBranch = type == MicrofacetType::GGX ? 1.0 : std::sqrt(0.5);
    if (a <= aBranch) return float(a);
    // Beyond the branch (Beckmann alpha in (1/sqrt 2, 1]): rho_bar strictly decreasing, bisect.
    if (t <= bound(type, masking, 1.0, transmission, eta)) return 1.f;
    double lo = std::log(aBranch), hi = 0.0;  // log alpha
    for (int i = 0; i < 100 && hi - lo > 1e-12; ++i) {
        const double mid = 0.5 * (lo + hi);
        if (bound(type, masking, std::exp(mid), transmission, eta) > t) lo = mid; else hi = mid;
    }
    return float(std::exp(0.5 * (lo + hi)));
}

double consistentTau(double tau0, uint64_t n) {
    if (n == 0) throw std::invalid_argument("consistentTau: the iteration index n starts at 1");
    if (!(tau0 > kMinTau))
        throw std::invalid_argument("consistentTau: tau0 must exceed 1/(2 pi) = 0.159, got " + std::to_string(tau0));
    if (std::isinf(tau0)) return std::numeric_limits<double>::infinity();
    const double k = 2.0 * kPiD * tau0 - 1.0;
    const double x2 = (4.0 * kPiD * tau0 - 1.0) / k / k;  // (not / (k * k): no overflow for huge tau0)
    const double y2 = x2 / std::cbrt(double(n));  // (x n^(-1/6))^2
    const double s = std::sqrt(1.0 + y2);
    return s * (1.0 + s) / (2.0 * kPiD * y2);
}

}  // namespace lt
