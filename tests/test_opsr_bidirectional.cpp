// OPSR in BPT, VCM and light tracing (integrators/transport/opsr.h (5)): which technique
// regularises a smooth vertex (only on paths nothing samples, the one nearest the light, with its
// own side's accumulated roughness), the MIS weights of glossy paths (Eq. 12 with each technique's
// ratios at its own ends) against a brute-force evaluation, and renders: no light counted twice,
// the class plain BPT cannot render, and the same integrand as the path tracer where both
// regularise the same vertex.
#include <catch2/catch.hpp>

#include "bsdf/energy_compensation.h"
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <vector>
#include "bsdf/roughness_bound.h"
#include "core/loader.h"
#include "integrators/integrator.h"
#include "integrators/transport/opsr.h"
#include "process.h"
#include "regularizer_paths.h"
#include "scene_builders.h"

using namespace lt;
using namespace lt::test;

namespace {

// (tau > 0: with JG19's fixed bound tau, --reg jg19,opsr: opsr.h (6))
reg::Opsr opsrFor(TechniqueSet set, bool merging, float gamma, double tau = 0.0, bool compensate = true) {
    reg::OpsrSettings o;
    o.compensate = compensate;
    o.attenuation.gamma = gamma;
    o.bidirectional = true;
    o.boundTau0 = tau;
    o.boundConsistent = false;
    reg::Opsr r(o);
    r.setTechniques(set, merging);
    return r;
}

// A hand path (regularizer_paths.h) whose vertices carry their BSDF's roughness, as the scene's
// intersection writes it.
HandPath onAxis(const Light& light, const std::vector<std::pair<float, const Bxdf*>>& surfaces) {
    HandPath h = HandPath::onAxis(light, surfaces);
    for (PathVertex& v : h.x)
        if (v.bxdf) v.roughness = v.bxdf->roughness();
    return h;
}

// The techniques (s) of the integrator that contribute to the path, and the vertices and
// roughnesses the last contributing one regularises.
std::vector<int> contributing(HandPath& h, const reg::Opsr& r, TechniqueSet set, std::vector<int>& ends,
                              std::vector<float>& g) {
    std::vector<int> out;
    const int n = int(h.x.size());
    for (int s = 0; s < n; ++s) {
        if (s == 0 && !h.x[0].light->isHittable()) continue;
        if (!allowsTechnique(set, s, n - s)) continue;
        Technique t = h.technique(r, s);
        if (s >= 1 && !r.connectible(t.y[s - 1])) continue;
        if (s >= 1 && t.z[t.t - 1].kind == VertexKind::Surface && !r.connectible(t.z[t.t - 1])) continue;
        if (!r.select(t)) continue;
        out.push_back(s);
        ends.clear();
        g.clear();
        for (int m = 0; m < 2; ++m)
            if (t.regularised[m] >= 0) ends.push_back(t.regularised[m]), g.push_back(t.bound[m]);
    }
    return out;
}

}  // namespace

