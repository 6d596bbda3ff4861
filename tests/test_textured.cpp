// Textured materials (issue 46): a material's model at a surface point from its textures at the
// point's uv (Bxdf::atUv through SurfaceBsdf), the shapes' uv parameterisations, the loader's
// <texture> elements, and every integrator agreeing on a textured scene.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include "bsdf/surface_bsdf.h"
#include "core/loader.h"
#include "core/scene.h"
#include "core/texture/texture.h"
#include "process.h"
#include "render_compare.h"
#include "scene_builders.h"

using namespace lt;
using namespace lt::test;
namespace fs = std::filesystem;

namespace {

// A texture whose value names the uv it was asked for: (u, v, 0.25), wrapped into [0, 1).
class UvTexture final : public Texture {
public:
    Color eval(const Vec2& uv) const override { return Color(uv.x - std::floor(uv.x), uv.y - std::floor(uv.y), 0.25f); }
    Color maxValue() const override { return Color(1.f, 1.f, 0.25f); }
    Color meanValue() const override { return Color(0.5f, 0.5f, 0.25f); }
    std::string name() const override { return "uv"; }
};

// Strong contrast in stripes along u: what a wrong uv or a missing texture in one technique shows.
class StripeTexture final : public Texture {
public:
    Color eval(const Vec2& uv) const override {
        return int(std::floor(uv.x * 4.f)) % 2 == 0 ? Color(0.9f, 0.8f, 0.7f) : Color(0.05f, 0.1f, 0.2f);
    }
    Color maxValue() const override { return Color(0.9f, 0.8f, 0.7f); }
    Color meanValue() const override { return Color(0.475f, 0.45f, 0.45f); }
    std::string name() const override { return "stripes"; }
};

}  // namespace

TEST_CASE("textured diffuse: the model at a point is Lambert with the texture's value there", "[texture][bsdf]") {
    const BxdfPtr b = makeTexturedDiffuse(std::make_shared<UvTexture>());
    CHECK(b->textured());
    CHECK(b->flags() == (kReflection | kDiffuse));
    CHECK(b->continuation() == 1.f);                            // the texture's largest channel
    CHECK(b->valueBound(BsdfContext{}) == Approx(kInvPi));       // max / pi, over every point
    CHECK(b->lambert() == nullptr);                              // the material has no single Lambert
    const Frame frame(Vec3(0, 0, 1));
    const Vec3 ng(0, 0, 1);
    const Vec3 wo = glm::normalize(Vec3(0.3f, -0.2f, 1.f)), wi = glm::normalize(Vec3(-0.5f, 0.1f, 0.8f));
    for (const Vec2 uv : {Vec2(0.1f, 0.7f), Vec2(0.9f, 0.2f), Vec2(1.3f, -0.4f)}) {
        const SurfaceBsdf s(b.get(), frame, ng, uv);
        const Color r = UvTexture().eval(uv);
        const BsdfEval e = s.eval(wo, wi, kRadianceContext);
        CHECK(e.f.x == Approx(r.x * kInvPi));
        CHECK(e.f.y == Approx(r.y * kInvPi));
        CHECK(e.f.z == Approx(r.z * kInvPi));
        CHECK(e.pdfFwd.value == Approx(wi.z * kInvPi));
        BsdfSample bs;
        REQUIRE(s.sample(wo, 0.5f, Vec2(0.3f, 0.6f), kRadianceContext, bs));
        CHECK(bs.weight.x == Approx(r.x));  // f cos / p = R
        CHECK(bs.weight.y == Approx(r.y));
        // Two-sided: from below, the same values (mirrored directions).
        const BxdfPtr two = makeTwoSided(b);
        CHECK(two->textured());
        CHECK(makeTwoSided(two) == two);
        const SurfaceBsdf t(two.get(), frame, ng, uv);
        const BsdfEval below = t.eval(Vec3(wo.x, wo.y, -wo.z), Vec3(wi.x, wi.y, -wi.z), kRadianceContext);
        CHECK(below.f.x == Approx(r.x * kInvPi));
        CHECK(below.f.y == Approx(r.y * kInvPi));
    }
}

