#include "integrators/transport/path.h"
#include "integrators/transport/light_paths.h"

namespace lt {

// A walk's own density of a vertex (`fwd`: fromCamera for a camera walk, fromLight for a light
// walk) and the one of the walk in the other direction (`rev`), as member pointers chosen once
// per walk. (Measured against a walk templated on the mode: that one made GCC stop inlining the
// BSDF sampling and the re-evaluation, +0.7% instructions on the VCM probe; these cost +0.09%.)
using VertexDensity = AreaPdf PathVertex::*;

// MIS densities must be functions of the path's vertices alone: the sampled ray left from an
// offset origin, so the densities of the segment path[i-1] -> path[i] are re-evaluated with the
// direction between the two vertex positions (the solid-angle pdfFwd that gives the walk's own
// density of path[i], and the reverse density of path[i-2]). Keeps the sampled values where the
// re-evaluation gives zero (grazing directions).
static void refreshPdfs(const Scene& scene, PathVertex* path, int i, const BsdfContext& ctx, VertexDensity rev,
                        SolidAnglePdf& pdfFwd) {
    const PathVertex& prev = path[i - 1];
    const Vec3 d = -path[i].wo;
    switch (prev.kind) {
        case VertexKind::Surface:
            if (!prev.delta && prev.bxdf) {
                BsdfEval e = prev.bsdf().eval(prev.wo, d, ctx);
                if (e.pdfFwd.value > 0.f) pdfFwd = e.pdfFwd;
                if (i >= 2 && e.pdfRev.value > 0.f)
                    path[i - 2].*rev = convertDensity(e.pdfRev, path[i - 2], prev.wo, sqr(prev.segmentLength));
            }
            break;
        case VertexKind::Camera: {
            SolidAnglePdf p = scene.camera().directionPdf(d);
            if (p.value > 0.f) pdfFwd = p;
            break;
        }
        case VertexKind::Light:
            if (!prev.infinite) {
                SolidAnglePdf p = prev.light->pdfLeDir(prev.ng, d);
                if (p.value > 0.f) pdfFwd = p;
            }
            break;
    }
}

int randomWalk(const Scene& scene, Ray ray, Color beta, SolidAnglePdf pdfDir, Rng& rng, TransportMode mode,
               int maxVertices, int rrDepth, PathVertex* path, WalkStats& stats, WalkPdfs pdfs) {
    constexpr float kNotComputed = std::numeric_limits<float>::quiet_NaN();
    const bool allPdfs = pdfs == WalkPdfs::All;
    const BsdfContext& ctx = plainContext(mode);  // the walks sample and evaluate the materials' own BSDFs
    const bool cameraWalk = mode == TransportMode::Radiance;  // a camera walk samples from the camera side
    const VertexDensity fwd = cameraWalk ? &PathVertex::fromCamera : &PathVertex::fromLight;
    const VertexDensity rev = cameraWalk ? &PathVertex::fromLight : &PathVertex::fromCamera;
    int n = 1;
    SolidAnglePdf pdfFwd = pdfDir;
    while (n < maxVertices) {
        PathVertex& prev = path[n - 1];
        PathVertex& v = path[n];
        ++stats.rays;
        if (stats.log) stats.log->addClosest(ray, prev.depth);
        if (!scene.intersect(ray, v)) {  // fills the SurfacePoint fields of v
            if (cameraWalk && !scene.infiniteLights().empty()) {
                // A vertex at infinity (its density stays in solid angle: see convertDensity).
                const Vec3 far = ray.o + ray.d * (2.f * scene.boundsRadius());
                v.setPoint(far, Vec3(0.f), scene.infiniteLights().front(), 1.f);
                v.init(VertexKind::Surface, &prev, -ray.d, kInf, beta, AreaPdf(0.f), AreaPdf(pdfFwd.value), true);
                ++n;
            }
            break;
        }
        // The record (the densities are not known yet: the reverse one when the walk continues,
        // the walk's own one after the re-evaluation below).
        Vec3 back = prev.p - v.p;
        float backLen = glm::length(back);
        const Vec3 wo = backLen > 0.f ? back * (1.f / backLen) : -ray.d;  // the direction the two vertices define
        const AreaPdf unfilled(allPdfs ? 0.f : kNotComputed);
        v.init(VertexKind::Surface, &prev, wo, backLen, beta, unfilled, unfilled);
        if (allPdfs || v.light) {
            refreshPdfs(scene, path, n, ctx, rev, pdfFwd);
            v.*fwd = convertDensity(pdfFwd, v, v.wo, sqr(backLen));
        }
        ++n;
        if (n >= maxVertices || !v.bxdf) break;

        BsdfSample bs;
        float uLobe = rng.uniform();
        Vec2 u = rng.uniform2();
        if (!v.bsdf().sample(v.wo, uLobe, u, ctx, bs) || isBlack(bs.weight)) break;
        v.lobe = bs.lobe;
        SolidAnglePdf pdfRev = bs.pdfRev;
        pdfFwd = bs.pdfFwd;
        if (bs.lobe & kDelta) {
            // No technique connects here (the MIS routine skips them), but the techniques on
            // either side of v compare densities that cross it: the generalised densities of
            // path.h ("Delta vertices"), the lobe's probability times |cos| on the outgoing side
            // times eta^2 of the crossing, in place of the Dirac delta in projected solid angle.
            v.delta = true;
            const float cosWi = std::abs(glm::dot(v.shading.n, bs.wi));
            const float cosWo = std::abs(glm::dot(v.shading.n, v.wo));
            pdfFwd = SolidAnglePdf(bs.pdfFwd.value * cosWi * (bs.eta * bs.eta));
            pdfRev = SolidAnglePdf(bs.pdfRev.value * cosWo);
        }
        if (allPdfs) prev.*rev = convertDensity(pdfRev, prev, v.wo, sqr(v.segmentLength));
        beta *= bs.weight;
        if (v.depth >= rrDepth) {
            float q = std::min(0.95f, maxComp(beta));
            if (!(rng.uniform() < q)) break;
            beta /= q;
        }
        ray = scene.spawnRay(v.p, v.ng, bs.wi);
    }
    return n;
}

// In place (no temporary vertex to build and copy: once per camera sample). beta = We cos /
// (pdfPos pdfDir) = 1 for a pinhole sampled by raster position; fromCamera = 1: the pinhole
// position is a delta.
static void setCameraEndpoint(const Scene& scene, PathVertex& c) {
    c.setPoint(scene.camera().position(), Vec3(0.f), nullptr, 0.f);
    c.init(VertexKind::Camera, nullptr, Vec3(0.f), 0.f, Color(1.f), AreaPdf(0.f), AreaPdf(1.f));
}

PathVertex cameraEndpoint(const Scene& scene) {
    PathVertex c;
    setCameraEndpoint(scene, c);
    return c;
}

int cameraWalk(const Scene& scene, const Vec2& raster, Rng& rng, int maxVertices, int rrDepth, PathVertex* path,
               WalkStats& stats, WalkPdfs pdfs) {
    SolidAnglePdf pdfDir;
    const Ray ray = scene.camera().generateRay(raster, pdfDir);
    setCameraEndpoint(scene, path[0]);
    if (maxVertices <= 1) return 1;
    return randomWalk(scene, ray, Color(1.f), pdfDir, rng, TransportMode::Radiance, maxVertices, rrDepth, path,
                      stats, pdfs);
}

int lightWalk(const Scene& scene, Rng& rng, int maxVertices, int rrDepth, PathVertex* path, WalkStats& stats) {
    if (scene.lights().empty() || maxVertices < 1) return 0;
    float uSel = rng.uniform();
    Vec2 uPos = rng.uniform2(), uDir = rng.uniform2();
    size_t li = scene.lightDistribution().sample(uSel);
    const Light& l = scene.lights()[li];
    float sel = scene.lightDistribution().probability(li);
    LightSampleLe le = l.sampleLe(scene, uPos, uDir);
    if (!(sel > 0.f) || !(le.pdfPos.value > 0.f) || !(le.pdfDir.value > 0.f) || isBlack(le.value)) return 0;
    // The endpoint's density is in the measure NEE uses: area for finite lights, the emission
    // direction's solid angle for lights at infinity (their position lives on the scene's disk).
    // Its beta leaves out the light's value, which is applied at connections.
    PathVertex& y0 = path[0];
    y0.setPoint(le.p, l.type == LightType::Area ? le.n : Vec3(0.f), &l, 1.f);
    y0.init(VertexKind::Light, nullptr, Vec3(0.f), 0.f, Color(1.f / (sel * le.pdfPos.value)),
            AreaPdf(sel * (l.isInfinite() ? le.pdfDir.value : le.pdfPos.value)), AreaPdf(0.f), l.isInfinite());
    if (maxVertices == 1) return 1;
    float cosL = l.type == LightType::Area ? std::abs(glm::dot(le.n, le.dir)) : 1.f;
    Color beta = le.value * cosL / (sel * le.pdfPos.value * le.pdfDir.value);
    Ray ray = l.type == LightType::Area ? scene.spawnRay(le.p, le.n, le.dir) : Ray{le.p, le.dir};
    int n = randomWalk(scene, ray, beta, le.pdfDir, rng, TransportMode::Importance, maxVertices, rrDepth, path, stats);
    if (y0.infinite && n > 1) {
        // A ray from the scene's disk: the first hit's density is the disk's, projected.
        path[1].fromLight = AreaPdf(le.pdfPos.value * std::abs(glm::dot(path[1].ng, le.dir)));
        path[1].segmentLength = 0.f;
        path[1].pathLength = 0.f;
    }
    return n;
}

namespace {

using detail::remapDensity;  // (path_inline.h, with the closed form misSumPathTracer)

// sum over all techniques k able to sample the path of (n_k p_k / p_VC(base))^2.
double misSumGeneral(const PathPdfs& pdfs, int base, const MisConfig& cfg) {
    const int n = pdfs.n;
    auto validVC = [&](int k) {
        if (!allowsTechnique(cfg.set, k, n - k)) return false;
        if (k == 0) return pdfs.lightHittable;
        if (k == n) return false;  // pinhole camera
        return !pdfs.delta[k - 1] && !pdfs.delta[k];
    };
    auto validVM = [&](int i) { return cfg.merging && i >= 1 && i <= n - 2 && !pdfs.delta[i]; };
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
        if (validVC(k)) sum += r * r;
        if (k < n && validVM(k)) {
            double q = r * vm * remapDensity(pdfs.fromLight[k]);
            sum += q * q;
        }
    }
    if (pdfs.belowBase >= 0.0) return sum + pdfs.belowBase;
    r = 1.0;
    for (int k = base - 1; k >= std::min(kMin, base); --k) {
        r *= remapDensity(pdfs.fromCamera[k]) / remapDensity(pdfs.fromLight[k]);
        if (validVC(k)) sum += r * r;
        if (validVM(k)) {
            double q = r * vm * remapDensity(pdfs.fromLight[k]);
            sum += q * q;
        }
    }
    return sum;
}

double misSum(const PathPdfs& pdfs, int base, const MisConfig& cfg) {
    if (cfg.set == TechniqueSet::PathTracer && !cfg.merging && base <= 1 && pdfs.belowBase < 0.0 &&
        pdfs.aboveBase < 0.0) {
        const detail::MisFraction f = detail::misSumPathTracer(pdfs, base);
        return f.den / f.num;
    }
    return misSumGeneral(pdfs, base, cfg);
}

}  // namespace

