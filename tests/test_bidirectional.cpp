// BPT, LT, VCM and PPM on the shared store: agreement with PT, each technique alone, MIS partition
// of unity against a from-scratch evaluation, robustness.
#include <catch2/catch.hpp>
#include <tbb/task_arena.h>
#include <algorithm>
#include <cstring>
#include <map>
#include "integrators/transport/light_paths.h"
#include "integrators/integrator.h"
#include "render_compare.h"
#include "scene_builders.h"
#include "stats.h"

using namespace lt;
using namespace lt::test;

namespace {

// Blocks whose means differ at family-wise significance alpha (Welch t, Sidak over blocks x pairs).
int differing(const std::vector<SampleStats>& a, const std::vector<SampleStats>& b, double alpha, int tests) {
    double perTest = sidak(alpha, tests);
    int bad = 0;
    for (size_t i = 0; i < a.size(); ++i) {
        double df;
        double t = welchT(a[i], b[i], df);
        if (std::abs(t) > studentTCritical(perTest, std::max(df, 1.0))) ++bad;
    }
    return bad;
}

BxdfPtr ggx() {
    return makeRoughConductor(MicrofacetType::GGX, 0.1f, 0.1f, Color(0.2f, 0.9f, 1.1f), Color(3.9f, 2.4f, 2.1f), Color(1.f));
}

// The three agreement scenes: diffuse box, GGX panel and sphere, point light; plus a smooth-normal
// mesh sphere in each so that shading normals (and the adjoint correction) matter.
std::vector<std::pair<std::string, SceneDesc>> agreementScenes(int res) {
    std::vector<std::pair<std::string, SceneDesc>> v;
    v.emplace_back("diffuse", cornellBox(res, makeDiffuse(Color(0.5f))));
    v.emplace_back("ggx", cornellBox(res, ggx()));
    v.emplace_back("point", cornellBoxPointLight(res, makeDiffuse(Color(0.5f))));
    for (auto& [name, d] : v) {
        d.meshes.push_back(smoothSphere(Vec3(-0.45f, -0.65f, 0.2f), 0.3f, 5, 7, 0));
        d.meshes[0].normals.assign(4, glm::normalize(Vec3(0.2f, 1.f, 0.1f)));  // tilted floor normals
        d.integrator.maxDepth = 4;
    }
    return v;
}

}  // namespace

TEST_CASE("PT, BPT, LT and VCM without merging agree (and a broken MIS weight or adjoint does not)",
          "[bpt][statistical]") {
    // 32x32 images in 4x4 blocks of 8x8 pixels; each integrator rendered with K = 10 independent
    // seeds; Welch t-test per block against PT. Family-wise significance 1% per scene (Sidak over
    // 16 blocks x 3 comparisons).
    const int res = 32, k = 10, blocks = 4, tests = blocks * blocks * 3;
    for (auto& [name, d] : agreementScenes(res)) {
        RenderSettings s;
        s.spp = 4;
        s.maxDepth = 4;
        s.integrator = "pt";
        auto pt = blockStats(d, s, k, blocks);
        for (std::string integ : {"bpt", "lt"}) {
            s.integrator = integ;
            s.spp = integ == "lt" ? 8 : 4;
            INFO(name << ": " << integ << " vs pt");
            CHECK(differing(blockStats(d, s, k, blocks, 2000), pt, 0.01, tests) == 0);
        }
        // VCM with merging off is BPT; with a vanishing radius the merges carry ~no weight.
        s.integrator = "vcm";
        s.spp = 4;
        s.radius = 1e-6f;
        INFO(name << ": vcm (radius -> 0) vs pt");
        CHECK(differing(blockStats(d, s, k, blocks, 3000), pt, 0.01, tests) == 0);
        if (name != "diffuse") continue;
        // Power: a 25% error in the weights of the s >= 2 connections is detected.
        RenderSettings broken;
        broken.integrator = "bpt";
        broken.spp = 4;
        broken.maxDepth = 4;
        broken.testMisScale = 1.25f;
        INFO("broken MIS weight must be detected");
        CHECK(differing(blockStats(d, broken, k, blocks, 4000), pt, 0.01, tests) > 0);
    }
}

