// The envmap emitter (core/envmap.h, Mitsuba 3's envmap): the map's orientation against Mitsuba's
// conventions, its sampling density (chi-square of sampleLi's and sampleLe's directions against
// pdfLi and pdfLeDir; the density integrates to 1), a constant map against the constant emitter,
// PT, BPT, VCM and LT agreeing under a non-uniform map, and the loader's parameters and errors.
#include <catch2/catch.hpp>

#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <glm/gtc/matrix_transform.hpp>

#include "chi2.h"
#include "core/envmap.h"
#include "core/loader.h"
#include "core/scene.h"
#include "integrators/integrator.h"
#include "render_compare.h"
#include "scene_builders.h"
#include "stats.h"
#include "process.h"

using namespace lt;
using namespace lt::test;
namespace fs = std::filesystem;

namespace {

// A per-process scratch directory for the files written here, removed at exit.
fs::path tempDir() {
    static lt::test::TempDir t("lt_test_envmap");
    return t.dir;
}

// A hot texel (5, 2) on a dim, slightly varying background.
Image hotTexelMap() {
    Image img(16, 8);
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) img.at(x, y) = Color(0.05f + 0.01f * float((x + 2 * y) % 5));
    img.at(5, 2) = Color(400.f, 300.f, 200.f);
    return img;
}

// A colour gradient in both directions, with a dark column.
Image gradientMap() {
    Image img(24, 12);
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            img.at(x, y) = Color(0.2f + float(x) / 6.f, 0.5f + float(y), 1.f + float((x * y) % 7)) * (x == 17 ? 0.f : 1.f);
    return img;
}

// A sky: blue, brighter towards the horizon, dim brown below it, and a "sun" of 2 x 2 texels at
// u ~ 0.16, theta ~ 50 degrees (the direction (0.62, 0.64, -0.45) in the map's frame).
Image sunSkyMap(int w = 32, int h = 16) {
    Image img(w, h);
    for (int y = 0; y < h; ++y) {
        const float theta = kPi * float(y) / float(h - 1);
        for (int x = 0; x < w; ++x)
            img.at(x, y) = theta < 0.5f * kPi ? Color(0.3f, 0.5f, 1.f) * (0.4f + 0.6f * theta / (0.5f * kPi))
                                              : Color(0.15f, 0.1f, 0.06f);
    }
    const int sx = int(0.16f * float(w)), sy = int(50.f / 180.f * float(h - 1) + 0.5f);
    for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) img.at(sx + dx, sy + dy) = Color(60.f, 55.f, 45.f);
    return img;
}

std::shared_ptr<const EnvironmentMap> makeMap(const Image& img, const Mat4& toWorld = Mat4(1.f), float scale = 1.f) {
    return std::make_shared<const EnvironmentMap>(img, toWorld, scale, "test map");
}

// Rotation about an oblique axis (not a symmetry of the lat-long grid).
Mat4 obliqueRotation() { return glm::rotate(Mat4(1.f), glm::radians(37.f), glm::normalize(Vec3(0.3f, 1.f, -0.5f))); }

EmitterDesc envEmitter(std::shared_ptr<const EnvironmentMap> map) {
    EmitterDesc e;
    e.type = EmitterType::Envmap;
    e.envmap = std::move(map);
    return e;
}

// A floor (y = 0), a diffuse and a rough metal sphere on it, lit by the emitter alone. With
// seeSky the camera looks across the floor at the horizon; without it, steeply down, so every
// pixel sees the floor or a sphere (light tracing cannot see the sky directly).
SceneDesc floorScene(const EmitterDesc& light, int res, bool seeSky) {
    SceneDesc d;
    d.bsdfs.push_back(makeDiffuse(Color(0.6f)));
    d.bsdfs.push_back(makeDiffuse(Color(0.7f, 0.3f, 0.2f)));
    d.bsdfs.push_back(makeRoughConductor(MicrofacetType::GGX, 0.25f, 0.25f, Color(0.2f, 0.9f, 1.1f),
                                         Color(3.9f, 2.4f, 2.1f), Color(1.f)));
    d.meshes.push_back(quad(Vec3(-3, 0, -3), Vec3(0, 0, 6), Vec3(6, 0, 0), 0));
    SphereDesc a;
    a.center = Vec3(-0.5f, 0.5f, 0.f);
    a.radius = 0.5f;
    a.bsdf = 1;
    d.spheres.push_back(a);
    SphereDesc b;
    b.center = Vec3(0.6f, 0.4f, 0.3f);
    b.radius = 0.4f;
    b.bsdf = 2;
    d.spheres.push_back(b);
    d.emitters.push_back(light);
    d.camera = seeSky ? lookAt(Vec3(0, 1.2f, 3.5f), Vec3(0, 0.5f, 0), Vec3(0, 1, 0), 50.f, res, res)
                      : lookAt(Vec3(0.2f, 4.f, 1.5f), Vec3(0, 0, 0), Vec3(0, 1, 0), 40.f, res, res);
    d.integrator.maxDepth = 4;
    return d;
}

