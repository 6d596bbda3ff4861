// Textured emitters (issue 46; core/textured_lights.cpp): area lights with a `radiance` texture,
// spot lights with a projected `texture`, and Mitsuba's `projector`, in every integrator.
#include <catch2/catch.hpp>
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

// 2 x 2 checks over the light (to_uv identity), strongly contrasting.
TexturePtr checks(const Color& c0, const Color& c1, float repeat = 1.f) {
    return makeCheckerboard(c0, c1, glm::mat3(glm::scale(glm::mat4(1.f), Vec3(repeat, repeat, 1.f))));
}

// The Cornell box with a larger ceiling light whose radiance is `tex` (uvs on its quad), or the
// constant `value` when tex is null.
SceneDesc boxWithLight(int res, TexturePtr tex, const Color& value) {
    SceneDesc d = cornellBox(res, makeDiffuse(Color(0.5f)));
    MeshDesc& light = d.meshes.back();
    light.positions = {Vec3(-0.6f, 0.99f, -0.6f), Vec3(0.6f, 0.99f, -0.6f), Vec3(0.6f, 0.99f, 0.6f),
                       Vec3(-0.6f, 0.99f, 0.6f)};
    light.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    d.emitters[0].value = value;
    d.emitters[0].texture = tex;
    d.integrator.maxDepth = 4;
    return d;
}

// A spot or projector straight above a white floor (y = 0), pointing down (-y); the emitter
// frame's x is world +x and its y world +z (a rotation: x cross y = -y is the axis).
SceneDesc floorUnder(EmitterDesc e, int res) {
    SceneDesc d;
    d.bsdfs.push_back(makeDiffuse(Color(0.8f)));
    d.meshes.push_back(quad(Vec3(-2, 0, -2), Vec3(0, 0, 4), Vec3(4, 0, 0), 0));  // normal +y
    e.toWorld = Mat4(Vec4(1, 0, 0, 0), Vec4(0, 0, 1, 0), Vec4(0, -1, 0, 0), Vec4(0, 1, 0, 1));
    e.position = Vec3(0, 1, 0);
    e.direction = Vec3(0, -1, 0);
    d.emitters.push_back(e);
    d.camera = lookAt(Vec3(0, 2.5f, 1.5f), Vec3(0, 0, 0), Vec3(0, 1, 0), 50.f, res, res);
    d.integrator.maxDepth = 3;
    return d;
}

EmitterDesc texturedSpot(TexturePtr tex) {
    EmitterDesc e;
    e.type = EmitterType::Spot;
    e.value = Color(3.f);
    e.cutoffAngleDeg = 40.f;
    e.beamWidthDeg = 30.f;
    e.texture = tex;
    return e;
}

EmitterDesc projector(TexturePtr tex, float fovX, float scale) {
    EmitterDesc e;
    e.type = EmitterType::Projector;
    e.value = Color(0.7f, 0.5f, 0.3f);
    e.texture = tex;
    e.fovXDeg = fovX;
    e.scale = scale;
    return e;
}

bool sameImages(const Image& a, const Image& b) {
    if (a.width != b.width || a.height != b.height) return false;
    for (size_t i = 0; i < a.pixels.size(); ++i)
        if (a.pixels[i] != b.pixels[i]) return false;
    return true;
}

// Each integrator against PT (MIS) on scene d: K = 10 renders per integrator, 16 blocks of 4 x 4
// pixels, Welch's t per block at family-wise significance 1% per comparison (Sidak over the
// blocks): a correct integrator differs in no block with probability 99%.
void agreeWithPt(const SceneDesc& d, const std::vector<std::string>& others, int spp, int ltSpp) {
    RenderSettings s;
    s.spp = spp;
    s.maxDepth = d.integrator.maxDepth;
    s.integrator = "pt";
    const auto pt = blockStats(d, s, 10, 4);
    for (const std::string& integ : others) {
        s.integrator = integ == "pt-bsdf" ? "pt" : integ;
        s.ptStrategy = integ == "pt-bsdf" ? "bsdf" : "mis";
        s.spp = integ == "lt" ? ltSpp : spp;
        s.radius = integ == "vcm" ? 1e-6f : -1.f;  // merges of ~no weight: VCM's other techniques
        double worst;
        const int bad = differingBlocks(pt, blockStats(d, s, 10, 4), 0.01, &worst);
        INFO(integ << " vs pt: " << bad << " blocks differ, worst |t|/crit " << worst);
        CHECK(bad == 0);
    }
}

