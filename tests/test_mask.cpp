// Mitsuba 3's mask BSDF as stochastic alpha testing in the intersection (core/opacity.h): hits on a
// masked shape accepted with probability opacity(uv), rejected ones skipped by intersect() and
// occludedRay() alike, so every integrator sees the same cut-outs.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include "core/loader.h"
#include "core/scene.h"
#include "core/texture/texture_factory.h"
#include "process.h"
#include "render_compare.h"
#include "scene_builders.h"

using namespace lt;
using namespace lt::test;
namespace fs = std::filesystem;

namespace {

// One value everywhere, as a texture: the filter runs (a texture makes a shape masked) but its
// decision is fixed.
class FlatTexture final : public Texture {
public:
    explicit FlatTexture(float v) : v_(v) {}
    Color eval(const Vec2&) const override { return Color(v_); }
    Color maxValue() const override { return Color(v_); }
    Color meanValue() const override { return Color(v_); }
    std::string name() const override { return "flat"; }

private:
    float v_;
};

Opacity textured(float v) { return Opacity{1.f, std::make_shared<FlatTexture>(v)}; }

// Mitsuba's checkerboard with color0 = 1 (opaque), color1 = 0 (cut out), cells of 1/8 in uv.
Opacity checker() {
    const glm::mat3 toUv(Vec3(4, 0, 0), Vec3(0, 4, 0), Vec3(0, 0, 1));
    return Opacity{1.f, makeCheckerboard(Color(1.f), Color(0.f), toUv)};
}

bool sameImage(const Image& a, const Image& b) {
    if (a.width != b.width || a.height != b.height) return false;
    for (size_t i = 0; i < a.pixels.size(); ++i)
        if (a.pixels[i] != b.pixels[i]) return false;
    return true;
}

// A floor (y = 0, [-2, 2]^2, diffuse 0.5) under a plane (y = 1, same extent, a black nested
// diffuse, uv 0..1) with `op`, a directional light of irradiance 1 straight down, and a camera at
// y = 0.9 between them looking down at the floor's [-1, 1]^2 (32x32 px, box filter): every pixel
// sees the floor, lit by L0 = 0.5 / pi where nothing is in the way. Direct light only.
SceneDesc shadowScene(const Opacity& op) {
    SceneDesc d;
    d.bsdfs.push_back(makeDiffuse(Color(0.5f)));
    d.bsdfs.push_back(makeDiffuse(Color(0.f)));
    d.meshes.push_back(quad(Vec3(-2, 0, -2), Vec3(0, 0, 4), Vec3(4, 0, 0), 0));  // normal +y
    MeshDesc plane = quad(Vec3(-2, 1, -2), Vec3(4, 0, 0), Vec3(0, 0, 4), 1);
    plane.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    plane.opacity = op;
    d.meshes.push_back(plane);
    EmitterDesc e;
    e.type = EmitterType::Directional;
    e.value = Color(1.f);
    e.direction = Vec3(0, -1, 0);
    d.emitters.push_back(e);
    d.camera = lookAt(Vec3(0, 0.9f, 0), Vec3(0, 0, 0), Vec3(0, 0, 1), float(2.0 * std::atan(1.0 / 0.9) * 180.0 / kPi),
                      32, 32);
    d.integrator.maxDepth = 2;
    return d;
}

RenderSettings settings(const std::string& integ, int spp, uint64_t seed = 7) {
    RenderSettings s;
    s.integrator = integ;
    s.spp = spp;
    s.seed = seed;
    s.maxDepth = 2;
    return s;
}

}  // namespace

