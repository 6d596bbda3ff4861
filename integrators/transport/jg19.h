// JG19: microfacet model regularisation (Jendersie and Grosch 2019, "Microfacet model
// regularization for robust light transport"), as a policy of the regulariser seam
// (regularizer.h). Paper: ../shared/papers/jg19-microfacet-model-regularization.txt.
//
// (1) Values. At a technique's own connection ends (and at the camera vertex of a merge) every
//     microfacet lobe is evaluated with alpha' = max(alpha, alpha_hat(tau_n)) per axis,
//     alpha_hat = rho_bar^-1 (Eqs. 1, 8-9; bsdf/roughness_bound.h), resolved by the lobe with its
//     own distribution, masking and eta (MicrofacetLobe::resolve). Smooth conductors and
//     dielectrics become rough GGX lobes there, so a connection may end on them (connectible),
//     and a merge too (VCM: the photon grid stores the light vertices on them, and the camera
//     vertex on one gathers; JG19 Fig. 2 right, Eq. 3).
//     The walks sample and evaluate the materials' own BSDFs (Sec. 3). tau_n: Eq. 16 with n the
//     iteration (consistent schedule) or tau_0 throughout (fixed).
// (2) Which vertices, per path (Sec. 3.5.1, Eqs. 17-18: the sampler quality heuristic, on by
//     default). Regularising every technique at its own connection ends, as Secs. 3.1-3.3 read
//     alone, makes each technique estimate its own integrand; Eq. 13 then weights them so that
//     where an unbiased technique reaches light through a delta or very glossy vertex and
//     another technique reaches the same light through its blurred version, both keep weight
//     ~1 and the light is counted twice (measured: BPT on cornell-box-point-in-glass, floor
//     +71% against VCM; PT on a mirror-sphere box, +5.2% with a sharp and a blurred reflection).
//     With the heuristic the choice is a function of the path alone, made once for all the
//     techniques that can produce it (select):
//       q = min_k rho_bar_k rho_bar_{k+1} (d_k / d_path)^-2 over the running integrator's
//       connections k (Eq. 17; rho_bar of an endpoint: its directional density's maximum, the
//       camera's importance at the image centre, 1/pi for an area light, 1/(4 pi) for a point,
//       an envmap's largest luminance over its integral over the sphere);
//       ours for VCM: the merge at x_i enters as rho_bar_i d_path^2 / (N pi r^2) (one BSDF and the
//       kernel over N light paths in place of the second BSDF and 1/d^2).
//       q < tau^2: an unbiased sampler is good enough, nothing is regularised (Eq. 18, tau' = inf).
//       Otherwise the technique whose connection term is smallest with the bounds under tau
//       (ties: the longer connection) is the one regularised, at those of its ends the request
//       changes (KD13's selective choice of one estimator per path, with JG19's measure).
//     Cost: q < tau^2 is the common answer, and it is known in O(1) when a term known without
//     the loop over the path is under tau^2: the joining segment's, and with every connection a
//     technique (BPT, VCM) d_path^2 times the walks' running minima of rho_bar_a rho_bar_b / d^2
//     over each subpath's segments (Jg19Heuristic::connectionMin), and with merging (VCM)
//     d_path^2 / (N pi r^2) times their running minima of rho_bar over the vertices a merge can
//     use (Jg19Heuristic::mergeMin). Only the other paths take the O(n) loop (selectByLoop: the
//     plain form, which tests compare it with).
//     Every technique then evaluates the same integrand on this path: those whose connection
//     ends contain the regularised vertices (and no smooth vertex left a delta: its value there
//     is 0, so select refuses it before its evaluations and shadow ray; BPT on caustic-mirror:
//     11,000 connections of 155,000) compete with their sampling densities (Eq. 13's
//     rho_hat / rho factors are common to all of them and cancel), the others (walking through a
//     regularised vertex, or hitting the emitter) have weight 0 there. Unbiased where no vertex
//     is regularised; the regularised share vanishes as tau_n grows.
// (3) MIS without the heuristic (--reg-quality off: every technique regularised at its own ends,
//     Sec. 3.3, Eqs. 12-13). Technique k estimates f_k = f prod_{x in C_k} rho_hat(x) / rho(x),
//     C_k its connection ends (the merge at x_i: {x_i}), and Eq. 12 weights the techniques in
//     proportion to n_k p_k / f_k (the variance-optimal balance for unequal integrands). Eq. 13
//     writes the same as p_hat = (rho_hat / rho) p at every *sampling* event of the path: a
//     technique has sampling events at all vertices but its connection ends, so after the
//     factor common to all techniques (the product over the whole path) cancels, technique k's
//     density is p_hat_k = p_k / prod_{x in C_k} rho_hat(x) / rho(x). (So a technique whose
//     blurred connection makes the path's value larger than f gets less weight: the combination
//     tends to the smaller of the integrands, with no fireflies from the blurred lobes' tails.
//     The product with the ratio, not its inverse, was our reading until 2026-11-25: measured
//     on a rough glass sphere round a diffuse body, BPT, tau 30, it had 3.2x the variance of the
//     sampling-density weights.) Where rho_hat is 0 (Eq. 12's 0/0) the technique is left out.
//     rho_hat / rho of a vertex is the same pair of directions in every technique that connects
//     there (its two path neighbours), so it is computed once per vertex: by the walk when it
//     extends past the vertex (SubpathState::ratio), by connect and merge at their own ends
//     (Technique::ratioLight, ratioCamera). The ratio is exact (both BSDFs evaluated), which is
//     what the paper's evaluation of the pdf with alpha_hat plus the Smith G ratio approximates.
//     Singular vertices: where rho is a delta (or 0) the ratio is +inf. A path that a technique
//     sampled through the delta is exactly specular there, and a technique regularising that
//     vertex has a finite value where the sampled one has a delta: its weight is 0. A path that a
//     technique regularised at a delta vertex is not specular there (almost surely), and no
//     technique sampling through it can produce it. So the techniques competing for a path are
//     those whose connection ends contain exactly the base's singular vertices; between them the
//     common rho_hat cancels (one tau per iteration).
//     MisDensities::Sampling (--reg-mis sampling) keeps the sampling densities p_k (JG19 Fig. 3a:
//     the naive weights), with the same rule for singular vertices. This mode counts light twice
//     as described in (2); it is kept for the paper's comparisons.
// (4) The path diffusion heuristic (Sec. 3.5.2, Eqs. 19-21; with the quality heuristic, on by
//     default): the request at a regularised vertex x_j is tau' = tau / sigma_j (Eq. 19), sigma_j
//     the angular spread of the segment arriving at x_j along the view sub-path, i.e. the path
//     from the camera x_{n-1} to x_j whichever subpaths sampled it: a function of the path, as
//     the quality heuristic's choice is, so every technique still estimates one integrand. From
//     the camera (sigma = footprint = 0), leaving vertex x_k (bound rho_bar_k, |mean curvature|
//     H_k, footprint F_k) over the segment of length d to the next vertex:
//       sigma' = sigma + (2 pi rho_bar_k)^(-1/2) + F_k H_k     (Eq. 21)
//       F'     = F_k + sigma' d                                 (Eq. 20)
//     (Eq. 20 as written multiplies d by the spread of the previous segment; we use the spread of
//     the segment d measures. A delta vertex adds no spread; |H| makes curvature spread a beam
//     either way, where a concave mirror would focus it: the 2D model has no sign for that.)
//     The camera walk carries sigma and F on its vertices (Jg19Heuristic::spread, footprint), so
//     select() steps only across the connection and down the light subpath. The request changes
//     a vertex when tau' is below its ceiling (Jg19Heuristic::rhoBarReg: rho_bar for a rough lobe,
//     the bound at alpha = kMinAlpha for a delta one, 0 for a diffuse one), and the heuristic's
//     regularised bound there is tau' (the lobe's exact bound, valueBound, differs only where
//     alpha_hat(tau') would exceed 1). The camera walk counts the vertices its tau' changes; a
//     light walk, which does not know the camera side, those the smallest tau' can change: the
//     spread is capped at Diffusion::kMaxSpread = 100 rad (ours; a spread of radians is all
//     directions already), so tau' >= tau / 100 (also what connectible() uses).
// (5) Smooth lobes as cones (--reg-specular cone, JG19 Fig. 4 and Sec. 3.6 with KD13's mollifier):
//     every request that carries a bound tau' also carries the cone whose value 1 / Omega is tau'
//     (coneForBound, bsdf/cone_mollifier.h); a smooth conductor or dielectric takes the cone, a
//     microfacet lobe the bound. The cone's value bound is tau' itself, so the heuristics of (2)
//     and (4) read it as they read a rough lobe's (with diffusion a smooth vertex's ceiling is +inf:
//     every finite tau' changes it, index-matched glass included). Unlike the rough GGX lobe, the
//     cone keeps the delta's energy (no single-scattering loss).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>
#include "bsdf/cone_mollifier.h"
#include "integrators/transport/path.h"

