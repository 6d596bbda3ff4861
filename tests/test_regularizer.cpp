// The regulariser seam (integrators/transport/regularizer.h) with test policies: each hook of the
// policy interface (per-subpath state, the BSDF context at connection and merge vertices, the
// per-technique densities for MIS and the bypass of the fast forms they need) reaches what it
// must, and nothing else changes. No regulariser is implemented here: the policies below only
// exercise the interface (reg::None is exercised by every other test and render).
#include <catch2/catch.hpp>
#include <array>
#include <cmath>
#include <vector>
#include "bsdf/cone_mollifier.h"
#include "core/sampling.h"
#include "integrators/transport/path_templates.h"
#include "scene_builders.h"

using namespace lt;
using namespace lt::test;

namespace {

// (3) State: the number of segments from the endpoint, carried along each subpath.
struct CountingState : reg::None {
    void start(PathVertex& v) const { v.regState.accumulated = 0.f; }
    void extend(PathVertex& v, const PathVertex& prev) const {
        v.regState.accumulated = prev.regState.accumulated + 1.f;
    }
};

// (1) A minimum alpha at both ends of every connection and at the camera vertex of every merge,
// which select() names (regularizer.h (5): the context carries a request only there).
struct RougherAtConnections : reg::None {
    bool select(Technique& tech) const {
        tech.regularised[0] = tech.s - 1;  // (a merge's camera vertex)
        tech.regularised[1] = tech.photon ? -1 : tech.s;
        return true;
    }
    BsdfContext context(const Technique&, End end) const {
        RegularizationRequest r;
        r.minAlpha = Roughness{0.4f, 0.4f};
        return BsdfContext(end == End::Light ? TransportMode::Importance : TransportMode::Radiance, r);
    }
};

// (2) Per-technique factors. As a regulariser's, they depend on the technique only (its own
// vertices), not on which technique is being weighted; `trivial` makes them all 1.
struct ScaledTechniques : reg::None {
    static constexpr bool kPerTechnique = true;
    bool perTechnique(const Technique&) const { return true; }
    bool trivial = false;
    void densities(const Technique&, PathPdfs& p) const {
        for (int k = 0; k <= p.n; ++k)
            p.connectionScale[k] = trivial ? 1.f : 0.3f + std::fmod(0.37f * float(k * k) + 0.11f, 2.f);
        for (int i = 0; i < p.n; ++i)
            p.mergeScale[i] = trivial ? 1.f : 0.5f + std::fmod(0.73f * float(i) + 0.29f, 1.5f);
    }
};

BxdfPtr ggx(float alpha) {
    return makeRoughConductor(MicrofacetType::GGX, alpha, alpha, Color(0.2f, 0.9f, 1.1f), Color(3.9f, 2.4f, 2.1f),
                              Color(1.f));
}

SceneDesc testScene() {
    SceneDesc d = cornellBox(8, ggx(0.1f));
    d.meshes.push_back(smoothSphere(Vec3(-0.45f, -0.65f, 0.2f), 0.3f, 5, 7, 0));
    return d;
}

bool samePdfs(const PathPdfs& a, const PathPdfs& b) {
    if (a.n != b.n || a.lightHittable != b.lightHittable) return false;
    for (int i = 0; i < a.n; ++i)
        if (a.fromLight[i] != b.fromLight[i] || a.fromCamera[i] != b.fromCamera[i] || a.delta[i] != b.delta[i])
            return false;
    return true;
}

}  // namespace

