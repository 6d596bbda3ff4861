// Mitsuba 3's thinlens and orthographic sensors (core/camera.h): ray and raster round trips, the
// importance's normalisation, the pinhole as the lens's limit, PT = BPT = VCM = LT with each, and
// the loader's checks.
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include "core/camera.h"
#include "core/loader.h"
#include "core/rng.h"
#include "integrators/integrator.h"
#include "process.h"
#include "render_compare.h"
#include "scene_builders.h"
#include "stats.h"

using namespace lt;
using namespace lt::test;

namespace {

CameraDesc thinLensDesc(float radius, float focus, int w = 40, int h = 30) {
    CameraDesc c = lookAt(Vec3(0.3f, 0.2f, 3.8f), Vec3(0.f), Vec3(0, 1, 0), 40.f, w, h);
    c.type = SensorType::ThinLens;
    c.apertureRadius = radius;
    c.focusDistance = focus;
    return c;
}

// Mitsuba's <scale x=sx y=sy/> then <lookat>: the film spans sx x (sy / aspect) half-extents.
CameraDesc orthoDesc(float sx, float sy, int w = 40, int h = 30) {
    CameraDesc c = lookAt(Vec3(0.1f, -0.1f, 3.8f), Vec3(0.f), Vec3(0, 1, 0), 40.f, w, h);
    c.toWorld = c.toWorld * glm::scale(Mat4(1.f), Vec3(sx, sy, 1.f));
    c.type = SensorType::Orthographic;
    c.nearClip = 0.5f;
    return c;
}

Vec3 uniformSphere(const Vec2& u) {
    const float z = 1.f - 2.f * u.x, r = std::sqrt(std::max(0.f, 1.f - z * z)), phi = 2.f * kPi * u.y;
    return Vec3(r * std::cos(phi), r * std::sin(phi), z);
}

}  // namespace

TEST_CASE("sensors: thin lens rays and raster positions round-trip", "[sensors]") {
    for (bool crop : {false, true}) {
        CameraDesc d = thinLensDesc(0.2f, 3.1f);
        if (crop) d.fullWidth = 60, d.fullHeight = 50, d.cropX = 7, d.cropY = 11;
        Camera cam(d);
        Rng rng(7, 1);
        for (int i = 0; i < 2000; ++i) {
            const Vec2 raster(rng.uniform() * 40.f, rng.uniform() * 30.f);
            SolidAnglePdf pdf;
            Vec3 lens;
            const Ray r = cam.generateRay(raster, rng.uniform2(), pdf, lens);
            // the lens point lies on the aperture disk, in the plane through the camera facing forward
            CHECK(std::abs(glm::dot(lens - cam.position(), cam.forward())) < 1e-5f);
            CHECK(glm::length(lens - cam.position()) <= 0.2f * 1.0001f);
            const Vec3 p = lens + r.d * (0.5f + 6.f * rng.uniform());
            const auto back = cam.rasterPosition(lens, p);
            REQUIRE(back);
            CHECK(back->x == Approx(raster.x).margin(2e-3));
            CHECK(back->y == Approx(raster.y).margin(2e-3));
            CHECK(cam.directionPdf(lens, r.d).value == Approx(pdf.value).epsilon(1e-4));
            // the throughput We cos / (p_pos p_dir) is 1: importance() is We over p_pos
            CHECK(cam.importance(lens, r.d) * glm::dot(r.d, cam.forward()) / pdf.value == Approx(1.f).epsilon(1e-4));
            // the ray starts on the near plane
            CHECK(glm::dot(r.o + r.d * r.tMin - cam.position(), cam.forward()) == Approx(d.nearClip).epsilon(1e-3));
        }
        // the point in focus: every lens point sees it at the same raster position
        SolidAnglePdf pdf;
        Vec3 lens;
        const Ray r = cam.generateRay(Vec2(12.5f, 20.25f), Vec2(0.5f), pdf, lens);
        const Vec3 focal = r.o + r.d * (3.1f / glm::dot(r.d, cam.forward()));
        for (int i = 0; i < 50; ++i) {
            const Vec3 c = cam.connectionPoint(focal, rng.uniform2());
            const auto back = cam.rasterPosition(c, focal);
            REQUIRE(back);
            CHECK(back->x == Approx(12.5f).margin(2e-3));
            CHECK(back->y == Approx(20.25f).margin(2e-3));
        }
    }
}

