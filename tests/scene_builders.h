// Small scenes built in code for integrator tests (independent of the XML loader).
#pragma once
#include <glm/gtc/matrix_transform.hpp>
#include "core/loader.h"
#include "core/scene_desc.h"

namespace lt::test {

// Quad with corners c, c+u, c+u+v, c+v; normal = normalize(cross(u, v)).
inline MeshDesc quad(const Vec3& c, const Vec3& u, const Vec3& v, int bsdf, int emitter = -1) {
    MeshDesc m;
    m.name = "quad";
    m.positions = {c, c + u, c + u + v, c + v};
    m.indices = {0, 1, 2, 0, 2, 3};
    m.bsdf = bsdf;
    m.emitter = emitter;
    return m;
}

inline CameraDesc lookAt(const Vec3& origin, const Vec3& target, const Vec3& up, float fov, int w, int h) {
    // Mitsuba's lookat: camera +Z towards target, +X = cross(up, dir) (image left).
    Vec3 dir = glm::normalize(target - origin);
    Vec3 left = glm::normalize(glm::cross(up, dir));
    Vec3 newUp = glm::cross(dir, left);
    CameraDesc c;
    c.toWorld = Mat4(Vec4(left, 0), Vec4(newUp, 0), Vec4(dir, 0), Vec4(origin, 1));
    c.fovDeg = fov;
    c.width = w;
    c.height = h;
    return c;
}

// A closed box [-1,1]^3 seen from the inside (Cornell-like), an area light under the ceiling, and a
// second material on a tilted panel. `scale` multiplies every length (radiance is unchanged).
inline SceneDesc cornellBox(int res, BxdfPtr panel, float scale = 1.f) {
    SceneDesc d;
    d.bsdfs.push_back(makeDiffuse(Color(0.7f)));               // 0 white
    d.bsdfs.push_back(makeDiffuse(Color(0.6f, 0.1f, 0.1f)));   // 1 red
    d.bsdfs.push_back(makeDiffuse(Color(0.1f, 0.6f, 0.1f)));   // 2 green
    d.bsdfs.push_back(panel);                                  // 3 panel
    d.bsdfs.push_back(makeDiffuse(Color(0.f)));                // 4 light
    float s = scale;
    auto P = [s](float x, float y, float z) { return Vec3(x, y, z) * s; };
    d.meshes.push_back(quad(P(-1, -1, -1), P(0, 0, 2), P(2, 0, 0), 0));   // floor, normal +y
    d.meshes.push_back(quad(P(-1, 1, -1), P(2, 0, 0), P(0, 0, 2), 0));    // ceiling, normal -y
    d.meshes.push_back(quad(P(-1, -1, -1), P(2, 0, 0), P(0, 2, 0), 0));   // back, normal +z
    d.meshes.push_back(quad(P(-1, -1, -1), P(0, 2, 0), P(0, 0, 2), 1));   // left (x=-1), normal +x
    d.meshes.push_back(quad(P(1, -1, -1), P(0, 0, 2), P(0, 2, 0), 2));    // right, normal -x
    d.meshes.push_back(quad(P(-0.6f, -1, -0.4f), P(0.8f, 0.6f, 0.2f), P(0, 0.1f, 0.8f), 3));  // panel
    EmitterDesc e;
    e.type = EmitterType::Area;
    e.value = Color(12.f, 10.f, 8.f);
    d.emitters.push_back(e);
    d.meshes.push_back(quad(P(-0.25f, 0.99f, -0.25f), P(0.5f, 0, 0), P(0, 0, 0.5f), 4, 0));  // light, normal -y
    SphereDesc sp;
    sp.center = P(0.45f, -0.6f, 0.1f);
    sp.radius = 0.35f * s;
    sp.bsdf = 3;
    d.spheres.push_back(sp);
    d.camera = lookAt(P(0, 0, 3.8f), P(0, 0, 0), Vec3(0, 1, 0), 40.f, res, res);
    d.camera.nearClip = 1e-3f * s;
    d.integrator.maxDepth = 6;
    return d;
}

// A coarse lat-long sphere mesh with smooth (radial) vertex normals: its shading normals differ
// from the geometric ones, which is what the adjoint correction is about.
inline MeshDesc smoothSphere(const Vec3& c, float r, int rings, int segs, int bsdf) {
    MeshDesc m;
    m.name = "smooth-sphere";
    for (int i = 0; i <= rings; ++i)
        for (int j = 0; j <= segs; ++j) {
            float th = kPi * i / rings, ph = 2 * kPi * j / segs;
            Vec3 n(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph));
            m.positions.push_back(c + r * n);
            m.normals.push_back(n);
        }
    auto idx = [&](int i, int j) { return uint32_t(i * (segs + 1) + j); };
    for (int i = 0; i < rings; ++i)
        for (int j = 0; j < segs; ++j) {
            uint32_t a = idx(i, j), b = idx(i + 1, j), cc = idx(i + 1, j + 1), d = idx(i, j + 1);
            if (i > 0) m.indices.insert(m.indices.end(), {a, cc, b});
            if (i < rings - 1) m.indices.insert(m.indices.end(), {a, d, cc});
        }
    m.bsdf = bsdf;
    return m;
}

// The Cornell box lit by a point light instead of the area light (which stays as a black panel).
inline SceneDesc cornellBoxPointLight(int res, BxdfPtr panel) {
    SceneDesc d = cornellBox(res, panel);
    d.meshes.back().emitter = -1;  // the light panel stays as black geometry
    EmitterDesc& e = d.emitters[0];
    e = EmitterDesc{};
    e.type = EmitterType::Point;
    e.position = Vec3(0.1f, 0.7f, 0.2f);
    e.value = Color(2.f, 1.8f, 1.5f);
    return d;
}

// White furnace: the camera inside a closed sphere (normals inwards) of diffuse albedo `albedo`
// that also emits radiance 1. Every pixel's radiance is sum_k albedo^k over the allowed bounces.
inline SceneDesc furnace(int res, float albedo) {
    SceneDesc d;
    d.bsdfs.push_back(makeDiffuse(Color(albedo)));
    EmitterDesc e;
    e.type = EmitterType::Area;
    e.value = Color(1.f);
    d.emitters.push_back(e);
    SphereDesc s;
    s.radius = 1.f;
    s.flipNormals = true;
    s.bsdf = 0;
    s.emitter = 0;
    d.spheres.push_back(s);
    d.camera = lookAt(Vec3(0.1f, 0.2f, 0.f), Vec3(0.1f, 0.2f, 1.f), Vec3(0, 1, 0), 60.f, res, res);
    return d;
}

// The loader's error for the scene file at path ("" if it loads).
inline std::string loadError(const std::string& path) {
    try {
        loadScene(path, {});
    } catch (const SceneError& e) {
        return e.what();
    }
    return "";
}

}  // namespace lt::test