TEST_CASE("mask: opacity 0 renders as if the shape were absent and opacity 1 as the plain shape", "[mask]") {
    // Bit for bit, in every integrator: the filters (meshes through Embree, spheres tested directly
    // and as Embree user geometry) accept every hit at 1 and none at 0, and nothing else changes.
    for (int extraSpheres : {0, 4}) {  // 4 more: more than Scene::kDirectSpheres, spheres in Embree
        SceneDesc plain = cornellBox(24, makeDiffuse(Color(0.6f, 0.5f, 0.3f)));
        for (int i = 0; i < extraSpheres; ++i) {
            SphereDesc s;
            s.center = Vec3(-0.8f + 0.1f * float(i), 0.8f, -0.8f);
            s.radius = 0.04f;
            s.bsdf = 0;
            plain.spheres.push_back(s);
        }
        plain.integrator.maxDepth = 4;
        // Opacity 1 by a texture on the panel and the big sphere (the filters run and accept).
        SceneDesc one = plain;
        one.meshes[5].opacity = textured(1.f);
        one.spheres[0].opacity = textured(1.f);
        // Opacity 0: a second panel and a second sphere that must not be there.
        SceneDesc zero = plain;
        MeshDesc ghost = quad(Vec3(-0.8f, -0.9f, 0.3f), Vec3(1.2f, 0.9f, 0.f), Vec3(0, 0.2f, 0.6f), 1);
        ghost.opacity = textured(0.f);
        zero.meshes.push_back(ghost);
        SphereDesc ghostSphere;
        ghostSphere.center = Vec3(-0.4f, 0.1f, 0.f);
        ghostSphere.radius = 0.3f;
        ghostSphere.bsdf = 2;
        ghostSphere.opacity = Opacity{0.f, nullptr};
        zero.spheres.push_back(ghostSphere);
        for (std::string integ : {"pt", "bpt", "vcm", "lt", "ppm"}) {
            RenderSettings s = settings(integ, 2);
            s.maxDepth = 4;
            s.threads = 1;
            const Image ref = renderDesc(plain, s);
            INFO(integ << " with " << extraSpheres << " extra spheres");
            CHECK(sameImage(ref, renderDesc(one, s)));
            CHECK(sameImage(ref, renderDesc(zero, s)));
            CHECK(imageMean(ref) > 0.0);
        }
        // Power: the ghosts at opacity 1 change the image.
        SceneDesc shown = zero;
        shown.meshes.back().opacity = Opacity{};
        shown.spheres.back().opacity = Opacity{};
        CHECK_FALSE(sameImage(renderDesc(plain, settings("pt", 2)), renderDesc(shown, settings("pt", 2))));
    }
}

