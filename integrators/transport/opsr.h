// OPSR: optimised path-space regularisation (Weier et al. 2021), as a policy of the regulariser
// seam (regularizer.h). Paper: ../shared/papers/opsr21-optimised-path-space-regularisation.txt.
// Reference attenuation factors: a JSON file the user passes by path (the authors' learnt tables,
// e.g. ../shared/data/opsr/opsr-reference-attenuation.json); the project ships no copy.
//
// (1) Roughness of a vertex (the reference file's convention): Lambert 1, a smooth conductor or
//     dielectric 0, a microfacet lobe min(alpha_u, alpha_v) clamped to [0, 1]
//     (Bxdf::roughness(), cached per shape in SurfacePoint::roughness).
// (2) Accumulated roughness of a subpath's surface vertices a_0 (the first after the endpoint;
//     endpoints have none) .. a_{k-1} (the connection vertex):
//       g = 1 - (1 - a_{k-1}) prod_{i<k-1} (1 - gamma a_i)          (Eq. 11: one constant gamma;
//                                                                      Eq. 13: gamma per class)
//     A subpath of one surface vertex keeps its roughness (Eq. 6).
//     Per-class gamma (a table): Q = 4 bins, bin(a) = min(floor((2^sqrt(a) - 1)(Q + 1)), Q - 1);
//     a window of k <= 5 vertices reads tables[k] at index sum_j Q^j bin(a_j) (a_0 the oldest),
//     one gamma for the whole window. Longer subpaths (Eq. 14): the first five vertices collapse
//     into a virtual roughness g_6(a_0..a_4) (with their own window's gamma), which takes the place
//     (and the bin) of a_4 in the next window; the window advances by four until at most five
//     remain. If the connection vertex falls in the top bin its own roughness is kept (the
//     reference implementation's rule; with a constant gamma there is no such rule).
//     Interp sets ('interp' in the set's name, trained with multilinear interpolation): each
//     window vertex has the continuous bin coordinate c(a) = (2^sqrt(a) - 1)(Q + 1) clamped to
//     [0, Q - 1], the table's entry for bin i stands at its centre i + 1/2 (so the nearest-bin
//     look-up is the nearest node), and gamma interpolates multilinearly between the two nearest
//     nodes per vertex (clamped at the first and last centre). The file does not state where the
//     nodes stand; bin centres are our reading.
// (3) The consistent offset (Sec. 4.2): g_N = a_{k-1} + (g - a_{k-1}) N^-lambda, N the pass (each
//     pixel takes one sample per pass), lambda in (0, 1/2) (default 1/6).
// (4) Where (the path tracer, as the reference implementation). At next-event estimation
//     the camera vertex z[t-1] is evaluated with the request minAlpha = g of the camera subpath
//     z[1..t-1] wherever that changes its BSDF (a smooth vertex with g >= kMinAlpha becomes a rough
//     GGX lobe, a glossy one with g > its alpha a rougher one). The path tracer's other technique
//     for such a path, the emitter hit, is a BSDF sample drawn at z[t-1] with the same request
//     (one extra ray there, when the scene has a light a ray can hit), as in the reference
//     implementation; the walk itself continues with the material's own BSDF (the prefix is the
//     unregularised one), and its own emitter hits through a vertex the request changes have
//     weight 0 (the regularised sample replaces them). So both techniques estimate one integrand,
//     the path with its last vertex before the light regularised, and the MIS compares their own
//     densities: the regularised BSDF's density at z[t-1] and the light sample's (densities()).
//     Except where the material's own sample covers the regularised BSDF (ours, not the
//     reference's): at a glossy vertex whose request bounds rho_hat / rho over every pair by
//     walkSampleBound (Bxdf::requestRatioBound: an isotropic GGX lobe made at most twice as rough,
//     so the walk's sample weighs the regularised value at most 4 times its own), the emitter-hit
//     technique is the walk's own sample, its value scaled by rho_hat / rho there and its density
//     the material's (in both techniques' MIS). It estimates the same integrand without the extra
//     sample and ray. Smooth vertices, Beckmann lobes and lobes made rougher still keep the
//     regularised sample, and so does every vertex under JG19's bound ((6); walkCovers).
//     A smooth vertex with nothing accumulated (g = 0: only smooth vertices before it) stays a
//     delta: next-event estimation cannot connect there and select() refuses it.
// (5) Where (BPT, VCM, light tracing: our extension; the paper has the path tracer only). Every
//     connection end x_j takes the accumulated roughness of its own subpath: g_L(j) over x_1..x_j
//     for the light end (the light walk's order: x_1 the oldest), g_C(j) over x_{n-2}..x_j for the
//     camera end. Merges and emitter hits are not regularised (no connection vertex; a merge is
//     a regularisation of its own). So technique k estimates f_k = f R_L(x_{k-1}) R_C(x_k), R the
//     ratio rho_hat / rho of the vertex's BSDF between its two path neighbours with that side's g
//     (1 where the request changes nothing), and the techniques estimate different integrands.
//     - Glossy ends (a microfacet lobe, alpha < 1): MIS as JG19 Eqs. 12-13 (jg19.h (3)): technique
//       k's density is p_k / (R_L(x_{k-1}) R_C(x_k)), each ratio at k's own ends with k's own
//       roughness. Each inner glossy vertex has its own side's R and its pair geometry from its
//       walk (extend; bsdf.h, PairGeometry); densities() takes its other side's R from that
//       geometry (Bxdf::requestRatio: D' G2' / (D G2), no evaluation; an anisotropic lobe, which
//       has no such form, is evaluated). The weights of the
//       techniques that can sample a path sum to one, each f_k is finite, and the combination
//       lies between them.
//     - Smooth ends (a conductor or dielectric with a delta BSDF): own-end regularisation and
//       Eq. 12 would count light twice. A technique that samples through the smooth vertex (a
//       walk follows its delta) puts the sharp light on the path that is exactly specular there;
//       a technique that connects there with a rough lobe puts a blurred copy on the paths next
//       to it, which no other technique can produce, so both keep weight 1 (JG19 measured +71% on
//       point-in-glass BPT this way: jg19.h (2)). So at smooth vertices OPSR is selective as KD13
//       (kd13.h (1)-(2)): a smooth end is regularised only on a path that no technique of the
//       running integrator samples without a regulariser (samplableUnregularised: a caustic of an
//       area light keeps BPT's sharp, unbiased estimate), and then by one technique: of the
//       connections whose smooth ends the request makes rough (g_L or g_C >= kMinAlpha, with the
//       roughness accumulated on that side), the one with the fewest smooth ends, then the one
//       nearest the light (the fewest light vertices; for a point light behind glass after a
//       rough vertex: next-event estimation at the glass, the path tracer's and the paper's
//       setting, for which the reference tables were learnt). It has weight 1; its glossy end, if
//       any, takes its own roughness too. (KD13's longest connection is ours no longer: its cone
//       narrows with the connection's length, OPSR's roughness does not, and on
//       scenes/hard/caustic-mirror.xml that rule chose light tracing at the mirror next to the
//       camera, which blurred everything seen in the mirror, horizon and caustic gone.) A path
//       whose smooth vertices only ever see smooth ones from both sides (a point light seen
//       through glass: L S S E) stays unrendered, as in the path tracer.
//     This differs from (4): the path tracer regularises next-event estimation at a smooth vertex
//     after a rough one whatever the light (the reference's choice), BPT only where nothing else
//     samples the path. With an area light, BPT keeps the sharp caustic the path tracer blurs.
// (6) With JG19's bound (--reg jg19,opsr; ours): the request at every vertex OPSR regularises
//     carries JG19's bound tau_n beside the accumulated roughness g, so each lobe is evaluated
//     with alpha' = max(alpha, g, alpha_hat(tau_n)) (MicrofacetLobe::resolve; alpha_hat per
//     lobe, with its distribution, masking and eta: jg19.h (1)). A vertex the bound changes
//     where g does not (g <= its roughness: a smooth vertex after only smooth ones, the
//     connection vertex in the top bin) is regularised with the bound alone, so the paths OPSR
//     leaves unrendered (a point light seen through glass: L S E, L S S E) render as with JG19.
//     OPSR chooses the vertices ((4), (5)) and the MIS (Eq. 12) as without the bound: JG19's
//     quality and diffusion heuristics do not apply (its bound only, with its schedule: tau_n
//     by Eq. 16 or tau_0).
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>
#include "integrators/transport/path.h"