namespace lt::reg {

enum class Schedule { Consistent, Fixed };
enum class MisDensities { Regularised, Sampling };
// How a smooth (delta) conductor or dielectric is regularised: as a rough GGX lobe with
// alpha_hat(tau') (JG19 Sec. 3.2), or as KD13's cone with the same bound, rho_cone = 1 / Omega =
// tau' (JG19 Fig. 4, Sec. 3.6: one knob for both).
enum class SpecularMode { Ggx, Cone };

struct Jg19Settings {
    double tau0 = 30.0;  // > 1 / (2 pi)
    Schedule schedule = Schedule::Consistent;
    MisDensities mis = MisDensities::Regularised;  // (without the quality heuristic only: (3))
    bool quality = true;                           // the sampler quality heuristic, (2)
    bool diffusion = true;                         // the path diffusion heuristic, (4) (with quality only)
    SpecularMode specular = SpecularMode::Ggx;     // smooth lobes: rough GGX or KD13's cone (5)
    BoundForm bound = BoundForm::Tight;            // (1) alpha_hat from the tight or the published bound
    bool compensate = true;                        // (1) smooth lobes made rough keep their albedo
};

// One step of (4): the spread and footprint arriving at the next vertex, leaving a vertex with
// bound rhoBar (+inf: a delta, 0: none) and |mean curvature| h, over a segment of length d.
struct Diffusion {
    // The spread is capped: a spread of radians is all directions already, and with the cap the
    // loosest bound a vertex can get, tau / kMaxSpread, is known before any path (connectible).
    static constexpr double kMaxSpread = 100.0;
    double spread = 0.0, footprint = 0.0;  // sigma (radians), F (length)
    // (inline: the walks take a step per camera vertex, select's loop one per light vertex)
    Diffusion next(double rhoBar, double h, double d) const {
        Diffusion out = *this;
        if (rhoBar > 0.0 && std::isfinite(rhoBar)) out.spread += 1.0 / std::sqrt(2.0 * std::numbers::pi * rhoBar);
        if (std::isfinite(h)) out.spread += footprint * h;
        out.spread = std::min(out.spread, kMaxSpread);
        if (std::isfinite(d)) out.footprint += out.spread * d;
        return out;
    }
};

class Jg19 : public TailRoulette {  // (regularizer.h (9))
public:
    // Throws std::invalid_argument for tau0 <= 1 / (2 pi) or NaN.
    explicit Jg19(const Jg19Settings& settings);
    const Jg19Settings& settings() const { return settings_; }
    // tau_n for iteration n >= 1 (Eq. 16, or tau0 for the fixed schedule); the camera's bound
    // and the integrator's techniques for the quality heuristic.
    void beginIteration(uint64_t n, const Scene& scene, const MisConfig& cfg);
    // Only tau_n (the constructor: n = 1; tests that build paths by hand).
    void setIteration(uint64_t n);
    float tau() const { return radiance_.reg.tau; }
    // regularizer.h (7): tau' values found not to be numbers (their techniques refused).
    uint64_t invalidValues() const { return invalid_.count(); }

