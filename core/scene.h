// The renderable scene: Embree 3 geometry (triangle meshes and exact analytic spheres as user
// geometry), materials, lights, camera. Ray offsets avoid self-intersection at any scene scale.
#pragma once
#include <embree3/rtcore.h>
#include <memory>
#include <vector>
#include "core/camera.h"
#include "core/huge_pages.h"
#include "core/lights.h"
#include "core/sampling.h"
#include "core/scene_desc.h"

namespace lt {

struct SphereGeom {
    double cx, cy, cz, r;
};

struct SurfaceHit {
    float t = kInf;
    Vec3 p{0.f};
    Vec3 ng{0.f};          // geometric normal (unit, the side the shape's normal points to)
    Frame shading;         // shading frame (n = interpolated normal, flipped to ng's hemisphere side)
    Vec2 uv{0.f};
    const Bxdf* bxdf = nullptr;
    const Light* light = nullptr;  // area light on this surface, if any
    bool deltaBsdf = false;        // bxdf has only delta lobes (cached: no virtual call per vertex)
    float roughness = 1.f;         // bxdf->roughness(), cached per shape
    int geomId = -1, primId = -1;
};

class Scene {
public:
    explicit Scene(const SceneDesc& desc);
    ~Scene();
    Scene(const Scene&) = delete;
    Scene& operator=(const Scene&) = delete;

    bool intersect(const Ray& ray, SurfaceHit& hit) const;
    // Is the segment between two surface points (with geometric normals; zero normal = not on a
    // surface, e.g. a point light) blocked? Both ends are offset, so the surfaces themselves never count.
    bool occluded(const Vec3& p0, const Vec3& n0, const Vec3& p1, const Vec3& n1) const;
    // A ray towards infinity (direction dir) from a surface point.
    bool occludedInfinite(const Vec3& p0, const Vec3& n0, const Vec3& dir) const;
    bool occludedRay(const Ray& r) const;
    // The shadow rays `occluded` and `occludedInfinite` cast (tMax = 0: degenerate, nothing to cast).
    Ray shadowRay(const Vec3& p0, const Vec3& n0, const Vec3& p1, const Vec3& n1) const;
    Ray shadowRayInfinite(const Vec3& p0, const Vec3& n0, const Vec3& dir) const {
        return (n0 == Vec3(0.f)) ? Ray{p0, dir} : spawnRay(p0, n0, dir);
    }

    // Ray leaving surface point p (geometric normal ng) in direction d, offset to the side of d.
    // Inline (with offsetPoint): called once or twice per path vertex from other files.
    Ray spawnRay(const Vec3& p, const Vec3& ng, const Vec3& d) const {
        return Ray{offsetPoint(p, ng, d), d, 0.f, kInf};
    }
    Vec3 offsetPoint(const Vec3& p, const Vec3& ng, const Vec3& towards) const {
        // Float error of a hit point is proportional to its coordinates' magnitude; the second term
        // covers points near the origin. Both scale with the scene. p - eps ng == p + (-eps) ng exactly.
        float eps = 8e-6f * maxAbs(p) + offsetScale_;
        return p + (glm::dot(towards, ng) >= 0.f ? eps : -eps) * ng;
    }

    const Camera& camera() const { return *camera_; }
    const std::vector<Light>& lights() const { return lights_; }
    const Distribution1D& lightDistribution() const { return lightDist_; }
    float lightSelectionProb(const Light* l) const;
    // Lights that a ray escaping the scene sees (constant environment).
    const std::vector<const Light*>& infiniteLights() const { return envLights_; }
    Vec3 boundsCenter() const { return center_; }
    float boundsRadius() const { return radius_; }           // geometry and camera
    float geometryRadius() const { return geometryRadius_; }  // geometry only (merge radius default)

    // Uniform point on the shape of an area light: position, normal.
    void sampleAreaLight(const Light& l, const Vec2& u, Vec3& p, Vec3& n) const;

    const SceneDesc& desc() const { return desc_; }
    size_t triangleCount() const { return triangleCount_; }
    RTCScene embreeScene() const { return scene_; }

private:
    SceneDesc desc_;
    RTCDevice device_ = nullptr;
    RTCScene scene_ = nullptr;
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
    struct MeshTri { Vec3 p0, p1, p2, ng; };   // 48 bytes
    struct MeshTriNormals { Vec3 n0, n1, n2; };  // 36 bytes
    // What a hit needs of its shape, by Embree geomID, flat (no lookups through the description).
    struct GeomInfo {
        int mesh = -1, sphere = -1;
        const MeshTri* tris = nullptr;
        const MeshTriNormals* normals = nullptr;  // null: face normals
        const Vec2* uvs = nullptr;
        const uint32_t* indices = nullptr;
        const Bxdf* bxdf = nullptr;
        const Light* light = nullptr;
        bool deltaBsdf = false;
        float roughness = 1.f;
    };
    // An emitting triangle, ready for sampling: p = p0 + b1 e1 + b2 e2, unit normal n.
    struct EmitterTriangle { Vec3 p0, e1, e2, n; };
    HugeVector<MeshTri> tris_;                // all meshes, in geometry order, + 1 padding record
    HugeVector<MeshTriNormals> triNormals_;   // meshes with vertex normals, + 1 padding record
    std::vector<SphereGeom> spheres_;  // user data of the Embree sphere geometries (double precision)
    std::vector<GeomInfo> geoms_;                  // by Embree geomID
    std::vector<int> meshLight_, sphereLight_;     // light index per mesh / sphere, -1 if none
    std::vector<Distribution1D> meshTriDist_;      // area-proportional triangle choice per emitter mesh
    std::vector<std::vector<EmitterTriangle>> meshTris_;  // per emitter mesh
    Vec3 center_{0.f};
    float radius_ = 1.f, geometryRadius_ = 1.f;
    float offsetScale_ = 0.f;  // scene-relative part of the ray offset
    size_t triangleCount_ = 0;
};

}  // namespace lt