// Mitsuba's uv_to_direction: the map-frame direction of (u, v).
Vec3 mitsubaDirection(float u, float v) {
    const float phi = 2.f * kPi * u, theta = kPi * v;
    return Vec3(std::sin(phi) * std::sin(theta), std::cos(theta), -std::cos(phi) * std::sin(theta));
}

bool near(const Color& a, const Color& b, float rel = 1e-4f) {
    return glm::length(a - b) <= rel * std::max(1.f, glm::length(b));
}

}  // namespace

TEST_CASE("envmap lookups follow Mitsuba's lat-long orientation with and without to_world", "[envmap]") {
    // Every texel distinct. Mitsuba 3 (src/emitters/envmap.cpp): u = atan2(x, -z) / 2 pi,
    // v = acos(y) / pi in the map's frame; column c centred at u = (c + 1/2) / W, row r at
    // v = r / (H - 1); so row 0 is +Y, u = 0 looks along -Z and u = 1/4 along +X.
    const int W = 4, H = 5;
    Image img(W, H);
    // (The top and bottom rows are the poles, one direction each: constant rows, as a sane map has.)
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            img.at(x, y) = y == 0       ? Color(7.f, 8.f, 9.f)
                           : y == H - 1 ? Color(3.f, 2.f, 1.f)
                                        : Color(1.f + float(x), 10.f + float(y), 100.f + float(x + W * y));
    const EnvironmentMap m(img, Mat4(1.f), 2.f, "test map");
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const Vec3 w = mitsubaDirection((float(x) + 0.5f) / W, float(y) / float(H - 1));
            INFO("texel " << x << " " << y);
            CHECK(near(m.eval(w), 2.f * img.at(x, y)));
        }
    // Named directions: row 2 of 5 is the horizon.
    const float s = std::sqrt(0.5f);
    CHECK(near(m.eval(Vec3(0, 1, 0)), 2.f * img.at(0, 0)));            // +Y: the top row
    CHECK(near(m.eval(Vec3(0, -1, 0)), 2.f * img.at(0, H - 1)));       // -Y: the bottom row
    CHECK(near(m.eval(Vec3(s, 0, -s)), 2.f * img.at(0, 2)));           // u = 1/8: column 0's centre
    CHECK(near(m.eval(Vec3(s, 0, s)), 2.f * img.at(1, 2)));            // u = 3/8
    CHECK(near(m.eval(Vec3(-s, 0, s)), 2.f * img.at(2, 2)));           // u = 5/8
    CHECK(near(m.eval(Vec3(-s, 0, -s)), 2.f * img.at(3, 2)));          // u = 7/8
    CHECK(near(m.eval(Vec3(0, 0, -1)), img.at(3, 2) + img.at(0, 2)));  // u = 0: halfway, across the seam
    CHECK(near(m.eval(Vec3(1, 0, 0)), img.at(0, 2) + img.at(1, 2)));   // u = 1/4: +X
    // Bilinear between rows: halfway between rows 1 and 2 (theta = 3 pi / 16).
    CHECK(near(m.eval(mitsubaDirection(0.125f, 0.375f)), img.at(0, 1) + img.at(0, 2)));
    CHECK(m.directionToUv(Vec3(1, 0, 0)).x == Approx(0.25f));
    CHECK(m.directionToUv(Vec3(0, 0, 1)).x == Approx(0.5f));
    CHECK(m.directionToUv(Vec3(0, -1, 0)).y == Approx(1.f));

    // With to_world: the texel seen in the map's direction w is seen in to_world w. A rotation of
    // 90 degrees about +Y maps +X to -Z (Mitsuba's <rotate y="1" angle="90"/>).
    const Mat4 rot = glm::rotate(Mat4(1.f), glm::radians(90.f), Vec3(0, 1, 0));
    const EnvironmentMap r(img, rot, 1.f, "rotated map");
    CHECK(near(r.eval(Vec3(-s, 0, -s)), img.at(0, 2)));  // column 0's centre (s, 0, -s), rotated
    CHECK(near(r.eval(Vec3(-s, 0, s)), img.at(3, 2)));
    const Mat4 obl = obliqueRotation();
    const EnvironmentMap o(img, obl, 1.f, "oblique map");
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const Vec3 w = Vec3(obl * Vec4(mitsubaDirection((float(x) + 0.5f) / W, float(y) / float(H - 1)), 0.f));
            INFO("oblique, texel " << x << " " << y);
            CHECK(near(o.eval(w), img.at(x, y), 1e-3f));
            const Vec2 uv = o.directionToUv(w);
            CHECK(glm::length(o.uvToDirection(uv) - w) < 1e-4f);
        }

    // The same through the loader and the scene's light: Le(n, w) is the radiance travelling
    // along w, so arriving from the sky direction -w.
    Image big(8, 5, Color(0.1f));
    big.at(0, 2) = Color(5.f, 0.f, 0.f);  // the horizon, u = 1/16
    const std::string exr = (tempDir() / "orient.exr").string();
    writeExr(big, exr);
    for (const bool rotated : {false, true}) {
        const std::string xml = (tempDir() / "orient.xml").string();
        std::ofstream(xml) << "<scene version=\"3.0.0\">\n<emitter type=\"envmap\">\n"
                              "<string name=\"filename\" value=\"orient.exr\"/>\n"
                           << (rotated ? "<transform name=\"to_world\"><rotate y=\"1\" angle=\"90\"/></transform>\n" : "")
                           << "</emitter>\n<shape type=\"sphere\"><float name=\"radius\" value=\"0.1\"/></shape>\n</scene>\n";
        const SceneDesc d = loadScene(xml);
        const Scene scene(d);
        REQUIRE(scene.lights().size() == 1);
        const Light& l = scene.lights()[0];
        CHECK(l.type == LightType::Envmap);
        CHECK(scene.infiniteLights().size() == 1);
        Vec3 sky = mitsubaDirection(1.f / 16.f, 0.5f);
        if (rotated) sky = Vec3(rot * Vec4(sky, 0.f));
        INFO("rotated " << rotated);
        CHECK(near(l.Le(Vec3(0.f), -sky), Color(5.f, 0.f, 0.f)));
        CHECK(near(l.Le(Vec3(0.f), sky), Color(0.1f)));  // the opposite side of the sky
    }
}

