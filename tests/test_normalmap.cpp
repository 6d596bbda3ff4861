// Mitsuba 3's normalmap and bumpmap adapters (bsdf/normal_perturbation.h): the perturbed frames,
// the hits' dp/du and frames (core/scene.cpp), the texture gradient, every integrator agreeing
// under a perturbed frame, and the loader's errors.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include "bsdf/normal_perturbation.h"
#include "bsdf/surface_bsdf.h"
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

// A normal map whose colour encodes the local normal (sin a, 0, cos a), a alternating between
// +angle and -angle in four stripes along u: a strong, visible perturbation.
class StripeNormals final : public Texture {
public:
    explicit StripeNormals(float angleDeg) : a_(angleDeg * kPi / 180.f) {}
    Color eval(const Vec2& uv) const override {
        const float a = int(std::floor(uv.x * 4.f)) % 2 == 0 ? a_ : -a_;
        return 0.5f * (Vec3(std::sin(a), 0.f, std::cos(a)) + Vec3(1.f));
    }
    Color maxValue() const override { return Color(1.f); }
    Color meanValue() const override { return Color(0.5f); }
    std::string name() const override { return "stripe-normals"; }

private:
    float a_;
};

// A height field with a constant gradient (a, b) in uv.
class Ramp final : public Texture {
public:
    Ramp(float a, float b) : a_(a), b_(b) {}
    Color eval(const Vec2& uv) const override { return Color(a_ * uv.x + b_ * uv.y); }
    Color maxValue() const override { return Color(1.f); }
    Color meanValue() const override { return Color(0.5f); }
    std::string name() const override { return "ramp"; }
    Vec2 evalGrad1(const Vec2&) const override { return Vec2(a_, b_); }

private:
    float a_, b_;
};

const NormalPerturbation& perturbation(const BxdfPtr& b) {
    const auto* p = dynamic_cast<const NormalPerturbation*>(b.get());
    REQUIRE(p);
    return *p;
}

// A tangent space with a non-trivial unperturbed frame: n = +y, dp/du along +z (tilted out of the
// tangent plane, which the Gram-Schmidt step removes), dp/dv along +x.
TangentSpace someTangentSpace() {
    TangentSpace ts;
    ts.ng = Vec3(0, 1, 0);
    ts.dpdu = Vec3(0.f, 0.3f, 2.f);
    ts.dpdv = Vec3(1.5f, 0.f, 0.f);
    ts.shading = tangentFrame(ts.ng, ts.dpdu);
    ts.uv = Vec2(0.3f, 0.6f);
    ts.wo = ts.ng;
    return ts;
}

void checkOrthonormal(const Frame& f) {
    CHECK(glm::length(f.n) == Approx(1.f).margin(1e-5));
    CHECK(glm::length(f.s) == Approx(1.f).margin(1e-5));
    CHECK(glm::dot(f.s, f.n) == Approx(0.f).margin(1e-5));
    CHECK(glm::dot(glm::cross(f.n, f.s), f.t) == Approx(1.f).margin(1e-5));  // right-handed
}

}  // namespace

TEST_CASE("the unperturbed frame follows dp/du", "[normalmap]") {
    const TangentSpace ts = someTangentSpace();
    CHECK(ts.shading.n == Vec3(0, 1, 0));
    CHECK(ts.shading.s.z == Approx(1.f));
    CHECK(ts.shading.s.y == Approx(0.f).margin(1e-6));
    checkOrthonormal(ts.shading);
    // dp/du zero or along n: any frame around n.
    CHECK(tangentFrame(Vec3(0, 1, 0), Vec3(0.f)).n == Vec3(0, 1, 0));
    CHECK(tangentFrame(Vec3(0, 1, 0), Vec3(0, 2, 0)).n == Vec3(0, 1, 0));
}