float misWeightGeneral(const PathPdfs& pdfs, int s, const MisConfig& cfg) {
    double sum = misSumGeneral(pdfs, s, cfg);
    return sum > 0.0 ? float(1.0 / sum) : 0.f;
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
    double ratio = remapDensity(y[m - 1].fromCamera) / remapDensity(y[m - 1].fromLight);
    return own + ratio * ratio * prev;
}

double cameraPrefixSum(const PathVertex* z, int m, const MisConfig& cfg, double prev) {
    // Technique with camera side z[0..m] (t' = m + 1; its light side ends at z[m+1]'s position),
    // and the merge at z[m] (not at the camera).
    double own = allowsTechnique(cfg.set, 1, m + 1) && !z[m + 1].delta && !z[m].delta ? 1.0 : 0.0;
    if (cfg.merging && m >= 1 && !z[m].delta) {
        double q = double(cfg.mergeArea) * double(cfg.lightPaths) * remapDensity(z[m].fromLight.value);
        own += q * q;
    }
    double ratio = remapDensity(z[m].fromLight.value) / remapDensity(z[m].fromCamera.value);
    return own + ratio * ratio * prev;
}

float misWeight(const PathPdfs& pdfs, int s, const MisConfig& cfg) {
    double sum = misSum(pdfs, s, cfg);
    return sum > 0.0 ? float(1.0 / sum) : 0.f;
}