TEST_CASE("sensors: orthographic rays and raster positions round-trip with Mitsuba's film mapping", "[sensors]") {
    for (bool crop : {false, true}) {
        CameraDesc d = orthoDesc(1.5f, 0.8f);
        if (crop) d.fullWidth = 60, d.fullHeight = 50, d.cropX = 7, d.cropY = 11;
        Camera cam(d);
        Rng rng(3, 2);
        for (int i = 0; i < 2000; ++i) {
            const Vec2 raster(rng.uniform() * 40.f, rng.uniform() * 30.f);
            SolidAnglePdf pdf;
            Vec3 o;
            const Ray r = cam.generateRay(raster, rng.uniform2(), pdf, o);
            CHECK(glm::length(r.d - cam.forward()) < 1e-6f);
            CHECK(glm::length(r.o - o) < 1e-6f);
            const Vec3 p = o + r.d * (0.1f + 5.f * rng.uniform());
            const auto back = cam.rasterPosition(Vec3(0.f), p);
            REQUIRE(back);
            CHECK(back->x == Approx(raster.x).margin(1e-3));
            CHECK(back->y == Approx(raster.y).margin(1e-3));
            CHECK(glm::length(cam.connectionPoint(p, Vec2(0.f)) - o) < 1e-4f);
            CHECK(!cam.rasterPosition(Vec3(0.f), o - r.d * 0.01f));  // behind the near plane
        }
        // Mitsuba's axes: x in [-1, 1] (times the scale) spans the full film's width, image left =
        // camera +X; y in [-1/aspect, 1/aspect] its height, image top = +Y; rays leave the near plane.
        const Camera full(orthoDesc(1.5f, 0.8f, 60, 50));
        const Vec3 left = glm::normalize(Vec3(d.toWorld[0])), up = glm::normalize(Vec3(d.toWorld[1]));
        const Vec3 centre = Vec3(d.toWorld[3]) + full.forward() * d.nearClip;
        SolidAnglePdf pdf;
        Vec3 o;
        full.generateRay(Vec2(0.f, 0.f), Vec2(0.5f), pdf, o);
        CHECK(glm::dot(o - centre, left) == Approx(1.5f).epsilon(1e-5));
        CHECK(glm::dot(o - centre, up) == Approx(0.8f * 50.f / 60.f).epsilon(1e-5));
        CHECK(glm::dot(o - centre, full.forward()) == Approx(0.f).margin(1e-5));
    }
}

TEST_CASE("sensors: the importance integrates to one over the image", "[sensors]") {
    // Monte Carlo over the sphere of directions (thin lens, fixed lens points; the pinhole for
    // reference), N = 4M uniform directions: the estimate of int We cos dw must be 1 within 5
    // standard errors of the estimate (two-sided level ~6e-7; the errors are measured, not assumed).
    auto checkIntegral = [](const Camera& cam, const Vec3& c) {
        Rng rng(11, 5);
        const int n = 4'000'000;
        double sum = 0, sum2 = 0, sumPdf = 0;
        for (int i = 0; i < n; ++i) {
            const Vec3 w = uniformSphere(rng.uniform2());
            const double f = double(cam.importance(c, w)) * std::max(0.f, glm::dot(w, cam.forward())) * 4.0 * kPi;
            sum += f, sum2 += f * f;
            sumPdf += double(cam.directionPdf(c, w).value) * 4.0 * kPi;
        }
        const double mean = sum / n, se = std::sqrt((sum2 / n - mean * mean) / n);
        INFO("We integral " << mean << " +- " << se);
        CHECK(std::abs(mean - 1.0) < 5.0 * se);
        CHECK(sumPdf / n == Approx(1.0).epsilon(0.02));  // (the density over the same directions: weaker)
    };
    checkIntegral(Camera(lookAt(Vec3(0.f), Vec3(0, 0, 1), Vec3(0, 1, 0), 40.f, 40, 30)), Vec3(0.f));
    const Camera lens(thinLensDesc(0.3f, 2.f));
    Rng rng(1, 1);
    for (int i = 0; i < 3; ++i) checkIntegral(lens, lens.connectionPoint(Vec3(0.f), rng.uniform2()));
    CameraDesc cropped = thinLensDesc(0.3f, 2.f);
    cropped.fullWidth = 60, cropped.fullHeight = 50, cropped.cropX = 7, cropped.cropY = 11;
    const Camera lensCrop(cropped);
    checkIntegral(lensCrop, lensCrop.connectionPoint(Vec3(0.f), Vec2(0.9f, 0.3f)));

    // Orthographic: W = 1 / A_film over the film's projection, so int W dA over a plane
    // perpendicular to the rays is 1: points uniform on a 6 x 6 square of that plane (larger than
    // the film), an estimate with 5 standard errors as above. A sheared to_world too.
    for (bool shear : {false, true}) {
        CameraDesc d = orthoDesc(1.3f, 0.9f);
        if (shear) d.toWorld = d.toWorld * Mat4(Vec4(1, 0, 0, 0), Vec4(0.3f, 1, 0, 0), Vec4(0.2f, -0.1f, 1, 0), Vec4(0, 0, 0, 1));
        const Camera cam(d);
        const Vec3 f = cam.forward();
        const Vec3 a = glm::normalize(glm::cross(f, Vec3(0.3f, 1.f, 0.1f))), b = glm::cross(f, a);
        const Vec3 centre = cam.connectionPoint(Vec3(0.f), Vec2(0.f)) + f * 2.f;
        Rng r2(5, 9);
        const int n = 1'000'000;
        double sum = 0, sum2 = 0;
        for (int i = 0; i < n; ++i) {
            const Vec2 u = r2.uniform2();
            const Vec3 p = centre + a * (6.f * u.x - 3.f) + b * (6.f * u.y - 3.f);
            const double v = cam.rasterPosition(Vec3(0.f), p) ? double(cam.filmDensity()) * 36.0 : 0.0;
            sum += v, sum2 += v * v;
        }
        const double mean = sum / n, se = std::sqrt((sum2 / n - mean * mean) / n);
        INFO("shear " << shear << ": W integral " << mean << " +- " << se);
        CHECK(std::abs(mean - 1.0) < 5.0 * se);
    }
}

