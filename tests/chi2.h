// Chi-square goodness-of-fit harness for direction samplers (after Mitsuba 3's chi2 test):
//  1. draw N directions with the sampler (failed draws are counted as "lost"),
//  2. histogram them over bins of the sphere parametrised around an axis c:
//     theta' = angle to c, warped as theta'(u) = s sinh(u asinh(pi/s)), u uniform in [0,1]
//     (bins of width ~ s asinh(pi/s)/nTheta near c, growing geometrically away from it, so a
//     lobe of angular size ~s is resolved whatever s is), phi' uniform in [0, 2 pi),
//  3. integrate the claimed pdf over every bin by adaptive Gauss-Legendre quadrature (4x4 nodes
//     per cell, cells split in 4 until the refinement changes the bin's expected count by less
//     than 0.1 sqrt(max(E, 1)) (halved per level): an error that small adds about 1% of a bin's
//     expected contribution (1) to the statistic),
//  4. add one bin for the lost samples (expected N (1 - integral of the pdf)),
//  5. pool all bins with expected count < 5 into one, and compute the chi-square statistic and
//     its p-value with dof = bins - 1 (regularised upper incomplete gamma, implemented here).
// Samples falling in a bin whose pdf integral is exactly 0 fail the test outright.
// The caller compares the p-value with a significance level corrected for the number of tests
// (Sidak: 1 - (1 - alpha)^(1/m)), see sidakCorrectedLevel.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include "core/math.h"
#include "core/rng.h"

namespace lt::chi2 {

// ---- Incomplete gamma and chi-square distribution ------------------------------------------
// Regularised lower incomplete gamma P(a, x) by its power series (x < a + 1).
inline double gammaPSeries(double a, double x) {
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 100000; ++n) {
        term *= x / (a + n);
        sum += term;
        if (std::abs(term) < std::abs(sum) * 1e-16) break;
    }
    return sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
}
// Regularised upper incomplete gamma Q(a, x) by its continued fraction (modified Lentz), x >= a + 1.
inline double gammaQContinuedFraction(double a, double x) {
    const double tiny = 1e-300;
    double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
    for (int i = 1; i < 100000; ++i) {
        const double an = -i * (i - a);
        b += 2.0;
        d = an * d + b;
        if (std::abs(d) < tiny) d = tiny;
        c = b + an / c;
        if (std::abs(c) < tiny) c = tiny;
        d = 1.0 / d;
        const double del = d * c;
        h *= del;
        if (std::abs(del - 1.0) < 1e-16) break;
    }
    return std::exp(-x + a * std::log(x) - std::lgamma(a)) * h;
}
// Q(a, x) = Gamma(a, x) / Gamma(a).
inline double gammaQ(double a, double x) {
    if (x <= 0.0) return 1.0;
    if (x < a + 1.0) return 1.0 - gammaPSeries(a, x);
    return gammaQContinuedFraction(a, x);
}
// P(X >= stat) for X ~ chi-square with dof degrees of freedom.
inline double chi2SurvivalProbability(double stat, int dof) { return gammaQ(0.5 * dof, 0.5 * stat); }

// Per-test level so that m independent tests at that level have a family-wise level alpha.
inline double sidakCorrectedLevel(double alpha, int m) { return 1.0 - std::pow(1.0 - alpha, 1.0 / m); }

// ---- Sphere domain around an axis -----------------------------------------------------------
struct Domain {
    Frame frame;
    double s = 1.0, A = 1.0;
    int nTheta = 40, nPhi = 80;

