// raybench: a bare Embree ray-casting loop, the bound the renderer's rays/s is compared with.
//
// Default mode (replay): the path tracer renders `--passes` samples per pixel with its ray log on
// (WalkStats::log) and the very rays it cast (camera rays, bounce rays at every depth, shadow
// rays, in the renderer's proportions) are then cast again with rtcIntersect1 / rtcOccluded1 and
// nothing else. Only the casting is timed. They are cast twice:
// - as cast: in the renderer's order (a camera ray, then that path's bounce and shadow rays, then
//   the next pixel's), split into contiguous chunks between the threads. This is the renderer's
//   own ray stream without the renderer: the bound its rays/s is compared with.
// - grouped by kind: all camera rays (neighbouring pixels one after the other), then all bounce
//   rays, then all shadow rays; gives the rate per kind. Consecutive camera rays are more coherent
//   than in the renderer's stream, so this bound is higher (Embree's traversal branches are better
//   predicted).
//
// Synthetic mode (--mode synthetic, the earlier yardstick): one camera ray, one diffuse bounce ray
// from its hit and one shadow ray from that hit per pixel, generated with the renderer's camera,
// offsets and light sampling.
//
// Prints rays/s per kind and overall.
#include <CLI/CLI.hpp>
#include <embree3/rtcore.h>
#include <fmt/core.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <chrono>
#include "core/loader.h"
#include "core/rng.h"
#include "core/scene.h"
#include "integrators/integrator.h"
#include "tools/analysis.h"

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

// Seconds for casting all rays, in parallel contiguous chunks: closest hit, or occlusion for the
// rays with shadow[i] set (shadow empty: all closest hit; allShadow: all occlusion).
double cast(RTCScene scene, std::vector<RTCRay>& rays, const std::vector<char>& shadow, bool allShadow = false) {
    std::vector<RTCRayHit> rh(allShadow ? 0 : rays.size());
    for (size_t i = 0; i < rh.size(); ++i) {
        rh[i].ray = rays[i];
        rh[i].hit.geomID = RTC_INVALID_GEOMETRY_ID;
    }
    auto t0 = std::chrono::steady_clock::now();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        for (size_t i = r.begin(); i != r.end(); ++i) {
            if (allShadow || (!shadow.empty() && shadow[i])) rtcOccluded1(scene, &ctx, &rays[i]);
            else rtcIntersect1(scene, &ctx, &rh[i]);
        }
    });
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
double cast(RTCScene scene, std::vector<RTCRay>& rays, bool occlusion) { return cast(scene, rays, {}, occlusion); }

struct Timings {
    double tCam = 0, tBounce = 0, tShadow = 0;
    size_t nCam = 0, nBounce = 0, nShadow = 0;
    double tAsCast = 0;  // replay: all rays in the renderer's order (0: not measured)
};

// One camera, one diffuse bounce and one shadow ray per pixel (the earlier yardstick).
Timings synthetic(const Scene* scene, int passes) {
    Timings T;
    double &tCam = T.tCam, &tBounce = T.tBounce, &tShadow = T.tShadow;
    size_t &nCam = T.nCam, &nBounce = T.nBounce, &nShadow = T.nShadow;
    const Camera& cam = scene->camera();
    const size_t w = size_t(cam.width()), h = size_t(cam.height());
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
            // The renderer's own shadow rays (Scene::shadowRay offsets both ends).
            Ray r = l.isInfinite() ? scene->shadowRayInfinite(hits[i].p, hits[i].ng, ls.wi)
                                   : scene->shadowRay(hits[i].p, hits[i].ng, ls.p, ls.n);
            if (r.tMax > 0.f) shadow.push_back(toRtc(r));
        }
        tCam += cast(scene->embreeScene(), camRays, false);
        tBounce += cast(scene->embreeScene(), bounce, false);
        tShadow += cast(scene->embreeScene(), shadow, true);
        nCam += camRays.size(), nBounce += bounce.size(), nShadow += shadow.size();
    }
    return T;
}

