// The regulariser seam: the one place where a path-space regulariser (JG19, KD13, OPSR; issues
// 13-15) changes light transport.
//
// A regulariser is a value-type policy. connect, emitterHit and merge (path.h) consult it with the
// vertices of the technique they evaluate; the walks carry its per-subpath state on the vertices.
// These routines are templates on the policy; the walks and the integrators' loops pass the
// policy object through and do not learn which one runs (the integrators are class templates on
// it, instantiated in one place: makeIntegrator). `reg::None` below is the identity and the
// reference for the interface: its hooks are empty or constant, so with it every routine compiles
// to the unregularised code.
//
// A policy provides, with None's signatures:
//
//  (1) A per-vertex roughness override at connection and merge vertices.
//        context(tech, end): the BsdfContext (bsdf/bsdf.h) with which the BSDF of the technique's
//        connection vertex at `end` is evaluated: y[s-1] for End::Light (mode Importance), z[t-1]
//        for End::Camera (mode Radiance; for a merge, the camera vertex where the photon is
//        gathered). Its request (a minimum alpha, a bound tau, a cone) is resolved by each lobe
//        with its own distribution, masking and eta. The walks never ask: they sample and evaluate
//        the materials' own BSDFs (JG19 Sec. 3). None returns the constant context of the mode.
//
//  (2) Per-technique densities for MIS.
//        kPerTechnique, perTechnique(tech), densities(tech, pdfs): a regulariser changes the
//        integrand of technique k at k's own connection vertices x_{k-1}, x_k (of the merge at x_i:
//        at x_i), and so k's density in the MIS (JG19 Eq. 13: p_hat_k = rho_hat / rho p_k, each
//        technique at its own vertices, not at those of the technique being weighted). A policy
//        with kPerTechnique = true is asked per evaluated technique, once its connection ends
//        are evaluated (tech.ratioLight, ratioCamera), whether the path needs per-technique
//        densities at all (perTechnique: false when no vertex of the path is regularised, and
//        then everything runs as unregularised, fast forms included). If it does, after connect,
//        emitterHit or merge has gathered the path's densities, densities() writes the factor of
//        every technique, evaluated from the path's vertices (tech gives both subpaths), into
//        PathPdfs::connectionScale[k] and mergeScale[i] (0: the technique cannot sample the path),
//        and the MIS sums multiply each technique's density by its factor. The fast forms that do
//        not see every technique's factor are bypassed then: the path tracer's closed-form weight
//        and the merges' prefix sums (photon.misLight, cameraSums): merge then needs the light
//        subpath's vertices and densities. The path tracer's limited gathers (readLimit,
//        WalkPdfs::EmitterHits) stay: its two techniques compare x_0's densities only, whatever
//        their factors, and a policy computes its factors from the vertices and its SubpathState,
//        not from the densities.
//  (3) Per-subpath state carried on the vertices.
//        start(v): at a subpath's endpoint (camera, light, NEE light sample), after its record is
//        written; extend(v, prev): at every vertex a walk adds, from the vertex it came from
//        (prev's lobe is known then; v's densities are not yet). Both write v.regState, a
//        SubpathState: what a regulariser accumulates along a subpath (JG19's diffusion, OPSR's
//        count of glossy vertices in BPT and VCM); extend may also complete prev's state, whose two
//        neighbours are known from then on (JG19's ratio rho_hat / rho at prev). None writes
//        nothing (the field is left as it was).
//
//  (4) Where connections and merges may be made, and the iteration.
//        connectible(v): may a connection use v as an end (None: v.connectible(), no delta
//        vertex; JG19 makes smooth conductors and dielectrics rough there, and KD13 puts its cone
//        there, so every surface vertex with a BSDF may). mergeable(v): may a merge gather at v
//        (the photon grid stores the light vertices where it holds, the camera walk merges where
//        it holds; None and KD13: v.connectible(); JG19: connectible(v)). PPM keeps
//        v.connectible().
//        beginIteration(n, scene, cfg): before iteration (pass) n >= 1 starts, walks included
//        (JG19's tau_n), with the scene and the running integrator's techniques (cfg: its
//        technique set, merging, and this iteration's merge area and light path count).
//  (5) Which vertices of the path are regularised.
//        select(tech): the first thing connect, emitterHit and merge do, before any evaluation.
//        Writes tech.regularised, the x indices (path.h) of the path's vertices evaluated with the
//        request; context(tech, end) is the request's context only at those (connect evaluates a
//        connection with nothing regularised with the plain contexts, without asking;
//        tests/test_seam_contract.cpp holds every policy to it). A policy whose
//        choice is a function of the path (the same for every technique that can produce it;
//        JG19's quality heuristic) makes every technique estimate one integrand per path, so the
//        MIS weights of the techniques that can sample it sum to one with no light counted twice.
//        Returns false when the technique's weight on this path is 0 (the routine then returns
//        nothing, before its shadow ray). None: regularises nothing, returns true.
//        The ends of a connection are connectible(v) when select() is asked (the integrators
//        connect only there, and connect checks its surface ends; endpoints have no delta flag),
//        so a policy need not ask again.
//  (6) Optional: the path tracer's regularised BSDF sample (OPSR, opsr.h (4)).
//        kEmitterSample = true and emitterSample(z, t, ctx): where it returns true, the path
//        tracer's emitter-hit technique through camera vertex z[t-1] is a BSDF sample drawn there
//        with the context ctx (an extra ray), evaluated by emitterHit with
//        Technique::regularisedSample set; select() then refuses the walk's own emitter hits
//        through z[t-1]. Where emitterSample returns false at a vertex the request changes because
//        the material's own sample covers the regularised BSDF (Bxdf::requestRatioBound), the
//        walk's own emitter hits through it are that technique instead: select() sets
//        Technique::walkSample and hitRatio, and emitterHit scales the walk's value by it.
//        A policy without the member has no such sample (None, JG19, KD13).
//  (7) A guard on the policy's own per-vertex values (issue 17 item 5): JG19's bound tau', KD13's
//        cone half-angle, OPSR's accumulated roughness. One that is not a number where select()
//        computes it (a degenerate vertex, a NaN from upstream) must not quietly read as "no
//        request" (NaN > 0 is false), which would evaluate the path as if unregularised or drop it
//        unseen: select() refuses the technique (its contribution is never written) and counts the
//        value in the policy's InvalidValueCount (invalidValues()), which render reports beside
//        the invalid samples. None has no values.
//  (8) Optional: the path tracer's cone hits (KD13, kd13.h (5)).
//        kConeHits = true and coneHitsAt(v): at camera vertex v where it returns true, the path
//        tracer draws a BSDF sample of v's own (delta) BSDF on a stream split from the walk's, and
//        counts each delta light whose direction lies in the cone of the sampled lobe: the
//        emitter-hit technique of the mollified path, evaluated through connect (the cone, the
//        shadow ray, the densities) and weighted by MIS against next-event estimation there
//        where coneHitsCompete() (more than one light), alone under BSDF sampling only.
//        A policy without the member has no such hits (None, JG19, OPSR).
//  (9) Russian roulette on the connections only the regulariser makes (every policy but None:
//        TailRoulette below, --reg-tail-rr). Where an end's own BSDF gives nothing for the pair
//        and the request's does (Technique::ratioLight or ratioCamera +inf: a delta made rough, or
//        a lobe widened onto the pair), connect, before its shadow ray, keeps the connection with
//        probability q = prod over those ends of min(1, pi f_hat / T) (f_hat the regularised
//        value, channel mean: pi f_hat is 1 for a white Lambertian) and divides its contribution
//        by q. A narrow regularised lobe has long tails of next to nothing: with OPSR's roughness
//        of 0.01 at amber's glass, 9 in 10 of its connections there carry together 0.15% of
//        their light; each costs a light sample, an evaluation and a shadow ray, where the
//        unregularised path has no connection at all. Unbiased for the regularised integrand
//        (each technique's value in expectation, its densities and so its MIS weight
//        unchanged); the variance it adds to a connection is c^2 (1/q - 1) <= (T cos / pi)^2 K^2 / 4
//        for c = K f_hat cos, at most T^2 / 4 of the square of a white Lambertian's at that end,
//        and a kept one is worth what a
//        Lambertian of albedo T would be there (no fireflies). The number is drawn from a stream
//        split from the sample's (so every other number, and every connection not culled, stays
//        as it was) keyed by (s, t).
// (10) The path tracer's plain next-event estimation.
//        plainNextEvent(v): true where every connection from camera vertex v to a light endpoint
//        is one select() leaves unregularised with no per-technique densities (nothing regularised,
//        the contexts the plain ones, no roulette), so that the connection, its value, densities
//        and MIS weight, are reg::None's bit for bit. The path tracer then runs None's routine
//        there, whose records no out-of-line call of the policy sees: the compiler keeps them in
//        registers instead of writing the light vertex and the technique out for select()'s
//        out-of-line form. None: always. OPSR: a vertex no request can change (mayChange). KD13:
//        a plain vertex. JG19: under the quality heuristic, a subpath with nothing the bound
//        changes (changeable 0); never without it (its MIS reads the subpath's ratios).
#pragma once
#include <type_traits>
#include <atomic>
#include <cstdint>
#include "bsdf/bsdf.h"

