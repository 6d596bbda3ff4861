// JG19's sampler quality heuristic (Eqs. 17-18, jg19.h (2)) and path diffusion heuristic (Eqs.
// 19-21, jg19.h (4)): their values against hand computation, one choice per path with MIS weights
// equal to a brute-force evaluation, no light counted twice, and the surface curvature they read.
#include <catch2/catch.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>
#include "core/loader.h"
#include "integrators/integrator.h"
#include "integrators/transport/light_paths.h"
#include "integrators/transport/path_templates.h"
#include "process.h"
#include "jg19_weights.h"
#include "regularizer_paths.h"
#include "scene_builders.h"

using namespace lt;
using namespace lt::test;

// ---- The sampler quality heuristic (jg19.h (2)) -------------------------------------------------

TEST_CASE("JG19 quality heuristic: q (Eq. 17) and the regularised vertex equal hand computation", "[jg19][quality]") {
    // Constructed paths on a line (x_0 the light at the origin, the camera at z = 5), so every
    // length and cosine is known: q = min_k rho_bar_k rho_bar_{k+1} (d_path / d_k)^2 over the
    // integrator's connections; regularised iff q >= tau^2 (Eq. 18), then at the connection whose
    // term is smallest under the bound. tau is set just below and just above sqrt(q) (a factor
    // 1e-3 either way) to pin the threshold; rho_bar of the BSDFs from Bxdf::valueBound (tested in
    // test_value_bound.cpp), of the camera from its importance at the image centre.
    Scene scene(mixedScene(16));
    const double camBound = scene.camera().directionPdf(scene.camera().forward()).value;
    const BxdfPtr diffuse = makeDiffuse(Color(0.5f)), glass = makeDielectric(1.5f);
    const BxdfPtr glossy = makeRoughConductor(MicrofacetType::GGX, 0.1f, 0.1f, Color(0.2f), Color(3.f), Color(1.f));
    const double rhoD = 0.5 / kPi, rhoG = glossy->valueBound(kRadianceContext);
    Light point;
    point.type = LightType::Point;
    Light area;
    area.type = LightType::Area;
    area.area = 1e-8f;  // (a hit probability of ~3e-5 from the glossy vertex: the hit is not the best)
    const MisConfig bpt{TechniqueSet::Bidirectional}, pt{TechniqueSet::PathTracer};
    // Every choice also made by the plain loop over the path (select() may answer from the
    // subpaths' running minima): the same answer, vertices and bounds.
    auto selectBoth = [](const reg::Jg19& jg, Technique& tech) {
        Technique loop = tech;
        const bool answer = jg.select(tech);
        CHECK(jg.selectByLoop(loop) == answer);
        for (int m = 0; m < 2; ++m) {
            CHECK(loop.regularised[m] == tech.regularised[m]);
            CHECK(loop.bound[m] == tech.bound[m]);
        }
        return answer;
    };

    SECTION("point light in glass, L S D E: BPT samples it (light tracing), PT regularises the glass") {
        HandPath h = HandPath::onAxis(point, {{1.f, glass.get()}, {4.9f, diffuse.get()}});
        // BPT: the only finite term is light tracing's, D-E: rho_D c (5 / 0.1)^2 (~ 760: the
        // diffuse vertex close to the camera makes light tracing a poor sampler). Under tau ~ 27
        // the glass's bound is <= tau, and S-D's term, <= tau rho_D (5 / 3.9)^2 ~ 7, is the smallest.
        const double q = rhoD * camBound * sqr(5.0 / (5.0 - double(4.9f)));
        for (double f : {0.999, 1.001}) {
            const reg::Jg19 jg = fixedTau(std::sqrt(q) * f, scene, bpt);
            Technique lt = h.technique(jg, 3);  // s = 3, t = 1
            const bool contributes = selectBoth(jg, lt);
            if (f < 1.0) {  // q >= tau^2: regularised at the glass, x_1 (D is diffuse: unchanged)
                CHECK(lt.regularised[0] == 1);
                CHECK(lt.regularised[1] == -1);
                CHECK(!contributes);  // light tracing walks through the glass: weight 0
                Technique sd = h.technique(jg, 2);  // the connection S-D
                CHECK(selectBoth(jg, sd));
            } else {
                CHECK(contributes);
                CHECK(lt.regularised[0] == -1);
                CHECK(lt.regularised[1] == -1);
                Technique nee = h.technique(jg, 1);
                CHECK(!selectBoth(jg, nee));  // connecting at the still-delta glass: nothing to add
            }
        }
        // PT: one connection, L-S, infinite: the glass x_1 is regularised, NEE contributes.
        const reg::Jg19 jg = fixedTau(30.0, scene, pt);
        Technique nee = h.technique(jg, 1);
        CHECK(selectBoth(jg, nee));
        CHECK(nee.regularised[0] == 1);
        CHECK(nee.regularised[1] == -1);
    }
    SECTION("point light seen through glass, L S S E: VCM merges at a smooth vertex made rough") {
        HandPath h = HandPath::onAxis(point, {{0.01f, glass.get()}, {3.f, glass.get()}}, 3.01f);
        // Every plain term is infinite (both glass vertices are deltas): q = inf, something is
        // regularised. Bounded terms (d_path = 3.01, glass bounds ~tau = 30): NEE (1 / 4 pi) tau
        // (3.01 / 0.01)^2 ~ 2e5, light tracing c tau 301^2 ~ 5e6, S-S tau^2 (3.01 / 2.99)^2 ~ 912,
        // the merges at either glass vertex tau 3.01^2 / (N pi r^2) ~ 27 with N pi r^2 = 10. The
        // merge at x_1 (first of the tie) wins: only x_1 is regularised. Without merging, S-S
        // regularises both.
        const MisConfig vcm{TechniqueSet::Bidirectional, true, 10.f / 256.f, 256.f};
        const reg::Jg19 jg = fixedTau(30.0, scene, vcm);
        const Photon photon{};
        Technique m = h.technique(jg, 1);  // z = E, S (x_2), S (x_1): the merge at x_1
        m.s = 2;
        m.photon = &photon;
        CHECK(selectBoth(jg, m));
        CHECK(m.regularised[0] == 1);
        CHECK(m.regularised[1] == -1);
        Technique nee = h.technique(jg, 1), ss = h.technique(jg, 2), lt = h.technique(jg, 3);
        CHECK(selectBoth(jg, nee));  // its ends contain x_1
        CHECK(nee.regularised[0] == 1);
        CHECK(!selectBoth(jg, ss));  // its ends contain x_1, but x_2 stays a delta: its value there is 0
        CHECK(ss.regularised[0] == 1);
        CHECK(!selectBoth(jg, lt));  // light tracing walks through x_1
        const reg::Jg19 jgBpt = fixedTau(30.0, scene, bpt);
        Technique ssBpt = h.technique(jgBpt, 2);
        CHECK(selectBoth(jgBpt, ssBpt));
        CHECK(ssBpt.regularised[0] == 1);
        CHECK(ssBpt.regularised[1] == 2);
        Technique neeBpt = h.technique(jgBpt, 1);
        CHECK(!selectBoth(jgBpt, neeBpt));  // x_2 is regularised, NEE walks through it
    }
    SECTION("glossy vertex lit by a small area light, L G E: NEE, light tracing and the emitter hit") {
        HandPath h;
        h.add(VertexKind::Light, Vec3(0, 0, 0), nullptr, &area, Vec3(0, 0, 1));
        h.add(VertexKind::Surface, Vec3(0, 0, 1), glossy.get(), nullptr, Vec3(0, 0, -1));
        h.add(VertexKind::Camera, Vec3(0, 0, 5), nullptr);
        // d_path = 5; L-G: (1/pi) rho_G 5^2; G-E: rho_G c (5/4)^2; hit: 1 / min(1, rho_G A cos / 1^2).
        const double nee = kInvPi * rhoG * 25.0, lt = rhoG * camBound * 25.0 / 16.0;
        const double hit = 1.0 / std::min(1.0, rhoG * 1e-8);
        for (const MisConfig& cfg : {bpt, pt}) {
            const double q = cfg.set == TechniqueSet::PathTracer ? std::min(nee, hit) : std::min({nee, lt, hit});
            INFO("set " << int(cfg.set) << " q " << q << " (nee " << nee << ", lt " << lt << ", hit " << hit << ")");
            for (double f : {0.999, 1.001}) {
                const reg::Jg19 jg = fixedTau(std::sqrt(q) * f, scene, cfg);
                Technique t1 = h.technique(jg, 1);
                const bool contributes = selectBoth(jg, t1);
                if (f > 1.0) {
                    CHECK(contributes);
                    CHECK(t1.regularised[0] == -1);
                } else {
                    // Regularised at G (x_1), the connection with the smaller bounded term.
                    const bool chosen = t1.regularised[0] == 1 || t1.regularised[1] == 1;
                    CHECK(chosen);
                    CHECK(contributes);  // NEE's ends contain x_1
                    Technique hitTech = h.technique(jg, 0);
                    CHECK(!selectBoth(jg, hitTech));  // the emitter hit walks through x_1
                }
            }
        }
    }
}

