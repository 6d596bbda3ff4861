#include "integrators/transport/path_templates.h"

namespace lt {

// The unregularised instantiations of the templates of path_templates.h; each regulariser
// compiles its own in its own file (jg19.cpp): in one unit, two instantiations of the walk made
// GCC stop inlining the BSDF sampling into the unregularised one (+1.6% instructions, VCM).
LT_INSTANTIATE_TRANSPORT(reg::None)

namespace {

using detail::remapDensity;  // (path_inline.h, with the closed form misSumPathTracer)

// sum over all techniques k able to sample the path of (n_k p_k / p_VC(base))^2. `scaled`: each
// technique's density times its per-technique factor (PathPdfs::perTechnique; a technique with
// factor 0 does not count); unscaled, the
// factors below are the constant 1 and fold away. The sum is relative to the base's unscaled
// density: the weights below multiply by the base's own factor. (Out of line, both: inlined into
// misSum, the scaled one made the VCM probe's instruction count +0.01% worse.)
template <bool scaled>
[[gnu::noinline]] double sumOverTechniques(const PathPdfs& pdfs, int base, const MisConfig& cfg) {
    const int n = pdfs.n;
    auto connectionScale = [&](int k) { return scaled ? double(pdfs.connectionScale[k]) : 1.0; };
    auto mergeScale = [&](int k) { return scaled ? double(pdfs.mergeScale[k]) : 1.0; };
    auto validVC = [&](int k) {
        if (!allowsTechnique(cfg.set, k, n - k)) return false;
        if (k == 0) return pdfs.lightHittable && (!scaled || pdfs.connectionScale[0] > 0.f);
        if (k == n) return false;  // pinhole camera
        return !pdfs.delta[k - 1] && !pdfs.delta[k] && (!scaled || pdfs.connectionScale[k] > 0.f);
    };
    auto validVM = [&](int i) {
        return cfg.merging && i >= 1 && i <= n - 2 && !pdfs.delta[i] && (!scaled || pdfs.mergeScale[i] > 0.f);
    };
    const double vm = double(cfg.mergeArea) * double(cfg.lightPaths);
    // The range of k in which a technique may be valid, to stop the ratio chains early.
    int kMin = 0, kMax = n;
    switch (cfg.set) {
        case TechniqueSet::PathTracer: kMax = 1; break;
        case TechniqueSet::LightTracer: kMin = kMax = n - 1; break;
        case TechniqueSet::None: kMin = n; kMax = 0; break;
        case TechniqueSet::Bidirectional: break;
    }
    if (cfg.merging) kMin = std::min(kMin, 1), kMax = std::max(kMax, n - 2);
    double sum = 0.0;
    // ratio = p_VC(k) / p_VC(base); p_VC(k) / p_VC(k-1) = pL[k-1] / pC[k-1].
    double r = 1.0;
    for (int k = base; k <= std::max(kMax, base); ++k) {
        if (k > base) r *= remapDensity(pdfs.fromLight[k - 1]) / remapDensity(pdfs.fromCamera[k - 1]);
        if (k == base + 2 && pdfs.aboveBase >= 0.0) {
            sum += r * r * pdfs.aboveBase;
            break;
        }
        if (validVC(k)) {
            const double rk = r * connectionScale(k);
            sum += rk * rk;
        }
        if (k < n && validVM(k)) {
            double q = r * vm * remapDensity(pdfs.fromLight[k]) * mergeScale(k);
            sum += q * q;
        }
    }
    if (pdfs.belowBase >= 0.0) return sum + pdfs.belowBase;
    r = 1.0;
    for (int k = base - 1; k >= std::min(kMin, base); --k) {
        r *= remapDensity(pdfs.fromCamera[k]) / remapDensity(pdfs.fromLight[k]);
        if (validVC(k)) {
            const double rk = r * connectionScale(k);
            sum += rk * rk;
        }
        if (validVM(k)) {
            double q = r * vm * remapDensity(pdfs.fromLight[k]) * mergeScale(k);
            sum += q * q;
        }
    }
    return sum;
}

// The plain sum for BPT's and VCM's technique set (TechniqueSet::Bidirectional, without and with
// merging): the loops of sumOverTechniques with what they test written out for that set, the same
// operations in the same order, so the same double (tests/test_bidirectional.cpp compares them bit
// for bit); about half the instructions (BPT on SmallVCM's point-light box: 80M instead of 156M, 4
// spp at 128^2). vm = mergeArea x lightPaths. `scaled` as for sumOverTechniques: each technique's
// density times its factor, a factor of 0 not counted (a regularised path's, regularizer.h (2)).
template <bool merging, bool scaled>
double sumBidirectional(const PathPdfs& pdfs, int base, double vm) {
    const int n = pdfs.n;
    auto connectionScale = [&](int k) { return scaled ? double(pdfs.connectionScale[k]) : 1.0; };
    auto mergeScale = [&](int k) { return scaled ? double(pdfs.mergeScale[k]) : 1.0; };
    // (0 <= k < n: every technique with a camera vertex; k = n, the pinhole, never counts)
    auto validVC = [&](int k) {
        if (scaled && !(pdfs.connectionScale[k] > 0.f)) return false;
        return k == 0 ? pdfs.lightHittable : !pdfs.delta[k - 1] && !pdfs.delta[k];
    };
    auto validVM = [&](int i) {
        return merging && i >= 1 && i <= n - 2 && !pdfs.delta[i] && (!scaled || pdfs.mergeScale[i] > 0.f);
    };
    auto addConnection = [&](double& sum, double r, int k) {
        const double rk = r * connectionScale(k);
        sum += rk * rk;
    };
    double sum = 0.0, r = 1.0;
    // (up to k = n with merging only, where the camera side's precomputed sum may start)
    for (int k = base; k <= (merging ? n : n - 1); ++k) {
        if (k > base) r *= remapDensity(pdfs.fromLight[k - 1]) / remapDensity(pdfs.fromCamera[k - 1]);
        if (merging && k == base + 2 && pdfs.aboveBase >= 0.0) {
            sum += r * r * pdfs.aboveBase;
            break;
        }
        if (k == n) break;
        if (validVC(k)) addConnection(sum, r, k);
        if (validVM(k)) {
            const double q = r * vm * remapDensity(pdfs.fromLight[k]) * mergeScale(k);
            sum += q * q;
        }
    }
    if (merging && pdfs.belowBase >= 0.0) return sum + pdfs.belowBase;
    r = 1.0;
    for (int k = base - 1; k >= 0; --k) {
        r *= remapDensity(pdfs.fromCamera[k]) / remapDensity(pdfs.fromLight[k]);
        if (validVC(k)) addConnection(sum, r, k);
        if (validVM(k)) {
            const double q = r * vm * remapDensity(pdfs.fromLight[k]) * mergeScale(k);
            sum += q * q;
        }
    }
    return sum;
}

// The plain sum, with the per-technique factors when the path has them.
double misSumGeneral(const PathPdfs& pdfs, int base, const MisConfig& cfg) {
    return pdfs.perTechnique ? sumOverTechniques<true>(pdfs, base, cfg) : sumOverTechniques<false>(pdfs, base, cfg);
}

// The plain sum, or the path tracer's closed form (unscaled paths only), or BPT's and VCM's loops.
double misSum(const PathPdfs& pdfs, int base, const MisConfig& cfg) {
    const bool noPrecomputed = pdfs.belowBase < 0.0 && pdfs.aboveBase < 0.0;
    if (cfg.set == TechniqueSet::Bidirectional) {
        if (cfg.merging) {
            const double vm = double(cfg.mergeArea) * double(cfg.lightPaths);
            return pdfs.perTechnique ? sumBidirectional<true, true>(pdfs, base, vm)
                                     : sumBidirectional<true, false>(pdfs, base, vm);
        }
        if (noPrecomputed)
            return pdfs.perTechnique ? sumBidirectional<false, true>(pdfs, base, 0.0)
                                     : sumBidirectional<false, false>(pdfs, base, 0.0);
    }
    if (pdfs.perTechnique) return sumOverTechniques<true>(pdfs, base, cfg);
    if (cfg.set == TechniqueSet::PathTracer && !cfg.merging && base <= 1 && noPrecomputed) {
        const detail::MisFraction f = detail::misSumPathTracer(pdfs, base);
        return f.den / f.num;
    }
    return sumOverTechniques<false>(pdfs, base, cfg);
}

// The weight of connection technique s from the sum (relative to its unscaled density).
float connectionWeight(const PathPdfs& pdfs, int s, double sum) {
    if (!(sum > 0.0)) return 0.f;
    if (!pdfs.perTechnique) return float(1.0 / sum);
    const double own = pdfs.connectionScale[s];
    return float(own * own / sum);
}

}  // namespace

float misWeightGeneral(const PathPdfs& pdfs, int s, const MisConfig& cfg) {
    return connectionWeight(pdfs, s, misSumGeneral(pdfs, s, cfg));
}

double lightPrefixSum(const VertexPdfs* y, int m, bool lightHittable, const MisConfig& cfg, double prev) {
    // Technique k = m (light vertices y[0..m-1], camera side from y[m]) and the merge at y[m].
    double own = 0.0;
    if (m == 0) own = lightHittable ? 1.0 : 0.0;
    else if (!y[m - 1].delta && !y[m].delta) own = 1.0;
    if (cfg.merging && m >= 1 && !y[m].delta) {
        double q = double(cfg.mergeArea) * double(cfg.lightPaths) * remapDensity(y[m].fromLight);
        own += q * q;
    }
    if (m == 0) return own;
    // (y[m-1]'s fromCamera with the roulette at y[m]: rrDepth 1, see path.h)
    double ratio = remapDensity(y[m - 1].fromCamera * y[m].continuation) / remapDensity(y[m - 1].fromLight);
    return own + ratio * ratio * prev;
}

double cameraPrefixSum(const PathVertex* z, int m, const MisConfig& cfg, double prev) {
    // Technique with camera side z[0..m] (t' = m + 1; its light side ends at z[m+1]'s position),
    // and the merge at z[m] (not at the camera).
    // (z[m]'s fromLight with the roulette at z[m+1]: rrDepth 1, see path.h)
    const double fromLight = remapDensity(z[m].fromLight.value * survival(z[m + 1], 1, 1));
    double own = allowsTechnique(cfg.set, 1, m + 1) && !z[m + 1].delta && !z[m].delta ? 1.0 : 0.0;
    if (cfg.merging && m >= 1 && !z[m].delta) {
        double q = double(cfg.mergeArea) * double(cfg.lightPaths) * fromLight;
        own += q * q;
    }
    double ratio = fromLight / remapDensity(z[m].fromCamera.value);
    return own + ratio * ratio * prev;
}

float misWeight(const PathPdfs& pdfs, int s, const MisConfig& cfg) {
    return connectionWeight(pdfs, s, misSum(pdfs, s, cfg));
}

namespace {

float mergeWeight(const PathPdfs& pdfs, int i, const MisConfig& cfg, double sum) {
    double own = double(cfg.mergeArea) * double(cfg.lightPaths) * remapDensity(pdfs.fromLight[i]);
    if (pdfs.perTechnique) own *= double(pdfs.mergeScale[i]);
    return sum > 0.0 ? float(own * own / sum) : 0.f;
}

}  // namespace

float misWeightMerge(const PathPdfs& pdfs, int i, const MisConfig& cfg) {
    return mergeWeight(pdfs, i, cfg, misSum(pdfs, i, cfg));
}

float misWeightMergeGeneral(const PathPdfs& pdfs, int i, const MisConfig& cfg) {
    return mergeWeight(pdfs, i, cfg, misSumGeneral(pdfs, i, cfg));
}

bool samplableUnregularised(const Technique& tech, TechniqueSet set, bool merging) {
    const int s = tech.s, n = s + tech.t;
    auto vertex = [&](int j) -> const PathVertex& { return j < s ? tech.y[j] : tech.z[n - 1 - j]; };
    if (allowsTechnique(set, 0, n) && tech.y[0].light && tech.y[0].light->isHittable()) return true;
    for (int k = 1; k < n; ++k)
        if (allowsTechnique(set, k, n - k) && plainConnectionEnd(vertex(k - 1)) && plainConnectionEnd(vertex(k)))
            return true;
    for (int i = 1; merging && i + 1 < n; ++i)
        if (plainConnectionEnd(vertex(i))) return true;
    return false;
}

}  // namespace lt
