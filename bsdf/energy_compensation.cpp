#include "bsdf/energy_compensation.h"

#include <algorithm>
#include <cmath>

#include "bsdf/albedo.h"
#include "bsdf/fresnel.h"
#include "bsdf/roughness_bound.h"

namespace lt {

namespace {
constexpr MicrofacetType kType = MicrofacetType::GGX;  // (a smooth lobe made rough is GGX/Smith: bsdf.h)
constexpr MaskingModel kMasking = MaskingModel::Smith;
// K's upward margin over its samples (96 cosines per alpha node, linear between the nodes).
constexpr float kMargin = 1.01f;
constexpr int kMus = 96;
float muAt(int j) {
    const float t = float(j) / float(kMus - 1);
    return kAlbedoMuMin + (1.f - kAlbedoMuMin) * t * t;  // (denser at grazing, where E falls fastest)
}
}  // namespace

float SmoothLobeCompensation::reflectionScale(float muL, float alpha) {
    return 1.f / reflectionAlbedo(kType, kMasking, muL, alpha);
}

float SmoothLobeCompensation::transmissionScale(float muL, float alpha, float etaL) {
    const float e = transmissionAlbedo(kType, kMasking, muL, alpha, etaL);
    return e > 0.f ? 1.f / e : 0.f;  // (no refraction from l at all: W = 1 - F is 0 there too)
}

SmoothLobeCompensation::SmoothLobeCompensation(float eta, bool dielectric) : eta_(eta), dielectric_(dielectric) {
    for (int k = 0; k < kAlphas; ++k) {
        const float t = float(k) / float(kAlphas - 1);
        const float alpha = std::max(t * t, kMinAlpha);
        float r = 0.f, tr = 0.f;
        for (int j = 0; j < kMus; ++j) {
            const float mu = muAt(j);
            if (!dielectric) {
                r = std::max(r, reflectionScale(mu, alpha));
                continue;
            }
            for (float etaL : {eta, 1.f / eta}) {
                const float F = fresnelDielectric(mu, etaL);
                r = std::max(r, F * reflectionScale(mu, alpha));
                tr = std::max(tr, (1.f - F) * transmissionScale(mu, alpha, etaL));
            }
        }
        kR_[size_t(k)] = r;
        kT_[size_t(k)] = tr;
    }
    for (BoundForm form : {BoundForm::Tight, BoundForm::Published})
        for (bool transmission : {false, true}) {
            if (transmission && !dielectric) continue;
            for (int k = 0; k < kTaus; ++k) {
                const float tau = std::pow(10.f, float(kTauMin) + float(k) / float(kTausPerDecade));
                inv_[int(form)][int(transmission)][size_t(k)] = alphaByBisection(tau, transmission, form);
            }
        }
}

float SmoothLobeCompensation::boundFactor(bool transmission, float alpha) const {
    const std::array<float, kAlphas>& K = transmission ? kT_ : kR_;
    const float x = std::clamp(std::sqrt(std::max(alpha, 0.f)), 0.f, 1.f) * float(kAlphas - 1);
    const int i = std::min(int(x), kAlphas - 2);
    const float t = x - float(i);  // (linear: K is smooth in alpha, its curvature within the margin)
    return kMargin * ((1.f - t) * K[size_t(i)] + t * K[size_t(i + 1)]);
}

float SmoothLobeCompensation::valueBound(bool transmission, float alpha, BoundForm form) const {
    const float a = std::max(alpha, kMinAlpha);
    return maxValueBound(kType, kMasking, a, transmission, dielectric_ ? eta_ : 1.f, form) * boundFactor(transmission, a);
}

float SmoothLobeCompensation::alphaFor(float tau, bool transmission, BoundForm form) const {
    const float x = (std::log10(tau) - float(kTauMin)) * float(kTausPerDecade);
    if (!(x >= 0.f && x < float(kTaus - 1)) || (transmission && !dielectric_))
        return alphaByBisection(tau, transmission, form);  // (outside the table: rare)
    const std::array<float, kTaus>& inv = inv_[int(form)][int(transmission)];
    const int k = int(x);
    const float a0 = inv[size_t(k)], a1 = inv[size_t(k + 1)];
    if (a0 == a1) return a0;
    const float t = x - float(k);
    const float a = a0 > 0.f && a1 > 0.f ? std::exp((1.f - t) * std::log(a0) + t * std::log(a1)) : a0;
    if (valueBound(transmission, a, form) <= tau) return a;
    // (the interpolant misses tau: a few bisection steps between it and a0, which meets it)
    float lo = a, hi = a0;
    for (int i = 0; i < 8; ++i) {
        const float mid = std::sqrt(lo * hi);
        if (valueBound(transmission, mid, form) <= tau) hi = mid; else lo = mid;
    }
    return hi;
}

MicrofacetLobe::Resolved SmoothLobeCompensation::resolve(const MicrofacetLobe& lobe, const RegularizationRequest& r,
                                                         bool transmission) const {
    const float eta = dielectric_ ? eta_ : 1.f;
    if (!(r.tau < kInf)) return lobe.resolve(r, transmission, eta);
    RegularizationRequest q = r;
    q.tau = kInf;
    MicrofacetLobe::Resolved a = lobe.resolve(q, transmission, eta);
    const float b = alphaFor(r.tau, transmission, r.bound);
    a.u = std::max(a.u, b);
    a.v = std::max(a.v, b);
    a.delta = !(std::max(a.u, a.v) >= kMinAlpha);
    return a;
}

float SmoothLobeCompensation::alphaByBisection(float tau, bool transmission, BoundForm form) const {
    if (!(tau > 0.f)) return 1.f;
    if (std::isinf(tau)) return 0.f;
    if (transmission && eta_ == 1.f) return 1.f;
    if (!(valueBound(transmission, 1.f, form) <= tau)) return 1.f;  // (no alpha meets tau: as alphaForBound)
    // The least alpha the bisection finds (sqrt(alpha) in [lo, hi], hi always meeting tau).
    float lo = 0.f, hi = 1.f;
    for (int i = 0; i < 30 && hi - lo > 1e-6f; ++i) {
        const float mid = 0.5f * (lo + hi);
        if (valueBound(transmission, mid * mid, form) <= tau) hi = mid; else lo = mid;
    }
    return hi * hi;
}

}  // namespace lt
