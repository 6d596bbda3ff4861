// Path tracer: known answers (furnace, point light over a plane), agreement of its techniques,
// determinism across thread counts, independence of scene scale.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cstring>
#include <map>
#include "integrators/integrator.h"
#include "scene_builders.h"
#include "render_compare.h"
#include "stats.h"

using namespace lt;
using namespace lt::test;

TEST_CASE("white furnace: closed emitting diffuse sphere has radiance sum albedo^k", "[pt]") {
    // Every pixel sees L = sum_{k=0}^{D-1} a^k (D = max_depth segments): 1/(1-a) when unlimited.
    // The furnace's only variance comes from Russian roulette and the light/BSDF sampling of a
    // constant integrand; the image mean over 32x32 pixels x 32 spp is compared with the known
    // value within 4 standard errors (two-sided significance ~6e-5; the standard error is
    // measured from the pixel spread). A floor of 3e-5 relative covers float precision: MIS weights
    // of emitter hits are recomputed from hit points whose error (the ray offset, ~1e-5 relative)
    // matters on very short segments; measured deficit 1.3e-5 with 256 spp.
    const float albedo = 0.5f;
    for (int depth : {-1, 1, 2, 3}) {
        double expected = depth < 0 ? 1.0 / (1.0 - albedo) : (1.0 - std::pow(albedo, depth)) / (1.0 - albedo);
        RenderSettings s;
        s.spp = 32;
        s.maxDepth = depth;
        s.seed = 3;
        Image img = renderDesc(furnace(32, albedo), s);
        double m = imageMean(img), v = 0;
        for (const Color& c : img.pixels) v += sqr(float((c.x + c.y + c.z) / 3.0 - m));
        double se = std::sqrt(v / (img.pixels.size() - 1) / img.pixels.size());
        INFO("max_depth " << depth << ": mean " << m << " expected " << expected << " se " << se);
        CHECK(std::abs(m - expected) <= 4.0 * se + 3e-5 * expected);
    }
}

TEST_CASE("point light over a diffuse plane matches the analytic radiance", "[pt]") {
    // L(p) = rho/pi * I cos(theta) / d^2 at every plane point. The only noise is the position of
    // the sample inside the pixel (box filter), so each pixel is compared with the analytic
    // function averaged over the pixel (16x16 midpoint rule), with a tolerance of 4.5 standard
    // errors of that footprint average (its spread over the pixel / sqrt(spp)): family-wise
    // significance ~0.2% over the 256 pixels (Sidak), plus 1e-4 relative for the quadrature.
    SceneDesc d;
    const float rho = 0.8f, I = 5.f;
    const Vec3 lightPos(0.3f, 1.5f, -0.2f);
    d.bsdfs.push_back(makeDiffuse(Color(rho)));
    d.meshes.push_back(quad(Vec3(-5, 0, -5), Vec3(0, 0, 10), Vec3(10, 0, 0), 0));  // y = 0, normal +y
    EmitterDesc e;
    e.type = EmitterType::Point;
    e.position = lightPos;
    e.value = Color(I);
    d.emitters.push_back(e);
    const int res = 16;
    d.camera = lookAt(Vec3(0, 2, 2), Vec3(0, 0, 0), Vec3(0, 1, 0), 50.f, res, res);
    RenderSettings s;
    s.spp = 256;
    s.maxDepth = 2;
    Image img = renderDesc(d, s);
    Camera cam(d.camera);
    int checked = 0;
    for (int y = 0; y < res; ++y)
        for (int x = 0; x < res; ++x) {
            double sum = 0, sum2 = 0;
            const int q = 16;
            for (int j = 0; j < q; ++j)
                for (int i = 0; i < q; ++i) {
                    Ray r = cam.generateRay(Vec2(x + (i + 0.5f) / q, y + (j + 0.5f) / q));
                    double v = 0;
                    if (r.d.y < 0) {
                        float t = -r.o.y / r.d.y;
                        Vec3 p = r.o + t * r.d;
                        Vec3 l = lightPos - p;
                        float d2 = glm::dot(l, l);
                        v = rho / kPi * I * (l.y / std::sqrt(d2)) / d2;
                    }
                    sum += v;
                    sum2 += v * v;
                }
            double expected = sum / (q * q);
            double sd = std::sqrt(std::max(0.0, sum2 / (q * q) - expected * expected));
            double tol = 4.5 * sd / std::sqrt(double(s.spp)) + 1e-4 * expected;
            INFO("pixel " << x << "," << y << ": " << img.at(x, y).x << " vs " << expected << " tol " << tol);
            CHECK(std::abs(img.at(x, y).x - expected) <= tol);
            ++checked;
        }
    CHECK(checked == res * res);
}

