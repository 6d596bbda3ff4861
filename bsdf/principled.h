// Mitsuba 3's principled BSDF (Burley's Disney BSDF as Mitsuba implements it): parameters with
// Mitsuba's names and defaults, each optionally a texture (bsdf/principled.cpp).
#pragma once
#include <memory>

#include "bsdf/bsdf.h"
#include "bsdf/microfacet.h"

namespace lt {

class Texture;

// The values of one point (or of an untextured material). eta is the relative IOR the loader
// derived from Mitsuba's eta or specular (eta = 2 / (1 - sqrt(0.08 specular)) - 1).
struct PrincipledParams {
    Color baseColor{0.5f};
    float roughness = 0.5f, anisotropic = 0.f, metallic = 0.f, specTrans = 0.f, specTint = 0.f;
    float sheen = 0.f, sheenTint = 0.f, flatness = 0.f, clearcoat = 0.f, clearcoatGloss = 0.f;
    float eta = 1.5f;
    // Mitsuba's diffuse_reflectance_sampling_rate, main_specular_sampling_rate,
    // clearcoat_sampling_rate (the relative weights of the lobes' sampling techniques).
    float diffuseRate = 1.f, specularRate = 1.f, clearcoatRate = 1.f;
};

// Textured parameters (null: the constant of PrincipledParams). Scalar parameters read a texture's
// grey value or luminance (scalarOf).
struct PrincipledTextures {
    std::shared_ptr<const Texture> baseColor, roughness, anisotropic, metallic, specTrans, specTint, sheen, sheenTint,
        flatness, clearcoat, clearcoatGloss;
    bool any() const {
        return baseColor || roughness || anisotropic || metallic || specTrans || specTint || sheen || sheenTint ||
               flatness || clearcoat || clearcoatGloss;
    }
};

BxdfPtr makePrincipled(const PrincipledParams& p, const PrincipledTextures& t = {});

// Mitsuba 3's principledthin (bsdf/principled_thin.cpp): a two-sided sheet without refraction.
// diffTrans is Mitsuba's diff_trans / 2 (its parameter runs over [0, 2]).
struct PrincipledThinParams {
    Color baseColor{0.5f};
    float roughness = 0.5f, anisotropic = 0.f, specTrans = 0.f, specTint = 0.f, sheen = 0.f, sheenTint = 0.f;
    float flatness = 0.f, diffTrans = 0.f, eta = 1.5f;
    // specular_reflectance_, specular_transmittance_, diffuse_reflectance_ and
    // diffuse_transmittance_sampling_rate
    float specReflRate = 1.f, specTransRate = 1.f, diffReflRate = 1.f, diffTransRate = 1.f;
};
// Textured parameters (null: the constant); diffTrans's texture is Mitsuba's diff_trans (halved here).
struct PrincipledThinTextures {
    std::shared_ptr<const Texture> baseColor, roughness, anisotropic, specTrans, specTint, sheen, sheenTint, flatness,
        diffTrans, eta;
    bool any() const {
        return baseColor || roughness || anisotropic || specTrans || specTint || sheen || sheenTint || flatness ||
               diffTrans || eta;
    }
};
BxdfPtr makePrincipledThin(const PrincipledThinParams& p, const PrincipledThinTextures& t = {});

// Mitsuba 3's principled and principledthin share these (principledhelpers.h's formulas).
namespace principled_detail {

// Mitsuba's luminance (the sRGB primaries' Y row).
inline float mitsubaLuminance(const Color& c) { return 0.212671f * c.x + 0.715160f * c.y + 0.072169f * c.z; }

inline float schlickWeight(float c) {
    const float m = std::clamp(1.f - c, 0.f, 1.f);
    return (m * m) * (m * m) * m;
}

// Schlick's approximation with reflectance r0 at normal incidence, at cosine cosI of wo with the
// microfacet normal; for light leaving the denser side the transmitted cosine is used (Mitsuba's
// calc_schlick).
template <class T>
T schlick(const T& r0, float cosI, float eta) {
    const float etaIt = cosI >= 0.f ? eta : 1.f / eta, etaTi = 1.f / etaIt;
    const float cosT = safeSqrt(1.f - (1.f - cosI * cosI) * etaTi * etaTi);
    const float w = etaIt > 1.f ? schlickWeight(std::abs(cosI)) : schlickWeight(cosT);
    return r0 + (T(1.f) - r0) * w;
}

// Burley's GTR1 ("Berry") distribution of the clearcoat, normalised as integral D cos = 1.
struct Gtr1 {
    float alpha;
    // (1 + (a^2 - 1) cos^2 written as a^2 cos^2 + sin^2: no cancellation at the peak of a sharp lobe,
    // where the former loses the few digits a^2 ~ 1e-6 has against 1)
    float D(const Vec3& m) const {
        const float a2 = alpha * alpha, c2 = m.z * m.z, s2 = m.x * m.x + m.y * m.y;
        const float d = (a2 - 1.f) / (kPi * std::log(a2) * (a2 * c2 + s2));
        return d * m.z > 1e-20f ? d : 0.f;
    }
    float pdf(const Vec3& m) const { return m.z > 0.f ? m.z * D(m) : 0.f; }
    Vec3 sample(const Vec2& u) const {
        const float a2 = alpha * alpha;
        const float c2 = (1.f - std::pow(a2, 1.f - u.y)) / (1.f - a2);
        const float sinT = safeSqrt(1.f - c2), cosT = safeSqrt(c2);
        const float phi = 2.f * kPi * u.x;
        return Vec3(std::cos(phi) * sinT, std::sin(phi) * sinT, cosT);
    }
};

// Smith's G1 of an isotropic GGX lobe (the clearcoat's masking).
inline float smithGgx1(const Vec3& v, const Vec3& h, float alpha) {
    if (glm::dot(v, h) * v.z <= 0.f) return 0.f;
    if (v.z == 1.f) return 1.f;
    const float c2 = v.z * v.z, t2 = (1.f - c2) / c2;
    return 2.f / (1.f + std::sqrt(1.f + alpha * alpha * t2));
}

inline float lerpf(float a, float b, float t) { return a + (b - a) * t; }

// The main lobe's alphas (Mitsuba's calc_dist_params; anisotropic 0 gives the isotropic ones).
inline Roughness mainAlphas(float roughness, float anisotropic) {
    const float r2 = roughness * roughness, aspect = std::sqrt(1.f - 0.9f * anisotropic);
    return {std::max(0.001f, r2 / aspect), std::max(0.001f, r2 * aspect)};
}
inline float clearcoatAlpha(float gloss) { return lerpf(0.1f, 0.001f, gloss); }

// ---- Regularisation (bsdf.h's requests): each microfacet lobe is resolved on its own ----------
// A lobe's value is w f, w its weight (spec_trans, clearcoat: the mixture's, colour and Fresnel
// left out as for the conductors, bsdf.h) and f its Fresnel- and colour-free form; under a bound
// tau its alphas are raised until w rho_bar(alpha) <= tau, i.e. the lobe meets tau / w.

// GTR1's largest value D(n) = (1 - a^2) / (pi a^2 ln(1 / a^2)) (Gtr1::D at m = n): the clearcoat
// is 0.25 clearcoat Schlick D G1 G1 without a 1 / (4 cos cos), so this times its weight bounds it.
float gtr1Peak(float alpha);
// GTR1's alphas stop below 1, where D is 0 / 0 (the uniform distribution's 1 / pi is the limit).
inline constexpr float kMaxGtr1Alpha = 0.99f;
// The least alpha in (0, kMaxGtr1Alpha] with gtr1Peak(alpha) <= bound (kMaxGtr1Alpha where none).
float gtr1AlphaForBound(float bound);
// A GTR1 lobe of alpha a and weight w under request r: max(a, the larger minAlpha, the alpha of
// tau / w), at most kMaxGtr1Alpha.
float resolveGtr1(float alpha, float weight, const RegularizationRequest& r);
// A GGX/Smith lobe of weight w under request r (MicrofacetLobe::resolve with tau / w).
MicrofacetLobe::Resolved resolveWeighted(const MicrofacetLobe& lobe, float weight, const RegularizationRequest& r,
                                         bool transmission, float eta);
// The supremum of the Disney diffuse lobe's shape factor (1 - Fo/2)(1 - Fi/2) + rr (Fo + Fi +
// Fo Fi (rr - 1)), rr = 2 roughness cos_d^2 <= 2 roughness: bilinear in (Fo, Fi) in [0, 1]^2, so
// its largest corner. (The flattened form has none: 1 / (cos_o + cos_i) at grazing pairs.)
float diffuseShapeBound(float roughness);
// The diffuse and sheen lobes' bound: weight (the diffuse mixture's) x maxBase / pi x the shape's
// bound, plus sheenWeight x sheenColour (the sheen colour's largest channel); 0 without diffuse,
// +inf with flatness (the flattened form has no bound).
float diffuseSheenBound(float weight, float maxBase, float roughness, float flatness, float sheenWeight,
                        float sheenColour);

}  // namespace principled_detail


}  // namespace lt
