// KD13 (integrators/transport/kd13.h): the cone mollifier of smooth BSDFs, the choice of paths and
// of the estimator (maximum-distance heuristic), and renders.
#include <catch2/catch.hpp>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>
#include "bsdf/cone_mollifier.h"
#include "bsdf/fresnel.h"
#include "core/loader.h"
#include "integrators/integrator.h"
#include "integrators/transport/kd13.h"
#include "process.h"
#include "regularizer_paths.h"
#include "scene_builders.h"

using namespace lt;
using namespace lt::test;

namespace {

// The integral of f |cos wi| over the directions around `ideal` (local frame), out to 1.5 eps, by
// the midpoint rule in polar coordinates about the ideal direction (theta' fine enough that the
// cone's edge falls inside a cell of width 1.5 eps / 600: the rule's error there is < 1e-3). The
// directions are built in double and rounded to float, as a connection's are.
double coneIntegral(const Bxdf& b, const Vec3& wo, const BsdfContext& ctx, const DVec3& ideal, double eps) {
    const DVec3 n = glm::normalize(ideal);
    const DVec3 helper = std::abs(n.z) < 0.9 ? DVec3(0, 0, 1) : DVec3(1, 0, 0);
    const DVec3 u = glm::normalize(glm::cross(helper, n)), v = glm::cross(n, u);
    const int nTheta = 600, nPhi = 64;
    const double thetaMax = 1.5 * eps, dTheta = thetaMax / nTheta, dPhi = 2.0 * std::numbers::pi / nPhi;
    double sum = 0.0;
    for (int i = 0; i < nTheta; ++i) {
        const double th = (i + 0.5) * dTheta;
        for (int j = 0; j < nPhi; ++j) {
            const double ph = (j + 0.5) * dPhi;
            const DVec3 w = std::cos(th) * n + std::sin(th) * (std::cos(ph) * u + std::sin(ph) * v);
            const Vec3 wf(w);
            const BsdfEval e = b.eval(wo, wf, ctx);
            sum += double(e.f.x) * std::abs(double(wf.z)) * std::sin(th) * dTheta * dPhi;
        }
    }
    return sum;
}

BsdfContext coneContext(TransportMode mode, float eps) {
    BsdfContext c(mode);
    c.reg.cone = eps;
    return c;
}

// scenes/cornell-box-point-in-glass.xml at `res`, its point light (intensity 5) split into `lights`
// coincident point lights of intensity 5 / lights: the same image, next-event estimation picking
// each with probability 1 / lights.
SceneDesc pointInGlass(int res, int lights) {
    SceneDesc desc = loadScene(std::string(LT_SOURCE_DIR) + "/scenes/cornell-box-point-in-glass.xml",
                               {{"res", std::to_string(res)}});
    REQUIRE(desc.emitters.size() == 1);
    desc.emitters[0].value = desc.emitters[0].value / float(lights);
    for (int i = 1; i < lights; ++i) desc.emitters.push_back(desc.emitters[0]);
    return desc;
}

reg::Kd13 kd13For(TechniqueSet set, bool merging, double r0 = 0.01, double lambda = -1.0) {
    reg::Kd13Settings k;
    k.r0 = r0;
    k.lambda = lambda;
    reg::Kd13 kd(k);
    kd.setScale(r0, 10.0);
    kd.setTechniques(set, merging);
    kd.setIteration(1);
    return kd;
}


}  // namespace

