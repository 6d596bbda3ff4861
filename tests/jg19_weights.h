// Shared by the JG19 tests (test_jg19.cpp, test_jg19_heuristics.cpp): a policy with a fixed tau,
// and the brute-force MIS weight of a technique under JG19 that their weights are checked against.
#pragma once
#include <algorithm>
#include <vector>
#include "integrators/transport/jg19.h"
#include "regularizer_paths.h"

namespace lt::test {

// (Without the diffusion heuristic unless asked: the hand computations of q use tau itself.)
inline reg::Jg19 fixedTau(double tau, const Scene& scene, const MisConfig& cfg, bool diffusion = false,
                          reg::SpecularMode specular = reg::SpecularMode::Ggx) {
    reg::Jg19Settings js;
    js.tau0 = tau;
    js.schedule = reg::Schedule::Fixed;
    js.diffusion = diffusion;
    js.specular = specular;
    reg::Jg19 jg(js);
    jg.beginIteration(1, scene, cfg);
    return jg;
}

// The brute-force weight of a technique under JG19, from the path's vertices and its gathered
// sampling densities (tested elsewhere), with nothing of the policy's bookkeeping (the walks'
// stored ratios, the singular-vertex rule, the delta flags): every BSDF is evaluated here at the
// path's vertices, and whether a smooth vertex is specular on this path is decided from its
// geometry.
struct BruteForce : PathWeights {
    const reg::Jg19& jg;
    bool regularisedMis;
    // With the quality heuristic: the vertices regularised on this path (one integrand for every
    // technique; only techniques whose ends contain them compete, with their sampling densities).
    bool quality = false;
    std::vector<int> R;

    // rho and rho_hat of x_j's BSDF between its path neighbours (channel sums).
    void values(int j, double& plain, double& hat) const {
        const PathVertex& v = *x[j];
        const SurfaceBsdf b(v.bxdf, v.shading, v.ng, v.uv);
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
        // Technique k's factor on its sampling density (1 / (f_k / f) without the heuristic, with
        // regularised densities), or -1 when technique k cannot produce this path.
        auto coefficient = [&](const std::vector<int>& ends) -> double {
            auto has = [](const std::vector<int>& v, int j) { return std::find(v.begin(), v.end(), j) != v.end(); };
            if (quality) {
                for (int r : R)
                    if (!has(ends, r)) return -1.0;
                for (int j = 1; j <= N - 2; ++j) {
                    if (!smooth[j]) continue;
                    // Regularised: not specular on a path a connection there made. Not: specular,
                    // and no technique connects there.
                    if (has(R, j) ? spec[j] : (!spec[j] || has(ends, j))) return -1.0;
                }
                return 1.0;
            }
            double f = 1.0;
            for (int j = 1; j <= N - 2; ++j) {
                const bool mine = std::find(ends.begin(), ends.end(), j) != ends.end();
                if (smooth[j]) {
                    // Specular here: only techniques sampling through it (a finite rho_hat beside a
                    // delta has weight 0). Not specular: only techniques regularising it, and
                    // only if its rho_hat is not 0.
                    if (spec[j] == mine || (mine && !(hat[j] > 0.0))) return -1.0;
                } else if (mine && regularisedMis) {
                    // Eq. 12: weight in proportion to p_k / f_k, f_k = f rho_hat / rho at k's ends.
                    if (!(plain[j] > 0.0) || !(hat[j] > 0.0)) return -1.0;
                    f *= plain[j] / hat[j];
                }
            }
            return f;
        };
        return powerWeight(
            s, [&](int k) { return coefficient({k - 1, k}); },
            // (photons lie where connections may end)
            [&](int i) { return jg.connectible(*x[i]) ? coefficient({i}) : -1.0; });
    }
};

}  // namespace lt::test
