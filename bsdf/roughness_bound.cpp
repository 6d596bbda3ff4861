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

// The tight form differs from the published one only for GGX/Smith refraction with alpha <= 1
// (header): c / pi max(1 / alpha^2, 4), with the upward margin kTightMargin.
constexpr double kTightMargin = 1.001;
bool tightDiffers(MicrofacetType type, MaskingModel masking, bool transmission) {
    return transmission && masking == MaskingModel::Smith && type == MicrofacetType::GGX;
}
double boundTight(MicrofacetType type, MaskingModel masking, double a, bool transmission, double eta) {
    if (!tightDiffers(type, masking, transmission) || a > 1.0) return bound(type, masking, a, transmission, eta);
    // (never above the published bound, which is a bound too and meets it at alpha = 1)
    return std::min(kTightMargin * lobeFactor(true, eta) / kPiD * std::max(1.0 / (a * a), 4.0),
                    bound(type, masking, a, transmission, eta));
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
    if (form == BoundForm::Tight && tightDiffers(type, masking, transmission)) {
        // c / pi max(1 / alpha^2, 4) (times the margin) <= tau: the first branch's inverse, where
        // it is at most 1/2; beyond, the bound is constant (the grazing pairs) and above tau.
        const double a = std::sqrt(kTightMargin * c / (kPiD * t));
        return a <= 0.5 ? float(a) : 1.f;
    }
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
