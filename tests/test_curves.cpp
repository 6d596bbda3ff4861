// Mitsuba's linearcurve and bsplinecurve (issue 46, core/curves.h): hits on a straight linear
// segment against the closed form of Embree's round-linear definition (a capsule for a constant
// radius: the cylinder between the two control points and their spheres), outward normals and
// Mitsuba's uv; B-spline hits on the sphere-swept surface; an instanced curve; PT, BPT and VCM
// agreeing on a curve under an area light; the loader's errors.
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <random>
#include "bsdf/surface_bsdf.h"
#include "core/curves.h"
#include "core/loader.h"
#include "core/scene.h"
#include "process.h"
#include "render_compare.h"
#include "scene_builders.h"

using namespace lt;
using namespace lt::test;

namespace {

std::string writeTemp(const std::string& name, const std::string& text) {
    static const TempDir dir("lt_test_curves");  // per process, removed at exit
    return dir.write(name, text);
}


std::string curveScene(const std::string& type, const std::string& file, const std::string& extra = "") {
    return R"(<scene version="3.0.0"><shape type=")" + type + R"("><string name="filename" value=")" + file + "\"/>" +
           extra + R"(</shape><emitter type="constant"/></scene>)";
}

// The nearest t > 0 of the ray o + t d (d unit) on the sphere (c, r), or infinity.
double sphereT(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& c, double r) {
    const glm::dvec3 oc = o - c;
    const double b = glm::dot(oc, d), disc = b * b - (glm::dot(oc, oc) - r * r);
    if (disc < 0) return INFINITY;
    const double t = -b - std::sqrt(disc);
    return t > 0 ? t : INFINITY;
}

}  // namespace

TEST_CASE("linearcurve: hits and normals and uv against the capsule", "[curves]") {
    // One segment from (0, 0, 0) to (2, 0, 0), radius 0.25: Embree's round linear curve with a
    // constant radius is the capsule: the cylinder 0 <= x <= 2, y^2 + z^2 = r^2, and the spheres
    // at the two control points.
    const std::string file = writeTemp("seg.txt", "0 0 0 0.25\n2 0 0 0.25\n");
    const SceneDesc d = loadScene(writeTemp("seg.xml", curveScene("linearcurve", file)), {});
    REQUIRE(d.curves.size() == 1);
    REQUIRE(d.curves[0].segments.size() == 1);
    const Scene scene(d);
    const double r = 0.25;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    int hits = 0, capHits = 0;
    for (int i = 0; i < 4000; ++i) {
        // From a random point on a sphere of radius 4 about (1, 0, 0) towards a random point of
        // the capsule's bounding box (a few miss: compared too).
        const double z = 2 * U(rng) - 1, ph = 2 * M_PI * U(rng), s = std::sqrt(1 - z * z);
        const glm::dvec3 o = glm::dvec3(1, 0, 0) + 4.0 * glm::dvec3(s * std::cos(ph), s * std::sin(ph), z);
        const glm::dvec3 target(-0.3 + 2.6 * U(rng), -0.3 + 0.6 * U(rng), -0.3 + 0.6 * U(rng));
        const glm::dvec3 dir = glm::normalize(target - o);
        // Closed form: the open cylinder (in its x range) and the two spheres.
        double tc = INFINITY;
        {
            const double a = dir.y * dir.y + dir.z * dir.z, b = o.y * dir.y + o.z * dir.z,
                         c = o.y * o.y + o.z * o.z - r * r, disc = b * b - a * c;
            if (a > 0 && disc >= 0) {
                const double t = (-b - std::sqrt(disc)) / a, x = o.x + t * dir.x;
                if (t > 0 && x >= 0 && x <= 2) tc = t;
            }
        }
        const double ts = std::min(sphereT(o, dir, glm::dvec3(0, 0, 0), r), sphereT(o, dir, glm::dvec3(2, 0, 0), r));
        const double tExpected = std::min(tc, ts);
        SurfaceHit h;
        const bool hit = scene.intersect(Ray{Vec3(o), Vec3(dir)}, h);
        // Rays grazing the surface within float error may go either way.
        if (hit != std::isfinite(tExpected)) {
            const glm::dvec3 q = o + glm::dot(glm::dvec3(1, 0, 0) - o, dir) * dir;
            INFO("ray " << i);
            CHECK(std::abs(std::hypot(q.y, q.z) - r) < 1e-3);  // never happens away from a silhouette
            continue;
        }
        if (!hit) continue;
        ++hits;
        INFO("ray " << i << " expected t " << tExpected << " got " << h.t);
        REQUIRE(h.t == Approx(tExpected).margin(2e-4));
        const glm::dvec3 p = o + tExpected * dir;
        // The capsule's outward normal: from the nearest axis point.
        const glm::dvec3 axisPoint(std::clamp(p.x, 0.0, 2.0), 0, 0);
        const glm::dvec3 n = glm::normalize(p - axisPoint);
        if (p.x < 0 || p.x > 2) ++capHits;
        CHECK(glm::dot(glm::dvec3(h.ng), n) > 0.9999);
        CHECK(glm::dot(glm::dvec3(h.shading.n), n) > 0.9999);
        CHECK(glm::dot(h.ng, Vec3(dir)) < 0.f);  // facing the ray: hits come from outside
        CHECK(h.curvature == Approx(0.5 / r).epsilon(1e-4));
        // Mitsuba's uv: v along the segment (one segment: the curve parameter, p.x / 2 on the
        // cylinder), u the angle about +x from v_rad = v_rot x axis, v_rot = +z: v_rad = +y.
        if (p.x > 0.01 && p.x < 1.99) {
            CHECK(h.uv.y == Approx(p.x / 2).margin(1e-3));
            double phi = std::atan2(n.z, n.y);
            if (phi < 0) phi += 2 * M_PI;
            const double du = std::abs(h.uv.x - phi / (2 * M_PI));
            CHECK(std::min(du, 1 - du) < 1e-3);
        }
    }
    CHECK(hits > 1000);
    CHECK(capHits > 20);
}