namespace {

Scene loadScene64(const std::string& file) {
    return Scene(loadScene(std::string(LT_SOURCE_DIR) + "/scenes/" + file, {{"res", "64"}}));
}

}  // namespace

TEST_CASE("JG19 with the quality heuristic counts no light twice (BPT, VCM, PT against each other)", "[jg19][quality][render]") {
    SECTION("point light in glass: BPT and VCM render the room as the unregularised VCM") {
        // Light tracing samples L S D E well (q ~ 1 << tau^2), so the room is not regularised and
        // only noise separates BPT+JG19 from the unregularised VCM reference. Without the heuristic
        // BPT's floor was +71% (the sharp caustic of light tracing plus the blurred one of the
        // connections at the glass). Measured, floor rows 44-63 at 64 x 64, max depth 8: VCM 128 spp
        // 0.7710; BPT+JG19 32 spp, seeds 1-3: 0.7765, 0.7713, 0.7706 (+0.7% at most). Bound: 3%.
        Scene scene = loadScene64("cornell-box-point-in-glass.xml");
        RenderStats st;
        RenderSettings ref = settingsFor("vcm", 128);
        ref.maxDepth = 8;
        const double floorRef = cropMean(renderImage(scene, ref, st), 64, 0, 44, 64, 20);
        for (const char* integrator : {"bpt", "vcm"}) {
            RenderSettings s = settingsFor(integrator, 32);
            s.maxDepth = 8;
            s.seed = 1;
            s.regularizer = "jg19";
            const double floor = cropMean(renderImage(scene, s, st), 64, 0, 44, 64, 20);
            INFO(integrator << ": floor " << floor << ", reference " << floorRef << ", regularised "
                            << st.regularisedContributions << " of " << st.contributions);
            CHECK(std::abs(floor / floorRef - 1.0) < 0.03);
            // The glass seen directly only: measured 5.8% of the contributions (5.9% VCM), most of
            // them light tracing's splats from the glass (every light path leaves the sphere there);
            // about 3.4% before light tracing's counts were included. A regularised room would be most.
            CHECK(st.regularisedContributions < st.contributions / 10);
        }
    }
    SECTION("a point light seen through glass (L S S E): PT and BPT agree") {
        // scenes/hard/specular-point-view.xml: no unbiased technique samples the imaged light; PT
        // regularises it at NEE, BPT at the one connection the heuristic picks. Without the
        // heuristic BPT's disc was twice PT's (14.8 against 7.4: two regularised techniques that
        // cannot produce each other's paths, each with weight 1). Measured, centre 20 x 20 of
        // 64 x 64, 16 spp: PT 8.005 / 7.995, BPT 8.008 / 7.996 (seeds 1, 2). Bound: 2%.
        Scene scene = loadScene64("hard/specular-point-view.xml");
        RenderStats st;
        double disc[2];
        for (int i = 0; i < 2; ++i) {
            RenderSettings s = settingsFor(i ? "bpt" : "pt", 16);
            s.maxDepth = 12;
            s.seed = 1;
            s.regularizer = "jg19";
            disc[i] = cropMean(renderImage(scene, s, st), 64, 22, 22, 20, 20);
            CHECK(st.regularisedContributions > 0);
        }
        INFO("PT " << disc[0] << ", BPT " << disc[1]);
        CHECK(disc[0] > 1.0);  // the imaged light is there (0.24 without a regulariser)
        CHECK(std::abs(disc[1] / disc[0] - 1.0) < 0.02);
    }
    SECTION("an area-light caustic that BPT samples well stays unregularised") {
        // scenes/cornell-box-glass-sphere.xml (area light, smooth glass): light tracing samples the
        // caustic, so q < tau^2 on (nearly) every path: BPT+JG19 equals BPT to noise. With
        // --reg-quality off the same render is +16% brighter overall with fireflies (measured at
        // 64 x 64, 32 spp: mean 0.1462 against 0.1260, relMSE 2.45 against 0.0137), which this
        // section also checks, so that the heuristic is what keeps the caustic.
        Scene scene = loadScene64("cornell-box-glass-sphere.xml");
        RenderStats st;
        RenderSettings plain = settingsFor("bpt", 32);
        const double meanPlain = cropMean(renderImage(scene, plain, st), 64, 0, 0, 64, 64);
        RenderSettings on = plain;
        on.regularizer = "jg19";
        const double meanOn = cropMean(renderImage(scene, on, st), 64, 0, 0, 64, 64);
        INFO("regularised " << st.regularisedContributions << " of " << st.contributions);
        CHECK(st.regularisedContributions < st.contributions / 200);
        CHECK(std::abs(meanOn / meanPlain - 1.0) < 0.01);
        RenderSettings off = on;
        off.regQuality = false;
        const double meanOff = cropMean(renderImage(scene, off, st), 64, 0, 0, 64, 64);
        INFO("means: plain " << meanPlain << ", quality on " << meanOn << ", off " << meanOff);
        CHECK(meanOff > 1.08 * meanPlain);
    }
}

