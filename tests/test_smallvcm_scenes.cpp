// SmallVCM's Cornell boxes transcribed as our scenes (scenes/smallvcm/*.xml, docs/smallvcm-comparison.md):
// every scene loads without warnings; its walls, light box, spheres, lights, camera and VCM settings are
// the numbers of SmallVCM's LoadCornellBox (its corner lists cb[0..7] and lb[0..7] are repeated here, and
// each wall is checked against the winding of SmallVCM's two triangles for it); each renders finite,
// non-negative and non-black with PT, BPT and VCM at 16x16.
#include <catch2/catch.hpp>
#include "process.h"
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>
#include "bsdf/bsdf.h"
#include "core/image.h"
#include "core/loader.h"

namespace fs = std::filesystem;
using namespace lt;

namespace {

fs::path sceneDir() { return fs::path(LT_SOURCE_DIR) / "scenes/smallvcm"; }

const std::vector<std::string> kScenes = {"empty-ceiling",         "large-glass-ceiling",     "large-mirror-ceiling",
                                          "small-spheres-ceiling", "small-spheres-point",     "small-spheres-sun",
                                          "small-spheres-background"};

// SmallVCM's corners of the box (cb) and of the light box under the ceiling (lb).
const Vec3 cb[8] = {{-1.27029f, 1.30455f, -1.28002f},  {1.28975f, 1.30455f, -1.28002f},
                    {1.28975f, 1.30455f, 1.28002f},    {-1.27029f, 1.30455f, 1.28002f},
                    {-1.27029f, -1.25549f, -1.28002f}, {1.28975f, -1.25549f, -1.28002f},
                    {1.28975f, -1.25549f, 1.28002f},   {-1.27029f, -1.25549f, 1.28002f}};
const Vec3 lb[8] = {{-0.25f, 0.25f, 1.26002f},  {0.25f, 0.25f, 1.26002f},  {0.25f, 0.25f, 1.28002f},
                    {-0.25f, 0.25f, 1.28002f},  {-0.25f, -0.25f, 1.26002f}, {0.25f, -0.25f, 1.26002f},
                    {0.25f, -0.25f, 1.28002f},  {-0.25f, -0.25f, 1.28002f}};

// One SmallVCM quad: its two triangles as corner indices (the first triangle's winding gives the front).
struct Quad {
    const Vec3* corners;
    int tri[2][3];
};
// Shape id -> SmallVCM's triangles for it (scene.hxx; the light box bottom is "light" when it emits).
const std::map<std::string, Quad> kQuads = {
    {"floor", {cb, {{0, 4, 5}, {5, 1, 0}}}},        {"back", {cb, {{0, 1, 2}, {2, 3, 0}}}},
    {"ceiling", {cb, {{2, 6, 7}, {7, 3, 2}}}},      {"left", {cb, {{3, 7, 4}, {4, 0, 3}}}},
    {"right", {cb, {{1, 5, 6}, {6, 2, 1}}}},        {"light-box-back", {lb, {{0, 2, 1}, {2, 0, 3}}}},
    {"light-box-left", {lb, {{3, 4, 7}, {4, 3, 0}}}}, {"light-box-right", {lb, {{1, 6, 5}, {6, 1, 2}}}},
    {"light-box-front", {lb, {{4, 5, 6}, {6, 7, 4}}}}, {"light", {lb, {{0, 5, 4}, {5, 0, 1}}}},
    {"light-box-bottom", {lb, {{0, 5, 4}, {5, 0, 1}}}}};

bool near(const Vec3& a, const Vec3& b, float eps = 1e-5f) { return glm::length(a - b) <= eps; }

Vec3 triNormal(const Vec3& a, const Vec3& b, const Vec3& c) { return glm::normalize(glm::cross(b - a, c - a)); }

double meshArea(const MeshDesc& m) {
    double a = 0;
    for (size_t t = 0; t < m.indices.size(); t += 3)
        a += 0.5 * glm::length(glm::cross(m.positions[m.indices[t + 1]] - m.positions[m.indices[t]],
                                          m.positions[m.indices[t + 2]] - m.positions[m.indices[t]]));
    return a;
}

// The mesh covers exactly SmallVCM's quad (same four corners, same area) and faces the same way.
void checkQuad(const MeshDesc& m, const Quad& q) {
    INFO(m.name);
    std::set<int> cornerIds;
    for (const auto& tri : q.tri)
        for (int i : tri) cornerIds.insert(i);
    REQUIRE(cornerIds.size() == 4);
    for (int i : cornerIds) {
        bool found = false;
        for (const Vec3& p : m.positions) found |= near(p, q.corners[i]);
        CHECK(found);
    }
    for (const Vec3& p : m.positions) {
        bool isCorner = false;
        for (int i : cornerIds) isCorner |= near(p, q.corners[i]);
        CHECK(isCorner);
    }
    const Vec3* c = q.corners;
    const double svArea = 0.5 * glm::length(glm::cross(c[q.tri[0][1]] - c[q.tri[0][0]], c[q.tri[0][2]] - c[q.tri[0][0]])) +
                          0.5 * glm::length(glm::cross(c[q.tri[1][1]] - c[q.tri[1][0]], c[q.tri[1][2]] - c[q.tri[1][0]]));
    CHECK(meshArea(m) == Approx(svArea).epsilon(1e-5));
    const Vec3 svNormal = triNormal(c[q.tri[0][0]], c[q.tri[0][1]], c[q.tri[0][2]]);
    CHECK(near(triNormal(c[q.tri[1][0]], c[q.tri[1][1]], c[q.tri[1][2]]), svNormal));
    for (size_t t = 0; t < m.indices.size(); t += 3)
        CHECK(near(triNormal(m.positions[m.indices[t]], m.positions[m.indices[t + 1]], m.positions[m.indices[t + 2]]),
                   svNormal));
    for (const Vec3& n : m.normals) CHECK(near(n, svNormal));  // shading normals (rectangles have them)
}

Color diffuseReflectance(const SceneDesc& s, int bsdf) {
    REQUIRE(bsdf >= 0);
    const Lambert* l = s.bsdfs[bsdf]->lambert();
    REQUIRE(l);
    return l->r;
}

const SphereDesc* findSphere(const SceneDesc& s, const std::string& name) {
    for (const SphereDesc& sp : s.spheres)
        if (sp.name == name) return &sp;
    return nullptr;
}

}  // namespace