TEST_CASE("sensors: a wall of known radiance measures that radiance in LT and PT", "[sensors][statistical]") {
    // An emitter of radiance L = 2 filling the view (a one-sided area light facing the camera):
    // every pixel's value is L. PT sees it exactly; light tracing splats the emitter's points
    // through We, so its image mean is L only if the importance is normalised over the image (the
    // sum over pixels of the splatted flux is the film's measurement). The LT mean must be L
    // within 5 standard errors of the pixel mean (pixels' values are independent: each light path
    // lands in one pixel; two-sided level ~6e-7).
    for (SensorType type : {SensorType::ThinLens, SensorType::Orthographic}) {
        SceneDesc d;
        d.bsdfs.push_back(makeDiffuse(Color(0.f)));
        EmitterDesc e;
        e.type = EmitterType::Area;
        e.value = Color(2.f);
        d.emitters.push_back(e);
        d.meshes.push_back(quad(Vec3(-4, -4, -1), Vec3(8, 0, 0), Vec3(0, 8, 0), 0, 0));  // normal +z, beyond the view
        d.camera = type == SensorType::ThinLens ? thinLensDesc(0.3f, 2.5f, 24, 16) : orthoDesc(1.3f, 1.f, 24, 16);
        d.camera.toWorld = glm::translate(Mat4(1.f), Vec3(0, 0, 3)) * glm::rotate(Mat4(1.f), kPi, Vec3(0, 1, 0)) *
                           (type == SensorType::Orthographic ? glm::scale(Mat4(1.f), Vec3(1.3f, 1.f, 1.f)) : Mat4(1.f));
        d.camera.filter = FilterType::Box;
        RenderSettings s;
        s.maxDepth = 1;
        s.spp = 2048;
        s.integrator = "lt";
        s.seed = 3;
        const Image lt = renderDesc(d, s);
        double sum = 0, sum2 = 0;
        for (const Color& c : lt.pixels) sum += c.x, sum2 += double(c.x) * c.x;
        const double n = double(lt.pixels.size()), mean = sum / n, se = std::sqrt((sum2 / n - mean * mean) / n);
        INFO("sensor " << int(type) << ": LT mean " << mean << " +- " << se);
        CHECK(std::abs(mean - 2.0) < 5.0 * se);
        CHECK(se < 0.01);  // (power: a 2% error in We is 4 standard errors)
        s.integrator = "pt";
        s.spp = 4;
        CHECK(imageMean(renderDesc(d, s)) == Approx(2.0).epsilon(1e-5));
    }
}

