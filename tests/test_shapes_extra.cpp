// Mitsuba's cylinder, shapegroup + instance and mesh_attribute (issue 46): the cylinder's hits,
// normals, uv and area sampling against closed forms, every integrator on a cylinder light, an
// instanced scene against the same geometry written out flat, PLY attributes interpolated at
// hits, and the loader's errors.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <glm/gtc/matrix_transform.hpp>
#include "bsdf/surface_bsdf.h"
#include "core/loader.h"
#include "core/mesh_attribute.h"
#include "core/mesh_io.h"
#include "core/scene.h"
#include "process.h"
#include "render_compare.h"
#include "scene_builders.h"

using namespace lt;
using namespace lt::test;

namespace {

std::string writeTemp(const std::string& name, const std::string& text) {
    static const TempDir dir("lt_test_shapes_extra");  // per process, removed at exit
    return dir.write(name, text);
}


// A cylinder of radius 0.5 from p0 = (1, 2, 3) to p1 = (1, 2, 5) (axis +z), under a constant sky.
const char* kCylinderXml = R"(<scene version="3.0.0">
    <shape type="cylinder">
        <point name="p0" x="1" y="2" z="3"/><point name="p1" x="1" y="2" z="5"/>
        <float name="radius" value="0.5"/>
        <emitter type="area"><rgb name="radiance" value="2"/></emitter>
    </shape>
    <emitter type="constant"/>
</scene>)";

}  // namespace

TEST_CASE("cylinder: hits and normals and uv against the closed form", "[shapes][cylinder]") {
    const SceneDesc d = loadScene(writeTemp("cyl.xml", kCylinderXml), {});
    REQUIRE(d.cylinders.size() == 1);
    CHECK(d.cylinders[0].radius == Approx(0.5));
    CHECK(d.cylinders[0].length == Approx(2.0));
    const Scene scene(d);
    const Vec3 axis0(1, 2, 3);
    // From outside, towards the axis at height h and angle phi: t = distance - r, p on the
    // surface, outward normal, uv = (phi / 2 pi, h / length).
    for (float phi : {0.1f, 1.3f, 2.9f, 4.4f, 6.0f})
        for (float h : {0.2f, 1.f, 1.9f}) {
            const Vec3 radial(std::cos(phi), std::sin(phi), 0.f);
            const Vec3 o = axis0 + Vec3(0, 0, h) + 3.f * radial;
            SurfaceHit hit;
            INFO("phi " << phi << " h " << h);
            REQUIRE(scene.intersect(Ray{o, -radial}, hit));
            CHECK(hit.t == Approx(2.5f).epsilon(1e-5));
            const Vec3 expect = axis0 + Vec3(0, 0, h) + 0.5f * radial;
            CHECK(glm::length(hit.p - expect) < 1e-5f);
            CHECK(glm::length(hit.ng - radial) < 1e-5f);
            CHECK(glm::length(hit.shading.n - radial) < 1e-5f);
            CHECK(hit.uv.x == Approx(phi / (2.f * kPi)).margin(1e-5));
            CHECK(hit.uv.y == Approx(h / 2.f).margin(1e-5));
            CHECK(hit.curvature == Approx(1.f));  // mean curvature 1 / (2 r)
            CHECK(hit.light != nullptr);
        }
    // From inside: the far wall, its normal still outward (Mitsuba's one-sided open cylinder).
    SurfaceHit in;
    REQUIRE(scene.intersect(Ray{axis0 + Vec3(0, 0, 1), Vec3(1, 0, 0)}, in));
    CHECK(in.t == Approx(0.5f));
    CHECK(glm::length(in.ng - Vec3(1, 0, 0)) < 1e-6f);
    // Open: a ray along the axis, and rays that pass above or below the mantle, miss.
    SurfaceHit miss;
    CHECK_FALSE(scene.intersect(Ray{axis0 + Vec3(0, 0, -1), Vec3(0, 0, 1)}, miss));
    CHECK_FALSE(scene.intersect(Ray{axis0 + Vec3(3, 0, 2.1f), Vec3(-1, 0, 0)}, miss));
    CHECK_FALSE(scene.intersect(Ray{axis0 + Vec3(3, 0, -0.1f), Vec3(-1, 0, 0)}, miss));
    // A slanted ray entering through the open top meets the inside of the wall.
    SurfaceHit slant;
    REQUIRE(scene.intersect(Ray{axis0 + Vec3(0, 0, 3), glm::normalize(Vec3(0.25f, 0, -1))}, slant));
    CHECK(slant.p.x == Approx(1.5f).margin(1e-5));
    CHECK(slant.p.z == Approx(6.f - 2.f).margin(1e-4));  // x = 0.5 after dropping 2 from z = 6
    CHECK(scene.occludedRay(Ray{axis0 + Vec3(3, 0, 1), Vec3(-1, 0, 0), 0.f, 10.f}));
    CHECK_FALSE(scene.occludedRay(Ray{axis0 + Vec3(3, 0, 1), Vec3(-1, 0, 0), 0.f, 2.4f}));
    // flip_normals and a rotated, uniformly scaled to_world: the axis along world +x.
    SceneDesc f = loadScene(writeTemp("cylflip.xml", R"(<scene version="3.0.0">
    <shape type="cylinder"><boolean name="flip_normals" value="true"/>
        <transform name="to_world"><scale value="2"/><rotate y="1" angle="90"/></transform></shape>
    <emitter type="constant"/>
</scene>)"),
                              {});
    const Scene fs(f);
    SurfaceHit h;
    REQUIRE(fs.intersect(Ray{Vec3(1, 0, 5), Vec3(0, 0, -1)}, h));  // radius 2, axis x in [0, 2]
    CHECK(h.t == Approx(3.f).epsilon(1e-5));
    CHECK(glm::length(h.ng - Vec3(0, 0, -1)) < 1e-5f);  // flipped: inwards
    CHECK(h.uv.y == Approx(0.5f).margin(1e-5));
}

