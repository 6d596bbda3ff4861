// Scene loader: every supported element and parameter lands in SceneDesc; every class of bad
// input (tests/data/bad/*.xml, each naming the expected line and words) gives a SceneError that
// names the file, the line and the parameter; the project's and the external scenes load.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <unistd.h>

#include "bsdf/ior.h"
#include "core/loader.h"
#include "core/mesh_io.h"
#include "integrators/integrator.h"
#include "process.h"

using namespace lt;
namespace fs = std::filesystem;

namespace {

const std::string kSrc = LT_SOURCE_DIR;
const std::string kData = kSrc + "/tests/data/loader";

// A per-process scratch directory for the files written here, removed at exit.
fs::path tempDir() {
    static lt::test::TempDir t("lt_test_loader");
    return t.dir;
}

// Writes an inline scene to a temporary file and loads it; $data is the fixture directory.
std::string writeScene(const std::string& body, const std::string& name = "inline.xml") {
    fs::path p = tempDir() / name;
    std::ofstream(p) << body;
    return p.string();
}

SceneDesc loadStr(const std::string& body, std::map<std::string, std::string> defines = {}) {
    defines.emplace("data", kData);
    return loadScene(writeScene(body), defines);
}

std::string wrap(const std::string& inner) { return "<scene version=\"3.0.0\">\n" + inner + "\n</scene>\n"; }

std::string errorOf(const std::string& path, const std::map<std::string, std::string>& defines = {}) {
    try {
        loadScene(path, defines);
    } catch (const SceneError& e) {
        return e.what();
    }
    return "";
}

std::string errorOfStr(const std::string& body) {
    std::string path = writeScene(body);
    std::string msg = errorOf(path, {{"data", kData}});
    return msg;
}

bool hasWarning(const SceneDesc& s, const std::string& a, const std::string& b = "") {
    for (auto& w : s.warnings)
        if (w.find(a) != std::string::npos && w.find(b) != std::string::npos) return true;
    return false;
}

bool near(const Vec3& a, const Vec3& b, float eps = 1e-4f) { return glm::length(a - b) <= eps; }

bool hasVertex(const MeshDesc& m, const Vec3& v) {
    for (auto& p : m.positions)
        if (near(p, v)) return true;
    return false;
}

Vec3 triNormal(const MeshDesc& m, size_t t) {
    Vec3 a = m.positions[m.indices[3 * t]], b = m.positions[m.indices[3 * t + 1]], c = m.positions[m.indices[3 * t + 2]];
    return glm::normalize(glm::cross(b - a, c - a));
}

// Compares two BSDFs on a few direction pairs (eval) and by sampling (delta lobes).
void requireSameBsdf(const BxdfPtr& a, const BxdfPtr& b) {
    REQUIRE(a);
    REQUIRE(b);
    CHECK(a->name() == b->name());
    CHECK(a->flags() == b->flags());
    const Vec3 dirs[] = {glm::normalize(Vec3(0.3f, 0.1f, 0.9f)), glm::normalize(Vec3(-0.2f, 0.4f, 0.7f)),
                         glm::normalize(Vec3(0.5f, -0.5f, 0.3f)), glm::normalize(Vec3(0.1f, 0.2f, -0.8f))};
    for (auto& wo : dirs)
        for (auto& wi : dirs) {
            BsdfEval ea = a->eval(wo, wi, TransportMode::Radiance), eb = b->eval(wo, wi, TransportMode::Radiance);
            CHECK(near(ea.f, eb.f, 1e-5f * (1.f + maxComp(eb.f))));
        }
    for (float uLobe : {0.05f, 0.5f, 0.95f}) {
        BsdfSample sa, sb;
        bool oka = a->sample(dirs[0], uLobe, Vec2(0.3f, 0.6f), TransportMode::Radiance, sa);
        bool okb = b->sample(dirs[0], uLobe, Vec2(0.3f, 0.6f), TransportMode::Radiance, sb);
        CHECK(oka == okb);
        if (oka && okb) {
            CHECK(near(sa.wi, sb.wi));
            CHECK(near(sa.weight, sb.weight, 1e-4f * (1.f + maxComp(sb.weight))));
            CHECK(sa.eta == Approx(sb.eta));
        }
    }
}

const char* kCam = R"(<sensor type="perspective"><float name="fov" value="45"/></sensor>)";

}  // namespace

