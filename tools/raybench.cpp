// raybench: a bare Embree ray-casting loop over the kinds of rays the renderer casts (camera rays,
// diffuse bounce rays from the hit points, shadow rays towards the lights), to compare the
// renderer's rays/s against the ray-casting bound. Prints rays/s per kind and overall.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <atomic>
#include <chrono>
#include "core/loader.h"
#include "core/rng.h"
#include "core/scene.h"

using namespace lt;

int main(int argc, char** argv) {
    CLI::App app{"raybench: bare Embree ray casting on a scene's camera, bounce and shadow rays"};
    std::string scenePath;
    int threads = 2, passes = 8;
    std::vector<std::string> defines;
    app.add_option("scene", scenePath, "Scene file")->required();
    app.add_option("--threads", threads, "Threads");
    app.add_option("--passes", passes, "Passes over the image (one ray of each kind per pixel each)");
    app.add_option("-D", defines, "name=value overrides")->take_all();
    CLI11_PARSE(app, argc, argv);
    std::map<std::string, std::string> defs;
    for (auto& d : defines) {
        auto eq = d.find('=');
        if (eq != std::string::npos) defs[d.substr(0, eq)] = d.substr(eq + 1);
    }
    std::unique_ptr<Scene> scene;
    try {
        scene = std::make_unique<Scene>(loadScene(scenePath, defs));
    } catch (const std::exception& e) {
        fmt::print(stderr, "error: {}\n", e.what());
        return 2;
    }
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const Camera& cam = scene->camera();
    const int w = cam.width(), h = cam.height();
    using Clock = std::chrono::steady_clock;
    double tCam = 0, tBounce = 0, tShadow = 0;
    std::atomic<uint64_t> nCam{0}, nBounce{0}, nShadow{0};
    for (int pass = 0; pass < passes; ++pass) {
        // Camera rays; keep the hit points for the other two kinds.
        std::vector<SurfaceHit> hits(size_t(w) * h);
        std::vector<char> valid(size_t(w) * h, 0);
        auto t0 = Clock::now();
        tbb::parallel_for(0, h, [&](int y) {
            for (int x = 0; x < w; ++x) {
                Rng rng = Rng::forSample(7, uint64_t(y) * w + x, pass);
                Ray r = cam.generateRay(Vec2(x, y) + rng.uniform2());
                valid[size_t(y) * w + x] = scene->intersect(r, hits[size_t(y) * w + x]);
            }
            nCam += uint64_t(w);
        });
        auto t1 = Clock::now();
        tbb::parallel_for(0, h, [&](int y) {
            uint64_t n = 0;
            for (int x = 0; x < w; ++x) {
                size_t i = size_t(y) * w + x;
                if (!valid[i]) continue;
                Rng rng = Rng::forSample(8, i, pass);
                Vec3 d = hits[i].shading.toWorld(sampleCosineHemisphere(rng.uniform2()));
                SurfaceHit hh;
                scene->intersect(scene->spawnRay(hits[i].p, hits[i].ng, d), hh);
                ++n;
            }
            nBounce += n;
        });
        auto t2 = Clock::now();
        tbb::parallel_for(0, h, [&](int y) {
            uint64_t n = 0;
            for (int x = 0; x < w; ++x) {
                size_t i = size_t(y) * w + x;
                if (!valid[i] || scene->lights().empty()) continue;
                Rng rng = Rng::forSample(9, i, pass);
                const Light& l = scene->lights()[scene->lightDistribution().sample(rng.uniform())];
                LightSampleLi ls = l.sampleLi(*scene, hits[i].p, rng.uniform2());
                if (l.isInfinite()) scene->occludedInfinite(hits[i].p, hits[i].ng, ls.wi);
                else scene->occluded(hits[i].p, hits[i].ng, ls.p, l.type == LightType::Area ? ls.n : Vec3(0.f));
                ++n;
            }
            nShadow += n;
        });
        auto t3 = Clock::now();
        tCam += std::chrono::duration<double>(t1 - t0).count();
        tBounce += std::chrono::duration<double>(t2 - t1).count();
        tShadow += std::chrono::duration<double>(t3 - t2).count();
    }
    auto rate = [](uint64_t n, double t) { return t > 0 ? double(n) / t / 1e6 : 0.0; };
    fmt::print("scene: {} ({} triangles, {}x{}), {} threads\n", scenePath, scene->triangleCount(), w, h, threads);
    fmt::print("camera rays:  {:8.2f} M rays/s\n", rate(nCam, tCam));
    fmt::print("bounce rays:  {:8.2f} M rays/s\n", rate(nBounce, tBounce));
    fmt::print("shadow rays:  {:8.2f} M rays/s\n", rate(nShadow, tShadow));
    fmt::print("all rays:     {:8.2f} M rays/s\n", rate(nCam + nBounce + nShadow, tCam + tBounce + tShadow));
    return 0;
}
