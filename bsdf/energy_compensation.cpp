#include "bsdf/energy_compensation.h"

#include <algorithm>
#include <cmath>

#include "bsdf/albedo.h"
#include "bsdf/fresnel.h"
#include "bsdf/roughness_bound.h"

namespace lt {

namespace {
// K's upward margin over its samples (96 cosines per alpha node, linear between the nodes).
constexpr float kMargin = 1.01f;
constexpr int kMus = 96;
float muAt(int j) {
    const float t = float(j) / float(kMus - 1);
    return kAlbedoMuMin + (1.f - kAlbedoMuMin) * t * t;  // (denser at grazing, where E falls fastest)
}
// Cosines above the critical angle of a light side inside the denser medium (etaL < 1), denser
// towards it: E(alpha) falls to 0 there faster than E(alpha_0) (the peak of K_T lies within 0.005
// of it for alpha <= 0.6); none for etaL > 1.
constexpr int kCriticalMus = 256;
float criticalMuAt(int j, float etaL) {
    if (!(etaL < 1.f)) return 1.f;
    const float muC = std::sqrt(1.f - etaL * etaL), t = float(j) / float(kCriticalMus - 1);
    return std::min(1.f, muC + 0.2f * t * t);
}
}  // namespace

float LobeCompensation::reflectionScale(float muL, float alpha) const {
    const float e = reflectionAlbedo(type_, masking_, muL, alpha);
    if (smooth()) return 1.f / e;
    return alpha == alpha0_ ? 1.f : reflectionAlbedo(type_, masking_, muL, alpha0_) / e;
}

float LobeCompensation::transmissionScale(float muL, float alpha, float etaL) const {
    const float e = transmissionAlbedo(type_, masking_, muL, alpha, etaL);
    return e > 0.f ? 1.f / e : 0.f;  // (no refraction from l at all: W = 1 - F is 0 there too)
}

LobeCompensation::LobeCompensation(const MicrofacetLobe& lobe, float eta, bool dielectric)
    : type_(lobe.type), masking_(lobe.masking), alpha0_(lobe.alphaU), eta_(eta), dielectric_(dielectric) {
    for (int k = 0; k < kAlphas; ++k) {
        const float t = float(k) / float(kAlphas - 1);
        const float alpha = std::max({t * t, kMinAlpha, alpha0_});  // (K(alpha_0) below alpha_0)
        float r = 0.f, tr = 0.f;
        for (int j = 0; j < kMus + (dielectric ? 2 * kCriticalMus : 0); ++j) {
            const float mu = j < kMus ? muAt(j) : criticalMuAt(j - kMus, j - kMus < kCriticalMus ? eta : 1.f / eta);
            if (!dielectric) {
                r = std::max(r, reflectionScale(mu, alpha));
                continue;
            }
            for (float etaL : {eta, 1.f / eta}) {  // (a smooth dielectric: W = F and 1 - F)
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

float LobeCompensation::boundFactor(bool transmission, float alpha) const {
    const std::array<float, kAlphas>& K = transmission ? kT_ : kR_;
    const float x = std::clamp(std::sqrt(std::max(alpha, 0.f)), 0.f, 1.f) * float(kAlphas - 1);
    const int i = std::min(int(x), kAlphas - 2);
    return kMargin * std::max(K[size_t(i)], K[size_t(i + 1)]);  // (K grows with alpha: the upper node bounds the cell)
}

float LobeCompensation::valueBound(bool transmission, float alpha, BoundForm form) const {
    const float a = std::max(alpha, kMinAlpha);
    return maxValueBound(type_, masking_, a, transmission, dielectric_ ? eta_ : 1.f, form) * boundFactor(transmission, a);
}

float LobeCompensation::alphaFor(float tau, bool transmission, BoundForm form) const {
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

bool LobeCompensation::meets(const RegularizationRequest& r, bool transmission) const {
    if (!(r.tau < kInf)) return true;
    return valueBound(transmission, alphaFor(r.tau, transmission, r.bound), r.bound) <= r.tau;
}

MicrofacetLobe::Resolved LobeCompensation::resolve(const MicrofacetLobe& lobe, const RegularizationRequest& r,
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

float LobeCompensation::alphaByBisection(float tau, bool transmission, BoundForm form) const {
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
