// KD13: selective path-space regularisation by cone mollification of pure specular vertices
// (Kaplanyan and Dachsbacher 2013, "Path space regularization for holistic and robust light
// transport"), as a policy of the regulariser seam (regularizer.h). Paper:
// ../shared/papers/kd13-path-space-regularization.txt.
//
// (1) Which paths (Sec. 4.4). Only a path that no technique of the running integrator can sample
//     is mollified (samplableUnregularised, path.h; Theorem 1: an unbiased local technique needs
//     two neighbouring non-delta vertices where it connects; the running integrator's techniques
//     decide which pairs count):
//       - the emitter hit (s = 0), where the set has it and the light can be hit (area lights, the
//         background; not a point, spot or directional light);
//       - connection k (x_{k-1} - x_k), where the set has it and neither end is a delta vertex
//         (light and camera endpoints always qualify: next-event estimation, light tracing);
//       - (VCM) the merge at x_i, 1 <= i <= n - 2, at a non-delta vertex: a merge is itself a
//         regularisation that converges, so VCM's paths through a non-delta vertex are left to it.
//     Any other path (a point light seen through glass, in a mirror, a caustic of a point light
//     seen in a mirror by BPT: L S D S E) gets one regularised estimator.
// (2) Which estimator (Sec. 4.5, the maximum-distance heuristic). The candidates are the running
//     integrator's connection techniques whose ends are non-delta or smooth surface vertices; the
//     smooth ends are mollified. The heuristic takes the candidate with the fewest mollified
//     vertices, then the longest connection (ties: the fewer light vertices); it gets weight 1, the
//     other techniques 0 (w_i = 1 for the chosen estimator, 0 otherwise). The choice is a function
//     of the path: every technique that can produce the path computes it and only the chosen one
//     contributes, so the weights over the techniques that can sample the regularised path sum to
//     one. (Why not MIS between the two connections at a mollified vertex: their cones differ,
//     eps depending on each connection's length, so they estimate different integrands; and no
//     technique walks *through* a mollified vertex, since the walks sample the delta, not the cone:
//     the cone's density is the density of a technique none of our walks runs.)
// (3) The mollifier (Eq. 5, bsdf/cone_mollifier.h). At the chosen connection's mollified ends each
//     delta lobe becomes its weight (the Fresnel term) spread uniformly over a cone of half-angle
//     eps = arctan(r_N / l) around the ideal direction, l the connection's length (a vertex at
//     infinity: twice the geometry's bounding radius), Omega(eps) = 4 pi sin^2(eps/2).
//     r_N = r0 N^-lambda (Sec. 5.1), N the iteration (pass) index: each pixel takes one sample per
//     pass, so N is the sample index of the consistency condition O(N^-1/d) < r_N < O(1), d = 2 per
//     mollified vertex. r0 defaults to 1% of the geometry's bounding radius (Sec. 6) and lambda to
//     1/6 for one mollified vertex and 1/12 for two (Sec. 5.1); a lambda the user gives applies to
//     both (consistent for two vertices only below 1/4). lambda = 0 keeps r0: a fixed bandwidth.
// (4) Where: connections only (the walks, emitter hits and merges are untouched); connect() may
//     end at a smooth vertex (connectible), and select() lets it contribute only as the chosen
//     estimator. MIS: the chosen technique's density is its sampling density; the others have
//     factor 0 (densities()), but for the path tracer's cone hit (5). Paths that some technique
//     samples keep their unbiased weights exactly (select() returns "unregularised" and the
//     routine runs as without a regulariser), so a scene where every path is samplable renders
//     bit-identically to --reg none.
// (5) The path tracer's second technique for a mollified path (regularizer.h (8)). In the path
//     tracer every path (2) mollifies is a delta light reached through a smooth camera vertex
//     z[t-1], and the one candidate is next-event estimation there. The cone lets a BSDF-sampled
//     ray count the light too: z[t-1] samples its delta BSDF (on a stream of its own), and a
//     light whose direction lies in the cone of half-angle eps around the sampled ideal direction
//     is counted, eps that of next-event estimation's connection to it (the same segment, so the
//     same cone: both techniques estimate one integrand). Its value is next-event estimation's for
//     that light and lobe times sel / P(lobe) (sel: the probability next-event estimation picks
//     the light); every delta light in the cone counts. Its density in the MIS sum is the cone's:
//     the probability P(lobe) that the sample's cone holds the light, the lobe being the one on
//     the light's side of the surface (the cone is cut by the horizon, so at most one lobe's cone
//     holds a direction). densities() writes it as the technique s = 0's density of x_0, against
//     next-event estimation's sel: power-heuristic weights sel^2 / (sel^2 + P^2) and
//     P^2 / (sel^2 + P^2), which sum to one for every light and lobe. With --pt-strategy nee only
//     next-event estimation runs, with bsdf only the cone hits (weight 1).
//     With a single light (sel = 1) next-event estimation has no choice to make: given the walk
//     it evaluates both lobes exactly, and the cone hit, whose only randomness is its lobe, can
//     only add variance. So the cone hits compete only when the scene has more than one light
//     (coneHitsCompete; densities() leaves the hit's density out otherwise, and the path tracer
//     does not draw them), and run alone under --pt-strategy bsdf. (Measured with one light, on
//     scenes/hard/amber.xml, 64^2, 256 spp, six seeds: relMSE 4.22 against 4.19 for next-event
//     estimation alone, at 12% more time. With four point lights behind the glass of
//     specular-point-view, the imaged lights' mean over eight seeds scattered 0.18 against 0.86.)
#pragma once
#include <cstdint>
#include <vector>
#include "integrators/transport/path.h"