namespace lt::opsr {

inline constexpr int kQ = 4;          // roughness bins
inline constexpr int kMaxWindow = 5;  // surface vertices per window

// The per-class attenuation factors of one set: tables[k] holds Q^k factors for a window of k
// surface vertices (k = 2..5).
struct AttenuationTable {
    std::string file, set;
    bool interpolated = false;  // an 'interp' set: multilinear look-ups
    std::array<std::vector<float>, kMaxWindow + 1> tables;
};

// Loads set `set` of the attenuation file at `path` (the reference file's layout: sets.<set>.tables
// with keys "2".."5", arrays of Q^k numbers in [0, 1]). Throws std::runtime_error naming the file
// and the field for a missing or unreadable file, malformed JSON, a missing set (listing those
// there are), a table of the wrong length, or a factor that is not a finite number in [0, 1].
std::shared_ptr<const AttenuationTable> loadAttenuationTable(const std::string& path, const std::string& set);

// (2) The bin of a roughness, its continuous coordinate, and the table index of a window.
// roughnessBin is the formula's bin, read from its edges (measured: the formula's exp2 and sqrt per
// window vertex were a third of BPT's cost of a table): kBinEdges[i] is the least float whose bin
// by the formula is i + 1. The formula is non-decreasing over every float in (0, 1), so the edges
// give its bin for every float; test_opsr checks both over all of them (binByFormula).
inline constexpr float kBinEdges[kQ - 1] = {0x1.1b63ecp-4f, 0x1.e296d4p-3f, 0x1.d6d0f6p-2f};
// (the three comparisons written out: a loop over the edges cost BPT with a table 1% more
// instructions)
static_assert(kQ == 4, "roughnessBin compares with kQ - 1 = 3 edges");
inline int roughnessBin(float a) { return int(a >= kBinEdges[0]) + int(a >= kBinEdges[1]) + int(a >= kBinEdges[2]); }
int binByFormula(float a);  // min(floor((2^sqrt(a) - 1)(Q + 1)), Q - 1); 0 at a <= 0, Q - 1 at a >= 1
float binCoordinate(float a);
int windowIndex(const float* a, int k);
// The attenuation factor of the window a[0..k-1] (2 <= k <= 5): the nearest-bin entry or the
// multilinear one (table.interpolated).
float windowFactor(const AttenuationTable& table, const float* a, int k);
// 1 - (1 - a_{k-1}) prod_{i<k-1} (1 - gamma a_i); a[0] for k = 1.
float accumulateWindow(const float* a, int k, float gamma);

// The constant gamma when none is given: the paper's naive setting (Sec. 5, "Results Analysis").
inline constexpr float kDefaultGamma = 0.01f;

// How gamma is chosen: one constant (Eq. 11), or per class from a table (Eqs. 13-14).
struct Attenuation {
    float gamma = kDefaultGamma;
    std::shared_ptr<const AttenuationTable> table;
};
// The accumulated roughness of a subpath's surface vertices a[0..count-1] (count >= 1), a[count-1]
// the connection vertex: Eq. 11 with a constant gamma, Eqs. 13-14 with a table.
float accumulatedRoughness(const float* a, int count, const Attenuation& att);

}  // namespace lt::opsr