TEST_CASE("cylinder: uniform area sampling and its pdf", "[shapes][cylinder][statistical]") {
    const SceneDesc d = loadScene(writeTemp("cyl.xml", kCylinderXml), {});
    const Scene scene(d);
    REQUIRE(scene.lights().size() == 2);
    const Light* l = nullptr;
    for (const Light& x : scene.lights())
        if (x.type == LightType::Area) l = &x;
    REQUIRE(l != nullptr);
    const float area = 2.f * kPi * 0.5f * 2.f;
    CHECK(l->area == Approx(area));
    const Vec3 ref(1, 2, 4);  // on the axis: every sampled point is seen from inside, 0 radiance
    // Points on the surface with outward normals; pdf 1 / area; chi-square over 8 x 4 (phi, z)
    // bins of N = 64000 samples, 31 degrees of freedom, at significance 1e-3 (critical 61.1): a
    // sampler off by 10% in one half of the bins exceeds it by far.
    Rng rng(7, 0);
    const int nPhi = 8, nZ = 4, n = 64000;
    std::vector<int> counts(nPhi * nZ, 0);
    for (int i = 0; i < n; ++i) {
        const LightSampleLi s = l->sampleLi(scene, ref + Vec3(3, 0, 0), Vec2(rng.uniform(), rng.uniform()));
        const Vec3 q = s.p - Vec3(1, 2, 3);
        REQUIRE(std::hypot(q.x, q.y) == Approx(0.5f).epsilon(1e-5));
        REQUIRE(q.z >= -1e-5f);
        REQUIRE(q.z <= 2.f + 1e-5f);
        REQUIRE(glm::length(s.n - glm::normalize(Vec3(q.x, q.y, 0.f))) < 1e-4f);
        REQUIRE(s.pdfPos.value == Approx(1.f / area));
        float phi = std::atan2(q.y, q.x);
        if (phi < 0.f) phi += 2.f * kPi;
        const int bp = std::min(nPhi - 1, int(phi / (2.f * kPi) * nPhi)), bz = std::min(nZ - 1, int(q.z / 2.f * nZ));
        ++counts[size_t(bp * nZ + bz)];
    }
    double chi2 = 0.0;
    const double expect = double(n) / double(counts.size());
    for (int c : counts) chi2 += (c - expect) * (c - expect) / expect;
    INFO("chi2 " << chi2);
    CHECK(chi2 < 61.1);
    CHECK(l->pdfLi(scene, ref, ref, Vec3(1, 0, 0), Vec3(0.f)).value == Approx(1.f / area));
    CHECK(l->pdfLePos(scene).value == Approx(1.f / area));
}