TEST_CASE("normalmap: identity and tilted maps give the expected frame", "[normalmap]") {
    const TangentSpace ts = someTangentSpace();
    // (0.5, 0.5, 1): the unperturbed frame itself (its tangent too).
    const BxdfPtr id = makeNormalMap(makeConstantTexture(Color(0.5f, 0.5f, 1.f)), makeDiffuse(Color(0.5f)));
    const Frame f0 = perturbation(id).frame(ts);
    for (int k = 0; k < 3; ++k) {
        CHECK(f0.n[k] == Approx(ts.shading.n[k]).margin(1e-6));
        CHECK(f0.s[k] == Approx(ts.shading.s[k]).margin(1e-6));
        CHECK(f0.t[k] == Approx(ts.shading.t[k]).margin(1e-6));
    }
    // Tilted by 30 degrees towards the tangent (local x = dp/du's direction) and towards local y.
    const float a = 30.f * kPi / 180.f;
    for (const Vec3 m : {Vec3(std::sin(a), 0.f, std::cos(a)), Vec3(0.f, std::sin(a), std::cos(a))}) {
        const BxdfPtr b = makeNormalMap(makeConstantTexture(0.5f * (m + Vec3(1.f))), makeDiffuse(Color(0.5f)));
        const Frame f = perturbation(b).frame(ts);
        const Vec3 want = ts.shading.toWorld(m);
        for (int k = 0; k < 3; ++k) CHECK(f.n[k] == Approx(want[k]).margin(1e-5));
        checkOrthonormal(f);
        // s' is the unperturbed tangent projected onto the new tangent plane.
        const Vec3 sp = glm::normalize(ts.shading.s - f.n * glm::dot(f.n, ts.shading.s));
        for (int k = 0; k < 3; ++k) CHECK(f.s[k] == Approx(sp[k]).margin(1e-5));
    }
    // flip_invalid_normals: an arrival direction above the surface but below the tilted normal's
    // plane mirrors the tilt (Mitsuba: m -> (-m_x, -m_y, m_z)); without the flip it stays.
    const Vec3 m(std::sin(a), 0.f, std::cos(a));
    TangentSpace grazing = ts;
    grazing.wo = ts.shading.toWorld(glm::normalize(Vec3(-1.f, 0.f, 0.2f)));  // 11 degrees above, against the tilt
    const auto tex = makeConstantTexture(0.5f * (m + Vec3(1.f)));
    const Frame flipped = perturbation(makeNormalMap(tex, makeDiffuse(Color(0.5f)), true)).frame(grazing);
    const Frame kept = perturbation(makeNormalMap(tex, makeDiffuse(Color(0.5f)), false)).frame(grazing);
    const Vec3 mirrored = ts.shading.toWorld(Vec3(-m.x, -m.y, m.z)), plain = ts.shading.toWorld(m);
    for (int k = 0; k < 3; ++k) {
        CHECK(flipped.n[k] == Approx(mirrored[k]).margin(1e-5));
        CHECK(kept.n[k] == Approx(plain[k]).margin(1e-5));
    }
    // A texel (0.5, 0.5, 0.5) has no normal: the frame stays.
    const BxdfPtr zero = makeNormalMap(makeConstantTexture(Color(0.5f)), makeDiffuse(Color(0.5f)));
    CHECK(perturbation(zero).frame(ts).n == ts.shading.n);
}