TEST_CASE("OPSR in BPT: a smooth vertex is regularised only on paths nothing samples, nearest the light, with its side's roughness", "[opsr][bidirectional][select]") {
    // Paths on a line (x_0 the light, the camera at z = 5), gamma 0.2. Accumulated roughness of a
    // smooth vertex after one diffuse one: g = 0 + 1 (1 - (1 - 0.2 * 1)) = 0.2 (Eq. 11).
    const BxdfPtr glass = makeDielectric(1.5f), diffuse = makeDiffuse(Color(0.5f));
    const BxdfPtr glossy = makeRoughConductor(MicrofacetType::GGX, 0.1f, 0.1f, Color(0.2f), Color(3.f), Color(1.f));
    Light point, area;
    point.type = LightType::Point;
    area.type = LightType::Area;
    const reg::Opsr bpt = opsrFor(TechniqueSet::Bidirectional, false, 0.2f),
                    vcm = opsrFor(TechniqueSet::Bidirectional, true, 0.2f),
                    lt = opsrFor(TechniqueSet::LightTracer, false, 0.2f);
    std::vector<int> ends;
    std::vector<float> g;
    SECTION("L S D S E (a caustic of a point light seen through glass): next-event estimation at x1") {
        HandPath h = onAxis(point, {{0.5f, glass.get()}, {2.f, diffuse.get()}, {2.5f, glass.get()}});
        // Candidates: x0-x1 (x1 from the camera side: glass, diffuse, glass: g = 0.2) and x3-camera
        // (x3 from the light side: 0.2); x1-x2 and x2-x3 have a smooth end with nothing rough on
        // its own side (g = 0). The first, nearest the light.
        CHECK(contributing(h, bpt, TechniqueSet::Bidirectional, ends, g) == std::vector<int>{1});
        CHECK(ends == std::vector<int>{1});
        REQUIRE(g.size() == 1);
        CHECK(g[0] == Approx(0.2f));
        // VCM merges at the diffuse vertex: nothing regularised, no connection contributes.
        CHECK(contributing(h, vcm, TechniqueSet::Bidirectional, ends, g).empty());
        // Light tracing alone: its one technique, at x3 with the light side's roughness.
        CHECK(contributing(h, lt, TechniqueSet::LightTracer, ends, g) == std::vector<int>{4});
        CHECK(ends == std::vector<int>{3});
        CHECK(g[0] == Approx(0.2f));
    }
    SECTION("L S S E: nothing rough on either side, so nothing renders it (as in the path tracer)") {
        HandPath h = onAxis(point, {{1.f, glass.get()}, {1.5f, glass.get()}});
        CHECK(contributing(h, bpt, TechniqueSet::Bidirectional, ends, g).empty());
    }
    SECTION("samplable paths: smooth vertices are left as they are") {
        // An area light behind glass onto a diffuse vertex: the emitter hit and light tracing
        // sample it; the connections at the glass contribute nothing, nothing is regularised.
        HandPath a = onAxis(area, {{1.f, glass.get()}, {2.f, diffuse.get()}});
        CHECK(contributing(a, bpt, TechniqueSet::Bidirectional, ends, g) == std::vector<int>{0, 3});
        CHECK(ends.empty());
        // A point light: light tracing from the diffuse vertex samples it.
        HandPath p = onAxis(point, {{1.f, glass.get()}, {2.f, diffuse.get()}});
        CHECK(contributing(p, bpt, TechniqueSet::Bidirectional, ends, g) == std::vector<int>{3});
        CHECK(ends.empty());
    }
    SECTION("glossy ends: every technique takes its own subpath's roughness at its own ends") {
        // L G D E, G = GGX alpha 0.1 (roughness 0.1). Next-event estimation at x1 (camera side:
        // diffuse, then G): g = 0.1 + 0.9 * 0.2 = 0.28. Connection x1-x2: x1 from the light side
        // has only itself, g = 0.1, unchanged. Light tracing from x2: diffuse, unchanged.
        HandPath h = onAxis(point, {{1.f, glossy.get()}, {2.f, diffuse.get()}});
        CHECK(contributing(h, bpt, TechniqueSet::Bidirectional, ends, g) == std::vector<int>{1, 2, 3});
        Technique nee = h.technique(bpt, 1);
        REQUIRE(bpt.select(nee));
        CHECK(nee.regularised[0] == 1);
        CHECK(nee.bound[0] == Approx(0.28f));
        Technique mid = h.technique(bpt, 2);
        REQUIRE(bpt.select(mid));
        CHECK(mid.regularised[0] == -1);
        CHECK(mid.regularised[1] == -1);
        // The path has a glossy vertex, so every technique's weight uses the factors.
        CHECK(bpt.perTechnique(mid));
        CHECK(bpt.requestFrom(mid, 1, End::Camera) == Approx(0.28f));
        CHECK(bpt.requestFrom(mid, 1, End::Light) == -1.f);
        // The mirror image: G next to the camera. Light tracing at x2 takes the light side's
        // 0.1 + 0.9 * 0.2; next-event estimation at the diffuse x1 changes nothing.
        HandPath m = onAxis(point, {{1.f, diffuse.get()}, {2.f, glossy.get()}});
        Technique ltech = m.technique(bpt, 3);
        REQUIRE(bpt.select(ltech));
        CHECK(ltech.regularised[0] == 2);
        CHECK(ltech.bound[0] == Approx(0.28f));
    }
}

namespace {

// The brute-force weight of a technique under OPSR in BPT and VCM, from the path's vertices and
// its gathered sampling densities (tested elsewhere), with nothing of the policy's bookkeeping:
// the accumulated roughness from the roughness lists (opsr::accumulatedRoughness, checked by hand
// in test_opsr.cpp), every BSDF evaluated here, samplability and the choice decided from the
// vertices' BSDFs. With a bound tau (> 0: --reg jg19,opsr) every request carries it: a smooth
// vertex is then made rough by it alone, a glossy one evaluated with max(alpha, g, alpha_hat(tau)).
struct BruteForce : PathWeights {
    float gamma;
    float tau = 0.f;

    bool smooth(int j) const { return x[j]->kind == VertexKind::Surface && x[j]->bxdf && x[j]->bxdf->isDelta(); }
    bool plain(int j) const { return x[j]->kind != VertexKind::Surface || (x[j]->bxdf && !x[j]->bxdf->isDelta()); }
    // g at x_j over the subpath from the light (x_1..x_j) or from the camera (x_{n-2}..x_j).
    float accumulated(int j, bool fromLight) const {
        std::vector<float> a;
        if (fromLight)
            for (int i = 1; i <= j; ++i) a.push_back(x[i]->bxdf->roughness());
        else
            for (int i = n() - 2; i >= j; --i) a.push_back(x[i]->bxdf->roughness());
        opsr::Attenuation att;
        att.gamma = gamma;
        return opsr::accumulatedRoughness(a.data(), int(a.size()), att);
    }
    // rho_hat / rho at the glossy inner vertex x_j with its side's roughness (1 if unchanged).
    double regularisedRatio(int j, bool fromLight) const {
        if (j < 1 || j > n() - 2 || smooth(j) || x[j]->bxdf->lambert()) return 1.0;
        const float a = x[j]->bxdf->roughness(), g = accumulated(j, fromLight);
        if (!(g > a) && !(tau > 0.f)) return 1.0;
        const SurfaceBsdf b(x[j]->bxdf, x[j]->shading, x[j]->ng, x[j]->uv);
        BsdfContext hatCtx(TransportMode::Radiance);
        hatCtx.reg.minAlpha = {std::max(g, a), std::max(g, a)};
        if (tau > 0.f) hatCtx.reg.tau = tau;
        const Vec3 wo = dir(j, j + 1), wi = dir(j, j - 1);
        const Color h = b.eval(wo, wi, hatCtx).f, p = b.eval(wo, wi, kRadianceContext).f;
        const double hs = double(h.x) + h.y + h.z, ps = double(p.x) + p.y + p.z;
        return ps > 0.0 ? hs / ps : (hs > 0.0 ? kInf : 1.0);
    }
    // The weight of connection technique s, or of the merge at mergeAt; `smoothChoice` receives
    // the technique chosen for a path no technique samples (-1: the path is samplable).
    double weight(int s, int& smoothChoice) const {
        const int N = n();
        auto allowed = [&](int k) { return allowsTechnique(cfg.set, k, N - k); };
        const bool hittable = x[0]->light && x[0]->light->isHittable();
        bool samplable = allowed(0) && hittable;
        for (int k = 1; k < N; ++k) samplable = samplable || (allowed(k) && plain(k - 1) && plain(k));
        for (int i = 1; cfg.merging && i + 1 < N; ++i) samplable = samplable || plain(i);
        smoothChoice = -1;
        if (!samplable) {
            int bestCount = 0;
            for (int k = 1; k < N; ++k) {
                if (!allowed(k)) continue;
                int count = 0;
                bool ok = true;
                for (int j : {k - 1, k}) {
                    if (plain(j)) continue;
                    ok = ok && smooth(j) && (accumulated(j, j == k - 1) >= kMinAlpha || tau > 0.f);
                    ++count;
                }
                if (ok && (smoothChoice < 0 || count < bestCount)) smoothChoice = k, bestCount = count;
            }
            return mergeAt < 0 && smoothChoice == s ? 1.0 : 0.0;
        }
        // Eq. 12: technique k's density p_k / (R_L(x_{k-1}) R_C(x_k)); merges and the emitter hit
        // are not regularised.
        auto connection = [&](int k) -> double {
            if (k == 0) return 1.0;
            if (smooth(k - 1) || smooth(k)) return -1.0;
            const double R = regularisedRatio(k - 1, true) * regularisedRatio(k, false);
            return R > 0.0 && !std::isinf(R) ? 1.0 / R : -1.0;
        };
        return powerWeight(s, connection, [&](int i) { return smooth(i) ? -1.0 : 1.0; });
    }
};

}  // namespace