TEST_CASE("light tracing needs the adjoint shading-normal correction", "[bpt][statistical]") {
    // The floor's vertex normals are all tilted by ~30 degrees (Veach's test case): shading and
    // geometric normals differ systematically. LT with the correction agrees with PT; LT without
    // it must differ (Welch t per 4x4 block, K = 10 seeds, family-wise 1%). (A faceted sphere with
    // smooth normals is a weak test: the deviations average out over each facet.)
    SceneDesc d = cornellBox(32, makeDiffuse(Color(0.5f)));
    d.meshes[0].normals.assign(4, glm::normalize(Vec3(0.5f, 1.f, 0.3f)));
    const int k = 10, blocks = 4, tests = blocks * blocks * 2;
    RenderSettings s;
    s.maxDepth = 3;
    s.integrator = "pt";
    s.spp = 4;
    auto pt = blockStats(d, s, k, blocks);
    s.integrator = "lt";
    s.spp = 8;
    CHECK(differing(blockStats(d, s, k, blocks, 2000), pt, 0.01, tests) == 0);
    gTestDisableAdjointCorrection = true;
    auto broken = blockStats(d, s, k, blocks, 2000);
    gTestDisableAdjointCorrection = false;
    CHECK(differing(broken, pt, 0.01, tests) > 0);
}

TEST_CASE("each BPT technique alone, unweighted, matches PT on paths of its length", "[bpt][statistical]") {
    // Technique (s, t) alone samples all paths of n = s + t - 1 segments; PT restricted to that
    // length is PT(max_depth n) - PT(max_depth n - 1) (independent seeds, variances add).
    // Welch t-tests on 2x2 blocks of the 16x16 image, K = 12 seeds, family-wise 1% over all
    // techniques and blocks.
    SceneDesc d = cornellBox(16, makeDiffuse(Color(0.5f)));
    const int k = 12, blocks = 2;
    std::vector<std::pair<int, int>> techniques = {{0, 3}, {1, 2}, {2, 1}, {0, 4}, {1, 3}, {2, 2}, {3, 1}};
    const int tests = int(techniques.size()) * blocks * blocks;
    auto ptDepth = [&](int depth, uint64_t seed0) {
        RenderSettings s;
        s.integrator = "pt";
        s.spp = 16;
        s.maxDepth = depth;
        return blockStats(d, s, k, blocks, seed0);
    };
    std::map<int, std::vector<SampleStats>> exact;
    for (int n : {2, 3}) {
        auto hi = ptDepth(n, 100 + n * 50), lo = ptDepth(n - 1, 7000 + n * 50);
        std::vector<SampleStats> diff(hi.size());
        for (size_t b = 0; b < hi.size(); ++b) {
            diff[b].mean = hi[b].mean - lo[b].mean;
            diff[b].var = hi[b].var + lo[b].var;  // independent renders
            diff[b].k = k;
        }
        exact[n] = diff;
    }
    for (auto [s_, t_] : techniques) {
        int n = s_ + t_ - 1;
        RenderSettings s;
        s.integrator = "bpt";
        s.spp = 16;
        s.maxDepth = n;
        s.onlyS = s_;
        s.onlyT = t_;
        auto tech = blockStats(d, s, k, blocks, 9000 + s_ * 100 + t_);
        INFO("technique s=" << s_ << " t=" << t_);
        CHECK(differing(tech, exact[n], 0.01, tests) == 0);
        double total = 0;
        for (auto& b : tech) total += b.mean;
        CHECK(total > 0.0);  // the technique contributes
    }
}

namespace {

// From-scratch pdfs of a full path x_0 (light) .. x_{n-1} (camera): every density recomputed
// from positions, normals, BSDFs and the light, without the walks' stored values.
PathPdfs bruteForcePdfs(const Scene& scene, const std::vector<PathVertex>& x, int rrDepth) {
    PathPdfs P;
    const int n = int(x.size());
    P.n = n;
    auto areaAt = [](SolidAnglePdf p, const PathVertex& from, const PathVertex& to) {
        Vec3 d = to.p - from.p;
        float d2 = glm::dot(d, d);
        float c = to.ng != Vec3(0.f) ? std::abs(glm::dot(to.ng, d)) / std::sqrt(d2) : 1.f;
        return p.value * c / d2;
    };
    auto dir = [](const PathVertex& a, const PathVertex& b) { return glm::normalize(b.p - a.p); };
    const Light& l = *x[0].light;
    P.fromLight[0] = scene.lightSelectionProb(&l) * l.pdfLePos(scene).value;
    P.lightHittable = l.isHittable();
    if (n > 1) P.fromLight[1] = areaAt(l.pdfLeDir(x[0].ng, dir(x[0], x[1])), x[0], x[1]);
    for (int i = 2; i < n; ++i) {
        const PathVertex& v = x[i - 1];
        BsdfEval e = v.bsdf().eval(dir(v, x[i - 2]), dir(v, x[i]), TransportMode::Importance);
        // times the roulette's continuation probability at v where the light walk plays it there,
        // i - 1 segments from the light (path.h, "Russian roulette")
        const float cont = i - 1 >= rrDepth ? v.bxdf->continuation() : 1.f;
        P.fromLight[i] = v.bxdf->isDelta() ? 0.f : cont * areaAt(e.pdfFwd, v, x[i]);
    }
    P.fromCamera[n - 1] = 1.f;
    P.fromCamera[n - 2] = areaAt(scene.camera().directionPdf(dir(x[n - 1], x[n - 2])), x[n - 1], x[n - 2]);
    for (int i = n - 3; i >= 0; --i) {
        const PathVertex& v = x[i + 1];
        BsdfEval e = v.bsdf().eval(dir(v, x[i + 2]), dir(v, x[i]), TransportMode::Radiance);
        const float cont = n - 2 - i >= rrDepth ? v.bxdf->continuation() : 1.f;  // (v: n - 2 - i from the camera)
        P.fromCamera[i] = v.bxdf->isDelta() ? 0.f : cont * areaAt(e.pdfFwd, v, x[i]);
    }
    for (int i = 0; i < n; ++i) P.delta[i] = x[i].kind == VertexKind::Surface && x[i].bxdf->isDelta();
    return P;
}

}  // namespace