std::string writeTemp(const std::string& name, const std::string& text) {
    static const lt::test::TempDir dir("lt_test_emitter_textures");  // per process, removed at exit
    return dir.write(name, text);
}


}  // namespace

TEST_CASE("a constant texture renders bit for bit as the untextured light", "[emitter][texture]") {
    // Area light (mesh, and a sphere light added) and spot: the textured code paths sample the
    // same points and directions with the same random numbers and give the same values, so every
    // integrator's image is the same bit for bit. (A texture evaluated at a wrong uv cannot show
    // here: the next test covers that.)
    SceneDesc plain = boxWithLight(12, nullptr, Color(6.f, 5.f, 4.f));
    EmitterDesc sphereLight;
    sphereLight.type = EmitterType::Area;
    sphereLight.value = Color(2.f, 3.f, 4.f);
    plain.emitters.push_back(sphereLight);
    SphereDesc sp;
    sp.center = Vec3(-0.5f, 0.5f, 0.f);
    sp.radius = 0.15f;
    sp.bsdf = 0;
    sp.emitter = int(plain.emitters.size()) - 1;
    plain.spheres.push_back(sp);
    SceneDesc textured = plain;
    textured.emitters[0].texture = checks(plain.emitters[0].value, plain.emitters[0].value);
    textured.emitters[1].texture = checks(sphereLight.value, sphereLight.value);
    const SceneDesc spot = floorUnder(texturedSpot(nullptr), 12);
    SceneDesc spotTextured = spot;
    spotTextured.emitters[0].texture = checks(Color(1.f), Color(1.f));
    RenderSettings s;
    s.spp = 2;
    s.maxDepth = 4;
    s.threads = 1;
    for (const std::string integ : {"pt", "bpt", "vcm", "lt", "ppm"}) {
        s.integrator = integ;
        INFO(integ);
        CHECK(sameImages(renderDesc(plain, s), renderDesc(textured, s)));
        CHECK(sameImages(renderDesc(spot, s), renderDesc(spotTextured, s)));
    }
    // The lights' powers (the choice between lights) are the same too.
    const Scene a(plain), b(textured);
    CHECK(a.lightSelectionProb(&a.lights()[0]) == b.lightSelectionProb(&b.lights()[0]));
    // And changing the texture changes the image (the test can fail).
    textured.emitters[0].texture = checks(Color(6.f, 5.f, 4.f), Color(1.f));
    s.integrator = "pt";
    CHECK_FALSE(sameImages(renderDesc(plain, s), renderDesc(textured, s)));
}