TEST_CASE("PT with NEE only, BSDF sampling only and MIS agree", "[pt][statistical]") {
    // Per-block Welch t-tests (4x4 blocks) between strategies, variance from K = 12 independent
    // seeds each; family-wise significance 1% (Sidak over the 16 blocks of each pair).
    SceneDesc d = cornellBox(24, makeRoughConductor(MicrofacetType::GGX, 0.2f, 0.2f, Color(0.2f, 0.9f, 1.1f),
                                                    Color(3.9f, 2.4f, 2.1f), Color(1.f)));
    RenderSettings s;
    s.spp = 8;
    s.maxDepth = 4;
    const int k = 12, blocks = 4;
    s.ptStrategy = "mis";
    auto mis = blockStats(d, s, k, blocks);
    s.ptStrategy = "nee";
    auto nee = blockStats(d, s, k, blocks);
    s.ptStrategy = "bsdf";
    s.spp = 32;  // BSDF sampling alone is much noisier; more samples keep the test's power
    auto bsdf = blockStats(d, s, k, blocks);
    double w1, w2, w3;
    CHECK(differingBlocks(mis, nee, 0.01, &w1) == 0);
    CHECK(differingBlocks(mis, bsdf, 0.01, &w2) == 0);
    CHECK(differingBlocks(nee, bsdf, 0.01, &w3) == 0);
    INFO("worst |t|/critical: " << w1 << " " << w2 << " " << w3);
    // The test has power: a 3% change in the light's power is detected between MIS renders.
    SceneDesc brighter = d;
    brighter.emitters[0].value *= 1.03f;
    s.ptStrategy = "mis";
    s.spp = 8;
    auto misBright = blockStats(brighter, s, k, blocks);
    CHECK(differingBlocks(mis, misBright, 0.01) > 0);
}

TEST_CASE("images are bit-identical for 1 and 2 threads", "[pt][determinism]") {
    SceneDesc d = cornellBox(32, makeDiffuse(Color(0.5f)));
    RenderSettings s;
    s.spp = 4;
    s.seed = 42;
    s.threads = 1;
    Image a = renderDesc(d, s);
    s.threads = 2;
    Image b = renderDesc(d, s);
    REQUIRE(a.pixels.size() == b.pixels.size());
    CHECK(std::memcmp(a.pixels.data(), b.pixels.data(), a.pixels.size() * sizeof(Color)) == 0);
    s.seed = 43;  // and the seed matters
    Image c = renderDesc(d, s);
    CHECK(std::memcmp(a.pixels.data(), c.pixels.data(), a.pixels.size() * sizeof(Color)) != 0);
}

TEST_CASE("the same image for a scene scaled by 1e-3 and 1e3", "[pt][statistical]") {
    // Radiance does not change with scale, so the images must agree: per-block Welch t-tests at
    // family-wise 1% (Sidak over 16 blocks), K = 10 seeds each. Broken ray offsets show up as
    // self-shadowing (too dark) at one of the scales.
    BxdfPtr panel = makeDiffuse(Color(0.5f));
    RenderSettings s;
    s.spp = 4;
    s.maxDepth = 4;
    auto small = blockStats(cornellBox(24, panel, 1e-3f), s, 10, 4);
    auto large = blockStats(cornellBox(24, panel, 1e3f), s, 10, 4);
    auto unit = blockStats(cornellBox(24, panel, 1.f), s, 10, 4);
    CHECK(differingBlocks(small, large, 0.01) == 0);
    CHECK(differingBlocks(small, unit, 0.01) == 0);
}