TEST_CASE("bumpmap: a constant height is the nested bsdf and a ramp tilts as the analytic normal", "[normalmap]") {
    const TangentSpace ts = someTangentSpace();
    const BxdfPtr flat = makeBumpMap(makeConstantTexture(Color(0.3f)), 5.f, makeDiffuse(Color(0.5f)));
    const Frame f0 = perturbation(flat).frame(ts);
    for (int k = 0; k < 3; ++k) {
        CHECK(f0.n[k] == Approx(ts.shading.n[k]).margin(1e-6));
        CHECK(f0.s[k] == Approx(ts.shading.s[k]).margin(1e-6));
    }
    // A flat patch with orthogonal dp/du = (L, 0, 0), dp/dv = (0, L, 0), n = +z, height
    // h = a u + b v scaled by `scale`: the displaced tangents (L, 0, s a) and (0, L, s b) have the
    // normal (-s a L, -s b L, L^2) / |.|.
    TangentSpace q;
    q.ng = Vec3(0, 0, 1);
    q.dpdu = Vec3(2, 0, 0);
    q.dpdv = Vec3(0, 2, 0);
    q.shading = tangentFrame(q.ng, q.dpdu);
    q.uv = Vec2(0.5f);
    q.wo = q.ng;
    const float a = 0.7f, b = -0.4f, scale = 1.5f, L = 2.f;
    const Frame f = perturbation(makeBumpMap(std::make_shared<Ramp>(a, b), scale, makeDiffuse(Color(0.5f)))).frame(q);
    const Vec3 want = glm::normalize(Vec3(-scale * a * L, -scale * b * L, L * L));
    for (int k = 0; k < 3; ++k) CHECK(f.n[k] == Approx(want[k]).margin(1e-5));
    checkOrthonormal(f);
    // The bitmap's gradient of a linear ramp: bilinear interpolation is exact on it, so
    // d/du = (texel step) x (width) inside the image (to_uv scaling u by 2 doubles it).
    Image img;
    img.width = 8;
    img.height = 4;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) img.pixels.push_back(Color(0.1f * float(x) + 0.05f * float(y)));
    const TexturePtr bmp = makeBitmap(img, TextureFilter::Bilinear, TextureWrap::Clamp, glm::mat3(1.f), "ramp");
    const Vec2 g = bmp->evalGrad1(Vec2(0.4f, 0.5f));
    CHECK(g.x == Approx(0.1f * 8.f));
    CHECK(g.y == Approx(0.05f * 4.f));
    glm::mat3 twice(1.f);
    twice[0][0] = 2.f;
    const Vec2 g2 = makeBitmap(img, TextureFilter::Bilinear, TextureWrap::Clamp, twice, "ramp")->evalGrad1(Vec2(0.2f, 0.5f));
    CHECK(g2.x == Approx(2.f * 0.1f * 8.f));
    CHECK(makeBitmap(img, TextureFilter::Nearest, TextureWrap::Clamp, glm::mat3(1.f), "ramp")->evalGrad1(Vec2(0.4f)) ==
          Vec2(0.f));
}

TEST_CASE("hits on a normal-mapped mesh and sphere take the perturbed frame", "[normalmap][scene]") {
    const float a = 25.f * kPi / 180.f;
    const Vec3 m(std::sin(a), 0.f, std::cos(a));
    SceneDesc d;
    d.bsdfs.push_back(makeNormalMap(makeConstantTexture(0.5f * (m + Vec3(1.f))), makeDiffuse(Color(0.5f))));
    // A quad in z = 0 facing +z whose u runs along +y: the tilt goes towards +y.
    MeshDesc q = quad(Vec3(-1, -1, 0), Vec3(2, 0, 0), Vec3(0, 2, 0), 0);
    q.uvs = {{0, 0}, {0, 1}, {1, 1}, {1, 0}};
    d.meshes.push_back(q);
    SphereDesc s;
    s.center = Vec3(0, 0, 10);
    s.radius = 2.f;
    s.bsdf = 0;
    d.spheres.push_back(s);
    EmitterDesc e;
    e.type = EmitterType::Constant;
    d.emitters.push_back(e);
    const Scene scene(d);
    SurfacePoint h;
    REQUIRE(scene.intersect(Ray{Vec3(0.2f, 0.1f, 1.f), Vec3(0, 0, -1)}, h));
    CHECK(h.shading.n.x == Approx(0.f).margin(1e-5));
    CHECK(h.shading.n.y == Approx(std::sin(a)).margin(1e-5));
    CHECK(h.shading.n.z == Approx(std::cos(a)).margin(1e-5));
    checkOrthonormal(h.shading);
    // Sphere at its equator point +x: dp/du along +y (phi grows), so the tilt goes towards +y.
    SurfaceHit hs;
    REQUIRE(scene.intersect(Ray{s.center + Vec3(5, 0, 0), Vec3(-1, 0, 0)}, hs));
    CHECK(hs.shading.n.x == Approx(std::cos(a)).margin(1e-4));
    CHECK(hs.shading.n.y == Approx(std::sin(a)).margin(1e-4));
    CHECK(hs.shading.n.z == Approx(0.f).margin(1e-4));
    // The walk sees the nested model (and the terminator flag of the adapter).
    const SurfaceBsdf sb(h.bxdf, h.shading, h.ng, h.uv);
    CHECK(sb.bxdf().lambert() != nullptr);
    CHECK(h.bxdf->shadowTerminator());
}