TEST_CASE("next-event estimation's light sample carries the uv a hit at its point has", "[emitter][texture]") {
    // A mesh light (uvs given) and a sphere light: for points sampled by sampleLi, a ray towards
    // the point hits it with the same uv (the sphere: Mitsuba's phi / 2 pi, theta / pi in its
    // rotated frame).
    SceneDesc d = boxWithLight(8, checks(Color(1.f), Color(0.f)), Color(1.f));
    d.meshes.back().uvs = {{0.1f, 0.2f}, {0.9f, 0.3f}, {0.7f, 0.95f}, {0.05f, 0.8f}};
    EmitterDesc e;
    e.type = EmitterType::Area;
    e.texture = checks(Color(1.f), Color(0.f));
    d.emitters.push_back(e);
    SphereDesc sp;
    sp.center = Vec3(-0.4f, 0.3f, 0.1f);
    sp.radius = 0.2f;
    sp.bsdf = 0;
    sp.emitter = 1;
    sp.toLocal = glm::mat3(glm::rotate(glm::mat4(1.f), 0.7f, glm::normalize(Vec3(1, 2, 3))));  // uv in its own frame
    d.spheres.push_back(sp);
    const Scene scene(d);
    Rng rng(7, 1);
    int checked = 0;
    for (const Light& l : scene.lights()) {
        for (int i = 0; i < 200; ++i) {
            const Vec3 ref = l.sphere ? sp.center + 0.6f * glm::normalize(Vec3(1, -0.2f, 0.1f)) : Vec3(0.1f, -0.5f, 0.2f);
            const LightSampleLi ls = l.sampleLi(scene, ref, rng.uniform2());
            if (!(ls.pdfPos.value > 0.f)) continue;
            const Vec3 o = ls.p + 0.05f * ls.n;  // from just outside the point, straight at it
            SurfaceHit h;
            REQUIRE(scene.intersect(Ray{o, -ls.n}, h));
            REQUIRE(h.light == &l);
            CHECK(h.uv.x == Approx(ls.uv.x).margin(2e-4));
            CHECK(h.uv.y == Approx(ls.uv.y).margin(2e-4));
            // The value it carries is the texture's there (towards the front side).
            if (glm::dot(ls.n, ref - ls.p) > 0.f) CHECK(ls.value == l.texture->eval(ls.uv));
            ++checked;
        }
    }
    CHECK(checked > 300);
}

TEST_CASE("a checkerboard area light: PT and PT with hits only and BPT and VCM and LT agree", "[emitter][texture][statistical]") {
    // 16 x 16 pixels in 4 x 4 blocks (agreeWithPt). A technique that evaluated the light without its
    // uv (the emitter hit, next-event estimation, the light walk's start or its direct splat)
    // would see color0 or the mean everywhere and differ in the blocks of the lit walls.
    const SceneDesc d = boxWithLight(16, checks(Color(12.f, 10.f, 8.f), Color(0.5f)), Color(1.f));
    agreeWithPt(d, {"pt-bsdf", "bpt", "vcm", "lt"}, 4, 8);
    // Power: the light at its mean radiance differs from PT (the texture is seen).
    SceneDesc flat = d;
    flat.emitters[0].texture = nullptr;
    flat.emitters[0].value = d.emitters[0].texture->meanValue();
    RenderSettings s;
    s.spp = 4;
    s.maxDepth = 4;
    CHECK(differingBlocks(blockStats(d, s, 10, 4), blockStats(flat, s, 10, 4), 0.01) > 0);
}

