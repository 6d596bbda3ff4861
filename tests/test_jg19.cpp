// JG19 microfacet regularisation (integrators/transport/jg19.h) in PT, BPT and VCM: the policy
// changes nothing when its bound changes no lobe, its MIS weights equal a brute-force evaluation
// of the regularised densities (Eq. 13), and it renders light that the unregularised path tracer
// cannot (a point light inside glass).
#include <catch2/catch.hpp>
#include <array>
#include <cmath>
#include <vector>
#include "core/loader.h"
#include "integrators/integrator.h"
#include "integrators/transport/light_paths.h"
#include "integrators/transport/path_templates.h"
#include "scene_builders.h"

using namespace lt;
using namespace lt::test;

namespace {

// Glossy panel (GGX alpha 0.05), a smooth glass sphere and a smooth mirror ball in the box.
SceneDesc mixedScene(int res) {
    SceneDesc d = cornellBox(res, makeRoughConductor(MicrofacetType::GGX, 0.05f, 0.05f, Color(0.2f, 0.9f, 1.1f),
                                                     Color(3.9f, 2.4f, 2.1f), Color(1.f)));
    d.bsdfs.push_back(makeDielectric(1.5f));
    d.spheres[0].bsdf = int(d.bsdfs.size()) - 1;  // the box's sphere: glass
    d.bsdfs.push_back(makeConductor(Color(0.2f), Color(3.f), Color(1.f)));
    d.meshes.push_back(smoothSphere(Vec3(-0.45f, -0.65f, 0.2f), 0.3f, 8, 12, int(d.bsdfs.size()) - 1));
    return d;
}

RenderSettings settingsFor(const std::string& integrator, int spp) {
    RenderSettings s;
    s.integrator = integrator;
    s.spp = spp;
    s.threads = 2;
    s.seed = 5;
    s.maxDepth = 6;
    s.quiet = true;
    return s;
}

}  // namespace

TEST_CASE("JG19 with a bound that changes no lobe renders bit-identically to no regulariser", "[jg19]") {
    // tau_0 = 1e30: alpha_hat ~ 1e-7 for every lobe of the scene (below kMinAlpha), so smooth
    // surfaces stay deltas and rough ones keep their alphas. Every code path of the policy runs
    // (walks computing ratios, connectibility, per-technique checks); the images must not change
    // by a single bit, for PT, BPT and VCM.
    Scene scene(mixedScene(24));
    for (const char* integrator : {"pt", "bpt", "vcm"}) {
        INFO(integrator);
        RenderSettings plain = settingsFor(integrator, 3), reg = plain;
        reg.regularizer = "jg19";
        reg.regTau = 1e30;
        RenderStats a, b;
        const Image ia = renderImage(scene, plain, a), ib = renderImage(scene, reg, b);
        REQUIRE(ia.pixels.size() == ib.pixels.size());
        size_t differ = 0;
        for (size_t i = 0; i < ia.pixels.size(); ++i) differ += !(ia.pixels[i] == ib.pixels[i]);
        CHECK(differ == 0);
        CHECK(b.regularisedContributions == 0);
        CHECK(b.contributions > 1000);
        CHECK(b.tau > 1e30);
    }
}

namespace {

// The brute-force weight of a technique under JG19, from the path's vertices and its gathered
// sampling densities (tested elsewhere), with nothing of the policy's bookkeeping (the walks'
// stored ratios, the singular-vertex rule, the delta flags): every BSDF is evaluated here at the
// path's vertices, and whether a smooth vertex is specular on this path is decided from its
// geometry.
struct BruteForce {
    const reg::Jg19& jg;
    std::vector<const PathVertex*> x;  // x_0 (light) .. x_{n-1} (camera)
    const PathPdfs& P;
    MisConfig cfg;
    bool regularisedMis;
    // A merge at x_i: the light vertex y[i] merged at the camera vertex x_i. The light subpath's
    // own vertex is x_{i-1}'s neighbour (as its walk saw it), and the camera vertex looks towards
    // y[i-1] along y[i].wo (as merge evaluates it).
    int mergeAt = -1;
    const PathVertex* mergeLight = nullptr;