TEST_CASE("KD13 cone: Omega = 4 pi sin^2(eps/2) stays accurate, positive and finite", "[kd13][cone]") {
    // Against the solid angle in long double, 2 pi (1 - cos eps) = 4 pi sin^2(eps/2) (the sine
    // form: in long double too, 1 - cos eps keeps only ~5 digits at eps = 1e-7): relative 1e-6 in
    // float for every eps from 1e-7 to 0.5 rad. The float form 2 pi (1 - cos eps) is 0 below eps
    // ~ 3e-4, which is why it is not used.
    for (double eps : {1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 0.1, 0.5}) {
        const long double half = std::sin((long double)float(eps) / 2.0L);
        const long double exact = 4.0L * std::numbers::pi_v<long double> * half * half;
        const float omega = coneSolidAngle(float(eps));
        INFO("eps " << eps << " Omega " << omega << " exact " << double(exact));
        CHECK(std::abs(double(omega) / double(exact) - 1.0) < 1e-6);
        CHECK(ConeMollifier(float(eps)).invOmega > 0.f);
        CHECK(std::isfinite(ConeMollifier(float(eps)).invOmega));
    }
    CHECK(2.f * kPi * (1.f - std::cos(1e-4f)) == 0.f);
    // Every r_N the schedule reaches by N = 1e12, for the default lambdas and a fixed radius, over
    // connections from 1e-4 to 1e4 scene radii: eps > 0 and 1 / Omega finite.
    for (double lambda : {-1.0, 0.0, 0.49}) {
        const reg::Kd13 kd = kd13For(TechniqueSet::Bidirectional, false, 0.01, lambda);
        for (double N : {1.0, 1e3, 1e6, 1e9, 1e12}) {
            reg::Kd13 k = kd;
            k.setIteration(uint64_t(N));
            for (int m : {1, 2})
                for (double l : {1e-4, 1.0, 1e4, double(kInf)}) {
                    const float eps = float(k.coneAngle(m, l));
                    const ConeMollifier c(eps);
                    INFO("lambda " << lambda << " N " << N << " mollified " << m << " l " << l << " eps " << eps);
                    CHECK(eps > 0.f);
                    CHECK(c.invOmega > 0.f);
                    CHECK(std::isfinite(c.invOmega));
                }
        }
    }
}

TEST_CASE("KD13 cone: the mollified BSDF integrates to the delta lobe's weight", "[kd13][cone]") {
    // A smooth conductor and a smooth dielectric (eta 1.5, from outside and inside, and index
    // matched), evaluated with a cone request: the integral of f |cos wi| over the cone is the
    // weight the walk's delta sample carries (Fresnel F of wo for reflection, (1 - F) for
    // refraction, over eta^2 for radiance), for eps from 1e-6 to 0.5 rad. Tolerance: 2e-3 relative
    // from the quadrature for eps >= 1e-4; below, the float directions' rounding (about 6e-8,
    // against a cone of radius 1e-6) moves the edge by up to 6%, which averages out over the
    // cone's rim to within 2% (measured: at most 1.4%, at eps 1e-6). Outside the cone f is 0.
    const BxdfPtr mirror = makeConductor(Color(0.2f), Color(3.f), Color(1.f));
    const BxdfPtr glass = makeDielectric(1.5f), matched = makeDielectric(1.f);
    const Vec3 woOut = glm::normalize(Vec3(0.3f, -0.2f, 0.8f)), woIn = glm::normalize(Vec3(0.1f, 0.25f, -0.9f));
    for (double eps : {1e-6, 1e-4, 1e-2, 0.1, 0.5}) {
        const double tol = eps >= 1e-4 ? 2e-3 : 2e-2;
        for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
            const BsdfContext ctx = coneContext(mode, float(eps));
            INFO("eps " << eps << " mode " << int(mode));
            {  // conductor: weight F(cos theta_o)
                const double F = fresnelConductor(woOut.z, 0.2f, 3.f);
                CHECK(std::abs(coneIntegral(*mirror, woOut, ctx, idealReflection(woOut), eps) / F - 1.0) < tol);
            }
            for (const Vec3& wo : {woOut, woIn}) {
                const float etaRel = wo.z > 0.f ? 1.5f : 1.f / 1.5f;
                const double F = fresnelDielectric(std::abs(wo.z), etaRel);
                INFO("wo.z " << wo.z << " F " << F);
                CHECK(std::abs(coneIntegral(*glass, wo, ctx, idealReflection(wo), eps) / F - 1.0) < tol);
                DVec3 t;
                REQUIRE(idealRefraction(wo, 1.5f, t));
                const double T = (1.0 - F) / (mode == TransportMode::Radiance ? double(etaRel) * etaRel : 1.0);
                CHECK(std::abs(coneIntegral(*glass, wo, ctx, t, eps) / T - 1.0) < tol);
            }
            CHECK(std::abs(coneIntegral(*matched, woOut, ctx, DVec3(-Vec3(woOut)), eps) - 1.0) < tol);
            // Outside the cone (twice eps off the ideal direction) and on the wrong lobe: 0.
            const DVec3 r = idealReflection(woOut);
            const DVec3 off = glm::normalize(r + 2.0 * eps * glm::normalize(glm::cross(r, DVec3(0, 0, 1))));
            CHECK(mirror->eval(woOut, Vec3(off), ctx).f == Color(0.f));
            CHECK(glass->eval(woOut, Vec3(r), ctx).f.x > 0.f);
            CHECK(glass->eval(woOut, Vec3(off), ctx).f == Color(0.f));
        }
    }
    // Without the cone the smooth BSDFs stay deltas; a rough lobe ignores the cone.
    CHECK(mirror->eval(woOut, Vec3(idealReflection(woOut)), kRadianceContext).f == Color(0.f));
    CHECK(mirror->isDelta());
    CHECK_FALSE(mirror->deltaUnder(coneContext(TransportMode::Radiance, 0.01f)));
    const BxdfPtr rough = makeRoughConductor(MicrofacetType::GGX, 0.3f, 0.3f, Color(0.2f), Color(3.f), Color(1.f));
    const Vec3 wi = Vec3(idealReflection(woOut));
    CHECK(rough->eval(woOut, wi, coneContext(TransportMode::Radiance, 0.01f)).f ==
          rough->eval(woOut, wi, kRadianceContext).f);
}

