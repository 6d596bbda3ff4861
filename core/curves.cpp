// Curve files, curve evaluation and hits (core/curves.h), and the Scene member that attaches the
// curves to Embree.
#include "core/curves.h"

#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include "core/scene.h"

namespace lt {

void readCurveFile(const std::string& path, bool bspline, const Mat4& toWorld, CurveDesc& c) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw CurveError(fmt::format("{}: cannot open the curve file", path));
    const size_t minPoints = bspline ? 4 : 2;
    const char* kind = bspline ? "a B-spline curve needs at least four control points"
                               : "a linear curve needs at least two control points";
    c.points.clear();
    c.segments.clear();
    size_t first = 0;      // the current curve's first point
    size_t firstLine = 0;  // and its line
    auto finish = [&](size_t line) {
        const size_t n = c.points.size() - first;
        if (n == 0) return;
        if (n < minPoints)
            throw CurveError(fmt::format("{}:{}: the curve starting here has {} control point{}: {}", path, firstLine,
                                         n, n == 1 ? "" : "s", kind));
        for (size_t i = first; i + minPoints <= c.points.size(); ++i) c.segments.push_back(uint32_t(i));
        first = c.points.size();
        (void)line;
    };
    std::string s;
    size_t line = 0;
    while (std::getline(in, s)) {
        ++line;
        if (s.find_first_not_of(" \t\r") == std::string::npos) {
            finish(line);
            continue;
        }
        if (c.points.size() == first) firstLine = line;
        float v[4];
        const char* cur = s.c_str();
        for (float& x : v) {
            char* end = nullptr;
            x = std::strtof(cur, &end);
            if (end == cur)
                throw CurveError(fmt::format("{}:{}: expected four numbers \"x y z radius\" (got \"{}\")", path, line, s));
            cur = end;
        }
        if (std::string_view(cur).find_first_not_of(" \t\r") != std::string_view::npos)
            throw CurveError(fmt::format("{}:{}: expected four numbers \"x y z radius\" (got \"{}\")", path, line, s));
        if (!(std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]) && std::isfinite(v[3])))
            throw CurveError(fmt::format("{}:{}: a control point must be finite (got \"{}\")", path, line, s));
        if (v[3] < 0.f) throw CurveError(fmt::format("{}:{}: negative radius {}", path, line, v[3]));
        const Vec3 p = Vec3(toWorld * glm::vec4(v[0], v[1], v[2], 1.f));
        if (!isFinite(p)) throw CurveError(fmt::format("{}:{}: the point is not finite after to_world", path, line));
        if (c.points.size() >= size_t(UINT32_MAX))
            throw CurveError(fmt::format("{}:{}: more than 2^32 control points", path, line));
        c.points.emplace_back(p, v[3]);
    }
    finish(line);
    if (c.points.empty()) throw CurveError(fmt::format("{}: the file holds no control points", path));
}

CurvePoint curvePoint(const CurveDesc& c, unsigned prim, float t) {
    const glm::vec4* q = c.points.data() + c.segments[prim];
    if (!c.bspline) {
        const glm::vec4 x = (1.f - t) * q[0] + t * q[1];
        return {Vec3(x), Vec3(q[1] - q[0]), x.w};
    }
    // The uniform cubic B-spline basis (1/6) [(1-t)^3, 3t^3 - 6t^2 + 4, -3t^3 + 3t^2 + 3t + 1, t^3]
    // and its derivative.
    const float t2 = t * t, t3 = t2 * t, s = 1.f - t;
    const float b0 = s * s * s, b1 = 3.f * t3 - 6.f * t2 + 4.f, b2 = -3.f * t3 + 3.f * t2 + 3.f * t + 1.f, b3 = t3;
    const float d0 = -3.f * s * s, d1 = 9.f * t2 - 12.f * t, d2 = -9.f * t2 + 6.f * t + 3.f, d3 = 3.f * t2;
    const glm::vec4 x = (b0 * q[0] + b1 * q[1] + b2 * q[2] + b3 * q[3]) * (1.f / 6.f);
    const glm::vec4 dx = (d0 * q[0] + d1 * q[1] + d2 * q[2] + d3 * q[3]) * (1.f / 6.f);
    return {Vec3(x), Vec3(dx), x.w};
}

CurveSurface curveSurface(const CurveDesc& c, unsigned prim, float u, const Vec3& embreeNg, const Vec3& o,
                          const Vec3& d, float t) {
    CurveSurface s;
    s.p = o + t * d;
    u = std::clamp(u, 0.f, 1.f);
    const CurvePoint cp = curvePoint(c, prim, u);
    const Vec3 radial = s.p - cp.c;
    Vec3 n = embreeNg;
    float len = glm::length(n);
    if (!(len > 0.f) || !std::isfinite(len)) n = radial, len = glm::length(n);
    n = len > 0.f && std::isfinite(len) ? n / len : Vec3(0.f, 0.f, 1.f);
    if (glm::dot(n, radial) < 0.f) n = -n;  // outward
    s.n = n;
    // Mitsuba's local_frame: v_rot the z axis made orthogonal to the tangent (y where they are
    // parallel), v_rad = v_rot x tangent; u the angle of the normal in that frame.
    const float tl = glm::length(cp.dc);
    const Vec3 a = tl > 0.f ? cp.dc / tl : Vec3(0.f, 0.f, 1.f);
    Vec3 vrot = Vec3(0.f, 0.f, 1.f) - a * a.z;
    const float rl = glm::length(vrot);
    vrot = (std::abs(a.z) < 1.f && rl > 0.f) ? vrot / rl : Vec3(0.f, 1.f, 0.f);
    const Vec3 vrad = glm::cross(vrot, a);
    float phi = std::atan2(glm::dot(vrot, n), glm::dot(vrad, n));
    if (phi < 0.f) phi += 2.f * kPi;
    s.uv = Vec2(std::min(phi * (0.5f * kInvPi), 1.f), (float(prim) + u) / float(c.segments.size()));
    s.curvature = cp.r > 0.f ? 0.5f / cp.r : 0.f;
    return s;
}

void Scene::attachCurves(Vec3& lo, Vec3& hi) {
    for (size_t i = 0; i < desc_.curves.size(); ++i) {
        const CurveDesc& c = desc_.curves[i];
        RTCGeometry g = rtcNewGeometry(device_, c.bspline ? RTC_GEOMETRY_TYPE_ROUND_BSPLINE_CURVE
                                                          : RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE);
        auto* v = static_cast<glm::vec4*>(
            rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, sizeof(glm::vec4), c.points.size()));
        std::copy(c.points.begin(), c.points.end(), v);
        auto* idx = static_cast<uint32_t*>(
            rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, sizeof(uint32_t), c.segments.size()));
        std::copy(c.segments.begin(), c.segments.end(), idx);
        rtcCommitGeometry(g);
        const unsigned id = attach(g, c.group);
        geoms_[id].curve = int(i);
        if (c.group >= 0) continue;
        // The tube lies in the union of the control points' spheres' boxes: the centre line is a
        // convex combination of them, and so is the radius (B-spline basis and lerp alike).
        for (const glm::vec4& q : c.points) {
            lo = glm::min(lo, Vec3(q) - Vec3(q.w));
            hi = glm::max(hi, Vec3(q) + Vec3(q.w));
        }
    }
}

}  // namespace lt
