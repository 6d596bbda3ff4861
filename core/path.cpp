#include "core/path.h"
#include "core/light_paths.h"

namespace lt {


// MIS densities must be functions of the path's vertices alone: the sampled ray left from an
// offset origin, so the densities of the segment path[i-1] -> path[i] are re-evaluated with the
// direction between the two vertex positions (pdfFwd of path[i], pdfRev of path[i-2]). Keeps the
// sampled values where the re-evaluation gives zero (grazing directions).
static void refreshPdfs(const Scene& scene, PathVertex* path, int i, TransportMode mode, SolidAnglePdf& pdfFwd) {
    const PathVertex& prev = path[i - 1];
    const Vec3 d = -path[i].wo;
    switch (prev.kind) {
        case VertexKind::Surface:
            if (!prev.delta && prev.bxdf) {
                BsdfEval e = prev.bsdf().eval(prev.wo, d, mode);
                if (e.pdfFwd.value > 0.f) pdfFwd = e.pdfFwd;
                if (i >= 2 && e.pdfRev.value > 0.f)
                    path[i - 2].pdfRev = convertDensity(e.pdfRev, path[i - 2], prev.wo, sqr(prev.segmentLength));
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
    int n = 1;
    SolidAnglePdf pdfFwd = pdfDir;
    while (n < maxVertices) {
        PathVertex& prev = path[n - 1];
        PathVertex& v = path[n];
        ++stats.rays;
        if (stats.log) stats.log->closest.push_back(ray), stats.log->closestDepth.push_back(prev.depth);
        if (!scene.intersect(ray, v)) {  // fills the SurfacePoint fields of v
            if (mode == TransportMode::Radiance && !scene.infiniteLights().empty()) {
                v = PathVertex{};
                v.infinite = true;
                v.light = scene.infiniteLights().front();
                v.p = ray.o + ray.d * (2.f * scene.boundsRadius());
                v.wo = -ray.d;
                v.beta = beta;
                v.pdfFwd = AreaPdf(pdfFwd.value);
                v.depth = uint16_t(prev.depth + 1);
                v.segmentLength = kInf;
                v.pathLength = kInf;
                ++n;
            }
            break;
        }
        // Every other field is written (no default construction first: this is the hot loop).
        v.kind = VertexKind::Surface;
        Vec3 back = prev.p - v.p;
        float backLen = glm::length(back);
        v.wo = backLen > 0.f ? back / backLen : -ray.d;  // the direction the two vertices define
        v.beta = beta;
        v.pdfRev = AreaPdf(allPdfs ? 0.f : kNotComputed);
        v.lobe = kNone;
        v.delta = false;
        v.infinite = false;
        v.depth = uint16_t(prev.depth + 1);
        v.segmentLength = backLen;
        v.pathLength = prev.pathLength + backLen;
        if (allPdfs || v.light) {
            refreshPdfs(scene, path, n, mode, pdfFwd);
            v.pdfFwd = convertDensity(pdfFwd, v, v.wo, sqr(backLen));
        } else {
            v.pdfFwd = AreaPdf(kNotComputed);
        }
        ++n;
        if (n >= maxVertices || !v.bxdf) break;

        BsdfSample bs;
        float uLobe = rng.uniform();
        Vec2 u = rng.uniform2();
        if (!v.bsdf().sample(v.wo, uLobe, u, mode, bs) || isBlack(bs.weight)) break;
        v.lobe = bs.lobe;
        SolidAnglePdf pdfRev = bs.pdfRev;
        pdfFwd = bs.pdfFwd;
        if (bs.lobe & kDelta) {
            // A delta lobe has no density: the MIS routine skips techniques that connect here.
            v.delta = true;
            pdfFwd = pdfRev = SolidAnglePdf(0.f);
        }
        if (allPdfs) prev.pdfRev = convertDensity(pdfRev, prev, v.wo, sqr(v.segmentLength));
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

// Writes every field (no temporary vertex to build and copy: once per camera sample).
static void setCameraEndpoint(const Scene& scene, PathVertex& c) {
    c.p = scene.camera().position();
    c.ng = Vec3(0.f);
    c.shading = Frame();
    c.bxdf = nullptr;
    c.light = nullptr;
    c.deltaBsdf = false;
    c.roughness = 0.f;
    c.kind = VertexKind::Camera;
    c.wo = Vec3(0.f);
    c.beta = Color(1.f);      // We cos / (pdfPos pdfDir) = 1 for a pinhole sampled by raster position
    c.pdfFwd = AreaPdf(1.f);  // the pinhole position is a delta
    c.pdfRev = AreaPdf(0.f);
    c.lobe = kNone;
    c.delta = false;
    c.infinite = false;
    c.depth = 0;
    c.segmentLength = 0.f;
    c.pathLength = 0.f;
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
    PathVertex& y0 = path[0];
    y0 = PathVertex{};
    y0.kind = VertexKind::Light;
    y0.light = &l;
    y0.infinite = l.isInfinite();
    y0.p = le.p;
    y0.ng = l.type == LightType::Area ? le.n : Vec3(0.f);
    y0.roughness = 1.f;
    // Density of the endpoint in the measure NEE uses: area for finite lights, the emission
    // direction's solid angle for lights at infinity (their position lives on the scene's disk).
    y0.pdfFwd = AreaPdf(sel * (y0.infinite ? le.pdfDir.value : le.pdfPos.value));
    y0.beta = Color(1.f / (sel * le.pdfPos.value));  // the light's value is applied at connections
    if (maxVertices == 1) return 1;
    float cosL = l.type == LightType::Area ? std::abs(glm::dot(le.n, le.dir)) : 1.f;
    Color beta = le.value * cosL / (sel * le.pdfPos.value * le.pdfDir.value);
    Ray ray = l.type == LightType::Area ? scene.spawnRay(le.p, le.n, le.dir) : Ray{le.p, le.dir};
    int n = randomWalk(scene, ray, beta, le.pdfDir, rng, TransportMode::Importance, maxVertices, rrDepth, path, stats);
    if (y0.infinite && n > 1) {
        // A ray from the scene's disk: the first hit's density is the disk's, projected.
        path[1].pdfFwd = AreaPdf(le.pdfPos.value * std::abs(glm::dot(path[1].ng, le.dir)));
        path[1].segmentLength = 0.f;
        path[1].pathLength = 0.f;
    }
    return n;
}

namespace {

// A density stored as 0 marks a vertex sampled through a delta lobe (or an entry a walk could not
// fill); in the MIS ratios it counts as 1: the delta factor is common to every technique that can
// sample such a path.
double remapDensity(float p) { return p != 0.f ? double(p) : 1.0; }

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

// The same sum for the path tracer's two techniques (s = 0: emitter hit, s = 1: NEE), which
// compare only x_0's two densities: the terms misSumGeneral adds for k = 0 and k = 1, in closed form.
double misSumPathTracer(const PathPdfs& pdfs, int base) {
    const int n = pdfs.n;
    const bool valid0 = n >= 2 && pdfs.lightHittable;
    const bool valid1 = n >= 3 && !pdfs.delta[0] && !pdfs.delta[1];
    const double r = remapDensity(pdfs.fromLight[0]) / remapDensity(pdfs.fromCamera[0]);  // p_1 / p_0
    if (base == 0) return (valid0 ? 1.0 : 0.0) + (valid1 ? r * r : 0.0);
    return (valid1 ? 1.0 : 0.0) + (valid0 ? 1.0 / (r * r) : 0.0);
}

double misSum(const PathPdfs& pdfs, int base, const MisConfig& cfg) {
    if (cfg.set == TechniqueSet::PathTracer && !cfg.merging && base <= 1 && pdfs.belowBase < 0.0 &&
        pdfs.aboveBase < 0.0)
        return misSumPathTracer(pdfs, base);
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
        double q = double(cfg.mergeArea) * double(cfg.lightPaths) * remapDensity(y[m].fwd);
        own += q * q;
    }
    if (m == 0) return own;
    double ratio = remapDensity(y[m - 1].rev) / remapDensity(y[m - 1].fwd);
    return own + ratio * ratio * prev;
}

double cameraPrefixSum(const PathVertex* z, int m, const MisConfig& cfg, double prev) {
    // Technique with camera side z[0..m] (t' = m + 1; its light side ends at z[m+1]'s position),
    // and the merge at z[m] (not at the camera).
    double own = allowsTechnique(cfg.set, 1, m + 1) && !z[m + 1].delta && !z[m].delta ? 1.0 : 0.0;
    if (cfg.merging && m >= 1 && !z[m].delta) {
        double q = double(cfg.mergeArea) * double(cfg.lightPaths) * remapDensity(z[m].pdfRev.value);
        own += q * q;
    }
    double ratio = remapDensity(z[m].pdfRev.value) / remapDensity(z[m].pdfFwd.value);
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

void gatherCameraPdfs(const PathVertex* z, int t, int s, PathPdfs& pdfs, int readLimit) {
    pdfs.n = s + t;
    // Entries up to readLimit + 1: the density there is not read, the delta flag is (cheap to copy).
    const int limit = readLimit < kMaxPathVertices ? readLimit + 1 : readLimit;
    for (int j = std::max(0, s + t - 1 - limit); j < t; ++j) {
        int i = s + t - 1 - j;
        pdfs.fromCamera[i] = z[j].pdfFwd.value;
        pdfs.fromLight[i] = z[j].pdfRev.value;
        pdfs.delta[i] = z[j].delta;
    }
}

void gatherLightPdfs(const PathVertex* y, int s, PathPdfs& pdfs) {
    for (int i = 0; i < s; ++i) {
        pdfs.fromLight[i] = y[i].pdfFwd.value;
        pdfs.fromCamera[i] = y[i].pdfRev.value;
        pdfs.delta[i] = y[i].delta;
    }
    pdfs.lightHittable = s > 0 && y[0].light && y[0].light->isHittable();
}

// Area density at `to` of the emission of light endpoint `lv` travelling in direction travelDir
// (unit; dist2: squared distance between the two).
static AreaPdf emissionDensity(const Scene& scene, const PathVertex& lv, const Vec3& travelDir, const PathVertex& to,
                               float dist2) {
    const Light& l = *lv.light;
    if (l.isInfinite())  // position on the scene's disk, projected onto the receiving surface
        return AreaPdf(l.pdfLePos(scene).value * (to.onSurface() ? std::abs(glm::dot(to.ng, travelDir)) : 1.f));
    return convertDensity(l.pdfLeDir(lv.ng, travelDir), to, travelDir, dist2);
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
    if (readLimit >= 1) pdfs.fromLight[1] = emissionDensity(scene, v, v.wo, z[t - 2], sqr(v.segmentLength)).value;
    return v.beta * Le;
}

bool sampleLightVertex(const Scene& scene, const Vec3& refP, Rng& rng, PathVertex& out) {
    if (scene.lights().empty()) return false;
    float uSel = rng.uniform();
    Vec2 u = rng.uniform2();
    size_t li = scene.lightDistribution().sample(uSel);
    const Light& l = scene.lights()[li];
    float sel = scene.lightDistribution().probability(li);
    LightSampleLi ls = l.sampleLi(scene, refP, u);
    if (!(ls.pdfPos.value > 0.f) || !(sel > 0.f) || isBlack(ls.value)) return false;
    // Every field is written (no default construction first: this is called per camera vertex).
    out.kind = VertexKind::Light;
    out.p = ls.p;
    out.ng = ls.n;  // zero but for area lights
    out.shading = Frame();
    out.wo = Vec3(0.f);
    out.bxdf = nullptr;
    out.light = &l;
    out.beta = Color(1.f / (sel * ls.pdfPos.value));
    out.pdfFwd = AreaPdf(sel * ls.pdfPos.value);
    out.pdfRev = AreaPdf(0.f);
    out.lobe = kNone;
    out.delta = false;
    out.infinite = l.isInfinite();
    out.deltaBsdf = false;
    out.depth = 0;
    out.roughness = 1.f;
    out.segmentLength = 0.f;
    out.pathLength = 0.f;
    return true;
}

// Value a light endpoint sends towards direction w (radiance, intensity or irradiance).
static Color lightEndpointValue(const PathVertex& a, const Vec3& w) {
    const Light& l = *a.light;
    switch (l.type) {
        case LightType::Area: return l.Le(a.ng, w);
        case LightType::Spot: return l.value * l.spotFalloff(w);
        default: return l.value;
    }
}

bool connect(const Scene& scene, const PathVertex* y, int s, const PathVertex* z, int t, Connection& c,
             WalkStats& stats, int readLimit) {
    const PathVertex& a = y[s - 1];  // light side
    const PathVertex& b = z[t - 1];  // camera side
    const bool toCamera = b.kind == VertexKind::Camera;
    if (!toCamera && (b.kind != VertexKind::Surface || b.infinite || !b.connectible())) return false;
    if (a.kind == VertexKind::Surface && !a.connectible()) return false;
    if (toCamera && a.infinite) return false;
    Vec3 d = a.p - b.p;
    const float abDist2 = glm::dot(d, d);  // the segment's squared length, for the densities
    if (!(abDist2 > 0.f)) return false;
    Vec3 wBA = d / std::sqrt(abDist2);
    const float dist2 = a.infinite ? 1.f : abDist2;  // in the geometry term

    BsdfEval eb;
    float cosB;
    if (toCamera) {
        // Light tracing: the camera's importance and the raster position of a.
        const Camera& cam = scene.camera();
        auto raster = cam.rasterPosition(a.p);
        if (!raster) return false;
        c.raster = *raster;
        eb.f = Color(cam.importance(wBA));
        eb.pdfFwd = cam.directionPdf(wBA);
        cosB = glm::dot(cam.forward(), wBA);
    } else {
        eb = b.bsdf().eval(b.wo, wBA, TransportMode::Radiance);
        cosB = std::abs(glm::dot(b.shading.n, wBA));
    }
    if (isBlack(eb.f)) return false;
    Color fa;
    BsdfEval ea;
    if (a.kind == VertexKind::Light) {
        fa = lightEndpointValue(a, -wBA);
    } else {
        ea = a.bsdf().eval(a.wo, -wBA, TransportMode::Importance);
        fa = ea.f;
    }
    if (isBlack(fa)) return false;
    float cosA = (a.kind == VertexKind::Surface) ? std::abs(glm::dot(a.shading.n, wBA))
                 : a.onSurface()                 ? std::abs(glm::dot(a.ng, wBA))
                                                 : 1.f;
    Color contrib = a.beta * fa * (cosA * cosB / dist2) * eb.f * b.beta;
    if (isBlack(contrib)) return false;
    // (for the camera b.ng is zero: the shadow ray starts exactly at the pinhole)
    Ray shadow = a.infinite ? scene.shadowRayInfinite(b.p, b.ng, wBA) : scene.shadowRay(b.p, b.ng, a.p, a.ng);
    if (shadow.tMax > 0.f) {
        ++stats.rays;
        if (stats.log) stats.log->shadow.push_back(shadow);
        if (scene.occludedRay(shadow)) return false;
    }

    // MIS pdfs: the path's own, with the four values at the connection recomputed.
    PathPdfs& P = c.pdfs;
    P.belowBase = P.aboveBase = -1.0;
    gatherLightPdfs(y, s, P);
    gatherCameraPdfs(z, t, s, P, readLimit);
    // The segments' directions and lengths are known: a-b here, and the walks' own segments
    // arriving at a and b (wo, segmentLength).
    // (Densities above readLimit are not read: the path tracer skips all but x_0's.)
    if (s - 1 <= readLimit) P.fromCamera[s - 1] = convertDensity(eb.pdfFwd, a, wBA, abDist2).value;
    if (s >= 2 && s - 2 <= readLimit)
        P.fromCamera[s - 2] = convertDensity(ea.pdfRev, y[s - 2], a.wo, sqr(a.segmentLength)).value;
    if (a.kind == VertexKind::Light) P.delta[s - 1] = false;
    if (s <= readLimit)
        P.fromLight[s] = a.kind == VertexKind::Light ? emissionDensity(scene, a, -wBA, b, abDist2).value
                                                     : convertDensity(ea.pdfFwd, b, wBA, abDist2).value;
    if (t >= 2 && s + 1 <= readLimit)
        P.fromLight[s + 1] = convertDensity(eb.pdfRev, z[t - 2], b.wo, sqr(b.segmentLength)).value;
    c.contribution = contrib;
    return true;
}

bool merge(const Photon& ph, const VertexPdfs* lightPdfs, const PathVertex* z, int t, Connection& c,
           const double* cameraSums) {
    const int i = ph.depth;
    const PathVertex& zv = z[t - 1];
    if (i < 1 || t < 2 || !zv.connectible() || zv.infinite) return false;
    if (glm::dot(ph.ng, zv.ng) <= 0.f) return false;  // the photon lies on the other side
    BsdfEval ez = zv.bsdf().eval(zv.wo, ph.wo, TransportMode::Radiance);
    if (isBlack(ez.f)) return false;
    c.contribution = zv.beta * ez.f * ph.beta;
    // Full path: x_0..x_i from the light subpath (x_i at the camera vertex), then z[t-2]..z[0].
    PathPdfs& P = c.pdfs;
    P.belowBase = -1.0;
    P.aboveBase = cameraSums ? (t >= 3 ? cameraSums[t - 3] : 0.0) : -1.0;
    if (lightPdfs) {
        for (int k = 0; k <= i; ++k) {
            P.fromLight[k] = lightPdfs[k].fwd;
            P.fromCamera[k] = lightPdfs[k].rev;
            P.delta[k] = lightPdfs[k].delta;
        }
    } else {
        P.fromLight[i - 1] = ph.prevPdfFwd;
        P.delta[i - 1] = ph.prevDelta != 0;
    }
    P.lightHittable = ph.lightHittable != 0;
    gatherCameraPdfs(z, t, i, P, cameraSums ? i + 1 : kMaxPathVertices);
    P.fromLight[i] = ph.pdfFwd;
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