TEST_CASE("a cylinder area light: PT and BPT and LT and VCM agree", "[shapes][cylinder][bpt][statistical]") {
    // A diffuse floor and back wall lit by a horizontal emitting cylinder (its light reaches them
    // by next-event estimation, emitter hits, light tracing and connections alike). 32x32 in 4x4
    // blocks, K = 10 renders per integrator, Welch's t per block against PT at family-wise
    // significance 1% per comparison (Sidak over the 16 blocks).
    SceneDesc d;
    d.bsdfs.push_back(makeDiffuse(Color(0.7f)));
    d.meshes.push_back(quad(Vec3(-2, -1, -2), Vec3(0, 0, 4), Vec3(4, 0, 0), 0));   // floor y = -1, up
    d.meshes.push_back(quad(Vec3(-2, -1, 2), Vec3(4, 0, 0), Vec3(0, 3, 0), 0));     // back wall z = 2
    EmitterDesc e;
    e.type = EmitterType::Area;
    e.value = Color(3.f);
    d.emitters.push_back(e);
    CylinderDesc c;
    // axis along x from (-1, 0.3, 0.5), radius 0.2, length 2
    c.toWorld = glm::translate(glm::dmat4(1.0), glm::dvec3(-1, 0.3, 0.5)) *
                glm::rotate(glm::dmat4(1.0), 3.14159265358979323846 / 2, glm::dvec3(0, 1, 0)) *
                glm::scale(glm::dmat4(1.0), glm::dvec3(0.2, 0.2, 2.0));
    c.radius = 0.2;
    c.length = 2.0;
    c.bsdf = 0;
    c.emitter = 0;
    d.cylinders.push_back(c);
    d.camera = lookAt(Vec3(0, 1.2f, -4), Vec3(0, 0, 0.5f), Vec3(0, 1, 0), 45.f, 32, 32);
    RenderSettings s;
    s.spp = 4;
    s.maxDepth = 4;
    const auto pt = checkAgreesWithPt(d, s, {"bpt", "lt", "vcm"});
    // Power: the light 20% brighter differs from PT.
    SceneDesc brighter = d;
    brighter.emitters[0].value = Color(3.6f);
    s.integrator = "pt";
    s.spp = 4;
    CHECK(differingBlocks(pt, blockStats(brighter, s, 10, 4), 0.01) > 0);
}

namespace {

// Shapes of every analytic and mesh kind, in a group instanced twice, and the same written out
// flat (each shape's transform followed by its instance's: the XML composes left to right). The
// rectangle, the rotated sphere and the cylinder are anisotropic: their hits take the dp/du frame,
// which an instance must map to the world as the flat shape's.
const char* kGroupShapes[] = {
    R"(<shape type="rectangle"><transform name="to_world"><scale value="0.8"/><rotate y="1" angle="-70"/>%T</transform>
        <bsdf type="roughconductor"><float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.3"/></bsdf></shape>)",
    R"(<shape type="sphere"><transform name="to_world"><scale value="0.4"/><rotate x="1" angle="30"/><translate x="-0.8"/>%T</transform>
        <bsdf type="roughconductor"><float name="alpha_u" value="0.3"/><float name="alpha_v" value="0.05"/></bsdf></shape>)",
    R"(<shape type="cylinder"><float name="radius" value="0.3"/><transform name="to_world"><translate y="0.5"/>%T</transform>
        <bsdf type="roughconductor"><float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.3"/></bsdf></shape>)",
    R"(<shape type="cube"><transform name="to_world"><scale value="0.2"/><translate x="0.7" z="0.5"/>%T</transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.3 0.8 0.3"/></bsdf></shape>)"};