TEST_CASE("envmap sampleLi and sampleLe directions follow pdfLi and pdfLeDir (chi-square)", "[envmap][statistical]") {
    // Three maps (a hot texel on a dim background; a colour gradient with a black column; the
    // gradient under an oblique to_world), each light's sampleLi directions (from a point in the
    // scene) against pdfLi and its sampleLe directions (reversed: towards the sky) against
    // pdfLeDir: 400,000 samples over 40 x 80 bins of the sphere about +Y (Sidak: family-wise 1%
    // over the 6 tests). Also: each sample's own density and value are pdfLi's and Le's in its
    // direction (but at a cell boundary, where rounding may pick the neighbour).
    struct Case {
        const char* name;
        std::shared_ptr<const EnvironmentMap> map;
    };
    const Case cases[] = {{"hot texel", makeMap(hotTexelMap())},
                          {"gradient", makeMap(gradientMap())},
                          {"rotated gradient", makeMap(gradientMap(), obliqueRotation(), 3.f)}};
    const double level = chi2::sidakCorrectedLevel(0.01, 6);
    const long long n = 400000;
    uint64_t seed = 11;
    for (const Case& c : cases) {
        SceneDesc d;
        d.bsdfs.push_back(makeDiffuse(Color(0.5f)));
        d.meshes.push_back(quad(Vec3(-1, 0, -1), Vec3(0, 0, 2), Vec3(2, 0, 0), 0));
        d.emitters.push_back(envEmitter(c.map));
        const Scene scene(d);
        const Light& l = scene.lights()[0];
        const Vec3 refP(0.1f, 0.2f, 0.3f);
        chi2::SampleFn li = [&](Rng& rng, Vec3& w) {
            const LightSampleLi s = l.sampleLi(scene, refP, rng.uniform2());
            if (!(s.pdfPos.value > 0.f)) return false;
            w = s.wi;
            return true;
        };
        chi2::PdfFn liPdf = [&](const Vec3& w) { return double(l.pdfLi(scene, refP, Vec3(0.f), Vec3(0.f), w).value); };
        chi2::SampleFn le = [&](Rng& rng, Vec3& w) {
            const Vec2 uPos = rng.uniform2();
            const LightSampleLe s = l.sampleLe(scene, uPos, rng.uniform2());
            if (!(s.pdfPos.value > 0.f && s.pdfDir.value > 0.f)) return false;
            w = -s.dir;
            return true;
        };
        chi2::PdfFn lePdf = [&](const Vec3& w) { return double(l.pdfLeDir(Vec3(0.f), -w).value); };
        const chi2::Domain dom(Vec3(0, 1, 0), 10.0, 40, 80);
        const chi2::Result rLi = chi2::Chi2Test(li, n, seed++).run(liPdf, dom, level);
        INFO(c.name << " sampleLi: " << rLi.summary());
        CHECK(rLi.passed);
        const chi2::Result rLe = chi2::Chi2Test(le, n, seed++).run(lePdf, dom, level);
        INFO(c.name << " sampleLe: " << rLe.summary());
        CHECK(rLe.passed);

        Rng rng(seed++, 7);
        int pdfMismatch = 0, valueMismatch = 0;
        const int m = 20000;
        for (int k = 0; k < m; ++k) {
            const LightSampleLi s = l.sampleLi(scene, refP, rng.uniform2());
            REQUIRE(s.pdfPos.value > 0.f);
            CHECK(glm::length(s.wi) == Approx(1.f).margin(1e-5));
            CHECK(glm::length(s.p - refP) == Approx(2.f * scene.boundsRadius()).epsilon(1e-4));
            if (std::abs(s.pdfPos.value - liPdf(s.wi)) > 1e-5f * s.pdfPos.value) ++pdfMismatch;
            if (!near(s.value, l.Le(Vec3(0.f), -s.wi), 1e-3f)) ++valueMismatch;
            const LightSampleLe e = l.sampleLe(scene, rng.uniform2(), rng.uniform2());
            REQUIRE(e.pdfDir.value > 0.f);
            CHECK(e.pdfPos.value == Approx(1.f / (kPi * sqr(scene.geometryRadius()))));
            // The disk: facing dir, at the geometry's bounding radius behind its centre.
            const Vec3 off = e.p - scene.geometryCenter();
            CHECK(glm::dot(off, e.dir) == Approx(-scene.geometryRadius()).epsilon(1e-4));
            if (std::abs(e.pdfDir.value - lePdf(-e.dir)) > 1e-5f * e.pdfDir.value) ++pdfMismatch;
            if (!near(e.value, l.Le(Vec3(0.f), e.dir), 1e-3f)) ++valueMismatch;
        }
        INFO(c.name << ": " << pdfMismatch << " density and " << valueMismatch << " value mismatches of " << 2 * m);
        CHECK(pdfMismatch <= 2 * m / 1000);
        CHECK(valueMismatch <= 2 * m / 1000);
    }
}

