// Direct lighting of a diffuse plane by each of the five light types, against the analytic
// radiance, for every integrator: L = rho/pi * E(p) with E the irradiance of the light at p.
#include <catch2/catch.hpp>
#include "core/loader.h"
#include "integrators/integrator.h"
#include "scene_builders.h"
#include "stats.h"

using namespace lt;
using namespace lt::test;

namespace {

constexpr float kRho = 0.8f;

// Irradiance at plane point p (normal +y) from the light.
double irradiance(const EmitterDesc& e, const Vec3& p) {
    switch (e.type) {
        case EmitterType::Point:
        case EmitterType::Spot: {
            Vec3 l = e.position - p;
            float d2 = glm::dot(l, l);
            Vec3 w = l / std::sqrt(d2);
            double falloff = 1.0;
            if (e.type == EmitterType::Spot) {
                float angle = std::acos(glm::dot(-w, glm::normalize(e.direction)));
                float cut = glm::radians(e.cutoffAngleDeg), beam = glm::radians(e.beamWidthDeg);
                falloff = angle >= cut ? 0.0 : angle <= beam ? 1.0 : (cut - angle) / (cut - beam);
            }
            return e.value.x * falloff * w.y / d2;
        }
        case EmitterType::Directional: return e.value.x * std::max(0.f, -glm::normalize(e.direction).y);
        case EmitterType::Constant: return e.value.x * kPi;  // unoccluded upper hemisphere
        default: return 0.0;
    }
}

}  // namespace

TEST_CASE("every light type and integrator matches the analytic direct lighting of a plane", "[lights][statistical]") {
    // Expected image mean: the analytic radiance averaged over each pixel's footprint (16x16
    // midpoint rule), then over the image. Each configuration is rendered with K = 8 seeds and a
    // one-sample t-test on the image mean is applied; family-wise significance 1% (Sidak over
    // all lights x integrators). For PT, BPT and VCM the standard errors are 0.05-0.5% of the
    // mean, so a 2% error in a light's normalisation fails; light tracing of the lights at
    // infinity is far noisier (emission spread over the scene's disk: se ~3%), so it is a weak
    // check there (measured at 4096 spp: within 1.7 se of the analytic value). The 1e-4 relative
    // floor is float precision for configurations without noise (PT with a directional light).
    const int res = 16, k = 8;
    std::vector<EmitterDesc> lights(4);
    lights[0].type = EmitterType::Point;
    lights[0].position = Vec3(0.3f, 1.5f, -0.2f);
    lights[0].value = Color(5.f);
    lights[1] = lights[0];
    lights[1].type = EmitterType::Spot;
    lights[1].direction = glm::normalize(Vec3(-0.2f, -1.f, 0.1f));
    lights[1].cutoffAngleDeg = 30.f;
    lights[1].beamWidthDeg = 15.f;
    lights[2].type = EmitterType::Directional;
    lights[2].direction = glm::normalize(Vec3(0.3f, -1.f, 0.2f));
    lights[2].value = Color(2.f);
    lights[3].type = EmitterType::Constant;
    lights[3].value = Color(0.7f);
    std::vector<std::string> integrators = {"pt", "bpt", "lt", "vcm"};
    const int tests = int(lights.size() * integrators.size());
    for (const EmitterDesc& e : lights) {
        SceneDesc d;
        d.bsdfs.push_back(makeDiffuse(Color(kRho)));
        d.meshes.push_back(quad(Vec3(-5, 0, -5), Vec3(0, 0, 10), Vec3(10, 0, 0), 0));  // y = 0, normal +y
        d.emitters.push_back(e);
        d.camera = lookAt(Vec3(0, 2, 2), Vec3(0, 0, 0), Vec3(0, 1, 0), 50.f, res, res);
        Camera cam(d.camera);
        double expected = 0;
        const int q = 16;
        for (int y = 0; y < res; ++y)
            for (int x = 0; x < res; ++x)
                for (int j = 0; j < q; ++j)
                    for (int i = 0; i < q; ++i) {
                        Ray r = cam.generateRay(Vec2(x + (i + 0.5f) / q, y + (j + 0.5f) / q));
                        if (r.d.y >= 0) continue;
                        Vec3 p = r.o + (-r.o.y / r.d.y) * r.d;
                        expected += kRho / kPi * irradiance(e, p);
                    }
        expected /= double(res * res * q * q);
        for (const std::string& integ : integrators) {
            RenderSettings s;
            s.integrator = integ;
            s.spp = integ == "lt" ? 16 : 8;
            s.maxDepth = 2;
            s.quiet = true;
            std::vector<double> means;
            for (int i = 0; i < k; ++i) {
                s.seed = 100 + i;
                Scene scene(d);
                RenderStats st;
                Image img = renderImage(scene, s, st);
                double m = 0;
                for (const Color& c : img.pixels) m += c.x;
                means.push_back(m / img.pixels.size());
            }
            SampleStats ss = sampleStats(means);
            double se = std::sqrt(ss.var / k);
            double crit = studentTCritical(sidak(0.01, tests), k - 1);
            INFO("light " << int(e.type) << " " << integ << ": mean " << ss.mean << " expected " << expected << " se "
                          << se);
            CHECK(std::abs(ss.mean - expected) <= crit * se + 1e-4 * expected);
        }
    }
}