const char* kInstanceTransforms[] = {R"(<rotate y="1" angle="45"/><scale value="1.5"/><translate z="2"/>)",
                                     R"(<rotate x="1" angle="-25"/><translate x="-1" z="-2"/>)"};

std::string replaceAll(std::string s, const std::string& from, const std::string& to) {
    for (size_t i = s.find(from); i != std::string::npos; i = s.find(from, i + to.size())) s.replace(i, from.size(), to);
    return s;
}

std::string instancingScene(bool flat) {
    std::string xml = R"(<scene version="3.0.0">
    <sensor type="perspective"><float name="fov" value="50"/>
        <transform name="to_world"><lookat origin="-5, -6, 1" target="0, 0, 0" up="0, 0, 1"/></transform>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
    </sensor>
    <emitter type="point"><point name="position" x="-5" y="-6" z="3"/><rgb name="intensity" value="300"/></emitter>
    <shape type="rectangle"><transform name="to_world"><scale value="1"/><translate x="4" y="3"/></transform>
        <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
)";
    if (flat) {
        for (const char* t : kInstanceTransforms)
            for (const char* s : kGroupShapes) xml += replaceAll(s, "%T", t) + "\n";
    } else {
        xml += "<shape type=\"shapegroup\" id=\"g\">\n";
        for (const char* s : kGroupShapes) xml += replaceAll(s, "%T", "") + "\n";
        xml += "</shape>\n";
        for (const char* t : kInstanceTransforms)
            xml += std::string("<shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\">") + t +
                   "</transform></shape>\n";
    }
    return xml + "</scene>";
}

}  // namespace

TEST_CASE("instancing: a shapegroup's instances are the same geometry as the shapes written out flat", "[shapes][instancing]") {
    const SceneDesc inst = loadScene(writeTemp("instanced.xml", instancingScene(false)), {});
    const SceneDesc flat = loadScene(writeTemp("flat.xml", instancingScene(true)), {});
    REQUIRE(inst.groupCount == 1);
    REQUIRE(inst.instances.size() == 2);
    REQUIRE(flat.instances.empty());
    const Scene a(inst), b(flat);
    CHECK(a.geometryRadius() == Approx(b.geometryRadius()).epsilon(0.05));  // (boxes of boxes: a little larger)
    // Every camera ray of a 48x48 grid: the same hit (point, normals, uv, material's name, t).
    int hits = 0;
    for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 48; ++x) {
            const Vec3 o(-5, -6, 1);
            const Vec3 target(-3.f + 6.f * (x + 0.5f) / 48.f, 0.f, -3.f + 6.f * (y + 0.5f) / 48.f);
            const Ray r{o, glm::normalize(target - o)};
            SurfaceHit ha, hb;
            const bool ia = a.intersect(r, ha), ib = b.intersect(r, hb);
            INFO("ray " << x << " " << y);
            REQUIRE(ia == ib);
            if (!ia) continue;
            ++hits;
            CHECK(ha.t == Approx(hb.t).epsilon(1e-4));
            CHECK(glm::length(ha.p - hb.p) < 1e-4f);
            CHECK(glm::length(ha.ng - hb.ng) < 1e-4f);
            CHECK(glm::length(ha.shading.n - hb.shading.n) < 1e-4f);
            CHECK(glm::length(ha.shading.s - hb.shading.s) < 1e-3f);
            CHECK(glm::length(ha.uv - hb.uv) < 1e-4f);
            CHECK(ha.curvature == Approx(hb.curvature).epsilon(1e-3));
            REQUIRE(ha.bxdf != nullptr);
            CHECK(ha.bxdf->valueBound(kRadianceContext) == Approx(hb.bxdf->valueBound(kRadianceContext)));
            CHECK(a.occludedRay(Ray{r.o, r.d, 0.f, ha.t * 1.001f}));
            CHECK_FALSE(a.occludedRay(Ray{r.o, r.d, 0.f, ha.t * 0.999f}));
        }
    CHECK(hits > 300);
    // The images: statistically identical (16 blocks, K = 6 renders each, Welch's t at family-wise
    // significance 1%), in PT and BPT.
    for (std::string integ : {"pt", "bpt"}) {
        RenderSettings s;
        s.spp = 4;
        s.maxDepth = 3;
        s.integrator = integ;
        double worst;
        const int bad = differingBlocks(blockStats(inst, s, 6, 4), blockStats(flat, s, 6, 4), 0.01, &worst);
        INFO(integ << ": " << bad << " blocks differ, worst |t|/crit " << worst);
        CHECK(bad == 0);
    }
}