TEST_CASE("OPSR in BPT and VCM: MIS weights equal a brute-force evaluation (Eq. 12 at each technique's own ends)", "[opsr][bidirectional][mis]") {
    // Paths of BPT and VCM in the box with a glossy panel (alpha 0.05), a smooth glass sphere with
    // a point light inside, a mirror ball and the area light; gamma 0.3, so the glossy vertices'
    // ratios are far from 1 and differ between the two sides. Tolerance 2e-3: the weights are
    // computed in float from float densities, the brute force in double from the same densities
    // and fresh BSDF evaluations, so only rounding separates them (largest difference: the INFO).
    // Again with JG19's bound tau 300 (--reg jg19,opsr): alpha_hat 0.18 for GGX reflection, above
    // the panel's alpha and many a g, and every smooth vertex made rough by the bound alone.
    Scene scene(mixedSceneWithPointInGlass(16));
    WalkStats ws;
    std::array<PathVertex, kMaxPathVertices> y, z;
    for (const float tau : {0.f, 300.f})
    for (bool merging : {false, true}) {
        INFO("tau " << tau);
        const reg::Opsr op = opsrFor(TechniqueSet::Bidirectional, merging, 0.3f, tau);
        const PathVertex cam = cameraEndpoint(scene, op);
        const MisConfig cfg{TechniqueSet::Bidirectional, merging, kPi * 0.02f * 0.02f, 256.f};
        int checked = 0, factored = 0, factorsNotOne = 0, smoothChosen = 0, merges = 0;
        double worst = 0.0;
        for (uint64_t i = 0; i < 1500; ++i) {
            Rng rng(i, 57 + merging);
            const int ny = lightWalk(scene, op, rng, 6, 100, y.data(), ws);
            const int nz = cameraWalk(scene, op, Vec2(rng.uniform() * 16, rng.uniform() * 16), rng, 6, 100, z.data(), ws);
            auto check = [&](const PathPdfs& P, std::vector<const PathVertex*> xs, int s, int mergeAt,
                             const PathVertex* mergeLight) {
                BruteForce bf{{std::move(xs), P, cfg, mergeAt, mergeLight}, 0.3f, tau};
                int choice = -1;
                const double ref = bf.weight(s, choice);
                const double ours = mergeAt >= 0 ? misWeightMerge(P, mergeAt, cfg) : misWeight(P, s, cfg);
                INFO("path " << i << " s=" << s << " merge " << mergeAt << " n=" << bf.n() << " ours " << ours
                             << " brute force " << ref << " smooth choice " << choice);
                CHECK(std::abs(ours - ref) <= 2e-3);
                worst = std::max(worst, std::abs(ours - ref));
                ++checked;
                smoothChosen += choice >= 0;
                if (P.perTechnique) {
                    ++factored;
                    for (int k = 0; k < P.n; ++k) factorsNotOne += P.connectionScale[k] != 1.f && P.connectionScale[k] != 0.f;
                }
            };
            forEachConnection(scene, op, y.data(), ny, z.data(), nz, cam, ws,
                              [&](int s, int t, const PathVertex* zz, const Connection& c) {
                                  // (the policy's O(1) samplability, from the walks' records)
                                  const Technique tech{s ? y.data() : nullptr, s, zz, t};
                                  CHECK(op.samplable(tech) == samplableUnregularised(tech, cfg.set, merging));
                                  std::vector<const PathVertex*> xs;
                                  for (int k = 0; k < s; ++k) xs.push_back(&y[k]);
                                  for (int k = t - 1; k >= 0; --k) xs.push_back(&zz[k]);
                                  check(c.pdfs, std::move(xs), s, -1, nullptr);
                              });
            if (!merging) continue;
            forEachMerge(op, y.data(), ny, z.data(), nz,
                         [&](int m, int, const Photon&, const Connection& c, std::vector<const PathVertex*> xs) {
                             check(c.pdfs, std::move(xs), -1, m, &y[m]);
                             ++merges;
                         });
        }
        INFO("merging " << merging << ": " << checked << " weights, " << factored << " with per-technique factors ("
                        << factorsNotOne << " factors not 0 or 1), " << smoothChosen
                        << " on paths no technique samples, " << merges << " merges; worst " << worst);
        CHECK(checked > 3000);
        CHECK(factored > 500);
        CHECK(factorsNotOne > 300);
        if (!merging) CHECK(smoothChosen > 10);
        if (merging) CHECK(merges > 200);
    }
}