    int n() const { return int(x.size()); }
    Vec3 dir(int from, int to) const {
        if (mergeLight && from == mergeAt - 1 && to == mergeAt) return glm::normalize(mergeLight->p - x[from]->p);
        if (mergeLight && from == mergeAt && to == mergeAt - 1) return mergeLight->wo;
        return glm::normalize(x[to]->p - x[from]->p);
    }
    // rho and rho_hat of x_j's BSDF between its path neighbours (channel sums).
    void values(int j, double& plain, double& hat) const {
        const PathVertex& v = *x[j];
        const SurfaceBsdf b(v.bxdf, v.shading, v.ng);
        const Vec3 wo = dir(j, j + 1), wi = dir(j, j - 1);  // (either order: the ratio is symmetric)
        RegularizationRequest request;
        request.tau = jg.tau();
        const Color p = b.eval(wo, wi, kRadianceContext).f, h = b.eval(wo, wi, BsdfContext(TransportMode::Radiance, request)).f;
        plain = double(p.x) + p.y + p.z;
        hat = double(h.x) + h.y + h.z;
    }
    // Is the smooth vertex x_j a specular pair on this path (mirror reflection or refraction)?
    bool specular(int j) const {
        const PathVertex& v = *x[j];
        const Vec3 n = v.shading.n, a = dir(j, j - 1), b = dir(j, j + 1);
        const float ca = glm::dot(a, n), cb = glm::dot(b, n);
        if (ca * cb > 0.f) return glm::length(b - (2.f * ca * n - a)) < 2e-3f;  // reflection
        const float eta = v.bxdf->name() == "dielectric" ? 1.5f : 1.f;
        const float etaRel = ca > 0.f ? eta : 1.f / eta;  // n_b / n_a
        // Snell: the tangential components satisfy t_a = -etaRel t_b.
        const Vec3 ta = a - ca * n, tb = b - cb * n;
        return glm::length(ta + etaRel * tb) < 2e-3f;
    }
    // p_k / p_base of the gathered sampling densities.
    double ratio(int k, int base) const {
        double r = 1.0;
        auto rm = [](float p) { return p != 0.f ? double(p) : 1.0; };
        for (int i = base; i < k; ++i) r *= rm(P.fromLight[i]) / rm(P.fromCamera[i]);
        for (int i = k; i < base; ++i) r *= rm(P.fromCamera[i]) / rm(P.fromLight[i]);
        return r;
    }
    // The weight of connection technique s, or of the merge (mergeAt >= 0; s ignored).
    double weight(int s) const {
        const int N = n();
        std::vector<double> plain(N, 1.0), hat(N, 1.0);
        std::vector<bool> smooth(N, false), spec(N, false);
        for (int j = 1; j <= N - 2; ++j) {
            values(j, plain[j], hat[j]);
            smooth[j] = x[j]->deltaBsdf;
            spec[j] = smooth[j] && specular(j);
        }
        // f_k p_k relative to the base, or -1 when technique k cannot produce this path.
        auto coefficient = [&](const std::vector<int>& ends) -> double {
            double f = 1.0;
            for (int j = 1; j <= N - 2; ++j) {
                const bool mine = std::find(ends.begin(), ends.end(), j) != ends.end();
                if (smooth[j]) {
                    // Specular here: only techniques sampling through it (a finite rho_hat beside a
                    // delta has weight 0). Not specular: only techniques regularising it, and
                    // only if its rho_hat is not 0.
                    if (spec[j] == mine || (mine && !(hat[j] > 0.0))) return -1.0;
                } else if (mine && regularisedMis) {
                    if (!(plain[j] > 0.0)) return -1.0;
                    f *= hat[j] / plain[j];
                }
            }
            return f;
        };
        const int base = mergeAt >= 0 ? mergeAt : s;
        const double vm = double(cfg.mergeArea) * double(cfg.lightPaths);
        auto mergeDensity = [&](int i) { return vm * (P.fromLight[i] != 0.f ? double(P.fromLight[i]) : 1.0); };
        double sum = 0.0, own = 0.0;
        for (int k = 0; k < N; ++k) {
            if (!allowsTechnique(cfg.set, k, N - k)) continue;
            if (k == 0 && !(x[0]->light && x[0]->light->isHittable())) continue;
            const double c = coefficient({k - 1, k});
            if (c < 0.0) continue;
            const double term = ratio(k, base) * c;
            sum += term * term;
            if (mergeAt < 0 && k == s) own = term * term;
        }
        if (cfg.merging)
            for (int i = 1; i <= N - 2; ++i) {
                if (smooth[i]) continue;  // photons lie on non-delta surfaces
                const double c = coefficient({i});
                if (c < 0.0) continue;
                const double term = ratio(i, base) * mergeDensity(i) * c;
                sum += term * term;
                if (i == mergeAt) own = term * term;
            }
        return sum > 0.0 ? own / sum : 0.0;
    }
};

}  // namespace