TEST_CASE("regulariser seam: per-subpath state is carried on every vertex", "[regularizer]") {
    // The state: nine floats at the end of the record (184 bytes).
    static_assert(sizeof(PathVertex) == 184);
    Scene scene(testScene());
    WalkStats ws;
    const CountingState counting;
    std::array<PathVertex, kMaxPathVertices> a, b;
    int vertices = 0;
    for (uint64_t i = 0; i < 500; ++i) {
        for (bool light : {false, true}) {
            Rng r1(i, 3), r2(i, 3);
            const Vec2 raster(float(i % 8) + 0.5f, float((i / 8) % 8) + 0.5f);
            const int na = light ? lightWalk(scene, reg::kNone, r1, 8, 100, a.data(), ws)
                                 : cameraWalk(scene, reg::kNone, raster, r1, 8, 100, a.data(), ws);
            const int nb = light ? lightWalk(scene, counting, r2, 8, 100, b.data(), ws)
                                 : cameraWalk(scene, counting, raster, r2, 8, 100, b.data(), ws);
            REQUIRE(na == nb);  // the state changes nothing else: the same walk
            for (int j = 0; j < nb; ++j) {
                INFO("walk " << i << (light ? " light" : " camera") << " vertex " << j);
                CHECK(b[j].regState.accumulated == float(b[j].depth));
                CHECK(b[j].p == a[j].p);
                CHECK(b[j].beta == a[j].beta);
                CHECK(b[j].fromLight.value == a[j].fromLight.value);
                CHECK(b[j].fromCamera.value == a[j].fromCamera.value);
                ++vertices;
            }
        }
        PathVertex lv;
        Rng r(i, 4);
        lv.regState.accumulated = -1.f;
        if (sampleLightVertex(scene, counting, Vec3(0.f), r, lv)) CHECK(lv.regState.accumulated == 0.f);
    }
    CHECK(cameraEndpoint(scene, counting).regState.accumulated == 0.f);
    CHECK(vertices > 3000);
}

TEST_CASE("regulariser seam: the context at connection and merge vertices changes values, not densities",
          "[regularizer]") {
    Scene scene(testScene());
    WalkStats ws;
    const RougherAtConnections rougher;
    std::array<PathVertex, kMaxPathVertices> y, z;
    int checked = 0, changed = 0;
    auto fAt = [](const PathVertex& v, const Vec3& wi, const BsdfContext& ctx) {
        return v.bsdf().eval(v.wo, wi, ctx).f;
    };
    for (uint64_t i = 0; i < 1500; ++i) {
        Rng rng(i, 5);
        const int ny = lightWalk(scene, reg::kNone, rng, 5, 100, y.data(), ws);
        const int nz = cameraWalk(scene, reg::kNone, Vec2(rng.uniform() * 8, rng.uniform() * 8), rng, 5, 100, z.data(), ws);
        for (int s = 2; s <= ny; ++s)
            for (int t = 2; t <= nz; ++t) {
                Connection plain, regularised;
                const bool okP = connect(scene, reg::kNone, y.data(), s, z.data(), t, 100, plain, ws);
                const bool okR = connect(scene, rougher, y.data(), s, z.data(), t, 100, regularised, ws);
                if (!okP || !okR) continue;
                INFO("path " << i << " s=" << s << " t=" << t);
                // The MIS densities are the sampling densities of the materials' own BSDFs.
                CHECK(samePdfs(plain.pdfs, regularised.pdfs));
                // The value: both ends' BSDFs with the request, the rest unchanged.
                const PathVertex &a = y[s - 1], &b = z[t - 1];
                const Vec3 wBA = glm::normalize(a.p - b.p);
                const Technique tech{y.data(), s, z.data(), t};
                const Color fa = fAt(a, -wBA, kImportanceContext), fb = fAt(b, wBA, kRadianceContext);
                const Color ra = fAt(a, -wBA, rougher.context(tech, End::Light));
                const Color rb = fAt(b, wBA, rougher.context(tech, End::Camera));
                for (int c = 0; c < 3; ++c) {
                    const double expect = double(plain.contribution[c]) * ra[c] * rb[c] / (double(fa[c]) * fb[c]);
                    CHECK(regularised.contribution[c] == Approx(expect).epsilon(1e-4));
                }
                ++checked;
                changed += std::abs(regularised.contribution.x / plain.contribution.x - 1.f) > 1e-3f;
            }
    }
    CHECK(checked > 1000);
    CHECK(changed > 300);  // the GGX panel and sphere (alpha 0.1 < 0.4) are at many ends

    // Merges: the camera vertex's BSDF with the request, the densities as without.
    const MisConfig cfg{TechniqueSet::Bidirectional, true, kPi * 0.05f * 0.05f, 256.f};
    LightPathStore store;
    store.begin(256, true);
    for (uint64_t j = 0; j < 256; ++j) {
        Rng rng(j, 6);
        store.chunk(0).commit(lightWalk(scene, reg::kNone, rng, 6, 100, store.chunk(0).next(), ws));
    }
    HashGrid grid;
    grid.build(store, 0.05f, cfg);
    int merges = 0, mergesChanged = 0;
    for (uint64_t i = 0; i < 500; ++i) {
        Rng rng(i, 7);
        const int nz = cameraWalk(scene, reg::kNone, Vec2(rng.uniform() * 8, rng.uniform() * 8), rng, 6, 100, z.data(), ws);
        for (int t = 2; t <= nz; ++t) {
            if (!z[t - 1].connectible() || z[t - 1].infinite) continue;
            grid.query(z[t - 1].p, [&](const Photon& ph) {
                const VertexPdfs* pdfs = store.pdfs(ph.path);
                Connection plain, regularised;
                const bool okP = merge(reg::kNone, ph, nullptr, pdfs, z.data(), t, 100, plain);
                const bool okR = merge(rougher, ph, nullptr, pdfs, z.data(), t, 100, regularised);
                if (!okP || !okR) return;
                CHECK(samePdfs(plain.pdfs, regularised.pdfs));
                const Technique tech{nullptr, ph.depth + 1, z.data(), t, &ph};
                const Color f = fAt(z[t - 1], ph.wo, kRadianceContext);
                const Color r = fAt(z[t - 1], ph.wo, rougher.context(tech, End::Camera));
                CHECK(regularised.contribution.y == Approx(double(plain.contribution.y) * r.y / f.y).epsilon(1e-4));
                ++merges;
                mergesChanged += std::abs(regularised.contribution.y / plain.contribution.y - 1.f) > 1e-3f;
            });
        }
    }
    INFO(merges << " merges, " << mergesChanged << " changed");
    CHECK(merges > 200);
    CHECK(mergesChanged > 20);  // merges on the GGX panel and sphere
}