namespace {

// scenes/hard/caustic-mirror.xml (a point light inside a glass sphere above a diffuse floor, seen
// only in a mirror) at 32^2, optionally without its back wall.
Scene causticMirror(bool wall) {
    SceneDesc d = loadScene(std::string(LT_SOURCE_DIR) + "/scenes/hard/caustic-mirror.xml", {{"res", "32"}});
    if (!wall) {
        auto isWall = [](const MeshDesc& m) {
            return std::all_of(m.positions.begin(), m.positions.end(), [](const Vec3& p) { return p.z > 2.9f; });
        };
        const size_t before = d.meshes.size();
        d.meshes.erase(std::remove_if(d.meshes.begin(), d.meshes.end(), isWall), d.meshes.end());
        REQUIRE(d.meshes.size() + 1 == before);
    }
    return Scene(d);
}

// The smooth vertices of a light walk y[0..ny-1] and a camera walk z[0..nz-1] that connectible()
// leaves out (Opsr::unchangedByOwnWalk) are those whose own walk's request (request, the plain
// form) changes nothing; counted in unchanged and changed (the kept ones), and in *changedByRequest
// those whose request does change them.
void checkLeftOut(const reg::Opsr& op, const PathVertex* y, int ny, const PathVertex* z, int nz, int& unchanged,
                  int& changed, int* changedByRequest) {
    for (const auto& [walk, count] : {std::pair{y, ny}, std::pair{z, nz}})
        for (int k = 1; k < count; ++k) {
            if (!reg::Opsr::smooth(walk[k])) continue;
            const bool left = op.unchangedByOwnWalk(walk[k]);
            INFO("vertex " << k << " of the " << (walk == y ? "light" : "camera") << " walk");
            CHECK(op.connectible(walk[k]) == !left);
            const bool requestChanges = !(op.request(walk, k + 1) < 0.f);
            if (left) CHECK_FALSE(requestChanges);
            ++(left ? unchanged : changed);
            if (changedByRequest) *changedByRequest += requestChanges;
        }
}

double meanOf(const Scene& scene, RenderSettings s, RenderStats& st) {
    const Image img = renderImage(scene, s, st);
    return cropMean(img, img.width, 0, 0, img.width, img.height);
}

}  // namespace

TEST_CASE("OPSR with a table leaves out the smooth vertices after only smooth ones, whose own walk's request changes nothing", "[opsr][select]") {
    // Opsr::unchangedByOwnWalk with per-class factors (a table whose every factor is 0.5: any
    // factor, since a window of zeros accumulates 0 whatever it is) on the walks of the box with
    // the point light in the glass sphere and the mirror ball, and of caustic-mirror.xml (a mirror
    // seen first, glass after the floor): every smooth walk vertex it leaves out is one whose own
    // walk's request (request, the plain form: Eqs. 13-14 over the walk) changes nothing, every
    // one it keeps is connectible, and both kinds occur. Before, a table kept every smooth vertex
    // a connection end (its techniques refused by select() after the light sample).
    auto table = std::make_shared<opsr::AttenuationTable>();
    for (int k = 2; k <= opsr::kMaxWindow; ++k) table->tables[k].assign(size_t(std::pow(opsr::kQ, k)), 0.5f);
    for (const bool box : {true, false}) {
        Scene scene = box ? Scene(mixedSceneWithPointInGlass(16)) : causticMirror(true);
        const int res = box ? 16 : 32;
        for (const bool bidirectional : {false, true}) {
            reg::OpsrSettings o;
            o.attenuation.table = table;
            o.bidirectional = bidirectional;
            reg::Opsr op(o);
            op.setTechniques(bidirectional ? TechniqueSet::Bidirectional : TechniqueSet::PathTracer, false);
            WalkStats ws;
            std::array<PathVertex, kMaxPathVertices> y, z;
            int unchanged = 0, changed = 0, changedByRequest = 0;
            for (uint64_t i = 0; i < 300; ++i) {
                Rng rng(i, 93);
                const int ny = lightWalk(scene, op, rng, 8, 100, y.data(), ws);
                const int nz = cameraWalk(scene, op, Vec2(rng.uniform() * res, rng.uniform() * res), rng, 8, 100, z.data(), ws);
                INFO("box " << box << " bidirectional " << bidirectional << " walks " << i);
                checkLeftOut(op, y.data(), ny, z.data(), nz, unchanged, changed, &changedByRequest);
            }
            INFO("box " << box << " bidirectional " << bidirectional << ": " << unchanged << " left out, " << changed
                        << " connectible, " << changedByRequest << " of them changed by their walk's request");
            CHECK(unchanged > 50);
            CHECK(changedByRequest > 50);
        }
    }
}

