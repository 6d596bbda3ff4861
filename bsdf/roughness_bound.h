// Maximum-value bound of microfacet BSDFs and its inverse, for roughness-based regularisation
// (Jendersie & Grosch 2019, "Microfacet model regularization for robust light transport",
// Sec. 3.2, Eqs. 8-9):
//   rho_bar_r(alpha) = G_bar(alpha) / (4 pi alpha^2)
//   rho_bar_t(alpha) = max(n_i, n_t)^2 / (pi alpha^2 (n_i - n_t)^2) G_bar(alpha)
//   G_bar = 1 (V-cavity), 4 / alpha^2 (Smith GGX), 4 pi / alpha^2 (Smith Beckmann),
// and alpha_hat(tau) = rho_bar^-1(tau): the regulariser evaluates the BSDF with
// max(alpha, alpha_hat) (each of alpha_u, alpha_v independently).
//
// WHAT IS BOUNDED (rho in the paper is the BSDF f, Eqs. 6-7, without any cosine):
// * The Fresnel-free BSDF of microfacet.h: microfacetReflection (F = 1) resp.
//   microfacetTransmission (1 - F = 1), in either TransportMode; the real materials multiply
//   by F <= 1 (1 - F <= 1) and their colour, so their f is bounded too when colours are <= 1.
// * Smith: the bound is on f itself, over ALL direction pairs. It relies on the SEPARABLE
//   G2 = G1 G1 used by microfacet.h: G_bar = (sup_w G1(w)/|cos w|)^2 with
//   sup G1/cos = 2/alpha (GGX) and 2 sqrt(pi)/alpha (Beckmann), approached at grazing angles,
//   combined with D <= D_max = 1/(pi alpha^2) and, for refraction,
//   |i.h||o.h| n_o^2 / (n_i i.h + n_o o.h)^2 <= max(n_i,n_t)^2/(n_i-n_t)^2 (normal facet
//   incidence). The reflection bound is tight: f -> rho_bar for a mirror pair at grazing angles.
//   (With the height-correlated G2, f would be unbounded when both directions graze.)
// * V-cavity: f itself is UNBOUNDED (for m = n the V-cavity G2 is 1, so
//   f = D(n) / (4 |cos_o cos_i|) -> infinity for a grazing mirror pair). The paper's G_bar = 1
//   bounds the cosine-weighted (projected) BSDF f |cos theta_o| |cos theta_i| = D G F / 4 (resp.
//   the refraction analogue), i.e. f at normal incidence. That is what maxValueBound returns
//   for MaskingModel::VCavity.
// * Deviations from the paper's formulas (outside its stated range only): D_max = 1/(pi alpha^2)
//   holds for GGX only for alpha <= 1 (else alpha^2 / pi, grazing facets) and for Beckmann only
//   for alpha <= 1/sqrt(2) (else 4 alpha^2 exp(1/alpha^2 - 2) / pi); sup G1/cos is
//   2 / min(alpha, 2) for GGX, and max(2 sqrt(pi) / alpha, 1.02) for Beckmann alpha > 3. These
//   exact suprema are used, so rho_bar stays a true bound for every alpha.
// * Anisotropic alphas: maxValueBound(min(alpha_u, alpha_v)) bounds the anisotropic model for
//   alphas <= 1 (D_max = 1/(pi alpha_u alpha_v) and the G1 bound use the smaller alpha).
// * The Smith refraction bound (Eq. 9 with the Smith G_bar) is valid but loose: for a refraction
//   pair the 1/|cos| factors cancel against |o.h| |i.h| at grazing angles, so the measured sup of
//   f_t is rho_bar_t times about alpha^2/4 (GGX; alpha^2 / (4 pi) for Beckmann at small alpha);
//   alpha_hat for Smith refraction therefore over-regularises. Kept as published.
// * TIGHT FORM (BoundForm::Tight, the default of a regularisation request; issue 45): the true
//   supremum of the bounded quantity over all direction pairs, both transport modes and both
//   sides, with a 0.1% upward margin. It differs from the published form only for Smith
//   refraction with alpha <= 1: sup f_t = c D_max max(1, G(alpha, eta)), c = max(1, eta^2) /
//   (1 - eta)^2. The 1 is normal incidence (G1 = 1); G is the grazing branch, pairs whose
//   lighter-side direction grazes, where the Jacobian's |i.h| |o.h| cancels the 1/|cos| of G1.
//   GGX: G = 4 alpha^2, i.e. sup f_t = c / pi max(1 / alpha^2, 4) (measured within 3e-5 by a 3D
//   search over (theta_o, theta_h, phi_h), eta in [1.01, 4] both sides, alpha in [0.02, 1]), a
//   quarter alpha^2 of Eq. 9 for alpha <= 1/2. Beckmann (the same search, then a 1D one along
//   the branch): the branch peaks with h tilted towards the grazing direction in its plane of
//   incidence; G depends on alpha and eta' = max(eta, 1/eta), from 1.52 (eta' - 1) / (eta' + 1)
//   for alpha -> 0 (at most 0.975 for alpha <= 0.1, eta' <= 4) to 5.98-6.82 at alpha 1. So
//   sup f_t is c D_max up to alpha 0.13-0.41 (by eta'), then c D_max G: at least 1.86 c, and
//   1.90-2.17 c at alpha 1. G is tabulated (roughness_bound.cpp) for eta' <= 4, at most 2% above
//   the measured supremum; for eta' > 4 the published bound stays. This bound is not monotone in
//   alpha: past its minimum (alpha 0.38-0.78) it rises again, by up to 8% towards alpha = 1.
//   The published Smith reflection bound and the V-cavity bounds are already the suprema
//   (reached at a grazing mirror pair, resp. at normal incidence), so the tight form equals them.
// * eta is the relative IOR int_ior / ext_ior; the transmission bound is symmetric in
//   eta <-> 1/eta and infinite for eta == 1 (an index-matched refraction is a delta).
#pragma once
#include <cstdint>