TEST_CASE("KD13 mollifies only paths no technique of the integrator samples, by the maximum-distance heuristic", "[kd13][select]") {
    // Paths on a line (x_0 the light at the origin, the camera at z = 5), so every length is known.
    // For each split into a technique (s light vertices), select() answers: unregularised (a path
    // some technique samples: only techniques with two non-delta ends contribute), or the one
    // chosen estimator (the fewest mollified vertices, then the longest connection) alone.
    const BxdfPtr glass = makeDielectric(1.5f), diffuse = makeDiffuse(Color(0.5f));
    Light point, area;
    point.type = LightType::Point;
    area.type = LightType::Area;
    // The techniques (s) of the integrator that contribute, and the vertices the contributing one
    // mollifies. (select() is asked by the integrators' techniques only: the emitter hit where
    // the light can be hit, the connections of their set.)
    auto contributing = [](HandPath& h, const reg::Kd13& kd, std::vector<int>& mollified) {
        std::vector<int> out;
        const int n = int(h.x.size());
        for (int s = 0; s < n; ++s) {
            if (s == 0 && !h.x[0].light->isHittable()) continue;
            if (!allowsTechnique(kd.techniques(), s, n - s)) continue;
            Technique t = h.technique(kd, s);
            if (!kd.select(t)) continue;
            out.push_back(s);
            mollified.clear();
            for (int j : t.regularised)
                if (j >= 0) mollified.push_back(j);
        }
        return out;
    };
    const reg::Kd13 bpt = kd13For(TechniqueSet::Bidirectional, false), pt = kd13For(TechniqueSet::PathTracer, false),
                    vcm = kd13For(TechniqueSet::Bidirectional, true);
    std::vector<int> m;
    SECTION("L S S E: one vertex beats two, then the longest connection") {
        // Connections: x0-x1 (mollify x1), x1-x2 (both), x2-x3 (x2: light tracing).
        HandPath a = HandPath::onAxis(point, {{1.f, glass.get()}, {1.5f, glass.get()}});  // lengths 1, 0.5, 3.5
        CHECK(contributing(a, bpt, m) == std::vector<int>{3});
        CHECK(m == std::vector<int>{2});
        HandPath b = HandPath::onAxis(point, {{0.2f, glass.get()}, {4.f, glass.get()}});  // 0.2, 3.8 (two vertices), 1
        CHECK(contributing(b, bpt, m) == std::vector<int>{3});
        CHECK(m == std::vector<int>{2});
        HandPath c = HandPath::onAxis(point, {{3.f, glass.get()}, {3.5f, glass.get()}});  // 3, 0.5, 1.5
        CHECK(contributing(c, bpt, m) == std::vector<int>{1});
        CHECK(m == std::vector<int>{1});
        // PT has next-event estimation only (s = 1): x0-x1 whatever the lengths.
        CHECK(contributing(a, pt, m) == std::vector<int>{1});
        CHECK(m == std::vector<int>{1});
        // VCM: no non-delta vertex to merge at, so as BPT.
        CHECK(contributing(a, vcm, m) == std::vector<int>{3});
        // The cone: eps = arctan(r_N / l) of the chosen connection, at its mollified end only.
        Technique t = a.technique(bpt, 3);
        REQUIRE(bpt.select(t));
        CHECK(t.bound[0] == Approx(std::atan(0.01 / 3.5)).epsilon(1e-5));
        CHECK(bpt.context(t, End::Light).reg.cone == t.bound[0]);
        CHECK(bpt.context(t, End::Camera).reg.cone == 0.f);
    }
    SECTION("L S D S E: BPT mollifies one vertex, VCM merges at the diffuse vertex instead") {
        HandPath h = HandPath::onAxis(point, {{0.5f, glass.get()}, {2.f, diffuse.get()}, {2.5f, glass.get()}});
        // Lengths 0.5, 1.5, 0.5, 2.5: light tracing from x3, the longest with one mollified vertex.
        CHECK(contributing(h, bpt, m) == std::vector<int>{4});
        CHECK(m == std::vector<int>{3});
        CHECK(contributing(h, vcm, m).empty());  // (no connection samples it: the merge at x2 does)
    }
    SECTION("paths some technique samples are left alone") {
        // An area light behind glass: the camera walk hits it (s = 0).
        HandPath h = HandPath::onAxis(area, {{1.f, glass.get()}});
        CHECK(contributing(h, bpt, m) == std::vector<int>{0});
        CHECK(m.empty());
        // A diffuse vertex next to the light, seen through glass: next-event estimation at x1
        // samples it (PT and BPT); the connections at the glass give nothing.
        HandPath d = HandPath::onAxis(point, {{1.f, diffuse.get()}, {2.f, glass.get()}});
        for (const reg::Kd13* kd : {&pt, &bpt}) {
            CHECK(contributing(d, *kd, m) == std::vector<int>{1});
            CHECK(m.empty());
        }
        // Light tracing alone (the LT integrator) has x2 - camera only: mollified at the glass.
        const reg::Kd13 lt = kd13For(TechniqueSet::LightTracer, false);
        CHECK(contributing(d, lt, m) == std::vector<int>{3});
        CHECK(m == std::vector<int>{2});
    }
}