TEST_CASE("MIS: gathered pdfs equal a from-scratch evaluation and weights sum to one", "[bpt][mis]") {
    SceneDesc d = cornellBox(8, ggx());
    d.meshes.push_back(smoothSphere(Vec3(-0.45f, -0.65f, 0.2f), 0.3f, 5, 7, 0));
    Scene scene(d);
    WalkStats ws;
    std::array<PathVertex, kMaxPathVertices> y, z;
    PathVertex cam = cameraEndpoint(scene, reg::kNone);
    int checkedPaths = 0, grazingPaths = 0;
    // Russian roulette (path.h) from the first bounce, from the second (the densities of steps
    // from either walk's first vertex carry no continuation probability, the others do), and never.
    for (int rrDepth : {1, 2, 100})
    for (bool merging : {false, true}) {
        MisConfig cfg{TechniqueSet::Bidirectional, merging, kPi * 0.01f * 0.01f, 64.f};
        INFO("rr depth " << rrDepth << (merging ? ", merging" : ""));
        for (uint64_t i = 0; i < 1000; ++i) {
            Rng rng(i, merging);
            int ny = lightWalk(scene, reg::kNone, rng, 5, rrDepth, y.data(), ws);
            int nz = cameraWalk(scene, reg::kNone, Vec2(rng.uniform() * 8, rng.uniform() * 8), rng, 5, rrDepth, z.data(), ws);
            for (int s = 1; s <= ny; ++s)
                for (int t = 1; t <= nz; ++t) {
                    Connection c;
                    const PathVertex* zz = t == 1 ? &cam : z.data();
                    if (t == 1 && s == 1) continue;
                    if (!connect(scene, reg::kNone, y.data(), s, zz, t, rrDepth, c, ws)) continue;
                    std::vector<PathVertex> x(y.begin(), y.begin() + s);
                    for (int j = t - 1; j >= 0; --j) x.push_back(t == 1 ? cam : z[j]);
                    PathPdfs bf = bruteForcePdfs(scene, x, rrDepth);
                    REQUIRE(c.pdfs.n == bf.n);
                    // Where a direction is grazing enough that shading and geometric normals
                    // disagree about its side, evaluation gives 0 while the walk kept its sampled
                    // density. Such paths are counted (they must stay rare) and skipped.
                    bool grazing = false;
                    for (int k = 0; k < bf.n; ++k)
                        grazing |= (bf.fromLight[k] == 0.f && c.pdfs.fromLight[k] != 0.f && !bf.delta[k]) ||
                                   (bf.fromCamera[k] == 0.f && c.pdfs.fromCamera[k] != 0.f && !bf.delta[k]);
                    if (grazing) {
                        ++grazingPaths;
                        continue;
                    }
                    for (int k = 0; k < bf.n; ++k) {
                        INFO("s=" << s << " t=" << t << " vertex " << k);
                        // Gathered values can be 0 where a walk stopped (remapped to 1 by MIS);
                        // they matter only for techniques that are not valid for this path.
                        if (c.pdfs.fromLight[k] != 0.f)
                            CHECK(c.pdfs.fromLight[k] == Approx(bf.fromLight[k]).epsilon(2e-3).margin(1e-12));
                        if (c.pdfs.fromCamera[k] != 0.f)
                            CHECK(c.pdfs.fromCamera[k] == Approx(bf.fromCamera[k]).epsilon(2e-3).margin(1e-12));
                    }
                    // The fast (gathered) weight equals the brute-force one.
                    CHECK(misWeight(c.pdfs, s, cfg) == Approx(misWeight(bf, s, cfg)).epsilon(1e-3).margin(1e-5));
                    // All techniques able to sample this path, weighted on the same pdfs, sum to 1.
                    double sum = 0;
                    for (int k = 0; k <= bf.n; ++k) {
                        bool valid = allowsTechnique(cfg.set, k, bf.n - k) &&
                                     (k == 0 ? bf.lightHittable : k < bf.n && !bf.delta[k - 1] && !bf.delta[k]);
                        if (valid) sum += misWeight(bf, k, cfg);
                        if (merging && k >= 1 && k <= bf.n - 2 && !bf.delta[k]) sum += misWeightMerge(bf, k, cfg);
                    }
                    CHECK(sum == Approx(1.0).margin(1e-4));
                    ++checkedPaths;
                }
        }
    }
    CHECK(checkedPaths > 1000);
    CHECK(grazingPaths * 1000 < checkedPaths);
}

