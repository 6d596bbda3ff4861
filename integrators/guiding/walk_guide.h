// What the camera walk asks of path guiding (integrators/transport/path_templates.h): at each
// surface vertex, whether it is guided, and there the one-sample mixture of BSDF sampling and the
// SD-tree's directional density (Rath et al. 2020 Eq. 22):
//   p_mix(wi) = alpha p_bsdf(wi) + (1 - alpha) p_guide(wi),
// alpha the BSDF fraction of the vertex's spatial leaf. The walk stores p_mix as the vertex's
// sampling density, so every MIS weight that reads the walk's density reads the mixture's. Three
// densities, three names: bsdf, guide, mixture.
#pragma once
#include <array>
#include "integrators/guiding/sd_tree.h"

namespace lt::guiding {

inline constexpr int kMaxWalkVertices = 66;  // = kMaxPathVertices (static_assert in path_templates.h)

// Lobes smoother than this are left to BSDF sampling (a piecewise-constant quadtree cannot
// represent them; Cycles guides from 0.05, Open PGL from 0.01); delta lobes are never guided.
inline constexpr float kMinGuidedRoughness = 0.05f;

// One per camera walk (per tile and thread), over a tree that no one writes during the pass.
struct WalkGuide {
    const SDTree* tree = nullptr;
    bool learnedFraction = false;  // alpha from the leaf (its samplingFraction, learned), else `fixedFraction`
    float fixedFraction = 0.5f;
    // Per walk vertex index, written where the walk sampled there: the leaf of a vertex guiding
    // applies to (null: a delta or too smooth lobe), whether it was guided (its leaf had learned
    // something), its alpha, and the BSDF's and the guide's densities of the sampled direction
    // (the training records read them; untrained: the uniform 1 / (4 pi)).
    std::array<const GuideLeaf*, kMaxWalkVertices> leaf{};
    std::array<bool, kMaxWalkVertices> active{};
    std::array<float, kMaxWalkVertices> alpha{}, pdfBsdf{}, pdfGuide{};

    // Decides for vertex i at p (roughness and deltaBsdf as the vertex caches them).
    bool decide(int i, const Vec3& p, float roughness, bool deltaBsdf) {
        leaf[i] = nullptr;
        active[i] = false;
        if (deltaBsdf || roughness < kMinGuidedRoughness) return false;
        const GuideLeaf& l = tree->leaf(p);
        leaf[i] = &l;
        if (!l.sampling.trained()) return false;
        active[i] = true;
        alpha[i] = learnedFraction ? l.samplingFraction : fixedFraction;
        return true;
    }
    bool guided(int i) const { return active[i]; }
    // The mixture's density at guided vertex i from the BSDF's and the guide's.
    float mix(int i, float pdfBsdf, float pdfGuide) const { return alpha[i] * pdfBsdf + (1.f - alpha[i]) * pdfGuide; }
    // The mixture's density of d at guided vertex i from the BSDF's, both times the roulette's
    // factor `cont` there (survival, path.h; the BSDF's comes with it).
    float mixture(int i, float bsdfPdfCont, const Vec3& d, float cont) const {
        return mix(i, bsdfPdfCont, cont * leaf[i]->sampling.pdf(d).value);
    }
};

}  // namespace lt::guiding