TEST_CASE("envmap density integrates to one and its luminance integral and bound match the map", "[envmap]") {
    // Adaptive quadrature over the sphere (tests/chi2.h) of pdf and of the radiance's luminance;
    // maps include a 1x1 one (padded to 2x3 as Mitsuba) and a black column.
    std::vector<std::pair<std::string, std::shared_ptr<const EnvironmentMap>>> maps = {
        {"hot texel", makeMap(hotTexelMap())},
        {"gradient", makeMap(gradientMap(), Mat4(1.f), 0.5f)},
        {"rotated gradient", makeMap(gradientMap(), obliqueRotation())},
        {"sun and sky", makeMap(sunSkyMap())},
        {"1x1", makeMap(Image(1, 1, Color(0.3f, 0.6f, 0.9f)))}};
    const chi2::Domain dom(Vec3(0.2f, 1.f, 0.1f), 10.0, 30, 60);
    for (const auto& [name, m] : maps) {
        INFO(name);
        const double total = chi2::Chi2Test::integrateSphere([&](const Vec3& w) { return double(m->pdf(w)); }, dom, 1e-8);
        CHECK(total == Approx(1.0).epsilon(1e-3));
        const double lum = chi2::Chi2Test::integrateSphere([&](const Vec3& w) { return double(luminance(m->eval(w))); },
                                                           dom, 1e-8);
        CHECK(m->luminanceIntegral() == Approx(lum).epsilon(1e-3));
        // The bound: no direction's luminance exceeds it times the integral, and a texel's reaches it.
        float maxSeen = 0.f;
        for (int i = 0; i < 20000; ++i) {
            const float u = (float(i % 200) + 0.5f) / 200.f, v = (float(i / 200) + 0.5f) / 100.f;
            maxSeen = std::max(maxSeen, luminance(m->evalUv(u, v)));
        }
        CHECK(maxSeen <= m->directionalBound() * m->luminanceIntegral() * 1.0001f);
    }
    // A constant map: uniform density 1 / (4 pi), integral 4 pi L, bound 1 / (4 pi).
    const auto& c = maps.back().second;
    const float L = luminance(Color(0.3f, 0.6f, 0.9f));
    CHECK(c->luminanceIntegral() == Approx(4.0 * kPi * L).epsilon(1e-5));
    CHECK(c->directionalBound() == Approx(kUniformSpherePdf).epsilon(1e-5));
    Rng rng(3, 4);
    for (int i = 0; i < 1000; ++i) {
        const EnvironmentMap::Sample s = c->sample(rng.uniform2());
        CHECK(s.pdf == Approx(kUniformSpherePdf).epsilon(1e-5));
        CHECK(c->pdf(s.toSky) == Approx(kUniformSpherePdf).epsilon(1e-5));
        CHECK(near(s.value, Color(0.3f, 0.6f, 0.9f)));
    }
    // A black map: no sample, density 0, no power.
    const EnvironmentMap black(Image(4, 4, Color(0.f)), Mat4(1.f), 1.f, "black");
    CHECK(black.sample(Vec2(0.3f, 0.6f)).pdf == 0.f);
    CHECK(black.pdf(Vec3(0, 1, 0)) == 0.f);
    CHECK(black.luminanceIntegral() == 0.f);
}