TEST_CASE("the terminator term is Estevez et al.'s and 1 without a perturbation", "[normalmap]") {
    CHECK(shadowTerminatorTerm(1.f, 0.3f) == 1.f);
    // n' at 45 degrees: alpha^2 = 1/8; a direction at 60 degrees: tan^2 = 3.
    const float c45 = std::sqrt(0.5f);
    CHECK(shadowTerminatorTerm(c45, 0.5f) == Approx(2.f / (1.f + std::sqrt(1.f + 3.f / 8.f))));
    CHECK(shadowTerminatorTerm(c45, 0.f) == 0.f);
}

namespace {

// The Cornell box with the floor, back wall, panel and sphere normal-mapped over a diffuse base.
SceneDesc normalMappedBox(const TexturePtr& map, bool flip, bool shadowing) {
    SceneDesc d = cornellBox(32, makeNormalMap(map, makeDiffuse(Color(0.6f)), flip, shadowing));
    d.bsdfs[0] = makeNormalMap(map, makeDiffuse(Color(0.7f)), flip, shadowing);  // floor, ceiling, back
    for (MeshDesc& m : d.meshes) m.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    d.integrator.maxDepth = 4;
    return d;
}

}  // namespace

TEST_CASE("an identity normal map renders as the nested bsdf alone", "[normalmap][statistical]") {
    // 32x32 in 4x4 blocks, K = 10 PT renders each, Welch's t per block at family-wise significance
    // 1% (Sidak over the 16 blocks): the identity map only turns the tangent about n (Lambert
    // does not see it) and its terminator term is 1. Power: the striped map differs.
    RenderSettings s;
    s.spp = 4;
    s.maxDepth = 4;
    s.integrator = "pt";
    SceneDesc plain = cornellBox(32, makeDiffuse(Color(0.6f)));
    plain.bsdfs[0] = makeDiffuse(Color(0.7f));
    plain.integrator.maxDepth = 4;
    const auto ref = blockStats(plain, s, 10, 4);
    double worst;
    const int bad = differingBlocks(ref, blockStats(normalMappedBox(makeConstantTexture(Color(0.5f, 0.5f, 1.f)), true, true), s, 10, 4),
                                    0.01, &worst);
    INFO(bad << " blocks differ, worst |t|/crit " << worst);
    CHECK(bad == 0);
    CHECK(differingBlocks(ref, blockStats(normalMappedBox(std::make_shared<StripeNormals>(25.f), true, true), s, 10, 4), 0.01) > 0);
}

TEST_CASE("PT and BPT and LT and VCM agree on a normal-mapped diffuse scene", "[normalmap][bpt][statistical]") {
    // Stripes of +-50 degree tilts on every wall, the panel and the sphere (enough tilt that the
    // terminator term applied to the camera-side direction in Importance mode fails this test),
    // with the terminator term (on the light-side direction in both transport modes) and without
    // the flip
    // (which Mitsuba bases on the direction each walk arrives from: a camera and a light walk
    // through one vertex would then perturb it differently). 32x32 in 4x4 blocks, K = 10 renders
    // per integrator, Welch's t per block against PT at family-wise significance 1% per
    // comparison (Sidak over the 16 blocks).
    const SceneDesc d = normalMappedBox(std::make_shared<StripeNormals>(50.f), false, true);
    RenderSettings s;
    s.spp = 4;
    s.maxDepth = 4;
    const auto pt = checkAgreesWithPt(d, s, {"bpt", "lt", "vcm"});
    // Power: light tracing without the shading-normal adjoint correction (which the perturbed
    // normals make matter on every wall) differs from PT.
    s.integrator = "lt";
    s.spp = 8;
    s.radius = 0.f;
    gTestDisableAdjointCorrection = true;
    const auto wrong = blockStats(d, s, 10, 4);
    gTestDisableAdjointCorrection = false;
    CHECK(differingBlocks(pt, wrong, 0.01) > 0);
}

