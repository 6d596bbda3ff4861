// Definitions of the transport routines that are templates on the regulariser policy
// (regularizer.h) and compiled out of line: the walks, the camera endpoint, emitter hits and
// merges (declared in path.h). path.cpp instantiates them for the renderer's policies; code that
// brings a policy of its own (tests) includes this file.
#pragma once
#include <stdexcept>
#include "integrators/transport/light_paths.h"
#include "integrators/transport/path.h"

namespace lt {

static_assert(guiding::kMaxWalkVertices == kMaxPathVertices);

namespace detail {

// A walk's own density of a vertex (`fwd`: fromCamera for a camera walk, fromLight for a light
// walk) and the one of the walk in the other direction (`rev`), as member pointers chosen once
// per walk. (Measured against a walk templated on the mode: that one made GCC stop inlining the
// BSDF sampling and the re-evaluation, +0.7% instructions on the VCM probe; these cost +0.09%.)
using VertexDensity = AreaPdf PathVertex::*;

// MIS densities must be functions of the path's vertices alone: the sampled ray left from an
// offset origin, so the densities of the segment path[i-1] -> path[i] are re-evaluated with the
// direction between the two vertex positions (the solid-angle pdfFwd that gives the walk's own
// density of path[i], and the reverse density of path[i-2]). Keeps the sampled values where the
// re-evaluation gives zero (grazing directions). The walk's own density carries the roulette's
// factor at prev (survival), the reverse one is stored without it (the gathers apply it).
// (A guided prev: the mixture's density, guide->mixture.)
static void refreshPdfs(const Scene& scene, PathVertex* path, int i, int rrDepth, const BsdfContext& ctx,
                        VertexDensity rev, SolidAnglePdf& pdfFwd, const guiding::WalkGuide* guide) {
    const PathVertex& prev = path[i - 1];
    const Vec3 d = -path[i].wo;
    switch (prev.kind) {
        case VertexKind::Surface:
            if (!prev.delta && prev.bxdf) {
                BsdfEval e = prev.bsdf().eval(prev.wo, d, ctx);
                const float sv = survival(prev, prev.depth, rrDepth);  // the roulette at prev
                e.pdfFwd.value *= sv;
                if (guide && guide->guided(i - 1)) e.pdfFwd = SolidAnglePdf(guide->mixture(i - 1, e.pdfFwd.value, d, sv));
                if (e.pdfFwd.value > 0.f) pdfFwd = e.pdfFwd;
                if (i >= 2 && e.pdfRev.value > 0.f)
                    path[i - 2].*rev = convertDensity(e.pdfRev, path[i - 2], prev.wo, sqr(prev.segmentLength));
            }
            break;
        case VertexKind::Camera: {
            SolidAnglePdf p = scene.camera().directionPdf(prev.p, d);  // (orthographic: 0, see cameraWalk)
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

// One sample of guided vertex v (walk index i): with probability alpha the BSDF's, else the
// guide's, and in either case the weight f |cos| / p_mix and the density p_mix of the mixture
// (Rath et al. 2020 Eq. 22; walk_guide.h). A BSDF sample of a delta lobe keeps its own weight
// and density (the guide has none there). The reverse density stays the BSDF's (a camera walk
// reads it only for BPT's MIS, which is not guided).
inline bool guidedSample(const PathVertex& v, guiding::WalkGuide& guide, int i, Rng& rng, const BsdfContext& ctx,
                         BsdfSample& bs) {
    const float alpha = guide.alpha[i];
    const float uSel = rng.uniform();
    const float uLobe = rng.uniform();
    const Vec2 u = rng.uniform2();
    const SurfaceBsdf bsdf = v.bsdf();
    if (uSel < alpha) {
        if (!bsdf.sample(v.wo, uLobe, u, ctx, bs) || isBlack(bs.weight)) return false;
        if (bs.lobe & kDelta) return true;
        guide.pdfBsdf[i] = bs.pdfFwd.value;
        guide.pdfGuide[i] = guide.leaf[i]->sampling.pdf(bs.wi).value;
        const float mix = guide.mix(i, bs.pdfFwd.value, guide.pdfGuide[i]);
        if (!(mix > 0.f)) return false;
        bs.weight *= bs.pdfFwd.value / mix;
        bs.pdfFwd = SolidAnglePdf(mix);
        return true;
    }
    SolidAnglePdf pdfGuide;
    const Vec3 wi = guide.leaf[i]->sampling.sample(u, &pdfGuide);
    const BsdfEval e = bsdf.eval(v.wo, wi, ctx);
    if (isBlack(e.f)) return false;
    guide.pdfBsdf[i] = e.pdfFwd.value;
    guide.pdfGuide[i] = pdfGuide.value;
    const float mix = guide.mix(i, e.pdfFwd.value, pdfGuide.value);
    if (!(mix > 0.f)) return false;
    bs.wi = wi;
    bs.weight = e.f * (std::abs(glm::dot(wi, v.shading.n)) / mix);
    bs.pdfFwd = SolidAnglePdf(mix);
    bs.pdfRev = e.pdfRev;
    const float cosO = glm::dot(v.wo, v.ng), cosI = glm::dot(wi, v.ng);
    bs.lobe = cosO * cosI > 0.f ? kGlossy | kReflection : kGlossy | kTransmission;
    bs.eta = 1.f;
    return true;
}

// Extends a subpath whose vertex path[0] (endpoint) is filled in, starting with `ray` whose
// direction was sampled with solid-angle density pdfDir and throughput beta (see the walks in
// path.h). `mode` says which walk it is: Radiance for camera subpaths (their own densities are
// fromCamera), Importance for light subpaths (fromLight).
template <class Reg>
int randomWalk(const Scene& scene, const Reg& reg, Ray ray, Color beta, SolidAnglePdf pdfDir, Rng& rng,
               TransportMode mode, int maxVertices, int rrDepth, PathVertex* path, WalkStats& stats,
               WalkPdfs pdfs, guiding::WalkGuide* guide = nullptr) {
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
                initAtInfinity(scene, reg, v, prev, ray, beta, pdfFwd);
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
        v.init(reg, VertexKind::Surface, &prev, wo, backLen, beta, unfilled, unfilled);
        if (allPdfs || v.light) {
            refreshPdfs(scene, path, n, rrDepth, ctx, rev, pdfFwd, guide);
            v.*fwd = convertDensity(pdfFwd, v, v.wo, sqr(backLen));
        }
        ++n;
        if (n >= maxVertices || !v.bxdf) break;

        BsdfSample bs;
        if (guide && guide->decide(n - 1, v.p, v.roughness, v.deltaBsdf)) {
            if (!guidedSample(v, *guide, n - 1, rng, ctx, bs)) break;
        } else {
            float uLobe = rng.uniform();
            Vec2 u = rng.uniform2();
            if (!v.bsdf().sample(v.wo, uLobe, u, ctx, bs) || isBlack(bs.weight)) break;
            if (guide && guide->leaf[n - 1]) {  // (a leaf that has not learned yet: for the records)
                guide->pdfBsdf[n - 1] = bs.pdfFwd.value;
                guide->pdfGuide[n - 1] = 0.25f * kInvPi;
            }
        }
        // The roulette's continuation probability is part of the walk's own density of the next
        // vertex where the roulette runs at v; the reverse density of prev is stored without it
        // ("Russian roulette", path.h).
        const float cont = v.bxdf->continuation();
        SolidAnglePdf pdfRev = bs.pdfRev;
        pdfFwd = SolidAnglePdf(bs.pdfFwd.value * survival(v, v.depth, rrDepth));
        if (bs.lobe & kDelta) {
            // No technique connects here (the MIS routine skips them), but the techniques on
            // either side of v compare densities that cross it: the generalised densities of
            // path.h ("Delta vertices"), the lobe's probability times |cos| on the outgoing side
            // times eta^2 of the crossing, in place of the Dirac delta in projected solid angle.
            v.delta = true;
            const float cosWi = std::abs(glm::dot(v.shading.n, bs.wi));
            const float cosWo = std::abs(glm::dot(v.shading.n, v.wo));
            pdfFwd = SolidAnglePdf(pdfFwd.value * cosWi * (bs.eta * bs.eta));
            pdfRev = SolidAnglePdf(pdfRev.value * cosWo);
        }
        if (allPdfs) prev.*rev = convertDensity(pdfRev, prev, v.wo, sqr(v.segmentLength));
        beta *= bs.weight;
        if (v.depth >= rrDepth && cont < 1.f) {
            if (!(rng.uniform() < cont)) break;
            beta /= cont;
        }
        ray = scene.spawnRay(v.p, v.ng, bs.wi);
    }
    return n;
}

// In place (no temporary vertex to build and copy: once per camera sample), at camera vertex
// `position` (core/camera.h: the pinhole, a lens point, a film point). beta = We cos /
// (pdfPos pdfDir) = 1 for every camera sampled by raster position; fromCamera = the camera's
// position density (1 for the pinhole: a delta), which no MIS ratio reads (no technique hits the
// camera).
template <class Reg>
void setCameraEndpoint(const Reg& reg, PathVertex& c, const Vec3& position, AreaPdf density) {
    c.setPoint(position, Vec3(0.f), nullptr, 0.f);
    c.init(reg, VertexKind::Camera, nullptr, Vec3(0.f), 0.f, Color(1.f), AreaPdf(0.f), density);
}

}  // namespace detail

template <class Reg>
PathVertex cameraEndpoint(const Scene& scene, const Reg& reg) {
    PathVertex c;
    detail::setCameraEndpoint(reg, c, scene.camera().position(), AreaPdf(scene.camera().positionDensity()));
    return c;
}

template <class Reg>
int cameraWalk(const Scene& scene, const Reg& reg, const Vec2& raster, Rng& rng, int maxVertices, int rrDepth,
               PathVertex* path, WalkStats& stats, WalkPdfs pdfs, guiding::WalkGuide* guide) {
    const Camera& cam = scene.camera();
    SolidAnglePdf pdfDir;
    if (cam.pinhole()) {
        const Ray ray = cam.generateRay(raster, pdfDir);
        detail::setCameraEndpoint(reg, path[0], cam.position(), AreaPdf(1.f));
        if (maxVertices <= 1) return 1;
        return detail::randomWalk(scene, reg, ray, Color(1.f), pdfDir, rng, TransportMode::Radiance, maxVertices,
                                  rrDepth, path, stats, pdfs, guide);
    }
    // A lens or a film: the camera vertex is the ray's (the thin lens draws its lens point after
    // the raster position; the orthographic film draws nothing).
    Vec3 origin;
    const Ray ray = cam.generateRay(raster, cam.thinLens() ? rng.uniform2() : Vec2(0.5f), pdfDir, origin);
    detail::setCameraEndpoint(reg, path[0], origin, AreaPdf(cam.positionDensity()));
    if (maxVertices <= 1) return 1;
    const int n = detail::randomWalk(scene, reg, ray, Color(1.f), pdfDir, rng, TransportMode::Radiance, maxVertices,
                                     rrDepth, path, stats, pdfs, guide);
    // Orthographic: the direction is a delta and the film point uniform, so the first hit's area
    // density is the film's projected onto it, |cos| / A_film (the mirror of a directional
    // light's first hit, lightWalk).
    if (cam.orthographic() && n > 1 && !path[1].infinite)
        path[1].fromCamera = AreaPdf(cam.filmDensity() * std::abs(glm::dot(path[1].ng, ray.d)));
    return n;
}

template <class Reg>
int lightWalk(const Scene& scene, const Reg& reg, Rng& rng, int maxVertices, int rrDepth, PathVertex* path,
              WalkStats& stats) {
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
    y0.uv = le.uv;  // (a textured area light's Le reads it)
    y0.init(reg, VertexKind::Light, nullptr, Vec3(0.f), 0.f, Color(1.f / (sel * le.pdfPos.value)),
            AreaPdf(sel * (l.isInfinite() ? le.pdfDir.value : le.pdfPos.value)), AreaPdf(0.f), l.isInfinite());
    if (maxVertices == 1) return 1;
    float cosL = l.type == LightType::Area ? std::abs(glm::dot(le.n, le.dir)) : 1.f;
    Color beta = le.value * cosL / (sel * le.pdfPos.value * le.pdfDir.value);
    Ray ray = l.type == LightType::Area ? scene.spawnRay(le.p, le.n, le.dir) : Ray{le.p, le.dir};
    int n = detail::randomWalk(scene, reg, ray, beta, le.pdfDir, rng, TransportMode::Importance, maxVertices, rrDepth,
                               path, stats, WalkPdfs::All);
    if (y0.infinite && n > 1) {
        // A ray from the scene's disk: the first hit's density is the disk's, projected.
        path[1].fromLight = AreaPdf(le.pdfPos.value * std::abs(glm::dot(path[1].ng, le.dir)));
        path[1].segmentLength = 0.f;
        path[1].pathLength = 0.f;
    }
    return n;
}

template <class Reg>
Color emitterHit(const Scene& scene, const Reg& reg, const PathVertex* z, int t, int rrDepth, PathPdfs& pdfs,
                 int readLimit, bool regularisedSample) {
    const PathVertex& v = z[t - 1];
    if (!v.light || t < 2) return Color(0.f);
    Color Le = v.light->Le(v.ng, v.wo, v.uv);
    if (isBlack(Le)) return Color(0.f);
    Technique tech{nullptr, 0, z, t};
    tech.regularisedSample = regularisedSample;
    if (!reg.select(tech)) return Color(0.f);  // regularizer.h (5)
    gatherCameraPdfs(z, t, 0, rrDepth, pdfs, readLimit);
    pdfs.belowBase = pdfs.aboveBase = -1.0;
    float sel = scene.lightSelectionProb(v.light);
    pdfs.fromLight[0] = sel * v.light->pdfLi(scene, z[t - 2].p, v.p, v.ng, -v.wo).value;
    // A light at infinity seen straight from the camera (t = 2): no technique joins the two (connect
    // refuses a light at infinity as the camera's partner), so x_0 is marked as no connection's end
    // (the emitter hit is the path's only technique).
    pdfs.delta[0] = t == 2 && v.infinite;
    pdfs.lightHittable = true;
    // light travels along v.wo, over the segment that arrived at v
    if (readLimit >= 1)
        pdfs.fromLight[1] = detail::emissionDensity(scene, v, v.wo, z[t - 2], sqr(v.segmentLength)).value;
    detail::techniqueDensities(reg, tech, pdfs, detail::needsPerTechnique(reg, tech));
    return v.beta * Le * tech.hitRatio;  // (regularizer.h (6): 1 but for a regulariser's walk sample)
}

template <class Reg>
bool merge(const Reg& reg, const Photon& ph, const PathVertex* y, const VertexPdfs* lightPdfs, const PathVertex* z,
           int t, int rrDepth, Connection& c, const double* cameraSums) {
    const int i = ph.depth;
    const PathVertex& zv = z[t - 1];
    if (i < 1 || t < 2 || !reg.mergeable(zv) || zv.infinite) return false;
    if (glm::dot(ph.ng, zv.ng) <= 0.f) return false;  // the photon lies on the other side
    Technique tech{y, i + 1, z, t, &ph};
    if (!reg.select(tech)) return false;  // regularizer.h (5)
    // (zv = x_i: the camera walk samples y[i-1] from t - 1 segments, the light walk z[t-2] from i)
    const detail::Survival sv{survival(zv, t - 1, rrDepth), survival(zv, i, rrDepth)};
    BsdfEval ez = detail::evalAtConnection<reg::kMayRequest<Reg>>(zv, ph.wo, reg.context(tech, End::Camera), sv,
                                                                  tech.ratioCamera, tech.pdfCamera);
    if (isBlack(ez.f)) return false;
    c.contribution = zv.beta * ez.f * ph.beta;
    // The fast forms (photon.misLight, cameraSums) hold unregularised sums: a path on which the
    // regulariser changes some technique's density is gathered on both sides (y and lightPdfs
    // given). Otherwise the light side is gathered when lightPdfs is given without cameraSums.
    const bool perTechnique = detail::needsPerTechnique(reg, tech);
    if (perTechnique && (!y || !lightPdfs))
        throw std::logic_error("merge: per-technique densities need the light subpath");
    if (perTechnique) cameraSums = nullptr;
    const bool gatherLight = perTechnique || (lightPdfs && !cameraSums);
    // Full path: x_0..x_i from the light subpath (x_i at the camera vertex), then z[t-2]..z[0].
    PathPdfs& P = c.pdfs;
    P.belowBase = -1.0;
    P.aboveBase = cameraSums ? (t >= 3 ? cameraSums[t - 3] : 0.0) : -1.0;
    if (gatherLight) {
        // (fromCamera of y[k] is sampled from y[k+1] by a camera walk, n - 2 - k segments from the
        // camera, n = i + t; the entries at k = i - 1 and i are recomputed below)
        const int n = i + t;
        for (int k = 0; k <= i; ++k) {
            P.fromLight[k] = lightPdfs[k].fromLight;
            P.fromCamera[k] =
                lightPdfs[k].fromCamera * (k < i && n - 2 - k >= rrDepth ? lightPdfs[k + 1].continuation : 1.f);
            P.delta[k] = lightPdfs[k].delta;
        }
    } else {
        P.fromLight[i - 1] = ph.prevFromLight;
        P.delta[i - 1] = ph.prevDelta != 0;
    }
    P.lightHittable = ph.lightHittable != 0;
    gatherCameraPdfs(z, t, i, rrDepth, P, cameraSums ? i + 1 : kMaxPathVertices);
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
    if (!gatherLight) {
        double ratio = detail::remapDensity(P.fromCamera[i - 1]) / detail::remapDensity(P.fromLight[i - 1]);
        P.belowBase = ratio * ratio * ph.misLight;
    }
    detail::techniqueDensities(reg, tech, P, perTechnique);
    return true;
}

// The explicit instantiations of the templates above for one regulariser policy: path.cpp for
// reg::None, jg19.cpp, kd13.cpp and opsr.cpp for theirs (each in its own unit: see path.cpp).
#define LT_INSTANTIATE_TRANSPORT(Reg)                                                                        \
    template int lightWalk(const Scene&, const Reg&, Rng&, int, int, PathVertex*, WalkStats&);               \
    template PathVertex cameraEndpoint(const Scene&, const Reg&);                                            \
    template int cameraWalk(const Scene&, const Reg&, const Vec2&, Rng&, int, int, PathVertex*, WalkStats&,  \
                            WalkPdfs, guiding::WalkGuide*);                                                  \
    template Color emitterHit(const Scene&, const Reg&, const PathVertex*, int, int, PathPdfs&, int, bool);  \
    template bool merge(const Reg&, const Photon&, const PathVertex*, const VertexPdfs*, const PathVertex*, \
                        int, int, Connection&, const double*);

}  // namespace lt
