// Mitsuba 3's normalmap and bumpmap BSDF adapters (src/bsdfs/normalmap.cpp, bumpmap.cpp; their
// plugin documentation is the spec): a nested BSDF evaluated in a shading frame perturbed at each
// surface point. The perturbation is a property of the hit, not of the BSDF evaluation: the scene
// asks for the perturbed frame where it computes a hit's shading frame (core/scene.cpp, only for
// shapes whose material has one) and hands the nested model to the walks, so everything downstream
// (SurfaceBsdf's side tests and its adjoint shading-normal correction in Importance mode, every
// integrator's densities) sees one consistent frame and unperturbed scenes pay nothing.
//
// Frames (Mitsuba's conventions):
//  * the unperturbed shading frame sh is Gram-Schmidt of dp/du against the shading normal n:
//    s = normalize(dpdu - n (n . dpdu)) (Frame(n).s where dp/du is zero or parallel to n),
//    t = n x s (SurfaceInteraction::initialize_sh_frame);
//  * normalmap: the texture's RGB c gives the normal m = 2c - 1 in sh's local coordinates; the
//    perturbed frame is n' = normalize(m), s' = normalize(e_x - n' n'_x), t' = n' x s' in sh's
//    local coordinates (so the tangent follows dp/du: an identity map (0.5, 0.5, 1) gives sh itself);
//  * bumpmap: g = scale * (dh/du, dh/dv) of the texture's luminance (Texture::evalGrad1);
//    dpdu' = dpdu + n (g_u - n . dpdu), dpdv' = dpdv + n (g_v - n . dpdv), n' = normalize(dpdu' x dpdv')
//    turned to the geometric normal's side, then in sh's local coordinates as for normalmap;
//  * flip_invalid_normals (Mitsuba's default true, after Schuessler et al. 2017): where the
//    arrival direction wo (towards the previous vertex) lies on one side of sh and the other of m,
//    m becomes (-m_x, -m_y, m_z);
//  * use_shadowing_function (Mitsuba's default true): Estevez et al. 2019's terminator term of the
//    light-side direction multiplies the value (SurfaceBsdf, shadowTerminatorTerm).
// A perturbation whose normal is not finite or zero (a texel (0.5, 0.5, 0.5)) leaves sh as it is.
#pragma once
#include <memory>
#include "bsdf/bsdf.h"

namespace lt {

class Texture;

// Mitsuba's shading frame from the shading normal n (unit) and dp/du.
inline Frame tangentFrame(const Vec3& n, const Vec3& dpdu) {
    const Vec3 s = dpdu - n * glm::dot(n, dpdu);
    const float len2 = glm::dot(s, s);
    if (!(len2 > 1e-20f) || !std::isfinite(len2)) return Frame(n);
    const Vec3 su = s / std::sqrt(len2);
    return Frame(su, glm::cross(n, su), n);
}

// What a perturbation reads at a hit (world space): the unperturbed shading frame (tangentFrame),
// the surface's dp/du and dp/dv, the geometric normal, the texture coordinates and the walk's
// arrival direction (unit, pointing away from the surface).
struct TangentSpace {
    Frame shading;
    Vec3 dpdu, dpdv, ng;
    Vec2 uv;
    Vec3 wo;
};

// A Bxdf adapter whose model is the nested one (every Bxdf call forwards to it, in whatever frame
// the caller gives) and which knows the perturbed frame at a point. It counts as textured, so that
// SurfaceBsdf takes the nested model (or its instance at uv) from atUv and evaluates it directly
// in the hit's frame (the scene's perturbed one); the forwarding serves code that holds the adapter.
class NormalPerturbation : public Bxdf {
public:
    NormalPerturbation(BxdfPtr nested, bool flipInvalid, bool shadowing);
    const BxdfPtr& nested() const { return nested_; }
    bool flipInvalid() const { return flipInvalid_; }
    // The perturbed shading frame (world space, orthonormal, right-handed) at the point.
    Frame frame(const TangentSpace& ts) const;
    // The perturbed normal in the unperturbed frame's local coordinates (not normalised, before
    // the flip): the normal map's 2c - 1, the bump map's n'.
    virtual Vec3 localNormal(const TangentSpace& ts) const = 0;

    BsdfEval eval(const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) const override {
        return nested_->eval(wo, wi, ctx);
    }
    bool sample(const Vec3& wo, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& out) const override {
        return nested_->sample(wo, uLobe, u, ctx, out);
    }
    uint32_t flags() const override { return nested_->flags(); }
    float roughness() const override { return nested_->roughness(); }
    Roughness alpha() const override { return nested_->alpha(); }
    bool anisotropic() const override { return nested_->anisotropic(); }
    bool deltaUnder(const BsdfContext& ctx) const override { return nested_->deltaUnder(ctx); }
    float valueBound(const BsdfContext& ctx) const override { return nested_->valueBound(ctx); }
    PairGeometry pairGeometry(const Vec3& wo, const Vec3& wi) const override { return nested_->pairGeometry(wo, wi); }
    float requestRatio(const PairGeometry& g, const BsdfContext& ctx) const override {
        return nested_->requestRatio(g, ctx);
    }
    float requestPdfRatio(const PairGeometry& g, const RegularizationRequest& r) const override {
        return nested_->requestPdfRatio(g, r);
    }
    float requestRatioBound(const RegularizationRequest& r) const override { return nested_->requestRatioBound(r); }
    const Bxdf* atUv(const Vec2& uv, void* storage, size_t capacity) const override {
        return nested_->atUv(uv, storage, capacity);
    }

private:
    BxdfPtr nested_;
    bool flipInvalid_;
};

// Mitsuba's normalmap: `normalmap` an RGB texture (raw values in [0, 1]), the nested BSDF.
BxdfPtr makeNormalMap(std::shared_ptr<const Texture> normalmap, BxdfPtr nested, bool flipInvalid = true,
                      bool shadowing = true);
// Mitsuba's bumpmap: a height texture (its luminance), `scale` the gradient multiplier.
BxdfPtr makeBumpMap(std::shared_ptr<const Texture> height, float scale, BxdfPtr nested, bool flipInvalid = true,
                    bool shadowing = true);

}  // namespace lt