namespace {
// The GGX Cornell box with a mirror sphere: paths with delta vertices for the fast-form tests.
SceneDesc boxWithMirrorSphere() {
    SceneDesc d = cornellBox(8, ggx());
    d.bsdfs.push_back(makeConductor(Color(0.2f), Color(3.f), Color(1.f)));
    d.meshes.push_back(smoothSphere(Vec3(-0.3f, -0.6f, 0.2f), 0.4f, 8, 12, int(d.bsdfs.size()) - 1));
    return d;
}
}  // namespace


// misWeight takes a closed form for the path tracer's two techniques; it must equal the plain sum
// over techniques (misWeightGeneral) for every path length, delta pattern, hittability and
// density (zero densities, i.e. delta vertices, included).
TEST_CASE("MIS: the path tracer's closed-form weights equal the plain sum", "[pt][mis]") {
    Rng rng(5, 9);
    const MisConfig cfg{TechniqueSet::PathTracer};
    int checked = 0, nonTrivial = 0;
    for (int trial = 0; trial < 20000; ++trial) {
        PathPdfs p;
        p.n = 2 + int(rng.uniform() * 8.f);
        for (int i = 0; i < p.n; ++i) {
            // densities over 12 decades, sometimes 0 (an entry a walk could not fill)
            p.fromLight[i] = rng.uniform() < 0.1f ? 0.f : std::pow(10.f, 12.f * rng.uniform() - 6.f);
            p.fromCamera[i] = rng.uniform() < 0.1f ? 0.f : std::pow(10.f, 12.f * rng.uniform() - 6.f);
            p.delta[i] = rng.uniform() < 0.2f;
        }
        p.lightHittable = rng.uniform() < 0.7f;
        for (int s = 0; s <= 1; ++s) {
            float fast = misWeight(p, s, cfg), plain = misWeightGeneral(p, s, cfg);
            CHECK(fast == Approx(plain).epsilon(1e-6).margin(1e-30));
            ++checked;
            nonTrivial += plain > 0.f && plain < 1.f;
        }
    }
    CHECK(checked == 40000);
    CHECK(nonTrivial > 10000);  // most cases compare two valid techniques, not just 0 or 1
}

// misWeight takes BPT's and VCM's own loops (sumBidirectional in path.cpp): the same operations as
// the plain sum, so the same weights bit for bit, for every path length (up to the longest), delta
// pattern, hittability and density (zeros included), merge's precomputed sums, and every s.
TEST_CASE("MIS: BPT's and VCM's own loops equal the plain sum bit for bit", "[bpt][vcm][mis]") {
    Rng rng(6, 9);
    int checked = 0, nonTrivial = 0, scaledChecked = 0, mergesChecked = 0;
    for (int trial = 0; trial < 20000; ++trial) {
        const MisConfig cfg{TechniqueSet::Bidirectional, trial % 2 == 1, 1e-4f, 65536.f};
        PathPdfs p;
        p.n = 2 + int(rng.uniform() * float(trial % 10 == 0 ? kMaxPathVertices - 2 : 10));
        for (int i = 0; i < p.n; ++i) {
            // densities over 12 decades, sometimes 0 (an entry a walk could not fill)
            p.fromLight[i] = rng.uniform() < 0.1f ? 0.f : std::pow(10.f, 12.f * rng.uniform() - 6.f);
            p.fromCamera[i] = rng.uniform() < 0.1f ? 0.f : std::pow(10.f, 12.f * rng.uniform() - 6.f);
            p.delta[i] = rng.uniform() < 0.2f;
        }
        p.lightHittable = rng.uniform() < 0.7f;
        // A regularised path's per-technique factors (regularizer.h (2)) on every third path: over
        // 8 decades, 0 on a fifth of the techniques (they do not count).
        p.perTechnique = trial % 3 == 2;
        for (int k = 0; k <= p.n && p.perTechnique; ++k) {
            p.connectionScale[k] = rng.uniform() < 0.2f ? 0.f : std::pow(10.f, 8.f * rng.uniform() - 4.f);
            p.mergeScale[k] = rng.uniform() < 0.2f ? 0.f : std::pow(10.f, 8.f * rng.uniform() - 4.f);
        }
        // A merge's precomputed sums (fast forms), sometimes; without merging too (BPT's loop is
        // taken only without them: the plain sum adds them).
        p.belowBase = rng.uniform() < 0.3f ? std::pow(10.0, 6.0 * rng.uniform() - 3.0) : -1.0;
        p.aboveBase = rng.uniform() < 0.3f ? std::pow(10.0, 6.0 * rng.uniform() - 3.0) : -1.0;
        for (int s = 0; s < p.n; ++s) {
            const float fast = misWeight(p, s, cfg), plain = misWeightGeneral(p, s, cfg);
            INFO("n " << p.n << " s " << s << " merging " << cfg.merging << " scaled " << p.perTechnique);
            REQUIRE(std::memcmp(&fast, &plain, sizeof(float)) == 0);
            ++checked;
            nonTrivial += plain > 0.f && plain < 1.f;
            scaledChecked += p.perTechnique && plain > 0.f && plain < 1.f;
            if (cfg.merging && s >= 1 && s + 1 < p.n) {  // the merge at x_s, from the same sum
                const float fastMerge = misWeightMerge(p, s, cfg), plainMerge = misWeightMergeGeneral(p, s, cfg);
                REQUIRE(std::memcmp(&fastMerge, &plainMerge, sizeof(float)) == 0);
                mergesChecked += plainMerge > 0.f && plainMerge < 1.f;
            }
        }
    }
    CHECK(checked > 100000);
    CHECK(nonTrivial > 50000);
    CHECK(scaledChecked > 10000);
    CHECK(mergesChecked > 10000);
}

