// Mitsuba 3's linearcurve and bsplinecurve shapes (src/shapes/linearcurve.cpp, bsplinecurve.cpp
// are the spec), on Embree's native round curves: RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE (each
// segment a cone between two spheres of the control points' radii: spherical joints and end caps)
// and RTC_GEOMETRY_TYPE_ROUND_BSPLINE_CURVE (the sweep of a sphere of radius r(t) along the
// uniform cubic B-spline c(t) of four control points; open-ended). As in Mitsuba (which uses the
// same Embree primitives), back faces are culled: a ray starting inside a curve does not hit it.
//
// File format (Mitsuba's): one control point "x y z radius" per line, blank lines between curves,
// at least 2 (linear) or 4 (B-spline) points per curve. to_world maps the positions; the radii are
// invariant to it (Mitsuba's documentation). uv as Mitsuba: u = the angle about the curve's
// tangent / 2 pi, measured in the frame of local_frame (v_rad = v_rot x tangent, v_rot the
// world z axis made orthogonal to the tangent), v = (segment index + t) / segment count.
//
// Curves cannot be area emitters: Mitsuba 3's curves implement no position sampling either.
#pragma once
#include <stdexcept>
#include <string>
#include "core/math.h"
#include "core/scene_desc.h"

namespace lt {

struct CurveError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// Reads a curve file into c.points (positions mapped by toWorld, radii as given) and c.segments.
// Throws CurveError naming the file and, for a bad line, its number: a line that is not four
// finite numbers, a negative radius, a curve with too few points, a file without points.
void readCurveFile(const std::string& path, bool bspline, const Mat4& toWorld, CurveDesc& c);

// The centre line, its derivative and the radius of segment `prim` at parameter t in [0, 1].
struct CurvePoint {
    Vec3 c, dc;
    float r;
};
CurvePoint curvePoint(const CurveDesc& c, unsigned prim, float t);

// A hit's surface: p = o + t d (the curve's space), n the unit outward normal (Embree's Ng, else
// p - c(u)), Mitsuba's uv, and |mean curvature| 1 / (2 r(u)): 1/r across the tube, ~0 along it.
struct CurveSurface {
    Vec3 p, n;
    Vec2 uv;
    float curvature;
};
CurveSurface curveSurface(const CurveDesc& c, unsigned prim, float u, const Vec3& embreeNg, const Vec3& o,
                          const Vec3& d, float t);

}  // namespace lt