// The light and emitting-triangle choice (branch-free binary search, remap by multiplication):
// deterministic, on a fine grid of u, against the definition cdf[i] <= u < cdf[i+1], for every
// size from 1 to 17 (the search's step count depends on the size) and with zero-weight bins
// (which must never be chosen), first, inside and last.
TEST_CASE("Distribution1D picks the bin whose cdf interval holds u and remaps u within it", "[lights]") {
    for (int n = 1; n <= 17; ++n) {
        std::vector<float> w(static_cast<size_t>(n));
        for (int i = 0; i < n; ++i) w[size_t(i)] = (i % 3 == 1) ? 0.f : float(1 + (i * 7) % 5);
        if (n > 2) w[0] = 0.f, w[size_t(n - 1)] = 0.f;
        double total = 0;
        for (float x : w) total += x;
        if (total == 0) continue;
        Distribution1D dist(w);
        REQUIRE(dist.size() == size_t(n));
        std::vector<double> cdf(size_t(n) + 1, 0.0);
        for (int i = 0; i < n; ++i) cdf[size_t(i) + 1] = cdf[size_t(i)] + w[size_t(i)] / total;
        for (int k = 0; k < 4096; ++k) {
            float u = (float(k) + 0.37f) / 4096.f;
            float remapped = -1.f;
            size_t i = dist.sample(u, &remapped);
            INFO("n=" << n << " u=" << u << " bin " << i);
            REQUIRE(i < size_t(n));
            CHECK(w[i] > 0.f);
            CHECK(cdf[i] <= double(u) + 1e-6);
            CHECK(double(u) < cdf[i + 1] + 1e-6);
            CHECK(remapped >= 0.f);
            CHECK(remapped < 1.f);
            CHECK(remapped == Approx((double(u) - cdf[i]) / (cdf[i + 1] - cdf[i])).margin(1e-4));
            CHECK(dist.probability(i) == Approx(w[i] / total).epsilon(1e-6));
        }
    }
}

TEST_CASE("Scene::mayHitEmitter is false only where no closest hit is on an emitter", "[lights][scene]") {
    // A bounding sphere per emitting shape makes the test conservative by construction; checked
    // on random rays leaving random surface points, in a scene with a mesh light (the Cornell box's
    // ceiling quad) and one with a sphere light (caustic-roughness): half in uniform directions,
    // half aimed near a point sampled on the light (hits and near misses). Every ray whose closest
    // hit is on an emitter must pass, and the test must reject most of the others (else it saves
    // nothing: the lights are small in both scenes).
    for (const char* name : {"scenes/cornell-box.xml", "scenes/hard/caustic-roughness.xml"}) {
        INFO(name);
        const Scene scene(loadScene(std::string(LT_SOURCE_DIR) + "/" + name, {{"res", "16"}}));
        REQUIRE(scene.infiniteLights().empty());
        Rng rng(11, 5);
        int emitterHits = 0, others = 0, rejected = 0;
        for (int i = 0; i < 20000; ++i) {
            SurfaceHit from;
            const Ray probe{scene.geometryCenter(), sampleUniformSphere(rng.uniform2())};
            if (!scene.intersect(probe, from)) continue;
            Vec3 dir = sampleUniformSphere(rng.uniform2());
            if (i % 2) {
                const LightSampleLi ls = scene.lights().front().sampleLi(scene, from.p, rng.uniform2());
                const Vec3 toLight = ls.p - from.p;
                dir = glm::normalize(toLight + 0.05f * glm::length(toLight) * sampleUniformSphere(rng.uniform2()));
            }
            const Ray ray = scene.spawnRay(from.p, from.ng, dir);
            SurfaceHit hit;
            const bool onEmitter = scene.intersect(ray, hit) && hit.light;
            const bool may = scene.mayHitEmitter(ray);
            if (onEmitter) {
                ++emitterHits;
                CHECK(may);
            } else {
                ++others;
                rejected += may ? 0 : 1;
            }
        }
        INFO(emitterHits << " rays on an emitter, " << rejected << " of " << others << " others rejected");
        CHECK(emitterHits > 500);  // (measured: 5351 and 713)
        CHECK(rejected > others / 2);
    }
}