    // (1) The request at the vertices select() chose, with their bounds. Value-only: connect and
    // merge read the regularised evaluation's value (its densities only where the policy samples
    // the regularised BSDF itself, Technique::pdfLight, pdfCamera: OPSR's path tracer, not JG19),
    // so its two densities are not computed.
    BsdfContext context(const Technique& tech, End end) const {
        const int j = end == End::Light || tech.photon ? tech.s - 1 : tech.s;  // the end's x index
        const TransportMode mode = end == End::Light ? TransportMode::Importance : TransportMode::Radiance;
        for (int m = 0; m < 2; ++m)
            if (j >= 0 && tech.regularised[m] == j) {
                BsdfContext c = end == End::Light ? importance_ : radiance_;  // (bound form, compensation)
                c.reg.tau = tech.bound[m];
                if (cone()) c.reg.cone = coneForBound(tech.bound[m]);
                c.valueOnly = true;
                return c;
            }
        return BsdfContext(mode);
    }
    // (2), (5). The commonest answer inline: a connection or merge whose subpaths' changeable
    // counts are 0, or whose joining segment's or running-minimum term is under tau^2
    // (connectionUnder; a merge's joining segment is the photon's, y[s-2] - z[t-1], the one of the
    // connection technique with the same vertices), is unregularised; everything else (emitter
    // hits, ends at infinity, the loop) is the out-of-line form.
    // (10) Under the quality heuristic, a camera vertex whose subpath has nothing the bound changes
    // (changeable 0; a light endpoint has none): select() leaves its connection to a light plain.
    bool plainNextEvent(const PathVertex& v) const { return settings_.quality && v.regState.jg.changeable == 0.f; }
    bool select(Technique& tech) const {
        const int lightCount = tech.photon ? tech.s - 1 : tech.s;  // (a merge's x_i is z[t-1])
        if (settings_.quality && lightCount >= 1 && tech.t >= 1 && tech.y) {
            const PathVertex &a = tech.y[lightCount - 1], &b = tech.z[tech.t - 1];
            const bool nothingChangeable = a.regState.jg.changeable + b.regState.jg.changeable == 0.f;
            if (nothingChangeable || (allowsTechnique(set_, lightCount, tech.t) && connectionUnder(a, b))) {
                tech.regularised[0] = tech.regularised[1] = -1;
                // Eq. 18's answer: no end (a merge's: x_i) may stay a delta.
                return nothingChangeable || ((tech.photon || a.connectible()) && b.connectible());
            }
            // The out-of-line form's own O(1) exit adds only the emitter hit's term to these, and
            // its answer is the loop's: measured, it never exits here (connections and merges of
            // PT, BPT and VCM on point-in-glass, 48^2 and 256^2). Straight to the loop.
            return select(tech, false, true);
        }
        return select(tech, true, true);
    }
    // select() without its O(1) exit (q < tau^2 from the subpaths' running minima) and without
    // the path tracer's O(1) form: the plain form over the whole path, which select() must agree
    // with (tests).
    bool selectByLoop(Technique& tech) const { return select(tech, false, false); }
    // (2), (3)
    static constexpr bool kPerTechnique = true;
    bool perTechnique(const Technique& tech) const;
    void densities(const Technique& tech, PathPdfs& pdfs) const;
    // SubpathState: rhoBar, rhoBarReg and changeable for the heuristic; without it, ratio =
    // rho_hat / rho at the vertex (see (3); 1 at endpoints and where nothing changes) and
    // accumulated = the number of vertices before this one on its subpath whose ratio is finite
    // and not 1. (A singular vertex the walk passed through changes no weight: every technique
    // regularising it has factor 0, as its delta flag says anyway.)
    void start(PathVertex& v) const {
        v.roughenedByRequest = false;  // (no BSDF)
        v.regState = SubpathState{};
        v.regState.rhoBar = v.regState.jg.rhoBarReg = endpointBound(v);
        if (diffusion()) {
            v.regState.jg.rhoBarReg = 0.f;  // (no BSDF: nothing to change)
            v.regState.jg.spread = v.kind == VertexKind::Camera ? 0.f : -1.f;
        }
    }
    void extend(PathVertex& v, PathVertex& prev) const {
        v.roughenedByRequest =
            v.deltaBsdf && v.kind == VertexKind::Surface && !v.infinite && v.bxdf && roughenedByLoosest(*v.bxdf);
        SubpathState& st = v.regState;
        st.ratio = 1.f;
        if (settings_.quality) {
            st.accumulated = 0.f;
            surfaceBounds(v, st.rhoBar, st.jg.rhoBarReg);
            // The running minima only where select() reads them (with every connection a technique,
            // with merging); +inf otherwise. (PT on point-in-glass: -1.1% instructions.)
            st.jg.connectionMin = set_ == TechniqueSet::Bidirectional
                                   ? std::min(prev.regState.jg.connectionMin,
                                              segmentTerm(prev.regState.rhoBar, st.rhoBar, v.segmentLength))
                                   : kInf;
            st.jg.mergeMin = merging_ && connectible(v) ? std::min(prev.regState.jg.mergeMin, st.rhoBar) : prev.regState.jg.mergeMin;
            if (!diffusion()) {
                st.jg.changeable = prev.regState.jg.changeable + (st.jg.rhoBarReg < st.rhoBar ? 1.f : 0.f);
                return;
            }
            const SubpathState& p = prev.regState;
            float tauHere = loosest_.reg.tau;  // (a light subpath: the smallest tau')
            st.jg.spread = -1.f;
            st.jg.footprint = 0.f;
            if (p.jg.spread >= 0.f) {
                const Diffusion d = Diffusion{p.jg.spread, p.jg.footprint}.next(p.rhoBar, prev.curvature, v.segmentLength);
                st.jg.spread = float(d.spread);
                st.jg.footprint = float(d.footprint);
                tauHere = boundAt(d.spread);
            }
            st.jg.changeable = p.jg.changeable + (tauHere < st.jg.rhoBarReg ? 1.f : 0.f);
            return;
        }
        const float r = ratioAt(prev, -v.wo);
        prev.regState.ratio = r;
        st.accumulated = prev.regState.accumulated + (r != 1.f && r < kInf ? 1.f : 0.f);
        st.rhoBar = st.jg.rhoBarReg = st.jg.changeable = 0.f;
    }
    // (4) Any surface vertex with a BSDF that is not still a delta under the smallest bound a
    // vertex can get (tau_n; with the diffusion heuristic tau_n / Diffusion::kMaxSpread): the
    // walk's answer for a smooth BSDF (extend; one virtual call per vertex, not per connection).
    bool connectible(const PathVertex& v) const {
        if (v.connectible()) return true;
        return v.kind == VertexKind::Surface && !v.infinite && v.bxdf && (!v.deltaBsdf || v.roughenedByRequest);
    }
    // Merges on the smooth vertices made rough too (1).
    bool mergeable(const PathVertex& v) const { return connectible(v); }