float misWeightMerge(const PathPdfs& pdfs, int i, const MisConfig& cfg) {
    double own = double(cfg.mergeArea) * double(cfg.lightPaths) * remapDensity(pdfs.fromLight[i]);
    double sum = misSum(pdfs, i, cfg);
    return sum > 0.0 ? float(own * own / sum) : 0.f;
}

Color emitterHit(const Scene& scene, const PathVertex* z, int t, PathPdfs& pdfs, int readLimit) {
    const PathVertex& v = z[t - 1];
    if (!v.light || t < 2) return Color(0.f);
    Color Le = v.light->Le(v.ng, v.wo);
    if (isBlack(Le)) return Color(0.f);
    gatherCameraPdfs(z, t, 0, pdfs, readLimit);
    pdfs.belowBase = pdfs.aboveBase = -1.0;
    float sel = scene.lightSelectionProb(v.light);
    pdfs.fromLight[0] = sel * v.light->pdfLi(scene, z[t - 2].p, v.p, v.ng, -v.wo).value;
    pdfs.delta[0] = false;
    pdfs.lightHittable = true;
    // light travels along v.wo, over the segment that arrived at v
    if (readLimit >= 1) pdfs.fromLight[1] = detail::emissionDensity(scene, v, v.wo, z[t - 2], sqr(v.segmentLength)).value;
    return v.beta * Le;
}