TEST_CASE("OPSR in BPT: a connection asks only whether the smooth-vertex choice of its path is its own (the plain choice's answer)", "[opsr][bidirectional][select]") {
    // choosesOwnTechnique (selectBidirectional's question) against chooseSmooth (the plain form:
    // the whole path's choice), on every split into a connection of the paths that join a prefix of
    // a light walk to a prefix of a camera walk (visible or not: both read the records alone), in
    // the box with the point light inside the glass sphere and the mirror ball, and in
    // caustic-mirror.xml without its back wall, where few paths are samplable (L S+ D (S D)* S E).
    // The answer and, where it is the split's own, the smooth ends and their roughnesses must be
    // the same. Counted: splits whose choice is their own, splits whose path another split takes,
    // and samplable paths (no choice).
    for (const bool box : {true, false}) {
        Scene scene = box ? Scene(mixedSceneWithPointInGlass(16)) : causticMirror(false);
        const int res = box ? 16 : 32;
        const reg::Opsr op = opsrFor(TechniqueSet::Bidirectional, false, 0.3f);
        WalkStats ws;
        std::array<PathVertex, kMaxPathVertices> y, z;
        int own = 0, other = 0, none = 0, unchanged = 0, changed = 0;
        for (uint64_t i = 0; i < 400; ++i) {
            Rng rng(i, 91);
            const int ny = lightWalk(scene, op, rng, 6, 100, y.data(), ws);
            const int nz = cameraWalk(scene, op, Vec2(rng.uniform() * res, rng.uniform() * res), rng, 6, 100, z.data(), ws);
            // The smooth vertices connectible() leaves out (unchangedByOwnWalk): the request from
            // their own walk's side changes nothing there (request, the plain form).
            checkLeftOut(op, y.data(), ny, z.data(), nz, unchanged, changed, nullptr);
            for (int s = 1; s <= ny; ++s)
                for (int t = 1; t <= nz; ++t) {
                    HandPath h;
                    for (int k = 0; k < s; ++k) h.x.push_back(y[k]);
                    for (int k = t - 1; k >= 0; --k) h.x.push_back(z[k]);
                    for (int k = 1; k + 1 <= s + t; ++k) {
                        const Technique tech = h.technique(op, k);
                        reg::Opsr::SmoothChoice mine;
                        const bool chosen = op.choosesOwnTechnique(tech, mine);
                        const reg::Opsr::SmoothChoice plain = op.chooseSmooth(tech);
                        INFO("box " << box << " walks " << i << " s=" << s << " t=" << t << " split " << k
                                    << " plain choice " << plain.technique);
                        CHECK(chosen == (plain.technique == k));
                        if (chosen) {
                            ++own;
                            for (int m = 0; m < 2; ++m) {
                                CHECK(mine.ends[m] == plain.ends[m]);
                                CHECK(mine.g[m] == plain.g[m]);
                            }
                        } else {
                            ++(plain.technique >= 0 ? other : none);
                        }
                    }
                }
        }
        INFO("box " << box << ": " << own << " splits chose themselves, " << other << " another split, " << none
                    << " samplable; smooth walk vertices " << unchanged << " left out, " << changed << " connectible");
        CHECK(unchanged > 100);
        CHECK(changed > 50);  // (coverage floors: 400 fixed walks give 317 and 78)
        CHECK(own > 200);
        CHECK(other > 1000);
        CHECK(none > 1000);
    }
}

TEST_CASE("OPSR in BPT renders the caustic seen in a mirror, as the path tracer's regularised estimate of it", "[opsr][bidirectional][render]") {
    // Without its back wall, every path of caustic-mirror.xml is L S+ D (S D)* S E: no two
    // neighbouring non-smooth vertices, so plain BPT renders nothing, and BPT with OPSR
    // regularises every path at the glass vertex next to the light with the camera side's
    // roughness (the technique nearest the light) -- the integrand the path tracer with OPSR
    // estimates on this scene (it regularises that vertex on every path: next-event estimation
    // and its regularised BSDF sample). So their means must agree, though BPT gets there by
    // next-event estimation alone. gamma 0.3 (smooth enough to converge at 32^2).
    // Measured (seeds 1-4, 512 spp): per-seed means PT 0.0430-0.0455, BPT 0.0432-0.0456, a spread
    // of about 2% per seed; the 4-seed means differ by 0.3%. The difference of two 4-seed means
    // has a standard deviation of about 1.4%: tolerance 5% (3.5 sigma). Choosing by KD13's longest
    // connection instead (light tracing at the mirror, another integrand) gave BPT 15% below PT.
    const Scene scene = causticMirror(false);
    auto settings = [](const std::string& integrator, uint64_t seed) {
        RenderSettings s = settingsFor(integrator, 512);
        s.maxDepth = 12;
        s.seed = seed;
        s.regularizer = "opsr";
        s.regOpsrGamma = 0.3;
        return s;
    };
    double pt = 0.0, bpt = 0.0;
    for (uint64_t seed : {1, 2, 3, 4}) {
        RenderStats a, b;
        const double mp = meanOf(scene, settings("pt", seed), a), mb = meanOf(scene, settings("bpt", seed), b);
        UNSCOPED_INFO("seed " << seed << ": PT " << mp << ", BPT " << mb << ", BPT regularised share "
                              << double(b.regularisedContributions) / double(b.contributions));
        pt += mp, bpt += mb;
        CHECK(b.regularisedContributions > 0);
    }
    RenderSettings plain = settings("bpt", 1);
    plain.regularizer = "none";
    RenderStats c;
    const double none = meanOf(scene, plain, c);
    INFO("PT " << pt / 4 << ", BPT " << bpt / 4 << ", plain BPT " << none);
    CHECK(std::abs(bpt / pt - 1.0) < 0.05);
    CHECK(none < 0.01 * bpt / 4);
}

