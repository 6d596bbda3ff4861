// Light sources: area (on meshes and spheres), point, spot, directional, constant environment,
// environment map (core/envmap.h). All emit RGB. Densities are typed: positions in area measure,
// directions in solid angle.
// For lights at infinity (directional, constant, envmap) a "position" is a direction; their NEE pdf
// is a solid-angle pdf carried in the AreaPdf slot (the measure of a vertex at infinity), and
// emission positions are sampled on a disk of the scene's bounding-sphere radius. An environment's
// emission direction is sampled with the density of its NEE direction: pdfLeDir(dir) ==
// pdfLi(-dir), as the vertex at infinity has one density for every technique.
#pragma once
#include <memory>
#include <vector>
#include "core/envmap.h"
#include "core/math.h"
#include "core/sampling.h"
#include "core/scene_desc.h"
#include "core/texture/texture.h"

namespace lt {

class Scene;

// Projector: Mitsuba 3's `projector`, a delta-position light projecting an image (core/textured_lights.cpp).
enum class LightType { Area, Point, Spot, Directional, Constant, Envmap, Projector };

// A point on a light, sampled for next-event estimation from a reference point.
struct LightSampleLi {
    Vec3 p{0.f};        // position (for infinite lights: a far point, refP + wi * 2R)
    Vec3 n{0.f};        // surface normal (area lights), zero otherwise
    Vec3 wi{0.f};       // lights at infinity: unit direction from the reference point to the light
                        // (finite lights: zero; the connection derives direction and distance from p)
    Color value{0.f};   // radiance (area, constant, envmap), intensity (point, spot) or irradiance (directional)
    AreaPdf pdfPos;     // density of the point (area; solid angle for infinite lights; 1 for delta positions)
    Vec2 uv{0.f};       // textured area lights: the point's uv (the shape's parameterisation); else zero
};

struct LightSampleLe {
    Vec3 p{0.f}, n{0.f}, dir{0.f};
    Color value{0.f};
    AreaPdf pdfPos;
    SolidAnglePdf pdfDir;
    Vec2 uv{0.f};  // as LightSampleLi::uv
};

// A piecewise-constant density over [0, 1]^2 in proportion to a texture (projector emission),
// mixed with a uniform one (core/textured_lights.cpp).
class UvDistribution;

// An emitting triangle, ready for sampling: p = p0 + b1 e1 + b2 e2, unit normal n.
struct EmitterTriangle {
    Vec3 p0, e1, e2, n;
};

class Light {
public:
    LightType type;
    Color value{0.f};
    // Mesh area lights: the mesh (index into the scene description).
    int meshIndex = -1;
    // What sampling a point on the shape reads, set by the scene (which owns it): a mesh's
    // triangles with the area-proportional choice between them, or the sphere.
    const EmitterTriangle* tris = nullptr;
    const Distribution1D* triDist = nullptr;
    const SphereDesc* sphere = nullptr;
    const CylinderDesc* cylinder = nullptr;  // (core/cylinder.h)
    const EnvironmentMap* envmap = nullptr;  // Envmap (owned by the scene description)
    Vec3 position{0.f}, direction{0, 0, 1};  // point/spot; spot axis; directional travel direction
    float cosCutoff = 1.f, cutoff = 0.f, beamWidth = 0.f;  // spot, radians
    float area = 0.f, invArea = 0.f;  // area lights (set by the scene)
    // Textures (core/textured_lights.cpp; owned by the scene description): an area light's
    // radiance (in place of `value`), a spot's projected texture (times `value`), a projector's
    // irradiance (null: the constant `value`). Null for every untextured light.
    const Texture* texture = nullptr;
    // Spot with a texture, projector: the emitter frame's x and y axes (direction is its z).
    Vec3 axisX{1, 0, 0}, axisY{0, 1, 0};
    // Projector (Mitsuba's projector.cpp): tan of half the horizontal fov, the image's aspect
    // (width / height), the area of the image rectangle on the plane z = 1, the scale, and the
    // density of emitted uv. Spot: tanCutoff = tan(cutoff) for the texture's uv.
    float tanHalfFovX = 1.f, aspect = 1.f, sensorArea = 4.f, scale = 1.f, tanCutoff = 1.f;
    std::shared_ptr<const UvDistribution> uvDist;

    bool isDeltaPosition() const {
        return type == LightType::Point || type == LightType::Spot || type == LightType::Projector;
    }
    bool isDeltaDirection() const { return type == LightType::Directional; }
    bool isDelta() const { return isDeltaPosition() || isDeltaDirection(); }
    bool isInfinite() const {
        return type == LightType::Directional || type == LightType::Constant || type == LightType::Envmap;
    }
    // A light at infinity that a ray leaving the scene hits (Mitsuba's "environment emitter").
    bool isEnvironment() const { return type == LightType::Constant || type == LightType::Envmap; }
    // Can a random walk hit this light?
    bool isHittable() const { return type == LightType::Area || isEnvironment(); }