TEST_CASE("the power a checkerboard light sends to the floor is the texture mean's", "[emitter][texture][statistical]") {
    // A 2 x 2 checkerboard light facing a floor, the camera between them on the light's axis
    // looking down: a quarter turn about the axis swaps the checks and leaves the floor, the light's
    // square and the camera's view as they were, so the image's expected mean is that of the light
    // at the texture's mean radiance. LT and PT, K = 12 renders each; Welch's t on the image means
    // at significance 1% (two-sided). The light's power for the choice between lights is
    // pi x area x the mean's luminance.
    SceneDesc d;
    d.bsdfs.push_back(makeDiffuse(Color(0.8f)));
    d.bsdfs.push_back(makeDiffuse(Color(0.f)));
    d.meshes.push_back(quad(Vec3(-1, 0, -1), Vec3(0, 0, 2), Vec3(2, 0, 0), 0));  // floor, normal +y
    EmitterDesc e;
    e.type = EmitterType::Area;
    e.texture = checks(Color(8.f, 6.f, 4.f), Color(0.5f, 1.f, 2.f));
    d.emitters.push_back(e);
    d.meshes.push_back(quad(Vec3(-0.5f, 1, -0.5f), Vec3(1, 0, 0), Vec3(0, 0, 1), 1, 0));  // normal -y
    d.meshes.back().uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    d.camera = lookAt(Vec3(0, 0.9f, 0), Vec3(0, 0, 0), Vec3(0, 0, 1), 60.f, 12, 12);
    d.integrator.maxDepth = 2;
    SceneDesc flat = d;
    flat.emitters[0].texture = nullptr;
    flat.emitters[0].value = e.texture->meanValue();
    {
        const Scene a(d);
        CHECK(a.lights()[0].power(a) == Approx(kPi * 1.f * luminance(e.texture->meanValue())));
    }
    RenderSettings s;
    s.maxDepth = 2;
    auto means = [&](const SceneDesc& sd, const std::string& integ) {
        std::vector<double> m;
        s.integrator = integ;
        s.spp = integ == "lt" ? 16 : 4;
        for (int k = 0; k < 12; ++k) {
            s.seed = 100 + uint64_t(k);
            m.push_back(imageMean(renderDesc(sd, s)));
        }
        return sampleStats(m);
    };
    for (const std::string integ : {"lt", "pt"}) {
        const SampleStats tex = means(d, integ), mean = means(flat, integ);
        double df;
        const double t = welchT(tex, mean, df);
        INFO(integ << ": t " << t);
        CHECK(std::abs(t) < studentTCritical(0.01, std::max(df, 1.0)));
    }
    // The same light at color0 alone (a texture looked up at one uv) differs.
    SceneDesc c0 = flat;
    c0.emitters[0].value = Color(8.f, 6.f, 4.f);
    double df;
    const double t = welchT(means(d, "pt"), means(c0, "pt"), df);
    CHECK(std::abs(t) > studentTCritical(0.01, std::max(df, 1.0)));
}

TEST_CASE("a textured spot and a projector: PT and LT and BPT agree", "[emitter][texture][statistical]") {
    // agreeWithPt on the floor under each light (max depth 3, so the floor's light also bounces off
    // nothing: direct light, PT's next-event estimation against LT's splats and BPT's connections).
    agreeWithPt(floorUnder(texturedSpot(checks(Color(1.f, 0.2f, 0.1f), Color(0.1f, 0.3f, 1.f), 3.f)), 16),
                {"lt", "bpt"}, 4, 8);
    agreeWithPt(floorUnder(projector(checks(Color(1.f, 0.2f, 0.1f), Color(0.05f, 0.3f, 1.f), 3.f), 70.f, 2.f), 16),
                {"lt", "bpt", "vcm"}, 4, 8);
}