TEST_CASE("KD13: one technique per regularised path with weight 1, unregularised paths weighted as without KD13", "[kd13][mis]") {
    // BPT and VCM paths in the box with a glass sphere, a mirror ball and a point light inside the
    // glass. For every connected path: every split of its vertices into a
    // technique of the set (the records rebuilt as the walks write them) agrees on the choice, so
    // that exactly one technique contributes to a regularised path, with MIS weight 1 (the
    // weights over the techniques that can sample the regularised path sum to one); a path some
    // technique samples is weighted exactly (bit for bit) as without a regulariser.
    // The point light alone (the area light's panel left as black geometry), so that every light
    // path starts inside the glass.
    SceneDesc desc = mixedSceneWithPointInGlass(16);
    for (MeshDesc& m : desc.meshes)
        if (m.emitter == 0) m.emitter = -1;
    desc.emitters.erase(desc.emitters.begin());
    const bool merging = GENERATE(false, true);
    INFO("merging " << merging);
    Scene scene(desc);
    WalkStats ws;
    std::array<PathVertex, kMaxPathVertices> y, z;
    const MisConfig cfg{TechniqueSet::Bidirectional, merging, kPi * 0.05f * 0.05f, 256.f};
    // A wide cone (r0 3 against a box of radius ~1.7: eps ~ 0.5-1.5 rad), so that many
    // connections at the glass and the mirror land in it.
    reg::Kd13 kd(reg::Kd13Settings{3.0, 0.0});
    kd.beginIteration(7, scene, cfg);
    const PathVertex cam = cameraEndpoint(scene, kd);
    int regularisedPaths = 0, plainPaths = 0;
    for (uint64_t i = 0; i < 3000; ++i) {
        Rng rng(i, 91);
        const int ny = lightWalk(scene, kd, rng, 6, 100, y.data(), ws);
        const int nz = cameraWalk(scene, kd, Vec2(rng.uniform() * 16, rng.uniform() * 16), rng, 6, 100, z.data(), ws);
        forEachConnection(scene, kd, y.data(), ny, z.data(), nz, cam, ws, [&](int s, int t, const PathVertex* zz,
                                                                              const Connection& c) {
            Technique own{y.data(), s, zz, t};
            REQUIRE(kd.select(own));
            const bool regularised = own.regularised[0] >= 0;
            INFO("path " << i << " s=" << s << " t=" << t);
            const float w = misWeight(c.pdfs, s, cfg);
            if (!regularised) {
                // The same connection without a regulariser: the same weight, bit for bit.
                Connection plain;
                REQUIRE(connect(scene, reg::kNone, y.data(), s, zz, t, 100, plain, ws));
                CHECK(w == misWeight(plain.pdfs, s, cfg));
                CHECK(c.contribution == plain.contribution);
                ++plainPaths;
                return;
            }
            CHECK(c.pdfs.regularised);
            CHECK(w == 1.f);
            // Every other split of the path: none contributes.
            HandPath h;
            for (int k = 0; k < s; ++k) h.x.push_back(y[k]);
            for (int k = t - 1; k >= 0; --k) h.x.push_back(zz[k]);
            const int n = s + t;
            for (int k = 1; k < n; ++k) {
                if (k == s) continue;
                Technique other = h.technique(kd, k);
                CHECK_FALSE(kd.select(other));
            }
            ++regularisedPaths;
        });
    }
    INFO(regularisedPaths << " regularised paths, " << plainPaths << " others");
    CHECK(regularisedPaths > 50);
    CHECK(plainPaths > 3000);
}