// The path tracer's fast forms: its camera walk computes densities at emitter hits only
// (WalkPdfs::EmitterHits) and its connections gather pdf entries 0..misReadLimit only. Both must
// give exactly the weights of a full walk with a full gather, for NEE (s = 1) and emitter hits (s = 0).
TEST_CASE("MIS: the path tracer's limited walk and gather give the full-gather weights", "[pt][mis]") {
    Scene scene(boxWithMirrorSphere());
    WalkStats ws;
    std::array<PathVertex, kMaxPathVertices> zFull, zFast;
    const MisConfig cfg{TechniqueSet::PathTracer};
    const int limit = misReadLimit(cfg);
    REQUIRE(limit < kMaxPathVertices);
    int neeChecked = 0, hitsChecked = 0;
    // Entries a limited gather does not fill are poisoned, so reading one shows.
    auto poison = [](PathPdfs& p) {
        p.fromLight.fill(std::numeric_limits<float>::quiet_NaN());
        p.fromCamera.fill(std::numeric_limits<float>::quiet_NaN());
        p.delta.fill(true);
    };
    for (uint64_t i = 0; i < 4000; ++i) {
        Vec2 raster(float(i % 8) + 0.5f, float((i / 8) % 8) + 0.5f);
        Rng r1(i, 7), r2(i, 7);
        int n1 = cameraWalk(scene, reg::kNone, raster, r1, 9, 100, zFull.data(), ws, WalkPdfs::All);
        int n2 = cameraWalk(scene, reg::kNone, raster, r2, 9, 100, zFast.data(), ws, WalkPdfs::EmitterHits);
        REQUIRE(n1 == n2);  // the same random numbers, the same path
        for (int t = 2; t <= n1; ++t) {
            INFO("path " << i << " t=" << t);
            if (zFull[t - 1].light) {
                PathPdfs a, b;
                poison(b);
                Color ca = emitterHit(scene, reg::kNone, zFull.data(), t, 100, a);
                Color cb = emitterHit(scene, reg::kNone, zFast.data(), t, 100, b, limit);
                REQUIRE(ca == cb);
                if (!isBlack(ca)) {
                    CHECK(misWeight(a, 0, cfg) == misWeight(b, 0, cfg));
                    ++hitsChecked;
                }
            }
            Rng lr(i * 131 + t, 9);
            PathVertex light;
            if (!sampleLightVertex(scene, reg::kNone, zFull[t - 1].p, lr, light)) continue;
            Connection a, b;
            poison(b.pdfs);
            bool okA = connect(scene, reg::kNone, &light, 1, zFull.data(), t, 100, a, ws);
            bool okB = connect(scene, reg::kNone, &light, 1, zFast.data(), t, 100, b, ws, limit);
            REQUIRE(okA == okB);
            // The path tracer's call: the same routine specialised for its known ends.
            if (!zFast[t - 1].infinite && zFast[t - 1].connectible()) {
                Connection c;
                poison(c.pdfs);
                bool okC =
                    connect<ConnectEnds::LightToSurface>(scene, reg::kNone, &light, 1, zFast.data(), t, 100, c, ws, limit);
                REQUIRE(okC == okB);
                if (okC) {
                    CHECK(c.contribution == b.contribution);
                    CHECK(misWeight(c.pdfs, 1, TechniqueSet::PathTracer) == misWeight(b.pdfs, 1, cfg));
                }
            }
            if (!okA) continue;
            CHECK(misWeight(a.pdfs, 1, cfg) == misWeight(b.pdfs, 1, cfg));
            CHECK(std::isfinite(misWeight(b.pdfs, 1, cfg)));
            ++neeChecked;
        }
    }
    CHECK(neeChecked > 3000);
    CHECK(hitsChecked > 100);
}

