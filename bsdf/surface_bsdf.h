// World-space wrapper around a local-frame Bxdf at one surface point (pbrt-v4 style thin BSDF).
// Same direction convention as bsdf.h (wo: towards the previous vertex; wi: next).
// It adds what depends on the geometry: the shading frame, rejection of directions on which the
// geometric and shading normals disagree (light leaks), and the adjoint shading-normal correction
// |wo.ns||wi.ng| / (|wo.ng||wi.ns|) in Importance mode (Veach 1997, sec. 5.3), and for normal- and
// bump-mapped materials (Bxdf::shadowTerminator) the terminator term of the light-side direction
// (shadowTerminatorTerm below).
#pragma once
#include "bsdf/bsdf.h"

namespace lt {

// Test hook: tests switch the adjoint correction off to show that the agreement tests detect it.
inline bool gTestDisableAdjointCorrection = false;

// Estevez et al. 2019, "A Microfacet-Based Shadowing Function to Solve the Bump Terminator
// Problem" (Ray Tracing Gems, ch. 12), as Mitsuba 3's normalmap_helpers.h: with the perturbed
// normal n' at angle theta_n to the unperturbed one, alpha^2 = min(tan^2(theta_n) / 8, 1), and a
// direction at angle theta to the unperturbed normal is attenuated by the Smith G1 of a GGX lobe
// of that alpha, 2 / (1 + sqrt(1 + alpha^2 tan^2 theta)). Arguments: the cosines of n' and of the
// direction with the unperturbed normal (the geometric one here: a mesh's interpolated normal
// differs from it by the tessellation's small angle).
inline float shadowTerminatorTerm(float cosN, float cosW) {
    const float cn2 = cosN * cosN, cw2 = cosW * cosW;
    if (!(cw2 > 0.f)) return 0.f;
    const float alpha2 = cn2 > 0.f ? std::min(0.125f * (1.f - cn2) / cn2, 1.f) : 1.f;
    return 2.f / (1.f + std::sqrt(1.f + alpha2 * std::max(0.f, 1.f - cw2) / cw2));
}

// A view: it refers to the frame and normal it is given (a path vertex's), without copying them.
// A textured material's model at the point (Bxdf::atUv, from the point's uv) lives inside it, so
// it is neither copied nor moved (it is built where it is used: PathVertex::bsdf()).
class SurfaceBsdf {
public:
    SurfaceBsdf(const Bxdf* bxdf, const Frame& shading, const Vec3& ng, const Vec2& uv)
        : bxdf_(bxdf->textured() ? bxdf->atUv(uv, instance_.bytes, sizeof(instance_.bytes)) : bxdf),
          frame_(shading), ng_(ng), terminator_(bxdf->shadowTerminator()) {}
    SurfaceBsdf(const Bxdf*, Frame&&, const Vec3&, const Vec2&) = delete;  // would dangle
    SurfaceBsdf(const Bxdf*, const Frame&, Vec3&&, const Vec2&) = delete;
    SurfaceBsdf(const SurfaceBsdf&) = delete;  // bxdf_ may point into instance_
    SurfaceBsdf& operator=(const SurfaceBsdf&) = delete;

    // Each direction's dot products with ng and the shading normal are computed once and serve the
    // consistency test, the local z (toLocal's n-dot) and the adjoint correction (the same
    // expressions as before, so the same floats). The correction is computed before the virtual
    // call, so that only it has to survive the call (all xmm registers are caller-saved), and it
    // is applied unconditionally: it is 1 in Radiance mode and x * 1 == x exactly.
    BsdfEval eval(const Vec3& woW, const Vec3& wiW, const BsdfContext& ctx) const {
        BsdfEval e;  // the one returned object (NRVO: the Bxdf writes straight into the caller's)
        const Vec3 n = frame_.n, ng = ng_;
        const float woN = glm::dot(woW, n), woG = glm::dot(woW, ng);
        const float wiN = glm::dot(wiW, n), wiG = glm::dot(wiW, ng);
        if (!consistent(woG, woN) || !consistent(wiG, wiN)) return e;
        const float corr = ctx.mode == TransportMode::Importance && !gTestDisableAdjointCorrection
                               ? adjointCorrection(woN, woG, wiN, wiG)
                               : 1.f;
        const Vec3 wo(glm::dot(woW, frame_.s), glm::dot(woW, frame_.t), woN);
        const Vec3 wi(glm::dot(wiW, frame_.s), glm::dot(wiW, frame_.t), wiN);
        const Lambert* lambert = bxdf_->lambert();
        e = lambert ? lambert->eval(wo, wi) : bxdf_->eval(wo, wi, ctx);
        e.f *= corr;
        if (terminator_) [[unlikely]]
            e.f *= ctx.mode == TransportMode::Radiance ? terminator(wiG) : terminator(woG);
        return e;
    }