TEST_CASE("KD13 in the path tracer: the cone hit's density is P(lobe), and it and next-event estimation share each path", "[kd13][mis]") {
    // kd13.h (5). Camera walks in scenes/cornell-box-point-in-glass.xml (a point light at the
    // centre of a smooth glass sphere, int_ior bk7 = 1.5046 in air 1.000277), split into two
    // coincident lights (next-event estimation picks each with sel = 1/2): at every glass vertex
    // z[t-1] where next-event estimation through the cone carries something, the path's densities
    // must hold the cone hit's: P(lobe) of the delta lobe on the light's side, computed here from
    // the Fresnel equations (transmission, 1 - F, from outside the sphere; reflection, F, from
    // inside, where the light is on wo's side), against next-event estimation's sel; the two
    // power-heuristic weights must be sel^2 / (sel^2 + P^2) and P^2 / (sel^2 + P^2) and sum to one
    // (float). With the one light of the scene file the cone hit does not compete (sel = 1: next-
    // event estimation alone has the lower variance), so next-event estimation's weight is 1. A
    // cone of fixed radius 3 (eps ~ 1.5 rad at the light's 0.3) lets most glass vertices in.
    // Taking the lobe on wo's side, or 1 - P, or no hit density fails it.
    const int lights = GENERATE(1, 2);
    INFO(lights << " lights");
    Scene scene(pointInGlass(16, lights));
    const double sel = 1.0 / lights;
    const MisConfig cfg{TechniqueSet::PathTracer};
    reg::Kd13 kd(reg::Kd13Settings{3.0, 0.0});
    kd.beginIteration(3, scene, cfg);
    WalkStats ws;
    std::array<PathVertex, kMaxPathVertices> z;
    int outside = 0, inside = 0;
    for (uint64_t i = 0; i < 4000; ++i) {
        Rng rng(i, 17);
        const int nz = cameraWalk(scene, kd, Vec2(rng.uniform() * 16, rng.uniform() * 16), rng, 8, 100, z.data(), ws);
        for (int t = 2; t <= nz; ++t) {
            const PathVertex& v = z[t - 1];
            if (!kd.coneHitsAt(v)) continue;
            PathVertex y;
            REQUIRE(lightEndpoint(scene, kd, 0, v.p, Vec2(0.5f), y));
            Connection c;
            if (!connect(scene, kd, &y, 1, z.data(), t, 100, c, ws, 0)) continue;
            INFO("walk " << i << " t=" << t);
            const Vec3 toLight = glm::normalize(y.p - v.p);
            const float cosO = glm::dot(v.wo, v.shading.n), cosL = glm::dot(toLight, v.shading.n);
            const float eta = 1.5046f / 1.000277f;
            const float F = fresnelDielectric(std::abs(cosO), cosO > 0.f ? eta : 1.f / eta);
            const bool sameSide = cosO * cosL > 0.f;
            const double P = sameSide ? F : 1.0 - F;
            (sameSide ? inside : outside) += 1;
            CHECK(c.pdfs.regularised);
            CHECK(c.pdfs.fromLight[0] == Approx(sel).epsilon(1e-6));
            const double wNee = misWeight(c.pdfs, 1, TechniqueSet::PathTracer),
                         wHit = misWeight(c.pdfs, 0, TechniqueSet::PathTracer);
            if (lights == 1) {
                CHECK(wNee == 1.0);
                CHECK(wHit == 0.0);
                continue;
            }
            CHECK(c.pdfs.fromCamera[0] == Approx(P).epsilon(1e-5));
            CHECK(wNee == Approx(sel * sel / (sel * sel + P * P)).epsilon(1e-5));
            CHECK(wHit == Approx(P * P / (sel * sel + P * P)).epsilon(1e-5));
            CHECK(std::abs(wNee + wHit - 1.0) < 1e-6);
            // The plain sum (no closed form) gives the same.
            CHECK(misWeightGeneral(c.pdfs, 0, cfg) == Approx(wHit).epsilon(1e-6));
        }
    }
    INFO(outside << " connections from outside the glass, " << inside << " from inside");
    CHECK(outside > 100);
    CHECK(inside > 20);
}