TEST_CASE("JG19 quality heuristic: one choice per path, and MIS weights equal a brute-force evaluation", "[jg19][quality][mis]") {
    // BPT paths (tau = 30, fixed) through the glossy panel, the glass sphere and the mirror ball.
    // For every connected path, each of its techniques (every split of the same vertices into a
    // light and a camera subpath, the records rebuilt as walks write them) makes the same choice
    // of regularised vertices, and returns false exactly when its ends do not contain them: the
    // choice is a function of the path. The weight of the technique that made the path equals the
    // brute force over the techniques containing the chosen vertices, from the path's sampling
    // densities, with specularity at smooth vertices decided from the geometry. Tolerance 2e-3
    // (float against double, as in the Eq. 13 test).
    // A point light inside the glass sphere besides the area light: its paths (L S ...) are the
    // ones no connection samples well, so many are regularised.
    SceneDesc desc = mixedSceneWithPointInGlass(16);
    // With and without the diffusion heuristic: with it, the bound at each chosen vertex (tau over
    // the spread along the path from the camera) is also the same in every split, up to float
    // rounding of the walks' stored spreads (relative 1e-4).
    const bool diffusion = GENERATE(false, true);
    // BPT, and VCM: merges compete in every weight, and the merges of each camera vertex with the
    // light walk's vertices are weighted too, smooth surfaces made rough included (merge radius
    // 0.05, 256 light paths: terms of the order of the connections', so merges are chosen on
    // some paths, a smooth vertex's on the L S ... S E paths of the point light).
    const bool merging = GENERATE(false, true);
    // Smooth vertices as rough GGX lobes, or as cones (--reg-specular cone): the choice and the
    // weights read the bounds, which the cone's 1 / Omega = tau' keeps.
    const reg::SpecularMode specular = GENERATE(reg::SpecularMode::Ggx, reg::SpecularMode::Cone);
    INFO("diffusion " << diffusion << " merging " << merging << " cone " << (specular == reg::SpecularMode::Cone));
    Scene scene(desc);
    WalkStats ws;
    std::array<PathVertex, kMaxPathVertices> y, z;
    const MisConfig cfg{TechniqueSet::Bidirectional, merging, kPi * 0.05f * 0.05f, 256.f};
    // (The cones at tau 30, eps 0.2 rad, catch few connections: 7-29 regularised paths in 1500
    // pairs of walks. At tau 3, eps 0.66 rad.)
    const bool cone = specular == reg::SpecularMode::Cone;
    const reg::Jg19 jg = fixedTau(cone ? 3.0 : 30.0, scene, cfg, diffusion, specular);
    const PathVertex cam = cameraEndpoint(scene, jg);
    int checked = 0, regularisedPaths = 0, splits = 0, merges = 0, smoothMerges = 0, smoothEndRefused = 0;
    double worst = 0.0;
    for (uint64_t i = 0; i < 1500; ++i) {
        Rng rng(i, 57);
        const int ny = lightWalk(scene, jg, rng, 6, 100, y.data(), ws);
        const int nz = cameraWalk(scene, jg, Vec2(rng.uniform() * 16, rng.uniform() * 16), rng, 6, 100, z.data(), ws);
        forEachConnection(scene, jg, y.data(), ny, z.data(), nz, cam, ws, [&](int s, int t, const PathVertex* zz,
                                                                              const Connection& c) {
                Technique own{y.data(), s, zz, t};
                REQUIRE(jg.select(own));
                std::vector<int> R;
                for (int j : own.regularised)
                    if (j >= 0) R.push_back(j);
                regularisedPaths += !R.empty();
                // Every split of the same path.
                HandPath h;
                for (int k = 0; k < s; ++k) h.x.push_back(y[k]);
                for (int k = t - 1; k >= 0; --k) h.x.push_back(zz[k]);
                const int n = s + t;
                for (int k = 0; k < n; ++k) {
                    if (k == 0 && !(y[0].light->isHittable())) continue;
                    Technique other = h.technique(jg, k);
                    const bool contributes = jg.select(other);
                    std::vector<int> Rk;
                    for (int j : other.regularised)
                        if (j >= 0) Rk.push_back(j);
                    INFO("path " << i << " s=" << s << " t=" << t << " split " << k);
                    CHECK(Rk == R);
                    for (int m = 0; m < 2 && Rk == R; ++m) {
                        if (own.regularised[m] < 0) continue;
                        CHECK(std::abs(other.bound[m] - own.bound[m]) <= 1e-4f * own.bound[m]);
                        if (!diffusion) CHECK(own.bound[m] == jg.tau());
                    }
                    bool contains = true;
                    for (int j : R) contains = contains && (j == k - 1 || j == k);
                    // ... and its other end is connectible as it is: a smooth end the choice left
                    // a delta would evaluate to 0, so the technique is refused before its
                    // evaluations and shadow ray.
                    bool evaluable = true;
                    for (int j : {k - 1, k})
                        if (j >= 0 && j < n && std::find(R.begin(), R.end(), j) == R.end() && !h.x[j].connectible())
                            evaluable = false;
                    if (!R.empty()) CHECK(contributes == (contains && evaluable));
                    smoothEndRefused += !R.empty() && contains && !evaluable;
                    ++splits;
                }
                std::vector<const PathVertex*> xs;
                for (int k = 0; k < s; ++k) xs.push_back(&y[k]);
                for (int k = t - 1; k >= 0; --k) xs.push_back(&zz[k]);
                BruteForce bf{{std::move(xs), c.pdfs, cfg, -1, nullptr}, jg, false, true, R};
                const double ours = misWeight(c.pdfs, s, cfg), ref = bf.weight(s);
                INFO("path " << i << " s=" << s << " t=" << t << " ours " << ours << " brute force " << ref);
                CHECK(std::abs(ours - ref) <= 2e-3);
                worst = std::max(worst, std::abs(ours - ref));
                ++checked;
            });
        if (!merging) continue;
        forEachMerge(jg, y.data(), ny, z.data(), nz,
                     [&](int m, int t, const Photon& ph, const Connection& c, std::vector<const PathVertex*> xs) {
                         Technique own{y.data(), m + 1, z.data(), t, &ph};
                         REQUIRE(jg.select(own));
                         std::vector<int> R;
                         for (int j : own.regularised)
                             if (j >= 0) R.push_back(j);
                         BruteForce bf{{std::move(xs), c.pdfs, cfg, m, &y[m]}, jg, false, true, R};
                         const double ours = misWeightMerge(c.pdfs, m, cfg), ref = bf.weight(-1);
                         INFO("path " << i << " merge at " << m << " t=" << t << " ours " << ours << " brute force "
                                      << ref);
                         CHECK(std::abs(ours - ref) <= 2e-3);
                         worst = std::max(worst, std::abs(ours - ref));
                         ++merges;
                         smoothMerges += z[t - 1].deltaBsdf && ours > 0.0;
                     });
    }
    INFO(checked << " weights, " << regularisedPaths << " on regularised paths, " << splits << " splits ("
                 << smoothEndRefused << " refused at a smooth end left a delta), " << merges << " merges ("
                 << smoothMerges << " on smooth surfaces made rough, with weight); worst " << worst);
    CHECK(checked > 3000);
    CHECK(smoothEndRefused > 0);
    // (Cones: 54-138 regularised paths and 7-9 merges on smooth surfaces with weight, measured.)
    CHECK(regularisedPaths > (cone ? 40 : 100));
    if (merging) CHECK(merges > 200);
    if (merging) CHECK(smoothMerges > (cone ? 3 : 20));
}