TEST_CASE("the ray log holds exactly the rays the path tracer counted, and they replay", "[pt][raylog]") {
    // raybench compares the renderer with a bare loop over the rays logged here, so the log must
    // be complete (every counted ray, camera rays at depth 0) and replaying must give the same hits.
    SceneDesc d = furnace(16, 0.5f);  // closed: every closest-hit ray hits
    Scene scene(d);
    RenderSettings s;
    s.maxDepth = 6;
    auto pt = makeIntegrator(s);
    Film film(16, 16, FilterType::Box);
    RayLog log;
    WalkStats stats;
    stats.log = &log;
    pt->renderTile(scene, film, 0, 0, 0, 16, 16, stats);
    CHECK(log.closest.size() + log.shadow.size() == stats.rays);
    REQUIRE(log.closestDepth.size() == log.closest.size());
    size_t cameraRays = 0, deep = 0;
    for (uint16_t depth : log.closestDepth) cameraRays += depth == 0, deep += depth >= 2;
    CHECK(cameraRays == 16 * 16);
    CHECK(deep > 0);
    CHECK(log.shadow.size() > 0);
    // The order of casting (raybench's as-cast replay): one entry per ray, a camera ray first,
    // shadow rays interleaved with the closest-hit rays (not all at the end), and each sample's
    // closest-hit rays in depth order 0, 1, 2, ...
    REQUIRE(log.shadowAt.size() == log.closest.size() + log.shadow.size());
    CHECK_FALSE(log.shadowAt.front());
    size_t nShadowAt = 0, closestSeen = 0;
    for (size_t k = 0; k < log.shadowAt.size(); ++k) {
        if (log.shadowAt[k]) ++nShadowAt;
        else {
            // A depth-0 ray starts a new sample; its depth follows the previous closest ray's otherwise.
            if (closestSeen > 0 && log.closestDepth[closestSeen] != 0)
                CHECK(log.closestDepth[closestSeen] == log.closestDepth[closestSeen - 1] + 1);
            ++closestSeen;
        }
    }
    CHECK(nShadowAt == log.shadow.size());
    const auto firstShadow = std::find(log.shadowAt.begin(), log.shadowAt.end(), true) - log.shadowAt.begin();
    const auto lastClosest = std::find(log.shadowAt.rbegin(), log.shadowAt.rend(), false) - log.shadowAt.rbegin();
    CHECK(firstShadow < std::ptrdiff_t(log.shadowAt.size()) - 1 - lastClosest);
    // Every logged closest-hit ray hits the closed sphere; every shadow ray is a finite segment.
    size_t hits = 0;
    for (const Ray& r : log.closest) {
        SurfaceHit h;
        hits += scene.intersect(r, h);
    }
    CHECK(hits == log.closest.size());
    for (const Ray& r : log.shadow) CHECK((r.tMax > 0.f && std::isfinite(r.tMax)));
    // Without a log the same counts are made.
    WalkStats plain;
    Film film2(16, 16, FilterType::Box);
    pt->renderTile(scene, film2, 0, 0, 0, 16, 16, plain);
    CHECK(plain.rays == stats.rays);
}

TEST_CASE("a triangle with one shading normal has one shading frame at every hit", "[scene]") {
    // A tilted quad whose three vertex normals per triangle are equal (as the built-in rectangle
    // and cube after a rotation): every hit on a triangle has the same frame, bit for bit (the
    // interpolated b0 n + b1 n + b2 n, renormalised, differs by rounding from hit to hit). A quad
    // without vertex normals: the frame of its face normal.
    SceneDesc d;
    d.bsdfs.push_back(makeDiffuse(Color(0.5f)));
    const Vec3 c(-0.7f, -0.6f, 0.f), u(1.3f, 0.2f, -0.4f), v(0.1f, 0.9f, 0.7f), behind(0.f, 0.f, 3.f);
    MeshDesc tilted = quad(c, u, v, 0);
    const Vec3 n = glm::normalize(glm::cross(u, v));
    tilted.normals.assign(4, n);
    d.meshes.push_back(tilted);
    d.meshes.push_back(quad(c + behind, u, v, 0));  // no normals
    d.camera = lookAt(Vec3(0, 0, -3), Vec3(0), Vec3(0, 1, 0), 40.f, 8, 8);
    Scene scene(d);
    Rng rng(7, 0);
    std::map<int, Frame> first;  // by primId: the first hit's frame
    int hitsTilted = 0, hitsPlain = 0;
    for (int i = 0; i < 2000; ++i) {
        const Vec2 a = rng.uniform2();
        const Vec3 o(-0.2f + 0.4f * rng.uniform(), 0.3f * rng.uniform(), -2.f);
        const bool plain = i % 2 == 1;  // the second quad, from beyond it (the first one is behind it)
        const Vec3 from = plain ? o + Vec3(0.f, 0.f, 7.f) : o;
        const Vec3 to = c + a.x * u + a.y * v + (plain ? behind : Vec3(0.f));
        SurfaceHit h;
        if (!scene.intersect(Ray{from, glm::normalize(to - from)}, h)) continue;
        if (plain) {
            ++hitsPlain;
            const Frame face(h.ng);
            REQUIRE(std::memcmp(&h.shading, &face, sizeof(Frame)) == 0);
            continue;
        }
        ++hitsTilted;
        REQUIRE(glm::length(h.shading.n - n) < 1e-6f);
        auto [it, inserted] = first.emplace(h.primId, h.shading);
        if (!inserted) REQUIRE(std::memcmp(&h.shading, &it->second, sizeof(Frame)) == 0);
    }
    CHECK(hitsTilted > 500);
    CHECK(hitsPlain > 500);
    CHECK(first.size() == 2);
}

