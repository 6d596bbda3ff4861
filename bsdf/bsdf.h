// BSDF interface shared by PT, BPT and VCM.
//
// ---- Direction convention (the only one in this project) -------------------------------
// * All directions are unit vectors pointing AWAY from the surface point.
// * A Bxdf works in the local shading frame: the shading normal is +z, cos(theta) = w.z.
// * `wo` points towards the PREVIOUS vertex of the random walk (where the walk came from);
//   `wi` points towards the NEXT vertex (the direction being sampled or evaluated).
// * Every call takes a BsdfContext (below): the transport mode and a regularisation request.
//   The mode says what the walk carries:
//     Radiance   (camera subpaths): wo points towards the camera side; light flows wi -> wo.
//     Importance (light subpaths):  wo points towards the light side; light flows wo -> wi.
//   eval(wo, wi, ctx) returns the value to multiply by |cos(wi)| in the walk's throughput:
//   f(wi -> wo) for Radiance, the adjoint f*(wo, wi) = f(wo -> wi) for Importance. The two differ
//   only for refraction (the 1/eta^2 radiance scaling is applied in Radiance mode only).
//   The shading-normal adjoint correction is NOT in the Bxdf: see Bsdf (world-space wrapper).
// * pdfFwd: solid-angle density of sampling wi given wo. pdfRev: density of sampling wo given wi
//   (what the walk in the other direction would have used). Both at this vertex.
// * A delta lobe (smooth conductor/dielectric, alpha below kMinAlpha) is never returned by eval
//   (f = 0, pdfs = 0); sample() returns it with the Delta flag, weight = f|cos|/pdf, and pdfFwd /
//   pdfRev set to the discrete probability of choosing that lobe (the walk turns it into the
//   generalised density of integrators/transport/path.h, "Delta vertices", with |cos| and
//   eta^2 = BsdfSample::eta^2).
#pragma once
#include <cmath>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <utility>
#include "core/math.h"
#include "core/sampling.h"