TEST_CASE("JG19 select(): the exit from the subpaths' running minima chooses as the loop over the path", "[jg19][quality]") {
    // select() answers "unregularised" in O(1) when a connection term it knows without the loop
    // (the joining segment, an emitter hit's first segment, d_path^2 times the walks' running
    // minima SubpathState::connectionMin, with merging d_path^2 / (N pi r^2) times the minima
    // SubpathState::mergeMin) is below tau^2; selectByLoop() is the plain form over
    // the whole path. On BPT, VCM (merges too) and PT techniques of random walks in the box with
    // the glossy panel, the glass and mirror balls, the area light and a point light in the glass,
    // both must return the same answer, the same vertices and the same bounds, for tau 30 and
    // 1000, with the diffusion heuristic off and on. Each configuration must also produce
    // regularised and unregularised techniques where the request could change a vertex, so the
    // comparison covers both outcomes. (Emitter hits on regularised paths, E S ... L with a tiny
    // light, are too rare here: the hand-computed paths of the test above compare both forms on
    // one.) And the running minima equal a recomputation over each walk's segments (relative
    // 1e-6: float storage of a double quotient; the merge minima exactly).
    SceneDesc desc = mixedSceneWithPointInGlass(16);
    Scene scene(desc);
    const bool diffusion = GENERATE(false, true);
    const double tau = GENERATE(30.0, 1000.0);
    // BPT, VCM (merging), PT, and VCM with a merge density N pi r^2 = 4 / tau^2 that puts the
    // merge terms (rho_bar ~ 0.2, d_path ~ 3-10) on both sides of tau^2, so that the exit from the
    // merge minima decides (with 0.05, nearly every merge term is far below tau^2).
    const int setIndex = GENERATE(0, 1, 2, 3);
    INFO("diffusion " << diffusion << " tau " << tau << " set " << setIndex);
    const bool merging = setIndex == 1 || setIndex == 3;
    const float mergeArea = setIndex == 3 ? float(4.0 / (tau * tau) / 256.0) : kPi * 0.05f * 0.05f;
    const MisConfig cfg{setIndex == 2 ? TechniqueSet::PathTracer : TechniqueSet::Bidirectional, merging, mergeArea,
                        256.f};
    const reg::Jg19 jg = fixedTau(tau, scene, cfg, diffusion);
    WalkStats ws;
    std::array<PathVertex, kMaxPathVertices> y, z;
    const Photon photon{};
    int compared = 0, regularised = 0, changeableButNot = 0;
    auto compare = [&](const Technique& tech) {
        Technique a = tech, b = tech;
        const bool ra = jg.select(a), rb = jg.selectByLoop(b);
        CHECK(ra == rb);
        for (int m = 0; m < 2; ++m) {
            CHECK(a.regularised[m] == b.regularised[m]);
            CHECK(a.bound[m] == b.bound[m]);
        }
        ++compared;
        const int lightCount = tech.photon ? tech.s - 1 : tech.s;
        const float changeable = tech.z[tech.t - 1].regState.jg.changeable +
                                 (lightCount >= 1 ? tech.y[lightCount - 1].regState.jg.changeable : 0.f);
        if (b.regularised[0] >= 0 || b.regularised[1] >= 0) ++regularised;
        else if (changeable > 0.f) ++changeableButNot;
    };
    auto checkMinima = [&](const PathVertex* w, int n) {
        double m = kInf;
        float merge = kInf;
        CHECK(std::isinf(w[0].regState.jg.mergeMin));  // (an endpoint: never a merge)
        for (int k = 1; k < n; ++k) {
            const double a = w[k - 1].regState.rhoBar, b = w[k].regState.rhoBar, d = w[k].segmentLength;
            if (a == 0.0 || b == 0.0) m = 0.0;
            else if (std::isfinite(d) && d > 0.0) m = std::min(m, a * b / (d * d));
            // (Tracked only where select() reads them: +inf otherwise.)
            if (std::isinf(m) || cfg.set != TechniqueSet::Bidirectional) CHECK(std::isinf(w[k].regState.jg.connectionMin));
            else CHECK(w[k].regState.jg.connectionMin == Approx(m).epsilon(1e-6));
            if (merging && jg.connectible(w[k])) merge = std::min(merge, w[k].regState.rhoBar);
            CHECK(w[k].regState.jg.mergeMin == merge);
        }
    };
    for (uint64_t i = 0; i < 400; ++i) {
        Rng rng(i, 71);
        const int ny = lightWalk(scene, jg, rng, 7, 100, y.data(), ws);
        const int nz = cameraWalk(scene, jg, Vec2(rng.uniform() * 16, rng.uniform() * 16), rng, 7, 100, z.data(), ws);
        checkMinima(y.data(), ny);
        checkMinima(z.data(), nz);
        for (int t = 1; t <= nz; ++t) {
            const PathVertex& zt = z[t - 1];
            // The emitter hit at z[t-1], and the connections to each light vertex.
            if (t >= 2 && zt.light && allowsTechnique(cfg.set, 0, t)) compare(Technique{nullptr, 0, z.data(), t});
            if (!jg.connectible(zt) || zt.infinite) continue;
            for (int s = 1; s <= ny; ++s)
                if (allowsTechnique(cfg.set, s, t) && jg.connectible(y[s - 1])) compare(Technique{y.data(), s, z.data(), t});
            if (!cfg.merging || t < 2) continue;
            for (int m = 1; m < ny; ++m)  // the merge of y[m] at z[t-1] (smooth surfaces made rough too)
                if (y[m].kind == VertexKind::Surface && jg.connectible(y[m]))
                    compare(Technique{y.data(), m + 1, z.data(), t, &photon});
        }
    }
    INFO(compared << " techniques, " << regularised << " regularised, " << changeableButNot
                  << " unregularised where the request could change a vertex");
    CHECK(compared > (setIndex == 2 ? 1000 : 5000));
    CHECK(regularised > 100);
    CHECK(changeableButNot > 200);
}