namespace lt::reg {

struct OpsrSettings {
    opsr::Attenuation attenuation;
    bool consistent = false;  // (3)
    double lambda = -1.0;     // < 0: 1/6
    bool bidirectional = false;  // (5) BPT, VCM, light tracing; else the path tracer (4)
    // (6) JG19's bound: tau_0 (> 1 / (2 pi)), 0 for none; its schedule (Eq. 16, or tau_0 throughout).
    double boundTau0 = 0.0;
    bool boundConsistent = true;
    // (4) The largest Bxdf::requestRatioBound at which the path tracer's walk sample is the
    // emitter-hit technique; below 1: never (every regularised vertex draws its own sample, the
    // plain form the tests compare with).
    float walkSampleBound = 4.f;
    // The bound's form for (6) and the energy compensation of smooth lobes made rough (bsdf.h,
    // RegularizationRequest).
    BoundForm bound = BoundForm::Tight;
    bool compensate = true;
};

class Opsr : public TailRoulette {  // (regularizer.h (9))
public:
    // Throws std::invalid_argument for gamma outside [0, 1], lambda outside (0, 1/2) or a bound
    // tau_0 that is neither 0 nor above 1 / (2 pi).
    explicit Opsr(const OpsrSettings& settings);
    const OpsrSettings& settings() const { return settings_; }
    void beginIteration(uint64_t n, const Scene& scene, const MisConfig& cfg);
    double lambda() const { return settings_.lambda < 0.0 ? 1.0 / 6.0 : settings_.lambda; }
    // The share of the accumulated offset g - a kept in pass N: N^-lambda (consistent), else 1.
    double offsetScale() const { return offsetScale_; }
    // (6) JG19's bound tau_n of this pass (0: none).
    float tau() const { return tau_; }
    // regularizer.h (7): roughnesses found not to be numbers (their techniques refused).
    uint64_t invalidValues() const { return invalid_.count(); }