TEST_CASE("smallvcm scenes: SmallVCM's box, light box, spheres, lights, camera and VCM settings", "[scenes][smallvcm]") {
    const Vec3 white(0.803922f), green(0.156863f, 0.803922f, 0.172549f), red(0.803922f, 0.152941f, 0.152941f);
    // SmallVCM's scene radius: half the diagonal of the bounding box of all geometry (the walls' box).
    const float sceneRadius = 0.5f * glm::length(cb[2] - cb[4]);
    CHECK(sceneRadius == Approx(2.21706f).epsilon(1e-5));
    for (const std::string& name : kScenes) {
        INFO(name);
        fs::path path = sceneDir() / (name + ".xml");
        REQUIRE(fs::exists(path));
        SceneDesc s = loadScene(path.string());
        CHECK(s.warnings.empty());

        // Camera: SmallVCM's position and forward, 45 degrees horizontal, 256x256, box filter.
        CHECK(s.camera.width == 256);
        CHECK(s.camera.height == 256);
        CHECK(s.camera.fovDeg == 45.f);
        CHECK(s.camera.fovAxis == FovAxis::X);
        CHECK(s.camera.filter == FilterType::Box);
        CHECK(near(Vec3(s.camera.toWorld[3]), Vec3(-0.0439815f, -4.12529f, 0.222539f)));
        CHECK(near(glm::normalize(Vec3(s.camera.toWorld[2])),
                   glm::normalize(Vec3(0.00688625f, 0.998505f, -0.0542161f))));
        // Camera +X is the image left: world -x (the green wall, x = -1.27, is on the image left).
        CHECK(glm::dot(Vec3(s.camera.toWorld[0]), Vec3(-1, 0, 0)) > 0.99f);
        CHECK(glm::dot(Vec3(s.camera.toWorld[1]), Vec3(0, 0, 1)) > 0.99f);

        // Integrator: VCM, max path length 10 segments, radius 0.003 x scene radius, alpha 0.75.
        CHECK(s.integrator.type == "vcm");
        CHECK(s.integrator.maxDepth == 10);
        CHECK(s.integrator.radius == Approx(0.003f * sceneRadius).epsilon(1e-5));
        CHECK(s.integrator.radiusAlpha == 0.75f);

        // Walls and light box: every quad is SmallVCM's, with its material.
        const bool pointLight = name == "small-spheres-point";
        const bool ceilingLight = name.find("ceiling") != std::string::npos;
        std::set<std::string> names;
        for (const MeshDesc& m : s.meshes) {
            names.insert(m.name);
            auto q = kQuads.find(m.name);
            REQUIRE(q != kQuads.end());
            checkQuad(m, q->second);
            if (m.name == "light") {
                CHECK(diffuseReflectance(s, m.bsdf) == Color(0.f));  // SmallVCM's light materials reflect nothing
            } else {
                CHECK(m.emitter == -1);
                CHECK(near(diffuseReflectance(s, m.bsdf), m.name == "left" ? green : m.name == "right" ? red : white));
            }
        }
        std::set<std::string> expected = {"floor", "back", "ceiling", "left", "right"};
        if (!pointLight)  // SmallVCM builds no light box with a point light
            expected.insert({"light-box-back", "light-box-left", "light-box-right", "light-box-front",
                             ceilingLight ? "light" : "light-box-bottom"});
        CHECK(names == expected);

        // Lights.
        REQUIRE(s.emitters.size() == 1);
        const EmitterDesc& e = s.emitters[0];
        if (ceilingLight) {
            CHECK(e.type == EmitterType::Area);
            CHECK(near(e.value, Color(25.03329895614464f), 1e-4f));  // SmallVCM's AreaLight::mIntensity (radiance)
            for (const MeshDesc& m : s.meshes)
                if (m.name == "light") {
                    CHECK(m.emitter == 0);
                    CHECK(meshArea(m) == Approx(0.25).epsilon(1e-6));
                }
        } else if (pointLight) {
            CHECK(e.type == EmitterType::Point);
            CHECK(near(e.position, Vec3(0.f, -0.5f, 1.f)));
            CHECK(near(e.value, Color(float(70.0 / (4.0 * M_PI))), 1e-5f));  // W/sr
        } else if (name == "small-spheres-sun") {
            CHECK(e.type == EmitterType::Directional);
            CHECK(near(e.direction, glm::normalize(Vec3(-1.f, 1.5f, -1.f))));  // direction of travel
            CHECK(near(e.value, Color(10.f, 4.f, 0.f)));                        // irradiance
        } else {
            CHECK(e.type == EmitterType::Constant);
            CHECK(near(e.value, Color(135.f, 206.f, 250.f) / 255.f));
        }

        // Spheres: centres on the floor as SmallVCM computes them, mirror and glass (IOR 1.6).
        const Vec3 floorCentre = (cb[0] + cb[1] + cb[4] + cb[5]) * 0.25f;
        const float xlen = cb[1].x - cb[0].x;
        const Vec3 smallLeft = (cb[0] + cb[4]) * 0.5f + Vec3(2.f * xlen / 7.f, 0.f, 0.5f);
        const Vec3 smallRight = (cb[1] + cb[5]) * 0.5f + Vec3(-2.f * xlen / 7.f, 0.f, 0.5f);
        struct Expected { const char* id; Vec3 centre; float radius; const char* bsdf; };
        std::vector<Expected> spheres;
        if (name.rfind("small-spheres", 0) == 0)
            spheres = {{"small-mirror-sphere", smallLeft, 0.5f, "conductor"}, {"small-glass-sphere", smallRight, 0.5f, "dielectric"}};
        else if (name == "large-glass-ceiling")
            spheres = {{"large-glass-sphere", floorCentre + Vec3(0, 0, 0.8f), 0.8f, "dielectric"}};
        else if (name == "large-mirror-ceiling")
            spheres = {{"large-mirror-sphere", floorCentre + Vec3(0, 0, 0.8f), 0.8f, "conductor"}};
        CHECK(s.spheres.size() == spheres.size());
        for (const Expected& x : spheres) {
            INFO(x.id);
            const SphereDesc* sp = findSphere(s, x.id);
            REQUIRE(sp);
            CHECK(near(sp->center, x.centre));
            CHECK(sp->radius == x.radius);
            CHECK_FALSE(sp->flipNormals);
            CHECK(s.bsdfs[sp->bsdf]->name() == x.bsdf);
        }
    }
}

