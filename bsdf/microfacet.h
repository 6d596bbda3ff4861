// Microfacet distributions (GGX / Trowbridge-Reitz and Beckmann, anisotropic) with two
// masking-shadowing models, in the local shading frame (macro normal = +z).
//
// Conventions
// * alphaU scales the x (tangent) axis, alphaV the y (bitangent) axis. Alphas are clamped to at
//   least kMinAlpha here; deciding that an alpha below kMinAlpha means a delta lobe is up to the
//   material (see bsdf.h).
// * Microfacet normals m always lie in the upper hemisphere (m.z > 0). D(m) is normalised as
//   integral D(m) m.z dm = 1 (projected-area normalisation).
// * Smith model: G1(w, m) = chi+((w.m)/(w.z)) / (1 + Lambda(w)), and the masking-shadowing term is
//   the SEPARABLE form G2 = G1(wo, m) G1(wi, m) (as in Mitsuba 3), not the height-correlated one.
//   Reason: with the separable form the BSDF f itself is bounded (sup G1(w)/|w.z| = 2/alpha for
//   GGX, 2 sqrt(pi)/alpha for Beckmann), which is what the JG19 bound rho_bar (roughness_bound.h)
//   assumes; the height-correlated form makes f unbounded when both directions are grazing.
// * V-cavity model (Heitz 2014, "Understanding the masking-shadowing function", Sec. 5):
//   G1(w, m) = chi+((w.m)/(w.z)) min(1, 2 |m.z| |w.z| / |w.m|),
//   G2 = min(G1(wo), G1(wi)) when wo, wi are on the same side (reflection) and
//   G2 = max(0, G1(wo) + G1(wi) - 1) when they are on opposite sides (transmission).
// * Visible normals: D_w(m) = G1(w, m) max(0, w.m) D(m) / w.z, for w.z > 0 (callers flip w
//   below the surface). Smith: sampled exactly (GGX: Heitz 2018; Beckmann: Heitz & d'Eon 2014
//   visible-slope inversion, solved to double precision). V-cavity: sampled exactly by the
//   Heitz & d'Eon 2014 V-cavity procedure: m ~ D(m) m.z, then m is swapped with its V-groove
//   partner m' = (-m.x, -m.y, m.z) with probability <w,m'>+ / (<w,m>+ + <w,m'>+). The resulting
//   density is exactly D_w(m) with the V-cavity G1 (pdfVisible).
#pragma once
#include "bsdf/bsdf.h"
#include "bsdf/roughness_bound.h"
#include "core/math.h"

namespace lt {

class Microfacet {
public:
    Microfacet(MicrofacetType type, float alphaU, float alphaV, MaskingModel masking = MaskingModel::Smith);

    MicrofacetType type() const { return type_; }
    MaskingModel masking() const { return masking_; }
    float alphaU() const { return au_; }
    float alphaV() const { return av_; }

    // Distribution of normals; 0 for m.z <= 0. m must be normalised.
    float D(const Vec3& m) const;
    // Smith Lambda(w) (uses |w.z|; independent of the side of w).
    float lambda(const Vec3& w) const;
    // Masking of w for microfacet m (model dependent, see above). 0 if w sees the back of m.
    float G1(const Vec3& w, const Vec3& m) const;
    // Masking-shadowing of the pair (model dependent, see above).
    float G2(const Vec3& wo, const Vec3& wi, const Vec3& m) const;
    // The same from the pair's two G1(w, m) (gO of wo, gI of wi), for a caller that has them.
    float G2(const Vec3& wo, const Vec3& wi, float gO, float gI) const;

    // Density of visible normals D_w(m) (per unit solid angle of m). Requires w.z > 0.
    float pdfVisible(const Vec3& w, const Vec3& m) const;
    // Samples m ~ D_w(m). Requires w.z > 0. The V-cavity model consumes uExtra (its uniform in
    // [0,1) is replaced by a fresh, independent uniform so that the caller can reuse it); the
    // Smith model leaves uExtra untouched.
    Vec3 sampleVisible(const Vec3& w, const Vec2& u, float& uExtra) const;

    // m ~ D(m) m.z (all normals, not only visible ones) and its density.
    Vec3 sampleD(const Vec2& u) const;
    float pdfD(const Vec3& m) const { return D(m) * std::max(0.f, m.z); }

private:
    Vec3 sampleVisibleSmith(const Vec3& w, const Vec2& u) const;
    float G1Smith(const Vec3& w, const Vec3& m) const;
    float G1VCavity(const Vec3& w, const Vec3& m) const;

    MicrofacetType type_;
    MaskingModel masking_;
    float au_, av_;
};

// A microfacet material's lobe as the material defines it (alphas 0 for a smooth material), and
// the alphas it uses for one call: its own, raised by the context's regularisation request
// (bsdf.h) as the lobe resolves it, max(alpha, minAlpha, alpha_hat(tau)) per axis, with
// alpha_hat = alphaForBound for this lobe's distribution and masking, reflection or transmission,
// and eta. An empty request gives the material's own alphas, as they are. delta is true when both
// resolved alphas are below kMinAlpha (the material then behaves as its smooth, delta variant);
// otherwise Microfacet clamps each alpha to at least kMinAlpha.
struct MicrofacetLobe {
    MicrofacetType type;
    MaskingModel masking;
    float alphaU, alphaV;