    // Radiance leaving a point of an area light with normal n in direction w; for the environments,
    // radiance travelling along w into the scene (w points from the sky towards the scene: it
    // arrives from the sky direction -w). uv: the area light's point's (read if textured).
    Color Le(const Vec3& n, const Vec3& w, const Vec2& uv = Vec2(0.f)) const {
        switch (type) {
            case LightType::Area:  // one-sided
                return glm::dot(n, w) > 0.f ? (texture ? texture->eval(uv) : value) : Color(0.f);
            case LightType::Constant: return value;
            case LightType::Envmap: return envmap->eval(-w);
            default: return Color(0.f);
        }
    }
    // Spot intensity profile (1 inside the beam, falling linearly in angle to 0 at the cutoff).
    float spotFalloff(const Vec3& wFromLight) const;
    // Intensity (W/sr) of a textured spot or of a projector towards unit direction w (Mitsuba's
    // spot.cpp and projector.cpp; core/textured_lights.cpp).
    Color texturedIntensity(const Vec3& w) const;
    // Set the textures and the projector's constants from the description (the scene calls it
    // once per light, after its type and value; nothing for untextured lights but a projector).
    void setTextures(const EmitterDesc& ed);
    // Projector: the largest density of an emission direction (a bound for JG19's heuristics).
    float projectorDirBound() const;

    // Mesh area lights inline (the NEE sample goes straight into the caller's light vertex, see
    // sampleLightVertex); every other light type through the call sampleLiOther.
    LightSampleLi sampleLi(const Scene& scene, const Vec3& refP, const Vec2& u) const {
        if (type == LightType::Area && !sphere && !cylinder && !texture) return areaSampleLi(sampleMesh(u), refP);
        return sampleLiOther(scene, refP, u);
    }
    // Density with which sampleLi picks point p (normal n) seen from refP, in the same measure as
    // sampleLi's pdfPos. For infinite lights `p` is ignored and `wi` (ref -> light) is used.
    AreaPdf pdfLi(const Scene& scene, const Vec3& refP, const Vec3& p, const Vec3& n, const Vec3& wi) const;

    LightSampleLe sampleLe(const Scene& scene, const Vec2& uPos, const Vec2& uDir) const;
    // Density of the emission direction dir leaving point p (normal n).
    SolidAnglePdf pdfLeDir(const Vec3& n, const Vec3& dir) const;
    AreaPdf pdfLePos(const Scene& scene) const;

    // Total emitted power, needs the scene radius for infinite lights (a light of power 0 is never
    // chosen by a light sample: core/scene.cpp, lightSelectionWeights).
    float power(const Scene& scene) const;

private:
    // Uniform point on an area light's shape: position p, normal n.
    struct AreaPoint {
        Vec3 p, n;
    };
    AreaPoint sampleArea(const Vec2& u) const;
    AreaPoint sampleMesh(const Vec2& uIn) const {
        Vec2 u = uIn;
        const EmitterTriangle& et = tris[triDist->sample(u.x, &u.x)];  // u.x reused, remapped within the bin
        const Vec2 bc = sampleUniformTriangle(u);
        return {et.p0 + bc.x * et.e1 + bc.y * et.e2, et.n};
    }
    AreaPoint sampleSphere(const Vec2& u) const;
    // A textured area light's point as sampleArea's (the same point for the same u) with its uv.
    struct TexturedPoint {
        Vec3 p, n;
        Vec2 uv;
    };
    TexturedPoint sampleTexturedArea(const Scene& scene, const Vec2& u) const;
    LightSampleLi texturedAreaSampleLi(const Scene& scene, const Vec3& refP, const Vec2& u) const;
    // The projector's emission: a direction in proportion to the image, and its density.
    LightSampleLe projectorSampleLe(const Vec2& uDir) const;
    SolidAnglePdf projectorPdfDir(const Vec3& dir) const;
    float texturedPower() const;  // spot with a texture, projector
    AreaPoint sampleCylinderPoint(const Vec2& u) const;
    // sampleLi's sample for an area light's point a. Only the side matters for the one-sided
    // emission: no normalised direction needed (the connection computes the unit direction and
    // the distance once).
    LightSampleLi areaSampleLi(const AreaPoint& a, const Vec3& refP) const {
        const Vec3 d = refP - a.p;
        if (!(glm::dot(d, d) > 0.f)) return {};
        return {a.p, a.n, Vec3(0.f), glm::dot(a.n, d) > 0.f ? value : Color(0.f), AreaPdf(invArea)};
    }
    // sampleLi for all but mesh area lights.
    [[gnu::noinline]] LightSampleLi sampleLiOther(const Scene& scene, const Vec3& refP, const Vec2& u) const;
};

// Mitsuba's parse_fov: the horizontal field of view (degrees) of a fov given along `axis` of an
// image of aspect width / height (the projector's, core/textured_lights.cpp).
float horizontalFovDeg(float fovDeg, FovAxis axis, float aspect);

}  // namespace lt
