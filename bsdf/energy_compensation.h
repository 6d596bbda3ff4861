// Energy compensation of a lobe that a regulariser makes rougher (issue 45; JG19 Sec. 3.2: the
// method preserves energy only if the microfacet model's loss is compensated).
//
// A lobe widened from alpha_0 to alpha keeps, for every direction l on the LIGHT side of the vertex,
// the flux the lobe it replaces sends on:
//   smooth (a delta, alpha_0 = 0, made a GGX/Smith lobe: bsdf.h)
//     f_c(l -> c) = W(mu_l) f1(l, c) / E(mu_l, alpha),
//     f1 the Fresnel-free lobe (microfacet.h), E its directional albedo (albedo.h), W the delta
//     lobe's weight from l: a conductor's F(mu_l) (per channel), a dielectric's F(mu_l) for
//     reflection and 1 - F(mu_l) for refraction, F seen from l's side (KD13's cone spreads the
//     same weights, cone_mollifier.h);
//   glossy conductor (alpha_0 > 0, isotropic)
//     f_c(l -> c) = f(alpha; l, c) E(mu_l, alpha_0) / E(mu_l, alpha),
//     f the material's own lobe at the raised alpha (its facet Fresnel and colour included), E the
//     Fresnel-free albedo of the material's own distribution and masking: the Fresnel-free albedo
//     of the lobe is kept exactly, its Fresnel-weighted one up to the change of the Fresnel
//     average over the wider normals (tests/test_energy_compensation.cpp).
// Glossy dielectrics are not compensated: the same ratio per lobe misplaces the energy that total
// internal reflection moves between reflection and refraction as the normals widen (GGX glass
// alpha 0.1 -> 0.3, light inside at mu 0.5: 0.79 for the material's 0.96); that needs the
// Fresnel-weighted albedos, which the tables do not hold.
// Hence the integral of f_c |cos c| over c is W(mu_l) (smooth), up to the tables' interpolation.
// l is wi in Radiance mode and wo in Importance mode (light flows l -> c), so every technique
// evaluates the same f_c on a path. The shape of the lobe is the rough lobe's; only the value is
// scaled. (Sampling: the smooth dielectric chooses reflection or refraction by the macro Fresnel
// of wo, the weight the value spreads, so the sample weight has no 1 / F(facet) tail; a glossy
// material samples as it always does.)
// Why this model rather than Kulla and Conty's added multiple-scattering lobe: it is exact per
// direction for any eta (a dielectric's reflection and refraction keep F and 1 - F separately),
// needs one or two table look-ups, keeps the regularised lobe's shape (Kulla-Conty adds a broad
// lobe, more blur), and bounds simply (below). The cost: it is not reciprocal (f_c depends on l's
// cosine), which the path space allows since every technique evaluates it with the same l.
// Anisotropic glossy conductors are not compensated (the tables are isotropic).
//
// The bound: sup f_c <= rho_bar(alpha) K(alpha), K(alpha) = sup over mu_l of W / E(alpha) (glossy:
// E(alpha_0) / E(alpha), 1 at alpha_0), with a 1% margin for the sampling over mu and the
// interpolation over alpha; tests/test_energy_compensation.cpp checks the value against tau over
// sampled pairs. alphaFor(tau) is the least alpha with rho_bar(alpha) K(alpha) <= tau (a tabulated
// bisection), so the compensated lobe's value stays under tau; where no alpha <= 1 meets tau (meets),
// the lobe is not compensated. K is sampled densely near a refraction's critical angle, where
// E(alpha_0) / E(alpha) peaks, and read at the upper alpha node (K grows with alpha).
#pragma once
#include <array>

#include "bsdf/bsdf.h"
#include "bsdf/microfacet.h"

namespace lt {

class LobeCompensation {
public:
    // A smooth material's, compensated as the GGX/Smith lobe it becomes. eta: the dielectric's
    // relative IOR; a conductor: reflection only (its Fresnel weight is the caller's, at most 1).
    LobeCompensation(float eta, bool dielectric)
        : LobeCompensation(MicrofacetLobe{MicrofacetType::GGX, MaskingModel::Smith, 0.f, 0.f}, eta, dielectric) {}
    // A conductor's lobe, smooth (alphas 0) or glossy and isotropic (its own distribution, masking
    // and alpha_0 = lobe.alphaU).
    explicit LobeCompensation(const MicrofacetLobe& conductor) : LobeCompensation(conductor, 1.f, false) {}
    bool smooth() const { return !(alpha0_ > 0.f); }
    // What the value of the lobe widened to alpha is multiplied by, at the light-side cosine muL (> 0):
    // smooth 1 / E(muL, alpha) (of W times the Fresnel-free lobe), glossy E(muL, alpha_0) / E(muL, alpha)
    // (of the material's lobe; exactly 1 at alpha_0). Refraction (a smooth dielectric's): 1 / E_T,
    // etaL the relative IOR seen from l's side.
    float reflectionScale(float muL, float alpha) const;
    float transmissionScale(float muL, float alpha, float etaL) const;
    // K(alpha) of the lobe (transmission: both sides of the interface); K(alpha) = K(alpha_0) below alpha_0.
    float boundFactor(bool transmission, float alpha) const;
    // The compensated lobe's bound and its inverse (form: the uncompensated bound's, roughness_bound.h).
    float valueBound(bool transmission, float alpha, BoundForm form) const;
    float alphaFor(float tau, bool transmission, BoundForm form) const;
    // Whether the compensated lobe keeps its value under r's bound with some alpha <= 1 (always
    // without a bound). Where it cannot (tau below rho_bar(1) K(1): a low-eta interface under a
    // small tau), the material resolves the request uncompensated: rho_hat <= tau comes first.
    bool meets(const RegularizationRequest& r, bool transmission) const;
    // The request r resolved for the material's lobe (as MicrofacetLobe::resolve, with alphaFor in
    // place of alphaForBound when r carries a bound).
    MicrofacetLobe::Resolved resolve(const MicrofacetLobe& lobe, const RegularizationRequest& r, bool transmission) const;

private:
    LobeCompensation(const MicrofacetLobe& lobe, float eta, bool dielectric);
    static constexpr int kAlphas = 128;  // K tabulated at alpha_k = (k / (kAlphas - 1))^2, k = 0..kAlphas-1
    std::array<float, kAlphas> kR_{}, kT_{};
    // alphaFor's bisection at tau_k = 10^(kTauMin + k / kTausPerDecade), per form and lobe: the
    // look-up interpolates in log-log between two nodes and keeps the result where it meets tau,
    // else bisects between it and the lower node's alpha (which meets tau_k <= tau).
    static constexpr int kTausPerDecade = 16, kTauMin = -1, kTauMax = 13;
    static constexpr int kTaus = (kTauMax - kTauMin) * kTausPerDecade + 1;
    std::array<float, kTaus> inv_[2][2]{};  // [form][transmission]
    float alphaByBisection(float tau, bool transmission, BoundForm form) const;
    MicrofacetType type_;
    MaskingModel masking_;
    float alpha0_;
    float eta_;
    bool dielectric_;
};

}  // namespace lt