TEST_CASE("no integrator produces NaN, Inf or negative pixels with point/spot lights, mirrors, glass",
          "[pt][bpt]") {
    for (BxdfPtr m : {makeDielectric(1.5f), makeConductor(Color(0.2f), Color(3.f), Color(1.f)),
                      makeRoughDielectric(MicrofacetType::GGX, 1e-4f, 1e-4f, 1.f),
                      makeRoughConductor(MicrofacetType::Beckmann, 0.01f, 0.01f, Color(0.2f), Color(3.f), Color(1.f))}) {
        SceneDesc d = cornellBoxPointLight(16, m);
        EmitterDesc spot;
        spot.type = EmitterType::Spot;
        spot.position = Vec3(0, 0.8f, 0);
        spot.direction = Vec3(0, -1, 0);
        spot.value = Color(3.f);
        d.emitters.push_back(spot);
        for (std::string integ : {"pt", "bpt", "lt", "vcm", "ppm"}) {
            RenderSettings s;
            s.integrator = integ;
            s.spp = 4;
            s.maxDepth = 6;
            Scene scene(d);
            RenderStats st;
            s.quiet = true;
            Image img = renderImage(scene, s, st);
            INFO(integ);
            for (const Color& c : img.pixels) {
                REQUIRE(isFinite(c));
                REQUIRE(c.x >= 0.f);
                REQUIRE(c.y >= 0.f);
                REQUIRE(c.z >= 0.f);
            }
            CHECK(st.invalidSamples == 0);
        }
    }
}

TEST_CASE("bidirectional images are bit-identical for 1 and 2 threads", "[bpt][determinism]") {
    SceneDesc d = cornellBox(24, ggx());
    for (std::string integ : {"bpt", "vcm", "lt", "ppm"}) {
        RenderSettings s;
        s.integrator = integ;
        s.spp = 2;
        s.threads = 1;
        Image a = renderDesc(d, s);
        s.threads = 2;
        Image b = renderDesc(d, s);
        INFO(integ);
        CHECK(std::memcmp(a.pixels.data(), b.pixels.data(), a.pixels.size() * sizeof(Color)) == 0);
    }
}

namespace {

// A light-path store of `count` light subpaths (at most 5 segments), with fixed seeds, Russian
// roulette from the first bounce (rrDepth 1: the fast merge forms' case, path.h).
LightPathStore lightPaths(const Scene& scene, int count, uint64_t stream, int rrDepth = 1) {
    WalkStats ws;
    LightPathStore store;
    store.begin(size_t(count), true);
    for (uint64_t j = 0; j < uint64_t(count); ++j) {
        Rng rng(j, stream);
        LightPathStore::Chunk& chunk = store.chunk(j / LightPathStore::kChunkPaths);
        chunk.commit(lightWalk(scene, reg::kNone, rng, 6, rrDepth, chunk.next(), ws));
    }
    return store;
}

}  // namespace

TEST_CASE("MIS: the fast merge weights (per-light-vertex partial sums) equal the gathered form", "[vcm][mis]") {
    Scene scene(boxWithMirrorSphere());
    WalkStats ws;
    MisConfig cfg{TechniqueSet::Bidirectional, true, kPi * 0.05f * 0.05f, 256.f};
    LightPathStore store = lightPaths(scene, 256, 77);
    std::array<PathVertex, kMaxPathVertices> z;
    HashGrid grid;
    grid.build(store, 0.05f, cfg);
    REQUIRE(grid.size() > 100);
    int merges = 0, deepMerges = 0;  // deep: the camera-side sum is used (t >= 3)
    for (uint64_t i = 0; i < 2000; ++i) {
        Rng rng(i, 78);
        int nz = cameraWalk(scene, reg::kNone, Vec2(rng.uniform() * 8, rng.uniform() * 8), rng, 6, 1, z.data(), ws);
        std::array<double, kMaxPathVertices> cameraSums;
        double prev = 0.0;
        for (int m = 0; m + 1 < nz; ++m) cameraSums[m] = prev = cameraPrefixSum(z.data(), m, cfg, prev);
        for (int t = 2; t <= nz; ++t) {
            if (!z[t - 1].connectible() || z[t - 1].infinite) continue;
            grid.query(z[t - 1].p, [&](const Photon& ph) {
                Connection gathered, fast, fastBoth;
                const VertexPdfs* pdfs = store.pdfs(ph.path);
                bool a = merge(reg::kNone, ph, nullptr, pdfs, z.data(), t, 1, gathered);
                bool b = merge(reg::kNone, ph, nullptr, nullptr, z.data(), t, 1, fast);
                bool c = merge(reg::kNone, ph, nullptr, nullptr, z.data(), t, 1, fastBoth, cameraSums.data());
                REQUIRE(a == b);
                REQUIRE(a == c);
                if (!a) return;
                float wg = misWeightMerge(gathered.pdfs, ph.depth, cfg), wf = misWeightMerge(fast.pdfs, ph.depth, cfg);
                float wb = misWeightMerge(fastBoth.pdfs, ph.depth, cfg);
                INFO("photon depth " << int(ph.depth) << " t " << t);
                CHECK(wf == Approx(wg).epsilon(1e-4).margin(1e-7));
                CHECK(wb == Approx(wg).epsilon(1e-4).margin(1e-7));  // light and camera sides both fast
                CHECK(fast.contribution == gathered.contribution);
                ++merges;
                if (t >= 3) ++deepMerges;
            });
        }
    }
    CHECK(merges > 500);
    CHECK(deepMerges > 200);
}