TEST_CASE("sensors: PT BPT VCM LT and PPM agree with a thin lens and an orthographic camera", "[sensors][statistical]") {
    // The diffuse Cornell box (tests/scene_builders.h) through each sensor (the pinhole too, as the
    // control): 32x32 images in 4x4 blocks, K = 10 seeds per integrator, Welch t per block against
    // PT, family-wise significance 1% per sensor (Sidak over 16 blocks x 3 comparisons), as
    // tests/test_bidirectional.cpp. A wrong camera density in the MIS (the orthographic first hit's
    // |cos| / A_film left out) moves BPT and VCM by over 20 critical values; a lens importance
    // without its last cosine moves LT past the critical value.
    const int res = 32, k = 10, blocks = 4, tests = blocks * blocks * 3;
    for (SensorType type : {SensorType::Perspective, SensorType::ThinLens, SensorType::Orthographic}) {
        SceneDesc d = cornellBox(res, makeDiffuse(Color(0.5f)));
        const CameraDesc pin = d.camera;
        d.camera.type = type;
        if (type == SensorType::ThinLens) {
            d.camera.apertureRadius = 0.25f;  // a strong blur: the box's edges are out of focus
            d.camera.focusDistance = 3.0f;
        } else {
            d.camera.toWorld = pin.toWorld * glm::scale(Mat4(1.f), Vec3(0.95f, 0.95f, 1.f));
            d.camera.nearClip = 0.1f;
        }
        d.integrator.maxDepth = 4;
        RenderSettings s;
        s.spp = 4;
        s.maxDepth = 4;
        s.integrator = "pt";
        const auto pt = blockStats(d, s, k, blocks);
        // differingBlocks applies Sidak over the 16 blocks: the family level over 16 of the 48 tests
        const double alpha16 = 1.0 - std::pow(1.0 - 0.01, double(blocks * blocks) / tests);
        for (std::string integ : {"bpt", "lt", "vcm"}) {
            s.integrator = integ;
            s.spp = integ == "lt" ? 8 : 4;  // (vcm: the default radius, merges weighted in)
            double worst = 0;
            const int bad = differingBlocks(blockStats(d, s, k, blocks, 2000), pt, alpha16, &worst);
            INFO("sensor " << int(type) << ": " << integ << " vs pt, worst |t| / critical " << worst);
            CHECK(bad == 0);
        }
        // PPM (merging only, consistent, not unbiased): its image mean within 5% of PT's. A
        // radius of 1.5% of the box's size gives about 0.4 merges per camera vertex (32 passes of
        // 1024 light paths): the mean's noise is about 1%, and the blur's loss near the box's
        // edges about 2%. (A wrong camera density or importance moves LT's and BPT's images,
        // tested above; PPM's camera side is the camera walk's throughput.)
        s.integrator = "ppm";
        s.spp = 32;
        s.radius = 0.03f;
        s.seed = 1;
        const double ppm = imageMean(renderDesc(d, s));
        s.integrator = "pt";
        s.spp = 32;
        const double ref = imageMean(renderDesc(d, s));
        INFO("sensor " << int(type) << ": ppm " << ppm << " pt " << ref);
        CHECK(std::abs(ppm / ref - 1.0) < 0.05);
    }
}

TEST_CASE("sensors: a thin lens of vanishing aperture is the pinhole", "[sensors][statistical]") {
    CameraDesc pin = lookAt(Vec3(0.3f, 0.2f, 3.8f), Vec3(0.f), Vec3(0, 1, 0), 40.f, 40, 30);
    CameraDesc lens = pin;
    lens.type = SensorType::ThinLens;
    lens.apertureRadius = 1e-6f;
    lens.focusDistance = 2.f;
    const Camera a(pin), b(lens);
    Rng rng(2, 2);
    for (int i = 0; i < 1000; ++i) {
        const Vec2 raster(rng.uniform() * 40.f, rng.uniform() * 30.f);
        SolidAnglePdf pa, pb;
        Vec3 oa, ob;
        const Ray ra = a.generateRay(raster, Vec2(0.5f), pa, oa);
        const Ray rb = b.generateRay(raster, rng.uniform2(), pb, ob);
        CHECK(glm::length(ra.d - rb.d) < 2e-6f);
        CHECK(glm::length(oa - ob) < 2e-6f);
        CHECK(pb.value == Approx(pa.value).epsilon(1e-5));
        const Vec3 p = oa + ra.d * 3.f;
        CHECK(b.importance(ob, rb.d) == Approx(a.importance(oa, ra.d)).epsilon(1e-5));
        const auto qa = a.rasterPosition(oa, p), qb = b.rasterPosition(ob, p);
        REQUIRE(qa);
        REQUIRE(qb);
        CHECK(qb->x == Approx(qa->x).margin(1e-3));
        CHECK(qb->y == Approx(qa->y).margin(1e-3));
    }
    // The images: the lens draws two more numbers per camera sample, so equal only in
    // distribution (the block test of the agreement case above, LT and PT, family-wise 1%).
    SceneDesc d = cornellBox(32, makeDiffuse(Color(0.5f)));
    d.integrator.maxDepth = 3;
    SceneDesc dl = d;
    dl.camera.type = SensorType::ThinLens;
    dl.camera.apertureRadius = 1e-6f;
    dl.camera.focusDistance = 3.8f;
    RenderSettings s;
    s.maxDepth = 3;
    for (std::string integ : {"pt", "lt"}) {
        s.integrator = integ;
        s.spp = integ == "lt" ? 8 : 4;
        const auto ref = blockStats(d, s, 10, 4);
        std::vector<std::vector<double>> per(16);
        for (int i = 0; i < 10; ++i) {
            RenderSettings si = s;
            si.seed = 5000 + i;
            auto m = blockMeans(renderDesc(dl, si), 4, 4);
            for (size_t j = 0; j < m.size(); ++j) per[j].push_back(m[j]);
        }
        std::vector<SampleStats> other;
        for (auto& v : per) other.push_back(sampleStats(v));
        INFO(integ);
        CHECK(differingBlocks(other, ref, 0.01) == 0);
    }
}