    struct Resolved {
        float u = 0.f, v = 0.f;
        bool delta = true;
    };
    Resolved resolve(const RegularizationRequest& r, bool transmission, float eta) const {
        float u = std::max(alphaU, r.minAlpha.alphaU), v = std::max(alphaV, r.minAlpha.alphaV);
        if (r.tau < kInf) {
            const float a = alphaForBound(type, masking, r.tau, transmission, eta, r.bound);
            u = std::max(u, a);
            v = std::max(v, a);
        }
        return {u, v, !(std::max(u, v) >= kMinAlpha)};
    }
    Microfacet microfacet(const Resolved& a) const { return Microfacet(type, a.u, a.v, masking); }
};
// Scalar roughness for OPSR: min(alphaU, alphaV) clamped to [0, 1] (the reference attenuation
// file's convention for anisotropic lobes; integrators/transport/opsr.h).
inline float scalarRoughness(float alphaU, float alphaV) {
    return std::clamp(std::min(alphaU, alphaV), 0.f, 1.f);
}

// ---- Fresnel-free microfacet BSDFs (F = 1 for reflection, 1 - F = 1 for refraction) -------
// These are the quantities bounded by maxValueBound() in roughness_bound.h; the materials
// multiply them by the Fresnel factor and their colour.
//
// Torrance-Sparrow reflection D(h) G2 / (4 |wo.z| |wi.z|), h = normalize(wo + wi), for wo, wi on
// the same side (any side); 0 otherwise.
float microfacetReflection(const Microfacet& mf, const Vec3& wo, const Vec3& wi);
// microfacetReflection with the terms it computes on the way, for a material that also needs the
// pair's visible-normal densities (ConductorBxdf): h, D(h) and G1(wo, h), G1(wi, h) are what
// Microfacet::pdfVisible(w, h) is made of, so the value and both densities cost one D and two
// G1 instead of three and four. value is microfacetReflection's, bit for bit; where it is 0 the
// terms after the one that made it 0 are not computed.
struct MicrofacetReflectionTerms {
    Vec3 h{0.f, 0.f, 1.f};
    float d = 0.f, gO = 0.f, gI = 0.f;
    float value = 0.f;
    // Microfacet::pdfVisible(w, h) / (4 w.h) (0 where w.h <= 0): the density of sampling the
    // reflection of w about h, for w = wo (gW = gO) or wi (gW = gI), where value > 0.
    float reflectDensity(const Vec3& w, float gW) const;
};
MicrofacetReflectionTerms microfacetReflectionTerms(const Microfacet& mf, const Vec3& wo, const Vec3& wi);
// Walter et al. 2007 refraction through an interface with relative IOR eta = n_lower / n_upper
// (lower = z < 0 side): wo and wi on opposite sides, generalised half vector
// h = normalize(n_wo wo + n_wi wi) facing +z, value
//   |wi.h| |wo.h| D(h) G2 / (|wi.z| |wo.z| (wi.h + wo.h / etap)^2)  [* 1/etap^2 in Radiance mode]
// with etap = n_wi / n_wo (the header's convention: Radiance = f(wi -> wo)). 0 for eta == 1.
// Computed symmetrically in (wo, wi), so f_rad(wo, wi) etap^2 == f_rad(wi, wo) up to rounding
// of one multiplication.
float microfacetTransmission(const Microfacet& mf, const Vec3& wo, const Vec3& wi, float eta, TransportMode mode);

// ---- rho_hat / rho without evaluations (bsdf.h, PairGeometry) ----------------------------------
// The geometry of a pair as microfacetReflection (same side) or microfacetTransmission (opposite
// sides, with the rough dielectric's own test that the half vector separates the two) see it:
// Lobe::Zero wherever they are 0 for every alpha (their tests before D, and the masking's
// alpha-independent factors: Smith's chi, V-cavity's G1 and G2).
PairGeometry microfacetPairGeometry(const Vec3& wo, const Vec3& wi, float eta, MaskingModel masking);
// D(b) G2(b) / (D(a) G2(a)) for the isotropic alphas a (the plain lobe's) and b (the request's) of
// a Reflection or Transmission pair: 1 where a == b (and for Lobe::Zero), +inf where the quotient
// overflows a float. V-cavity masking does not depend on alpha: its factor is 1.
// density: D(b) G1(b, wo) / (D(a) G1(a, wo)) instead, the ratio of the sampling densities of wi
// (pdfVisible of wo times factors without alpha: the reflection's 1 / (4 wo.h), the refraction's
// Jacobian, the dielectric's Fresnel choice).
float microfacetAlphaRatio(MicrofacetType type, MaskingModel masking, float a, float b, const PairGeometry& g,
                           bool density = false);
// The supremum of microfacetAlphaRatio (not density) over every pair, for isotropic alphas
// a <= b (both clamped to kMinAlpha as Microfacet clamps them): (b / a)^2 for GGX (D's quotient
// (b^2 / a^2) ((a^2 + t) / (b^2 + t))^2 rises with t = tan^2 h towards it; Smith's G2 falls as
// alpha grows, V-cavity's does not depend on it), +inf for Beckmann with b > a (no bound), 1 where
// a == b.
float microfacetAlphaRatioBound(MicrofacetType type, float a, float b);

}  // namespace lt