TEST_CASE("envmap rejects bad texels and transforms naming the map", "[envmap]") {
    Image img(4, 3, Color(1.f));
    img.at(2, 1) = Color(1.f, std::numeric_limits<float>::quiet_NaN(), 1.f);
    CHECK_THROWS_WITH(EnvironmentMap(img, Mat4(1.f), 1.f, "nan.exr"), Catch::Contains("nan.exr") && Catch::Contains("(2, 1)") &&
                                                                         Catch::Contains("NaN"));
    img.at(2, 1) = Color(1.f, 1.f, -0.5f);
    CHECK_THROWS_WITH(EnvironmentMap(img, Mat4(1.f), 1.f, "neg.exr"), Catch::Contains("neg.exr") && Catch::Contains("negative"));
    img.at(2, 1) = Color(kInf);
    CHECK_THROWS_WITH(EnvironmentMap(img, Mat4(1.f), 1.f, "inf.exr"), Catch::Contains("infinite"));
    img.at(2, 1) = Color(1.f);
    CHECK_THROWS_WITH(EnvironmentMap(img, glm::scale(Mat4(1.f), Vec3(2.f)), 1.f, "s.exr"), Catch::Contains("rotation"));
    CHECK_THROWS_WITH(EnvironmentMap(img, Mat4(1.f), -1.f, "s.exr"), Catch::Contains("scale"));
    // A reflection and a translation are accepted (directions only).
    CHECK_NOTHROW(EnvironmentMap(img, glm::translate(glm::scale(Mat4(1.f), Vec3(-1.f, 1.f, 1.f)), Vec3(3.f)), 1.f, "r"));
}