// The path tracer's own rays, logged while it renders, then cast bare.
Timings replay(const Scene& scene, RenderSettings settings, int passes) {
    Timings T;
    settings.integrator = "pt";
    auto integrator = makeIntegrator(settings);
    const int w = scene.camera().width(), h = scene.camera().height();
    for (int pass = 0; pass < passes; ++pass) {
        Film film(w, h, FilterType::Box);
        RayLog log;
        WalkStats stats;
        stats.log = &log;
        integrator->renderTile(scene, film, uint32_t(pass), 0, 0, w, h, stats);  // untimed, one thread
        std::vector<RTCRay> cam, bounce, shadow;
        for (size_t i = 0; i < log.closest.size(); ++i)
            (log.closestDepth[i] == 0 ? cam : bounce).push_back(toRtc(log.closest[i]));
        for (const Ray& r : log.shadow) shadow.push_back(toRtc(r));
        std::vector<RTCRay> seq;
        std::vector<char> seqShadow;
        size_t ic = 0, is = 0;
        for (bool sh : log.shadowAt) {
            seq.push_back(toRtc(sh ? log.shadow[is++] : log.closest[ic++]));
            seqShadow.push_back(sh);
        }
        T.tAsCast += cast(scene.embreeScene(), seq, seqShadow);
        T.tCam += cast(scene.embreeScene(), cam, false);
        T.tBounce += cast(scene.embreeScene(), bounce, false);
        T.tShadow += cast(scene.embreeScene(), shadow, true);
        T.nCam += cam.size(), T.nBounce += bounce.size(), T.nShadow += shadow.size();
    }
    return T;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"raybench: bare Embree ray casting of the renderer's rays (replayed) or of synthetic ones"};
    std::string scenePath, mode = "replay";
    int threads = 2, passes = 4, maxDepth = -2;
    std::vector<std::string> defines;
    app.add_option("scene", scenePath, "Scene file")->required();
    app.add_option("--threads", threads, "Threads for casting");
    app.add_option("--passes", passes, "Samples per pixel whose rays are cast (replay) / passes over the image (synthetic)");
    app.add_option("--mode", mode, "replay (the path tracer's own rays) or synthetic (camera + one bounce + one shadow ray per pixel)")
        ->check(CLI::IsMember({"replay", "synthetic"}));
    app.add_option("--max-depth", maxDepth, "Replay: the path tracer's max depth (default: the scene's)");
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
    Timings T;
    if (mode == "replay") {
        // The scene's settings, as the analysis tools read them, with the max depth overridden.
        analysis::RunConfig cfg = analysis::parseConfig("pt");
        if (maxDepth >= -1) cfg.maxDepth = maxDepth;
        T = replay(*scene, analysis::makeSettings(scene->desc(), cfg, threads, scene->desc().seed), passes);
    } else {
        T = synthetic(scene.get(), passes);
    }
    const Camera& cam = scene->camera();
    auto rate = [](size_t n, double t) { return t > 0 ? double(n) / t / 1e6 : 0.0; };
    size_t n = T.nCam + T.nBounce + T.nShadow;
    fmt::print("scene: {} ({} triangles, {}x{}), {} threads, mode {}\n", scenePath, scene->triangleCount(),
               cam.width(), cam.height(), threads, mode);
    fmt::print("camera rays:  {:8.2f} M rays/s ({:.1f}% of the rays)\n", rate(T.nCam, T.tCam), 100.0 * T.nCam / std::max<size_t>(n, 1));
    fmt::print("bounce rays:  {:8.2f} M rays/s ({:.1f}%)\n", rate(T.nBounce, T.tBounce), 100.0 * T.nBounce / std::max<size_t>(n, 1));
    fmt::print("shadow rays:  {:8.2f} M rays/s ({:.1f}%)\n", rate(T.nShadow, T.tShadow), 100.0 * T.nShadow / std::max<size_t>(n, 1));
    if (T.tAsCast > 0) {
        fmt::print("all rays, grouped by kind: {:8.2f} M rays/s\n", rate(n, T.tCam + T.tBounce + T.tShadow));
        fmt::print("all rays, as cast:         {:8.2f} M rays/s (the renderer's order; the bound)\n", rate(n, T.tAsCast));
    } else {
        fmt::print("all rays:     {:8.2f} M rays/s\n", rate(n, T.tCam + T.tBounce + T.tShadow));
    }
    return 0;
}
