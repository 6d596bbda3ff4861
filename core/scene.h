// The renderable scene: Embree 3 geometry (triangle meshes, and exact analytic spheres as user
// geometry or, up to kDirectSpheres of them, tested directly), materials, lights, camera. Ray
// offsets avoid self-intersection at any scene scale.
#pragma once
#include <mutex>
#include <embree3/rtcore.h>
#include <immintrin.h>
#include <cstring>
#include <memory>
#include <vector>
#include "core/camera.h"
#include "core/cylinder.h"
#include "core/instancing.h"
#include "core/huge_pages.h"
#include "core/lights.h"
#include "core/sampling.h"
#include "core/scene_desc.h"

namespace lt {

class NormalPerturbation;  // bsdf/normal_perturbation.h

struct SphereGeom {
    double cx, cy, cz, r;
    const SphereDesc* mask = nullptr;  // a masked sphere's description (opacity, toLocal), else null
};

// The part of a surface hit a path vertex keeps (PathVertex derives from it, so that
// Scene::intersect writes straight into the vertex: no hit record to initialise and copy).
// p, ng and shading are adjacent (intersect stores p and ng as whole 16-byte vectors).
struct SurfacePoint {
    Vec3 p{0.f};
    Vec3 ng{0.f};          // geometric normal (unit, the side the shape's normal points to)
    Frame shading;         // shading frame (n = interpolated normal, flipped to ng's hemisphere side)
    float roughness = 1.f;         // bxdf->roughness(), cached per shape (read by regularisation)
    const Bxdf* bxdf = nullptr;
    const Light* light = nullptr;  // area light on this surface, if any
    bool deltaBsdf = false;        // bxdf has only delta lobes (cached: no virtual call per vertex)
    // |mean curvature| of the surface here (1/length; JG19's diffusion heuristic): 1/r on a
    // sphere, 0 on a flat mesh, on a mesh with vertex normals the triangle's estimate (MeshTri).
    float curvature = 0.f;
    // Texture coordinates (Mitsuba's parameterisation of the shape; (0, 0) without one). The
    // walk's form of a hit writes them only where the material is textured.
    Vec2 uv{0.f};
};

struct SurfaceHit : SurfacePoint {
    float t = kInf;
    int geomId = -1, primId = -1;
};

// |mean curvature| of a triangle estimated from its vertex normals: the mean over its three edges
// of the normal curvature along the edge, (n_j - n_i) . (p_j - p_i) / |p_j - p_i|^2 (exact, 1/r,
// for any triangle whose normals are a sphere's). 0 for a degenerate triangle.
float meanCurvature(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& n0, const Vec3& n1, const Vec3& n2);

class Scene {
public:
    explicit Scene(const SceneDesc& desc);
    ~Scene();
    Scene(const Scene&) = delete;
    Scene& operator=(const Scene&) = delete;

    bool intersect(const Ray& ray, SurfaceHit& hit) const;
    // The same hit, only the fields of SurfacePoint written (not t, uv and the ids: the walk's form).
    bool intersect(const Ray& ray, SurfacePoint& hit) const;
    // Is anything hit on the ray's [tMin, tMax]? (For the shadow rays below.)
    bool occludedRay(const Ray& r) const;
    // The shadow ray of the segment between two surface points (with geometric normals; zero
    // normal = not on a surface, e.g. a point light): both ends are offset, so the surfaces
    // themselves never count (tMax = 0: degenerate, nothing to cast). shadowRayInfinite: the ray
    // towards infinity (direction dir) from a surface point.
    Ray shadowRay(const Vec3& p0, const Vec3& n0, const Vec3& p1, const Vec3& n1) const;
    Ray shadowRayInfinite(const Vec3& p0, const Vec3& n0, const Vec3& dir) const {
        return (n0 == Vec3(0.f)) ? Ray{p0, dir} : spawnRay(p0, n0, dir);
    }