TEST_CASE("JG19 MIS weights equal a brute-force evaluation of the regularised densities (Eq. 13)", "[jg19][mis]") {
    // Paths of BPT and VCM through a glossy panel (alpha 0.05), a smooth glass sphere and a mirror
    // ball, tau = 30: connections end on glossy, glass and mirror vertices (both ends regularised
    // on many paths), merges regularise their camera vertex. Tolerance 2e-3: the weights are
    // computed in float from float densities; the brute force in double from the same densities
    // and fresh BSDF evaluations (the walks' ratios used directions from the same positions), so
    // only rounding separates them (largest difference measured: see the INFO on failure).
    Scene scene(mixedScene(16));
    WalkStats ws;
    std::array<PathVertex, kMaxPathVertices> y, z;
    for (bool regularisedMis : {true, false}) {
        reg::Jg19Settings js;
        js.tau0 = 30.0;
        js.schedule = reg::Schedule::Fixed;
        js.mis = regularisedMis ? reg::MisDensities::Regularised : reg::MisDensities::Sampling;
        js.quality = false;  // every technique at its own ends: Eq. 13 as Sec. 3.3 states it
        const reg::Jg19 jg(js);
        const PathVertex cam = cameraEndpoint(scene, jg);
        for (bool merging : {false, true}) {
            const MisConfig cfg{TechniqueSet::Bidirectional, merging, kPi * 0.02f * 0.02f, 256.f};
            int checked = 0, regularisedPaths = 0, twoEnds = 0, smoothEnds = 0, merges = 0;
            double worst = 0.0;
            LightPathStore store;
            for (uint64_t i = 0; i < 1200; ++i) {
                Rng rng(i, 31 + merging);
                const int ny = lightWalk(scene, jg, rng, 6, 100, y.data(), ws);
                const int nz = cameraWalk(scene, jg, Vec2(rng.uniform() * 16, rng.uniform() * 16), rng, 6, 100,
                                          z.data(), ws);
                auto check = [&](const PathPdfs& P, std::vector<const PathVertex*> xs, int s, int mergeAt,
                                 const PathVertex* mergeLight) {
                    BruteForce bf{jg, std::move(xs), P, cfg, regularisedMis, mergeAt, mergeLight};
                    const double ours = mergeAt >= 0 ? misWeightMerge(P, mergeAt, cfg) : misWeight(P, s, cfg);
                    const double ref = bf.weight(s);
                    INFO("path " << i << " s=" << s << " merge " << mergeAt << " n=" << bf.n() << " ours " << ours
                                 << " brute force " << ref << " regularised MIS " << regularisedMis);
                    CHECK(std::abs(ours - ref) <= 2e-3);
                    worst = std::max(worst, std::abs(ours - ref));
                    ++checked;
                };
                for (int s = 1; s <= ny; ++s)
                    for (int t = 1; t <= nz; ++t) {
                        if (s + t < 3) continue;
                        const PathVertex* zz = t == 1 ? &cam : z.data();
                        Connection c;
                        if (!connect(scene, jg, y.data(), s, zz, t, c, ws)) continue;
                        std::vector<const PathVertex*> xs;
                        for (int k = 0; k < s; ++k) xs.push_back(&y[k]);
                        for (int k = t - 1; k >= 0; --k) xs.push_back(&zz[k]);
                        regularisedPaths += c.pdfs.perTechnique;
                        twoEnds += c.pdfs.regularised && s >= 2 && t >= 2 && !(y[s - 1].bxdf->lambert()) &&
                                   !(zz[t - 1].bxdf->lambert());
                        smoothEnds += c.pdfs.regularised && ((s >= 2 && y[s - 1].deltaBsdf) ||
                                                             (t >= 2 && zz[t - 1].deltaBsdf));
                        check(c.pdfs, xs, s, -1, nullptr);
                    }
                if (!merging) continue;
                // Merges of this camera path with the light vertices of the same light walk.
                for (int m = 1; m < ny; ++m) {
                    if (!y[m].connectible() || y[m].kind != VertexKind::Surface) continue;
                    std::vector<VertexPdfs> lp;
                    for (int k = 0; k <= m; ++k) lp.push_back(VertexPdfs::of(y[k]));
                    Photon ph;
                    ph.set(0, y[m], y[m - 1], y[0].light->isHittable(), 0.0);
                    for (int t = 2; t <= nz; ++t) {
                        Connection c;
                        if (!merge(jg, ph, y.data(), lp.data(), z.data(), t, c)) continue;
                        std::vector<const PathVertex*> xs;
                        for (int k = 0; k < m; ++k) xs.push_back(&y[k]);
                        for (int k = t - 1; k >= 0; --k) xs.push_back(&z[k]);
                        check(c.pdfs, xs, -1, m, &y[m]);
                        ++merges;
                    }
                }
            }
            INFO("regularised MIS " << regularisedMis << " merging " << merging << ": " << checked << " weights, "
                                    << regularisedPaths << " on regularised paths, " << twoEnds
                                    << " with two glossy or smooth ends, " << smoothEnds
                                    << " with a smooth end made rough, " << merges << " merges; worst " << worst);
            CHECK(checked > 3000);
            CHECK(regularisedPaths > 800);
            CHECK(twoEnds > 20);
            CHECK(smoothEnds > 200);
            if (merging) CHECK(merges > 200);
        }
    }
}