// With rr_depth above 1 merges gather their densities (the fast forms assume 1: path.h), and the
// light side's reverse densities get the roulette's factor by the merged path's length. Against the
// from-scratch densities of the merged path x = y[0..i-1], z[t-1..0]: every entry the gathers give
// that does not involve the merge vertex (its own and its neighbours' are evaluated at the photon,
// a radius away from z[t-1]).
TEST_CASE("MIS: gathered merge densities equal a from-scratch evaluation with rr_depth above 1", "[vcm][mis]") {
    Scene scene(boxWithMirrorSphere());
    WalkStats ws;
    MisConfig cfg{TechniqueSet::Bidirectional, true, kPi * 0.05f * 0.05f, 256.f};
    std::array<PathVertex, kMaxPathVertices> z;
    // (with rr_depth 2 every entry compared carries the factor: the merged paths are too short
    // for one without it away from the merge vertex)
    for (int rrDepth : {3, 4}) {
        LightPathStore store = lightPaths(scene, 256, 77, rrDepth);
        HashGrid grid;
        grid.build(store, 0.05f, cfg);
        int checked = 0, withFactor = 0;
        for (uint64_t i = 0; i < 2000; ++i) {
            Rng rng(i, 79);
            int nz = cameraWalk(scene, reg::kNone, Vec2(rng.uniform() * 8, rng.uniform() * 8), rng, 6, rrDepth, z.data(), ws);
            for (int t = 2; t <= nz; ++t) {
                if (!z[t - 1].connectible() || z[t - 1].infinite) continue;
                grid.query(z[t - 1].p, [&](const Photon& ph) {
                    Connection c;
                    const PathVertex* y = store.path(ph.path);
                    if (!merge(reg::kNone, ph, y, store.pdfs(ph.path), z.data(), t, rrDepth, c)) return;
                    const int m = ph.depth;
                    std::vector<PathVertex> x(y, y + m);
                    for (int j = t - 1; j >= 0; --j) x.push_back(z[j]);
                    const PathPdfs bf = bruteForcePdfs(scene, x, rrDepth);
                    REQUIRE(c.pdfs.n == bf.n);
                    INFO("rr depth " << rrDepth << " photon depth " << m << " t " << t);
                    // light side: fromCamera of x_k, sampled at x_{k+1} from x_{k+2} (which is y[m],
                    // the photon, not z[t-1], for k = m - 2: the merge's approximation)
                    for (int k = 0; k + 3 <= m; ++k)
                        if (c.pdfs.fromCamera[k] != 0.f && bf.fromCamera[k] != 0.f) {
                            CHECK(c.pdfs.fromCamera[k] == Approx(bf.fromCamera[k]).epsilon(2e-3));
                            ++checked;
                            withFactor += bf.n - 2 - k >= rrDepth;
                        }
                    for (int k = m + 2; k < bf.n; ++k)  // camera side: fromLight sampled from x_{k-1}
                        if (c.pdfs.fromLight[k] != 0.f && bf.fromLight[k] != 0.f) {
                            CHECK(c.pdfs.fromLight[k] == Approx(bf.fromLight[k]).epsilon(2e-3));
                            ++checked;
                            withFactor += k - 1 >= rrDepth;
                        }
                });
            }
        }
        INFO("rr depth " << rrDepth << ": " << checked << " densities, " << withFactor << " with the roulette's factor");
        CHECK(checked > 500);
        CHECK(withFactor > 100);
        CHECK(checked - withFactor > 100);
    }
}