namespace lt::reg {

struct Kd13Settings {
    double r0 = 0.0;       // initial radius r_0 (world units); <= 0: 1% of the geometry's bounding radius
    double lambda = -1.0;  // r_N = r0 N^-lambda, lambda in [0, 1/2); < 0: 1/6 (one vertex), 1/12 (two)
};

class Kd13 : public TailRoulette {  // (regularizer.h (9))
public:
    // Throws std::invalid_argument for lambda >= 1/2 or NaN, r0 not finite.
    explicit Kd13(const Kd13Settings& settings);
    const Kd13Settings& settings() const { return settings_; }
    void beginIteration(uint64_t n, const Scene& scene, const MisConfig& cfg);
    // Tests without a scene: the iteration, r_0 and the length used for a segment to infinity,
    // and the running integrator's techniques.
    void setIteration(uint64_t n) { n_ = n, setRadii(); }
    void setScale(double r0, double farLength) { r0_ = r0, farLength_ = farLength, setRadii(); }
    void setTechniques(TechniqueSet set, bool merging) { set_ = set, merging_ = merging; }
    TechniqueSet techniques() const { return set_; }

    // lambda for a path with `mollified` (1 or 2) vertices, and r_N for it at the current N.
    double lambda(int mollified) const;
    double radius(int mollified) const;
    // regularizer.h (7): cone half-angles found not to be numbers (their techniques refused).
    uint64_t invalidValues() const { return invalid_.count(); }
    // eps = arctan(r_N / l) for a connection of length l (in double; l may be +inf: farLength).
    double coneAngle(int mollified, double length) const;

    // (1), (2): the choice for the path of `tech` (a connection: s >= 1, t >= 1), the plain form.
    struct Choice {
        bool samplable = false;  // some technique of the running integrator samples the path
        int technique = -1;      // the chosen connection k (light vertices), -1: none
        int mollified[2] = {-1, -1};
        int count = 0;           // the number of mollified vertices
        double length = 0.0;     // the chosen connection's length (+inf: to a vertex at infinity)
    };
    Choice choose(const Technique& tech) const;

    // The seam (regularizer.h).
    BsdfContext context(const Technique& tech, End end) const {
        BsdfContext c(modeAt(end));
        const float eps = boundAt(tech, end);
        if (eps >= 0.f) c.reg.cone = eps;
        return c;
    }
    static constexpr bool kPerTechnique = true;
    bool perTechnique(const Technique& tech) const { return anyRegularised(tech); }
    void densities(const Technique& tech, PathPdfs& pdfs) const;
    void start(PathVertex&) const {}
    void extend(PathVertex&, PathVertex&) const {}
    bool connectible(const PathVertex& v) const { return v.connectible() || mollifiable(v); }
    // (5), regularizer.h (8): the path tracer's cone hits at camera vertex v.
    static constexpr bool kConeHits = true;
    bool coneHitsAt(const PathVertex& v) const {
        return set_ == TechniqueSet::PathTracer && !deltaLights_.empty() && mollifiable(v);
    }
    // (5): whether the cone hits compete with next-event estimation in the MIS (more than one light).
    bool coneHitsCompete() const { return coneHitsCompete_; }
    // The scene's delta lights (indices into Scene::lights()), the only ones a cone hit can count.
    const std::vector<uint32_t>& deltaLights() const { return deltaLights_; }
    // (5): the density of the cone hit on the path of next-event estimation `tech` (s = 1, its
    // camera end z[t-1] mollified): P(lobe) of z[t-1]'s delta lobe on the light's side, 0 if none.
    static float coneHitDensity(const Technique& tech);
    bool mergeable(const PathVertex& v) const { return v.connectible(); }
    // The common answers inline: a merge (at a non-delta vertex) or an emitter hit samples its
    // path itself, and so does a connection whose ends are both non-delta.
    // (10) A plain camera vertex (a light endpoint is one): select() mollifies nothing.
    bool plainNextEvent(const PathVertex& v) const { return plain(v); }
    bool select(Technique& tech) const {
        tech.regularised[0] = tech.regularised[1] = -1;
        if (tech.photon || tech.s == 0) return true;
        if (plain(tech.y[tech.s - 1]) && plain(tech.z[tech.t - 1])) return true;
        return selectMollified(tech);
    }

    // A smooth surface vertex (delta BSDF) a cone can mollify, and a vertex where an unbiased
    // connection can end (not a delta, not a surface point at infinity).
    static bool mollifiable(const PathVertex& v) {
        return v.kind == VertexKind::Surface && !v.infinite && v.bxdf && v.deltaBsdf;
    }
    static bool plain(const PathVertex& v) { return plainConnectionEnd(v); }

private:
    bool selectMollified(Technique& tech) const;
    InvalidValueCount invalid_;  // regularizer.h (7)
    Kd13Settings settings_;
    uint64_t n_ = 1;
    double r0_ = 0.0, farLength_ = 0.0;
    // r_N for one mollified vertex and for two (radius(), whose pow a connection would otherwise
    // pay: 3% of the path tracer's instructions on caustic-mirror), set with n_ and r0_.
    double radii_[2] = {0.0, 0.0};
    void setRadii();
    TechniqueSet set_ = TechniqueSet::Bidirectional;
    bool merging_ = false;
    std::vector<uint32_t> deltaLights_;
    bool coneHitsCompete_ = false;
};

}  // namespace lt::reg
