#include "integrators/transport/jg19.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include "bsdf/roughness_bound.h"
#include "integrators/transport/path_templates.h"

namespace lt::reg {

Jg19::Jg19(const Jg19Settings& settings) : settings_(settings) {
    if (!(settings.tau0 > 1.0 / (2.0 * kPi)))
        throw std::invalid_argument("JG19: tau must exceed 1/(2 pi) = 0.159, got " + std::to_string(settings.tau0));
    beginIteration(1);
}

void Jg19::beginIteration(uint64_t n) {
    const double tau = settings_.schedule == Schedule::Consistent ? consistentTau(settings_.tau0, n) : settings_.tau0;
    radiance_.reg.tau = importance_.reg.tau = float(tau);  // (beyond FLT_MAX: +inf, no regularisation)
}

float Jg19::ratioAt(const PathVertex& v, const Vec3& wi) const {
    if (!detail::requestCanChange(v, radiance_)) return 1.f;
    const SurfaceBsdf b = v.bsdf();
    return detail::regularisedRatio(b.eval(v.wo, wi, radiance_).f, b.eval(v.wo, wi, kRadianceContext).f);
}

namespace {

// The vertices of the path a technique evaluates (x_0 the light end), and the ratios at them.
struct PathView {
    const Technique& tech;
    int n;
    bool isMerge;
    int lightCount;           // x_0..x_{lightCount-1} are y[0..]; a merge's x_i is its camera vertex
    int lightEnd, cameraEnd;  // the base's own ends (x indices; -1: none)

    PathView(const Technique& t, int pathLength)
        : tech(t), n(pathLength), isMerge(t.photon != nullptr), lightCount(isMerge ? t.s - 1 : t.s) {
        if (isMerge) lightEnd = -1, cameraEnd = t.s - 1;  // x_i, the merge's camera vertex
        else if (t.s == 0) lightEnd = cameraEnd = -1;     // an emitter hit: no connection
        else lightEnd = t.s - 1, cameraEnd = t.s;
    }
    bool inner(int j) const { return j >= 1 && j <= n - 2; }  // x_0, x_{n-1}: the endpoints
    const PathVertex& vertex(int j) const { return j < lightCount ? tech.y[j] : tech.z[n - 1 - j]; }
    float ratio(int j) const {
        if (j == lightEnd) return tech.ratioLight;
        if (j == cameraEnd) return tech.ratioCamera;
        return vertex(j).regState.ratio;
    }
};

}  // namespace

bool Jg19::perTechnique(const Technique& tech) const {
    if (tech.ratioLight != 1.f || tech.ratioCamera != 1.f) return true;
    // accumulated counts the vertices before its own on its subpath: y[s-1] (a connection's light
    // end, or the photon's vertex y[i] of a merge, s = i + 1) and z[t-1] cover the rest of the path.
    if (tech.s >= 1 && tech.y && tech.y[tech.s - 1].regState.accumulated > 0.f) return true;
    return tech.t >= 1 && tech.z[tech.t - 1].regState.accumulated > 0.f;
}

void Jg19::densities(const Technique& tech, PathPdfs& P) const {
    const PathView path(tech, P.n);
    const int n = P.n;
    const bool regularisedMis = settings_.mis == MisDensities::Regularised;
    // The base's singular ends: every competitor must connect (merge) there too.
    int singular[2], nSingular = 0;
    for (int j : {path.lightEnd, path.cameraEnd})
        if (j >= 0 && path.inner(j) && std::isinf(path.ratio(j))) singular[nSingular++] = j;
    for (int m = 0; m < nSingular; ++m)
        P.delta[singular[m]] = false;  // connectible now: the factors decide (regularizer.h (2))
    // The factor of the technique whose regularised vertices are {a, b} (-1: none).
    auto factor = [&](int a, int b) -> float {
        for (int m = 0; m < nSingular; ++m)
            if (singular[m] != a && singular[m] != b) return 0.f;
        float f = 1.f;
        for (int j : {a, b}) {
            if (j < 0 || !path.inner(j)) continue;
            const float r = path.ratio(j);
            if (std::isinf(r)) {
                bool common = false;
                for (int m = 0; m < nSingular; ++m) common = common || singular[m] == j;
                if (!common) return 0.f;
                continue;  // rho_hat in both: cancels
            }
            if (regularisedMis) f *= r;
        }
        return f;
    };
    P.connectionScale[0] = factor(-1, -1);
    for (int k = 1; k < n; ++k) P.connectionScale[k] = factor(k - 1, k);
    P.connectionScale[n] = 0.f;  // (the pinhole: never valid)
    // Merges where the photon grid stores photons and merge() gathers them: connectible vertices.
    for (int i = 0; i < n; ++i)
        P.mergeScale[i] = path.inner(i) && path.vertex(i).connectible() ? factor(i, -1) : 0.f;
    P.regularised = (path.lightEnd >= 0 && tech.ratioLight != 1.f) || (path.cameraEnd >= 0 && tech.ratioCamera != 1.f);
}

}  // namespace lt::reg

namespace lt {

// The templates of path_templates.h for this policy (path.cpp has the unregularised ones).
LT_INSTANTIATE_TRANSPORT(reg::Jg19)

}  // namespace lt