TEST_CASE("regulariser seam: a smooth connection end evaluates as the general form does", "[regularizer]") {
    // evalAtConnection skips a smooth BSDF's plain evaluation (0 for every pair) and the question
    // whether the request leaves it a delta (its evaluation says so). Against the general form
    // (the plain evaluation, requestCanChange, the request's evaluation), bit for bit: the value,
    // both densities, rho_hat / rho and the regularised density, for a mirror, glass (eta 1.5 and
    // its inverse) and index-matched glass, two-sided too, under no request, bounds that leave the
    // lobe a delta or make it rough, and cones; random directions on both sides.
    const std::vector<BxdfPtr> smooth{makeConductor(Color(0.2f, 0.9f, 1.1f), Color(3.f, 2.5f, 2.f), Color(1.f)),
                                      makeDielectric(1.5f), makeDielectric(1.f / 1.5f), makeDielectric(1.f),
                                      makeTwoSided(makeConductor(Color(1.5f), Color(3.f), Color(0.8f)))};
    std::vector<BsdfContext> contexts;
    for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
        contexts.emplace_back(mode);
        for (float tau : {1e12f, 1e6f, 300.f, 30.f, 1.f}) {
            BsdfContext c(mode);
            c.reg.tau = tau;
            contexts.push_back(c);
            contexts.push_back(c.valueOnlyCopy());
            c.reg.cone = coneForBound(tau);
            contexts.push_back(c);
        }
    }
    Rng rng(3, 11);
    int checked = 0, nonZero = 0, leftDelta = 0;
    for (const BxdfPtr& b : smooth)
        for (int i = 0; i < 400; ++i) {
            PathVertex v;
            v.kind = VertexKind::Surface;
            v.p = Vec3(0.f);
            v.ng = Vec3(0.f, 0.f, 1.f);
            v.shading = Frame(v.ng);
            v.bxdf = b.get();
            v.deltaBsdf = b->isDelta();
            REQUIRE(v.deltaBsdf);
            v.wo = sampleUniformSphere(rng.uniform2());
            // wi: near the mirror or refracted direction half of the time (where a rough lobe is large)
            Vec3 wi = sampleUniformSphere(rng.uniform2());
            if (i % 2) wi = glm::normalize(Vec3(-v.wo.x, -v.wo.y, (i % 4 == 1 ? 1.f : -1.f) * v.wo.z) + 0.05f * wi);
            for (const BsdfContext& ctx : contexts) {
                float ratio = 1.f, pdf = 0.f, ratioRef = 1.f, pdfRef = 0.f;
                const detail::Survival sv{0.8f, 0.6f};  // (the roulette's factors, as a connection gives them)
                const BsdfEval e = detail::evalAtConnection(v, wi, ctx, sv, ratio, pdf);
                // the general form
                BsdfEval r = v.bsdf().eval(v.wo, wi, plainContext(ctx.mode));
                if (detail::requestCanChange(v, ctx)) {
                    const Color plain = r.f;
                    const BsdfEval hat = v.bsdf().eval(v.wo, wi, ctx);
                    r.f = hat.f;
                    pdfRef = hat.pdfFwd.value;
                    ratioRef = detail::regularisedRatio(r.f, plain);
                } else {
                    leftDelta += !ctx.reg.empty();
                }
                detail::applySurvival(r, sv);
                CHECK(e.f == r.f);
                CHECK(e.pdfFwd.value == r.pdfFwd.value);
                CHECK(e.pdfRev.value == r.pdfRev.value);
                CHECK((ratio == ratioRef || (std::isnan(ratio) && std::isnan(ratioRef))));
                CHECK(pdf == pdfRef);
                ++checked;
                nonZero += !isBlack(e.f);
            }
        }
    INFO(checked << " evaluations, " << nonZero << " non-zero, " << leftDelta << " left a delta by the request");
    CHECK(nonZero > 2000);
    CHECK(leftDelta > 1000);
}

