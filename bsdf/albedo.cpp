// Directional albedos of the Fresnel-free microfacet lobes (albedo.h): the numerical integral and
// the table look-up.
#include "bsdf/albedo.h"

#include <cmath>
#include <vector>

#include "bsdf/fresnel.h"
#include "bsdf/microfacet.h"

namespace lt {

// ---- Numerical integration ----------------------------------------------------------------------
//
// E = integral over u in [0,1)^2 of G2 / G1(wo, m) at m = sampleVisible(wo, u) (albedo.h). The
// integral over u is taken on an n x n grid of cell centres in s, u = P(s) per coordinate with the
// quintic P(s) = s^3 (10 - 15 s + 6 s^2) and weight P'(s) = 30 s^2 (1 - s)^2 (a polynomial
// "periodising" change of variables, Sidi 1993): the cells shrink towards u = 0 and 1, where the
// visible-normal maps put their tails (GGX's heavy tail of normals at u.x -> 1 holds the grazing
// reflections of a smooth lobe: with plain cell centres it falls into one or two cells and the
// estimate of a 0.5% loss jumps by 0.1% from one n to the next). The weights are normalised to sum
// to 1, so a constant integrand is exact.
//
// V-cavity: sampleVisible draws m ~ D(m) m.z and keeps it or swaps it for its groove partner m'
// with probability q = <wo,m'>+ / (<wo,m>+ + <wo,m'>+), using the third uniform uExtra. Instead of
// stratifying uExtra, the choice is integrated exactly: both outcomes of one u (uExtra = 0 gives m'
// whenever q > 0, uExtra -> 1 gives m whenever q < 1) with weights q and 1 - q.
//
// The refraction integrand jumps to 0 across the curve in u where refraction about m stops
// existing (total internal reflection, eta < 1 or GGX's tilted normals); everything else is
// continuous (G1(wi) -> 0 as wi grazes the surface). A cell whose total-internal-reflection state
// differs from one of its 4 neighbours' is therefore integrated on a kRefine x kRefine sub-grid,
// which turns the O(n^-1.5) error of a jump into that of a grid kRefine times finer.

namespace albedo_detail {

namespace {

constexpr float kOneMinusEps = 0x1.fffffep-1f;
constexpr int kRefine = 4;

double warp(double s) { return s * s * s * (10.0 + s * (-15.0 + 6.0 * s)); }
double warpDeriv(double s) { return 30.0 * s * s * (1.0 - s) * (1.0 - s); }

// One visible normal of a quadrature point: m, G1(wo, m), and the weight of this outcome.
struct Normal {
    Vec3 m{0.f, 0.f, 1.f};
    float g1 = 0.f;
    double w = 0.0;
};

// The (one or two) visible normals of the quadrature point s (pre-warp), each weighted by w times
// its probability. Returns how many were written.
int pointNormals(const Microfacet& mf, const Vec3& wo, double s0, double s1, double w, Normal out[2]) {
    const Vec2 u(float(warp(s0)), float(warp(s1)));
    if (mf.masking() == MaskingModel::Smith) {
        float e = 0.5f;  // (unused by Smith)
        out[0].m = mf.sampleVisible(wo, u, e);
        out[0].g1 = mf.G1(wo, out[0].m);
        out[0].w = w;
        return 1;
    }
    float e0 = 0.f, e1 = kOneMinusEps;
    const Vec3 mA = mf.sampleVisible(wo, u, e0), mB = mf.sampleVisible(wo, u, e1);
    const float b = std::max(0.f, glm::dot(wo, mA)), a = std::max(0.f, glm::dot(wo, mB));
    const double q = a + b > 0.f ? double(b) / (double(a) + double(b)) : 0.0;
    out[0] = {mA, mf.G1(wo, mA), w * q};
    out[1] = {mB, mf.G1(wo, mB), w * (1.0 - q)};
    return 2;
}

double reflectValue(const Microfacet& mf, const Vec3& wo, const Normal& n) {
    if (!(n.g1 > 0.f)) return 0.0;
    const Vec3 wi = reflectAbout(wo, n.m);
    if (!(wi.z > 0.f)) return 0.0;
    return double(mf.G2(wo, wi, n.g1, mf.G1(wi, n.m))) / n.g1;
}

// The refraction estimator; tir is set where refraction about m does not exist.
double refractValue(const Microfacet& mf, const Vec3& wo, const Normal& n, float eta, bool& tir) {
    Vec3 wi;
    tir = !refractAbout(wo, n.m, eta, wi);
    if (tir || !(n.g1 > 0.f) || !(wi.z < 0.f)) return 0.0;
    return double(mf.G2(wo, wi, n.g1, mf.G1(wi, n.m))) / n.g1;
}

}  // namespace


// ---- Grids ----------------------------------------------------------------------------------------
//
// y (alpha): uniform in sqrt(alpha) over [kMinAlpha, 1].
// x (mu, given alpha): half uniform in the polar angle theta_o (dense towards normal incidence,
//   where sin theta_o, the critical eta below, moves fast), half atan(mu / alpha), which packs
//   nodes into the grazing layer mu ~ alpha where the masking of wo and of its mirror direction
//   sets in; both parts normalised to [0, 1] over [kAlbedoMuMin, 1].
// z (eta, given mu and alpha): z = 1/2 + atan((ln eta - lambda ln c) / w) / pi, with
//   c = max(sin theta_o, 0.3), w = min(wRaw, 0.5), wRaw = alpha (mu + alpha / 2) / c and
//   lambda = 1 / (1 + (wRaw / 0.3)^2). For eta < 1 the refraction of a smooth lobe stops at the
//   critical eta = sin theta_o, and the step of E_T there is about as wide (in ln eta) as wRaw,
//   the spread of the normals (alpha cos theta_o; alpha^2 at grazing). For a narrow step
//   (lambda -> 1) the nodes follow it, so that E_T is nearly the same function of z at the
//   corners of a cell (whose mu and alpha differ); a broad step (large alpha) is left where it
//   is (lambda -> 0): E_T is then smooth in ln eta, and centring would move the nodes of
//   neighbouring mu far apart. Nodes beyond [1/3, 3] are kept (eta clamped to [1/30, 30]).
// A look-up computes (x, y, z) from its own (mu, alpha, eta), so the table is a regular grid in
// (x, y, z); node (i, j, k) holds E at alpha_j = alphaOfY(y_j), mu = muOfX(x_i, alpha_j),
// eta = etaOfZ(z_k, mu, alpha_j).

namespace {
constexpr double kBetaX = 0.5, kKappaX = 1.0;
constexpr double kKappaZ = 1.0, kCMin = 0.3, kWMax = 0.5, kW0 = 0.3;
constexpr double kEtaNodeMin = 1.0 / 30.0, kEtaNodeMax = 30.0;
constexpr double kPiD = 3.14159265358979323846;

double sqrtAlphaMin() { return std::sqrt(double(kMinAlpha)); }

// Bisection of a monotone increasing f on [lo, hi] for f(t) = target.
template <class F>
double invert(const F& f, double target, double lo, double hi) {
    for (int it = 0; it < 80; ++it) {
        const double mid = 0.5 * (lo + hi);
        (f(mid) < target ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}
}  // namespace

double yOfAlpha(double alpha) {
    const double a = std::clamp(alpha, double(kMinAlpha), 1.0);
    return (std::sqrt(a) - sqrtAlphaMin()) / (1.0 - sqrtAlphaMin());
}
double alphaOfY(double y) {
    const double r = sqrtAlphaMin() + std::clamp(y, 0.0, 1.0) * (1.0 - sqrtAlphaMin());
    return r * r;
}

double xOfMu(double mu, double alpha) {
    const double m0 = kAlbedoMuMin, m = std::clamp(mu, m0, 1.0);
    const double a = std::clamp(alpha, double(kMinAlpha), 1.0), w = kKappaX * a;
    const double lin = (std::acos(m0) - std::acos(m)) / std::acos(m0);
    const double t0 = std::atan(m0 / w);
    const double at = (std::atan(m / w) - t0) / (std::atan(1.0 / w) - t0);
    return std::clamp((1.0 - kBetaX) * lin + kBetaX * at, 0.0, 1.0);
}
double muOfX(double x, double alpha) {
    return invert([&](double m) { return xOfMu(m, alpha); }, std::clamp(x, 0.0, 1.0), kAlbedoMuMin, 1.0);
}

// The centre c and log-width of the z map at (mu, alpha).
void zMap(double mu, double alpha, double& c, double& w, double& lambda) {
    const double m = std::clamp(mu, double(kAlbedoMuMin), 1.0);
    const double a = std::clamp(alpha, double(kMinAlpha), 1.0);
    c = std::max(std::sqrt(1.0 - m * m), kCMin);
    const double wRaw = kKappaZ * a * (m + 0.5 * a) / c;
    w = std::min(wRaw, kWMax);
    lambda = 1.0 / (1.0 + (wRaw / kW0) * (wRaw / kW0));
}
double zOfEta(double eta, double mu, double alpha) {
    double c, w, lambda;
    zMap(mu, alpha, c, w, lambda);
    const double e = std::clamp(eta, double(kAlbedoEtaMin), double(kAlbedoEtaMax));
    return 0.5 + std::atan((std::log(e) - lambda * std::log(c)) / w) / kPiD;
}
double etaOfZ(double z, double mu, double alpha) {
    double c, w, lambda;
    zMap(mu, alpha, c, w, lambda);
    const double t = std::clamp(z, 0.0, 1.0) - 0.5;
    const double s = std::abs(t) < 0.5 ? std::tan(kPiD * t) : (t > 0 ? 1e30 : -1e30);
    return std::clamp(std::exp(lambda * std::log(c) + std::clamp(w * s, -20.0, 20.0)), kEtaNodeMin, kEtaNodeMax);
}

const char* gridDescription() {
    return "y = (sqrt(alpha) - 0.01) / 0.99, alpha in [1e-4, 1];\n"
           "x = 0.5 (acos(mu0) - acos(mu)) / acos(mu0) + 0.5 (atan(mu / alpha) - atan(mu0 / alpha)) / "
           "(atan(1 / alpha) - atan(mu0 / alpha)), mu in [mu0, 1], mu0 = 1e-3;\n"
           "z = 1/2 + atan((ln eta - lambda ln c) / w) / pi, c = max(sqrt(1 - mu^2), 0.3), w = min(wRaw, 0.5),\n"
           "    wRaw = alpha (mu + alpha / 2) / c, lambda = 1 / (1 + (wRaw / 0.3)^2), eta in [1/3, 3]";
}

Vec3 albedoDirection(double mu) {
    mu = std::clamp(mu, 1e-6, 1.0);
    return Vec3(float(std::sqrt(std::max(0.0, 1.0 - mu * mu))), 0.f, float(mu));
}

void albedoIntegrals(MicrofacetType type, MaskingModel masking, double mu, double alpha, int n, const double* etas,
                     int nEta, double* reflection, double* transmission) {
    n = std::max(n, 1);
    const Microfacet mf(type, float(alpha), float(alpha), masking);
    const Vec3 wo = albedoDirection(mu);
    const int k = masking == MaskingModel::Smith ? 1 : 2;
    const double h = 1.0 / n;
    std::vector<Normal> normals(size_t(n) * n * 2);
    std::vector<double> cellW(size_t(n) * n);
    double wSum = 0.0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const double s0 = (i + 0.5) * h, s1 = (j + 0.5) * h;
            const double w = warpDeriv(s0) * warpDeriv(s1);
            cellW[size_t(i) * n + j] = w;
            wSum += w;
            pointNormals(mf, wo, s0, s1, w, &normals[(size_t(i) * n + j) * 2]);
        }
    if (reflection) {
        double sum = 0.0;
        for (size_t c = 0; c < cellW.size(); ++c)
            for (int l = 0; l < k; ++l) sum += normals[c * 2 + l].w * reflectValue(mf, wo, normals[c * 2 + l]);
        *reflection = sum / wSum;
    }
    std::vector<double> value(cellW.size());
    std::vector<uint8_t> tirMask(cellW.size());
    for (int e = 0; e < nEta; ++e) {
        const float eta = float(etas[e]);
        for (size_t c = 0; c < cellW.size(); ++c) {
            double v = 0.0;
            uint8_t mask = 0;
            for (int l = 0; l < k; ++l) {
                bool tir;
                const double x = refractValue(mf, wo, normals[c * 2 + l], eta, tir);
                v += normals[c * 2 + l].w * x;
                mask |= uint8_t((tir ? 1 : 0) | (x == 0.0 ? 2 : 0)) << (2 * l);
            }
            value[c] = v;
            tirMask[c] = mask;
        }
        double sum = 0.0;
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) {
                const size_t c = size_t(i) * n + j;
                const uint8_t t = tirMask[c];
                const bool edge = (i > 0 && tirMask[c - n] != t) || (i + 1 < n && tirMask[c + n] != t) ||
                                  (j > 0 && tirMask[c - 1] != t) || (j + 1 < n && tirMask[c + 1] != t);
                if (!edge) {
                    sum += value[c];
                    continue;
                }
                // Sub-grid of the cell, each point weighted by its own P'(s0) P'(s1) / kRefine^2.
                double sub = 0.0;
                for (int a = 0; a < kRefine; ++a)
                    for (int b = 0; b < kRefine; ++b) {
                        const double s0 = (i + (a + 0.5) / kRefine) * h, s1 = (j + (b + 0.5) / kRefine) * h;
                        Normal pts[2];
                        const int np = pointNormals(mf, wo, s0, s1, warpDeriv(s0) * warpDeriv(s1), pts);
                        for (int l = 0; l < np; ++l) {
                            bool tir;
                            sub += pts[l].w * refractValue(mf, wo, pts[l], eta, tir);
                        }
                    }
                sum += sub / (kRefine * kRefine);
            }
        transmission[e] = sum / wSum;
    }
}

}  // namespace albedo_detail


// ---- Interpolation error ----------------------------------------------------------------------------
//
// Measured against fresh integrals (n = kAlbedoTableN) at random off-grid points, 200 per model
// and kind; tolerance = max(0.3% E, 0.001):
// * E_R, mu >= 0.1: within the tolerance everywhere (worst 0.58 of it, 0.0017 absolute).
//   mu < 0.1: worst 0.027 absolute (GGX Smith, mu ~ 1e-3 with alpha ~ 2e-3); the other models
//   0.004.
// * E_T, mu >= 0.1, eta log-uniform: median 0.0002 absolute, 95th percentile 0.0016 - 0.0028
//   (1 - 2.7 times the tolerance), worst 0.01 - 0.058 absolute. Near the critical eta of eta < 1
//   (|eta - sin theta_o| < 3 alpha (mu + alpha / 2)): 95th percentile 0.003 - 0.009, worst
//   0.026 - 0.11 (the steep step of a nearly smooth lobe). mu < 0.1: worst 0.008 - 0.065.
//   The 0.3% target is not met for E_T with trilinear interpolation at this table size.

// ---- Look-up --------------------------------------------------------------------------------------

namespace {

#include "bsdf/albedo_tables.inc"

int modelIndex(MicrofacetType type, MaskingModel masking) { return 2 * int(type) + int(masking); }

// Cell index and fraction of a coordinate t in [0, 1] on n uniform nodes.
void cell(double t, int n, int& i, double& f) {
    const double p = std::clamp(t, 0.0, 1.0) * (n - 1);
    i = std::min(int(p), n - 2);
    f = p - i;
}

}  // namespace

int albedo_detail::tableIntegrationN() { return kAlbedoTableGeneratedN; }

float reflectionAlbedo(MicrofacetType type, MaskingModel masking, float mu, float alpha) {
    using namespace albedo_detail;
    const double a = std::clamp(double(alpha), double(kMinAlpha), 1.0);
    int i, j;
    double fx, fy;
    cell(xOfMu(mu, a), kNx, i, fx);
    cell(yOfAlpha(a), kNy, j, fy);
    const auto& t = kReflectionTable[modelIndex(type, masking)];
    const double v0 = (1 - fx) * t[j][i] + fx * t[j][i + 1];
    const double v1 = (1 - fx) * t[j + 1][i] + fx * t[j + 1][i + 1];
    return float((1 - fy) * v0 + fy * v1);
}

float transmissionAlbedo(MicrofacetType type, MaskingModel masking, float mu, float alpha, float eta) {
    using namespace albedo_detail;
    const double a = std::clamp(double(alpha), double(kMinAlpha), 1.0);
    int i, j, k;
    double fx, fy, fz;
    cell(xOfMu(mu, a), kNx, i, fx);
    cell(yOfAlpha(a), kNy, j, fy);
    cell(zOfEta(eta, mu, a), kNz, k, fz);
    const auto& t = kTransmissionTable[modelIndex(type, masking)];
    double v = 0.0;
    for (int dj = 0; dj < 2; ++dj)
        for (int di = 0; di < 2; ++di) {
            const float* row = t[j + dj][i + di];
            const double w = (dj ? fy : 1 - fy) * (di ? fx : 1 - fx);
            v += w * ((1 - fz) * row[k] + fz * row[k + 1]);
        }
    return float(v);
}

double reflectionAlbedoIntegral(MicrofacetType type, MaskingModel masking, double mu, double alpha, int n) {
    double r = 0.0;
    albedo_detail::albedoIntegrals(type, masking, mu, alpha, n, nullptr, 0, &r, nullptr);
    return r;
}

double transmissionAlbedoIntegral(MicrofacetType type, MaskingModel masking, double mu, double alpha, double eta,
                                  int n) {
    double t = 0.0;
    albedo_detail::albedoIntegrals(type, masking, mu, alpha, n, &eta, 1, nullptr, &t);
    return t;
}

}  // namespace lt