// ---- The path diffusion heuristic (jg19.h (4)) --------------------------------------------------

TEST_CASE("JG19 diffusion heuristic: Eqs. 20-21, one step at a time", "[jg19][diffusion]") {
    // Leaving a vertex with bound rho_bar, |mean curvature| h and footprint F over a segment of
    // length d: sigma += (2 pi rho_bar)^(-1/2) + F h, then F += sigma d. Values chosen to be exact.
    reg::Diffusion d;
    d = d.next(1.0 / (2.0 * std::numbers::pi), 0.0, 2.0);  // a bound of 1/(2 pi): spread 1
    CHECK(d.spread == 1.0);
    CHECK(d.footprint == 2.0);
    d = d.next(kInf, 0.5, 1.0);  // a delta vertex on a curved surface: only F h = 1
    CHECK(d.spread == 2.0);
    CHECK(d.footprint == 4.0);
    d = d.next(0.0, 0.0, kInf);  // no BSDF bound, a segment to infinity: nothing changes
    CHECK(d.spread == 2.0);
    CHECK(d.footprint == 4.0);
    d = reg::Diffusion{90.0, 100.0}.next(1.0 / (2.0 * std::numbers::pi), 1.0, 1.0);  // 191: capped
    CHECK(d.spread == reg::Diffusion::kMaxSpread);
    CHECK(d.footprint == 100.0 + reg::Diffusion::kMaxSpread);
}