TEST_CASE("OPSR in BPT and VCM counts no light twice", "[opsr][bidirectional][render]") {
    // (1) VCM on caustic-mirror.xml: every path has a diffuse vertex a merge samples, and no
    // glossy one, so OPSR changes nothing: bit-identical to VCM without it.
    {
        const Scene scene = causticMirror(true);
        RenderSettings plain = settingsFor("vcm", 4), reg = plain;
        plain.maxDepth = reg.maxDepth = 12;
        reg.regularizer = "opsr";
        reg.regOpsrGamma = 0.3;
        RenderStats a, b;
        const Image ia = renderImage(scene, plain, a), ib = renderImage(scene, reg, b);
        CHECK(differingPixels(ia, ib) == 0);
        CHECK(b.regularisedContributions == 0);
        CHECK(b.contributions > 1000);
    }
    // (2) BPT in the box with a point light inside a glass sphere, the area light, a glossy panel
    // (alpha 0.05) and a mirror ball: the connections at the glass next to the point light
    // (regularised per end, they would add a blurred copy of the caustics light tracing renders
    // sharp: +71% on the floor for JG19 without its heuristic) and the glossy panel's connections
    // (Eq. 12). Plain BPT misses the paths it cannot sample (the caustics seen through the glass
    // and in the mirror ball); with OPSR the image mean must be VCM's (which samples them by
    // merging) within the noise and the regularisation's small bias, not above it. Measured
    // (seeds 1-4): plain BPT 0.501-0.510, with OPSR 0.528-0.537, VCM (256 spp) 0.524-0.554; the
    // 4-seed means: plain 0.504, OPSR 0.533, VCM 0.534. Standard deviation of the difference of
    // the OPSR and VCM 4-seed means: about 0.8% (VCM's per-seed spread 2%, OPSR's 0.7%), so the
    // tolerance 3% is about 3.5 sigma; plain BPT is 5.8% below VCM, the second check's 3% margin
    // about 3.5 sigma from there.
    {
        const Scene scene(mixedSceneWithPointInGlass(32));
        double plainSum = 0.0, regSum = 0.0, vcmSum = 0.0;
        for (uint64_t seed : {1, 2, 3, 4}) {
            RenderSettings plain = settingsFor("bpt", 64), reg = plain, vcm = settingsFor("vcm", 256);
            plain.seed = reg.seed = vcm.seed = seed;
            reg.regularizer = "opsr";
            reg.regOpsrGamma = 0.3;
            RenderStats a, b, c;
            const Image ip = renderImage(scene, plain, a), ir = renderImage(scene, reg, b), iv = renderImage(scene, vcm, c);
            const double mp = cropMean(ip, 32, 0, 0, 32, 32), mr = cropMean(ir, 32, 0, 0, 32, 32),
                         mv = cropMean(iv, 32, 0, 0, 32, 32);
            UNSCOPED_INFO("seed " << seed << ": plain BPT " << mp << ", with OPSR " << mr << ", VCM " << mv);
            plainSum += mp, regSum += mr, vcmSum += mv;
            CHECK(b.regularisedContributions > 500);
        }
        INFO("plain BPT " << plainSum / 4 << ", with OPSR " << regSum / 4 << ", VCM " << vcmSum / 4);
        CHECK(std::abs(regSum / vcmSum - 1.0) < 0.03);
        CHECK(plainSum < 0.97 * vcmSum);
    }
}

TEST_CASE("OPSR with JG19's bound renders the point seen through glass that OPSR alone cannot", "[opsr][jg19][render]") {
    // cornell-box-point-in-glass.xml at max depth 2: every path is L S E (the point seen through
    // the glass), with no rough vertex for OPSR to accumulate from: OPSR alone renders nothing.
    // With JG19's bound (opsr.h (6)) the path tracer regularises next-event estimation at the
    // glass with tau_n alone, which is JG19's own choice there (the quality heuristic: nothing
    // samples the path; without diffusion the bound is tau_n): bit for bit JG19's image. BPT
    // chooses the same estimator (the technique nearest the light), so its mean is PT's
    // (measured: equal to 5 digits; tolerance 1%, pixel jitter only).
    const Scene scene(loadScene(std::string(LT_SOURCE_DIR) + "/scenes/cornell-box-point-in-glass.xml", {{"res", "32"}}));
    auto settings = [](const std::string& integrator, const std::string& reg) {
        RenderSettings s = settingsFor(integrator, 16);
        s.maxDepth = 2;
        s.regularizer = reg;
        if (reg == "jg19") s.regDiffusion = false;
        return s;
    };
    RenderStats a, b, c, d;
    const Image combined = renderImage(scene, settings("pt", "jg19,opsr"), a);
    const Image jg19 = renderImage(scene, settings("pt", "jg19"), b);
    const Image opsrAlone = renderImage(scene, settings("pt", "opsr"), c);
    const Image bpt = renderImage(scene, settings("bpt", "jg19,opsr"), d);
    const double mean = cropMean(combined, 32, 0, 0, 32, 32), bptMean = cropMean(bpt, 32, 0, 0, 32, 32);
    INFO("PT jg19,opsr " << mean << ", BPT jg19,opsr " << bptMean << ", PT opsr " << cropMean(opsrAlone, 32, 0, 0, 32, 32));
    CHECK(mean > 0.1);
    CHECK(differingPixels(combined, jg19) == 0);
    CHECK(a.regularisedContributions == a.contributions);
    CHECK(cropMean(opsrAlone, 32, 0, 0, 32, 32) == 0.0);
    CHECK(std::abs(bptMean / mean - 1.0) < 0.01);
    CHECK(d.regularisedContributions > 0);
    // The scene format names it as the command line does (integrator parameter regularizer).
    const std::filesystem::path dir = lt::test::tempDir("lt_opsr", "bound_xml");
    std::ofstream(dir / "scene.xml") << R"(<scene version="3.0.0">
    <integrator type="path">
        <string name="regularizer" value="jg19,opsr"/>
        <float name="reg_tau" value="50"/>
        <string name="reg_schedule" value="fixed"/>
        <string name="reg_bound" value="published"/>
        <string name="reg_energy" value="none"/>
    </integrator>
    <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
    <emitter type="point"><point name="position" value="0, 0, -2"/><rgb name="intensity" value="1, 1, 1"/></emitter>
</scene>
)";
    const SceneDesc desc = loadScene((dir / "scene.xml").string(), {});
    CHECK(desc.integrator.regularizer == "jg19,opsr");
    CHECK(desc.integrator.regTau == Approx(50.0));
    CHECK(desc.integrator.regSchedule == "fixed");
    CHECK(desc.integrator.regBound == "published");
    CHECK(desc.integrator.regEnergy == "none");
    // A value the parameters do not take: an error naming the parameter.
    for (const std::string& bad : {std::string(R"(<string name="reg_bound" value="loose"/>)"),
                                   std::string(R"(<string name="reg_energy" value="some"/>)")}) {
        std::ofstream(dir / "bad.xml") << "<scene version=\"3.0.0\"><integrator type=\"path\">" << bad
                                       << "</integrator></scene>\n";
        const std::string name = bad.find("reg_bound") != std::string::npos ? "reg_bound" : "reg_energy";
        CHECK_THROWS_WITH(loadScene((dir / "bad.xml").string(), {}), Catch::Contains(name) && Catch::Contains("bad.xml"));
    }
    std::filesystem::remove_all(dir);
}

