// World-space wrapper around a local-frame Bxdf at one surface point (pbrt-v4 style thin BSDF).
// Same direction convention as bsdf.h (wo: towards the previous vertex; wi: next).
// It adds what depends on the geometry: the shading frame, rejection of directions on which the
// geometric and shading normals disagree (light leaks), and the adjoint shading-normal correction
// |wo.ns||wi.ng| / (|wo.ng||wi.ns|) in Importance mode (Veach 1997, sec. 5.3).
#pragma once
#include "bsdf/bsdf.h"

namespace lt {

// Test hook: tests switch the adjoint correction off to show that the agreement tests detect it.
inline bool gTestDisableAdjointCorrection = false;

// A view: it refers to the frame and normal it is given (a path vertex's), without copying them.
class SurfaceBsdf {
public:
    SurfaceBsdf(const Bxdf* bxdf, const Frame& shading, const Vec3& ng) : bxdf_(bxdf), frame_(shading), ng_(ng) {}
    SurfaceBsdf(const Bxdf*, Frame&&, const Vec3&) = delete;  // would dangle
    SurfaceBsdf(const Bxdf*, const Frame&, Vec3&&) = delete;

    BsdfEval eval(const Vec3& woW, const Vec3& wiW, TransportMode mode, const Roughness* rough = nullptr) const {
        BsdfEval e;
        if (!consistent(woW) || !consistent(wiW)) return e;
        e = bxdf_->eval(frame_.toLocal(woW), frame_.toLocal(wiW), mode, rough);
        if (mode == TransportMode::Importance && !gTestDisableAdjointCorrection) e.f *= adjointCorrection(woW, wiW);
        return e;
    }

    bool sample(const Vec3& woW, float uLobe, const Vec2& u, TransportMode mode, BsdfSample& s,
                const Roughness* rough = nullptr) const {
        if (!consistent(woW)) return false;
        if (!bxdf_->sample(frame_.toLocal(woW), uLobe, u, mode, s, rough)) return false;
        s.wi = frame_.toWorld(s.wi);
        if (!consistent(s.wi)) return false;
        if (mode == TransportMode::Importance && !gTestDisableAdjointCorrection) s.weight *= adjointCorrection(woW, s.wi);
        return true;
    }

    const Bxdf& bxdf() const { return *bxdf_; }
    const Frame& frame() const { return frame_; }
    const Vec3& ng() const { return ng_; }

private:
    // The geometric and shading normals must agree on which side w is.
    bool consistent(const Vec3& w) const { return glm::dot(w, ng_) * glm::dot(w, frame_.n) > 0.f; }
    float adjointCorrection(const Vec3& wo, const Vec3& wi) const {
        float num = std::abs(glm::dot(wo, frame_.n) * glm::dot(wi, ng_));
        float den = std::abs(glm::dot(wo, ng_) * glm::dot(wi, frame_.n));
        return den > 0.f ? num / den : 0.f;
    }
    const Bxdf* bxdf_;
    const Frame& frame_;
    const Vec3& ng_;
};

}  // namespace lt
