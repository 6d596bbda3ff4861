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
//        kPerTechnique, densities(tech, pdfs): a regulariser changes the integrand of technique k
//        at k's own connection vertices x_{k-1}, x_k (of the merge at x_i: at x_i), and so k's
//        density in the MIS (JG19 Eq. 13: p_hat_k = rho_hat / rho p_k, each technique at its own
//        vertices, not at those of the technique being weighted). After connect, emitterHit or
//        merge has gathered the path's densities, a policy with kPerTechnique = true writes the
//        factor of every technique, evaluated from the path's vertices (tech gives both subpaths),
//        into PathPdfs::connectionScale[k] and mergeScale[i], and the MIS sums multiply each
//        technique's density by its factor (PathPdfs::perTechnique). The fast forms that do not
//        see every technique's vertices are bypassed then: the path tracer's limited gathers
//        (readLimit, WalkPdfs::EmitterHits), its closed-form weight, and the camera-side sums of
//        merges (cameraSums). A merge's light side must then be gathered (lightPdfs given):
//        photon.misLight holds unregularised sums only.
//
//  (3) Per-subpath state carried on the vertices.
//        start(v): at a subpath's endpoint (camera, light, NEE light sample), after its record is
//        written; extend(v, prev): at every vertex a walk adds, from the vertex it came from
//        (prev's lobe is known then; v's densities are not yet). Both write v.regState, a
//        SubpathState: what a regulariser accumulates along a subpath (JG19's diffusion, OPSR's
//        product of (1 - gamma alpha_i)). None writes nothing (the field is left as it was).
#pragma once
#include "bsdf/bsdf.h"

namespace lt {

struct PathVertex;
struct PathPdfs;
struct Photon;

// Per-subpath state of a regulariser on every vertex (PathVertex::regState). One float today: it
// fits the vertex record's tail padding (the record stays 144 bytes). A regulariser that needs
// more (JG19's 2D diffusion) widens it here.
struct SubpathState {
    float accumulated = 0.f;
};

// The vertices of the technique that connect, emitterHit or merge evaluates.
struct Technique {
    const PathVertex* y = nullptr;  // light subpath y[0..s-1] (none for s = 0, or a merge's fast form)
    int s = 0;
    const PathVertex* z = nullptr;  // camera subpath z[0..t-1]
    int t = 0;
    const Photon* photon = nullptr;  // a merge: the light vertex y[i] merged at z[t-1] (s = i + 1)
};

// The two ends of a technique's connection.
enum class End { Light, Camera };

namespace reg {

// No regularisation: the reference implementation of the interface above.
struct None {
    // (1) The context at the technique's connection vertex at `end`.
    const BsdfContext& context(const Technique&, End end) const {
        return end == End::Light ? kImportanceContext : kRadianceContext;
    }
    // (2) No per-technique densities: the MIS compares the unregularised densities.
    static constexpr bool kPerTechnique = false;
    void densities(const Technique&, PathPdfs&) const {}
    // (3) No per-subpath state.
    void start(PathVertex&) const {}
    void extend(PathVertex&, const PathVertex&) const {}
};
// The unregularised policy as a value, for callers that pass it directly (the tests).
inline constexpr None kNone{};

}  // namespace reg

}  // namespace lt