TEST_CASE("mask: hits are accepted where the opacity is 1 and skipped where it is 0", "[mask]") {
    // A binary checkerboard on a plane and on a sphere: a ray's hit in the masked scene is the
    // first hit of the unmasked scene whose uv lies on an opaque cell (a sphere's far side when its
    // near side is cut out), and occludedRay agrees. Every ray, not a statistic.
    auto opaqueAt = [](const Vec2& uv) {
        const float s = 4.f * uv.x - std::floor(4.f * uv.x), t = 4.f * uv.y - std::floor(4.f * uv.y);
        return (s > 0.5f) == (t > 0.5f);
    };
    auto nearEdge = [](const Vec2& uv) {
        for (float c : {uv.x, uv.y}) {
            const float f = 8.f * c;
            if (std::abs(f - std::round(f)) < 1e-2f) return true;
        }
        return false;
    };
    for (int extraSpheres : {0, 5}) {
        SceneDesc plain;
        plain.bsdfs.push_back(makeDiffuse(Color(0.5f)));
        MeshDesc plane = quad(Vec3(-2, 0, -2), Vec3(0, 0, 4), Vec3(4, 0, 0), 0);
        plane.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
        plain.meshes.push_back(plane);
        SphereDesc sphere;
        sphere.center = Vec3(0, 2, 0);
        sphere.radius = 0.7f;
        sphere.bsdf = 0;
        sphere.toLocal = glm::mat3(glm::rotate(Mat4(1.f), 0.7f, Vec3(1.f, 0.3f, 0.f)));  // (a rotated to_world)
        plain.spheres.push_back(sphere);
        for (int i = 0; i < extraSpheres; ++i) {  // out of the way of the rays below
            SphereDesc s;
            s.center = Vec3(10.f + float(i), -10.f, 10.f);
            s.radius = 0.1f;
            s.bsdf = 0;
            plain.spheres.push_back(s);
        }
        plain.camera = lookAt(Vec3(0, 5, 5), Vec3(0, 0, 0), Vec3(0, 1, 0), 40.f, 8, 8);
        SceneDesc masked = plain;
        masked.meshes[0].opacity = checker();
        masked.spheres[0].opacity = checker();
        const Scene u(plain), m(masked);
        Rng rng(3, 0);
        int planeHits = 0, planeKept = 0, nearKept = 0, farKept = 0, missed = 0;
        for (int i = 0; i < 4000; ++i) {
            // Half the rays at the plane from above, half at the sphere from random directions.
            const bool atSphere = i % 2 == 1;
            const Vec3 target = atSphere ? Vec3(0, 2, 0) + 0.6f * Vec3(rng.uniform() - 0.5f, rng.uniform() - 0.5f,
                                                                         rng.uniform() - 0.5f)
                                         : Vec3(3.6f * rng.uniform() - 1.8f, 0.f, 3.6f * rng.uniform() - 1.8f);
            const Vec3 dirToOrigin = glm::normalize(Vec3(rng.uniform() - 0.5f, 1.f, rng.uniform() - 0.5f));
            const Vec3 o = atSphere ? target + 3.f * glm::normalize(Vec3(rng.uniform() - 0.5f, rng.uniform() - 0.5f,
                                                                        rng.uniform() - 0.5f))
                                    : target + Vec3(0, 0.5f, 0) + 0.5f * dirToOrigin;  // below the sphere
            const Ray ray{o, glm::normalize(target - o)};
            SurfaceHit hu, hm;
            if (!u.intersect(ray, hu)) continue;
            if (nearEdge(hu.uv)) continue;
            const bool gotM = m.intersect(ray, hm);
            Ray shadow = ray;
            shadow.tMax = 100.f;
            CHECK(m.occludedRay(shadow) == gotM);
            if (!atSphere) {
                if (hu.geomId != 0) continue;  // (the plane: mesh 0)
                ++planeHits;
                if (opaqueAt(hu.uv)) {
                    ++planeKept;
                    REQUIRE(gotM);
                    CHECK(hm.t == hu.t);
                    CHECK(hm.geomId == hu.geomId);
                } else {
                    CHECK_FALSE(gotM);
                }
                continue;
            }
            // The far side: the unmasked scene's hit from just past the near one.
            Ray far = ray;
            far.tMin = hu.t * (1.f + 1e-4f);
            SurfaceHit hf;
            const bool gotFar = u.intersect(far, hf) && hf.geomId == hu.geomId;
            if (opaqueAt(hu.uv)) {
                ++nearKept;
                REQUIRE(gotM);
                CHECK(hm.t == Approx(hu.t).epsilon(1e-5));
            } else if (gotFar && !nearEdge(hf.uv) && opaqueAt(hf.uv)) {
                ++farKept;
                REQUIRE(gotM);
                CHECK(hm.t == Approx(hf.t).epsilon(1e-5));
            } else if (gotFar && !nearEdge(hf.uv)) {
                ++missed;
                CHECK((!gotM || hm.geomId != hu.geomId));  // (through the sphere, maybe onto the plane)
            }
        }
        INFO(planeHits << " plane hits, " << nearKept << " near, " << farKept << " far, " << missed << " through");
        CHECK(planeKept > planeHits / 3);
        CHECK(planeKept < 2 * planeHits / 3);
        CHECK(nearKept > 100);
        CHECK(farKept > 50);
        CHECK(missed > 50);
    }
}

TEST_CASE("mask: a constant opacity 0.3 passes 0.7 of the light in PT and BPT and VCM and LT and PPM",
          "[mask][statistical]") {
    // The floor under the plane of opacity 0.3 has radiance 0.7 L0 everywhere (L0 = rho E / pi,
    // E = 1). K = 10 independent renders (seeds) per integrator: the mean of their image means is
    // compared with it by Student's t (9 degrees of freedom; independent renders, so the merges'
    // and splats' correlations between pixels do not matter), two-sided at 0.1% per integrator
    // (0.5% for the five). PPM is consistent here: the irradiance is uniform, so the merge disc
    // (radius 0.1, the camera's view ends 1 from the floor's edge) sees the same photon density
    // everywhere. Power: the unmasked value L0 and twice-masked 0.49 L0 are far outside.
    const double l0 = 0.5 / kPi, expected = 0.7 * l0;
    const SceneDesc d = shadowScene(Opacity{0.3f, nullptr});
    const int k = 10;
    const double crit = studentTCritical(0.001, k - 1);
    for (std::string integ : {"pt", "bpt", "vcm", "lt", "ppm"}) {
        std::vector<double> means;
        for (int i = 0; i < k; ++i) {
            RenderSettings s = settings(integ, integ == "lt" || integ == "ppm" ? 16 : 4, 100 + uint64_t(i));
            s.radius = 0.1f;
            means.push_back(imageMean(renderDesc(d, s)));
        }
        const SampleStats st = sampleStats(means);
        const double se = std::sqrt(st.var / k);
        const double t = (st.mean - expected) / se;
        INFO(integ << ": mean " << st.mean << " expected " << expected << " se " << se << " t " << t << " crit " << crit);
        CHECK(std::abs(t) < crit);
        CHECK(std::abs(st.mean - l0) / se > 3.0 * crit);
        CHECK(std::abs(st.mean - 0.49 * l0) / se > 3.0 * crit);
    }
}