namespace lt {

enum class TransportMode { Radiance, Importance };

enum BsdfFlags : uint32_t {
    kNone = 0,
    kReflection = 1u << 0,
    kTransmission = 1u << 1,
    kDiffuse = 1u << 2,
    kGlossy = 1u << 3,
    kDelta = 1u << 4,
};

// The form of the maximum-value bound of a microfacet lobe (bsdf/roughness_bound.h).
enum class BoundForm : uint8_t { Tight, Published };

// Microfacet alphas below this are treated as a delta lobe (smooth surface).
inline constexpr float kMinAlpha = 1e-4f;

// A pair of microfacet alphas (u: tangent axis, v: bitangent axis).
struct Roughness {
    float alphaU = 0.f, alphaV = 0.f;
};

// What a regulariser asks of one BSDF call (JG19, KD13, OPSR: issues 13-15). Empty by default,
// and an empty request leaves every BSDF exactly as its material defines it. The caller states
// what it wants; each lobe resolves it with its own distribution, masking model and eta, which
// the caller does not know (bsdf/microfacet.h, MicrofacetLobe::resolve):
//   minAlpha  a microfacet lobe uses alpha' = max(alpha, minAlpha) per axis (OPSR's accumulated
//             roughness, or any alpha a regulariser computed itself);
//   tau       a bound on the value of f (JG19 Sec. 3.2): a microfacet lobe uses
//             alpha' = max(alpha, alpha_hat(tau)) per axis, alpha_hat = alphaForBound
//             (roughness_bound.h) of its distribution, masking, and reflection or transmission
//             with its eta (eval: the lobe of the pair; sample: see the dielectric);
//   cone      half-angle eps in radians of KD13's cone mollifier (Eq. 5): a smooth conductor
//             or dielectric (whatever minAlpha and tau say) replaces each delta lobe by its
//             weight spread uniformly over the cone of half-angle eps around the ideal direction
//             (bsdf/cone_mollifier.h); the densities stay 0 (the walks never sample it), and
//             valueBound is 1 / Omega(eps). With tau too: JG19 with --reg-specular cone.
//   bound     how tau becomes alpha_hat: the lobe's true supremum (Tight) or JG19's Eqs. 8-9
//             (Published, to reproduce the paper); roughness_bound.h
//   compensate  a smooth conductor or dielectric made rough keeps the albedo of its delta lobes,
//             an isotropic glossy one made rougher its own (bsdf/energy_compensation.h); its
//             alpha_hat then bounds the compensated value
// A smooth (delta) conductor or dielectric whose resolved alpha reaches kMinAlpha becomes a rough
// GGX/Smith lobe. Diffuse and rough lobes ignore the cone, diffuse lobes the whole request.
// bound and compensate only qualify the other fields: they alone make no request.
struct RegularizationRequest {
    Roughness minAlpha;  // {0, 0}: none
    float tau = kInf;    // +inf: none
    float cone = 0.f;    // 0: none
    BoundForm bound = BoundForm::Tight;
    bool compensate = true;
    bool empty() const {
        return !(minAlpha.alphaU > 0.f) && !(minAlpha.alphaV > 0.f) && !(tau < kInf) && !(cone > 0.f);
    }
};

// The context of one BSDF call, besides the directions (Mitsuba 3's BSDFContext is the model):
// the transport mode and the regularisation request. A TransportMode converts to the context
// without a request.
struct BsdfContext {
    TransportMode mode = TransportMode::Radiance;
    RegularizationRequest reg;
    // eval() may leave the densities 0: the caller reads the value only (a regulariser's ratio
    // rho_hat / rho, evaluated per technique). The value is the same bit for bit.
    bool valueOnly = false;
    // sample() may return after the direction: the caller reads wi only (and whether the sample
    // was drawn), to decide whether the full sample, with the same numbers, is worth its
    // densities and weight. Where it returns true the full sample's wi is the same bit for bit,
    // and where it returns false so does the full sample.
    bool directionOnly = false;
    constexpr BsdfContext(TransportMode m = TransportMode::Radiance) : mode(m) {}
    constexpr BsdfContext(TransportMode m, const RegularizationRequest& r) : mode(m), reg(r) {}
    // This context for a value-only evaluation.
    constexpr BsdfContext valueOnlyCopy() const {
        BsdfContext c = *this;
        c.valueOnly = true;
        return c;
    }
    // This context for a direction-only sample.
    constexpr BsdfContext directionOnlyCopy() const {
        BsdfContext c = *this;
        c.directionOnly = true;
        return c;
    }
};
// The two contexts without a request, for the walks and connections (a reference to one of
// these is passed, no context is built per call).
inline constexpr BsdfContext kRadianceContext{TransportMode::Radiance};
inline constexpr BsdfContext kImportanceContext{TransportMode::Importance};
inline const BsdfContext& plainContext(TransportMode mode) {
    return mode == TransportMode::Radiance ? kRadianceContext : kImportanceContext;
}

struct BsdfEval {
    Color f{0.f};
    SolidAnglePdf pdfFwd, pdfRev;
};

struct BsdfSample {
    Vec3 wi{0.f};
    Color weight{0.f};  // f * |cos(wi)| / pdfFwd (for delta lobes: f|cos| / P(lobe))
    SolidAnglePdf pdfFwd, pdfRev;
    uint32_t lobe = kNone;  // flags of the sampled lobe
    float eta = 1.f;        // relative IOR crossed (1 for reflection)
};

enum class MicrofacetType { GGX, Beckmann };
enum class MaskingModel { Smith, VCavity };

// What of a microfacet lobe's value between one pair of directions does not depend on its alphas
// (isotropic lobes): tan^2 of the polar angles of the pair's half vector (a reflection's, or a
// refraction's generalised one) and of the two directions. The rest of the value (Fresnel,
// colour, a refraction's Jacobian and 1/eta^2, the shading-normal correction) is the same under
// every alpha, so rho_hat / rho under a request is D' G2' / (D G2) of these alone
// (Bxdf::requestRatio): a regulariser's ratio at a vertex without evaluating the BSDF twice
// (OPSR's Eq. 12 factors at every inner glossy vertex of a connection, opsr.h (5)).
struct PairGeometry {
    enum class Lobe : uint8_t {
        Unavailable,   // the model has no such form (anisotropic, not microfacet, delta): evaluate
        Zero,          // the pair's value is 0 under every request (sides, chi, no refraction)
        Reflection,
        Transmission,
    };
    // (no default member initializers: a trivial type, for SubpathState's union; PairGeometry{}
    // is Unavailable)
    float tanH2, tanO2, tanI2;
    Lobe lobe;
    bool woAbove;  // wo.z > 0 (a compensated refraction's side of the light, energy_compensation.h)
    bool available() const { return lobe != Lobe::Unavailable; }
    // |cos| of wo and wi (an energy compensation's light-side cosine).
    float cosO() const { return 1.f / std::sqrt(1.f + tanO2); }
    float cosI() const { return 1.f / std::sqrt(1.f + tanI2); }
};

// Lambert's model (f = R / pi, cosine-weighted sampling), the one implementation: the diffuse
// Bxdf's virtual functions and SurfaceBsdf's inline path for it both call these.
struct Lambert {
    Color r;  // reflectance
    Color f;  // r / pi, the value of f