TEST_CASE("surface curvature: 1/r on analytic and tessellated spheres, 0 on flat surfaces", "[scene][diffusion]") {
    // The estimate from vertex normals is exact for any triangle whose normals are a sphere's.
    const Vec3 c(0.3f, -0.2f, 1.f);
    const float r = 0.4f;
    const Vec3 n0 = glm::normalize(Vec3(1, 0.2f, 0.1f)), n1 = glm::normalize(Vec3(0.8f, 0.5f, 0.f)),
               n2 = glm::normalize(Vec3(0.9f, 0.f, 0.6f));
    CHECK(meanCurvature(c + r * n0, c + r * n1, c + r * n2, n0, n1, n2) == Approx(1.f / r).epsilon(1e-4));
    CHECK(meanCurvature(Vec3(0.f), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1), Vec3(0, 0, 1), Vec3(0, 0, 1)) == 0.f);
    CHECK(meanCurvature(Vec3(0.f), Vec3(0.f), Vec3(0, 1, 0), n0, n1, n2) == 0.f);  // degenerate

    // Hits: the box's analytic sphere, a tessellated one (8 x 12: exact normals at the vertices,
    // so the per-triangle estimate is exact too), a wall.
    SceneDesc desc = mixedScene(16);
    const SphereDesc sphere = desc.spheres[0];
    const MeshDesc& ball = desc.meshes.back();  // smoothSphere(centre (-0.45, -0.65, 0.2), 0.3)
    REQUIRE(ball.name == "smooth-sphere");
    Scene scene(desc);
    auto hitFrom = [&](const Vec3& o, const Vec3& target) {
        SurfaceHit h;
        REQUIRE(scene.intersect(Ray{o, glm::normalize(target - o), 0.f, kInf}, h));
        return h;
    };
    const Vec3 o = scene.camera().position();
    CHECK(hitFrom(o, sphere.center).curvature == Approx(1.f / sphere.radius).epsilon(1e-5));
    CHECK(hitFrom(o, Vec3(-0.45f, -0.65f, 0.2f)).curvature == Approx(1.f / 0.3f).epsilon(1e-3));
    // The walls (flat meshes): the axis rays from inside the box that hit neither sphere.
    int walls = 0;
    for (int axis = 0; axis < 6; ++axis) {
        Vec3 d(0.f);
        d[axis / 2] = axis % 2 ? 1.f : -1.f;
        SurfaceHit hit;
        if (!scene.intersect(Ray{Vec3(0.f, 0.4f, -0.3f), d, 0.f, kInf}, hit)) continue;  // (the open side)
        if (std::abs(glm::length(hit.p - sphere.center) - sphere.radius) < 1e-3f ||
            std::abs(glm::length(hit.p - Vec3(-0.45f, -0.65f, 0.2f)) - 0.3f) < 1e-2f)
            continue;
        CHECK(hit.curvature == 0.f);
        ++walls;
    }
    CHECK(walls >= 4);
}