TEST_CASE("mask: a binary checkerboard casts its pattern through shadow rays and through walks", "[mask][statistical]") {
    // The plane's 8x8 cells of 0.5 project onto 8x8-pixel blocks of the image (the light is
    // straight down, the camera's view [-1, 1]^2 starts on a cell edge). PT reaches the light by
    // next-event estimation only (a directional light): its blocks are exactly 0 under opaque cells
    // and L0 under cut-out ones, alternating. Light tracing reaches the floor by walks through the
    // plane: its blocks are 0 where PT's are (no light can get there) and agree with L0 elsewhere
    // by a z-test on the block's 64 pixels, Sidak-corrected to 1% over the 8 lit blocks.
    const double l0 = 0.5 / kPi;
    const SceneDesc d = shadowScene(checker());
    const std::vector<double> pt = blockMeans(renderDesc(d, settings("pt", 4)), 4, 4);
    const Image ltImg = renderDesc(d, settings("lt", 64));
    const std::vector<double> lt = blockMeans(ltImg, 4, 4);
    const double zCrit = 3.22;  // two-sided at 1 - 0.99^(1/8) = 0.00126
    int lit = 0;
    for (int by = 0; by < 4; ++by)
        for (int bx = 0; bx < 4; ++bx) {
            const size_t b = size_t(by * 4 + bx);
            const bool on = pt[b] > 0.5 * l0;
            INFO("block " << bx << "," << by << ": pt " << pt[b] << " lt " << lt[b]);
            if (on) {
                ++lit;
                CHECK(pt[b] == Approx(l0).epsilon(1e-4));
                std::vector<double> v;
                for (int y = 8 * by; y < 8 * by + 8; ++y)
                    for (int x = 8 * bx; x < 8 * bx + 8; ++x) {
                        const Color& c = ltImg.at(x, y);
                        v.push_back((double(c.x) + c.y + c.z) / 3.0);
                    }
                const SampleStats st = sampleStats(v);
                CHECK(std::abs(st.mean - l0) / std::sqrt(st.var / 64.0) < zCrit);
            } else {
                CHECK(pt[b] == 0.0);
                CHECK(lt[b] == 0.0);
            }
            // A checkerboard: the right and lower neighbours differ.
            if (bx < 3) CHECK(on != (pt[b + 1] > 0.5 * l0));
            if (by < 3) CHECK(on != (pt[b + 4] > 0.5 * l0));
        }
    CHECK(lit == 8);
}

TEST_CASE("mask: the image is the same for any thread count", "[mask]") {
    SceneDesc d = cornellBox(24, makeDiffuse(Color(0.6f, 0.5f, 0.3f)));
    d.meshes[5].uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    d.meshes[5].opacity = checker();
    d.spheres[0].opacity = Opacity{0.5f, nullptr};
    d.integrator.maxDepth = 5;
    for (std::string integ : {"pt", "bpt", "vcm", "lt", "ppm"}) {
        RenderSettings s = settings(integ, 2);
        s.maxDepth = 5;
        s.threads = 1;
        const Image a = renderDesc(d, s);
        s.threads = 2;
        const Image b = renderDesc(d, s);
        s.threads = 3;
        const Image c = renderDesc(d, s);
        INFO(integ);
        CHECK(sameImage(a, b));
        CHECK(sameImage(a, c));
        for (const Color& p : a.pixels) REQUIRE(isFinite(p));
    }
}

namespace {

std::string writeTemp(const std::string& name, const std::string& text) {
    static const lt::test::TempDir dir("lt_test_mask");
    return dir.write(name, text);
}


}  // namespace