TEST_CASE("JG19 lets the path tracer render a point light inside glass", "[jg19][render]") {
    // scenes/cornell-box-point-in-glass.xml: the only light is a point inside a smooth glass
    // sphere, so every path is L S D ... E. Plain PT cannot sample any of them (black image);
    // with JG19 next-event estimation connects through the regularised glass. Reference: VCM,
    // 64 x 64, 128 spp. Region: the room outside the sphere's image (rows 0-19 and 44-63, and the
    // side strips), 3424 pixels. PT with JG19, tau_0 = 1e4 (alpha_hat 0.24 for this glass at
    // N = 1, 0.11 at N = 256), consistent schedule, 4 seeds x 256 spp: the region's mean must
    // lie within 5% of the reference. Measured (render CLI, VCM 512 spp reference 0.7386): the
    // four seeds give 0.7125, 0.7539, 0.7301, 0.7122, mean -1.5% with a standard error of 1.3%;
    // tau_0 = 1e5 gives +1.0% but a spread of +-7%, tau_0 = 30 gives -33% at 64 spp (the glass
    // is then nearly diffuse, alpha ~ 0.6-0.8, and loses energy as a single-scattering microfacet
    // model does). 5% is about 2.5 standard errors beyond the measured bias: a regularised glass
    // that lost or doubled energy (wrong eta^2, a missing Fresnel factor) fails it.
    SceneDesc desc = loadScene(std::string(LT_SOURCE_DIR) + "/scenes/cornell-box-point-in-glass.xml", {{"res", "64"}});
    Scene scene(desc);
    auto regionMean = [](const Image& img) {
        double sum = 0.0;
        int count = 0;
        for (int yy = 0; yy < 64; ++yy)
            for (int xx = 0; xx < 64; ++xx) {
                if (yy >= 20 && yy < 44 && xx >= 18 && xx < 46) continue;  // the sphere
                const Color c = img.pixels[size_t(yy) * 64 + xx];
                sum += (double(c.x) + c.y + c.z) / 3.0;
                ++count;
            }
        return sum / count;
    };
    RenderStats st;
    RenderSettings vcm = settingsFor("vcm", 128);
    vcm.maxDepth = 8;
    const double ref = regionMean(renderImage(scene, vcm, st));
    RenderSettings plain = settingsFor("pt", 16);
    plain.maxDepth = 8;
    CHECK(regionMean(renderImage(scene, plain, st)) < 1e-3 * ref);  // black without the regulariser
    std::vector<double> means;
    for (uint64_t seed = 1; seed <= 4; ++seed) {
        RenderSettings pt = settingsFor("pt", 256);
        pt.maxDepth = 8;
        pt.seed = seed;
        pt.regularizer = "jg19";
        pt.regTau = 1e4;
        means.push_back(regionMean(renderImage(scene, pt, st)));
        CHECK(st.regularisedContributions == st.contributions);  // all light passes the glass
    }
    double mean = 0.0;
    for (double m : means) mean += m / means.size();
    INFO("reference " << ref << ", PT+JG19 per seed " << means[0] << " " << means[1] << " " << means[2] << " "
                      << means[3] << ", mean " << mean);
    CHECK(std::abs(mean / ref - 1.0) < 0.05);
}