TEST_CASE("spot and projector: the irradiance at a point by hand", "[emitter][texture]") {
    // Projector 1 above the floor pointing down, fov_x 70, constant irradiance E0, scale s: the
    // intensity towards theta is pi s E0 / cos^3 theta, so the floor (at distance 1 / cos theta,
    // incidence theta) receives pi s E0 everywhere in the image's footprint (Mitsuba's plane z = 1).
    const SceneDesc dp = floorUnder(projector(nullptr, 70.f, 2.f), 8);
    const Scene ps(dp);
    const Light& proj = ps.lights()[0];
    const Color e0(0.7f, 0.5f, 0.3f);
    for (const Vec3 p : {Vec3(0, 0, 0), Vec3(0.3f, 0, -0.2f), Vec3(-0.6f, 0, 0.35f)}) {
        const LightSampleLi ls = proj.sampleLi(ps, p, Vec2(0.5f));
        const Vec3 d = ls.p - p;
        const float r2 = glm::dot(d, d), cosFloor = d.y / std::sqrt(r2);
        const Color E = ls.value * cosFloor / r2;
        INFO(p.x << " " << p.z);
        CHECK(E.x == Approx(kPi * 2.f * e0.x).epsilon(1e-5));
        CHECK(E.z == Approx(kPi * 2.f * e0.z).epsilon(1e-5));
    }
    // Outside the footprint (|x| > tan 35 deg at distance 1; aspect 1: also |z|): nothing.
    CHECK(isBlack(proj.sampleLi(ps, Vec3(0.75f, 0, 0), Vec2(0.5f)).value));
    // The emitted power: pi s E0 over the footprint's area (2 tan 35)^2.
    CHECK(proj.power(ps) == Approx(kPi * 2.f * sqr(2.f * std::tan(glm::radians(35.f))) * luminance(e0)).epsilon(1e-5));
    // Spot 1 above the floor, a checkerboard: at (0.2, 0, 0.1) the direction in the spot's frame is
    // (0.2, 0.1, 1) / |.| (frame x = world x, y = world z), uv = 0.5 + 0.5 (0.2, 0.1) / tan 40 deg,
    // both > 0.5: color0; inside the beam (atan(|(0.2, 0.1)|) = 12.6 < 30 deg): falloff 1. E = I c0
    // cos / r^2 with cos = 1 / r.
    const SceneDesc ds = floorUnder(texturedSpot(checks(Color(1.f, 0.2f, 0.1f), Color(0.1f, 0.3f, 1.f))), 8);
    const Scene ss(ds);
    const Light& spot = ss.lights()[0];
    const float r = std::sqrt(0.2f * 0.2f + 0.1f * 0.1f + 1.f);
    Color E = spot.sampleLi(ss, Vec3(0.2f, 0, 0.1f), Vec2(0.5f)).value / (r * r * r);
    CHECK(E.x == Approx(3.f * 1.f / (r * r * r)).epsilon(1e-5));
    CHECK(E.z == Approx(3.f * 0.1f / (r * r * r)).epsilon(1e-5));
    // At (0.2, 0, -0.1): v < 0.5, color1.
    E = spot.sampleLi(ss, Vec3(0.2f, 0, -0.1f), Vec2(0.5f)).value / (r * r * r);
    CHECK(E.z == Approx(3.f * 1.f / (r * r * r)).epsilon(1e-5));
}

TEST_CASE("projector: emission directions follow the image and their density integrates to one", "[emitter][texture]") {
    // pdfLeDir over the sphere of directions (a 512 x 512 grid over the image's square on z = 1,
    // dw = cos^3 theta dA) integrates to 1, and sampleLe's density is pdfLeDir's at its direction.
    const SceneDesc d = floorUnder(projector(checks(Color(1.f), Color(0.02f), 4.f), 60.f, 1.f), 8);
    const Scene scene(d);
    const Light& l = scene.lights()[0];
    const float t = std::tan(glm::radians(30.f));
    double sum = 0.0;
    const int n = 512;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const float x = (2.f * (float(i) + 0.5f) / float(n) - 1.f) * t, y = (2.f * (float(j) + 0.5f) / float(n) - 1.f) * t;
            const Vec3 local = glm::normalize(Vec3(x, y, 1.f));
            const Vec3 w = local.x * l.axisX + local.y * l.axisY + local.z * l.direction;
            sum += double(l.pdfLeDir(Vec3(0.f), w).value) * double(local.z * local.z * local.z) * double(sqr(2.f * t / float(n)));
        }
    CHECK(sum == Approx(1.0).epsilon(2e-3));
    Rng rng(3, 1);
    int bright = 0;
    for (int k = 0; k < 2000; ++k) {
        const LightSampleLe le = l.sampleLe(scene, rng.uniform2(), rng.uniform2());
        REQUIRE(le.pdfDir.value > 0.f);
        CHECK(le.pdfDir.value == Approx(l.pdfLeDir(Vec3(0.f), le.dir).value).epsilon(1e-3));
        if (luminance(le.value) > 0.5f * luminance(l.texturedIntensity(l.direction))) ++bright;
    }
    // The bright checks are half the image and 98% of its weight: 0.9 x 0.98 + 0.1 x 0.5 of the samples.
    CHECK(bright > 1700);
}