namespace {

std::string writeTemp(const std::string& name, const std::string& text) {
    static const lt::test::TempDir dir("lt_test_normalmap");  // per process, removed at exit
    return dir.write(name, text);
}

std::string loadError(const std::string& name, const std::string& bsdf) {
    const std::string path = writeTemp(name, "<scene version=\"3.0.0\">\n<shape type=\"rectangle\">\n" + bsdf +
                                                 "\n</shape>\n<emitter type=\"constant\"/>\n</scene>");
    try {
        loadScene(path, {});
    } catch (const SceneError& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST_CASE("loader: normalmap and bumpmap and their errors", "[normalmap][loader]") {
    const std::string ok = writeTemp("ok.xml", R"(<scene version="3.0.0">
    <shape type="rectangle"><bsdf type="normalmap">
        <texture name="normalmap" type="rawconstant"><vector name="value" value="0.5, 0.5, 1"/></texture>
        <boolean name="flip_invalid_normals" value="false"/>
        <bsdf type="roughconductor"/>
    </bsdf></shape>
    <shape type="rectangle"><bsdf type="bumpmap">
        <float name="scale" value="0.1"/>
        <texture name="anything" type="checkerboard"/>
        <bsdf type="diffuse"/>
        <boolean name="use_shadowing_function" value="false"/>
    </bsdf></shape>
    <emitter type="constant"/>
</scene>)");
    const SceneDesc d = loadScene(ok, {});
    REQUIRE(d.meshes.size() == 2);
    const auto& nm = perturbation(d.bsdfs[size_t(d.meshes[0].bsdf)]);
    CHECK_FALSE(nm.flipInvalid());
    CHECK(nm.shadowTerminator());
    CHECK(nm.nested()->name().find("conductor") != std::string::npos);
    const auto& bm = perturbation(d.bsdfs[size_t(d.meshes[1].bsdf)]);
    CHECK(bm.flipInvalid());
    CHECK_FALSE(bm.shadowTerminator());
    // Errors name the file, the line and the parameter or element.
    std::string e = loadError("notex.xml", R"(<bsdf type="normalmap"><bsdf type="diffuse"/></bsdf>)");
    INFO(e);
    CHECK(e.find("notex.xml:3") != std::string::npos);
    CHECK(e.find("'normalmap'") != std::string::npos);
    e = loadError("nobsdf.xml", R"(<bsdf type="bumpmap"><texture type="checkerboard" name="h"/></bsdf>)");
    CHECK(e.find("nobsdf.xml:3") != std::string::npos);
    CHECK(e.find("nested <bsdf>") != std::string::npos);
    e = loadError("two.xml", R"(<bsdf type="bumpmap"><texture type="checkerboard" name="h"/>
        <bsdf type="diffuse"/>
        <bsdf type="diffuse"/></bsdf>)");
    CHECK(e.find("two.xml:5") != std::string::npos);
    CHECK(e.find("one nested bsdf") != std::string::npos);
    e = loadError("scale.xml", R"(<bsdf type="bumpmap"><texture type="checkerboard" name="h"/>
        <string name="scale" value="big"/><bsdf type="diffuse"/></bsdf>)");
    CHECK(e.find("scale.xml:4") != std::string::npos);
    CHECK(e.find("scale") != std::string::npos);
    e = loadError("unknown.xml", R"(<bsdf type="normalmap"><bsdf type="diffuse"/>
        <texture name="normalmap" type="rawconstant"><vector name="value" value="0.5, 0.5, 1"/></texture>
        <float name="strength" value="2"/></bsdf>)");
    CHECK(e.find("unknown.xml:5") != std::string::npos);
    CHECK(e.find("strength") != std::string::npos);
    e = loadError("nested.xml", R"(<bsdf type="twosided"><bsdf type="normalmap"><bsdf type="diffuse"/>
        <texture name="normalmap" type="rawconstant"><vector name="value" value="0.5, 0.5, 1"/></texture></bsdf></bsdf>)");
    CHECK(e.find("nested.xml:3") != std::string::npos);
    CHECK(e.find("twosided") != std::string::npos);
    e = loadError("raw.xml", R"(<bsdf type="normalmap"><bsdf type="diffuse"/>
        <texture name="normalmap" type="rawconstant"><rgb name="value" value="0.5, 0.5, 1"/></texture></bsdf>)");
    CHECK(e.find("raw.xml:4") != std::string::npos);
    CHECK(e.find("value") != std::string::npos);
}