#include "bsdf/bsdf.h"

namespace lt {

// rho_bar(alpha): see above (form: the tight supremum or JG19's Eqs. 8-9). Returns +inf for
// alpha <= 0 or (transmission && eta == 1).
float maxValueBound(MicrofacetType type, MaskingModel masking, float alpha, bool transmission, float eta,
                    BoundForm form = BoundForm::Published);

// alpha_hat(tau) = rho_bar^-1(tau) on alpha in (0, 1], where rho_bar is strictly decreasing.
// Closed form (the paper's) where D_max = 1/(pi alpha^2) holds, else a bisection in log(alpha).
// Returns 1 if even alpha = 1 exceeds tau (tau < rho_bar(1)) and for an index-matched
// transmission (eta == 1: no finite alpha bounds it; the dielectric ignores roughness there).
// tau <= 0 gives 1; tau = +inf gives 0.
// The tight form's inverse is closed too; it returns the least alpha from which on the bound
// stays <= tau, i.e. with rho_bar(alpha') <= tau for every alpha' in [alpha, 1] (the Beckmann
// refraction bound is not monotone: 1 wherever rho_bar(1) > tau). GGX/Smith refraction: alpha =
// sqrt(c / (pi tau)) up to the margin, where that is at most 1/2, else 1.
float alphaForBound(MicrofacetType type, MaskingModel masking, float tau, bool transmission, float eta,
                    BoundForm form = BoundForm::Published);

// The least bound tau can be: 1/(2 pi) bounds a lobe spread uniformly over the hemisphere. Every
// tau a user gives (XML reg_tau, --reg-tau) must exceed it; Eq. 16 needs 2 pi tau0 > 1.
inline constexpr double kMinTau = 1.0 / (2.0 * 3.14159265358979323846);

// The consistent bound of JG19 Eq. 16 for iteration (sample index) n >= 1:
//   tau_n = 1 / (2 pi [1 - cos(atan(x n^(-1/6)))]),  x = sqrt(4 pi tau0 - 1) / (2 pi tau0 - 1),
// so tau_1 = tau0, tau_n increases strictly and grows like n^(1/3) / (pi x^2). Evaluated in
// double without the cancellation of 1 - cos(small): with y^2 = x^2 n^(-1/3) and
// s = sqrt(1 + y^2), 1 - cos(atan y) = y^2 / (s (1 + s)), hence tau_n = s (1 + s) / (2 pi y^2),
// accurate to a few ulp up to n = 1e12 and beyond (tests/test_regularization_schedule.cpp).
// tau0 = +inf gives +inf (no regularisation). Throws std::invalid_argument for n == 0 or
// tau0 <= 1 / (2 pi) or NaN (the formula needs 2 pi tau0 > 1: 1/(2 pi) bounds a lobe spread
// uniformly over the hemisphere, the least any tau can mean).
double consistentTau(double tau0, uint64_t n);

}  // namespace lt
