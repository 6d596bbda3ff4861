// JG19: microfacet model regularisation (Jendersie and Grosch 2019, "Microfacet model
// regularization for robust light transport"), as a policy of the regulariser seam
// (regularizer.h). Paper: ../shared/papers/jg19-microfacet-model-regularization.txt.
//
// (1) Values. At a technique's own connection ends (and at the camera vertex of a merge) every
//     microfacet lobe is evaluated with alpha' = max(alpha, alpha_hat(tau_n)) per axis,
//     alpha_hat = rho_bar^-1 (Eqs. 1, 8-9; bsdf/roughness_bound.h), resolved by the lobe with its
//     own distribution, masking and eta (MicrofacetLobe::resolve). Smooth conductors and
//     dielectrics become rough GGX lobes there, so a connection may end on them (connectible).
//     The walks sample and evaluate the materials' own BSDFs (Sec. 3). tau_n: Eq. 16 with n the
//     iteration (consistent schedule) or tau_0 throughout (fixed).
// (2) MIS (Sec. 3.3, Eq. 13). Technique k's density is p_hat_k = p_k prod_{x in C_k} rho_hat(x) /
//     rho(x), C_k its connection ends (the merge at x_i: {x_i}). rho_hat / rho of a vertex is the
//     same pair of directions in every technique that connects there (its two path neighbours),
//     so it is computed once per vertex: by the walk when it extends past the vertex
//     (SubpathState::ratio), by connect and merge at their own ends (Technique::ratioLight,
//     ratioCamera). The ratio is exact (both BSDFs evaluated), which is what the paper's
//     evaluation of the pdf with alpha_hat plus the Smith G ratio approximates.
//     Singular vertices: where rho is a delta (or 0) the ratio is +inf. A path that a technique
//     sampled through the delta is exactly specular there, and a technique regularising that
//     vertex has a finite value where the sampled one has a delta: its weight is 0. A path that a
//     technique regularised at a delta vertex is not specular there (almost surely), and no
//     technique sampling through it can produce it. So the techniques competing for a path are
//     those whose connection ends contain exactly the base's singular vertices; between them the
//     common rho_hat cancels (one tau per iteration).
//     MisDensities::Sampling (--reg-mis sampling) keeps the sampling densities p_k (JG19 Fig. 3a:
//     the naive weights), with the same rule for singular vertices.
// Not yet here (issue 13): the quality and diffusion heuristics (Eqs. 17-21), merges on delta
// surfaces (photons are stored on non-delta surfaces only).
#pragma once
#include <cstdint>
#include "integrators/transport/path.h"

namespace lt::reg {

enum class Schedule { Consistent, Fixed };
enum class MisDensities { Regularised, Sampling };

struct Jg19Settings {
    double tau0 = 30.0;  // > 1 / (2 pi)
    Schedule schedule = Schedule::Consistent;
    MisDensities mis = MisDensities::Regularised;
};

class Jg19 {
public:
    // Throws std::invalid_argument for tau0 <= 1 / (2 pi) or NaN.
    explicit Jg19(const Jg19Settings& settings);
    const Jg19Settings& settings() const { return settings_; }
    // tau_n for iteration n >= 1 (Eq. 16, or tau0 for the fixed schedule).
    void beginIteration(uint64_t n);
    float tau() const { return radiance_.reg.tau; }

    // (1)
    const BsdfContext& context(const Technique&, End end) const {
        return end == End::Light ? importance_ : radiance_;
    }
    // (2)
    static constexpr bool kPerTechnique = true;
    bool perTechnique(const Technique& tech) const;
    void densities(const Technique& tech, PathPdfs& pdfs) const;
    // (3) SubpathState: ratio = rho_hat / rho at the vertex (see above; 1 at endpoints and where
    // nothing changes), accumulated = the number of vertices before this one on its subpath
    // whose ratio is finite and not 1. (A singular vertex the walk passed through changes no
    // weight: every technique regularising it has factor 0, as its delta flag says anyway.)
    void start(PathVertex& v) const { v.regState = SubpathState{}; }
    void extend(PathVertex& v, PathVertex& prev) const {
        const float r = ratioAt(prev, -v.wo);
        prev.regState.ratio = r;
        v.regState.ratio = 1.f;
        v.regState.accumulated = prev.regState.accumulated + (r != 1.f && r < kInf ? 1.f : 0.f);
    }
    // (4) Any surface vertex with a BSDF that is not still a delta under tau_n.
    bool connectible(const PathVertex& v) const {
        if (v.connectible()) return true;
        return v.kind == VertexKind::Surface && !v.infinite && v.bxdf && !v.bxdf->deltaUnder(radiance_);
    }

    // rho_hat / rho of v's BSDF between v.wo and wi (1 where nothing changes, +inf where rho is a
    // delta or 0 and rho_hat is not).
    float ratioAt(const PathVertex& v, const Vec3& wi) const;

private:
    Jg19Settings settings_;
    BsdfContext radiance_{TransportMode::Radiance}, importance_{TransportMode::Importance};
};

}  // namespace lt::reg