    Domain(const Vec3& axis, double scale, int nt, int np)
        : frame(glm::normalize(axis)), s(std::clamp(scale, 1e-5, 10.0)), A(std::asinh(3.14159265358979323846 / s)),
          nTheta(nt), nPhi(np) {}
    double thetaOf(double u) const { return std::min(3.14159265358979323846, s * std::sinh(u * A)); }
    double uOf(double theta) const { return std::asinh(theta / s) / A; }
    double thetaEdge(int i) const { return i >= nTheta ? 3.14159265358979323846 : thetaOf(double(i) / nTheta); }
    double phiEdge(int j) const { return 2.0 * 3.14159265358979323846 * j / nPhi; }
    Vec3 direction(double theta, double phi) const {
        const double st = std::sin(theta);
        return frame.toWorld(Vec3(float(st * std::cos(phi)), float(st * std::sin(phi)), float(std::cos(theta))));
    }
    // Bin index of a direction, or -1 if not finite.
    int bin(const Vec3& w) const {
        const Vec3 l = frame.toLocal(w);
        if (!std::isfinite(l.x) || !std::isfinite(l.y) || !std::isfinite(l.z)) return -1;
        const double rxy = std::hypot(double(l.x), double(l.y));
        const double theta = std::atan2(rxy, double(l.z));
        double phi = std::atan2(double(l.y), double(l.x));
        if (phi < 0) phi += 2.0 * 3.14159265358979323846;
        int i = std::clamp(int(uOf(theta) * nTheta), 0, nTheta - 1);
        // guard against the rounding of uOf near bin edges
        while (i > 0 && theta < thetaEdge(i)) --i;
        while (i + 1 < nTheta && theta >= thetaEdge(i + 1)) ++i;
        const int j = std::clamp(int(phi / (2.0 * 3.14159265358979323846) * nPhi), 0, nPhi - 1);
        return i * nPhi + j;
    }
};

struct Result {
    double stat = 0, pValue = 0, significance = 0;
    int dof = 0, bins = 0;
    double pdfIntegral = 0;      // integral of the pdf over the sphere
    long long samples = 0, lost = 0;
    long long samplesInZeroBins = 0;
    bool passed = false;
    std::string summary() const {
        std::ostringstream o;
        o << "chi2=" << stat << " dof=" << dof << " p=" << pValue << " (level " << significance << ")"
          << " integral(pdf)=" << pdfIntegral << " lost=" << lost << "/" << samples
          << " (expected " << (1.0 - pdfIntegral) * samples << ")"
          << " samplesInZeroPdfBins=" << samplesInZeroBins;
        return o.str();
    }
};

// Axis and angular size of a set of directions (for choosing a Domain): normalised mean and
// the median angle to it.
struct LobeShape {
    Vec3 axis{0, 0, 1};
    double scale = 1.0;
    size_t count = 0;
};
inline LobeShape lobeShape(const std::vector<Vec3>& dirs, const Vec3& fallbackAxis) {
    LobeShape r;
    r.count = dirs.size();
    glm::dvec3 mean(0.0);
    for (const Vec3& d : dirs) mean += glm::dvec3(d);
    r.axis = glm::length(mean) > 1e-6 * std::max<size_t>(1, dirs.size()) ? Vec3(glm::normalize(mean))
                                                                           : glm::normalize(fallbackAxis);
    if (dirs.empty()) return r;
    std::vector<double> ang;
    ang.reserve(dirs.size());
    for (const Vec3& d : dirs) {
        const glm::dvec3 a(r.axis), b(d);
        ang.push_back(std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b)));
    }
    std::nth_element(ang.begin(), ang.begin() + ang.size() / 2, ang.end());
    r.scale = std::clamp(ang[ang.size() / 2], 1e-4, 3.14159265358979323846);
    return r;
}

struct Region {
    Domain dom;
    std::function<bool(const Vec3&)> contains;  // empty: the whole sphere
};
inline int regionOf(const std::vector<Region>& regions, const Vec3& w) {
    for (size_t k = 0; k < regions.size(); ++k)
        if (!regions[k].contains || regions[k].contains(w)) return int(k);
    return -1;
}

// Samples a direction; returns false if the sampler fails (the sample is "lost").
using SampleFn = std::function<bool(Rng&, Vec3&)>;
using PdfFn = std::function<double(const Vec3&)>;

class Chi2Test {
public:
    // Draws and stores n samples (seeded, reproducible).
    Chi2Test(const SampleFn& sampler, long long n, uint64_t seed) : n_(n) {
        Rng rng(seed, 0x5eed);
        dirs_.reserve(size_t(n));
        for (long long k = 0; k < n; ++k) {
            Vec3 w;
            if (sampler(rng, w)) dirs_.push_back(w);
        }
    }
    const std::vector<Vec3>& samples() const { return dirs_; }
    long long count() const { return n_; }