// An anisotropic material on a cylinder orients its lobe by Mitsuba's dp/du: the tangent of the
// circle about the axis (u = phi / 2 pi), for a tilted cylinder too. Rays from all around hit it.
TEST_CASE("cylinder: hits on an anisotropic cylinder take the circle's tangent as dp/du", "[shapes][cylinder]") {
    for (const bool tilted : {false, true}) {
        const std::string xf = tilted ? R"(<rotate x="1" angle="40"/><rotate z="1" angle="25"/>)" : "";
        const std::string xml = R"(<scene version="3.0.0">
    <shape type="cylinder"><float name="radius" value="0.5"/><point name="p0" x="0" y="0" z="-1"/>
        <point name="p1" x="0" y="0" z="1"/><transform name="to_world">)" + xf + R"(</transform>
        <bsdf type="roughconductor"><float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.3"/></bsdf></shape>
    </scene>)";
        const Scene scene(loadScene(writeTemp(tilted ? "cyl-tilted.xml" : "cyl.xml", xml), {}));
        const Vec3 axis = tilted ? glm::normalize(Vec3(glm::rotate(glm::mat4(1.f), glm::radians(25.f), Vec3(0, 0, 1)) *
                                                       glm::rotate(glm::mat4(1.f), glm::radians(40.f), Vec3(1, 0, 0)) *
                                                       glm::vec4(0, 0, 1, 0)))
                                 : Vec3(0, 0, 1);
        int hits = 0;
        for (int k = 0; k < 64; ++k) {
            const float a = 2.f * kPi * (k + 0.5f) / 64.f;
            const Vec3 side = glm::normalize(glm::cross(axis, Vec3(std::cos(a), std::sin(a), 0.3f)));
            const Vec3 o = 3.f * side + 0.2f * float(k % 5 - 2) * axis;
            SurfaceHit h;
            if (!scene.intersect(Ray{o, -side}, h)) continue;
            ++hits;
            INFO("tilted " << tilted << " ray " << k);
            // s: unit, perpendicular to the axis and to the normal, turning as phi grows (+z right-handed)
            CHECK(std::abs(glm::dot(h.shading.s, axis)) < 1e-4f);
            CHECK(std::abs(glm::dot(h.shading.s, h.shading.n)) < 1e-4f);
            CHECK(glm::dot(h.shading.s, glm::cross(axis, h.ng)) > 0.999f);
        }
        CHECK(hits == 64);
    }
}