TEST_CASE("a constant-valued envmap renders as the constant emitter", "[envmap][statistical]") {
    // The same radiance (0.8, 0.6, 0.4) from a 6x4 map (scale 2, an oblique to_world) and from the
    // constant emitter; the camera sees the sky too. PT and BPT, 32x32 images in 4x4 blocks, K = 8
    // seeds each, Welch t per block; family-wise 1% (Sidak over 16 blocks x 2 integrators).
    const int res = 32, k = 8, blocks = 4;
    EmitterDesc constant;
    constant.type = EmitterType::Constant;
    constant.value = Color(0.8f, 0.6f, 0.4f);
    const EmitterDesc env = envEmitter(makeMap(Image(6, 4, Color(0.4f, 0.3f, 0.2f)), obliqueRotation(), 2.f));
    for (const char* integ : {"pt", "bpt"}) {
        RenderSettings s;
        s.integrator = integ;
        s.spp = 4;
        s.maxDepth = 4;
        const auto a = blockStats(floorScene(constant, res, true), s, k, blocks);
        const auto b = blockStats(floorScene(env, res, true), s, k, blocks);
        // Blocks of sky alone have no variance (the constant emitter's radiance exactly, the map's
        // bilinear lookup up to rounding): a standard-error floor of 1e-5 of the mean.
        const double perBlock = sidak(1.0 - std::pow(1.0 - 0.01, 0.5), int(a.size()));  // (1% over both)
        double worst = 0;
        for (size_t i = 0; i < a.size(); ++i) {
            const double floor2 = 0.5 * sqr(1e-5f * float(a[i].mean));
            const double va = a[i].var / k + floor2, vb = b[i].var / k + floor2;
            const double df = sqr(float(va + vb)) / (va * va / (k - 1) + vb * vb / (k - 1));  // Welch's
            const double t = std::abs(a[i].mean - b[i].mean) / std::sqrt(va + vb);
            worst = std::max(worst, t / studentTCritical(perBlock, std::max(df, 1.0)));
        }
        INFO(integ << ": worst |t| / critical " << worst);
        CHECK(worst <= 1.0);
    }
}

TEST_CASE("BPT and VCM count a directly seen environment at full weight", "[envmap][bpt]") {
    // A camera (90 degrees) that sees only the sky: the emitter hit is the one technique for such
    // a path (no technique joins a light at infinity to the camera), so every pixel is the
    // radiance, exactly up to rounding, for constant and envmap alike.
    EmitterDesc constant;
    constant.type = EmitterType::Constant;
    constant.value = Color(0.8f, 0.6f, 0.4f);
    const EmitterDesc env = envEmitter(makeMap(Image(6, 4, Color(0.4f, 0.3f, 0.2f)), obliqueRotation(), 2.f));
    for (const EmitterDesc& e : {constant, env}) {
        SceneDesc d;
        d.bsdfs.push_back(makeDiffuse(Color(0.5f)));
        SphereDesc behind;
        behind.center = Vec3(0, 0, 5);
        behind.radius = 0.5f;
        behind.bsdf = 0;
        d.spheres.push_back(behind);
        d.emitters.push_back(e);
        d.camera = lookAt(Vec3(0, 0, 0), Vec3(0, 0, -1), Vec3(0, 1, 0), 90.f, 16, 16);
        for (const char* integ : {"pt", "bpt", "vcm"}) {
            RenderSettings s;
            s.integrator = integ;
            s.spp = 2;
            const Image img = renderDesc(d, s);
            float worst = 0.f;
            for (const Color& c : img.pixels) worst = std::max(worst, glm::length(c - Color(0.8f, 0.6f, 0.4f)));
            INFO(integ << (e.type == EmitterType::Envmap ? " envmap" : " constant") << ": largest error " << worst);
            CHECK(worst < 1e-5f);
        }
    }
}