    // rho_hat / rho of v's BSDF between v.wo and wi (1 where nothing changes, +inf where rho is a
    // delta or 0 and rho_hat is not).
    float ratioAt(const PathVertex& v, const Vec3& wi) const;
    // rho_bar of a light's directional emission (see (2)), and of a surface vertex's BSDF without
    // and with the iteration's request (0 without a BSDF; with diffusion, the ceiling of (4)).
    static float lightBound(const Light& light);
    // rho_bar_a rho_bar_b / d^2 of a segment (Jg19Heuristic::connectionMin): 0 where a bound is 0,
    // +inf where d is not finite and positive (the loop of select() compares those unscaled).
    static float segmentTerm(float a, float b, float d) {
        if (a == 0.f || b == 0.f) return 0.f;
        if (!(std::isfinite(d) && d > 0.f)) return kInf;
        return float(double(a) * double(b) / (double(d) * double(d)));
    }
    void surfaceBounds(const PathVertex& v, float& plain, float& regularised) const {
        if (!v.bxdf || v.infinite) {
            plain = regularised = 0.f;
            return;
        }
        if (const Lambert* l = v.bxdf->lambert()) {
            plain = maxComp(l->f);
            regularised = diffusion() ? 0.f : plain;  // ((4): no request changes it)
            return;
        }
        plain = v.bxdf->plainBound(settings_.bound);
        if (!diffusion()) {
            regularised = v.bxdf->valueBound(radiance_);
            return;
        }
        // (4): the ceiling. A rough lobe changes under any bound below its own; a delta one under
        // a bound that makes it rough at least at kMinAlpha (none: an index-matched dielectric), or
        // as a cone (5) under every finite bound; a diffuse one under none (Bxdf::changeableBound).
        regularised = v.deltaBsdf && cone() ? kInf : v.bxdf->changeableBound(settings_.bound);
    }

private:
    Jg19Settings settings_;
    float endpointBound(const PathVertex& v) const {
        if (v.kind == VertexKind::Camera) return cameraBound_;
        return v.light ? lightBound(*v.light) : 0.f;
    }
    bool diffusion() const { return settings_.quality && settings_.diffusion; }
    bool cone() const { return settings_.specular == SpecularMode::Cone; }
    // shortcut: the O(1) exit; fast: the path tracer's O(1) form of the loop (selectBounds).
    bool select(Technique& tech, bool shortcut, bool fast) const;
    bool selectBounds(Technique& tech, bool shortcut, bool fast) const;  // select() before the check (7)
    // The O(1) exit of select() for a connection a - b (a = y[s-1], b = z[t-1], both finite; a
    // technique of the running integrator, so its own segment's term is one of Eq. 17's), in
    // float: the joining segment's term rho_bar_a rho_bar_b (d_path / d)^2, or (BPT, VCM) d_path^2
    // times the subpaths' running minima (VCM: their merge terms too), is under tau^2 with the
    // margin of the out-of-line exit (kExitMargin, far above float's rounding here), so the
    // loop's q in double is under tau^2 too. False where a term cannot be formed in float (d = 0,
    // overflow): the out-of-line form decides.
    bool connectionUnder(const PathVertex& a, const PathVertex& b) const {
        if (a.infinite || b.infinite) return false;
        const Vec3 ab = a.p - b.p;
        const float d2 = glm::dot(ab, ab);
        if (!(d2 > 0.f)) return false;
        const float dPath = a.pathLength + b.pathLength + std::sqrt(d2);
        const float dPath2 = dPath * dPath;
        if (a.regState.rhoBar * b.regState.rhoBar * dPath2 < tauSqExit_ * d2) return true;
        if (set_ == TechniqueSet::Bidirectional &&
            std::min(a.regState.jg.connectionMin, b.regState.jg.connectionMin) * dPath2 < tauSqExit_)
            return true;
        return merging_ &&
               std::min(a.regState.jg.mergeMin, b.regState.jg.mergeMin) * dPath2 < tauSqExit_ * float(mergeDensity_);
    }
    void setLimits();  // loosest_ from tau_n (and smooth_ cleared: it was for the previous one)
    // Whether the loosest request makes the smooth BSDF b rough (PathVertex::roughenedByRequest):
    // from smooth_ for the scene's smooth BSDFs (beginIteration), else b's own answer, a virtual
    // call of about 100 instructions that extend() would otherwise make at every smooth vertex.
    struct SmoothBsdf {
        const Bxdf* bxdf;
        bool roughened;
    };
    std::vector<SmoothBsdf> smooth_;
    bool roughenedByLoosest(const Bxdf& b) const {
        for (const SmoothBsdf& e : smooth_)
            if (e.bxdf == &b) return e.roughened;
        return !b.deltaUnder(loosest_);
    }
    // tau' = tau_n / sigma (Eq. 19).
    float boundAt(double spread) const {
        if (std::isnan(spread)) return float(spread);  // (7): select() refuses it, not tau_n in its place
        return spread > 0.0 ? float(double(radiance_.reg.tau) / spread) : radiance_.reg.tau;
    }
    InvalidValueCount invalid_;  // regularizer.h (7)
    BsdfContext radiance_{TransportMode::Radiance}, importance_{TransportMode::Importance};
    // The smallest bound a vertex gets: tau_n, or tau_n / kMaxSpread with diffusion ((4), connectible).
    BsdfContext loosest_{TransportMode::Radiance};
    // The O(1) exits answer "q < tau^2" only below tau^2 (1 - kExitMargin): the running minima
    // are stored in float, the loop computes q in double.
    static constexpr double kExitMargin = 1e-4;
    float tauSqExit_ = 0.f;  // tau_n^2 (1 - kExitMargin), connectionUnder's threshold (setLimits)
    // The quality heuristic's view of the running integrator (beginIteration).
    float cameraBound_ = 1.f;
    TechniqueSet set_ = TechniqueSet::Bidirectional;
    bool merging_ = false;
    double mergeDensity_ = 0.0;  // N pi r^2
};

}  // namespace lt::reg