TEST_CASE("KD13 on a scene where every path is samplable renders bit-identically to no regulariser", "[kd13][render]") {
    // The box with a glass sphere and a mirror ball lit by an area light: every path ends on a
    // light the camera walk can hit, so KD13 mollifies nothing (selectivity, KD13 Sec. 4.4), for
    // PT, BPT and VCM, though its connections at the smooth surfaces run (and are refused).
    Scene scene(mixedScene(24));
    checkBitIdenticalToNone(
        scene, [](RenderSettings& s) { s.regularizer = "kd13"; }, [](const RenderStats&) {});
}

TEST_CASE("KD13 renders a point light seen through glass, with the energy of the point seen directly", "[kd13][render][strategies]") {
    // scenes/cornell-box-point-in-glass.xml: the point light (intensity 5) at the centre of a
    // smooth glass sphere, 6.8 in front of the pinhole. No unregularised technique renders it seen
    // through the glass (L S E, L S S E); KD13 does (singular.exr). The truth: every ray from the
    // centre leaves the sphere at normal incidence, after any number of internal reflections (each
    // back through the centre), so the sphere sends the point's whole intensity out radially,
    // T (1 + R + R^2 + ...) = 1: the point looks exactly as seen directly, I / (d^2 A) = 0.9156 on
    // the image mean (A = 4 tan^2(fov / 2); the JG19 test checks this formula with a small
    // spherical light). A cone conserves the energy of the delta it replaces to first order in
    // eps, so the singular part's mean tends to 0.9156 up to O(eps^2).
    // Fixed radii (lambda 0) giving a cone of eps ~ 0.1 rad on the chosen connection: PT's
    // next-event estimation from the glass to the light (l = 0.3: r0 0.03), BPT's and VCM's light
    // tracing from the glass to the camera (l ~ 6.5: r0 0.65). Measured (64^2, max depth 8): PT
    // 256 spp, eight seeds: mean 0.9155, standard deviation 0.018 (the cone's image covers about
    // 4 pixels: a sample is in it or not), so about 0.009 at 1024 spp; BPT 1024 spp 0.909, 0.907,
    // 0.922, 0.912 (seeds 3-6; about 8 light paths per pass land in the cone: ~1% noise, ~1.5% at
    // 512 spp). Tolerances: PT 4% at 1024 spp, BPT and VCM 5% at 512 spp (over 3 standard
    // deviations each). A missing 1/eta^2 (x 2.26), F in place of 1 - F (x 0.04) or a wrong Omega
    // fails them.
    // PT has two techniques for these paths (kd13.h (5)): next-event estimation through the cone
    // and the cone hit of a BSDF sample. With the scene's one light the cone hits do not compete
    // (no image s0_t3, the cone hit's of L S E); with --pt-strategy bsdf they run alone and must
    // give the same energy (measured 0.927, 0.909, 0.904, 0.907 at 1024 spp, seeds 3-6, against
    // next-event estimation 0.924, 0.909, 0.906, 0.909: the same tolerance). With the light split
    // into two coincident lights of half the intensity (the same image), they compete: the energy
    // is the same (measured 0.906, 0.909, seeds 5-6), and the cone hits' share of the singular
    // image is predicted exactly: L S E (s0_t3, t = 3 camera-side vertices) carries
    // T = 1 - F(0) = 0.9594 of the singular energy (the rest leaves after internal reflections),
    // and the cone hit's weight there is P^2 / (sel^2 + P^2) with P = T (the refraction lobe's
    // probability) and sel = 1/2: 0.7864, so the share is 0.7545 (measured 0.7548, 0.7545: the
    // ratio's noise is small, both images holding the same few pixels). Tolerance 0.01: sel = 1
    // (0.460), the balance heuristic (0.657 x 0.959 = 0.630), the reflection lobe's P (0.04:
    // share 0.006) or a hit counting only one of the two lights (half the share) fail.
    const double tanHalf = std::tan(19.5 * std::numbers::pi / 360.0);
    const double direct = 5.0 / (6.8 * 6.8 * 4.0 * tanHalf * tanHalf);
    const Scene scene(pointInGlass(64, 1));
    const std::filesystem::path dir = lt::test::tempDir("lt_kd13", "singular");
    auto singularMean = [&](const std::string& integrator, int spp, double r0, const std::string& strategy = "mis",
                            const Scene* on = nullptr, const std::string& tag = "") {
        RenderSettings s = settingsFor(integrator, spp);
        s.maxDepth = 8;
        s.regularizer = "kd13";
        s.regR0 = r0;
        s.regLambda = 0.0;
        s.ptStrategy = strategy;
        const std::filesystem::path out = dir / (integrator + strategy + tag);
        s.strategyImages = out.string();
        RenderStats st;
        renderImage(on ? *on : scene, s, st);
        return cropMean(readImage((out / "singular.exr").string()), 64, 0, 0, 64, 64);
    };
    const double pt = singularMean("pt", 1024, 0.03), bpt = singularMean("bpt", 512, 0.65),
                 vcm = singularMean("vcm", 512, 0.65);
    const bool hitsWithOneLight = std::filesystem::exists(dir / "ptmis" / "s0_t3.exr");
    const double ptHits = singularMean("pt", 1024, 0.03, "bsdf");
    const Scene two(pointInGlass(64, 2));
    const double ptTwo = singularMean("pt", 1024, 0.03, "mis", &two, "two");
    const double hitShare = cropMean(readImage((dir / "ptmistwo" / "s0_t3.exr").string()), 64, 0, 0, 64, 64) / ptTwo;
    INFO("direct " << direct << ": PT " << pt << ", PT cone hits alone " << ptHits << ", PT with two lights " << ptTwo
                   << " (cone hits' share of it " << hitShare << "), BPT " << bpt << ", VCM " << vcm);
    CHECK(std::abs(pt / direct - 1.0) < 0.04);
    CHECK_FALSE(hitsWithOneLight);
    CHECK(std::abs(ptHits / direct - 1.0) < 0.04);
    CHECK(std::abs(ptTwo / direct - 1.0) < 0.04);
    CHECK(std::abs(hitShare - 0.7545) < 0.01);
    CHECK(std::abs(bpt / direct - 1.0) < 0.05);
    CHECK(std::abs(vcm / direct - 1.0) < 0.05);
    std::filesystem::remove_all(dir);
}