TEST_CASE("PT and BPT and VCM and LT agree under a non-uniform envmap", "[envmap][bpt][statistical]") {
    // The floor scene seen from above (no sky in view: light tracing cannot see it), lit only by
    // the sun-and-sky map under an oblique to_world. 32x32 images in 4x4 blocks, K = 10 seeds per
    // integrator, Welch t per block against PT; family-wise 1% (Sidak over 16 blocks x 3
    // comparisons). VCM with a vanishing radius (its merges carry ~no weight). LT reaches the
    // scene only by sampleLe's rays from the disk: its agreement checks the emission densities.
    const int res = 32, k = 10, blocks = 4;
    const double alpha = 1.0 - std::pow(1.0 - 0.01, 1.0 / 3.0);  // per comparison (Sidak over its blocks inside)
    const SceneDesc d = floorScene(envEmitter(makeMap(sunSkyMap(), obliqueRotation())), res, false);
    RenderSettings s;
    s.spp = 4;
    s.maxDepth = 4;
    s.integrator = "pt";
    const auto pt = blockStats(d, s, k, blocks);
    for (const char* integ : {"bpt", "lt", "vcm"}) {
        RenderSettings o = s;
        o.integrator = integ;
        o.spp = std::string(integ) == "lt" ? 16 : 4;
        if (std::string(integ) == "vcm") o.radius = 1e-6f;
        double worst = 0;
        const int bad = differingBlocks(blockStats(d, o, k, blocks), pt, alpha, &worst);
        INFO(integ << " vs pt: worst |t| / critical " << worst);
        CHECK(bad == 0);
    }
    // Power: the map mirrored (to_world with x -> -x after the rotation) must differ.
    const Mat4 mirrored = glm::scale(Mat4(1.f), Vec3(-1.f, 1.f, 1.f)) * obliqueRotation();
    const SceneDesc m = floorScene(envEmitter(makeMap(sunSkyMap(), mirrored)), res, false);
    CHECK(differingBlocks(blockStats(m, s, k, blocks), pt, alpha) > 0);
}

TEST_CASE("regularised integrators render an envmap scene to finite values", "[envmap]") {
    // JG19 reads the envmap's directional bound (largest luminance over its integral).
    const SceneDesc d = floorScene(envEmitter(makeMap(sunSkyMap())), 16, true);
    const std::pair<const char*, const char*> configs[] = {
        {"pt", "jg19"}, {"bpt", "jg19"}, {"vcm", "jg19"}, {"pt", "opsr"}, {"pt", "kd13"}};
    for (const auto& [integ, reg] : configs) {
        RenderSettings s;
        s.integrator = integ;
        s.regularizer = reg;
        s.spp = 2;
        s.maxDepth = 4;
        const Image img = renderDesc(d, s);
        bool finite = true;
        for (const Color& c : img.pixels) finite = finite && isFinite(c) && c.x >= 0.f && c.y >= 0.f && c.z >= 0.f;
        INFO(integ << " " << reg);
        CHECK(finite);
        CHECK(imageMean(img) > 0.0);
    }
}