TEST_CASE("hits carry Mitsuba's uv: meshes interpolate theirs and spheres use phi and theta", "[texture][scene]") {
    SceneDesc d;
    d.bsdfs.push_back(makeTexturedDiffuse(std::make_shared<UvTexture>()));
    MeshDesc q = quad(Vec3(-1, -1, 0), Vec3(2, 0, 0), Vec3(0, 2, 0), 0);  // z = 0, facing +z
    q.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    d.meshes.push_back(q);
    SphereDesc s;
    s.center = Vec3(0, 0, 10);
    s.radius = 1.f;
    s.bsdf = 0;
    d.spheres.push_back(s);
    EmitterDesc e;
    e.type = EmitterType::Constant;
    d.emitters.push_back(e);
    const Scene scene(d);
    // The walk's form of a hit (SurfacePoint) carries uv on a textured material too.
    SurfacePoint hp;
    REQUIRE(scene.intersect(Ray{Vec3(0.5f, -0.5f, 1.f), Vec3(0, 0, -1)}, hp));
    CHECK(hp.uv.x == Approx(0.75f));
    CHECK(hp.uv.y == Approx(0.25f));
    // Sphere: u = phi / (2 pi), phi in [0, 2 pi) about +z from +x; v = theta / pi from +z.
    const std::pair<Vec3, Vec2> cases[] = {{Vec3(1, 0, 0), Vec2(0.f, 0.5f)}, {Vec3(-1, 0, 0), Vec2(0.5f, 0.5f)},
                                           {Vec3(0, -1, 0), Vec2(0.75f, 0.5f)}, {Vec3(0, 1, 0), Vec2(0.25f, 0.5f)},
                                           {glm::normalize(Vec3(1, 0, 1)), Vec2(0.f, 0.25f)}};
    for (const auto& [dir, uv] : cases) {
        SurfaceHit h;
        REQUIRE(scene.intersect(Ray{s.center + 3.f * dir, -dir}, h));
        INFO("direction " << dir.x << " " << dir.y << " " << dir.z);
        CHECK(h.uv.x == Approx(uv.x).margin(1e-5));
        CHECK(h.uv.y == Approx(uv.y).margin(1e-5));
    }
}

TEST_CASE("PT and BPT and LT and VCM agree on a textured scene", "[texture][bpt][statistical]") {
    // The Cornell box with a striped floor and back wall (texture in every technique: the camera's
    // and the light's walks, next-event estimation, connections). 32x32 in 4x4 blocks, K = 10
    // independent renders per integrator, Welch's t per block against PT at family-wise
    // significance 1% per comparison (Sidak over the 16 blocks). A technique that evaluated the
    // material without its texture (the stripes' mean) differs in most blocks.
    SceneDesc d = cornellBox(32, makeDiffuse(Color(0.5f)));
    d.bsdfs.push_back(makeTexturedDiffuse(std::make_shared<StripeTexture>()));
    const int tex = int(d.bsdfs.size()) - 1;
    for (int m : {0, 2}) {  // floor, back
        d.meshes[size_t(m)].bsdf = tex;
        d.meshes[size_t(m)].uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    }
    d.integrator.maxDepth = 4;
    RenderSettings s;
    s.spp = 4;
    s.maxDepth = 4;
    const auto pt = checkAgreesWithPt(d, s, {"bpt", "lt", "vcm"});
    // Power: the same scene with the stripes' mean instead of the texture differs from PT.
    SceneDesc flat = d;
    flat.bsdfs[size_t(tex)] = makeDiffuse(StripeTexture().meanValue());
    s.integrator = "pt";
    s.spp = 4;
    CHECK(differingBlocks(pt, blockStats(flat, s, 10, 4), 0.01) > 0);
}

namespace {

std::string writeTemp(const std::string& name, const std::string& text) {
    static const lt::test::TempDir dir("lt_test_textured");  // per process, removed at exit
    return dir.write(name, text);
}


}  // namespace