TEST_CASE("KD13 renders the point light imaged by a glass sphere, which no unregularised technique renders", "[kd13][render][strategies]") {
    // scenes/hard/specular-point-view.xml: L S S E (a point light behind a smooth glass sphere,
    // imaged by it onto the centre of the image). Without a regulariser PT, BPT and VCM have no
    // singular part at all (no singular.exr); with KD13 each has one, inside the sphere's image
    // (the centre 16^2 of 32^2 holds all of it), where it brightens the centre by that much.
    const std::filesystem::path dir = lt::test::tempDir("lt_kd13", "spv");
    SceneDesc desc = loadScene(std::string(LT_SOURCE_DIR) + "/scenes/hard/specular-point-view.xml", {{"res", "32"}});
    Scene scene(desc);
    for (const char* integrator : {"pt", "bpt", "vcm"}) {
        INFO(integrator);
        RenderSettings s = settingsFor(integrator, 64);
        s.maxDepth = 12;
        RenderSettings k = s;
        k.regularizer = "kd13";
        s.strategyImages = (dir / (std::string(integrator) + "-none")).string();
        k.strategyImages = (dir / (std::string(integrator) + "-kd13")).string();
        RenderStats a, b;
        const Image plain = renderImage(scene, s, a), reg = renderImage(scene, k, b);
        CHECK_FALSE(std::filesystem::exists(dir / (std::string(integrator) + "-none") / "singular.exr"));
        const Image singular = readImage((dir / (std::string(integrator) + "-kd13") / "singular.exr").string());
        const double all = cropMean(singular, 32, 0, 0, 32, 32), centre = cropMean(singular, 32, 8, 8, 16, 16);
        INFO("singular mean " << all << ", in the centre " << centre * 0.25);
        CHECK(all > 0.01);
        CHECK(centre * 0.25 == Approx(all).epsilon(1e-6));
        CHECK(b.regularisedContributions > 0);
        CHECK(a.regularisedContributions == 0);
        (void)plain, (void)reg;
    }
    std::filesystem::remove_all(dir);
}

// The consistency test (r_N shrinking the blur) is in test_regularizer_consistency.cpp.