TEST_CASE("loader: envmap parameters and errors", "[envmap][loader]") {
    const fs::path dir = tempDir() / "loader";
    fs::create_directories(dir / "maps");
    writeExr(gradientMap(), (dir / "maps" / "sky.exr").string());
    Image negMap(4, 3, Color(1.f));
    negMap.at(1, 1).z = -2.f;
    writeExr(negMap, (dir / "maps" / "negative.exr").string());
    {
        // A PFM by hand (writers refuse NaN): 4 x 3 RGB, little endian, rows bottom to top; the NaN
        // in file row 1 is image row 1 (of 3) too, column 2.
        std::ofstream f(dir / "maps" / "nan.pfm", std::ios::binary);
        f << "PF\n4 3\n-1.0\n";
        for (int row = 0; row < 3; ++row)
            for (int x = 0; x < 4; ++x)
                for (int ch = 0; ch < 3; ++ch) {
                    const float v = row == 1 && x == 2 && ch == 0 ? std::numeric_limits<float>::quiet_NaN() : 1.f;
                    f.write(reinterpret_cast<const char*>(&v), 4);
                }
    }
    std::ofstream(dir / "maps" / "garbage.exr") << "not an image";
    std::ofstream(dir / "maps" / "sky.png") << "not read";
    auto write = [&](const std::string& body) {
        const fs::path p = dir / "scene.xml";
        std::ofstream(p) << "<scene version=\"3.0.0\">\n" << body << "\n</scene>\n";
        return p.string();
    };
    auto errorOf = [&](const std::string& body) -> std::string {
        try {
            loadScene(write(body));
        } catch (const SceneError& e) {
            return e.what();
        }
        return "";
    };

    // Parameters: filename (relative to the scene), scale, to_world; mis_compensation is accepted
    // with a warning.
    const SceneDesc s = loadScene(write(R"(<emitter type="envmap">
        <string name="filename" value="maps/sky.exr"/>
        <float name="scale" value="2.5"/>
        <transform name="to_world"><rotate y="1" angle="90"/><translate x="4"/></transform>
        <boolean name="mis_compensation" value="true"/>
    </emitter>)"));
    REQUIRE(s.emitters.size() == 1);
    const EmitterDesc& e = s.emitters[0];
    CHECK(e.type == EmitterType::Envmap);
    CHECK(fs::equivalent(e.filename, dir / "maps" / "sky.exr"));
    CHECK(e.scale == 2.5f);
    REQUIRE(e.envmap);
    CHECK(e.envmap->width() == 24);
    CHECK(e.envmap->height() == 12);
    const Vec3 x = Vec3(e.toWorld * Vec4(1, 0, 0, 0));
    CHECK(glm::length(x - Vec3(0, 0, -1)) < 1e-5f);
    bool warned = false;
    for (const std::string& w : s.warnings) warned = warned || w.find("mis_compensation") != std::string::npos;
    CHECK(warned);
    // Defaults: scale 1, identity.
    const SceneDesc s2 = loadScene(write(R"(<emitter type="envmap"><string name="filename" value="maps/sky.exr"/></emitter>)"));
    CHECK(s2.emitters[0].scale == 1.f);
    CHECK(s2.emitters[0].toWorld == Mat4(1.f));
    for (const std::string& w : s2.warnings) CHECK(w.find("mis_compensation") == std::string::npos);

    // Errors name the file, the line and the parameter.
    auto expect = [&](const std::string& body, const std::vector<std::string>& words) {
        const std::string msg = errorOf(body);
        INFO("error: " << msg);
        CHECK(msg.find("scene.xml:") != std::string::npos);
        for (const std::string& w : words) CHECK(msg.find(w) != std::string::npos);
    };
    expect(R"(<emitter type="envmap">
        <string name="filename" value="maps/missing.exr"/></emitter>)",
           {"scene.xml:3", "'filename'", "missing.exr", "not found"});
    expect(R"(<emitter type="envmap"/>)", {"scene.xml:2", "filename", "required"});
    expect(R"(<emitter type="envmap"><string name="filename" value="maps/garbage.exr"/></emitter>)",
           {"scene.xml:2", "'filename'", "garbage.exr"});
    expect(R"(<emitter type="envmap"><string name="filename" value="maps/sky.png"/></emitter>)",
           {"'filename'", "sky.png"});
    expect(R"(<emitter type="envmap"><string name="filename" value="maps/nan.pfm"/></emitter>)",
           {"'filename'", "nan.pfm", "NaN", "(2, 1)"});
    expect(R"(<emitter type="envmap"><string name="filename" value="maps/negative.exr"/></emitter>)",
           {"'filename'", "negative.exr", "negative", "(1, 1)"});
    expect(R"(<emitter type="envmap"><string name="filename" value="maps/sky.exr"/>
        <float name="scale" value="-1"/></emitter>)",
           {"scene.xml:3", "'scale'", ">= 0"});
    expect(R"(<emitter type="envmap"><string name="filename" value="maps/sky.exr"/>
        <transform name="to_world"><scale value="2"/></transform></emitter>)",
           {"scene.xml:3", "'to_world'", "rotation"});
    expect(R"(<emitter type="envmap"><string name="filename" value="maps/sky.exr"/>
        <string name="bitmap" value="x"/></emitter>)",
           {"bitmap"});
    // One environment per scene (Mitsuba 3), constant and envmap alike.
    expect(R"(<emitter type="constant"/>
        <emitter type="envmap"><string name="filename" value="maps/sky.exr"/></emitter>)",
           {"scene.xml:3", "only one environment emitter", "scene.xml:2"});
    expect(R"(<emitter type="envmap"><string name="filename" value="maps/sky.exr"/></emitter>
        <emitter type="constant"/>)",
           {"scene.xml:3", "only one environment emitter"});
    // The scene refuses two as well (descriptions built in code).
    SceneDesc two;
    two.emitters.push_back(envEmitter(makeMap(gradientMap())));
    EmitterDesc c;
    c.type = EmitterType::Constant;
    two.emitters.push_back(c);
    CHECK_THROWS_WITH(Scene(two), Catch::Contains("only one environment emitter"));
}
