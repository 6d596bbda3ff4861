// Mitsuba 3's shapegroup and instance (src/shapes/shapegroup.cpp, instance.cpp): a group's shapes
// live in their own Embree scene, in the group's (object) space, and each instance is an Embree
// instance geometry of that scene with its to_world (RTC_GEOMETRY_TYPE_INSTANCE: one copy of the
// geometry however many instances). A hit inside an instance is computed on the group's shape in
// object space and mapped to the world here: the point by to_world, the normals by its inverse
// transpose (renormalised), the curvature by the inverse of the mean linear scale.
#pragma once
#include <immintrin.h>
#include "core/math.h"
#include "core/ray.h"

namespace lt {

struct InstanceXf {
    Mat4 toWorld{1.f}, toObject{1.f};
    glm::mat3 normal{1.f};       // inverse transpose of toWorld's linear part
    float curvatureScale = 1.f;  // 1 / cbrt|det|
};
InstanceXf makeInstanceXf(const Mat4& toWorld);

// The ray in the instance's object space (the same parameter t: the direction is not normalised).
Ray toObjectRay(const InstanceXf& x, const Ray& r);
// p (a point), ng and ns (unit normals) from object to world space.
void instanceToWorld(const InstanceXf& x, __m128& p, __m128& ng, __m128& ns);

}  // namespace lt