TEST_CASE("sensors: the loader reads thinlens and orthographic and refuses bad input", "[sensors][loader]") {
    TempDir tmp("lt_test_sensors");
    auto write = [&](const std::string& sensor) {
        const std::string path = (tmp.dir / "s.xml").string();
        std::ofstream(path) << "<scene version=\"3.0.0\">\n" << sensor
                            << "\n<shape type=\"sphere\"><bsdf type=\"diffuse\"/></shape>\n</scene>\n";
        return path;
    };
    auto errorOf = [&](const std::string& sensor) -> std::string {
        try {
            loadScene(write(sensor));
        } catch (const SceneError& e) {
            return e.what();
        }
        return "";
    };
    SceneDesc t = loadScene(write(R"(<sensor type="thinlens"><float name="aperture_radius" value="0.1"/>
        <float name="fov" value="30"/><float name="far_clip" value="50"/></sensor>)"));
    CHECK(t.camera.type == SensorType::ThinLens);
    CHECK(t.camera.apertureRadius == 0.1f);
    CHECK(t.camera.focusDistance == 50.f);  // Mitsuba's default: far_clip
    SceneDesc o = loadScene(write(R"(<sensor type="orthographic"><float name="near_clip" value="1"/>
        <transform name="to_world"><scale x="2" y="3"/><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
        </sensor>)"));
    CHECK(o.camera.type == SensorType::Orthographic);
    CHECK(glm::length(Vec3(o.camera.toWorld[0])) == Approx(2.f));  // the scale is kept
    SceneDesc z = loadScene(write(R"(<sensor type="thinlens"><float name="aperture_radius" value="0"/></sensor>)"));
    CHECK(z.camera.type == SensorType::Perspective);
    CHECK(!z.warnings.empty());

    // file, line 2 (the sensor and its parameters are on line 2 of the written file), parameter
    struct Bad {
        const char* sensor;
        const char* param;
    };
    const Bad bad[] = {
        {"<sensor type=\"thinlens\"><float name=\"aperture_radius\" value=\"-0.1\"/></sensor>", "aperture_radius"},
        {"<sensor type=\"thinlens\"><float name=\"aperture_radius\" value=\"0.1\"/><float name=\"focus_distance\" value=\"0\"/></sensor>",
         "focus_distance"},
        {"<sensor type=\"thinlens\"><float name=\"aperture_radius\" value=\"0.1\"/><float name=\"focus_distance\" value=\"-2\"/></sensor>",
         "focus_distance"},
        {"<sensor type=\"thinlens\"><float name=\"fov\" value=\"30\"/></sensor>", "aperture_radius"},
        {"<sensor type=\"orthographic\"><float name=\"fov\" value=\"30\"/></sensor>", "fov"},
        {"<sensor type=\"orthographic\"><transform name=\"to_world\"><scale x=\"0\"/></transform></sensor>", "to_world"},
        {"<sensor type=\"thinlens\"><float name=\"aperture_radius\" value=\"0.1\"/><transform name=\"to_world\"><scale x=\"2\"/></transform></sensor>",
         "to_world"},
        {"<sensor type=\"orthographic\"><float name=\"near_clip\" value=\"5\"/><float name=\"far_clip\" value=\"4\"/></sensor>",
         "far_clip"},
    };
    for (const Bad& b : bad) {
        const std::string msg = errorOf(b.sensor);
        INFO(b.sensor << " -> " << msg);
        CHECK(msg.find("s.xml") != std::string::npos);
        CHECK(msg.find(":2") != std::string::npos);
        CHECK(msg.find(b.param) != std::string::npos);
    }
    CHECK(errorOf("<sensor type=\"fisheye\"/>").find("thinlens, orthographic") != std::string::npos);
}