namespace {

// One triangle with a vertex colour (float color_0..2 -> "vertex_color"), 8-bit red/green/blue
// ("vertex_color" too: the r g b rule comes first, so only one is kept; see below), and a face
// weight (weight_0 -> "face_weight") and a face colour (float c_r c_g c_b -> "face_c_color").
const char* kTrianglePly = R"(ply
format ascii 1.0
element vertex 3
property float x
property float y
property float z
property float color_0
property float color_1
property float color_2
element face 1
property list uchar int vertex_indices
property float weight_0
property uchar c_r
property uchar c_g
property uchar c_b
end_header
0 0 0 1 0 0
1 0 0 0 1 0
0 1 0 0 0 1
3 0 1 2 0.25 255 0 128
)";

Color reflectanceAt(const Scene& scene, const Vec3& p) {
    SurfaceHit h;
    if (!scene.intersect(Ray{p + Vec3(0, 0, 1), Vec3(0, 0, -1)}, h)) return Color(-1.f);
    const SurfaceBsdf b(h.bxdf, h.shading, h.ng, h.uv);
    return b.eval(Vec3(0, 0, 1), Vec3(0, 0, 1), kRadianceContext).f * kPi;
}

std::string attributeScene(const std::string& ply, const std::string& name, float scale) {
    return R"(<scene version="3.0.0">
    <shape type="ply"><string name="filename" value=")" + ply + R"("/>
        <bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance">
            <string name="name" value=")" + name + R"("/><float name="scale" value=")" + std::to_string(scale) + R"("/>
        </texture></bsdf></shape>
    <emitter type="constant"/>
</scene>)";
}

}  // namespace

TEST_CASE("mesh_attribute: PLY vertex and face attributes interpolated at hits", "[shapes][mesh_attribute]") {
    const std::string ply = writeTemp("tri.ply", kTrianglePly);
    MeshAttributes attrs;
    readPly(ply, &attrs);
    REQUIRE(attrs.size() == 3);
    CHECK(attrs[0].name == "vertex_color");
    CHECK(attrs[0].channels == 3);
    CHECK(attrs[1].name == "face_weight");
    CHECK(attrs[1].channels == 1);
    CHECK(attrs[2].name == "face_c_color");
    REQUIRE(attrs[2].values.size() == 3);
    CHECK(attrs[2].values[0] == Approx(1.f));
    CHECK(attrs[2].values[1] == Approx(0.f));
    CHECK(attrs[2].values[2] == Approx(0.2158605f).epsilon(1e-4));  // 128/255 sRGB-decoded
    // The vertex colour at barycentrics (b0, b1, b2) is (b0, b1, b2) here; scale 0.5.
    {
        const Scene scene(loadScene(writeTemp("vertex.xml", attributeScene(ply, "vertex_color", 0.5f)), {}));
        for (const Vec2 q : {Vec2(0.2f, 0.3f), Vec2(0.6f, 0.1f), Vec2(0.05f, 0.9f), Vec2(0.33f, 0.33f)}) {
            const Color c = reflectanceAt(scene, Vec3(q.x, q.y, 0.f));
            INFO("at " << q.x << " " << q.y);
            CHECK(c.x == Approx(0.5f * (1.f - q.x - q.y)).margin(2e-6));
            CHECK(c.y == Approx(0.5f * q.x).margin(2e-6));
            CHECK(c.z == Approx(0.5f * q.y).margin(2e-6));
        }
    }
    // Face attributes: constant over the face; one channel is grey.
    {
        const Scene scene(loadScene(writeTemp("face.xml", attributeScene(ply, "face_weight", 2.f)), {}));
        for (const Vec2 q : {Vec2(0.2f, 0.3f), Vec2(0.6f, 0.1f)}) {
            const Color c = reflectanceAt(scene, Vec3(q.x, q.y, 0.f));
            CHECK(c.x == Approx(0.5f));
            CHECK(c.y == Approx(0.5f));
            CHECK(c.z == Approx(0.5f));
        }
        const Scene color(loadScene(writeTemp("facec.xml", attributeScene(ply, "face_c_color", 1.f)), {}));
        const Color c = reflectanceAt(color, Vec3(0.3f, 0.3f, 0.f));
        CHECK(c.x == Approx(1.f));
        CHECK(c.y == Approx(0.f).margin(1e-7));
        CHECK(c.z == Approx(0.2158605f).epsilon(1e-4));
    }
    // The key itself: the primitive and the barycentrics come back to 1e-6.
    uint32_t prim;
    float b1, b2;
    decodeAttributeKey(attributeKey(12345678u, 0.123456f, 0.654321f), prim, b1, b2);
    CHECK(prim == 12345678u);
    CHECK(b1 == Approx(0.123456f).margin(1e-6));
    CHECK(b2 == Approx(0.654321f).margin(1e-6));
}

