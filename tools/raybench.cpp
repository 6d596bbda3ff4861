// raybench: a bare Embree ray-casting loop over the kinds of rays the renderer casts: camera rays,
// diffuse bounce rays from the camera hits, and shadow rays from those hits towards light
// samples. The rays are generated first (with the renderer's camera, offsets and light sampling);
// only rtcIntersect1 / rtcOccluded1 over the stored rays is timed. Prints rays/s per kind and
// overall: the bound the renderer's rays/s is compared with.
#include <CLI/CLI.hpp>
#include <embree3/rtcore.h>
#include <fmt/core.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <chrono>
#include "core/loader.h"
#include "core/rng.h"
#include "core/scene.h"

using namespace lt;

namespace {

RTCRay toRtc(const Ray& r) {
    RTCRay rr{};
    rr.org_x = r.o.x, rr.org_y = r.o.y, rr.org_z = r.o.z;
    rr.dir_x = r.d.x, rr.dir_y = r.d.y, rr.dir_z = r.d.z;
    rr.tnear = r.tMin;
    rr.tfar = r.tMax;
    rr.mask = 0xFFFFFFFFu;
    return rr;
}

// Seconds for casting all rays (closest hit or occlusion), in parallel chunks.
double cast(RTCScene scene, std::vector<RTCRay>& rays, bool occlusion) {
    std::vector<RTCRayHit> rh(occlusion ? 0 : rays.size());
    for (size_t i = 0; i < rh.size(); ++i) {
        rh[i].ray = rays[i];
        rh[i].hit.geomID = RTC_INVALID_GEOMETRY_ID;
    }
    auto t0 = std::chrono::steady_clock::now();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        for (size_t i = r.begin(); i != r.end(); ++i) {
            if (occlusion) rtcOccluded1(scene, &ctx, &rays[i]);
            else rtcIntersect1(scene, &ctx, &rh[i]);
        }
    });
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"raybench: bare Embree ray casting of a scene's camera, bounce and shadow rays"};
    std::string scenePath;
    int threads = 2, passes = 4;
    std::vector<std::string> defines;
    app.add_option("scene", scenePath, "Scene file")->required();
    app.add_option("--threads", threads, "Threads");
    app.add_option("--passes", passes, "Passes over the image (one ray of each kind per pixel each)");
    app.add_option("-D", defines, "name=value overrides")->take_all();
    CLI11_PARSE(app, argc, argv);
    std::unique_ptr<Scene> scene;
    try {
        scene = std::make_unique<Scene>(loadScene(scenePath, parseDefines(defines)));
    } catch (const std::exception& e) {
        fmt::print(stderr, "error: {}\n", e.what());
        return 2;
    }
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const Camera& cam = scene->camera();
    const size_t w = size_t(cam.width()), h = size_t(cam.height());
    double tCam = 0, tBounce = 0, tShadow = 0;
    size_t nCam = 0, nBounce = 0, nShadow = 0;
    for (int pass = 0; pass < passes; ++pass) {
        std::vector<RTCRay> camRays(w * h), bounce, shadow;
        std::vector<SurfaceHit> hits(w * h);
        std::vector<char> valid(w * h, 0);
        for (size_t i = 0; i < w * h; ++i) {
            Rng rng = Rng::forSample(7, i, pass);
            Ray r = cam.generateRay(Vec2(float(i % w), float(i / w)) + rng.uniform2());
            camRays[i] = toRtc(r);
            valid[i] = scene->intersect(r, hits[i]);  // untimed: to place the other kinds of rays
        }
        for (size_t i = 0; i < w * h; ++i) {
            if (!valid[i]) continue;
            Rng rng = Rng::forSample(8, i, pass);
            Vec3 d = hits[i].shading.toWorld(sampleCosineHemisphere(rng.uniform2()));
            bounce.push_back(toRtc(scene->spawnRay(hits[i].p, hits[i].ng, d)));
            if (scene->lights().empty()) continue;
            const Light& l = scene->lights()[scene->lightDistribution().sample(rng.uniform())];
            LightSampleLi ls = l.sampleLi(*scene, hits[i].p, rng.uniform2());
            if (l.isInfinite()) {
                shadow.push_back(toRtc(scene->spawnRay(hits[i].p, hits[i].ng, ls.wi)));
            } else {
                Vec3 a = scene->offsetPoint(hits[i].p, hits[i].ng, ls.p - hits[i].p);
                Vec3 dd = ls.p - a;
                float len = glm::length(dd);
                if (len > 0.f) shadow.push_back(toRtc(Ray{a, dd / len, 0.f, len * (1.f - 1e-4f)}));
            }
        }
        tCam += cast(scene->embreeScene(), camRays, false);
        tBounce += cast(scene->embreeScene(), bounce, false);
        tShadow += cast(scene->embreeScene(), shadow, true);
        nCam += camRays.size(), nBounce += bounce.size(), nShadow += shadow.size();
    }
    auto rate = [](size_t n, double t) { return t > 0 ? double(n) / t / 1e6 : 0.0; };
    fmt::print("scene: {} ({} triangles, {}x{}), {} threads\n", scenePath, scene->triangleCount(), w, h, threads);
    fmt::print("camera rays:  {:8.2f} M rays/s\n", rate(nCam, tCam));
    fmt::print("bounce rays:  {:8.2f} M rays/s\n", rate(nBounce, tBounce));
    fmt::print("shadow rays:  {:8.2f} M rays/s\n", rate(nShadow, tShadow));
    fmt::print("all rays:     {:8.2f} M rays/s\n", rate(nCam + nBounce + nShadow, tCam + tBounce + tShadow));
    return 0;
}