TEST_CASE("spheres tested directly hit as Embree's user geometry does, and the bare Embree scene holds them", "[scene]") {
    // Up to Scene::kDirectSpheres spheres are tested after Embree's meshes instead of as Embree
    // user geometry. The same box with 4 spheres (direct) and with a 5th far outside it (all five
    // in Embree): every ray from inside the box must give the same hit (geometry id, distance,
    // point, normals) and the same occlusion answer, bit for bit. The spheres overlap each other
    // and the walls, and one is inside another (flipped normals), so rays meet several.
    SceneDesc direct = cornellBox(8, makeDiffuse(Color(0.5f)));
    direct.spheres.clear();
    const Vec3 centres[4] = {{0.45f, -0.6f, 0.1f}, {-0.4f, -0.5f, -0.2f}, {0.1f, 0.6f, -0.7f}, {-0.4f, -0.5f, -0.2f}};
    const float radii[4] = {0.35f, 0.45f, 0.5f, 0.2f};
    for (int i = 0; i < 4; ++i) {
        SphereDesc sp;
        sp.center = centres[i];
        sp.radius = radii[i];
        sp.bsdf = i % 2 == 0 ? 3 : 0;
        sp.flipNormals = i == 3;
        direct.spheres.push_back(sp);
    }
    SceneDesc embree = direct;
    SphereDesc far;
    far.center = Vec3(50.f, 50.f, 50.f);
    far.radius = 0.1f;
    far.bsdf = 0;
    embree.spheres.push_back(far);
    REQUIRE(direct.spheres.size() <= Scene::kDirectSpheres);
    REQUIRE(embree.spheres.size() > Scene::kDirectSpheres);
    Scene a(direct), b(embree);
    Rng rng(11, 3);
    int sphereHits = 0, occluded = 0, free = 0;
    for (int i = 0; i < 20000; ++i) {
        const Vec3 o = Vec3(rng.uniform(), rng.uniform(), rng.uniform()) * 1.9f - Vec3(0.95f);
        const Vec3 d = sampleUniformSphere(rng.uniform2());
        const Ray ray{o, d};
        SurfaceHit ha, hb;
        const bool hitA = a.intersect(ray, ha), hitB = b.intersect(ray, hb);
        REQUIRE(hitA == hitB);
        if (hitA) {
            INFO("ray " << i);
            REQUIRE(ha.geomId == hb.geomId);
            REQUIRE(ha.t == hb.t);
            REQUIRE(ha.p == hb.p);
            REQUIRE(ha.ng == hb.ng);
            REQUIRE(std::memcmp(&ha.shading, &hb.shading, sizeof(Frame)) == 0);
            REQUIRE(ha.bxdf == hb.bxdf);
            sphereHits += ha.geomId >= int(direct.meshes.size());
            // The bare Embree scene of `a` (raybench's) finds the same shape at the same distance.
            RTCIntersectContext ctx;
            rtcInitIntersectContext(&ctx);
            RTCRayHit rh{};
            rh.ray.org_x = o.x, rh.ray.org_y = o.y, rh.ray.org_z = o.z;
            rh.ray.dir_x = d.x, rh.ray.dir_y = d.y, rh.ray.dir_z = d.z;
            rh.ray.tnear = ray.tMin, rh.ray.tfar = ray.tMax, rh.ray.mask = ~0u;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(a.embreeScene(), &ctx, &rh);
            REQUIRE(int(rh.hit.geomID) == ha.geomId);
            REQUIRE(rh.ray.tfar == ha.t);
        }
        // A segment of random length along the ray.
        Ray seg = ray;
        seg.tMax = 2.f * rng.uniform();
        const bool occA = a.occludedRay(seg), occB = b.occludedRay(seg);
        REQUIRE(occA == occB);
        occluded += occA;
        free += !occA;
    }
    CHECK(sphereHits > 3000);
    CHECK(occluded > 3000);
    CHECK(free > 3000);
}
