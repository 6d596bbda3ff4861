// Mitsuba 3's cylinder shape (src/shapes/cylinder.cpp is the spec): the open unit cylinder
// x^2 + y^2 = 1, 0 <= z <= 1 of object space, mapped to the world by CylinderDesc::toWorld (the
// user's to_world composed with p0, the frame of p1 - p0, and the scale (radius, radius, length)).
// Exact and analytic: the ray is intersected in object space in double precision (as the
// sphere's sphereHit, core/scene.cpp), as Embree user geometry. Parameterisation as Mitsuba's:
// u = phi / 2 pi (phi in [0, 2 pi) about the local z axis from local x), v = local z.
#pragma once
#include <embree3/rtcore.h>
#include "core/math.h"
#include "core/scene_desc.h"

namespace lt {

// What a hit needs, in double precision: object -> world (3 x 4, row-major), its inverse, and the
// normal matrix (the inverse transpose of the linear part).
struct CylinderGeom {
    double toWorld[3][4], toObject[3][4], normal[3][3];
    bool flipNormals = false;
};
CylinderGeom makeCylinderGeom(const CylinderDesc& c);

// The nearest t in [tnear, tfar] at which the ray (any space the geometry's toObject takes: world,
// or an instance's object space) meets the cylinder, or a negative value.
double cylinderHit(const CylinderGeom& g, double ox, double oy, double oz, double dx, double dy, double dz,
                   double tnear, double tfar);

// The surface at ray parameter t: the point re-projected onto the cylinder, the unit normal
// (outward, or inward with flip_normals) and Mitsuba's uv.
struct CylinderSurface {
    Vec3 p, n;
    Vec2 uv;
};
CylinderSurface cylinderSurface(const CylinderGeom& g, const Vec3& o, const Vec3& d, float t);

// A uniformly distributed point on the cylinder (density 1 / area) and its normal: Mitsuba's
// sample_position (phi = 2 pi u.y, z = u.x).
void sampleCylinder(const CylinderDesc& c, const Vec2& u, Vec3& p, Vec3& n);
inline double cylinderArea(const CylinderDesc& c) { return 2.0 * 3.14159265358979323846 * c.radius * c.length; }

// Embree user-geometry callbacks (user data: a CylinderGeom).
void cylinderBounds(const RTCBoundsFunctionArguments* args);
void cylinderIntersect(const RTCIntersectFunctionNArguments* args);
void cylinderOccluded(const RTCOccludedFunctionNArguments* args);

}  // namespace lt