TEST_CASE("bsplinecurve: hits lie on the sphere-swept surface with outward normals", "[curves]") {
    // Two curves: a constant radius 0.1 (hits at distance 0.1 from the centre line) and a varying
    // radius. A point p is on the sweep of spheres (c(s), r(s)) where min_s |p - c(s)| - r(s) = 0,
    // and its normal is (p - c(s*)) / |p - c(s*)| at the minimiser s*; s sampled densely.
    const std::string file = writeTemp("bs.txt",
                                       "-1 0 -0.2 0.1\n-0.5 0.1 0.2 0.1\n0 -0.1 -0.2 0.1\n0.5 0.1 0.2 0.1\n1 0 -0.2 0.1\n"
                                       "\n"
                                       "-1 1.5 0 0.05\n-0.3 1.8 0.4 0.1\n0.3 1.2 -0.2 0.15\n1 1.5 0.3 0.2\n");
    const SceneDesc d = loadScene(writeTemp("bs.xml", curveScene("bsplinecurve", file)), {});
    REQUIRE(d.curves.size() == 1);
    const CurveDesc& c = d.curves[0];
    REQUIRE(c.segments.size() == 3);  // 5 - 3 and 4 - 3
    const Scene scene(d);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    int hits = 0, exitHits = 0;
    double worst = 0, worstN = 1;
    for (int i = 0; i < 600; ++i) {
        const unsigned seg = unsigned(i % 3);
        const CurvePoint target = curvePoint(c, seg, float(U(rng)));
        const double z = 2 * U(rng) - 1, ph = 2 * M_PI * U(rng), s = std::sqrt(1 - z * z);
        const glm::dvec3 o = glm::dvec3(target.c) + 3.0 * glm::dvec3(s * std::cos(ph), s * std::sin(ph), z);
        const Vec3 dir = Vec3(glm::normalize(glm::dvec3(target.c) - o));
        SurfaceHit h;
        if (!scene.intersect(Ray{Vec3(o), dir}, h)) continue;
        ++hits;
        double best = INFINITY;
        glm::dvec3 bestC(0);
        for (unsigned k = 0; k < c.segments.size(); ++k)
            for (int j = 0; j <= 4000; ++j) {
                const CurvePoint q = curvePoint(c, k, float(j) / 4000.f);
                const double dist = glm::length(glm::dvec3(h.p) - glm::dvec3(q.c)) - q.r;
                if (dist < best) best = dist, bestC = glm::dvec3(q.c);
            }
        worst = std::max(worst, std::abs(best));
        worstN = std::min(worstN, glm::dot(glm::dvec3(h.ng), glm::normalize(glm::dvec3(h.p) - bestC)));
        if (glm::dot(h.ng, dir) >= 0.f) ++exitHits;
        CHECK(h.uv.y >= 0.f);
        CHECK(h.uv.y <= 1.f);
    }
    INFO("worst |distance| " << worst << " worst normal cosine " << worstN << " exit hits " << exitHits);
    CHECK(hits > 400);
    // Embree 3.13's round B-spline intersector misses the entry on some rays at a small angle to
    // the tangent and reports the exit (outward normal facing along the ray): 0.9% of random rays
    // on a straight B-spline, about 11% on these bent ones (measured with Embree alone; linear curves:
    // none). Mitsuba's scalar variants call the same primitive. Bounded here, not fixed.
    CHECK(exitHits < hits / 5);
    CHECK(worst < 1e-3);    // Embree's float intersection; a sampling step of 1/4000 adds < 1e-5
    CHECK(worstN > 0.995);  // the normal from the dense-sampled nearest sphere
}