bool merge(const Photon& ph, const VertexPdfs* lightPdfs, const PathVertex* z, int t, Connection& c,
           const double* cameraSums) {
    const int i = ph.depth;
    const PathVertex& zv = z[t - 1];
    if (i < 1 || t < 2 || !zv.connectible() || zv.infinite) return false;
    if (glm::dot(ph.ng, zv.ng) <= 0.f) return false;  // the photon lies on the other side
    BsdfEval ez = zv.bsdf().eval(zv.wo, ph.wo, kRadianceContext);
    if (isBlack(ez.f)) return false;
    c.contribution = zv.beta * ez.f * ph.beta;
    // Full path: x_0..x_i from the light subpath (x_i at the camera vertex), then z[t-2]..z[0].
    PathPdfs& P = c.pdfs;
    P.belowBase = -1.0;
    P.aboveBase = cameraSums ? (t >= 3 ? cameraSums[t - 3] : 0.0) : -1.0;
    if (lightPdfs) {
        for (int k = 0; k <= i; ++k) {
            P.fromLight[k] = lightPdfs[k].fromLight;
            P.fromCamera[k] = lightPdfs[k].fromCamera;
            P.delta[k] = lightPdfs[k].delta;
        }
    } else {
        P.fromLight[i - 1] = ph.prevFromLight;
        P.delta[i - 1] = ph.prevDelta != 0;
    }
    P.lightHittable = ph.lightHittable != 0;
    gatherCameraPdfs(z, t, i, P, cameraSums ? i + 1 : kMaxPathVertices);
    P.fromLight[i] = ph.fromLight;
    P.delta[i] = false;
    // Camera walk continuing from the merge vertex to y[i-1].
    if (ph.prevInfinite) {
        P.fromCamera[i - 1] = ez.pdfFwd.value;
    } else {
        Vec3 d = ph.prevP - zv.p;
        float d2 = glm::dot(d, d);
        float cosPrev = ph.prevNg != Vec3(0.f) ? std::abs(glm::dot(ph.prevNg, d)) / std::sqrt(d2) : 1.f;
        P.fromCamera[i - 1] = d2 > 0.f ? ez.pdfFwd.value * cosPrev / d2 : 0.f;
    }
    P.fromLight[i + 1] = convertDensity(ez.pdfRev, z[t - 2], zv.wo, sqr(zv.segmentLength)).value;
    if (!lightPdfs) {
        double ratio = remapDensity(P.fromCamera[i - 1]) / remapDensity(P.fromLight[i - 1]);
        P.belowBase = ratio * ratio * ph.misLight;
    }
    return true;
}

}  // namespace lt
