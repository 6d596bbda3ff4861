// Path guiding in the path tracer (integrators/guiding/): unbiased against unguided PT with both
// targets and both fractions, exact in the white furnace, the mixture's density in every MIS
// weight, deterministic across thread counts, bounded in memory.
#include <catch2/catch.hpp>
#include <atomic>
#include <cstring>
#include "integrators/integrator.h"
#include "scene_builders.h"
#include "render_compare.h"
#include "stats.h"

using namespace lt;
using namespace lt::test;

namespace {

// A Cornell box with a glossy panel: indirect light everywhere, a glossy lobe to guide.
SceneDesc glossyBox(int res) {
    return cornellBox(res, makeRoughConductor(MicrofacetType::GGX, 0.2f, 0.2f, Color(0.2f), Color(3.f), Color(1.f)));
}

RenderSettings guided(const std::string& target, double fraction) {
    RenderSettings s;
    s.integrator = "pt";
    s.guiding = target;
    s.guidingBsdfFraction = fraction;
    s.guidingSpatialThreshold = 200.0;  // small images: a tree that splits
    return s;
}

}  // namespace

TEST_CASE("guided PT matches unguided PT on a glossy Cornell box (both targets and fractions)", "[guiding]") {
    // 12 renders per configuration (16x16, 64 spp: five training iterations and the final one),
    // 4x4 block means compared by Welch's t at family-wise significance 1e-3 per configuration
    // (Sidak over the 16 blocks): a correct estimator fails with probability 1e-3. A mixture
    // density missing from one technique's MIS weight (the walk's or next-event estimation's)
    // makes the weights not sum to one where the guide and the BSDF differ.
    const SceneDesc d = glossyBox(16);
    RenderSettings plain;
    plain.spp = 64;
    plain.threads = 2;
    const auto ref = blockStats(d, plain, 12, 4);
    for (const auto& [target, fraction] : std::vector<std::pair<std::string, double>>{
             {"radiance", 0.5}, {"variance", 0.5}, {"radiance", -1.0}, {"variance", -1.0}}) {
        RenderSettings s = guided(target, fraction);
        s.spp = 64;
        s.threads = 2;
        double worst;
        const int bad = differingBlocks(ref, blockStats(d, s, 12, 4), 1e-3, &worst);
        INFO(target << " fraction " << fraction << ": " << bad << " blocks differ, worst |t|/crit " << worst);
        CHECK(bad == 0);
    }
}

TEST_CASE("guiding runs: the tree splits and learns, and the guided image differs from the unguided one", "[guiding]") {
    const SceneDesc d = glossyBox(16);
    RenderSettings s = guided("variance", 0.5);
    s.spp = 64;
    s.seed = 7;
    RenderStats st;
    const Image g = renderDesc(d, s, &st);
    CHECK(st.guidingIterations == 6);  // 1, 2, 4, 8, 16 training passes and the final 33
    CHECK(st.guidingTrainingSpp == 31);
    CHECK(st.guidingLeaves > 1);
    CHECK(st.guidingDirectionalNodes > 2 * st.guidingLeaves);  // refined beyond the roots
    RenderSettings p;
    p.spp = 64;
    p.seed = 7;
    const Image u = renderDesc(d, p);
    CHECK(std::memcmp(g.pixels.data(), u.pixels.data(), g.pixels.size() * sizeof(Color)) != 0);
}

TEST_CASE("guided PT in the white furnace stays exact", "[guiding]") {
    // As the path tracer's furnace test: mean of 32x32 pixels x 64 spp within 4 standard errors
    // (two-sided ~6e-5) of 1 / (1 - albedo) = 2, plus 3e-5 relative for float precision.
    for (const char* target : {"radiance", "variance"}) {
        RenderSettings s = guided(target, -1.0);
        s.spp = 64;
        s.seed = 3;
        const Image img = renderDesc(furnace(32, 0.5f), s);
        const double m = imageMean(img);
        double v = 0;
        for (const Color& c : img.pixels) v += sqr(float((c.x + c.y + c.z) / 3.0 - m));
        const double se = std::sqrt(v / (img.pixels.size() - 1) / img.pixels.size());
        INFO(target << ": mean " << m << " se " << se);
        CHECK(std::abs(m - 2.0) <= 4.0 * se + 3e-5 * 2.0);
    }
}