    bool sample(const Vec3& woW, float uLobe, const Vec2& u, const BsdfContext& ctx, BsdfSample& s) const {
        const float woN = glm::dot(woW, frame_.n), woG = glm::dot(woW, ng_);
        if (!consistent(woG, woN)) return false;
        const Vec3 wo(glm::dot(woW, frame_.s), glm::dot(woW, frame_.t), woN);
        const Lambert* lambert = bxdf_->lambert();
        if (!(lambert ? lambert->sample(wo, u, s) : bxdf_->sample(wo, uLobe, u, ctx, s))) return false;
        const Frame& f = frame_;
        const Vec3 wi = f.toWorld(s.wi);
        s.wi.x = wi.x;  // per component: a Vec3 copy goes through the stack
        s.wi.y = wi.y;
        s.wi.z = wi.z;
        const float wiN = glm::dot(wi, f.n), wiG = glm::dot(wi, ng_);
        if (!consistent(wiG, wiN)) return false;
        if (ctx.mode == TransportMode::Importance && !gTestDisableAdjointCorrection)
            s.weight *= adjointCorrection(woN, woG, wiN, wiG);
        if (terminator_) [[unlikely]]
            s.weight *= ctx.mode == TransportMode::Radiance ? terminator(wiG) : terminator(woG);
        return true;
    }

    // The pair's PairGeometry (bsdf.h) for Bxdf::requestRatio, from the world directions as eval
    // takes them: Lobe::Zero where eval is 0 before the Bxdf (the normals disagree on a side).
    PairGeometry pairGeometry(const Vec3& woW, const Vec3& wiW) const {
        if (bxdf_->lambert()) return {};
        const Vec3 n = frame_.n;
        const float woN = glm::dot(woW, n), wiN = glm::dot(wiW, n);
        if (!consistent(glm::dot(woW, ng_), woN) || !consistent(glm::dot(wiW, ng_), wiN))
            return PairGeometry{0.f, 0.f, 0.f, PairGeometry::Lobe::Zero, false};
        return bxdf_->pairGeometry(Vec3(glm::dot(woW, frame_.s), glm::dot(woW, frame_.t), woN),
                                   Vec3(glm::dot(wiW, frame_.s), glm::dot(wiW, frame_.t), wiN));
    }

    const Bxdf& bxdf() const { return *bxdf_; }  // the model at this point (a textured material's instance)
    const Frame& frame() const { return frame_; }
    const Vec3& ng() const { return ng_; }

private:
    // The geometric and shading normals must agree on which side w is (arguments: w.ng, w.n).
    static bool consistent(float wG, float wN) { return wG * wN > 0.f; }
    // |wo.n wi.ng| / |wo.ng wi.n|, from the dot products.
    static float adjointCorrection(float woN, float woG, float wiN, float wiG) {
        float num = std::abs(woN * wiG);
        float den = std::abs(woG * wiN);
        return den > 0.f ? num / den : 0.f;
    }
    // The terminator term of a light-side direction with w.ng = wG (unit ng and w).
    float terminator(float wG) const { return shadowTerminatorTerm(glm::dot(frame_.n, ng_), wG); }
    BxdfInstance instance_;  // (first: bxdf_'s initialiser writes it; uninitialised where unused)
    const Bxdf* bxdf_;
    const Frame& frame_;
    const Vec3& ng_;
    bool terminator_;  // the material's Bxdf::shadowTerminator
};

}  // namespace lt