TEST_CASE("linearcurve in a shapegroup: an instance moves it and scales its radius", "[curves][instancing]") {
    const std::string file = writeTemp("gseg.txt", "0 0 0 0.25\n2 0 0 0.25\n");
    const SceneDesc d = loadScene(writeTemp("g.xml", R"(<scene version="3.0.0">
        <shape type="shapegroup" id="g"><shape type="linearcurve"><string name="filename" value=")" + file +
                                                            R"("/></shape></shape>
        <shape type="instance"><ref id="g"/><transform name="to_world"><scale value="2"/><translate y="5"/></transform></shape>
        <emitter type="constant"/></scene>)"),
                                  {});
    const Scene scene(d);
    SurfaceHit h;
    // The segment becomes (0, 5, 0) - (4, 5, 0) with radius 0.5: a ray down -z at x = 2, y = 5.2.
    REQUIRE(scene.intersect(Ray{Vec3(2, 5.2f, 3), Vec3(0, 0, -1)}, h));
    const double zExpected = std::sqrt(0.25 - 0.04);
    CHECK(h.p.z == Approx(zExpected).margin(1e-4));
    CHECK(h.ng.z > 0.9f);
    CHECK(h.curvature == Approx(0.5 / 0.5).epsilon(1e-3));
    CHECK_FALSE(scene.intersect(Ray{Vec3(2, 0.1f, 3), Vec3(0, 0, -1)}, h));  // the group alone is not rendered
}

TEST_CASE("a curve under an area light: PT and BPT and VCM agree", "[curves][bpt][statistical]") {
    // A diffuse floor and a diffuse B-spline arc and a linear zigzag lit by a small area light
    // (NEE, emitter hits, light tracing and connections). 32x32 in 4x4 blocks, K = 10 renders
    // per integrator, Welch's t per block against PT at family-wise significance 1% per
    // comparison (Sidak over the 16 blocks): a false alarm in 1% of runs per integrator, fixed
    // seeds make it deterministic.
    SceneDesc d;
    d.bsdfs.push_back(makeDiffuse(Color(0.7f)));
    d.bsdfs.push_back(makeDiffuse(Color(0.8f, 0.4f, 0.2f)));
    d.meshes.push_back(quad(Vec3(-2, -1, -2), Vec3(0, 0, 4), Vec3(4, 0, 0), 0));  // floor y = -1, up
    d.meshes.push_back(quad(Vec3(-0.4f, 1.5f, 0.1f), Vec3(0.8f, 0, 0), Vec3(0, 0, 0.8f), 0, 0));  // light, down
    EmitterDesc e;
    e.type = EmitterType::Area;
    e.value = Color(6.f);
    d.emitters.push_back(e);
    CurveDesc arc;
    arc.bspline = true;
    arc.points = {glm::vec4(-1.5f, -1.f, 0.5f, 0.15f), glm::vec4(-0.8f, 0.2f, 0.5f, 0.2f),
                  glm::vec4(0.f, 0.6f, 0.3f, 0.2f), glm::vec4(0.8f, 0.2f, 0.5f, 0.2f), glm::vec4(1.5f, -1.f, 0.5f, 0.15f)};
    arc.segments = {0, 1};
    arc.bsdf = 1;
    d.curves.push_back(arc);
    CurveDesc zig;
    zig.points = {glm::vec4(-1.2f, -0.8f, -0.5f, 0.12f), glm::vec4(-0.4f, -0.3f, -0.5f, 0.12f),
                  glm::vec4(0.4f, -0.8f, -0.5f, 0.12f), glm::vec4(1.2f, -0.3f, -0.5f, 0.12f)};
    zig.segments = {0, 1, 2};
    zig.bsdf = 0;
    d.curves.push_back(zig);
    d.camera = lookAt(Vec3(0, 1.2f, -4), Vec3(0, -0.2f, 0.2f), Vec3(0, 1, 0), 45.f, 32, 32);
    RenderSettings s;
    s.spp = 4;
    s.maxDepth = 4;
    const auto pt = checkAgreesWithPt(d, s, {"bpt", "vcm"});
    // Power: without the arc the image differs from PT's.
    SceneDesc without = d;
    without.curves.erase(without.curves.begin());
    s.integrator = "pt";
    CHECK(differingBlocks(pt, blockStats(without, s, 10, 4), 0.01) > 0);
    // No NaN or infinity reaches the image.
    const Image img = renderDesc(d, s);
    for (const Color& px : img.pixels) REQUIRE(isFinite(px));
}