TEST_CASE("guided PT is bit-identical for any thread count", "[guiding]") {
    const SceneDesc d = glossyBox(24);
    for (double fraction : {0.5, -1.0}) {
        RenderSettings s = guided("variance", fraction);
        s.spp = 32;
        s.seed = 11;
        RenderStats a, b;
        s.threads = 1;
        const Image one = renderDesc(d, s, &a);
        s.threads = 2;
        const Image two = renderDesc(d, s, &b);
        INFO("fraction " << fraction);
        CHECK(std::memcmp(one.pixels.data(), two.pixels.data(), one.pixels.size() * sizeof(Color)) == 0);
        CHECK(a.guidingLeaves == b.guidingLeaves);
        CHECK(a.guidingDirectionalNodes == b.guidingDirectionalNodes);
        CHECK(a.guidingBytes == b.guidingBytes);
    }
}

TEST_CASE("the guiding trees stay under --guiding-max-mb", "[guiding]") {
    // The same render with a tiny spatial threshold grows past 64 KiB without a cap; with the
    // cap, the trees stop splitting there.
    const SceneDesc d = glossyBox(32);
    RenderSettings s = guided("radiance", 0.5);
    s.spp = 32;
    s.guidingSpatialThreshold = 4.0;
    RenderStats free, capped;
    renderDesc(d, s, &free);
    const double capMb = 64.0 / 1024.0;
    s.guidingMaxMb = capMb;
    renderDesc(d, s, &capped);
    INFO("uncapped " << free.guidingBytes << " bytes, capped " << capped.guidingBytes);
    CHECK(double(free.guidingBytes) > capMb * (1 << 20));
    CHECK(double(capped.guidingBytes) <= capMb * (1 << 20));
    CHECK(capped.guidingLeaves < free.guidingLeaves);
}

TEST_CASE("guiding is refused where it does not apply", "[guiding]") {
    const SceneDesc d = glossyBox(8);
    RenderSettings s = guided("variance", 0.5);
    s.spp = 4;
    s.integrator = "bpt";
    CHECK_THROWS_WITH(renderDesc(d, s), Catch::Contains("--integrator pt"));
    s.integrator = "pt";
    s.guiding = "bogus";
    CHECK_THROWS_WITH(renderDesc(d, s), Catch::Contains("unknown guiding"));
    s.guiding = "radiance";
    s.guidingBsdfFraction = 0.0;
    CHECK_THROWS_WITH(renderDesc(d, s), Catch::Contains("--guiding-bsdf-fraction"));
}

TEST_CASE("a guided vertex's density is the mixture's in the walk and in next-event estimation", "[guiding]") {
    // The emitter hit's density (the walk's, re-evaluated at the vertex positions) and next-event
    // estimation's density of the same light point from the same vertex must be one number, the
    // mixture's: were either the BSDF's alone, the two MIS weights would not sum to one. Deterministic:
    // a tree trained on synthetic records (directions towards +y, the light's side), walks with
    // it, and for every walk that hits the light through a guided vertex, connect() to that point.
    const SceneDesc d = glossyBox(16);
    const Scene scene(d);
    guiding::TreeSettings ts;
    ts.spatialThreshold = 50.f;
    guiding::SDTree tree(scene.boundsCenter(), scene.boundsRadius() * 1.001f, ts, 0.5f);
    Rng rng(5, 1);
    for (int it = 0; it < 2; ++it) {
        std::vector<guiding::Record> recs;
        for (int i = 0; i < 20000; ++i) {
            guiding::Record r;
            r.p = Vec3(rng.uniform(), rng.uniform(), rng.uniform()) * 1.8f - Vec3(0.9f);  // inside the box
            const Vec2 u = rng.uniform2();
            r.d = glm::normalize(Vec3(u.x - 0.5f, 1.f, u.y - 0.5f));
            r.value = 1.f;
            recs.push_back(r);
        }
        tree.addRecords({&recs}, 77 + it, false);
        tree.endIteration(it, false);
    }
    guiding::WalkGuide guide;
    guide.tree = &tree;
    guide.fixedFraction = 0.3f;
    std::array<PathVertex, kMaxPathVertices> z;
    WalkStats ws;
    int checked = 0;
    double worst = 0.0;
    for (int i = 0; i < 20000 && checked < 200; ++i) {
        const int nz = cameraWalk(scene, reg::kNone, Vec2(rng.uniform() * 16, rng.uniform() * 16), rng, 6, 100, z.data(),
                                  ws, WalkPdfs::All, &guide);
        for (int t = 3; t <= nz; ++t) {
            const PathVertex& v = z[t - 1];
            if (!v.light || !guide.guided(t - 2)) continue;
            PathVertex y;
            y.setPoint(v.p, v.ng, v.light, 1.f);
            y.init(reg::kNone, VertexKind::Light, nullptr, Vec3(0.f), 0.f, Color(1.f), AreaPdf(1.f), AreaPdf(0.f));
            Connection conn;
            if (!connect<ConnectEnds::LightToSurface>(scene, reg::kNone, &y, 1, z.data(), t - 1, 100, conn, ws,
                                                      kMaxPathVertices, nullptr, &guide))
                continue;
            const float walk = v.fromCamera.value, nee = conn.pdfs.fromCamera[0];
            worst = std::max(worst, std::abs(double(walk) / nee - 1.0));
            ++checked;
        }
    }
    INFO(checked << " light hits through guided vertices, worst relative difference " << worst);
    CHECK(checked >= 50);
    CHECK(worst < 1e-3);  // (float rounding of directions recomputed from offset points)
}

