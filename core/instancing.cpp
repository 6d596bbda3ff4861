// Shapegroups and instances (core/instancing.h), and the cylinders' part of the scene
// (core/cylinder.h): the Scene members that build them, apart from core/scene.cpp.
#include "core/instancing.h"

#include <cmath>
#include "core/scene.h"

namespace lt {

InstanceXf makeInstanceXf(const Mat4& toWorld) {
    InstanceXf x;
    x.toWorld = toWorld;
    x.toObject = glm::inverse(toWorld);
    x.normal = glm::transpose(glm::inverse(glm::mat3(toWorld)));
    const float det = std::abs(glm::determinant(glm::mat3(toWorld)));
    x.curvatureScale = det > 0.f ? 1.f / std::cbrt(det) : 1.f;
    return x;
}

Ray toObjectRay(const InstanceXf& x, const Ray& r) {
    Ray o = r;
    o.o = Vec3(x.toObject * glm::vec4(r.o, 1.f));
    o.d = Vec3(x.toObject * glm::vec4(r.d, 0.f));
    return o;
}

void instanceToWorld(const InstanceXf& x, __m128& p, __m128& ng, __m128& ns) {
    const Vec3 pw = Vec3(x.toWorld * glm::vec4(sse::toVec3(p), 1.f));
    const Vec3 gw = glm::normalize(x.normal * sse::toVec3(ng));
    const Vec3 sw = glm::normalize(x.normal * sse::toVec3(ns));
    p = _mm_setr_ps(pw.x, pw.y, pw.z, 0.f);
    ng = _mm_setr_ps(gw.x, gw.y, gw.z, 0.f);
    ns = _mm_setr_ps(sw.x, sw.y, sw.z, 0.f);
}

unsigned Scene::attach(RTCGeometry g, int group) {
    const unsigned id = unsigned(geoms_.size());
    rtcAttachGeometryByID(group < 0 ? scene_ : groupScenes_.at(size_t(group)), g, id);
    rtcReleaseGeometry(g);
    geoms_.emplace_back();
    return id;
}

void Scene::attachCylinders(Vec3& lo, Vec3& hi) {
    cylinders_.reserve(desc_.cylinders.size());  // (user data pointers: no reallocation below)
    for (const CylinderDesc& c : desc_.cylinders) cylinders_.push_back(makeCylinderGeom(c));
    for (size_t i = 0; i < desc_.cylinders.size(); ++i) {
        const CylinderDesc& c = desc_.cylinders[i];
        RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_USER);
        rtcSetGeometryUserPrimitiveCount(g, 1);
        rtcSetGeometryUserData(g, &cylinders_[i]);
        rtcSetGeometryBoundsFunction(g, cylinderBounds, nullptr);
        rtcSetGeometryIntersectFunction(g, cylinderIntersect);
        rtcSetGeometryOccludedFunction(g, cylinderOccluded);
        rtcCommitGeometry(g);
        const unsigned id = attach(g, c.group);
        geoms_[id].cylinder = int(i);
        geoms_[id].curvature = c.radius > 0.0 ? float(0.5 / c.radius) : 0.f;  // mean curvature 1 / 2r
        if (c.group >= 0) continue;
        RTCBounds b;
        RTCBoundsFunctionArguments args{&cylinders_[i], 0, 0, &b};
        cylinderBounds(&args);
        lo = glm::min(lo, Vec3(b.lower_x, b.lower_y, b.lower_z));
        hi = glm::max(hi, Vec3(b.upper_x, b.upper_y, b.upper_z));
    }
}

void Scene::attachInstances(Vec3& lo, Vec3& hi) {
    for (RTCScene s : groupScenes_) rtcCommitScene(s);
    instances_.reserve(desc_.instances.size());
    for (const InstanceDesc& in : desc_.instances) {
        RTCScene group = groupScenes_.at(size_t(in.group));
        RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_INSTANCE);
        rtcSetGeometryInstancedScene(g, group);
        rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT4X4_COLUMN_MAJOR, &in.toWorld[0][0]);
        rtcCommitGeometry(g);
        const unsigned id = attach(g, -1);
        geoms_[id].instance = int(instances_.size());
        instances_.push_back(makeInstanceXf(in.toWorld));
        RTCBounds b;
        rtcGetSceneBounds(group, &b);
        if (!(b.lower_x <= b.upper_x)) continue;  // an empty group
        for (int k = 0; k < 8; ++k) {
            const Vec3 c((k & 1) ? b.upper_x : b.lower_x, (k & 2) ? b.upper_y : b.lower_y, (k & 4) ? b.upper_z : b.lower_z);
            const Vec3 w = Vec3(in.toWorld * glm::vec4(c, 1.f));
            lo = glm::min(lo, w);
            hi = glm::max(hi, w);
        }
    }
}

void Scene::cylinderLights(const std::vector<int>& emitterToLight) {
    cylinderLight_.assign(desc_.cylinders.size(), -1);
    for (size_t i = 0; i < desc_.cylinders.size(); ++i) {
        const CylinderDesc& c = desc_.cylinders[i];
        if (c.emitter < 0) continue;
        const int li = emitterToLight.at(size_t(c.emitter));
        Light& l = lights_[size_t(li)];
        l.cylinder = &c;
        l.area = float(cylinderArea(c));
        l.invArea = l.area > 0.f ? 1.f / l.area : 0.f;
        cylinderLight_[i] = li;
        // Its bounding sphere (mayHitEmitter): the centre of the axis, the distance to a rim.
        const Vec3 centre = Vec3(c.toWorld * glm::dvec4(0.0, 0.0, 0.5, 1.0));
        emitterBounds_.push_back({centre, float(std::sqrt(c.radius * c.radius + 0.25 * c.length * c.length))});
    }
}

}  // namespace lt