TEST_CASE("OPSR with JG19's bound: each lobe takes the larger of the accumulated roughness and JG19's alpha_hat", "[opsr][jg19]") {
    // A hand path light - diffuse - glossy (alpha 0.05) - camera, gamma 0.3. Light tracing ends
    // at the glossy vertex with the light side's g = 1 - 0.95 (1 - 0.3) = 0.335; next-event
    // estimation ends there with the camera side's, over the glossy vertex alone: its own 0.05,
    // which changes nothing, so the bound alone. The bound's alpha_hat(tau) for GGX reflection is
    // (pi tau)^(-1/4): 0.18 at tau 300 (above 0.05, below 0.335), 0.57 at tau 3 (above both).
    // The request at each end must evaluate the BSDF as the material with alpha' = max(alpha, g,
    // alpha_hat) does (uncompensated; compensated, alpha_hat is the compensated lobe's and the
    // value is that material's times E(alpha) / E(alpha') at the light side, energy_compensation.h).
    const BxdfPtr glossy = makeRoughConductor(MicrofacetType::GGX, 0.05f, 0.05f, Color(0.2f), Color(3.f), Color(1.f));
    const BxdfPtr diffuse = makeDiffuse(Color(0.5f));
    Light light;
    light.type = LightType::Point;
    const LobeCompensation comp(MicrofacetLobe{MicrofacetType::GGX, MaskingModel::Smith, 0.05f, 0.05f});
    for (const double tau : {300.0, 3.0})
      for (bool compensate : {false, true}) {
        const reg::Opsr op = opsrFor(TechniqueSet::Bidirectional, false, 0.3f, tau, compensate);
        const float alphaHat = compensate ? comp.alphaFor(float(tau), false, BoundForm::Tight)
                                          : alphaForBound(MicrofacetType::GGX, MaskingModel::Smith, float(tau), false,
                                                          1.f, BoundForm::Tight);
        INFO("compensate " << compensate);
        INFO("tau " << tau << ": alpha_hat " << alphaHat);
        HandPath h = onAxis(light, {{1.f, diffuse.get()}, {2.f, glossy.get()}});
        // Light tracing (s = 3) regularises x2 with the light side's g; NEE (s = 2) with the camera
        // side's, which is x2's own roughness: the bound alone.
        for (const auto& [s, g] : std::vector<std::pair<int, float>>{{3, 0.335f}, {2, 0.05f}}) {
            Technique t = h.technique(op, s);
            REQUIRE(op.select(t));
            const int m = t.regularised[0] == 2 ? 0 : 1;
            REQUIRE(t.regularised[m] == 2);
            CHECK(t.bound[m] == Approx(std::max(g, 0.05f)));
            const float expected = std::max({0.05f, g, alphaHat});
            const BxdfPtr reference =
                makeRoughConductor(MicrofacetType::GGX, expected, expected, Color(0.2f), Color(3.f), Color(1.f));
            const Vec3 wo = glm::normalize(Vec3(0.3f, 0.f, 1.f)), wi = glm::normalize(Vec3(-0.1f, 0.2f, 1.f));
            const BsdfContext ctx = op.context(t, s == 3 ? End::Light : End::Camera);
            const float muL = ctx.mode == TransportMode::Radiance ? wi.z : wo.z;
            const float scale = compensate ? comp.reflectionScale(muL, expected) : 1.f;
            const Color got = glossy->eval(wo, wi, ctx).f, want = reference->eval(wo, wi, BsdfContext(ctx.mode)).f;
            INFO("s " << s << ": alpha' " << expected << ", compensation " << scale);
            CHECK(got.x == Approx(want.x * scale).epsilon(1e-5));
            if (compensate && expected > 0.05f) CHECK(scale > 1.f);
        }
      }
}