    // The roughness the request asks for at the last vertex of the subpath path[0..count-1]
    // (path[0] its endpoint, path[1..count-1] surface vertices), with (3) applied; -1 where the
    // request would not change that vertex's BSDF (g not above its roughness, a BSDF that ignores
    // requests, or a smooth one the request leaves a delta).
    float request(const PathVertex* path, int count) const;
    // (5) The same at x_j of the path of `tech` (x_0 the light end), for the subpath that reaches
    // it from `side`'s endpoint: x_0..x_j (End::Light) or x_{n-1}..x_j (End::Camera).
    float requestFrom(const Technique& tech, int j, End side) const;
    // (5) Tests without a scene: the running integrator's techniques (beginIteration sets them).
    void setTechniques(TechniqueSet set, bool merging) { set_ = set, merging_ = merging; }
    // (5) The technique that regularises the smooth vertices of the path of connection `tech`
    // (its number of light vertices; -1: none, the path is samplable or no connection's smooth
    // ends can be made rough), its smooth ends (x indices, -1: none) and their roughness.
    struct SmoothChoice {
        int technique = -1;
        int ends[2] = {-1, -1};
        float g[2] = {-1.f, -1.f};
    };
    SmoothChoice chooseSmooth(const Technique& tech) const;
    // Whether chooseSmooth(tech).technique is tech.s itself (then `choice` is that choice), from the
    // techniques that could be preferred to it only: none where tech.s cannot make its smooth ends
    // rough, those nearer the light where it has one smooth end, and where it has two the others
    // with one, or two and nearer the light. The connection's own question (selectBidirectional);
    // tests compare it with chooseSmooth, the plain form, on every split of every path.
    bool choosesOwnTechnique(const Technique& tech, SmoothChoice& choice) const;
    // (5) samplableUnregularised(tech, the running integrator's techniques), in O(1) from the
    // walks' records where every connection is a technique (BPT, VCM).
    bool samplable(const Technique& tech) const;

