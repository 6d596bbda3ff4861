#include "integrators/transport/jg19.h"

#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include "bsdf/roughness_bound.h"
#include "integrators/transport/path_templates.h"

namespace lt::reg {

Jg19::Jg19(const Jg19Settings& settings) : settings_(settings) {
    if (!(settings.tau0 > kMinTau))
        throw std::invalid_argument("JG19: tau must exceed 1/(2 pi) = 0.159, got " + std::to_string(settings.tau0));
    for (BsdfContext* c : {&radiance_, &importance_}) {
        c->reg.bound = settings.bound;
        c->reg.compensate = settings.compensate;
    }
    setIteration(1);
}

void Jg19::setIteration(uint64_t n) {
    const double tau = settings_.schedule == Schedule::Consistent ? consistentTau(settings_.tau0, n) : settings_.tau0;
    radiance_.reg.tau = importance_.reg.tau = float(tau);  // (beyond FLT_MAX: +inf, no regularisation)
    if (cone()) radiance_.reg.cone = importance_.reg.cone = coneForBound(radiance_.reg.tau);  // (5)
    setLimits();
}

void Jg19::setLimits() {
    smooth_.clear();
    loosest_ = radiance_;
    const double tau = double(radiance_.reg.tau);
    tauSqExit_ = float(tau * tau * (1.0 - kExitMargin));
    if (diffusion()) loosest_.reg.tau = float(double(radiance_.reg.tau) / Diffusion::kMaxSpread);  // (4)
    if (cone()) loosest_.reg.cone = coneForBound(loosest_.reg.tau);  // (5)
}

void Jg19::beginIteration(uint64_t n, const Scene& scene, const MisConfig& cfg) {
    setIteration(n);
    cameraBound_ = scene.camera().importanceBound();  // the importance's maximum (perspective: at the image centre)
    set_ = cfg.set;
    merging_ = cfg.merging;
    mergeDensity_ = double(cfg.mergeArea) * double(cfg.lightPaths);
    for (const BxdfPtr& b : scene.desc().bsdfs)
        if (b && b->isDelta()) smooth_.push_back({b.get(), !b->deltaUnder(loosest_)});
}

float Jg19::lightBound(const Light& light) {
    switch (light.type) {
        case LightType::Area: return kInvPi;  // cosine emission
        case LightType::Point:
        case LightType::Constant: return kUniformSpherePdf;
        case LightType::Spot: return 1.f / coneSolidAngle(light.cutoff);
        case LightType::Projector: return light.projectorDirBound();
        case LightType::Directional: return kInvPi;  // (a delta direction that NEE samples exactly: as an area light)
        case LightType::Envmap: return light.envmap->directionalBound();  // largest radiance / its integral
    }
    return kInvPi;
}

float Jg19::ratioAt(const PathVertex& v, const Vec3& wi) const {
    if (!detail::requestCanChange(v, radiance_)) return 1.f;
    return detail::regularisedRatioAt(v.bsdf(), v.wo, wi, radiance_);
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

int pathVertexCount(const Technique& t) { return t.photon ? t.s - 1 + t.t : t.s + t.t; }

// The emitter hit's term in q (see select): 1 / P, P = min(1, rho_bar_k A |cos theta_L| / D^2),
// x0 the light's vertex, x1 the next one on the path, rhoK the bound of the first vertex from the
// light that is not a delta and D the length unfolded up to it (1 for a background: constant, envmap).
double emitterHitTerm(const PathVertex& x0, const PathVertex& x1, double rhoK, double D) {
    double hitProbability = 0.0;
    if (x0.light && x0.light->isEnvironment()) {
        hitProbability = 1.0;
    } else if (x0.light && x0.light->type == LightType::Area && std::isfinite(D) && D > 0.0) {
        const double cosL = std::abs(glm::dot(x0.ng, glm::normalize(x1.p - x0.p)));
        hitProbability = std::min(1.0, rhoK * x0.light->area * cosL / sqr(D));
    }
    return hitProbability > 0.0 ? 1.0 / hitProbability : kInf;
}

// Whether the ends a, b (x indices; -1: none) of a technique contain the vertices select() chose
// to regularise on this path (the techniques that compete for it, jg19.h (2)).
bool containsRegularised(const Technique& tech, int a, int b) {
    for (int j : tech.regularised)
        if (j >= 0 && j != a && j != b) return false;
    return true;
}

// Whether each end of the technique is regularised or connectible as it is: an end that is a
// smooth vertex left a delta (on an unregularised path, or a technique of the path ending beside
// the regularised vertex) evaluates to 0, and its connection's shadow ray and evaluations are
// spared.
bool endsEvaluable(const Technique& tech, const PathView& path) {
    for (int j : {path.lightEnd, path.cameraEnd})
        if (j >= 0 && j != tech.regularised[0] && j != tech.regularised[1] && !path.vertex(j).connectible()) return false;
    return true;
}

}  // namespace

bool Jg19::select(Technique& tech, bool shortcut, bool fast) const {
    // regularizer.h (7): a bound that is not a number (or not positive) is refused and counted,
    // never read as "no request".
    return selectBounds(tech, shortcut, fast) && boundsValid(tech, [](float b) { return b > 0.f; }, invalid_);
}

bool Jg19::selectBounds(Technique& tech, bool shortcut, bool fast) const {
    tech.regularised[0] = tech.regularised[1] = -1;
    const PathView path(tech, pathVertexCount(tech));
    if (!settings_.quality) {  // (3): every technique at its own ends
        tech.regularised[0] = path.lightEnd;
        tech.regularised[1] = path.cameraEnd;
        tech.bound[0] = tech.bound[1] = radiance_.reg.tau;
        return true;
    }
    // Nothing the request changes on this path: unregularised (the common case, O(1)).
    float changeable = tech.t >= 1 ? tech.z[tech.t - 1].regState.jg.changeable : 0.f;
    if (path.lightCount >= 1) {
        if (!tech.y) throw std::logic_error("JG19: a merge needs the light subpath");
        changeable += tech.y[path.lightCount - 1].regState.jg.changeable;
    }
    if (changeable == 0.f) return true;

    const int n = path.n;
    // Eq. 18's "unregularised" answer: nothing regularised (tech.regularised is still -1, -1), so a
    // technique connecting at a vertex that stays a delta has nothing to add (endsEvaluable).
    auto unregularised = [&]() { return endsEvaluable(tech, path); };
    // The segment x_join - x_{join+1} joins the two subpaths (measured here; the others' lengths
    // d_j are on the walks' records), and d_path (Eq. 17) is the sum of the subpaths' running
    // lengths and this one. A segment to a vertex at infinity (or the light walk's first segment
    // from a light at infinity, recorded as 0) is left out of d_path, and its connection compared
    // without the distance factor.
    const int join = path.lightCount - 1;
    double joinLength = 0.0;
    if (join >= 0) {
        const PathVertex &a = path.vertex(join), &b = path.vertex(join + 1);
        joinLength = a.infinite || b.infinite ? kInf : double(glm::length(a.p - b.p));
    }
    auto runningLength = [](const PathVertex& v, const PathVertex* before) -> double {
        if (v.infinite) return before ? double(before->pathLength) : 0.0;  // (the camera walk's escape)
        return double(v.pathLength);
    };
    double dPath = std::isfinite(joinLength) ? joinLength : 0.0;
    if (tech.t >= 1) dPath += runningLength(tech.z[tech.t - 1], tech.t >= 2 ? &tech.z[tech.t - 2] : nullptr);
    if (path.lightCount >= 1) dPath += double(tech.y[path.lightCount - 1].pathLength);
    const double tau = double(radiance_.reg.tau);
    // The connection term of Eq. 17 (q's quantity) for bounds ra, rb over segment length dj.
    // (distanceFactor: (d_path / d_j)^2, 1 where it cannot be formed; the term then compares
    // the bounds unscaled)
    auto distanceFactor = [&](double dj) { return std::isfinite(dj) && dj > 0.0 && dPath > 0.0 ? sqr(dPath / dj) : 1.0; };
    auto scaledTerm = [](double ra, double rb, double factor) { return ra == 0.0 || rb == 0.0 ? 0.0 : ra * rb * factor; };
    auto connectionTerm = [&](double ra, double rb, double dj) { return scaledTerm(ra, rb, distanceFactor(dj)); };

    // d_j from the records (the joining segment measured above).
    auto segmentAt = [&](int j) -> double {
        if (j == join) return joinLength;
        return double(j < join ? tech.y[j + 1].segmentLength : tech.z[n - 1 - j].segmentLength);
    };

    // The common case without the loops below: a connection term already under tau^2, so q is
    // (Eq. 18). Known in O(1): the joining segment's term, an emitter hit's first segment, and,
    // where every connection is a technique (BPT, VCM), d_path^2 times the subpaths' running
    // minima (Jg19Heuristic::connectionMin, stored in float: the margin kExitMargin keeps this exit
    // to paths whose q from the loop, in double, is under tau^2 too, so the choice is the loop's).
    if (shortcut) {
        double known = kInf;
        if (join >= 0 && allowsTechnique(set_, join + 1, n - join - 1))
            known = connectionTerm(path.vertex(join).regState.rhoBar, path.vertex(join + 1).regState.rhoBar, joinLength);
        if (tech.s == 0 && n >= 2 && allowsTechnique(set_, 1, n - 1))
            known = std::min(known, connectionTerm(lightBound(*tech.z[tech.t - 1].light),
                                                   tech.z[tech.t - 2].regState.rhoBar, segmentAt(0)));
        // A running minimum over both subpaths: the light subpath's last vertex and the camera
        // subpath's (an emitter hit's x_0 is not a connection or merge end: its camera walk's
        // vertex before it).
        const int lastCamera = tech.s == 0 ? tech.t - 2 : tech.t - 1;
        auto subpathsMin = [&](float Jg19Heuristic::*field) {
            double m = kInf;
            if (path.lightCount >= 1) m = tech.y[path.lightCount - 1].regState.jg.*field;
            if (lastCamera >= 0) m = std::min(m, double(tech.z[lastCamera].regState.jg.*field));
            return m;
        };
        if (set_ == TechniqueSet::Bidirectional) {
            const double m = subpathsMin(&Jg19Heuristic::connectionMin);
            if (m == 0.0) known = 0.0;
            else if (dPath > 0.0) known = std::min(known, m * sqr(dPath));
        }
        // The merges' terms (the merge at x_i: rho_bar_i d_path^2 / (N pi r^2), x_i inner and
        // connectible: on the light subpath after x_0, on the camera subpath before an emitter).
        if (merging_ && mergeDensity_ > 0.0)
            known = std::min(known, subpathsMin(&Jg19Heuristic::mergeMin) * (sqr(dPath) / mergeDensity_));
        // The emitter hit's term where x_1 is not a delta (nothing to unfold).
        if (allowsTechnique(set_, 0, n) && n >= 2) {
            const double rho1 = path.vertex(1).regState.rhoBar;
            if (std::isfinite(rho1)) known = std::min(known, emitterHitTerm(path.vertex(0), path.vertex(1), rho1, segmentAt(0)));
        }
        if (known < tau * tau * (1.0 - kExitMargin)) return unregularised();
    }

    // The path tracer's two techniques, next-event estimation (the connection x_0 - x_1) and the
    // emitter hit, leave only x_1 to regularise: what the loops below find, in O(1) but for the
    // emitter hit's unfolding through delta vertices and the checks of (7) on the view sub-path's
    // spreads (tested against the loops: selectByLoop). For the path tracer's own techniques
    // (s <= 1: x_1 is a camera vertex, its spread on the walk's record).
    if (fast && set_ == TechniqueSet::PathTracer && !merging_ && !tech.photon && tech.s <= 1 && n >= 2) {
        const bool diffuse = diffusion();
        if (diffuse)  // (7): the loop's tau' at every camera vertex is a number iff its spread is
            for (int i = 0; i < tech.t; ++i)
                if (std::isnan(tech.z[i].regState.jg.spread)) {
                    invalid_.add();
                    return false;
                }
        auto plainAt = [&](int j) -> double {
            return j == 0 && tech.s == 0 ? double(lightBound(*path.vertex(0).light)) : double(path.vertex(j).regState.rhoBar);
        };
        const PathVertex &x0 = path.vertex(0), &x1 = path.vertex(1);
        const double p0 = plainAt(0), p1 = plainAt(1), d0 = segmentAt(0);
        double r0 = p0, r1 = p1;
        float tau1 = radiance_.reg.tau;  // tau' at x_1 (tau_n itself without diffusion)
        if (diffuse) {
            if (tech.s == 1) {  // (7) at x_0, the light side: its spread across the connection
                const Diffusion d = Diffusion{x1.regState.jg.spread, x1.regState.jg.footprint}.next(p1, double(x1.curvature), d0);
                if (std::isnan(boundAt(d.spread))) {
                    invalid_.add();
                    return false;
                }
            }
            tau1 = boundAt(x1.regState.jg.spread);
            if (path.inner(1) && double(tau1) < double(x1.regState.jg.rhoBarReg)) r1 = double(tau1);
        } else {
            if (tech.s != 0) r0 = x0.regState.jg.rhoBarReg;
            r1 = x1.regState.jg.rhoBarReg;
        }
        double q = kInf, best = kInf, bestLength = -1.0;
        // (the loop's consider and choice below, for the two terms: kept apart, as sharing them
        // with the loop cost BPT on caustic-mirror 2.3% more instructions)
        int bestA = -1;  // x_0's index for the connection x_0 - x_1
        auto consider = [&](double plain, double reg, double length, int a) {
            q = std::min(q, plain);
            if (reg < best || (reg == best && length > bestLength)) best = reg, bestLength = length, bestA = a;
        };
        if (allowsTechnique(set_, 1, n - 1)) {  // next-event estimation
            const double factor = distanceFactor(d0);
            consider(scaledTerm(p0, p1, factor), scaledTerm(r0, r1, factor), d0, 0);
        }
        if (allowsTechnique(set_, 0, n)) {  // the emitter hit, as below
            double D = d0;
            int k = 1;
            if (std::isfinite(D) && D > 0.0)
                while (k < n - 1 && std::isinf(plainAt(k)) && std::isfinite(segmentAt(k))) D += segmentAt(k++);
            const double term = emitterHitTerm(x0, x1, plainAt(k), D);
            consider(term, term, -1.0, -1);
        }
        if (q < tau * tau || !(best < q)) return unregularised();
        if (bestA == 0) {
            int m = 0;
            if (r0 < p0) tech.bound[m] = radiance_.reg.tau, tech.regularised[m++] = 0;  // (without diffusion only)
            if (r1 < p1) tech.bound[m] = tau1, tech.regularised[m++] = 1;
        }
        return containsRegularised(tech, path.lightEnd, path.cameraEnd);
    }

    // The path's vertices x_j, segment lengths d_j (x_j - x_{j+1}) and bounds, gathered once (the
    // loops below read each several times), in one pass from the camera end. With the diffusion
    // heuristic, the bound tau' of the request at each vertex is tau / sigma_j along the view
    // sub-path (4), and the regularised bounds are under it: the camera subpath's spreads from its
    // walk, then across the connection and down the light subpath.
    std::array<const PathVertex*, kMaxPathVertices> xs;
    std::array<double, kMaxPathVertices> seg, plainB, regB;
    std::array<float, kMaxPathVertices> taus;  // tau' at each vertex (diffusion)
    const int firstCamera = path.lightCount;  // x index of z[t-1] (a merge's too)
    for (int j = 0; j < firstCamera; ++j) xs[j] = &tech.y[j];
    for (int j = firstCamera; j < n; ++j) xs[j] = &tech.z[n - 1 - j];
    const bool diffuse = diffusion();
    Diffusion d;
    for (int j = n - 1; j >= 0; --j) {
        const PathVertex& v = *xs[j];
        // (a segment's length is on the record of the vertex it arrived at: x_{j+1} on the light
        // subpath, x_j on the camera subpath)
        if (j + 1 < n) seg[j] = j == join ? joinLength : double(j < join ? xs[j + 1]->segmentLength : v.segmentLength);
        if (j == 0 && tech.s == 0) {
            plainB[j] = regB[j] = lightBound(*v.light);  // the emitter a camera walk hit
        } else {
            plainB[j] = v.regState.rhoBar;
            regB[j] = v.regState.jg.rhoBarReg;
        }
        if (!diffuse) continue;
        if (j >= firstCamera) d = Diffusion{v.regState.jg.spread, v.regState.jg.footprint};
        else d = d.next(plainB[j + 1], double(xs[j + 1]->curvature), seg[j]);
        taus[j] = boundAt(d.spread);
        if (std::isnan(taus[j])) {  // regularizer.h (7): refused and counted, not read as "no request"
            invalid_.add();
            return false;
        }
        regB[j] = path.inner(j) && double(taus[j]) < double(v.regState.jg.rhoBarReg) ? double(taus[j]) : plainB[j];
    }
    auto bound = [&](int j, bool reg) -> double { return reg ? regB[j] : plainB[j]; };
    double q = kInf, best = kInf, bestLength = -1.0;
    int bestA = -1, bestB = -1;
    auto consider = [&](double plain, double reg, double length, int a, int b) {
        q = std::min(q, plain);
        if (reg < best || (reg == best && length > bestLength)) best = reg, bestLength = length, bestA = a, bestB = b;
    };
    for (int k = 1; k < n; ++k) {  // connection technique k: x_{k-1} - x_k
        if (!allowsTechnique(set_, k, n - k)) continue;
        const double dk = seg[k - 1], factor = distanceFactor(dk);
        consider(scaledTerm(bound(k - 1, false), bound(k, false), factor),
                 scaledTerm(bound(k - 1, true), bound(k, true), factor), dk, k - 1, k);
    }
    // The emitter hit (ours; Eq. 17 has connections only): its one random choice is the direction
    // sampled at x_k, the first vertex from the light that is not a delta; it hits with probability
    // P ~ rho_bar_k A |cos theta_L| / D^2 (D: the length unfolded through the deltas x_{k-1}..x_1),
    // and its relative variance ~ 1 / P plays the connection term's part. Without it a light seen
    // in a mirror (E S L, which the camera walk samples as well as a pixel) would be blurred.
    if (allowsTechnique(set_, 0, n) && n >= 2) {
        double D = seg[0];
        int k = 1;
        if (std::isfinite(D) && D > 0.0)
            while (k < n - 1 && std::isinf(bound(k, false)) && std::isfinite(seg[k])) D += seg[k++];
        const double term = emitterHitTerm(*xs[0], *xs[1], bound(k, false), D);
        consider(term, term, -1.0, -1, -1);
    }
    if (merging_ && mergeDensity_ > 0.0) {
        const double scale = sqr(dPath) / mergeDensity_;
        for (int i = 1; i + 1 < n; ++i) {  // the merge at x_i (photons lie where connections may end)
            if (!connectible(*xs[i])) continue;
            consider(bound(i, false) * scale, bound(i, true) * scale, 0.0, i, -1);
        }
    }
    // Eq. 18: a good unbiased sampler (or none better with the bound): no regularisation. A
    // technique connecting at a vertex that stays a delta then has nothing to add.
    if (q < tau * tau || !(best < q)) return unregularised();
    int m = 0;
    for (int j : {bestA, bestB})
        if (j >= 0 && bound(j, true) < bound(j, false)) {
            tech.bound[m] = diffusion() ? taus[j] : radiance_.reg.tau;
            tech.regularised[m++] = j;
        }
    return containsRegularised(tech, path.lightEnd, path.cameraEnd) && endsEvaluable(tech, path);
}

bool Jg19::perTechnique(const Technique& tech) const {
    if (settings_.quality) return tech.regularised[0] >= 0 || tech.regularised[1] >= 0;
    if (tech.ratioLight != 1.f || tech.ratioCamera != 1.f) return true;
    // accumulated counts the vertices before its own on its subpath: y[s-1] (a connection's light
    // end, or the photon's vertex y[i] of a merge, s = i + 1) and z[t-1] cover the rest of the path.
    if (tech.s >= 1 && tech.y && tech.y[tech.s - 1].regState.accumulated > 0.f) return true;
    return tech.t >= 1 && tech.z[tech.t - 1].regState.accumulated > 0.f;
}

void Jg19::densities(const Technique& tech, PathPdfs& P) const {
    const PathView path(tech, P.n);
    const int n = P.n;
    if (settings_.quality) {
        // (2): one integrand for the path; the techniques whose ends contain the regularised
        // vertices compete with their sampling densities, the others cannot produce it.
        for (int j : tech.regularised)
            if (j >= 0) P.delta[j] = false;  // a smooth vertex made rough: a connection end now
        P.connectionScale[0] = 0.f;  // (the emitter hit walks through every vertex)
        for (int k = 1; k < n; ++k) P.connectionScale[k] = containsRegularised(tech, k - 1, k) ? 1.f : 0.f;
        P.connectionScale[n] = 0.f;
        for (int i = 0; i < n; ++i)
            P.mergeScale[i] =
                path.inner(i) && connectible(path.vertex(i)) && containsRegularised(tech, i, -1) ? 1.f : 0.f;
        P.regularised = true;  // (select let only techniques containing them through)
        return;
    }
    const bool regularisedMis = settings_.mis == MisDensities::Regularised;
    constexpr float kMaxFactor = 1e30f;  // (two ratios near FLT_MIN would overflow the product)
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
            if (regularisedMis) {
                // Eq. 12: weights in proportion to p_k / f_k, f_k = f times the ratios at k's
                // own ends (jg19.h (3)). A regularised value of 0: Eq. 12's 0/0, the technique
                // adds nothing and is left out (the others keep the path).
                if (!(r > 0.f)) return 0.f;
                f = std::min(f / r, kMaxFactor);
            }
        }
        return f;
    };
    P.connectionScale[0] = factor(-1, -1);
    for (int k = 1; k < n; ++k) P.connectionScale[k] = factor(k - 1, k);
    P.connectionScale[n] = 0.f;  // (the pinhole: never valid)
    // Merges where the photon grid stores photons and merge() gathers them: connectible vertices
    // (the smooth ones too, as connections: their factor decides).
    for (int i = 0; i < n; ++i)
        P.mergeScale[i] = path.inner(i) && connectible(path.vertex(i)) ? factor(i, -1) : 0.f;
    P.regularised = (path.lightEnd >= 0 && tech.ratioLight != 1.f) || (path.cameraEnd >= 0 && tech.ratioCamera != 1.f);
}

}  // namespace lt::reg

namespace lt {

// The templates of path_templates.h for this policy (path.cpp has the unregularised ones).
LT_INSTANTIATE_TRANSPORT(reg::Jg19)

}  // namespace lt