namespace lt {

struct PathVertex;
struct PathPdfs;
struct Photon;
struct MisConfig;
class Scene;

// JG19's quality and diffusion heuristics' part of SubpathState (below).
struct Jg19Heuristic {
    // rho_bar of this vertex with the iteration's request (with the diffusion heuristic: the
    // largest bound under which the request changes the BSDF, 0 if none does), and the number of
    // vertices of the subpath up to this one that the request changes (may change, on a light
    // subpath under the diffusion heuristic).
    float rhoBarReg = 0.f;
    float changeable = 0.f;
    // The diffusion heuristic on a camera subpath: the angular spread of the segment arriving
    // here and the footprint here (jg19.h (4)); spread -1 on a light subpath.
    float spread = 0.f, footprint = 0.f;
    // The smallest rho_bar_a rho_bar_b / d^2 over the segments of this subpath up to here (a, b
    // the segment's ends, d > 0 finite its length; 0 where either bound is 0; +inf with no such
    // segment). Its connection terms of Eq. 17 are d_path^2 times these, so select() can tell
    // that q < tau^2 without the path's loop (jg19.h (2)).
    float connectionMin = kInf;
    // With merging (VCM): the smallest rho_bar over the vertices of this subpath after its
    // endpoint up to here where a merge can happen (connectible(); +inf with none). The merge
    // terms of Eq. 17 are d_path^2 / (N pi r^2) times these (jg19.h (2)).
    float mergeMin = kInf;
};

// OPSR's part of SubpathState (opsr.h).
struct OpsrState {
    // BPT, VCM: the geometry of a glossy vertex the walk has left, between its two walk
    // neighbours, for rho_hat / rho under the other side's roughness (opsr.h (5)).
    PairGeometry pair;
    // With one constant gamma: prod (1 - gamma a_i) over the subpath's surface vertices before this
    // one, in the order of Eq. 11's product (opsr.h (2)), so that a vertex's accumulated roughness
    // is known without a loop over its subpath.
    float keep;
    // Over the subpath before this vertex (Opsr::samplable): whether two neighbouring vertices are
    // plain connection ends, whether one after the endpoint is, and whether the one before this
    // is (so that the next vertex can tell its pair).
    bool plainPairBefore, plainInnerBefore, previousPlain;
    // Whether every surface vertex of the subpath before this one has roughness 0 (smooth): then
    // Eqs. 11, 13 and 14 give this vertex its own roughness, whatever the factors
    // (Opsr::unchangedByOwnWalk).
    bool smoothBefore;
};

// Per-subpath state of a regulariser on every vertex (PathVertex::regState; the comments give
// JG19's meanings, OPSR uses accumulated, ratio and rhoBar its own way: opsr.h). Nine floats: the
// record is 176 bytes with them (168 with eight, 160 with six, 144 with two, which fit the tail
// padding). The last six are JG19's heuristics' or OPSR's, never both (one policy runs).
struct SubpathState {
    float accumulated = 0.f;  // (JG19: the number of vertices before this one whose ratio is finite, not 1)
    // JG19: rho_hat / rho at this vertex, between its two neighbours on its own subpath (written
    // when the walk extends past it; +inf when rho is 0 or a delta: a "singular" vertex).
    float ratio = 1.f;
    // JG19's quality heuristic: rho_bar of this vertex (its BSDF's bound, Bxdf::valueBound, or an
    // endpoint's bound on its directional density) without the iteration's request.
    float rhoBar = 0.f;
    union {
        Jg19Heuristic jg{};
        OpsrState opsr;
    };
};

// (7) The count of a policy's values found not to be numbers; shared by the render's threads
// (relaxed: only the total is read, after the render). A policy is a value type: copying it
// copies the count.
class InvalidValueCount {
public:
    InvalidValueCount() = default;
    InvalidValueCount(const InvalidValueCount& o) : n_(o.count()) {}
    InvalidValueCount& operator=(const InvalidValueCount& o) {
        n_.store(o.count(), std::memory_order_relaxed);
        return *this;
    }
    void add() const { n_.fetch_add(1, std::memory_order_relaxed); }
    uint64_t count() const { return n_.load(std::memory_order_relaxed); }

private:
    mutable std::atomic<uint64_t> n_{0};
};

// The vertices of the technique that connect, emitterHit or merge evaluates.
struct Technique {
    const PathVertex* y = nullptr;  // light subpath y[0..s-1] (none for s = 0, or a merge's fast form)
    int s = 0;
    const PathVertex* z = nullptr;  // camera subpath z[0..t-1]
    int t = 0;
    const Photon* photon = nullptr;  // a merge: the light vertex y[i] merged at z[t-1] (s = i + 1)
    // rho_hat / rho of the BSDF at the technique's own connection ends, y[s-1] (light) and z[t-1]
    // (camera; for a merge, its camera vertex), as the routine evaluated them (1 without a
    // request; +inf when rho is 0 or a delta). Written by connect and merge before densities().
    float ratioLight = 1.f, ratioCamera = 1.f;
    // The regularised BSDF's own solid-angle density of the connection direction at each end (0
    // where the request did not change the BSDF, or where the policy's context is value-only),
    // written with the ratios. Read by OPSR's path tracer, which samples the regularised BSDF
    // itself (opsr.h (4)); JG19's context is value-only (its densities are never read).
    float pdfLight = 0.f, pdfCamera = 0.f;
    // The x indices (path.h: x_0 the light end) of the vertices of this path that the policy
    // regularises (regularizer.h (5); -1: none), written by select(), and the parameter of the
    // request at each (a policy whose request varies per vertex or per path: JG19's bound tau
    // under the diffusion heuristic, KD13's cone half-angle).
    int regularised[2] = {-1, -1};
    float bound[2] = {kInf, kInf};
    // An emitter hit (s = 0) whose last direction was the path tracer's regularised BSDF sample
    // (6), not the camera walk's own.
    bool regularisedSample = false;
    // (6) The path tracer's emitter-hit technique through the regularised camera vertex next to
    // the light is the walk's own BSDF sample, not a regularised one (select() writes it, for
    // next-event estimation and the emitter hit alike): the technique's density is the material's
    // own, and an emitter hit's value is the walk's times hitRatio, rho_hat / rho at that vertex.
    bool walkSample = false;
    float hitRatio = 1.f;
};

// (7) True where valid(bound) holds at every vertex select() regularised in `tech` (write valid
// so that a NaN fails it); otherwise the value is counted in `invalid` and the answer is false
// (the technique is refused).
template <class Valid>
bool boundsValid(const Technique& tech, Valid&& valid, const InvalidValueCount& invalid) {
    for (int m = 0; m < 2; ++m)
        if (tech.regularised[m] >= 0 && !valid(tech.bound[m])) {
            invalid.add();
            return false;
        }
    return true;
}

// The two ends of a technique's connection.
enum class End { Light, Camera };

// For policies whose request at a connection end is one number per regularised vertex (KD13's
// cone, OPSR's roughness): the bound select() gave the technique's vertex at `end` (x index s - 1
// or s), -1 where it regularises none there; the transport mode of that end; and whether select()
// regularised any vertex.
inline float boundAt(const Technique& tech, End end) {
    const int j = end == End::Light ? tech.s - 1 : tech.s;
    for (int m = 0; m < 2; ++m)
        if (tech.regularised[m] == j) return tech.bound[m];
    return -1.f;
}
inline TransportMode modeAt(End end) { return end == End::Light ? TransportMode::Importance : TransportMode::Radiance; }
inline bool anyRegularised(const Technique& tech) { return tech.regularised[0] >= 0 || tech.regularised[1] >= 0; }

namespace reg {

// (9) The threshold T of the roulette, held by every policy that requests (a base; 0: every
// connection is traced; a policy without the base, as None, traces every connection).
struct TailRoulette {
    float tailThreshold = 0.f;
};
// The default of --reg-tail-rr: at 0.1 the regularised contributions of OPSR's path tracer on
// amber fall from 13.8% of all to 1.6% (the rest culled), its sample takes 2.6% less time (JG19's
// 4.2%), and the variance the roulette adds is at most 0.07% of a 64-spp render's error in twelve
// SDS configurations (docs/regularisation-cost.md, "Tail roulette").
inline constexpr double kDefaultTailThreshold = 0.1;

// No regularisation: the reference implementation of the interface above.
struct None {
    // (1) The context at the technique's connection vertex at `end`.
    const BsdfContext& context(const Technique&, End end) const {
        return end == End::Light ? kImportanceContext : kRadianceContext;
    }
    // (2) No per-technique densities: the MIS compares the unregularised densities.
    static constexpr bool kPerTechnique = false;
    bool perTechnique(const Technique&) const { return false; }
    void densities(const Technique&, PathPdfs&) const {}
    // (3) No per-subpath state.
    void start(PathVertex&) const {}
    void extend(PathVertex&, PathVertex&) const {}
    // (4) Connections at non-delta vertices only; nothing depends on the iteration.
    bool connectible(const PathVertex& v) const;
    bool mergeable(const PathVertex& v) const;
    void beginIteration(uint64_t, const Scene&, const MisConfig&) {}
    // (5) Nothing regularised; every technique contributes.
    bool select(Technique&) const { return true; }
    // (10) Every next-event estimation is plain.
    bool plainNextEvent(const PathVertex&) const { return true; }
};
// The unregularised policy as a value, for callers that pass it directly (the tests).
inline constexpr None kNone{};
// Whether a policy's contexts may carry a request (None's never do: the connection routines then
// evaluate a connection end once, without asking whether a request could change it).
template <class Reg>
inline constexpr bool kMayRequest = !std::is_same_v<Reg, None>;

}  // namespace reg

}  // namespace lt

// (None::connectible needs the vertex record: defined at the end of path.h.)