TEST_CASE("loader: curve errors name the file and line and parameter", "[curves][loader]") {
    SECTION("missing file") {
        const std::string m = loadError(writeTemp("m.xml", curveScene("linearcurve", "nope.txt")));
        CHECK_THAT(m, Catch::Contains("nope.txt") && Catch::Contains("filename") && Catch::Contains("m.xml"));
    }
    SECTION("malformed line") {
        const std::string f = writeTemp("bad.txt", "0 0 0 0.1\n1 0 x 0.1\n");
        const std::string m = loadError(writeTemp("b.xml", curveScene("linearcurve", f)));
        CHECK_THAT(m, Catch::Contains("bad.txt:2") && Catch::Contains("x y z radius") && Catch::Contains("b.xml"));
    }
    SECTION("negative radius") {
        const std::string f = writeTemp("neg.txt", "0 0 0 0.1\n1 0 0 0.1\n\n0 1 0 0.1\n1 1 0 -0.2\n");
        const std::string m = loadError(writeTemp("n.xml", curveScene("linearcurve", f)));
        CHECK_THAT(m, Catch::Contains("neg.txt:5") && Catch::Contains("negative radius"));
    }
    SECTION("too few control points") {
        const std::string f = writeTemp("few.txt", "0 0 0 0.1\n1 0 0 0.1\n2 0 0 0.1\n");
        const std::string m = loadError(writeTemp("f.xml", curveScene("bsplinecurve", f)));
        CHECK_THAT(m, Catch::Contains("few.txt:1") && Catch::Contains("four control points"));
        const std::string one = writeTemp("one.txt", "0 0 0 0.1\n1 0 0 0.1\n\n\n5 5 5 1\n");
        CHECK_THAT(loadError(writeTemp("o.xml", curveScene("linearcurve", one))), Catch::Contains("one.txt:5"));
    }
    SECTION("empty file") {
        const std::string f = writeTemp("empty.txt", "\n  \n");
        CHECK_THAT(loadError(writeTemp("e.xml", curveScene("linearcurve", f))), Catch::Contains("no control points"));
    }
    SECTION("an emitting curve is refused") {
        const std::string f = writeTemp("ok.txt", "0 0 0 0.1\n1 0 0 0.1\n");
        const std::string m = loadError(writeTemp(
            "em.xml", curveScene("linearcurve", f, R"(<emitter type="area"><rgb name="radiance" value="1"/></emitter>)")));
        CHECK_THAT(m, Catch::Contains("cannot be an area emitter"));
    }
    SECTION("a valid file loads: positions mapped by to_world, radii not") {
        const std::string f = writeTemp("ok2.txt", "0 0 0 0.1\r\n1 0 0 0.2\r\n");
        const SceneDesc d = loadScene(
            writeTemp("ok.xml", curveScene("linearcurve", f, R"(<transform name="to_world"><scale value="3"/></transform>
                <float name="silhouette_sampling_weight" value="2"/>)")),
            {});
        REQUIRE(d.curves.size() == 1);
        CHECK(d.curves[0].points[1] == glm::vec4(3, 0, 0, 0.2f));
    }
}