TEST_CASE("JG19 diffusion heuristic: spreads along the camera walk and the bound at the regularised vertex", "[jg19][diffusion]") {
    // L S D E on a line (a point light in glass, a diffuse vertex 0.1 below the camera), the glass
    // on a sphere of radius 0.5 (curvature 2). From the camera: sigma_D = a = (2 pi rho_cam)^(-1/2),
    // F_D = 0.1 a; sigma_S = a + (2 pi rho_D)^(-1/2) + F_D * 0 (the diffuse vertex is flat),
    // F_S = F_D + 3.9 sigma_S. PT regularises the glass x_1 (NEE's light end) with tau / sigma_S;
    // every split of the path gets the same bound (the camera walk's stored spreads, or steps
    // across the connection and down the light subpath); a light walk stores spread -1.
    Scene scene(mixedScene(16));
    const double camBound = scene.camera().directionPdf(scene.camera().forward()).value;
    const BxdfPtr diffuse = makeDiffuse(Color(0.5f)), glass = makeDielectric(1.5f);
    Light point;
    point.type = LightType::Point;
    HandPath h = HandPath::onAxis(point, {{1.f, glass.get()}, {4.9f, diffuse.get()}});
    h.x[1].curvature = 2.f;
    const double a = 1.0 / std::sqrt(2.0 * std::numbers::pi * camBound);
    const double dD = 5.0 - double(4.9f), dS = double(4.9f) - 1.0;
    const double sigmaS = a + 1.0 / std::sqrt(2.0 * std::numbers::pi * 0.5 / std::numbers::pi), footS = a * dD + sigmaS * dS;
    const reg::Jg19 jg = fixedTau(30.0, scene, MisConfig{TechniqueSet::PathTracer}, true);
    Technique nee = h.technique(jg, 1);  // z = E, D, S
    CHECK(h.z[1].regState.jg.spread == Approx(a).epsilon(1e-6));
    CHECK(h.z[1].regState.jg.footprint == Approx(a * dD).epsilon(1e-5));
    CHECK(h.z[2].regState.jg.spread == Approx(sigmaS).epsilon(1e-6));
    CHECK(h.z[2].regState.jg.footprint == Approx(footS).epsilon(1e-5));
    CHECK(h.y[0].regState.jg.spread == -1.f);
    REQUIRE(jg.select(nee));
    CHECK(nee.regularised[0] == 1);
    CHECK(nee.bound[0] == Approx(30.0 / sigmaS).epsilon(1e-5));
    for (int s : {2, 3}) {  // S-D (the glass on the light subpath), light tracing (through it)
        Technique other = h.technique(jg, s);
        CHECK(jg.select(other) == (s == 2));
        CHECK(other.regularised[0] == 1);
        CHECK(other.bound[0] == Approx(30.0 / sigmaS).epsilon(1e-5));
        CHECK(h.y[s - 1].regState.jg.spread == -1.f);
    }
    // The diffusion makes the request looser than tau here (sigma_S > 1): a blurrier glass.
    CHECK(sigmaS > 1.0);
    // Without the heuristic: tau itself.
    const reg::Jg19 off = fixedTau(30.0, scene, MisConfig{TechniqueSet::PathTracer}, false);
    Technique plainNee = h.technique(off, 1);
    REQUIRE(off.select(plainNee));
    CHECK(plainNee.bound[0] == 30.f);
}