    // Integral of the pdf over every bin of the domain (adaptive quadrature, see top).
    std::vector<double> integrate(const PdfFn& pdf, const Domain& dom) const {
        std::vector<double> q(size_t(dom.nTheta) * dom.nPhi, 0.0);
        for (int i = 0; i < dom.nTheta; ++i) {
            const double t0 = dom.thetaEdge(i), t1 = dom.thetaEdge(i + 1);
            for (int j = 0; j < dom.nPhi; ++j) {
                const double p0 = dom.phiEdge(j), p1 = dom.phiEdge(j + 1);
                const double coarse = cell(pdf, dom, t0, t1, p0, p1);
                const double n = double(n_);
                const double tol = 0.1 * std::sqrt(std::max(coarse * n, 1.0)) / n;
                q[size_t(i) * dom.nPhi + j] = adaptive(pdf, dom, t0, t1, p0, p1, coarse, tol, 0);
            }
        }
        return q;
    }

    // Integral of pdf over the whole sphere (absolute tolerance per bin of dom: tol).
    static double integrateSphere(const PdfFn& pdf, const Domain& dom, double tol) {
        double sum = 0;
        for (int i = 0; i < dom.nTheta; ++i)
            for (int j = 0; j < dom.nPhi; ++j) {
                const double t0 = dom.thetaEdge(i), t1 = dom.thetaEdge(i + 1), p0 = dom.phiEdge(j), p1 = dom.phiEdge(j + 1);
                sum += adaptive(pdf, dom, t0, t1, p0, p1, cell(pdf, dom, t0, t1, p0, p1), tol, 0);
            }
        return sum;
    }

    // Single domain covering the whole sphere.
    Result run(const PdfFn& pdf, const Domain& dom, double significance) const {
        return run(pdf, std::vector<Region>{Region{dom, nullptr}}, significance);
    }

    // Several domains, each restricted to a region; the regions must partition the sphere (a
    // direction belongs to the first region whose predicate accepts it). This resolves several
    // lobes at once (e.g. reflection in the upper and refraction in the lower hemisphere).
    Result run(const PdfFn& pdf, const std::vector<Region>& regions, double significance) const {
        Result r;
        r.samples = n_;
        r.lost = n_ - (long long)dirs_.size();
        r.significance = significance;
        std::vector<double> q;
        std::vector<size_t> offset;
        for (size_t k = 0; k < regions.size(); ++k) {
            offset.push_back(q.size());
            const Region& reg = regions[k];
            PdfFn restricted = pdf;
            if (reg.contains) {
                restricted = [&pdf, &regions, k](const Vec3& w) { return regionOf(regions, w) == int(k) ? pdf(w) : 0.0; };
            } else if (k > 0) {
                restricted = [&pdf, &regions, k](const Vec3& w) { return regionOf(regions, w) == int(k) ? pdf(w) : 0.0; };
            }
            const std::vector<double> qk = integrate(restricted, reg.dom);
            q.insert(q.end(), qk.begin(), qk.end());
        }
        std::vector<double> obs(q.size() + 1, 0.0), expv(q.size() + 1, 0.0);
        for (const Vec3& w : dirs_) {
            const int k = regionOf(regions, w);
            const int b = k < 0 ? -1 : regions[size_t(k)].dom.bin(w);
            if (b < 0) ++r.lost; else obs[offset[size_t(k)] + size_t(b)] += 1.0;
        }
        // A bin whose quadrature nodes all missed the pdf's support (a thin sliver cut by the
        // horizon, say) integrates to 0. Where samples landed in such a bin, integrate it again
        // with a forced 32x32 subdivision before calling it a zero-pdf bin.
        for (size_t k = 0; k < regions.size(); ++k) {
            const Domain& dom = regions[k].dom;
            PdfFn restricted = [&pdf, &regions, k](const Vec3& w) { return regionOf(regions, w) == int(k) ? pdf(w) : 0.0; };
            for (int i = 0; i < dom.nTheta; ++i)
                for (int j = 0; j < dom.nPhi; ++j) {
                    const size_t b = offset[k] + size_t(i) * dom.nPhi + j;
                    if (q[b] != 0.0 || obs[b] == 0.0) continue;
                    const double t0 = dom.thetaEdge(i), t1 = dom.thetaEdge(i + 1), p0 = dom.phiEdge(j), p1 = dom.phiEdge(j + 1);
                    q[b] = adaptive(restricted, dom, t0, t1, p0, p1, 0.0, 0.0, 0, 5);
                }
        }
        double integral = 0;
        for (size_t b = 0; b < q.size(); ++b) {
            integral += q[b];
            expv[b] = q[b] * double(n_);
        }
        r.pdfIntegral = integral;
        obs.back() = double(r.lost);
        expv.back() = std::max(0.0, 1.0 - integral) * double(n_);
        // Samples where the pdf is zero over a whole bin: immediate failure.
        for (size_t b = 0; b < q.size(); ++b)
            if (expv[b] == 0.0 && obs[b] > 0) r.samplesInZeroBins += (long long)obs[b];
        // Pool bins with expected count < 5.
        std::vector<size_t> idx(obs.size());
        std::iota(idx.begin(), idx.end(), 0);
        std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return expv[a] < expv[b]; });
        double pooledObs = 0, pooledExp = 0, stat = 0;
        int bins = 0;
        size_t k = 0;
        for (; k < idx.size() && expv[idx[k]] < 5.0; ++k) {
            pooledObs += obs[idx[k]];
            pooledExp += expv[idx[k]];
        }
        for (; k < idx.size(); ++k) {
            double o = obs[idx[k]], e = expv[idx[k]];
            if (pooledExp > 0 && pooledExp < 5.0) {  // fold a too-small pool into the next bin
                o += pooledObs;
                e += pooledExp;
                pooledObs = pooledExp = 0;
            }
            stat += (o - e) * (o - e) / e;
            ++bins;
        }
        if (pooledExp >= 5.0) {
            stat += (pooledObs - pooledExp) * (pooledObs - pooledExp) / pooledExp;
            ++bins;
        }
        r.stat = stat;
        r.bins = bins;
        r.dof = std::max(1, bins - 1);
        r.pValue = bins > 1 ? chi2SurvivalProbability(stat, r.dof) : 1.0;
        r.passed = r.samplesInZeroBins == 0 && r.pValue >= significance && bins > 1;
        return r;
    }