TEST_CASE("loader: textured emitters and their errors", "[emitter][texture][loader]") {
    const std::string tiles = std::string(LT_SOURCE_DIR) + "/scenes/textured/tiles.png";
    const SceneDesc d = loadScene(writeTemp("ok.xml", R"(<scene version="3.0.0">
    <shape type="rectangle"><emitter type="area"><texture type="checkerboard" name="radiance"/></emitter></shape>
    <emitter type="spot"><texture type="bitmap" name="texture"><string name="filename" value=")" + tiles + R"("/></texture>
        <transform name="to_world"><lookat origin="0, 1, 0" target="0, 0, 0" up="0, 0, 1"/></transform></emitter>
    <emitter type="projector"><texture type="bitmap" name="irradiance"><string name="filename" value=")" + tiles + R"("/></texture>
        <float name="fov" value="30"/><string name="fov_axis" value="y"/><float name="scale" value="3"/></emitter>
    <emitter type="projector"><rgb name="irradiance" value="0.5"/><string name="focal_length" value="50mm"/></emitter>
</scene>)"),
                                  {});
    REQUIRE(d.emitters.size() == 4);
    CHECK(d.emitters[0].texture);
    CHECK(d.emitters[1].texture);
    CHECK(d.emitters[2].type == EmitterType::Projector);
    CHECK(d.emitters[2].scale == 3.f);
    const glm::ivec2 res = d.emitters[2].texture->resolution();
    const float aspect = float(res.x) / float(res.y);
    CHECK(d.emitters[2].fovXDeg == Approx(glm::degrees(2.f * std::atan(std::tan(glm::radians(15.f)) * aspect))));
    CHECK_FALSE(d.emitters[3].texture);
    CHECK(d.emitters[3].value == Color(0.5f));
    // 50mm along the diagonal of a square image: 2 atan(diagonal tan / sqrt 2).
    const float diag = std::tan(std::atan(std::sqrt(36.f * 36.f + 24.f * 24.f) / 100.f));
    CHECK(d.emitters[3].fovXDeg == Approx(glm::degrees(2.f * std::atan(diag / std::sqrt(2.f)))));
    struct Bad {
        const char* name;
        std::string body, where, what;
    };
    const std::vector<Bad> bad = {
        {"intensity.xml", R"(<emitter type="spot">
        <texture type="checkerboard" name="intensity"/></emitter>)", "intensity.xml:3", "'intensity'"},
        {"noirr.xml", R"(<emitter type="projector">
        <float name="fov" value="30"/></emitter>)", "noirr.xml:2", "'irradiance'"},
        {"scale.xml", R"(<emitter type="projector"><rgb name="irradiance" value="1"/>
        <transform name="to_world"><scale value="2"/></transform></emitter>)", "scale.xml:3", "to_world"},
        {"fov.xml", R"(<emitter type="projector"><rgb name="irradiance" value="1"/>
        <float name="fov" value="190"/></emitter>)", "fov.xml:3", "fov"},
        {"axis.xml", R"(<emitter type="projector"><rgb name="irradiance" value="1"/>
        <string name="fov_axis" value="z"/><float name="fov" value="30"/></emitter>)", "axis.xml:3", "fov_axis"},
        {"areaparam.xml", R"(<shape type="rectangle"><emitter type="area">
        <texture type="checkerboard" name="intensity"/></emitter></shape>)", "areaparam.xml:3", "'intensity'"},
        {"pointtex.xml", R"(<emitter type="point">
        <texture type="checkerboard" name="intensity"/></emitter>)", "pointtex.xml:3", "'intensity'"},
        {"spotscale.xml", R"(<emitter type="spot"><texture type="checkerboard" name="texture"/>
        <transform name="to_world"><scale value="2"/></transform></emitter>)", "spotscale.xml:3", "to_world"},
    };
    for (const Bad& b : bad) {
        const std::string e = loadError(writeTemp(b.name, "<scene version=\"3.0.0\">\n    " + b.body + "\n</scene>"));
        INFO(b.name << ": " << e);
        CHECK(e.find(b.where) != std::string::npos);
        CHECK(e.find(b.what) != std::string::npos);
    }
}