TEST_CASE("regulariser seam: per-technique densities enter every technique's MIS weight", "[regularizer][mis]") {
    Scene scene(testScene());
    WalkStats ws;
    ScaledTechniques unit, scaled;
    unit.trivial = true;
    std::array<PathVertex, kMaxPathVertices> y, z;
    PathVertex cam = cameraEndpoint(scene, reg::kNone);
    int checked = 0, moved = 0;
    for (bool merging : {false, true}) {
        const MisConfig cfg{TechniqueSet::Bidirectional, merging, kPi * 0.01f * 0.01f, 64.f};
        for (uint64_t i = 0; i < 1500; ++i) {
            Rng rng(i, 8 + merging);
            const int ny = lightWalk(scene, reg::kNone, rng, 5, 100, y.data(), ws);
            const Vec2 raster(rng.uniform() * 8, rng.uniform() * 8);
            const int nz = cameraWalk(scene, reg::kNone, raster, rng, 5, 100, z.data(), ws);
            for (int s = 1; s <= ny; ++s)
                for (int t = 1; t <= nz; ++t) {
                    if (s == 1 && t == 1) continue;
                    const PathVertex* zz = t == 1 ? &cam : z.data();
                    Connection plain, ones, withFactors;
                    if (!connect(scene, reg::kNone, y.data(), s, zz, t, 100, plain, ws)) continue;
                    REQUIRE(connect(scene, unit, y.data(), s, zz, t, 100, ones, ws));
                    REQUIRE(connect(scene, scaled, y.data(), s, zz, t, 100, withFactors, ws));
                    INFO("path " << i << " s=" << s << " t=" << t << " merging " << merging);
                    CHECK_FALSE(plain.pdfs.perTechnique);
                    CHECK(withFactors.pdfs.perTechnique);
                    CHECK(samePdfs(plain.pdfs, withFactors.pdfs));
                    CHECK(withFactors.contribution == plain.contribution);
                    // Factors of 1: the unregularised weights.
                    CHECK(misWeight(ones.pdfs, s, cfg) == Approx(misWeight(plain.pdfs, s, cfg)).epsilon(1e-6));
                    // Any factors: the weights of all techniques, on one path, sum to one.
                    const PathPdfs& P = withFactors.pdfs;
                    double sum = 0.0;
                    for (int k = 0; k <= P.n; ++k) {
                        const bool valid = allowsTechnique(cfg.set, k, P.n - k) &&
                                           (k == 0 ? P.lightHittable : k < P.n && !P.delta[k - 1] && !P.delta[k]);
                        if (valid) sum += misWeight(P, k, cfg);
                        if (merging && k >= 1 && k <= P.n - 2 && !P.delta[k]) sum += misWeightMerge(P, k, cfg);
                    }
                    CHECK(sum == Approx(1.0).margin(1e-4));
                    ++checked;
                    moved += std::abs(misWeight(P, s, cfg) - misWeight(plain.pdfs, s, cfg)) > 1e-3f;
                }
        }
    }
    CHECK(checked > 2000);
    CHECK(moved > 500);  // the factors are applied
}