// The grid query (hashed cells, compact positions, staged prefetching) finds exactly the light
// vertices a merge can use within the radius, each once: compared with a brute-force search.
TEST_CASE("the photon grid finds exactly the usable light vertices within the radius", "[vcm]") {
    SceneDesc d = cornellBox(8, ggx());
    Scene scene(d);
    WalkStats ws;
    MisConfig cfg{TechniqueSet::Bidirectional, true, 0.f, 512.f};
    LightPathStore store = lightPaths(scene, 1500, 5);  // (two chunks)
    REQUIRE(store.chunks() == 2);
    // Every light vertex, and its (path, depth) as a key.
    std::vector<PathVertex> v;
    std::vector<uint64_t> key;
    for (size_t j = 0; j < store.paths(); ++j)
        for (int i = 0; i < store.length(j); ++i) {
            v.push_back(store.path(j)[i]);
            key.push_back(uint64_t(j) << 8 | uint64_t(i));
        }
    for (float radius : {0.02f, 0.1f, 0.4f}) {
        HashGrid grid, grid1, grid61;
        grid.build(store, radius, cfg);
        // The build's counting sort splits the cells into one range per thread: the same grid,
        // photon for photon in the same order, with 1 and 61 threads (61 ranges: boundary cells hold photons).
        tbb::task_arena(1).execute([&] { grid1.build(store, radius, cfg); });
        tbb::task_arena(61).execute([&] { grid61.build(store, radius, cfg); });
        size_t found = 0;
        for (int q = 0; q < 300; ++q) {
            Rng rng(q, 6);
            Vec3 p = v[size_t(rng.uniform() * float(v.size()))].p + (rng.uniform() - 0.5f) * radius * Vec3(1, -0.5f, 0.7f);
            std::vector<uint64_t> expected, got;
            for (size_t k = 0; k < v.size(); ++k) {
                bool usable = v[k].depth >= 1 && v[k].kind == VertexKind::Surface && v[k].connectible();
                Vec3 dd = v[k].p - p;
                if (usable && glm::dot(dd, dd) <= radius * radius) expected.push_back(key[k]);
            }
            std::vector<uint64_t> got1, got61;
            grid1.query(p, [&](const Photon& ph) { got1.push_back(uint64_t(ph.path) << 8 | ph.depth); });
            grid61.query(p, [&](const Photon& ph) { got61.push_back(uint64_t(ph.path) << 8 | ph.depth); });
            grid.query(p, [&](const Photon& ph) {
                got.push_back(uint64_t(ph.path) << 8 | ph.depth);
                // The record is that vertex's.
                const PathVertex& y = store.path(ph.path)[ph.depth];
                CHECK(ph.wo == y.wo);
                CHECK(ph.prevP == store.path(ph.path)[ph.depth - 1].p);
            });
            CHECK(got1 == got);  // (in query order)
            CHECK(got61 == got);
            std::sort(got.begin(), got.end());
            INFO("radius " << radius << " query " << q);
            CHECK(got == expected);
            found += got.size();
        }
        CHECK(found > 100);
    }
}

// The roulette (path.h, "Russian roulette"): from depth rr_depth a walk leaves a vertex with the
// material's continuation probability (here the albedo 0.5 of a closed sphere) and divides the
// throughput by it, so from there on the throughput stays exactly what it was (R / c = 1: no path
// is amplified). The number K of surface vertices of a walk is then rr_depth - 1 plus a geometric
// variable of mean 1 / (1 - 0.5) = 2 and variance 2: mean rr_depth + 1. 20,000 walks: standard
// error 0.01; checked within 5 standard errors (two-sided normal tail 6e-7). The former
// throughput-based roulette (continue with min(0.95, max(beta)), divide) fails it.
TEST_CASE("the roulette continues with the material's albedo from rr_depth and keeps throughput", "[bpt][roulette]") {
    Scene scene(furnace(8, 0.5f));
    WalkStats ws;
    std::array<PathVertex, kMaxPathVertices> z;
    for (int rrDepth : {1, 3, 5}) {
        std::vector<double> k;
        for (uint64_t i = 0; i < 20000; ++i) {
            Rng rng(i, uint64_t(rrDepth));
            const int n = cameraWalk(scene, reg::kNone, Vec2(4.f), rng, kMaxPathVertices, rrDepth, z.data(), ws);
            REQUIRE(n < kMaxPathVertices);  // stopped by the roulette, not by the length limit
            // Bounces before rr_depth multiply by R, later ones by R / c = 1.
            for (int j = 1; j < n; ++j) REQUIRE(z[j].beta == Color(std::pow(0.5f, float(std::min(j, rrDepth) - 1))));
            k.push_back(double(n - 1));
        }
        const SampleStats st = sampleStats(k);
        INFO("rr_depth " << rrDepth << ": mean " << st.mean << " +- " << std::sqrt(st.var / st.k));
        CHECK(std::abs(st.mean - (rrDepth + 1)) < 5.0 * std::sqrt(2.0 / 20000.0));
        CHECK(*std::min_element(k.begin(), k.end()) == double(rrDepth));
    }
}