TEST_CASE("a guided render stopped and resumed from its checkpoint is the straight render bit for bit", "[guiding]") {
    // In process: the render is stopped after 5 of 24 passes (inside the third training
    // iteration) and after 17 (inside the final one), each time resumed from the film and the
    // guiding state the checkpoint callback received, with another thread count; the image must be
    // the straight render's. A state from a render to another --spp is refused.
    const SceneDesc d = glossyBox(16);
    const Scene scene(d);
    for (double fraction : {0.5, -1.0}) {
        RenderSettings s = guided("variance", fraction);
        s.spp = 24;
        s.seed = 5;
        s.quiet = true;
        RenderStats st;
        const Image straight = renderImage(scene, s, st);
        uint64_t passes = 0;
        std::string film, state;
        for (const uint64_t stopAt : {uint64_t(5), uint64_t(17), uint64_t(0)}) {
            RenderSettings r = s;
            r.threads = stopAt == 17 ? 1 : 2;
            r.resumePasses = passes;
            r.resumeFilm = film;
            r.resumeIntegrator = state;
            std::atomic<bool> stop{false};
            r.stop = &stop;
            r.checkpointEvery = 1e9;  // only the last one
            r.checkpoint = [&](uint64_t p, const Film& f, const std::string& g) {
                passes = p;
                film = f.state();
                state = g;
            };
            RenderStats rs;
            const Image img = renderImage(scene, r, rs, [&](const Progress& p) {
                if (stopAt > 0 && p.passesDone >= stopAt) stop = true;
            });
            if (stopAt == 0) {
                INFO("fraction " << fraction);
                CHECK(passes == 24);
                CHECK(std::memcmp(img.pixels.data(), straight.pixels.data(), img.pixels.size() * sizeof(Color)) == 0);
                CHECK(rs.guidingLeaves == st.guidingLeaves);
            } else {
                REQUIRE(passes == stopAt);
                REQUIRE(!state.empty());
            }
        }
        RenderSettings other = s;
        other.spp = 32;
        other.resumePasses = 17;
        other.resumeFilm = film;
        other.resumeIntegrator = state;
        RenderStats os;
        CHECK_THROWS_WITH(renderImage(scene, other, os), Catch::Contains("another sample count"));
    }
}

TEST_CASE("the study tools' image so far is the guided render's combination", "[guiding]") {
    // convergence and biasvar read developSoFar in the progress callback: after the last pass it
    // must be the image renderImage returns (the iterations combined), not the film's average.
    const SceneDesc d = glossyBox(16);
    const Scene scene(d);
    RenderSettings s = guided("variance", 0.5);
    s.spp = 16;
    s.quiet = true;
    RenderStats st;
    Image last, average;
    const Image img = renderImage(scene, s, st, [&](const Progress& p) {
        last = developSoFar(p);
        average = p.film->develop(p.passesDone);
    });
    CHECK(std::memcmp(last.pixels.data(), img.pixels.data(), img.pixels.size() * sizeof(Color)) == 0);
    CHECK(std::memcmp(average.pixels.data(), img.pixels.data(), img.pixels.size() * sizeof(Color)) != 0);
}