    // Ray leaving surface point p (geometric normal ng) in direction d, offset to the side of d.
    // Inline (with the offset rule below): called once or twice per path vertex from other files.
    Ray spawnRay(const Vec3& p, const Vec3& ng, const Vec3& d) const {
        return sse::makeRay(offsetPoint(sse::load3(p), sse::load3(ng), glm::dot(d, ng) >= 0.f), sse::load3(d));
    }
    // The offset rule itself, on SSE lanes x, y, z (lane 3: p3 + eps ng3), to the side of +ng or -ng.
    __m128 offsetPoint(__m128 p, __m128 ng, bool positiveSide) const {
        // Float error of a hit point is proportional to its coordinates' magnitude; the second term
        // covers points near the origin. Both scale with the scene. p - eps ng == p + (-eps) ng exactly.
        const float eps = 8e-6f * sse::maxAbs3(p) + offsetScale_;
        return _mm_add_ps(p, _mm_mul_ps(_mm_set1_ps(positiveSide ? eps : -eps), ng));
    }

    // False only if no ray hit along `ray` (t >= 0) can be on an emitting shape: a conservative
    // test against a bounding sphere of each area light's shape (always true with more than
    // kMaxEmitterBounds of them). A path tracer's extra ray that counts only emitter hits (OPSR's
    // regularised BSDF sample) is cast only where it is true.
    bool mayHitEmitter(const Ray& ray) const;
    static constexpr size_t kMaxEmitterBounds = 16;

    const Camera& camera() const { return *camera_; }
    const std::vector<Light>& lights() const { return lights_; }
    const Distribution1D& lightDistribution() const { return lightDist_; }
    float lightSelectionProb(const Light* l) const;
    // Lights that a ray escaping the scene sees (constant environment).
    const std::vector<const Light*>& infiniteLights() const { return envLights_; }
    // The sphere bounding the geometry and the camera (a point at 2 x its radius from any of
    // them is beyond everything: the far ends of rays to infinity).
    Vec3 boundsCenter() const { return center_; }
    float boundsRadius() const { return radius_; }
    // The sphere bounding the geometry alone: the merge radius's default, and the disk that
    // light paths from lights at infinity start on (as SmallVCM and pbrt-v4: a ray that misses
    // it hits nothing, and one from the camera's side of it would be wasted).
    Vec3 geometryCenter() const { return geometryCenter_; }
    float geometryRadius() const { return geometryRadius_; }

    const SceneDesc& desc() const { return desc_; }
    size_t triangleCount() const { return triangleCount_; }
    // Every shape of the scene in one Embree scene (for bare Embree casts: tools/raybench), with the
    // renderer's geometry ids. The renderer's own Embree scene leaves out up to kDirectSpheres
    // spheres, which intersect() and occludedRay() test directly; this one is built on first use.
    RTCScene embreeScene() const;
    static constexpr size_t kDirectSpheres = 4;

private:
    template <class Hit>
    bool intersectImpl(const Ray& ray, Hit& hit) const;
    void attachSphere(RTCScene scene, size_t i, unsigned id);  // sphere i as Embree user geometry
    struct GeomInfo;
    // The shading frame of a hit on a shape with GeomInfo::tangentFrame: tangent dp/du, perturbed by
    // the material's GeomInfo::perturb where it has one. n the unperturbed shading normal, (b1, b2)
    // the barycentrics on a triangle, ix the hit's instance (null outside one).
    Frame perturbedFrame(const GeomInfo& gi, unsigned prim, float b1, float b2, const Ray& ray, const InstanceXf* ix,
                         const Vec3& p,
                         const Vec3& ng, const Vec3& n) const;
    // Attaches g (and releases it) to the main scene or to shapegroup `group`'s, with the next free
    // geometry id (ids are unique across the scenes: geoms_ serves both); returns the id.
    unsigned attach(RTCGeometry g, int group);
    // Cylinders as Embree user geometry; shapegroups committed and their instances attached
    // (growing lo/hi by the instances' bounds). core/instancing.cpp
    void attachCylinders(Vec3& lo, Vec3& hi);
    void attachInstances(Vec3& lo, Vec3& hi);
    // Curves as Embree round curves (core/curves.cpp), growing lo/hi as attachCylinders.
    void attachCurves(Vec3& lo, Vec3& hi);
    void cylinderLights(const std::vector<int>& emitterToLight);