TEST_CASE("JG19 diffusion heuristic: no request changes a diffuse vertex whatever its bound", "[jg19][diffusion]") {
    // L D D E on a line, white Lambert (f = 1 / pi = 0.318) at z = 1 and 3, tau 0.2 (fixed): along
    // the camera walk tau' = tau / sigma falls below f at the second diffuse vertex (sigma > 0.63),
    // and on a light walk the loosest bound (tau / 100) is below f everywhere. No request changes a
    // Lambert lobe, so no vertex counts as changeable (SubpathState::changeable, the gate of
    // select's loop) and no technique is regularised: with a diffuse vertex's ceiling taken as its
    // own rho_bar, the loop chose the white vertex as if a bound could lower it.
    // The same with Mitsuba's two-sided adapter around it (not the inline Lambert path).
    Scene scene(mixedScene(16));
    const BxdfPtr white = GENERATE(makeDiffuse(Color(1.f)), makeTwoSided(makeDiffuse(Color(1.f))));
    INFO(white->name());
    Light point;
    point.type = LightType::Point;
    HandPath h = HandPath::onAxis(point, {{1.f, white.get()}, {3.f, white.get()}});
    for (TechniqueSet set : {TechniqueSet::PathTracer, TechniqueSet::Bidirectional}) {
        const reg::Jg19 jg = fixedTau(0.2, scene, MisConfig{set}, true);
        for (int s = 1; s <= 3; ++s) {
            if (!allowsTechnique(set, s, 4 - s)) continue;
            Technique tech = h.technique(jg, s);
            INFO("set " << int(set) << " s " << s);
            for (int k = 0; k < s; ++k) CHECK(h.y[k].regState.jg.changeable == 0.f);
            for (int k = 0; k < 4 - s; ++k) CHECK(h.z[k].regState.jg.changeable == 0.f);
            CHECK(jg.selectByLoop(tech));
            CHECK(tech.regularised[0] == -1);
            CHECK(tech.regularised[1] == -1);
        }
        // (the premise: tau' at the diffuse vertex next to the light is below its rho_bar)
        h.technique(jg, 1);
        CHECK(0.2 / double(h.z[2].regState.jg.spread) < 1.0 / std::numbers::pi);
    }
}
