// Energy compensation of a smooth conductor or dielectric that a regulariser makes rough (issue 45;
// JG19 Sec. 3.2: the method preserves energy only if the microfacet model's loss is compensated).
//
// A smooth surface made rough becomes a GGX/Smith lobe (bsdf.h). Its single-scattering value loses
// energy (at alpha 1 as much as two thirds), and a regularised path tracer lit a room seen around a
// glass sphere far below the truth. The compensated lobe keeps, for every direction l on
// the LIGHT side of the vertex, the flux the delta lobe it replaces sends on:
//   f_c(l -> c) = W(mu_l) f1(l, c) / E(mu_l, alpha),
// f1 the Fresnel-free lobe (microfacet.h), E its directional albedo (albedo.h), W the delta lobe's
// weight from l: a conductor's F(mu_l) (per channel), a dielectric's F(mu_l) for reflection and
// 1 - F(mu_l) for refraction, F seen from l's side (KD13's cone spreads the same weights,
// cone_mollifier.h). Hence the integral of f_c |cos c| over c is W(mu_l), up to the tables'
// interpolation. l is wi in Radiance mode and wo in Importance mode (light flows l -> c), so every
// technique evaluates the same f_c on a path. The shape of the lobe is the rough lobe's; only the
// value is scaled. (Sampling: the dielectric chooses reflection or refraction by the macro Fresnel of
// wo, the weight the value spreads, so the sample weight has no 1 / F(facet) tail.)
// Why this model rather than Kulla and Conty's added multiple-scattering lobe: it is exact per
// direction for any eta (a dielectric's reflection and refraction keep F and 1 - F separately),
// needs one table look-up, keeps the regularised lobe's shape (Kulla-Conty adds a broad lobe, more
// blur), and bounds simply (below). The cost: it is not reciprocal (f_c depends on l's cosine), which
// the path space allows since every technique evaluates it with the same l.
// Glossy lobes made rougher are not compensated (their own loss is the material's; what they lose
// more under the request is left: issue 45's notes).
//
// The bound: sup f_c <= rho_bar(alpha) K(alpha), K(alpha) = sup over mu_l of W / E (with a 1%
// margin for the sampling over mu and the interpolation over alpha; tests/test_energy_compensation.cpp
// checks the value against tau over sampled pairs). alphaFor(tau) is the least alpha with
// rho_bar(alpha) K(alpha) <= tau (a tabulated bisection), so the compensated lobe's value stays under
// tau.
#pragma once
#include <array>

#include "bsdf/bsdf.h"
#include "bsdf/microfacet.h"

namespace lt {

class SmoothLobeCompensation {
public:
    // eta: the dielectric's relative IOR; conductor: reflection only (the Fresnel weight is the
    // caller's, bounded by 1).
    explicit SmoothLobeCompensation(float eta, bool dielectric);
    // 1 / E of the lobe at the light-side cosine muL (> 0) and alpha; etaL the relative IOR seen
    // from l's side (dielectric refraction only).
    static float reflectionScale(float muL, float alpha);
    static float transmissionScale(float muL, float alpha, float etaL);
    // K(alpha) of the lobe (transmission: both sides of the interface).
    float boundFactor(bool transmission, float alpha) const;
    // The compensated lobe's bound and its inverse (form: the uncompensated bound's, roughness_bound.h).
    float valueBound(bool transmission, float alpha, BoundForm form) const;
    float alphaFor(float tau, bool transmission, BoundForm form) const;
    // The request r resolved for the smooth material's lobe (as MicrofacetLobe::resolve, with
    // alphaFor in place of alphaForBound when r carries a bound).
    MicrofacetLobe::Resolved resolve(const MicrofacetLobe& lobe, const RegularizationRequest& r, bool transmission) const;

private:
    static constexpr int kAlphas = 48;  // K tabulated at alpha_k = (k / (kAlphas - 1))^2, k = 0..kAlphas-1
    std::array<float, kAlphas> kR_{}, kT_{};
    // alphaFor's bisection at tau_k = 10^(kTauMin + k / kTausPerDecade), per form and lobe: the
    // look-up interpolates in log-log between two nodes and keeps the result where it meets tau,
    // else bisects between it and the lower node's alpha (which meets tau_k <= tau).
    static constexpr int kTausPerDecade = 16, kTauMin = -1, kTauMax = 13;
    static constexpr int kTaus = (kTauMax - kTauMin) * kTausPerDecade + 1;
    std::array<float, kTaus> inv_[2][2]{};  // [form][transmission]
    float alphaByBisection(float tau, bool transmission, BoundForm form) const;
    float eta_;
    bool dielectric_;
};

}  // namespace lt