    // The seam (regularizer.h).
    // The regularised BSDF's own densities (Technique::pdfLight, pdfCamera) are read only by the
    // path tracer's MIS against its regularised emitter hit ((4): with a light it can hit); every
    // other connection reads the value alone, so the evaluation leaves them out (valueOnly).
    BsdfContext context(const Technique& tech, End end) const {
        const float g = boundAt(tech, end);
        if (!(g >= 0.f)) return BsdfContext(modeAt(end));
        BsdfContext c = contextFor(modeAt(end), g);
        c.valueOnly = settings_.bidirectional || !hittableLight_ || tech.walkSample;
        return c;
    }
    // The request for accumulated roughness g: every lobe at least alpha g on both axes (and (6)
    // at least alpha_hat(tau_n)).
    BsdfContext contextFor(TransportMode mode, float g) const {
        BsdfContext c(mode);
        c.reg.minAlpha = {g, g};
        if (tau_ > 0.f) c.reg.tau = tau_;
        c.reg.bound = settings_.bound;
        c.reg.compensate = settings_.compensate;
        return c;
    }
    static constexpr bool kPerTechnique = true;
    // The path tracer (4): where its connection vertex is regularised. BPT and VCM (5): also where
    // another technique's end may be, i.e. the path has a glossy surface vertex (the subpaths
    // count them: SubpathState::accumulated).
    bool perTechnique(const Technique& tech) const {
        if (anyRegularised(tech)) return true;
        if (!settings_.bidirectional) return false;
        const float glossy = (tech.s >= 1 && tech.y ? tech.y[tech.s - 1].regState.accumulated : 0.f) +
                             (tech.t >= 1 ? tech.z[tech.t - 1].regState.accumulated : 0.f);
        return glossy > 0.f;
    }
    void densities(const Technique& tech, PathPdfs& pdfs) const;
    // SubpathState (BPT, VCM: (5)): accumulated, the number of glossy surface vertices (a
    // microfacet lobe a request may change: glossy()) of the subpath up to this one, for
    // perTechnique; at a glossy vertex the walk has left, ratio = rho_hat / rho between its two
    // walk neighbours with its own subpath's roughness (1 where that changes nothing) and the
    // pair's geometry (OpsrState::pair), from which densities() has the other side's ratio; where
    // the BSDF has no pair geometry, rhoBar = rho there instead (the channel sum, in the walk's
    // transport mode; 0 elsewhere), and densities() evaluates the other side's rho_hat. The path
    // tracer needs none of it.
    // keep (OpsrState): the product of Eq. 11 over the subpath before this vertex (constant gamma).
    void start(PathVertex& v) const {
        v.regState.accumulated = 0.f;
        v.regState.ratio = 1.f;
        v.regState.rhoBar = 0.f;
        v.regState.opsr.keep = 1.f;
        v.regState.opsr.plainPairBefore = v.regState.opsr.plainInnerBefore = v.regState.opsr.previousPlain = false;
        v.regState.opsr.smoothBefore = true;
    }
    void extend(PathVertex& v, PathVertex& prev) const {
        v.regState.accumulated = prev.regState.accumulated + (glossy(v) ? 1.f : 0.f);
        v.regState.ratio = 1.f;
        v.regState.rhoBar = 0.f;
        const bool prevSurface = prev.kind == VertexKind::Surface;
        v.regState.opsr.keep =
            prevSurface ? prev.regState.opsr.keep * (1.f - settings_.attenuation.gamma * prev.roughness) : 1.f;
        v.regState.opsr.smoothBefore = !prevSurface || (prev.regState.opsr.smoothBefore && prev.roughness == 0.f);
        if (!settings_.bidirectional) return;
        if (glossy(prev) && prev.depth >= 1) walkRatio(prev, -v.wo);
        // samplable()'s flags, where it may be asked: with smooth connection ends.
        // (prev is complete: the walk has sampled its way out of it)
        if (!smoothEnds_) return;
        const OpsrState& p = prev.regState.opsr;
        const bool prevPlain = plainConnectionEnd(prev);
        v.regState.opsr.plainPairBefore = p.plainPairBefore || (p.previousPlain && prevPlain);
        v.regState.opsr.plainInnerBefore = p.plainInnerBefore || (prev.kind == VertexKind::Surface && prevPlain);
        v.regState.opsr.previousPlain = prevPlain;
    }
    // Smooth surface vertices too where a connection may end there: whether the request makes one
    // rough depends on the subpath (select decides). BPT and VCM regularise a smooth end only on
    // paths no technique samples, and with the emitter hit among the techniques and every light
    // hittable every path has one (beginIteration).
    // (A smooth vertex no connection at it can make rough is left out: its techniques would be
    // refused by select() after their light sample or walk set-up.)
    bool connectible(const PathVertex& v) const {
        return v.connectible() || (smoothEnds_ && smooth(v) && !unchangedByOwnWalk(v));
    }
    // A smooth vertex whose own walk has no rough vertex before it (every roughness 0 before it,
    // OpsrState::smoothBefore) accumulates its own roughness 0 from that walk's side (Eqs. 11, 13
    // and 14 of zeros, whatever the factors; the consistent offset keeps 0), which no request
    // raises without JG19's bound (requestFor). A connection ending there takes that side's
    // roughness (the path tracer's next-event estimation; BPT's and VCM's technique of its own
    // ends, choosesOwnTechnique), so none can make it rough.
    bool unchangedByOwnWalk(const PathVertex& v) const {
        return tau_ <= 0.f && smooth(v) && v.roughness == 0.f && v.regState.opsr.smoothBefore;
    }
    bool mergeable(const PathVertex& v) const { return v.connectible(); }
    // The common answers inline: an emitter hit (the path tracer: through a vertex no request can
    // change; BPT and VCM: any) or a connection whose vertices no request can change (mayChange)
    // is unregularised; the rest is the out-of-line form.
    bool select(Technique& tech) const {
        tech.regularised[0] = tech.regularised[1] = -1;
        if (tech.photon) return true;
        if (tech.s == 0) {
            if (settings_.bidirectional) return true;
            if (tech.t < 3 || !mayChange(tech.z[tech.t - 2])) return !tech.regularisedSample;
        } else if (!mayChange(tech.y[tech.s - 1]) && !mayChange(tech.z[tech.t - 1])) {
            return true;  // (both ends connectible: regularizer.h (5); neither is smooth here)
        }
        return selectRequest(tech);
    }
    // (10) A camera vertex no request can change (mayChange): select() leaves its connections
    // to a light plain, with no per-technique densities.
    bool plainNextEvent(const PathVertex& v) const { return !mayChange(v); }
    // (6) The path tracer's regularised BSDF sample at camera vertex z[t-1]: true (and its context)
    // where the request changes z[t-1]'s BSDF and the scene has a light a ray can hit.
    static constexpr bool kEmitterSample = true;
    bool emitterSample(const PathVertex* z, int t, BsdfContext& ctx) const {
        return hittableLight_ && mayChange(z[t - 1]) && emitterSampleRequest(z, t, ctx);
    }
    // A surface vertex whose BSDF a request may change: a roughness below 1 (Lambert counts 1, and
    // a microfacet lobe at alpha >= 1 cannot be made rougher). request() decides the rest.
    // (A vertex without a BSDF or at infinity has roughness 1: SurfacePoint, PathVertex::setPoint.
    // So the roughness decides first, and Lambert's 1 answers the commonest case in one test.)
    static bool mayChange(const PathVertex& v) { return v.roughness < 1.f && v.kind == VertexKind::Surface; }
    // A smooth surface vertex (a delta BSDF, not at infinity), and a glossy one (a lobe a request
    // may make rougher, not smooth).
    // (deltaBsdf is false without a BSDF and at infinity: PathVertex::setPoint)
    static bool smooth(const PathVertex& v) { return v.deltaBsdf && v.kind == VertexKind::Surface; }
    static bool glossy(const PathVertex& v) { return mayChange(v) && !v.deltaBsdf; }
    // (4) Whether the path tracer's walk sample at v is the emitter-hit technique for v's request g.
    // Not with JG19's bound (6): its alpha_hat is many times a glossy lobe's alpha (on
    // caustic-roughness, glossy-chains and cornell-box-ggx no vertex passed), and resolving it for
    // the bound cost the path tracer 2-3% more instructions for nothing.
    bool walkCovers(const PathVertex& v, float g) const {
        return settings_.walkSampleBound >= 1.f && tau_ <= 0.f && !v.deltaBsdf &&
               v.bxdf->requestRatioBound(contextFor(TransportMode::Radiance, g).reg) <= settings_.walkSampleBound;
    }

private:
    bool selectRequest(Technique& tech) const;
    bool selectRoughness(Technique& tech) const;  // selectRequest() before the check (7)
    InvalidValueCount invalid_;                    // regularizer.h (7)
    bool selectBidirectional(Technique& tech) const;
    void densitiesBidirectional(const Technique& tech, PathPdfs& pdfs) const;
    bool emitterSampleRequest(const PathVertex* z, int t, BsdfContext& ctx) const;
    // chooseSmooth's candidate k (the connection x_{k-1} - x_k): false where one of its ends is
    // neither a plain connection end nor a smooth vertex the request makes rough; else its smooth
    // ends and their roughnesses in c (c.technique = k) and their number in count.
    bool smoothCandidate(const Technique& tech, int k, SmoothChoice& c, int& count) const;
    // The request for the roughnesses a[0..count-1] of a subpath's surface vertices (a[count-1]
    // that of v, its last).
    float requestWith(const PathVertex& v, const float* a, int count) const;
    // The same for v's accumulated roughness g (its subpath's, before (3)).
    float requestFor(const PathVertex& v, float g) const;
    // (6) The request where g changes nothing: v's own roughness (the bound alone) where the bound
    // changes v's BSDF, else -1.
    float boundOnly(const PathVertex& v) const;
    // SubpathState::ratio and rhoBar of the glossy walk vertex v (its walk's vertices are
    // contiguous: v.depth is its index), towards its successor in direction wi.
    void walkRatio(PathVertex& v, const Vec3& wi) const;
    OpsrSettings settings_;
    double offsetScale_ = 1.0;  // offsetScale() of the pass (beginIteration: one pow a pass, not a request)
    float tau_ = 0.f;  // (6) tau_n, 0 without the bound
    bool hittableLight_ = true;
    bool smoothEnds_ = true;  // connectible(): may a connection end at a smooth vertex?
    TechniqueSet set_ = TechniqueSet::PathTracer;
    bool merging_ = false;
};

}  // namespace lt::reg