    // The cosines are read once into locals: for all the compiler knows the output may alias wo,
    // so reading wo.z after storing to it would be a reload (and a repeated > 0 test).
    BsdfEval eval(const Vec3& wo, const Vec3& wi) const {
        const float cosO = wo.z, cosI = wi.z;
        if (!(cosO > 0.f) || !(cosI > 0.f)) return BsdfEval{};
        return BsdfEval{f, SolidAnglePdf(cosI * kInvPi), SolidAnglePdf(cosO * kInvPi)};  // cos/pi, cos > 0 known
    }
    bool sample(const Vec3& wo, const Vec2& u, BsdfSample& out) const {
        const float cosO = wo.z;
        if (!(cosO > 0.f)) return false;
        const Vec3 wi = sampleCosineHemisphere(u);
        if (!(wi.z > 0.f)) return false;
        out.wi.x = wi.x;  // per component: a Vec3 copy goes through the stack
        out.wi.y = wi.y;
        out.wi.z = wi.z;
        out.weight = r;  // (R/pi) cos / (cos/pi)
        out.pdfFwd = SolidAnglePdf(wi.z * kInvPi);  // cos/pi, cos > 0 known
        out.pdfRev = SolidAnglePdf(cosO * kInvPi);
        out.lobe = kReflection | kDiffuse;
        out.eta = 1.f;
        return true;
    }
};

// Storage for a material's model at one surface point (Bxdf::atUv): a textured material looks its
// textures up at the point's uv and constructs the model with those values here (pbrt-v4 builds a
// BSDF per intersection the same way). kInstanceBytes holds any leaf model; a two-sided adapter
// keeps its inner model's instance in kInnerInstanceBytes of its own.
inline constexpr size_t kInstanceBytes = 384, kInnerInstanceBytes = 288;  // (a two-sided blend of two textured models fits: bsdf/blend.cpp)
struct alignas(16) BxdfInstance {
    unsigned char bytes[kInstanceBytes];
};

class Bxdf;
// Constructs the instance T in Bxdf::atUv's storage of `capacity` bytes.
template <class T, class... Args>
const Bxdf* emplaceInstance(void* storage, size_t capacity, Args&&... args) {
    static_assert(alignof(T) <= alignof(BxdfInstance));
    if (sizeof(T) > capacity) throw std::logic_error("Bxdf::atUv: instance storage too small");
    return new (storage) T(std::forward<Args>(args)...);
}

// Local-frame BSDF model. Stateless after construction, shared by all hits on a material.
class Bxdf {
public:
    virtual ~Bxdf() = default;
    virtual BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const = 0;
    // uLobe chooses between lobes (reflection/transmission), u the direction.
    virtual bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const = 0;
    // Union of the flags of all lobes.
    virtual uint32_t flags() const = 0;
    // Scalar roughness in [0,1] for accumulated roughness (OPSR, integrators/transport/opsr.h, the
    // reference attenuation file's convention): 0 delta, 1 diffuse, microfacet: min(alpha_u, alpha_v)
    // clamped to [0,1].
    virtual float roughness() const = 0;
    // The microfacet alphas (0,0 for non-microfacet lobes).
    virtual Roughness alpha() const { return {}; }
    // Whether some point's lobe differs along the tangent and the bitangent: its shading frame's
    // tangent must then be the surface's dp/du, as Mitsuba's (core/scene.cpp).
    virtual bool anisotropic() const {
        const Roughness a = alpha();
        return a.alphaU != a.alphaV;
    }
    virtual std::string name() const = 0;
    bool isDelta() const { return (flags() & (kDiffuse | kGlossy)) == 0; }
    // Whether the BSDF is still only delta lobes when evaluated with ctx's request (a smooth
    // conductor or dielectric stays a delta while the request's resolved alpha is below kMinAlpha;
    // such a vertex cannot be a regularised connection end: its eval is 0 for every pair).
    virtual bool deltaUnder(const BsdfContext&) const { return isDelta(); }
    // rho_bar: an upper bound on the value of f over all direction pairs, with ctx's request
    // resolved as eval resolves it (JG19 Eqs. 8-9 for microfacet lobes, without Fresnel and
    // colour, which are <= 1; R / pi for Lambert; +inf for a lobe that is still a delta). JG19's
    // quality heuristic (Eq. 17) compares connections by it.
    virtual float valueBound(const BsdfContext& ctx) const = 0;
    // The pair's PairGeometry (local frame, wo and wi as eval's); Lobe::Unavailable where the
    // model has no such form (the default), and then requestRatio is not to be asked.
    virtual PairGeometry pairGeometry(const Vec3& /*wo*/, const Vec3& /*wi*/) const { return {}; }
    // rho_hat / rho of a pair from its available geometry: the value under request r over the
    // value without one (each channel's ratio is the same), as eval would give them up to
    // rounding. Exactly 1 where the request changes no alpha of the pair's lobe or the value is 0
    // under every request (Lobe::Zero); where only the plain value underflows (a Beckmann lobe far
    // from its peak) large or +inf.
    // (ctx: the request and the transport mode, whose light side an energy-compensated lobe's
    // value depends on: energy_compensation.h)
    virtual float requestRatio(const PairGeometry& /*g*/, const BsdfContext& /*ctx*/) const { return 1.f; }
    // The same for the sampling density of wi given wo (eval's pdfFwd): its only factor that
    // depends on alpha is the visible-normal density of wo, D(h) G1(wo, h), so the ratio is
    // D' G1'(wo) / (D G1(wo)) (a regulariser's own density at a connection end, OPSR's path tracer).
    virtual float requestPdfRatio(const PairGeometry& /*g*/, const RegularizationRequest& /*r*/) const { return 1.f; }
    // An upper bound on requestRatio over every pair (both lobes), or +inf where there is none the
    // model knows: (b / a)^2 for an isotropic GGX lobe whose alpha a request r raises to b (D's
    // quotient is at most that, reached in the tails; the request's masking G2' <= G2), +inf for a
    // Beckmann lobe made rougher (the quotient grows as exp(tan^2 (1/a^2 - 1/b^2))), an anisotropic
    // or delta lobe, or a model without pair geometry; 1 where r changes nothing. Where it is finite
    // the material's own sample covers the regularised value with a weight at most this many times
    // its own (f' / p = (f' / f) f / p): OPSR's path tracer then lets the walk's own sample be the
    // regularised emitter-hit technique (integrators/transport/opsr.h (4)).
    virtual float requestRatioBound(const RegularizationRequest& /*r*/) const { return kInf; }
    // Non-null when this is the plain diffuse model: SurfaceBsdf then evaluates and samples it
    // inline (no virtual call, no spills around one), as pbrt-v4 dispatches on a type tag. The
    // diffuse surface is the most common of all; every other model goes through the virtual calls.
    const Lambert* lambert() const { return lambert_; }
    // Whether the model's parameters vary over the surface (textures): eval and sample then belong
    // to atUv's instance (SurfaceBsdf asks for it), and the functions above and below describe the
    // material as a whole: flags, roughness, alpha and continuation are the material's, the bounds
    // hold for every point (from the textures' maxima).
    bool textured() const { return textured_; }
    // The model at a point with texture coordinates uv, constructed in `storage` (at least
    // `capacity` bytes, 16-byte aligned; trivially destructible, so it is never destroyed), or this
    // model where it is not textured. The instance is only evaluated and sampled.
    virtual const Bxdf* atUv(const Vec2& /*uv*/, void* /*storage*/, size_t /*capacity*/) const { return this; }
    // The probability that a random walk continues from a vertex on this material (Russian
    // roulette, as SmallVCM's ContinuationProb): the largest component of the scale of its lobes
    // (reflectance, or the larger of the specular reflectance and transmittance), at most 1.
    // Independent of the directions, so that the same factor enters a vertex's density in both
    // walk directions (the walks and connections multiply it into the MIS densities, path.h); a
    // Lambert sample's weight over it is at most 1 in every channel, so no throughput grows.
    float continuation() const { return continuation_; }
    // Mitsuba's normalmap and bumpmap use_shadowing_function (bsdf/normal_perturbation.h):
    // SurfaceBsdf multiplies the value by Estevez et al.'s terminator term of the light-side
    // direction at points of this material.
    bool shadowTerminator() const { return shadowTerminator_; }
    // valueBound without a request, and with the smallest one that makes a smooth BSDF rough
    // (alphas raised to kMinAlpha; 0 where none can: index-matched glass), cached by each model's
    // constructor: JG19's walks read them at every vertex (integrators/transport/jg19.h (2), (4)).
    // Each in the bound form f of the caller's requests.
    float plainBound(BoundForm f = BoundForm::Tight) const { return plainBound_[int(f)]; }
    float smoothestBound(BoundForm f = BoundForm::Tight) const { return smoothestBound_[int(f)]; }
    // The largest bound under which a request (a bound alone) changes the BSDF, 0 where none does
    // (JG19's diffusion heuristic, jg19.h (4)): plainBound for a glossy lobe (any bound below its
    // own makes it rougher), smoothestBound for a delta one, 0 for a lobe no request changes (a
    // diffuse one).
    float changeableBound(BoundForm f = BoundForm::Tight) const { return changeableBound_[int(f)]; }

protected:
    // The last statement of each model's constructor (valueBound is then the model's own).
    void cacheBounds() {
        for (BoundForm form : {BoundForm::Tight, BoundForm::Published}) {
            const int i = int(form);
            BsdfContext plain(TransportMode::Radiance);
            plain.reg.bound = form;
            plainBound_[i] = valueBound(plain);
            BsdfContext smoothest = plain;
            smoothest.reg.minAlpha = {kMinAlpha, kMinAlpha};
            const float c = valueBound(smoothest);
            smoothestBound_[i] = std::isfinite(c) ? c : 0.f;
            const uint32_t f = flags();
            changeableBound_[i] = (f & kGlossy) ? plainBound_[i] : (f & kDelta) ? smoothestBound_[i] : 0.f;
        }
    }
    const Lambert* lambert_ = nullptr;
    bool textured_ = false;
    bool shadowTerminator_ = false;
    float continuation_ = 1.f;  // set by each model's constructor
    float plainBound_[2] = {0.f, 0.f}, smoothestBound_[2] = {0.f, 0.f}, changeableBound_[2] = {0.f, 0.f};
};

// min(1, max(0, the largest channel of c)): the continuation probability of a lobe scaled by c.
inline float continuationOf(const Color& c) { return std::min(1.f, std::max(0.f, maxComp(c))); }

using BxdfPtr = std::shared_ptr<const Bxdf>;

// ---- Factories (the scene loader builds materials through these) ----
BxdfPtr makeDiffuse(const Color& reflectance);
// eta, k: complex IOR of the conductor relative to the exterior (RGB).
BxdfPtr makeConductor(const Color& eta, const Color& k, const Color& specularReflectance);
BxdfPtr makeRoughConductor(MicrofacetType dist, float alphaU, float alphaV, const Color& eta, const Color& k,
                           const Color& specularReflectance, MaskingModel masking = MaskingModel::Smith);
// eta = int_ior / ext_ior.
BxdfPtr makeDielectric(float eta, const Color& specularReflectance = Color(1.f),
                       const Color& specularTransmittance = Color(1.f));
BxdfPtr makeRoughDielectric(MicrofacetType dist, float alphaU, float alphaV, float eta,
                            const Color& specularReflectance = Color(1.f),
                            const Color& specularTransmittance = Color(1.f),
                            MaskingModel masking = MaskingModel::Smith);
// Mitsuba 3's plastic and roughplastic (bsdf/plastic.cpp): a dielectric coating, eta = int_ior /
// ext_ior, over a Lambertian base; nonlinear: the internal scattering's colour shift. The rough
// coating is Smith-masked and isotropic; alpha below kMinAlpha gives the smooth model.
BxdfPtr makePlastic(float eta, const Color& diffuseReflectance = Color(0.5f),
                    const Color& specularReflectance = Color(1.f), bool nonlinear = false);
BxdfPtr makeRoughPlastic(MicrofacetType dist, float alpha, float eta, const Color& diffuseReflectance = Color(0.5f),
                         const Color& specularReflectance = Color(1.f), bool nonlinear = false);
// Mitsuba's twosided: the inner BSDF on both sides (wo, wi mirrored when wo.z < 0). A two-sided
// model made two-sided again is itself.
BxdfPtr makeTwoSided(BxdfPtr inner);
// Lambert's model with its reflectance from a texture at the point's uv (bsdf/diffuse.cpp), as
// Mitsuba's diffuse takes a texture (values above 1 are kept, as a constant's are).
class Texture;
BxdfPtr makeTexturedDiffuse(std::shared_ptr<const Texture> reflectance);
// plastic (rough false) or roughplastic whose diffuse_reflectance is a texture (bsdf/plastic.cpp).
BxdfPtr makeTexturedPlastic(bool rough, MicrofacetType dist, float alpha, float eta,
                            std::shared_ptr<const Texture> diffuseReflectance, const Color& specularReflectance,
                            bool nonlinear);
// Mitsuba 3's thindielectric (eta = int_ior / ext_ior), null and polarizer as its rgb variants
// render them (transmittance / 2, straight through): two-sided delta sheets, bsdf/thin_dielectric.cpp.
BxdfPtr makeThinDielectric(float eta, const Color& specularReflectance = Color(1.f),
                           const Color& specularTransmittance = Color(1.f));
BxdfPtr makeNull();
BxdfPtr makePolarizer(const Color& transmittance = Color(1.f));
// Mitsuba 3's blendbsdf: (1 - weight) first + weight second (bsdf/blend.cpp); weight in [0, 1], or
// a texture (its luminance clamped to [0, 1] at the point's uv) when weightTexture is not null.
BxdfPtr makeBlend(BxdfPtr first, BxdfPtr second, float weight, std::shared_ptr<const Texture> weightTexture = nullptr);
// Mitsuba 3's pplastic as its rgb variants render it (bsdf/pplastic.cpp): a microfacet reflection
// specR F D G / (4 cos cos) plus the base diffR (1 - F(cos_o)) (1 - F(cos_i)) / pi, eta = int_ior / ext_ior.
BxdfPtr makePolarizedPlastic(MicrofacetType dist, float alphaU, float alphaV, float eta,
                             const Color& diffuseReflectance = Color(0.5f), const Color& specularReflectance = Color(1.f));

// Textured parameters of a conductor or dielectric (Mitsuba 3's roughconductor, conductor,
// roughdielectric and dielectric plugins take textures for these): null where the parameter is
// the constant the factory is given. Scalar parameters (the alphas) read a texture's grey value or
// luminance (scalarOf, core/texture/texture.h). A material's model at a point (atUv) is the
// untextured model of the point's values, bit for bit; over the material its flags are the union
// over the alphas' range and its bounds hold at every point (bsdf/conductor.cpp).
struct ConductorTextures {
    std::shared_ptr<const Texture> alphaU, alphaV, eta, k, specularReflectance;
    float extEta = 1.f;  // eta and k textures are divided by it (relative to the exterior)
};
// rough false: Mitsuba's conductor (smooth; the alphas unused).
BxdfPtr makeTexturedConductor(bool rough, MicrofacetType dist, float alphaU, float alphaV, const Color& eta,
                              const Color& k, const Color& specularReflectance, MaskingModel masking,
                              const ConductorTextures& textures);
struct DielectricTextures {
    std::shared_ptr<const Texture> alphaU, alphaV, specularReflectance, specularTransmittance;
};
// rough false: Mitsuba's dielectric (smooth; the alphas unused).
BxdfPtr makeTexturedDielectric(bool rough, MicrofacetType dist, float alphaU, float alphaV, float eta,
                               const Color& specularReflectance, const Color& specularTransmittance,
                               MaskingModel masking, const DielectricTextures& textures);
// plastic or roughplastic with textured specular_reflectance (and diffuse_reflectance, either may
// be null: the constant is used); Mitsuba's roughplastic takes no texture for alpha.
BxdfPtr makeTexturedPlastic(bool rough, MicrofacetType dist, float alpha, float eta,
                            std::shared_ptr<const Texture> diffuseReflectance, const Color& diffuseConstant,
                            std::shared_ptr<const Texture> specularReflectance, const Color& specularConstant,
                            bool nonlinear);
// Oren and Nayar's rough diffuse model as Mitsuba 0.6's roughdiffuse (bsdf/rough_diffuse.cpp):
// reflectance and alpha (RMS slope; sigma = alpha / sqrt(2)), each a constant or a texture (null:
// the constant); fast: the qualitative model (use_fast_approx). Cosine-weighted sampling.
BxdfPtr makeRoughDiffuse(const Color& reflectance, float alpha, bool fast,
                         std::shared_ptr<const Texture> reflectanceTexture = nullptr,
                         std::shared_ptr<const Texture> alphaTexture = nullptr);

}  // namespace lt
