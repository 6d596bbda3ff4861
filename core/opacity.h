// Opacity masks (Mitsuba 3's `mask` BSDF) as stochastic alpha testing in the intersection itself.
//
// Mitsuba's mask is the nested BSDF times the opacity o plus a null (pass-through) lobe of weight
// 1 - o. Here the opacity belongs to the shape: a candidate hit on a masked shape is accepted with
// probability o(uv), decided by a hash of the ray (origin, direction) and the hit (geometry,
// primitive, which root of a sphere), and a rejected hit is skipped by the traversal (Embree's
// intersect and occluded filter functions for meshes, the analytic spheres' own test). Each
// segment's visibility is then a Bernoulli variable whose mean is the transmittance 1 - o, and a
// vertex on the shape exists with probability o, which multiplies its (nested) BSDF by o in
// expectation: every estimator stays unbiased without any change to the transport or its MIS
// (the weights, functions of the path alone, still sum to 1). Shadow rays, walks, connections and
// photons see the same cut-outs, and the decision, a function of the ray alone, is the same for
// any thread count.
//
// Unlike Mitsuba's `path` integrator, a pass-through is not a bounce (max_depth counts scattering
// vertices only, as Mitsuba's volpath counts null interactions) and shadow rays pass cut-outs.
#pragma once
#include <cstdint>
#include <deque>
#include "core/math.h"
#include "core/texture/texture.h"

struct RTCGeometryTy;  // Embree's RTCGeometry (kept out of the scene description's includes)

namespace lt {

// A shape's opacity: `value`, or the texture's scalar (Mitsuba's eval_1: scalarOf) at the hit's
// uv clamped to [0, 1] as Mitsuba's mask clamps it. Opaque by default.
struct Opacity {
    float value = 1.f;
    TexturePtr texture;
    bool masked() const { return texture != nullptr || value < 1.f; }
    float eval(const Vec2& uv) const {
        if (!texture) return value;
        const float o = scalarOf(texture->eval(uv));
        return o > 0.f ? (o < 1.f ? o : 1.f) : 0.f;  // (NaN -> 0)
    }
};

// The mask's decision for one candidate hit: true with probability op.eval(uv) over rays, a
// deterministic function of the ray (org, dir as given to the traversal), the geometry id, the
// primitive id, the instance id (Embree's instID, RTC_INVALID_GEOMETRY_ID outside instances) and
// `root` (a sphere's 0 entering, 1 leaving; 0 for triangles). A uniform u in [0, 1) from a 64-bit
// hash of those words; accepted when u < opacity (always at 1, never at 0).
bool acceptMaskedHit(const Opacity& op, const Vec2& uv, const float org[3], const float dir[3], unsigned geomId,
                     unsigned primId, unsigned instId, unsigned root);

// Mitsuba's sphere parameterisation of a unit direction from the centre in the sphere's frame:
// u = phi / (2 pi) with phi in [0, 2 pi), v = theta / pi (as Scene::intersect's hit uv).
Vec2 sphereUv(const Vec3& unitDir);

// The decision for a hit at distance t on the sphere (center in double precision as the scene's
// spheres; toLocal: world -> the sphere's frame, SphereDesc::toLocal) of the ray (org, dir): its
// uv and which root it is from the hit point.
bool acceptSphereHit(const Opacity& op, const double center[3], const glm::mat3& toLocal, const float org[3],
                     const float dir[3], double t, unsigned geomId, unsigned instId);

// The filters of masked triangle meshes: attach() gives an Embree triangle geometry (before its
// commit) the intersect and occluded filter functions and, as its user data, a record of the
// mesh's opacity, uvs and indices (pointers that must outlive the scene; the records live in this
// object, whose address must not change while the geometry is used). Nothing for a mesh that is
// not masked: unmasked geometry traverses exactly as before.
class MeshMasks {
public:
    void attach(RTCGeometryTy* geometry, const Opacity& op, const Vec2* uvs, const uint32_t* indices);
    size_t count() const { return records_.size(); }

    struct Record {
        const Opacity* opacity;
        const Vec2* uvs;          // null: uv (0, 0), as the hit's
        const uint32_t* indices;
    };

private:
    std::deque<Record> records_;  // (a deque: records never move)
};

}  // namespace lt