TEST_CASE("loader: cylinder and shapegroup and mesh_attribute errors name file and line and parameter", "[shapes][loader]") {
    const std::string ply = writeTemp("tri2.ply", kTrianglePly);
    std::string e = loadError(writeTemp("noattr.xml", attributeScene(ply, "vertex_weight", 1.f)));
    INFO(e);
    CHECK(e.find("noattr.xml:4") != std::string::npos);
    CHECK(e.find("'name'") != std::string::npos);
    CHECK(e.find("vertex_weight") != std::string::npos);
    CHECK(e.find("vertex_color") != std::string::npos);  // the attributes it has
    e = loadError(writeTemp("badattr.xml", attributeScene(ply, "color", 1.f)));
    CHECK(e.find("badattr.xml:4") != std::string::npos);
    CHECK(e.find("vertex_") != std::string::npos);
    e = loadError(writeTemp("attrsphere.xml", R"(<scene version="3.0.0">
    <shape type="sphere"><bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance">
        <string name="name" value="vertex_color"/></texture></bsdf></shape>
</scene>)"));
    CHECK(e.find("attrsphere.xml:2") != std::string::npos);
    CHECK(e.find("PLY") != std::string::npos);
    e = loadError(writeTemp("groupemitter.xml", R"(<scene version="3.0.0">
    <shape type="shapegroup" id="g">
        <shape type="sphere">
            <emitter type="area"/>
        </shape>
    </shape>
    <shape type="instance"><ref id="g"/></shape>
</scene>)"));
    CHECK(e.find("groupemitter.xml:4") != std::string::npos);
    CHECK(e.find("shapegroup") != std::string::npos);
    e = loadError(writeTemp("instnotgroup.xml", R"(<scene version="3.0.0">
    <shape type="sphere" id="s"/>
    <shape type="instance"><ref id="s"/></shape>
</scene>)"));
    CHECK(e.find("instnotgroup.xml:3") != std::string::npos);
    e = loadError(writeTemp("cylshear.xml", R"(<scene version="3.0.0">
    <shape type="cylinder"><transform name="to_world"><scale x="1" y="2" z="1"/></transform></shape>
</scene>)"));
    CHECK(e.find("cylshear.xml:2") != std::string::npos);
    CHECK(e.find("'to_world'") != std::string::npos);
    e = loadError(writeTemp("cylradius.xml", R"(<scene version="3.0.0">
    <shape type="cylinder"><float name="radius" value="-1"/></shape>
</scene>)"));
    CHECK(e.find("cylradius.xml:2") != std::string::npos);
    CHECK(e.find("'radius'") != std::string::npos);
    // A shapegroup no instance uses: loaded, with a warning naming it.
    const SceneDesc d = loadScene(writeTemp("unused.xml", R"(<scene version="3.0.0">
    <shape type="shapegroup" id="g"><shape type="sphere"/></shape>
    <emitter type="constant"/>
</scene>)"),
                                  {});
    bool warned = false;
    for (const std::string& w : d.warnings) warned = warned || (w.find("unused.xml:2") != std::string::npos &&
                                                                w.find("used by no instance") != std::string::npos);
    CHECK(warned);
}