TEST_CASE("loader: textures inline and referenced and their errors", "[texture][loader]") {
    const std::string tiles = std::string(LT_SOURCE_DIR) + "/scenes/textured/tiles.png";
    const std::string ok = writeTemp("tex.xml", R"(<scene version="3.0.0">
    <texture type="checkerboard" id="c"><rgb name="color0" value="0.9, 0.1, 0.1"/></texture>
    <shape type="rectangle"><bsdf type="diffuse"><ref name="reflectance" id="c"/></bsdf></shape>
    <shape type="rectangle"><bsdf type="twosided"><bsdf type="diffuse">
        <texture type="bitmap" name="reflectance"><string name="filename" value=")" + tiles + R"("/></texture>
    </bsdf></bsdf></shape>
    <shape type="rectangle"><bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>
    <emitter type="constant"/>
</scene>)");
    const SceneDesc d = loadScene(ok, {});
    REQUIRE(d.meshes.size() == 3);
    const Bxdf& checker = *d.bsdfs[size_t(d.meshes[0].bsdf)];
    const Bxdf& bitmap = *d.bsdfs[size_t(d.meshes[1].bsdf)];
    CHECK(checker.textured());
    CHECK(bitmap.textured());
    CHECK_FALSE(d.bsdfs[size_t(d.meshes[2].bsdf)]->textured());
    // The checkerboard's color0 at uv (0.25, 0.25) through the material's model there.
    const Frame f(Vec3(0, 0, 1));
    const Vec3 ng(0, 0, 1), w(0, 0, 1);
    const SurfaceBsdf at(&checker, f, ng, Vec2(0.25f, 0.25f));
    CHECK(at.eval(w, w, kRadianceContext).f.x == Approx(0.9f * kInvPi));
    const SurfaceBsdf other(&checker, f, ng, Vec2(0.75f, 0.25f));
    CHECK(other.eval(w, w, kRadianceContext).f.x == Approx(0.2f * kInvPi));  // color1's default
    // Errors name the file, the line and the parameter.
    const std::string missing = writeTemp("missing.xml", R"(<scene version="3.0.0">
    <shape type="rectangle"><bsdf type="diffuse">
        <texture type="bitmap" name="reflectance"><string name="filename" value="no-such.png"/></texture>
    </bsdf></shape>
</scene>)");
    std::string e = loadError(missing);
    INFO(e);
    CHECK(e.find("missing.xml:3") != std::string::npos);
    CHECK(e.find("filename") != std::string::npos);
    CHECK(e.find("no-such.png") != std::string::npos);
    const std::string notImage = writeTemp("notimage.png", "this is not a PNG");
    e = loadError(writeTemp("notimage.xml", R"(<scene version="3.0.0">
    <shape type="rectangle"><bsdf type="diffuse">
        <texture type="bitmap" name="reflectance"><string name="filename" value=")" + notImage + R"("/></texture>
    </bsdf></shape>
</scene>)"));
    CHECK(e.find("notimage.xml:3") != std::string::npos);
    CHECK(e.find("notimage.png") != std::string::npos);
    e = loadError(writeTemp("wrap.xml", R"(<scene version="3.0.0">
    <shape type="rectangle"><bsdf type="diffuse">
        <texture type="bitmap" name="reflectance"><string name="filename" value=")" + tiles + R"("/>
            <string name="wrap_mode" value="bogus"/></texture>
    </bsdf></shape>
</scene>)"));
    CHECK(e.find("wrap_mode") != std::string::npos);
    CHECK(e.find("wrap.xml:4") != std::string::npos);
    // A texture where Mitsuba 3 takes a value only (roughplastic's alpha): an error naming the parameter.
    e = loadError(writeTemp("alpha.xml", R"(<scene version="3.0.0">
    <shape type="rectangle"><bsdf type="roughplastic">
        <texture type="checkerboard" name="alpha"/>
    </bsdf></shape>
</scene>)"));
    CHECK(e.find("alpha.xml:3") != std::string::npos);
    CHECK(e.find("'alpha'") != std::string::npos);
    // A texture without a name, and a value given twice.
    CHECK(loadError(writeTemp("noname.xml", R"(<scene version="3.0.0">
    <shape type="rectangle"><bsdf type="diffuse"><texture type="checkerboard"/></bsdf></shape>
</scene>)")).find("needs a name") != std::string::npos);
    CHECK(loadError(writeTemp("twice.xml", R"(<scene version="3.0.0">
    <shape type="rectangle"><bsdf type="diffuse"><rgb name="reflectance" value="0.5"/>
        <texture type="checkerboard" name="reflectance"/></bsdf></shape>
</scene>)")).find("both as a value and as a texture") != std::string::npos);
    CHECK(loadError(writeTemp("type.xml", R"(<scene version="3.0.0">
    <shape type="rectangle"><bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance"/></bsdf></shape>
</scene>)")).find("a mesh_attribute texture reads a PLY mesh's attributes") != std::string::npos);
}

TEST_CASE("textured plastic: the model at a point is the plastic with the texture's reflectance there", "[texture][bsdf]") {
    // Bit for bit: the same coating, the base and Mitsuba's sampling weight from the texel.
    const auto tex = std::make_shared<UvTexture>();
    const Frame frame(Vec3(0, 0, 1));
    const Vec3 ng(0, 0, 1);
    const Vec3 wo = glm::normalize(Vec3(0.3f, -0.2f, 1.f)), wi = glm::normalize(Vec3(-0.5f, 0.1f, 0.8f));
    for (const bool rough : {false, true}) {
        const BxdfPtr b = makeTexturedPlastic(rough, MicrofacetType::GGX, 0.2f, 1.5f, tex, Color(0.9f), true);
        CHECK(b->textured());
        CHECK(b->flags() == (kReflection | kDiffuse | (rough ? kGlossy : kDelta)));
        for (const Vec2 uv : {Vec2(0.1f, 0.7f), Vec2(0.8f, 0.3f)}) {
            const BxdfPtr plain = rough ? makeRoughPlastic(MicrofacetType::GGX, 0.2f, 1.5f, tex->eval(uv), Color(0.9f), true)
                                        : makePlastic(1.5f, tex->eval(uv), Color(0.9f), true);
            const SurfaceBsdf t(b.get(), frame, ng, uv), p(plain.get(), frame, ng, uv);
            const BsdfEval et = t.eval(wo, wi, kRadianceContext), ep = p.eval(wo, wi, kRadianceContext);
            CHECK(et.f == ep.f);
            CHECK(et.pdfFwd.value == ep.pdfFwd.value);
            CHECK(et.pdfRev.value == ep.pdfRev.value);
            for (const float uLobe : {0.02f, 0.5f, 0.98f}) {
                BsdfSample st, sp;
                const bool okT = t.sample(wo, uLobe, Vec2(0.3f, 0.6f), kRadianceContext, st);
                const bool okP = p.sample(wo, uLobe, Vec2(0.3f, 0.6f), kRadianceContext, sp);
                REQUIRE(okT == okP);
                if (!okT) continue;
                CHECK(st.wi == sp.wi);
                CHECK(st.weight == sp.weight);
                CHECK(st.lobe == sp.lobe);
            }
        }
    }
    // The loader: a roughplastic's diffuse_reflectance as a texture.
    const std::string tiles = std::string(LT_SOURCE_DIR) + "/scenes/textured/tiles.png";
    const SceneDesc d = loadScene(writeTemp("plastic.xml", R"(<scene version="3.0.0">
    <shape type="rectangle"><bsdf type="roughplastic"><float name="alpha" value="0.3"/>
        <texture type="bitmap" name="diffuse_reflectance"><string name="filename" value=")" + tiles + R"("/></texture>
    </bsdf></shape>
    <emitter type="constant"/>
</scene>)"), {});
    CHECK(d.bsdfs[size_t(d.meshes[0].bsdf)]->textured());
    CHECK(d.bsdfs[size_t(d.meshes[0].bsdf)]->name() == "roughplastic");
}

TEST_CASE("the textured and environment-lit scenes render in PT and BPT and VCM", "[texture][scene]") {
    // Each scene at 16x12, 2 spp: the loader takes it (no warning), every pixel is finite and the
    // image is not black (the textures and the sky reach the camera in every integrator).
    for (const char* name : {"textured/textured-room.xml", "textured/textured-envmap.xml", "envmap/envmap-spheres.xml",
                             "cornell-box-plastic.xml"}) {
        const std::string path = std::string(LT_SOURCE_DIR) + "/scenes/" + name;
        SceneDesc d = loadScene(path, {{"res", "16"}, {"res_x", "16"}, {"res_y", "12"}});
        INFO(name);
        for (const std::string& w : d.warnings) CHECK(w.find("never uses") != std::string::npos);  // (the unused -D sizes)
        for (const char* integ : {"pt", "bpt", "vcm"}) {
            RenderSettings s;
            s.integrator = integ;
            s.spp = 2;
            s.maxDepth = 6;
            const Image img = renderDesc(d, s);
            INFO(integ);
            bool finite = true;
            for (const Color& c : img.pixels) finite = finite && isFinite(c);
            CHECK(finite);
            CHECK(imageMean(img) > 1e-3);
        }
    }
}