    SceneDesc desc_;
    RTCDevice device_ = nullptr;
    RTCScene scene_ = nullptr;
    bool direct_ = false;       // the spheres are not in scene_: tested directly, ids from embreeGeoms_ on
    unsigned embreeGeoms_ = 0;  // geometries in scene_ (direct_ only)
    mutable std::once_flag fullOnce_;
    mutable RTCScene fullScene_ = nullptr;  // embreeScene(), when it differs from scene_
    std::unique_ptr<Camera> camera_;
    std::vector<Light> lights_;
    Distribution1D lightDist_;
    std::vector<const Light*> envLights_;
    // What a hit on a triangle reads, by primID, built at construction so that a hit touches one
    // or two records instead of indices -> positions and normals: the vertices (the same floats as
    // the mesh's, so the barycentric position is unchanged), the unit face normal
    // normalize(cross(p1 - p0, p2 - p0)), and in a second array (meshes with vertex normals only)
    // the three vertex normals. Each array ends with one padding record: 16-byte loads of the last
    // Vec3 of a record stay inside the allocation.
    // Meshes whose three vertex normals are equal on every triangle (the built-in rectangle, cube
    // and disk) keep each triangle's shading frame instead of its normals: a hit copies it, with
    // no interpolation, normalisation or frame construction (36 bytes, as the normals).
    struct MeshTri { Vec3 p0, p1, p2, ng; };   // 48 bytes
    // The vertex normals, and the triangle's |mean curvature| estimated from them (meanCurvature).
    struct MeshTriNormals { Vec3 n0, n1, n2; float curvature; };  // 40 bytes
    // What a hit needs of its shape, by Embree geomID, flat (no lookups through the description).
    struct GeomInfo {
        int mesh = -1, sphere = -1, cylinder = -1;
        int curve = -1;           // a linearcurve or bsplinecurve (SceneDesc::curves; core/curves.h)
        int instance = -1;        // an instance of a shapegroup (index into instances_)
        bool attributeKey = false;  // hits carry the mesh-attribute key in uv (MeshDesc::attributeKey)
        const MeshTri* tris = nullptr;
        const MeshTriNormals* normals = nullptr;  // null: face normals, or frames
        const Frame* frames = nullptr;            // shading frame per triangle (flat meshes)
        const Vec2* uvs = nullptr;
        const uint32_t* indices = nullptr;
        const Bxdf* bxdf = nullptr;
        const Light* light = nullptr;
        bool deltaBsdf = false;
        bool textured = false;  // the material's model varies with uv (Bxdf::textured)
        // The material's normalmap or bumpmap: hits take its perturbed frame (bxdf is then its
        // nested model). Null for every other material.
        const NormalPerturbation* perturb = nullptr;
        // Hits take the frame whose tangent is dp/du (perturbedFrame; perturbed where perturb is
        // set): a normalmap or bumpmap, or an anisotropic material (Bxdf::anisotropic), whose lobe
        // is oriented along dp/du as in Mitsuba. Elsewhere any frame about the normal will do.
        bool tangentFrame = false;
        float roughness = 1.f;
        float curvature = 0.f;  // a sphere's 1/r
    };
    HugeVector<MeshTri> tris_;                // all meshes, in geometry order, + 1 padding record
    HugeVector<MeshTriNormals> triNormals_;   // meshes with varying vertex normals, + 1 padding record
    HugeVector<Frame> triFrames_;             // flat meshes with vertex normals
    std::vector<SphereGeom> spheres_;  // user data of the Embree sphere geometries (double precision)
    MeshMasks meshMasks_;              // the filters' records of masked meshes (core/opacity.h)
    std::vector<CylinderGeom> cylinders_;  // user data of the cylinders (double precision)
    std::vector<int> cylinderLight_;       // light index per cylinder, -1 if none
    std::vector<RTCScene> groupScenes_;    // one Embree scene per shapegroup (instanced)
    std::vector<InstanceXf> instances_;    // by GeomInfo::instance (core/instancing.h)
    std::vector<GeomInfo> geoms_;                  // by Embree geomID
    std::vector<int> meshLight_, sphereLight_;     // light index per mesh / sphere, -1 if none
    // Emitting meshes: their triangles (all, in mesh order) and the choice between them (per mesh).
    std::vector<EmitterTriangle> emitterTris_;
    // Bounding spheres of the emitting shapes, radii slightly enlarged (mayHitEmitter); empty with
    // more than kMaxEmitterBounds shapes (then every ray may hit one).
    struct EmitterBound { Vec3 center; float radius; };
    std::vector<EmitterBound> emitterBounds_;
    bool manyEmitters_ = false;
    std::vector<Distribution1D> meshTriDist_;
    Vec3 center_{0.f};
    float radius_ = 1.f, geometryRadius_ = 1.f;
    Vec3 geometryCenter_{0.f};
    float offsetScale_ = 0.f;  // scene-relative part of the ray offset
    size_t triangleCount_ = 0;
};

// Inline: per NEE sample, in the connection loop (no call, no spills around it).
inline Ray Scene::shadowRay(const Vec3& p0v, const Vec3& n0v, const Vec3& p1v, const Vec3& n1v) const {
    const __m128 p0 = sse::load3(p0v), n0 = sse::load3(n0v), p1 = sse::load3(p1v), n1 = sse::load3(n1v);
    // Both ends offset by the one rule, unless not on a surface (zero normal), each towards the
    // other end. p0 - p1 == -(p1 - p0) up to the sign of zero components, so
    // dot(p0 - p1, n1) >= 0 exactly when dot(p1 - p0, n1) <= 0 (a zero dot passes both; NaN neither).
    const __m128 d01 = _mm_sub_ps(p1, p0);
    const __m128 a = sse::isZero3(n0) ? p0 : offsetPoint(p0, n0, sse::dot3(d01, n0) >= 0.f);
    const __m128 b = sse::isZero3(n1) ? p1 : offsetPoint(p1, n1, sse::dot3(d01, n1) <= 0.f);
    const __m128 d = _mm_sub_ps(b, a);
    const float len = std::sqrt(sse::dot3(d, d));
    if (!(len > 0.f)) return Ray{sse::toVec3(a), Vec3(0.f, 0.f, 1.f), 0.f, 0.f};
    // (a, d.x) and (d.y, d.z, tMin = 0, tMax) as two whole vectors: the lanes of d / len, and of
    // len (1 - 1e-5) masked to (0, tMax).
    const __m128 lenV = _mm_set1_ps(len);
    const __m128 dn = _mm_div_ps(d, lenV);
    const __m128 tMax = _mm_and_ps(_mm_mul_ps(lenV, _mm_set1_ps(1.f - 1e-5f)),
                                   _mm_castsi128_ps(_mm_setr_epi32(0, -1, 0, 0)));   // 0 tMax 0 0
    const __m128 a2d0 = _mm_shuffle_ps(a, dn, _MM_SHUFFLE(0, 0, 2, 2));              // a.z a.z d.x d.x
    const __m128 v[2] = {_mm_shuffle_ps(a, a2d0, _MM_SHUFFLE(2, 0, 1, 0)),           // a.x a.y a.z d.x
                         _mm_shuffle_ps(dn, tMax, _MM_SHUFFLE(1, 0, 2, 1))};         // d.y d.z 0 tMax
    Ray r;
    static_assert(sizeof(Ray) == sizeof(v));
    std::memcpy(&r, v, sizeof(r));
    return r;
}

}  // namespace lt