TEST_CASE("smallvcm scenes: render finite and non-black with PT, BPT and VCM", "[scenes][smallvcm]") {
    fs::path dir = lt::test::tempDir("lt_smallvcm", "render");
    for (const std::string& name : kScenes) {
        for (const char* integrator : {"pt", "bpt", "vcm"}) {
            INFO(name << " with " << integrator);
            fs::path out = dir / (name + "-" + integrator + ".exr");
            lt::test::Run r = lt::test::sh(std::string(LT_RENDER_BIN) + " " + (sceneDir() / (name + ".xml")).string() +
                                           " -D res=16 --spp 2 --quiet --integrator " + integrator + " -o " + out.string());
            INFO(r.output);
            REQUIRE(r.code == 0);
            CHECK(r.output.find("warning") == std::string::npos);
            Image img = readImage(out.string());
            REQUIRE(img.width == 16);
            REQUIRE(img.height == 16);
            double sum = 0;
            for (const auto& c : img.pixels) {
                REQUIRE(isFinite(c));
                REQUIRE(c.x >= 0.f);
                REQUIRE(c.y >= 0.f);
                REQUIRE(c.z >= 0.f);
                sum += double(c.x) + c.y + c.z;
            }
            CHECK(sum > 0.0);
        }
    }
    fs::remove_all(dir);
}