TEST_CASE("regulariser seam: per-technique densities keep the path tracer's limited forms", "[regularizer][pt]") {
    // The path tracer's two techniques compare x_0's densities only, so its limited gathers
    // (WalkPdfs::EmitterHits, readLimit 0) give the weights of the full gathers with a policy's
    // per-technique factors too (the closed form is bypassed; the factors come from the policy,
    // not from the densities). Entries the limited forms do not fill are poisoned (NaN): a sum
    // that read one would give NaN and fail.
    SceneDesc d = testScene();
    d.bsdfs.push_back(makeConductor(Color(0.2f), Color(3.f), Color(1.f)));
    d.meshes.push_back(smoothSphere(Vec3(0.3f, -0.6f, -0.2f), 0.3f, 8, 12, int(d.bsdfs.size()) - 1));
    Scene scene(d);
    WalkStats ws;
    const ScaledTechniques scaled;  // factors that differ per technique
    const MisConfig cfg{TechniqueSet::PathTracer};
    const int limit = misReadLimit(cfg);
    REQUIRE(limit < kMaxPathVertices);
    auto poison = [](PathPdfs& p) {
        p.fromLight.fill(std::numeric_limits<float>::quiet_NaN());
        p.fromCamera.fill(std::numeric_limits<float>::quiet_NaN());
    };
    std::array<PathVertex, kMaxPathVertices> zFull, zFast;
    int hits = 0, nee = 0;
    for (uint64_t i = 0; i < 2000; ++i) {
        const Vec2 raster(float(i % 8) + 0.5f, float((i / 8) % 8) + 0.5f);
        Rng r1(i, 9), r2(i, 9);
        const int n1 = cameraWalk(scene, scaled, raster, r1, 8, 100, zFull.data(), ws, WalkPdfs::All);
        // The path tracer's call (densities at emitter hits only).
        const int n2 = cameraWalk(scene, scaled, raster, r2, 8, 100, zFast.data(), ws, WalkPdfs::EmitterHits);
        REQUIRE(n1 == n2);
        for (int t = 2; t <= n1; ++t) {
            INFO("path " << i << " t=" << t);
            if (zFull[t - 1].light) {
                CHECK(zFast[t - 1].fromCamera.value == zFull[t - 1].fromCamera.value);  // computed at emitters
                PathPdfs a, b;
                poison(b);
                const Color ca = emitterHit(scene, scaled, zFull.data(), t, 100, a);
                const Color cb = emitterHit(scene, scaled, zFast.data(), t, 100, b, limit);
                REQUIRE(ca == cb);
                if (!isBlack(ca)) {
                    REQUIRE(b.perTechnique);
                    const float w = misWeight(b, 0, TechniqueSet::PathTracer);
                    CHECK(std::isfinite(w));
                    CHECK(w == Approx(misWeightGeneral(a, 0, cfg)).epsilon(1e-6));
                    ++hits;
                }
            }
            if (zFast[t - 1].infinite || !zFast[t - 1].connectible()) continue;
            Rng lr(i * 131 + t, 10), lr2(i * 131 + t, 10);
            PathVertex light, light2;
            if (!sampleLightVertex(scene, scaled, zFull[t - 1].p, lr, light)) continue;
            REQUIRE(sampleLightVertex(scene, scaled, zFast[t - 1].p, lr2, light2));
            Connection a, b;
            poison(b.pdfs);
            const bool okA = connect(scene, scaled, &light, 1, zFull.data(), t, 100, a, ws);
            const bool okB =
                connect<ConnectEnds::LightToSurface>(scene, scaled, &light2, 1, zFast.data(), t, 100, b, ws, limit);
            REQUIRE(okA == okB);
            if (!okA) continue;
            const float w = misWeight(b.pdfs, 1, TechniqueSet::PathTracer);
            CHECK(std::isfinite(w));
            CHECK(w == Approx(misWeightGeneral(a.pdfs, 1, cfg)).epsilon(1e-6));
            ++nee;
        }
    }
    CHECK(hits > 50);
    CHECK(nee > 2000);
}
