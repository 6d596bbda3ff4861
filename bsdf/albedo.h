// Directional albedos of the Fresnel-free microfacet lobes of microfacet.h (F = 1 for reflection,
// 1 - F = 1 for refraction), for an energy compensation of regularised lobes: a lobe whose alpha a
// regulariser raised can be scaled by E(alpha) / E(alpha') to keep its albedo.
//
// For wo = (sqrt(1 - mu^2), 0, mu), mu in (0, 1], isotropic alpha, TransportMode::Importance (no
// 1/eta^2 radiance factor):
//   reflection   E_R(mu, alpha)      = integral over wi.z > 0 of microfacetReflection(mf, wo, wi) |wi.z| dwi
//   transmission E_T(mu, alpha, eta) = integral over wi.z < 0 of
//                                      microfacetTransmission(mf, wo, wi, eta, Importance) |wi.z| dwi
// eta = n_lower / n_upper is the relative IOR seen from wo's (upper) side: a caller whose wo is
// inside the denser medium passes 1 / eta (eta < 1; the lobe then has total internal reflection).
//
// With visible-normal sampling of wo (Heitz 2014, "Importance sampling microfacet-based BSDFs using
// the distribution of visible normals") and wi the reflection / refraction of wo about m, f |wi.z|
// over the density of wi is G2(wo, wi, m) / G1(wo, m) for both lobes (Importance mode), so
//   E = expectation over m ~ D_wo(m) of G2 / G1(wo, m),
// with 0 where wi is on the wrong side or refraction about m does not exist (total internal
// reflection). That is what the *Integral functions compute, and what the tables are built from.
//
// At eta == 1 microfacetTransmission is 0 (an index-matched interface is a straight-through
// delta, never a rough lobe); the integral and the table give the limit eta -> 1 there instead
// (every wi = -wo: E_T = G1(wo) for Smith), which is continuous with the neighbouring eta.
#pragma once
#include "bsdf/bsdf.h"

namespace lt {

// Table look-ups (bilinear for reflection, trilinear for transmission; bsdf/albedo_tables.inc,
// written by tools/albedo_tables). Arguments outside the tables are clamped to them:
// mu to [kAlbedoMuMin, 1], alpha to [kMinAlpha, 1] (Microfacet treats alpha < kMinAlpha as
// kMinAlpha; alpha > 1 is NOT extrapolated: it returns the value at alpha = 1), eta to
// [1/3, 3]. Interpolation error (albedo.cpp): E_R within max(0.3%, 0.001) for mu >= 0.1; E_T
// typically ~0.0002 absolute, but up to ~0.01 - 0.1 near the critical angle for eta < 1.
float reflectionAlbedo(MicrofacetType type, MaskingModel masking, float mu, float alpha);
float transmissionAlbedo(MicrofacetType type, MaskingModel masking, float mu, float alpha, float eta);

// The same by direct numerical integration (slow; for the table tool and tests): the visible
// normal of wo on an n x n grid of cell centres in u, warped towards the edges of [0,1]^2 (with
// weights), cells across a total-internal-reflection edge subdivided 4 x 4; the V-cavity's choice
// between a normal and its groove partner is integrated exactly (albedo.cpp). mu is clamped to
// [1e-6, 1].
double reflectionAlbedoIntegral(MicrofacetType type, MaskingModel masking, double mu, double alpha, int n);
double transmissionAlbedoIntegral(MicrofacetType type, MaskingModel masking, double mu, double alpha, double eta,
                                  int n);

// The tables' ranges.
inline constexpr float kAlbedoMuMin = 1e-3f;
inline constexpr float kAlbedoEtaMin = 1.f / 3.f, kAlbedoEtaMax = 3.f;

namespace albedo_detail {
// The tables' grids (albedo.cpp): nodes uniform in x (mu), y (alpha) and z (eta), with maps
// that depend on the other arguments (so that the nodes follow the features that move with them).
inline constexpr int kNx = 32, kNy = 24, kNz = 48;
inline constexpr int kModels = 4;  // index 2 * int(type) + int(masking)
// The integration grid (n) the committed tables were generated with (tools/albedo_tables).
inline constexpr int kAlbedoTableN = 96;
double yOfAlpha(double alpha);
double alphaOfY(double y);
double xOfMu(double mu, double alpha);
double muOfX(double x, double alpha);
double zOfEta(double eta, double mu, double alpha);
double etaOfZ(double z, double mu, double alpha);
// The n the compiled-in tables were generated with (kAlbedoTableN unless they are stale).
int tableIntegrationN();
// The maps above in words, for the generated file's header.
const char* gridDescription();

// wo = (sqrt(1 - mu^2), 0, mu), mu clamped to [1e-6, 1].
Vec3 albedoDirection(double mu);
// E_R (if reflection) and E_T at each of etas[0..nEta) (into transmission) from one set of visible
// normals: each value is bit for bit what the single calls above return.
void albedoIntegrals(MicrofacetType type, MaskingModel masking, double mu, double alpha, int n, const double* etas,
                     int nEta, double* reflection, double* transmission);
}  // namespace albedo_detail

}  // namespace lt