TEST_CASE("loader: built-in shapes have Mitsuba's geometry", "[loader]") {
    SceneDesc s = loadStr(wrap(std::string(kCam) + R"(
        <shape type="rectangle"/>
        <shape type="cube"/>
        <shape type="disk"/>)"));
    REQUIRE(s.meshes.size() == 3);
    const MeshDesc &rect = s.meshes[0], &cube = s.meshes[1], &disk = s.meshes[2];
    CHECK(rect.positions.size() == 4);
    CHECK(rect.indices.size() == 6);
    CHECK(meshArea(rect) == Approx(4.0));
    for (size_t t = 0; t < 2; ++t) CHECK(near(triNormal(rect, t), Vec3(0, 0, 1)));
    for (auto& n : rect.normals) CHECK(near(n, Vec3(0, 0, 1)));
    CHECK(hasVertex(rect, Vec3(-1, -1, 0)));
    CHECK(hasVertex(rect, Vec3(1, 1, 0)));

    CHECK(cube.positions.size() == 24);
    CHECK(cube.indices.size() == 36);
    CHECK(meshArea(cube) == Approx(24.0));
    for (size_t t = 0; t < 12; ++t) {
        Vec3 centroid = (cube.positions[cube.indices[3 * t]] + cube.positions[cube.indices[3 * t + 1]] +
                         cube.positions[cube.indices[3 * t + 2]]) / 3.f;
        Vec3 n = triNormal(cube, t);
        CHECK(glm::dot(n, centroid) > 0.3f);  // outward
        CHECK(near(cube.normals[cube.indices[3 * t]], n));
        CHECK(maxAbs(n) == Approx(1.f));      // axis aligned
    }

    CHECK(disk.positions.size() == 129);
    CHECK(disk.indices.size() == 3 * 128);
    CHECK(meshArea(disk) == Approx(kPi).epsilon(1e-5));
    for (size_t t = 0; t < 128; ++t) CHECK(near(triNormal(disk, t), Vec3(0, 0, 1)));
    // Shapes without a bsdf get one diffuse 0.5 material, as in Mitsuba.
    REQUIRE(s.bsdfs.size() == 1);
    CHECK(rect.bsdf == 0);
    CHECK(disk.bsdf == 0);
    requireSameBsdf(s.bsdfs[0], makeDiffuse(Color(0.5f)));
}

TEST_CASE("loader: transforms compose in document order", "[loader]") {
    SceneDesc s = loadStr(wrap(std::string(kCam) + R"(
        <shape type="rectangle">
            <transform name="to_world">
                <scale value="2"/>
                <rotate y="1" angle="90"/>
                <translate x="1" y="2" z="3"/>
            </transform>
        </shape>
        <shape type="rectangle">
            <transform name="to_world">
                <matrix value="1, 0, 0, 5,  0, 1, 0, 6,  0, 0, 1, 7,  0, 0, 0, 1"/>
                <translate value="1 1 1"/>
                <scale x="1" y="1" z="3"/>
            </transform>
        </shape>
        <shape type="rectangle">
            <transform name="to_world">
                <rotate value="1 0 0" angle="45"/>
                <scale x="1" y="2" z="1"/>
            </transform>
        </shape>
        <shape type="rectangle">
            <transform name="to_world"><matrix value="0 0 1  1 0 0  0 1 0"/></transform>
        </shape>)"));
    REQUIRE(s.meshes.size() == 4);
    // (1,1,0) -> scale (2,2,0) -> rotate about y by 90 deg (x -> -z) -> (0,2,-2) -> translate.
    CHECK(hasVertex(s.meshes[0], Vec3(1, 4, 1)));
    CHECK(near(s.meshes[0].normals[0], Vec3(1, 0, 0)));
    CHECK(meshArea(s.meshes[0]) == Approx(16.0));
    // Row-major matrix: translation in the last column; then +1; then z scaled by 3.
    CHECK(hasVertex(s.meshes[1], Vec3(5, 6, 24)));
    CHECK(hasVertex(s.meshes[1], Vec3(7, 8, 24)));
    // Normals use the inverse transpose: rotate +Z by 45 deg about x -> (0,-s,s); scale y by 2
    // -> inverse transpose gives (0, -s/2, s), normalised.
    Vec3 expected = glm::normalize(Vec3(0, -0.5f, 1.f));
    CHECK(near(s.meshes[2].normals[0], expected));
    CHECK(near(triNormal(s.meshes[2], 0), expected));
    // 3x3 row-major matrix: maps +z (the normal) to +x.
    CHECK(near(s.meshes[3].normals[0], Vec3(1, 0, 0)));
}

TEST_CASE("loader: camera, film, sampler and lookat", "[loader]") {
    SceneDesc s = loadStr(wrap(R"(
        <sensor type="perspective">
            <float name="fov" value="30"/>
            <string name="fov_axis" value="smaller"/>
            <float name="near_clip" value="0.5"/>
            <float name="far_clip" value="100"/>
            <float name="focus_distance" value="3"/>
            <transform name="to_world">
                <lookat origin="1, 2, 3" target="1, 2, 4" up="0, 1, 0"/>
            </transform>
            <sampler type="independent">
                <integer name="sample_count" value="64"/>
                <integer name="seed" value="7"/>
            </sampler>
            <film type="hdrfilm">
                <integer name="width" value="320"/>
                <integer name="height" value="200"/>
                <string name="pixel_format" value="rgb"/>
                <string name="file_format" value="openexr"/>
                <string name="component_format" value="float32"/>
                <rfilter type="tent"/>
            </film>
        </sensor>)"));
    const CameraDesc& c = s.camera;
    CHECK(c.fovDeg == Approx(30));
    CHECK(c.fovAxis == FovAxis::Smaller);
    CHECK(c.nearClip == Approx(0.5));
    CHECK(c.width == 320);
    CHECK(c.height == 200);
    CHECK(c.filter == FilterType::Tent);
    CHECK(s.sampleCount == 64);
    CHECK(s.seed == 7);
    CHECK(near(Vec3(c.toWorld[3]), Vec3(1, 2, 3)));
    CHECK(near(Vec3(c.toWorld[2]), Vec3(0, 0, 1)));
    CHECK(near(Vec3(c.toWorld[1]), Vec3(0, 1, 0)));
    CHECK(near(Vec3(c.toWorld[0]), Vec3(1, 0, 0)));  // Mitsuba: +x = cross(up, dir), image left

    for (auto [name, axis] : {std::pair{"x", FovAxis::X}, {"y", FovAxis::Y}, {"larger", FovAxis::Larger},
                              {"diagonal", FovAxis::Diagonal}}) {
        SceneDesc t = loadStr(wrap(std::string(R"(<sensor type="perspective"><string name="fov_axis" value=")") + name +
                                   R"("/><float name="fov" value="50"/>
            <transform name="to_world"><lookat origin="0,0,5" target="0,0,0"/></transform></sensor>)"));
        CHECK(t.camera.fovAxis == axis);
        CHECK(near(Vec3(t.camera.toWorld[2]), Vec3(0, 0, -1)));
        CHECK(std::abs(glm::dot(Vec3(t.camera.toWorld[0]), Vec3(t.camera.toWorld[1]))) < 1e-5f);
    }
    // Mitsuba's default: a 50 mm focal length along the diagonal.
    SceneDesc d = loadStr(wrap(R"(<sensor type="perspective"><string name="focal_length" value="28mm"/></sensor>)"));
    CHECK(d.camera.fovAxis == FovAxis::Diagonal);
    CHECK(d.camera.fovDeg == Approx(2.0 * std::atan(std::sqrt(36.0 * 36 + 24 * 24) / 56.0) * 180.0 / kPi).epsilon(1e-4));
}

TEST_CASE("loader: fallbacks warn and name what is used instead", "[loader]") {
    SceneDesc s = loadStr(wrap(R"(
        <integrator type="direct"/>
        <sensor type="perspective">
            <sampler type="stratified"><integer name="sample_count" value="9"/></sampler>
            <film type="ldrfilm">
                <integer name="width" value="10"/><integer name="height" value="12"/>
                <rfilter type="lanczos"><integer name="lobes" value="3"/></rfilter>
            </film>
        </sensor>)"));
    CHECK(s.integrator.type == "path");
    CHECK(hasWarning(s, "direct", "path"));
    CHECK(s.sampleCount == 9);
    CHECK(hasWarning(s, "stratified", "independent"));
    CHECK(hasWarning(s, "ldrfilm", "hdrfilm"));
    CHECK(hasWarning(s, "ldrfilm", "PNG"));
    CHECK(hasWarning(s, "lanczos", "box"));
    CHECK(s.camera.filter == FilterType::Box);
    // Mitsuba's gaussian filter, also its default where the film has no <rfilter>.
    SceneDesc g = loadStr(wrap(R"(<sensor type="perspective"><film type="hdrfilm">
            <rfilter type="gaussian"><float name="stddev" value="0.3"/></rfilter></film></sensor>)"));
    CHECK(g.camera.filter == FilterType::Gaussian);
    CHECK(g.camera.filterStddev == 0.3f);
    SceneDesc none = loadStr(wrap(R"(<sensor type="perspective"><film type="hdrfilm"/></sensor>)"));
    CHECK(none.camera.filter == FilterType::Gaussian);
    CHECK(none.camera.filterStddev == 0.5f);
    CHECK(errorOfStr(wrap(R"(<sensor type="perspective"><film type="hdrfilm">
            <rfilter type="gaussian"><float name="stddev" value="0"/></rfilter></film></sensor>)")).find("stddev") != std::string::npos);
    CHECK(s.camera.width == 10);
    CHECK(s.camera.height == 12);
}

TEST_CASE("loader: integrators and their parameters", "[loader]") {
    SceneDesc p = loadStr(wrap(R"(<integrator type="path"><integer name="max_depth" value="12"/>
        <integer name="rr_depth" value="3"/><boolean name="hide_emitters" value="true"/></integrator>)"));
    CHECK(p.integrator.type == "path");
    CHECK(p.integrator.maxDepth == 12);
    CHECK(p.integrator.rrDepth == 3);
    CHECK(p.integrator.hideEmitters);
    SceneDesc d = loadStr(wrap(R"(<integrator type="path"/>)"));
    CHECK(d.integrator.maxDepth == -1);  // Mitsuba: unlimited
    CHECK(d.integrator.rrDepth == 0);    // absent: the integrator's default, resolved by rrDepthOf
    RenderSettings rs;
    for (auto [integ, depth] : {std::pair<const char*, int>{"pt", 5}, {"bpt", 1}, {"vcm", 1}, {"lt", 1}, {"ppm", 1}}) {
        rs.integrator = integ;
        CHECK(rrDepthOf(rs) == depth);
    }
    rs.rrDepth = 3;
    CHECK(rrDepthOf(rs) == 3);
    SceneDesc vp = loadStr(wrap(R"(<integrator type="volpath"><integer name="max_depth" value="4"/>
        <boolean name="unknown_thing" value="true"/></integrator>)"));
    CHECK(vp.integrator.type == "path");
    CHECK(vp.integrator.maxDepth == 4);
    CHECK(hasWarning(vp, "volpath", "falling back to 'path'"));
    for (const char* t : {"bdpt", "ptracer"}) {
        SceneDesc b = loadStr(wrap(std::string("<integrator type=\"") + t +
                                   R"("><integer name="max_depth" value="-1"/></integrator>)"));
        CHECK(b.integrator.type == t);
        CHECK(b.integrator.maxDepth == -1);
    }
    SceneDesc v = loadStr(wrap(R"(<integrator type="vcm"><float name="radius" value="0.02"/>
        <float name="alpha" value="0.5"/><integer name="max_depth" value="6"/></integrator>)"));
    CHECK(v.integrator.type == "vcm");
    CHECK(v.integrator.radius == Approx(0.02f));
    CHECK(v.integrator.radiusAlpha == Approx(0.5f));
    CHECK(v.integrator.maxDepth == 6);
    SceneDesc sp = loadStr(wrap(R"(<integrator type="sppm"><float name="initial_radius" value="0.1"/>
        <integer name="photon_count" value="1000"/></integrator>)"));
    CHECK(sp.integrator.type == "ppm");
    CHECK(sp.integrator.radius == Approx(0.1f));
    CHECK(hasWarning(sp, "sppm", "ppm"));
    // radius on a path tracer is kept (for a --integrator override) with a warning.
    SceneDesc pr = loadStr(wrap(R"(<integrator type="path"><float name="radius" value="0.5"/></integrator>)"));
    CHECK(pr.integrator.radius == Approx(0.5f));
    CHECK(hasWarning(pr, "radius", "ignored by path"));
    // Unknown parameters are errors that list the supported ones.
    std::string err = errorOfStr(wrap(R"(<integrator type="bdpt"><float name="radious" value="1"/></integrator>)"));
    CHECK(err.find("radious") != std::string::npos);
    CHECK(err.find("max_depth") != std::string::npos);
    CHECK(err.find("rr_depth") != std::string::npos);
    CHECK(errorOfStr(wrap(R"(<integrator type="vcm"><float name="alpha" value="1.5"/></integrator>)")).find("alpha") !=
          std::string::npos);
}

TEST_CASE("loader: defaults, command-line defines and $ in type", "[loader]") {
    std::string body = R"(<scene version="3.0.0">
        <default name="spp" value="8"/>
        <default name="integrator" value="path"/>
        <default name="res" value="16"/>
        <integrator type="$integrator"/>
        <sensor type="perspective">
            <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
            <film type="hdrfilm"><integer name="width" value="$res"/><integer name="height" value="$res"/></film>
        </sensor></scene>)";
    std::string path = writeScene(body, "defines.xml");
    SceneDesc a = loadScene(path);
    CHECK(a.sampleCount == 8);
    CHECK(a.integrator.type == "path");
    SceneDesc b = loadScene(path, {{"spp", "32"}, {"integrator", "bdpt"}});
    CHECK(b.sampleCount == 32);
    CHECK(b.integrator.type == "bdpt");
    CHECK(b.camera.width == 16);
    SceneDesc c = loadScene(path, {{"unused_name", "1"}});
    CHECK(hasWarning(c, "unused_name"));
}

TEST_CASE("loader: include, forward ref and ref name", "[loader]") {
    SceneDesc s = loadScene(kData + "/include_main.xml");
    CHECK(s.sampleCount == 7);    // the includer's <default> wins over the fragment's
    CHECK(s.camera.width == 32);  // $res from the fragment's default
    CHECK(s.camera.fovDeg == Approx(40));
    CHECK(s.camera.filter == FilterType::Gaussian);  // no <rfilter>: Mitsuba's default
    REQUIRE(s.meshes.size() == 1);
    REQUIRE(s.emitters.size() == 1);
    CHECK(s.meshes[0].emitter == 0);
    CHECK(s.emitters[0].type == EmitterType::Area);
    CHECK(near(s.emitters[0].value, Color(1, 2, 3)));
    CHECK(s.emitters[0].source.find("include_main.xml:15") != std::string::npos);
    requireSameBsdf(s.bsdfs[s.meshes[0].bsdf], makeDiffuse(Color(0.25f, 0.5f, 0.75f)));
}

TEST_CASE("loader: Mitsuba 0.6 spellings and defaults", "[loader]") {
    SceneDesc s = loadScene(kData + "/legacy06.xml");
    CHECK(s.integrator.maxDepth == 5);
    CHECK(s.integrator.rrDepth == 3);
    CHECK(s.camera.fovDeg == Approx(30));
    CHECK(s.camera.fovAxis == FovAxis::Y);
    CHECK(s.camera.nearClip == Approx(0.5));
    CHECK(near(Vec3(s.camera.toWorld[3]), Vec3(0, 0, 5)));
    CHECK(s.sampleCount == 12);
    CHECK(s.camera.width == 40);
    CHECK(s.camera.height == 30);
    CHECK(hasWarning(s, "ldsampler", "independent"));
    REQUIRE(s.spheres.size() == 1);
    REQUIRE(s.meshes.size() == 2);
    requireSameBsdf(s.bsdfs[s.spheres[0].bsdf], makeDielectric(1.333f / 1.0f));
    // 0.6: a conductor without material is copper (Mitsuba 3: a perfect mirror).
    requireSameBsdf(s.bsdfs[s.meshes[0].bsdf], makeConductor(Color(0.200438f, 0.924033f, 1.10221f),
                                                             Color(3.91295f, 2.45285f, 2.14219f), Color(1.f)));
    CHECK(near(s.meshes[0].positions[0], Vec3(-1, -1, -2)));
    REQUIRE(s.emitters.size() == 1);
    CHECK(near(s.emitters[0].value, Color(2.f)));
    auto au = conductorPreset("Au");
    REQUIRE(au);
    requireSameBsdf(s.bsdfs[s.meshes[1].bsdf],
                    makeRoughConductor(MicrofacetType::GGX, 0.1f, 0.3f, au->eta, au->k, Color(1.f)));
    CHECK(glm::dot(triNormal(s.meshes[1], 0), s.meshes[1].positions[s.meshes[1].indices[0]]) < 0.f);  // flipped
}

TEST_CASE("loader: materials", "[loader]") {
    SceneDesc s = loadStr(wrap(R"(
        <bsdf type="diffuse" id="d"><rgb name="reflectance" value="0.1 0.2 0.3"/></bsdf>
        <bsdf type="diffuse" id="ds"><spectrum name="reflectance" value="0.4"/></bsdf>
        <bsdf type="conductor" id="mirror"/>
        <bsdf type="conductor" id="etak">
            <rgb name="eta" value="0.2, 0.9, 1.1"/><rgb name="k" value="3.9, 2.4, 2.1"/>
            <rgb name="specular_reflectance" value="0.5"/>
        </bsdf>
        <bsdf type="roughconductor" id="rc"/>
        <bsdf type="roughconductor" id="rcggx">
            <string name="distribution" value="ggx"/><float name="alpha" value="0.2"/>
            <string name="material" value="Al"/><string name="masking" value="vcavity"/>
        </bsdf>
        <bsdf type="roughconductor" id="aniso">
            <float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.3"/>
            <spectrum name="eta" value="1.5"/><spectrum name="k" value="2"/>
        </bsdf>
        <bsdf type="dielectric" id="glass"/>
        <bsdf type="dielectric" id="water">
            <string name="int_ior" value="water"/><float name="ext_ior" value="1.1"/>
            <rgb name="specular_transmittance" value="0.9"/>
        </bsdf>
        <bsdf type="roughdielectric" id="rd">
            <float name="alpha" value="0.3"/><string name="distribution" value="ggx"/>
            <float name="int_ior" value="1.7"/>
        </bsdf>
        <bsdf type="twosided" id="ts"><bsdf type="diffuse"><rgb name="reflectance" value="0.7"/></bsdf></bsdf>
        <bsdf type="twosided" id="tsref"><ref id="d"/></bsdf>
        )"));
    REQUIRE(s.bsdfs.size() == 12);
    requireSameBsdf(s.bsdfs[0], makeDiffuse(Color(0.1f, 0.2f, 0.3f)));
    requireSameBsdf(s.bsdfs[1], makeDiffuse(Color(0.4f)));
    requireSameBsdf(s.bsdfs[2], makeConductor(Color(0.f), Color(1.f), Color(1.f)));
    requireSameBsdf(s.bsdfs[3], makeConductor(Color(0.2f, 0.9f, 1.1f), Color(3.9f, 2.4f, 2.1f), Color(0.5f)));
    requireSameBsdf(s.bsdfs[4], makeRoughConductor(MicrofacetType::Beckmann, 0.1f, 0.1f, Color(0.f), Color(1.f), Color(1.f)));
    auto al = conductorPreset("Al");
    REQUIRE(al);
    requireSameBsdf(s.bsdfs[5], makeRoughConductor(MicrofacetType::GGX, 0.2f, 0.2f, al->eta, al->k, Color(1.f),
                                                   MaskingModel::VCavity));
    CHECK(s.bsdfs[6]->alpha().alphaU == Approx(0.05f));
    CHECK(s.bsdfs[6]->alpha().alphaV == Approx(0.3f));
    requireSameBsdf(s.bsdfs[6], makeRoughConductor(MicrofacetType::Beckmann, 0.05f, 0.3f, Color(1.5f), Color(2.f), Color(1.f)));
    requireSameBsdf(s.bsdfs[7], makeDielectric(1.5046f / 1.000277f));
    requireSameBsdf(s.bsdfs[8], makeDielectric(1.333f / 1.1f, Color(1.f), Color(0.9f)));
    requireSameBsdf(s.bsdfs[9], makeRoughDielectric(MicrofacetType::GGX, 0.3f, 0.3f, 1.7f / 1.000277f));
    requireSameBsdf(s.bsdfs[10], makeTwoSided(makeDiffuse(Color(0.7f))));
    requireSameBsdf(s.bsdfs[11], makeTwoSided(makeDiffuse(Color(0.1f, 0.2f, 0.3f))));
    // The distribution matters (a wrong default would pass the checks above only by accident).
    BsdfEval g = s.bsdfs[5]->eval(glm::normalize(Vec3(0.3f, 0, 1)), glm::normalize(Vec3(-0.6f, 0.2f, 1)), TransportMode::Radiance);
    BsdfEval b = makeRoughConductor(MicrofacetType::Beckmann, 0.2f, 0.2f, al->eta, al->k, Color(1.f), MaskingModel::VCavity)
                     ->eval(glm::normalize(Vec3(0.3f, 0, 1)), glm::normalize(Vec3(-0.6f, 0.2f, 1)), TransportMode::Radiance);
    CHECK(std::abs(g.f.x - b.f.x) > 1e-4f);
}

TEST_CASE("loader: emitters", "[loader]") {
    SceneDesc s = loadStr(wrap(R"(
        <emitter type="point"><point name="position" x="1" y="2" z="3"/><rgb name="intensity" value="5"/></emitter>
        <emitter type="point">
            <transform name="to_world"><translate x="-1"/></transform>
        </emitter>
        <emitter type="spot">
            <rgb name="intensity" value="1, 2, 3"/>
            <float name="cutoff_angle" value="40"/>
            <transform name="to_world"><lookat origin="0, 1, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
        </emitter>
        <emitter type="spot"/>
        <emitter type="directional"><vector name="direction" value="0, -2, 0"/><rgb name="irradiance" value="3"/></emitter>
        <emitter type="directional">
            <transform name="to_world"><rotate x="1" angle="90"/></transform>
        </emitter>
        <emitter type="constant"><rgb name="radiance" value="0.5, 0.25, 1"/></emitter>
        <shape type="rectangle">
            <emitter type="area"><rgb name="radiance" value="4"/></emitter>
        </shape>)"));
    REQUIRE(s.emitters.size() == 8);
    CHECK(s.emitters[0].type == EmitterType::Point);
    CHECK(near(s.emitters[0].position, Vec3(1, 2, 3)));
    CHECK(near(s.emitters[0].value, Color(5)));
    CHECK(near(s.emitters[1].position, Vec3(-1, 0, 0)));
    CHECK(near(s.emitters[1].value, Color(1)));
    CHECK(s.emitters[2].type == EmitterType::Spot);
    CHECK(near(s.emitters[2].position, Vec3(0, 1, 0)));
    CHECK(near(s.emitters[2].direction, Vec3(0, -1, 0)));
    CHECK(s.emitters[2].cutoffAngleDeg == Approx(40));
    CHECK(s.emitters[2].beamWidthDeg == Approx(30));
    CHECK(near(s.emitters[2].value, Color(1, 2, 3)));
    CHECK(s.emitters[3].cutoffAngleDeg == Approx(20));
    CHECK(s.emitters[3].beamWidthDeg == Approx(15));
    CHECK(near(s.emitters[3].direction, Vec3(0, 0, 1)));
    CHECK(s.emitters[4].type == EmitterType::Directional);
    CHECK(near(s.emitters[4].direction, Vec3(0, -1, 0)));
    CHECK(near(s.emitters[4].value, Color(3)));
    CHECK(near(s.emitters[5].direction, Vec3(0, -1, 0)));
    CHECK(s.emitters[6].type == EmitterType::Constant);
    CHECK(near(s.emitters[6].value, Color(0.5f, 0.25f, 1.f)));
    CHECK(s.emitters[7].type == EmitterType::Area);
    CHECK(s.meshes.at(0).emitter == 7);
    CHECK(near(s.emitters[7].value, Color(4)));
    CHECK(std::regex_search(s.emitters[0].source, std::regex("inline\\.xml:3$")));
    CHECK(std::regex_search(s.emitters[7].source, std::regex("inline\\.xml:19$")));
}

TEST_CASE("loader: spheres, flip_normals and face_normals", "[loader]") {
    SceneDesc s = loadStr(wrap(R"(
        <shape type="sphere"><point name="center" value="1 2 3"/><float name="radius" value="0.5"/></shape>
        <shape type="sphere">
            <transform name="to_world"><scale value="2"/><rotate z="1" angle="30"/><translate y="1"/></transform>
            <boolean name="flip_normals" value="true"/>
            <emitter type="area"/>
        </shape>
        <shape type="rectangle"><boolean name="flip_normals" value="true"/></shape>
        <shape type="obj"><string name="filename" value="$data/shapes.obj"/><boolean name="face_normals" value="true"/></shape>)"));
    REQUIRE(s.spheres.size() == 2);
    CHECK(near(s.spheres[0].center, Vec3(1, 2, 3)));
    CHECK(s.spheres[0].radius == Approx(0.5f));
    CHECK_FALSE(s.spheres[0].flipNormals);
    CHECK(s.spheres[0].emitter == -1);
    CHECK(near(s.spheres[1].center, Vec3(0, 1, 0)));
    CHECK(s.spheres[1].radius == Approx(2.f));
    CHECK(s.spheres[1].flipNormals);
    CHECK(s.spheres[1].emitter == 0);
    REQUIRE(s.meshes.size() == 2);
    CHECK(near(triNormal(s.meshes[0], 0), Vec3(0, 0, -1)));
    CHECK(near(s.meshes[0].normals[0], Vec3(0, 0, -1)));
    CHECK(s.meshes[1].normals.empty());
}

TEST_CASE("loader: OBJ, PLY and serialized meshes", "[loader]") {
    SceneDesc s = loadStr(wrap(R"(
        <path value="$data"/>
        <shape type="obj"><string name="filename" value="shapes.obj"/></shape>
        <shape type="ply"><string name="filename" value="quad_ascii.ply"/></shape>
        <shape type="ply"><string name="filename" value="quad_le.ply"/></shape>
        <shape type="ply"><string name="filename" value="quad_be.ply"/>
            <transform name="to_world"><translate z="1"/></transform></shape>
        <shape type="serialized"><string name="filename" value="meshes_v4.serialized"/></shape>
        <shape type="serialized"><string name="filename" value="meshes_v4.serialized"/>
            <integer name="shape_index" value="1"/></shape>
        <shape type="serialized"><string name="filename" value="meshes_v3.serialized"/>
            <integer name="shape_index" value="1"/></shape>
        <shape type="serialized" id="named"><string name="filename" value="meshes_v3.serialized"/></shape>
        <shape type="obj"><string name="filename" value="shapes.obj"/>
            <boolean name="flip_tex_coords" value="false"/></shape>)"));
    REQUIRE(s.meshes.size() == 9);
    const MeshDesc& obj = s.meshes[0];
    CHECK(obj.positions.size() == 9);
    CHECK(obj.indices.size() == 15);
    CHECK(meshArea(obj) == Approx(1.0 + 2.5));
    CHECK(obj.normals.size() == 9);  // computed (Mitsuba does) since the pentagon has none
    for (auto& n : obj.normals) CHECK(near(n, Vec3(0, 0, 1)));
    REQUIRE(obj.uvs.size() == 9);
    CHECK(hasVertex(obj, Vec3(0, 1, 0)));
    // flip_tex_coords (default true): v -> 1 - v; vertex (0,1,0) has vt 0 0.25.
    for (size_t i = 0; i < obj.positions.size(); ++i)
        if (near(obj.positions[i], Vec3(0, 1, 0))) CHECK(obj.uvs[i].y == Approx(0.75f));
    for (size_t i = 0; i < s.meshes[8].positions.size(); ++i)
        if (near(s.meshes[8].positions[i], Vec3(0, 1, 0))) CHECK(s.meshes[8].uvs[i].y == Approx(0.25f));

    const MeshDesc& ascii = s.meshes[1];
    CHECK(ascii.positions.size() == 5);
    CHECK(ascii.indices.size() == 9);
    CHECK(ascii.uvs.size() == 5);
    CHECK(ascii.uvs[2] == Vec2(1, 1));
    for (int i : {2, 3}) {
        const MeshDesc& b = s.meshes[i];
        CHECK(b.positions.size() == 4);
        CHECK(b.indices.size() == 6);
        CHECK(meshArea(b) == Approx(1.0));
        REQUIRE(b.normals.size() == 4);
        CHECK(near(b.normals[1], Vec3(0, 0, 1)));
        REQUIRE(b.uvs.size() == 4);
        CHECK(b.uvs[2] == Vec2(1, 1));
        CHECK(near(triNormal(b, 0), Vec3(0, 0, 1)));
    }
    CHECK(near(s.meshes[3].positions[2], Vec3(1, 1, 1)));
    const MeshDesc &tri = s.meshes[4], &quad4 = s.meshes[5], &quad3 = s.meshes[6];
    CHECK(tri.positions.size() == 3);
    CHECK(tri.indices.size() == 3);
    CHECK(meshArea(tri) == Approx(2.0));
    CHECK(quad4.positions.size() == 4);
    CHECK(quad4.indices.size() == 6);
    CHECK(quad4.uvs.size() == 4);
    CHECK(meshArea(quad4) == Approx(1.0));
    CHECK(quad3.positions.size() == 4);
    CHECK(near(quad3.positions[2], Vec3(1, 1, 0)));
    CHECK(s.meshes[7].positions.size() == 3);
    CHECK(s.meshes[7].name == "named");

    // The readers directly (the loader wraps their errors with the XML location).
    CHECK(readSerialized(kData + "/meshes_v4.serialized", 1).name == "quad");
    CHECK_THROWS_AS(readSerialized(kData + "/meshes_v4.serialized", 2), MeshError);
    CHECK_THROWS_AS(readPly(kData + "/shapes.obj"), MeshError);
    CHECK_THROWS_AS(readSerialized(kData + "/quad_le.ply", 0), MeshError);
}

TEST_CASE("loader: every bad input gives a SceneError naming file, line and parameter", "[loader]") {
    std::vector<fs::path> files;
    for (auto& e : fs::directory_iterator(kSrc + "/tests/data/bad"))
        if (e.path().extension() == ".xml") files.push_back(e.path());
    std::sort(files.begin(), files.end());
    REQUIRE(files.size() >= 40);
    for (const fs::path& f : files) {
        std::ifstream in(f);
        std::stringstream ss;
        ss << in.rdbuf();
        std::string text = ss.str();
        std::smatch m;
        REQUIRE(std::regex_search(text, m, std::regex("expect-line: *([0-9]+)")));
        std::string line = m[1];
        REQUIRE(std::regex_search(text, m, std::regex("expect: *([^\\n]*?) *-->")));
        std::vector<std::string> words;
        std::stringstream ws(m[1].str());
        for (std::string w; std::getline(ws, w, ';');) {
            w.erase(0, w.find_first_not_of(' '));
            w.erase(w.find_last_not_of(' ') + 1);
            if (!w.empty()) words.push_back(w);
        }
        INFO("bad input " << f.filename().string());
        std::string msg = errorOf(f.string());
        INFO("message: " << msg);
        REQUIRE_FALSE(msg.empty());
        CHECK(msg.find(f.filename().string() + ":" + line + ":") != std::string::npos);
        for (auto& w : words) {
            INFO("expected word: " << w);
            CHECK(msg.find(w) != std::string::npos);
        }
    }
}

TEST_CASE("loader: more error classes", "[loader]") {
    CHECK(errorOf(kSrc + "/tests/data/bad/no_such_scene.xml").find("no_such_scene.xml") != std::string::npos);
    // The same messages for inline scenes: parameter named, supported ones listed.
    std::string e1 = errorOfStr(wrap(R"(<shape type="rectangle"><string name="filename" value="x.obj"/></shape>)"));
    CHECK(e1.find("inline.xml:2:") != std::string::npos);  // (wrap() puts <scene> on line 1)
    CHECK(e1.find("'filename'") != std::string::npos);
    CHECK(e1.find("flip_normals") != std::string::npos);
    std::string e2 = errorOfStr(wrap(R"(<shape type="sphere"><float name="radius" value="0"/></shape>)"));
    CHECK(e2.find("radius") != std::string::npos);
    std::string e3 = errorOfStr(wrap(R"(<emitter type="spot"><float name="cutoff_angle" value="120"/></emitter>)"));
    CHECK(e3.find("cutoff_angle") != std::string::npos);
    std::string e4 = errorOfStr(wrap(R"(<shape type="rectangle"><ref id="nope"/></shape><bsdf type="diffuse" id="x"/>)"));
    CHECK(e4.find("nope") != std::string::npos);
    CHECK(e4.find("x") != std::string::npos);
    std::string e5 = errorOfStr(wrap(R"(<shape type="rectangle"><emitter type="area"/></shape>
        <shape type="sphere"><float name="radius" value="-1"/><emitter type="area"/></shape>)"));
    CHECK(e5.find("inline.xml:3:") != std::string::npos);
    std::string e6 = errorOfStr(wrap(R"(<bsdf type="roughconductor" id="c"><float name="alpha_u" value="0.1"/></bsdf>)"));
    CHECK(e6.find("alpha_v") != std::string::npos);
    std::string e7 = errorOfStr(wrap(R"(<shape type="obj"><string name="filename" value="$data/quad_le.ply"/></shape>)"));
    CHECK(e7.find("filename") != std::string::npos);
    std::string e8 = errorOfStr(wrap(R"(<emitter type="constant"><rgb name="radiance" value="inf"/></emitter>)"));
    CHECK(e8.find("radiance") != std::string::npos);
    std::string e9 = errorOfStr(wrap(R"(<bsdf type="conductor" id="c"><float name="alpha" value="0.1"/></bsdf>)"));
    CHECK(e9.find("alpha") != std::string::npos);  // a smooth conductor has no alpha
    CHECK(e9.find("specular_reflectance") != std::string::npos);
    std::string e10 = errorOfStr(wrap(R"(<sensor type="perspective"/><sensor type="perspective"/>
        <integrator type="path"/><integrator type="bdpt"/>)"));
    CHECK(e10.find("more than one <integrator>") != std::string::npos);
}

TEST_CASE("loader: the project's scenes load", "[loader]") {
    SceneDesc c = loadScene(kSrc + "/scenes/cornell-box.xml");
    CHECK(c.camera.width == 256);
    CHECK(c.camera.height == 256);
    CHECK(c.sampleCount == 16);
    CHECK(c.integrator.type == "path");
    CHECK(c.integrator.maxDepth == 8);
    CHECK(c.meshes.size() == 8);  // 5 walls, light, 2 boxes
    REQUIRE(c.emitters.size() == 1);
    CHECK(c.warnings.empty());
    // The light faces down, just below the ceiling; walls face into the room.
    for (const MeshDesc& m : c.meshes) {
        if (m.name == "light") {
            CHECK(near(triNormal(m, 0), Vec3(0, -1, 0)));
            CHECK(meshArea(m) == Approx(0.47 * 0.38).epsilon(1e-4));
        }
        if (m.name == "floor") CHECK(near(triNormal(m, 0), Vec3(0, 1, 0)));
        if (m.name == "left") CHECK(near(triNormal(m, 0), Vec3(1, 0, 0)));
        if (m.name == "ceiling") CHECK(near(triNormal(m, 0), Vec3(0, -1, 0)));
    }
    SceneDesc big = loadScene(kSrc + "/scenes/cornell-box.xml", {{"res", "512"}, {"spp", "4"}, {"max_depth", "-1"}});
    CHECK(big.camera.width == 512);
    CHECK(big.sampleCount == 4);
    CHECK(big.integrator.maxDepth == -1);
    for (const char* name : {"cornell-box-ggx.xml", "cornell-box-mirror-sphere.xml", "cornell-box-glass-sphere.xml",
                             "cornell-box-point-in-glass.xml", "furnace.xml"}) {
        INFO(name);
        SceneDesc s = loadScene(kSrc + "/scenes/" + name);
        CHECK(s.warnings.empty());
        CHECK_FALSE(s.emitters.empty());
    }
    SceneDesc pg = loadScene(kSrc + "/scenes/cornell-box-point-in-glass.xml");
    REQUIRE(pg.emitters.size() == 1);
    CHECK(pg.emitters[0].type == EmitterType::Point);
    SceneDesc f = loadScene(kSrc + "/scenes/furnace.xml");
    REQUIRE(f.spheres.size() == 1);
    CHECK(f.spheres[0].flipNormals);
    CHECK(f.spheres[0].emitter == 0);
    CHECK(f.integrator.maxDepth == -1);
}

TEST_CASE("loader: the external scenes load", "[loader]") {
    const std::string ext = kSrc + "/scenes/external/";
    SceneDesc rgb = loadScene(ext + "mitsuba3-cbox/cbox-rgb.xml");
    CHECK(rgb.meshes.size() == 8);
    REQUIRE(rgb.emitters.size() == 1);
    CHECK(near(rgb.emitters[0].value, Color(18.387f, 10.9873f, 2.75357f)));
    CHECK(rgb.camera.fovAxis == FovAxis::Smaller);
    CHECK(rgb.sampleCount == 256);
    CHECK(rgb.integrator.maxDepth == 6);
    CHECK(rgb.meshes[0].emitter == 0);
    CHECK(meshArea(rgb.meshes[0]) == Approx(130.0 * 105.0));
    // The spectral versions: their spectra converted as Mitsuba 3's RGB variants do (test_spectrum).
    for (const char* spectral : {"mitsuba3-cbox/cbox-spectral.xml", "mitsuba3-cbox/cbox.xml"}) {
        INFO(spectral);
        SceneDesc s = loadScene(ext + spectral);
        CHECK(s.meshes.size() == 8);
        REQUIRE(s.emitters.size() == 1);
        CHECK(near(s.emitters[0].value, Color(20.7108f, 10.8546f, 2.7712f), 0.05f));
    }
    SceneDesc cb = loadScene(ext + "bitterli-cornell-box/scene.xml", {{"spp", "4"}});
    CHECK(cb.meshes.size() == 8);
    CHECK(cb.emitters.size() == 1);
    CHECK(cb.camera.filter == FilterType::Tent);
    CHECK(cb.camera.width == 1024);
    CHECK(cb.sampleCount == 4);
    CHECK(cb.integrator.maxDepth == 30);
    CHECK(near(Vec3(cb.camera.toWorld[3]), Vec3(0, 1, 6.8f)));
    SceneDesc mis = loadScene(ext + "bitterli-veach-mis/scene.xml");
    CHECK(mis.spheres.size() == 3);
    CHECK(mis.emitters.size() == 3);
    CHECK(mis.meshes.size() == 6);
    CHECK(mis.spheres[2].radius == Approx(0.05f));
    CHECK(mis.bsdfs[mis.meshes[0].bsdf]->name() == "twosided(roughconductor)");
    CHECK(mis.bsdfs[mis.meshes[0].bsdf]->alpha().alphaU == Approx(0.01f));
}

TEST_CASE("loader: as tolerant as Mitsuba - crop window and sheared camera and top-level sampler and no-op parameters", "[loader]") {
    // hdrfilm's crop window: the image is the window, the film's size stays the field of view's.
    SceneDesc c = loadStr(wrap(R"(<sensor type="perspective"><film type="hdrfilm">
            <integer name="width" value="40"/><integer name="height" value="30"/>
            <integer name="crop_offset_x" value="10"/><integer name="crop_offset_y" value="5"/>
            <integer name="crop_width" value="20"/><integer name="crop_height" value="12"/>
            <rfilter type="box"/></film></sensor>)"));
    CHECK(c.camera.width == 20);
    CHECK(c.camera.height == 12);
    CHECK(c.camera.fullWidth == 40);
    CHECK(c.camera.fullHeight == 30);
    CHECK(c.camera.cropX == 10);
    CHECK(c.camera.cropY == 5);
    // Only an offset: the window runs to the film's edge (Mitsuba's default crop size).
    SceneDesc o = loadStr(wrap(R"(<sensor type="perspective"><film type="hdrfilm">
            <integer name="width" value="40"/><integer name="height" value="30"/>
            <integer name="crop_offset_x" value="30"/><rfilter type="box"/></film></sensor>)"));
    CHECK(o.camera.width == 10);
    CHECK(o.camera.height == 30);
    for (const auto& [param, value] : std::vector<std::pair<std::string, std::string>>{
             {"crop_offset_x", "40"}, {"crop_offset_y", "-1"}, {"crop_width", "31"}, {"crop_height", "0"}}) {
        const std::string msg = errorOfStr(wrap(R"(<sensor type="perspective"><film type="hdrfilm">
            <integer name="width" value="40"/><integer name="height" value="30"/>
            <integer name="crop_offset_x" value=")" + std::string(param == "crop_offset_x" ? value : "10") + R"("/>
            <integer name=")" + (param == "crop_offset_x" ? std::string("crop_offset_y") : param) + R"(" value=")" +
                                                 (param == "crop_offset_x" ? std::string("0") : value) + R"("/>
            </film></sensor>)"));
        INFO(param << " = " << value << ": " << msg);
        CHECK(msg.find(param) != std::string::npos);
        CHECK(msg.find(param == "crop_offset_x" ? "inline.xml:4" : "inline.xml:5") != std::string::npos);
    }
    // A sheared camera frame is accepted (as Mitsuba does) with a warning; a scaled one is not.
    SceneDesc sh = loadStr(wrap(R"(<sensor type="perspective"><transform name="to_world">
            <matrix value="1 0.1 0 0  0 0.995 0 0  0 0 1 0  0 0 0 1"/></transform></sensor>)"));
    CHECK(hasWarning(sh, "sheared", "orthonormalised"));
    CHECK(errorOfStr(wrap(R"(<sensor type="perspective"><transform name="to_world">
            <scale value="1.1"/></transform></sensor>)")).find("no scale factors") != std::string::npos);
    // A sampler declared at the top level and referenced from the sensor; one used by no sensor warns.
    SceneDesc sm = loadStr(wrap(R"(<sampler type="independent" id="smp"><integer name="sample_count" value="37"/></sampler>
        <sampler type="independent" id="unused"><integer name="sample_count" value="2"/></sampler>
        <sensor type="perspective"><ref id="smp"/></sensor>)"));
    CHECK(sm.sampleCount == 37);
    CHECK(hasWarning(sm, "unused", "used by no sensor"));
    CHECK_FALSE(hasWarning(sm, "smp"));
    // A film cannot be referenced (Mitsuba declares films inside sensors only).
    CHECK(errorOfStr(wrap(R"(<bsdf type="diffuse" id="b"/><sensor type="perspective"><ref id="b"/></sensor>)"))
              .find("unexpected element inside <sensor>") != std::string::npos);
    // Mitsuba's integrator parameters that change nothing here: accepted, each named in a note.
    SceneDesc in = loadStr(wrap(R"(<integrator type="path"><integer name="samples_per_pass" value="4"/>
        <float name="timeout" value="10"/><boolean name="strict_normals" value="true"/></integrator>)"));
    CHECK(hasWarning(in, "samples_per_pass", "ignored"));
    CHECK(hasWarning(in, "timeout", "ignored"));
    CHECK(hasWarning(in, "strict_normals", "ignored"));
    // Mitsuba's direct integrator is the path tracer's paths of up to two segments; moment's
    // nested integrator is the one that renders.
    SceneDesc di = loadStr(wrap(R"(<integrator type="direct"><integer name="emitter_samples" value="4"/></integrator>)"));
    CHECK(di.integrator.type == "path");
    CHECK(di.integrator.maxDepth == 2);
    CHECK(hasWarning(di, "emitter_samples", "ignored"));
    SceneDesc mo = loadStr(wrap(R"(<integrator type="moment"><integrator type="bdpt"><integer name="max_depth" value="5"/></integrator></integrator>)"));
    CHECK(mo.integrator.type == "bdpt");
    CHECK(mo.integrator.maxDepth == 5);
    CHECK(hasWarning(mo, "moment", "nested"));
    SceneDesc md = loadStr(wrap(R"(<integrator type="moment"><integrator type="direct"/></integrator>)"));
    CHECK(md.integrator.maxDepth == 2);
    CHECK(errorOfStr(wrap(R"(<integrator type="moment"/>)")).find("moment needs one nested") != std::string::npos);
    // A typo stays an error.
    CHECK(errorOfStr(wrap(R"(<integrator type="path"><integer name="samples_per_pas" value="4"/></integrator>)"))
              .find("samples_per_pas") != std::string::npos);
}