TEST_CASE("OPSR with JG19's bound in BPT counts no light twice", "[opsr][jg19][bidirectional][render]") {
    // The box with a point light inside a glass sphere, the area light, a glossy panel (alpha
    // 0.05) and a mirror ball (the second case of "OPSR in BPT and VCM counts no light twice"),
    // BPT with gamma 0.3 and JG19's bound tau 1e4 (fixed; alpha_hat 0.056 for GGX reflection):
    // besides what OPSR alone renders, the bound renders the point seen through the glass and in
    // the mirror ball (singular.exr: paths no unregularised technique produces, which VCM does
    // not render either). Outside that part the image mean must be VCM's within the noise and the
    // regularisation's bias, as OPSR's alone is: a smooth vertex made rough by the bound on a
    // path some technique samples would add a blurred copy of its light.
    const Scene scene(mixedSceneWithPointInGlass(32));
    const std::filesystem::path dir = lt::test::tempDir("lt_opsr", "bound_twice");
    double regSum = 0.0, singularSum = 0.0, vcmSum = 0.0, opsrSum = 0.0;
    for (uint64_t seed : {1, 2, 3, 4}) {
        RenderSettings reg = settingsFor("bpt", 64), vcm = settingsFor("vcm", 256);
        reg.seed = vcm.seed = seed;
        reg.regularizer = "jg19,opsr";
        reg.regOpsrGamma = 0.3;
        reg.regTau = 1e4;
        reg.regSchedule = "fixed";
        reg.strategyImages = (dir / std::to_string(seed)).string();
        RenderSettings opsr = reg;
        opsr.regularizer = "opsr";
        opsr.regTau = -1.0;
        opsr.regSchedule = "consistent";
        opsr.strategyImages.clear();
        RenderStats a, b, c;
        const double mr = cropMean(renderImage(scene, reg, a), 32, 0, 0, 32, 32);
        const double ms = cropMean(readImage((dir / std::to_string(seed) / "singular.exr").string()), 32, 0, 0, 32, 32);
        const double mo = cropMean(renderImage(scene, opsr, b), 32, 0, 0, 32, 32);
        const double mv = cropMean(renderImage(scene, vcm, c), 32, 0, 0, 32, 32);
        UNSCOPED_INFO("seed " << seed << ": BPT jg19,opsr " << mr << " (singular " << ms << "), opsr " << mo << ", VCM " << mv);
        regSum += mr, singularSum += ms, vcmSum += mv, opsrSum += mo;
    }
    INFO("BPT jg19,opsr " << regSum / 4 << " of which singular " << singularSum / 4 << "; opsr " << opsrSum / 4 << ", VCM "
                          << vcmSum / 4);
    CHECK(singularSum > 0.0);
    CHECK(std::abs((regSum - singularSum) / vcmSum - 1.0) < 0.03);
    std::filesystem::remove_all(dir);
}

TEST_CASE("OPSR's vertex predicates read the roughness and the delta flag first, as the full tests would answer", "[opsr]") {
    // mayChange and smooth (opsr.h) test a vertex's roughness (below 1) or delta flag before its
    // kind, and leave out "has a BSDF" and "not at infinity": a vertex without a BSDF or at
    // infinity has roughness 1 and no delta flag (SurfacePoint, PathVertex::setPoint). Every
    // vertex the walks, the light samples and the camera make, on scenes with a glossy conductor,
    // glass, a mirror and an environment light (vertices at infinity), must get the full tests'
    // answers; a vertex kind whose record breaks the rule fails here.
    int infinite = 0, lights = 0, changeable = 0, smoothCount = 0, checked = 0;
    auto check = [&](const PathVertex& v) {
        const bool surface = v.kind == VertexKind::Surface && !v.infinite && v.bxdf;
        INFO("kind " << int(v.kind) << " infinite " << v.infinite << " roughness " << v.roughness);
        CHECK(reg::Opsr::mayChange(v) == (surface && v.roughness < 1.f));
        CHECK(reg::Opsr::smooth(v) == (surface && v.deltaBsdf));
        ++checked;
        infinite += v.infinite;
        lights += v.kind == VertexKind::Light;
        changeable += surface && v.roughness < 1.f;
        smoothCount += surface && v.deltaBsdf;
    };
    for (const char* name : {"cornell-box-ggx", "cornell-box-glass-sphere", "smallvcm/small-spheres-background"}) {
        INFO(name);
        const Scene scene(loadScene(std::string(LT_SOURCE_DIR) + "/scenes/" + name + ".xml", {{"res", "16"}}));
        const reg::Opsr op = opsrFor(TechniqueSet::Bidirectional, false, 0.01f);
        check(cameraEndpoint(scene, op));
        std::array<PathVertex, kMaxPathVertices> y, z;
        WalkStats ws;
        for (uint64_t i = 0; i < 300; ++i) {
            Rng rng(i, 71);
            const int ny = lightWalk(scene, op, rng, 8, 100, y.data(), ws);
            const int nz = cameraWalk(scene, op, Vec2(rng.uniform() * 16, rng.uniform() * 16), rng, 8, 100, z.data(), ws);
            for (int j = 0; j < ny; ++j) check(y[j]);
            for (int j = 0; j < nz; ++j) check(z[j]);
            PathVertex light;
            if (nz >= 2 && sampleLightVertex(scene, op, z[1].p, rng, light)) check(light);
        }
    }
    // (each kind of vertex met: at infinity, light endpoints and samples, glossy and smooth ones)
    CHECK(infinite > 0);
    CHECK(lights > 0);
    CHECK(changeable > 0);
    CHECK(smoothCount > 0);
    CHECK(checked > 5000);  // (8,979 with these seeds: the walks are not cut short)
}