private:
    // 4-point Gauss-Legendre on [-1, 1].
    static constexpr std::array<double, 4> kX = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563,
                                                 0.8611363115940526};
    static constexpr std::array<double, 4> kW = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461,
                                                 0.3478548451374538};

    // Integral of pdf(direction) sin(theta) over a (theta, phi) cell.
    static double cell(const PdfFn& pdf, const Domain& dom, double t0, double t1, double p0, double p1) {
        const double tc = 0.5 * (t0 + t1), th = 0.5 * (t1 - t0), pc = 0.5 * (p0 + p1), ph = 0.5 * (p1 - p0);
        double sum = 0;
        for (int a = 0; a < 4; ++a) {
            const double t = tc + th * kX[a];
            const double st = std::sin(t);
            for (int b = 0; b < 4; ++b) {
                const double p = pc + ph * kX[b];
                const double v = pdf(dom.direction(t, p));
                if (std::isfinite(v)) sum += kW[a] * kW[b] * v * st;
            }
        }
        return sum * th * ph;
    }

    // Refines a cell until splitting it in 4 changes its integral by at most tol; the
    // tolerance is halved for each child (classic adaptive quadrature), depth capped at 8.
    static double adaptive(const PdfFn& pdf, const Domain& dom, double t0, double t1, double p0, double p1,
                           double coarse, double tol, int depth, int minDepth = 0) {
        const double tm = 0.5 * (t0 + t1), pm = 0.5 * (p0 + p1);
        const double c[4] = {cell(pdf, dom, t0, tm, p0, pm), cell(pdf, dom, tm, t1, p0, pm),
                             cell(pdf, dom, t0, tm, pm, p1), cell(pdf, dom, tm, t1, pm, p1)};
        const double fine = c[0] + c[1] + c[2] + c[3];
        if (depth >= std::max(8, minDepth) || (depth >= minDepth && std::abs(fine - coarse) <= tol)) return fine;
        const double t = 0.5 * tol;
        const int d = depth + 1;
        return adaptive(pdf, dom, t0, tm, p0, pm, c[0], t, d, minDepth) + adaptive(pdf, dom, tm, t1, p0, pm, c[1], t, d, minDepth) +
               adaptive(pdf, dom, t0, tm, pm, p1, c[2], t, d, minDepth) + adaptive(pdf, dom, tm, t1, pm, p1, c[3], t, d, minDepth);
    }

    long long n_;
    std::vector<Vec3> dirs_;
};

}  // namespace lt::chi2