TEST_CASE("mask: the loader reads opacity and the nested bsdf and names file line and parameter on errors",
          "[mask][loader]") {
    const SceneDesc d = loadScene(writeTemp("ok.xml", R"(<scene version="3.0.0">
    <bsdf type="mask" id="m"><float name="opacity" value="0.3"/><bsdf type="diffuse"/></bsdf>
    <shape type="rectangle"><ref id="m"/></shape>
    <shape type="sphere"><bsdf type="mask"><bsdf type="conductor"/></bsdf></shape>
    <shape type="rectangle"><bsdf type="twosided"><bsdf type="mask">
        <texture type="checkerboard" name="opacity"/><bsdf type="diffuse"/></bsdf></bsdf></shape>
    <shape type="rectangle"><bsdf type="mask"><float name="opacity" value="1"/><bsdf type="diffuse"/></bsdf></shape>
    <shape type="rectangle"><bsdf type="diffuse"/></shape>
    <emitter type="constant"/>
</scene>)"),
                                  {});
    REQUIRE(d.meshes.size() == 4);
    REQUIRE(d.spheres.size() == 1);
    CHECK(d.meshes[0].opacity.value == 0.3f);
    CHECK(d.meshes[0].opacity.masked());
    CHECK(d.spheres[0].opacity.value == 0.5f);  // Mitsuba's default
    CHECK(d.bsdfs[size_t(d.spheres[0].bsdf)]->isDelta());  // the nested conductor is the material
    CHECK(d.meshes[1].opacity.texture != nullptr);         // through the twosided
    CHECK_FALSE(d.meshes[2].opacity.masked());             // opacity 1: no mask at all
    CHECK_FALSE(d.meshes[3].opacity.masked());
    struct Bad {
        const char* name;
        const char* body;
        int line;
        const char* what;
    };
    const Bad bad[] = {
        {"range.xml", R"(<bsdf type="mask"><float name="opacity" value="1.5"/><bsdf type="diffuse"/></bsdf>)", 3,
         "'opacity'"},
        {"nan.xml", R"(<bsdf type="mask"><float name="opacity" value="nan"/><bsdf type="diffuse"/></bsdf>)", 3,
         "opacity"},
        {"neg.xml", R"(<bsdf type="mask"><rgb name="opacity" value="-0.2"/><bsdf type="diffuse"/></bsdf>)", 3,
         "'opacity'"},
        {"none.xml", R"(<bsdf type="mask"><float name="opacity" value="0.5"/></bsdf>)", 3, "nested <bsdf>"},
        {"two.xml", R"(<bsdf type="mask"><bsdf type="diffuse"/>
            <bsdf type="diffuse"/></bsdf>)", 4, "one nested bsdf"},
        {"tex.xml", R"(<bsdf type="mask"><texture type="checkerboard" name="alpha"/><bsdf type="diffuse"/></bsdf>)", 3,
         "'alpha'"},
        {"nested.xml", R"(<bsdf type="mask"><bsdf type="mask"><bsdf type="diffuse"/></bsdf></bsdf>)", 3,
         "a mask inside a mask"},
        {"blend.xml", R"(<bsdf type="blendbsdf"><bsdf type="mask"><bsdf type="diffuse"/></bsdf>
            <bsdf type="diffuse"/></bsdf>)", 3, "a mask inside a blendbsdf"},
    };
    for (const Bad& b : bad) {
        const std::string e = loadError(writeTemp(b.name, std::string(R"(<scene version="3.0.0">
    <emitter type="constant"/>
    <shape type="rectangle">)") + b.body + "</shape>\n</scene>"));
        INFO(b.name << ": " << e);
        CHECK(e.find(std::string(b.name) + ":" + std::to_string(b.line)) != std::string::npos);
        CHECK(e.find(b.what) != std::string::npos);
    }
    const std::string e = loadError(writeTemp("emit.xml", R"(<scene version="3.0.0">
    <shape type="rectangle"><bsdf type="mask"><bsdf type="diffuse"/></bsdf>
        <emitter type="area"/></shape>
</scene>)"));
    INFO(e);
    CHECK(e.find("emit.xml:2") != std::string::npos);
    CHECK(e.find("emitting") != std::string::npos);
}
