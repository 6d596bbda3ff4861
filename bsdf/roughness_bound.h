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
//   f_t is below rho_bar_t by about alpha^2/4 (tests/test_microfacet_bounds.cpp); alpha_hat for
//   Smith refraction therefore over-regularises. Kept as published.
// * TIGHT FORM (BoundForm::Tight, the default of a regularisation request; issue 45): the true
//   supremum of the bounded quantity over all direction pairs, both transport modes and both
//   sides. It differs from the published form only for Smith refraction: the supremum is reached
//   at normal incidence (G1 = 1: c D_max, c = max(1, eta^2) / (1 - eta)^2) or, for larger alpha,
//   at grazing pairs, where the Jacobian's |i.h| |o.h| cancels the 1/|cos| of G1. For GGX,
//   measured by a 3D search over (theta_o, theta_h, phi_h) for eta in [1.01, 4] (both sides) and
//   alpha in [0.02, 1]: sup f_t = c / pi max(1 / alpha^2, 4) within 3e-5, i.e. alpha^2 / 4 of Eq. 9
//   for alpha <= 1/2; it is used with a 0.1% upward margin (tests/test_microfacet_bounds.cpp checks
//   it holds and is tight over dense sweeps). The published Smith reflection bound and the
//   V-cavity bounds are already the suprema (reached at a grazing mirror pair, resp. at normal
//   incidence), so the tight form equals them. Beckmann/Smith refraction keeps the published
//   bound: its supremum has a third branch (grazing wo, wi near 65 degrees) whose height depends
//   on eta and alpha (1.9-2.8 c for alpha in [0.4, 1]), not yet tabulated.
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
// The tight form's inverse is closed too (GGX/Smith refraction: alpha = sqrt(c / (pi tau)) up to
// the margin, where that is at most 1/2, else 1).
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
