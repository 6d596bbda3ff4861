#include "core/cylinder.h"

#include <cmath>

namespace lt {

namespace {

void apply(const double m[3][4], double x, double y, double z, double w, double out[3]) {
    for (int i = 0; i < 3; ++i) out[i] = m[i][0] * x + m[i][1] * y + m[i][2] * z + m[i][3] * w;
}

}  // namespace

CylinderGeom makeCylinderGeom(const CylinderDesc& c) {
    CylinderGeom g;
    const glm::dmat4 inv = glm::inverse(c.toWorld);
    const glm::dmat3 nm = glm::transpose(glm::inverse(glm::dmat3(c.toWorld)));
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 4; ++j) {
            g.toWorld[i][j] = c.toWorld[j][i];  // glm is column-major: [column][row]
            g.toObject[i][j] = inv[j][i];
        }
        for (int j = 0; j < 3; ++j) g.normal[i][j] = nm[j][i];
    }
    g.flipNormals = c.flipNormals;
    return g;
}

double cylinderHit(const CylinderGeom& g, double ox, double oy, double oz, double dx, double dy, double dz,
                   double tnear, double tfar) {
    double o[3], d[3];
    apply(g.toObject, ox, oy, oz, 1.0, o);
    apply(g.toObject, dx, dy, dz, 0.0, d);  // not normalised: t is the same parameter as the caller's
    const double a = d[0] * d[0] + d[1] * d[1];
    if (!(a > 0.0)) return -1;  // parallel to the axis (or degenerate): no hit on the open mantle
    const double b = o[0] * d[0] + o[1] * d[1];  // half b
    const double c = o[0] * o[0] + o[1] * o[1] - 1.0;
    // The squared distance of the closest approach to the axis, without cancellation (as sphereHit).
    const double fx = o[0] - b / a * d[0], fy = o[1] - b / a * d[1];
    const double disc = a * (1.0 - (fx * fx + fy * fy));
    if (disc < 0) return -1;
    const double q = -(b + std::copysign(std::sqrt(disc), b));
    double t0 = q / a, t1 = (q != 0) ? c / q : t0;
    if (t0 > t1) std::swap(t0, t1);
    for (double t : {t0, t1}) {
        if (!(t >= tnear && t <= tfar)) continue;
        const double z = o[2] + t * d[2];
        if (z >= 0.0 && z <= 1.0) return t;
    }
    return -1;
}

CylinderSurface cylinderSurface(const CylinderGeom& g, const Vec3& o, const Vec3& d, float t) {
    const double td = t;
    double local[3];
    apply(g.toObject, double(o.x) + td * d.x, double(o.y) + td * d.y, double(o.z) + td * d.z, 1.0, local);
    const double r = std::hypot(local[0], local[1]);
    const double x = r > 0 ? local[0] / r : 1.0, y = r > 0 ? local[1] / r : 0.0;
    const double z = std::clamp(local[2], 0.0, 1.0);
    double p[3], n[3];
    apply(g.toWorld, x, y, z, 1.0, p);
    for (int i = 0; i < 3; ++i) n[i] = g.normal[i][0] * x + g.normal[i][1] * y;
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    const double s = (g.flipNormals ? -1.0 : 1.0) / len;
    double phi = std::atan2(y, x);
    if (phi < 0) phi += 2.0 * 3.14159265358979323846;
    return {Vec3(float(p[0]), float(p[1]), float(p[2])), Vec3(float(n[0] * s), float(n[1] * s), float(n[2] * s)),
            Vec2(float(phi / (2.0 * 3.14159265358979323846)), float(z))};
}

void sampleCylinder(const CylinderDesc& c, const Vec2& u, Vec3& p, Vec3& n) {
    const double phi = 2.0 * 3.14159265358979323846 * double(u.y);
    const double x = std::cos(phi), y = std::sin(phi);
    const glm::dvec4 pw = c.toWorld * glm::dvec4(x, y, double(u.x), 1.0);
    const glm::dvec3 nw = glm::transpose(glm::inverse(glm::dmat3(c.toWorld))) * glm::dvec3(x, y, 0.0);
    p = Vec3(pw);
    n = Vec3(glm::normalize(nw) * (c.flipNormals ? -1.0 : 1.0));
}

void cylinderBounds(const RTCBoundsFunctionArguments* args) {
    const auto* g = static_cast<const CylinderGeom*>(args->geometryUserPtr);
    // The box of the two end circles: centre M(0,0,z) +- sqrt(c0^2 + c1^2) per axis, c0 and c1 the
    // images of the local x and y axes; padded against rounding.
    float lo[3], hi[3];
    for (int i = 0; i < 3; ++i) {
        const double e = std::sqrt(g->toWorld[i][0] * g->toWorld[i][0] + g->toWorld[i][1] * g->toWorld[i][1]);
        const double a = g->toWorld[i][3], b = g->toWorld[i][3] + g->toWorld[i][2];
        const double pad = 1e-6 * (e + std::abs(a) + std::abs(b)) + 1e-30;
        lo[i] = float(std::min(a, b) - e - pad);
        hi[i] = float(std::max(a, b) + e + pad);
    }
    args->bounds_o->lower_x = lo[0], args->bounds_o->lower_y = lo[1], args->bounds_o->lower_z = lo[2];
    args->bounds_o->upper_x = hi[0], args->bounds_o->upper_y = hi[1], args->bounds_o->upper_z = hi[2];
}

void cylinderIntersect(const RTCIntersectFunctionNArguments* args) {
    if (!args->valid[0]) return;
    const auto* g = static_cast<const CylinderGeom*>(args->geometryUserPtr);
    RTCRayHit* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);  // N == 1 (rtcIntersect1 only)
    RTCRay& r = rh->ray;
    const double t = cylinderHit(*g, r.org_x, r.org_y, r.org_z, r.dir_x, r.dir_y, r.dir_z, r.tnear, r.tfar);
    if (t < 0) return;
    r.tfar = float(t);
    rh->hit.Ng_x = 0.f;  // (the renderer computes the normal from the hit: cylinderSurface)
    rh->hit.Ng_y = 0.f;
    rh->hit.Ng_z = 1.f;
    rh->hit.u = 0.f;
    rh->hit.v = 0.f;
    rh->hit.primID = args->primID;
    rh->hit.geomID = args->geomID;
    rh->hit.instID[0] = args->context->instID[0];
}

void cylinderOccluded(const RTCOccludedFunctionNArguments* args) {
    if (!args->valid[0]) return;
    const auto* g = static_cast<const CylinderGeom*>(args->geometryUserPtr);
    RTCRay* r = reinterpret_cast<RTCRay*>(args->ray);
    if (cylinderHit(*g, r->org_x, r->org_y, r->org_z, r->dir_x, r->dir_y, r->dir_z, r->tnear, r->tfar) >= 0)
        r->tfar = -kInf;
}

}  // namespace lt
