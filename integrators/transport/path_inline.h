// Inline definitions of the per-sample routines of path.h that the path tracer calls per camera
// vertex (NEE: sampleLightVertex, connect, the pdf gathers, the path tracer's MIS weight).
// In a header so that the compiler specialises them per call site: at the path tracer's call
// (integrators/path_tracer.h) s = 1, readLimit = 0 and the light endpoint are known, and the light
// sample goes straight into the vertex. Included at the end of path.h.
#pragma once

namespace lt {

namespace detail {

// A density stored as 0 is an entry a walk could not fill (e.g. a re-evaluation that gave 0 at a
// grazing direction and no sampled value); in the MIS ratios it counts as 1. (Vertices sampled
// through a delta lobe store generalised densities: see "Delta vertices" in path.h.)
inline double remapDensity(float p) { return p != 0.f ? double(p) : 1.0; }

// rho_hat / rho of one BSDF evaluation pair, as a scalar (the means of the channels): +inf when rho
// is 0 and rho_hat is not (a delta lobe evaluates to 0), exactly 1 when the two are equal (no
// regularisation there, both 0 included).
inline float regularisedRatio(float h, float p) {
    if (h == p) return 1.f;
    if (!(p > 0.f)) return kInf;
    return h / p;
}
inline float regularisedRatio(const Color& hat, const Color& plain) {
    return regularisedRatio(hat.x + hat.y + hat.z, plain.x + plain.y + plain.z);
}
// The same for b between wo and wi under ctx's request: from the pair's geometry where the BSDF
// has that form (bsdf.h, PairGeometry: no evaluation), else from its two value-only evaluations.
inline float regularisedRatioAt(const SurfaceBsdf& b, const Vec3& wo, const Vec3& wi, const BsdfContext& ctx) {
    if (const PairGeometry pair = b.pairGeometry(wo, wi); pair.available()) return b.bxdf().requestRatio(pair, ctx);
    return regularisedRatio(b.eval(wo, wi, ctx.valueOnlyCopy()).f, b.eval(wo, wi, plainContext(ctx.mode).valueOnlyCopy()).f);
}

// The MIS sum (see misSumGeneral in path.cpp) for the path tracer's two techniques (s = 0: emitter
// hit, s = 1: NEE), which compare only x_0's two densities: the terms the plain sum adds for
// k = 0 and k = 1, in closed form, as a fraction den / num. With a = p_1^2 and b = p_0^2 (the
// squared densities of x_0 for NEE and for the emitter hit) the sum is (v1 a + v0 b) / a for
// s = 1 and (v0 b + v1 a) / b for s = 0: the weight num / den is one division (the plain
// sum's ratio, square and reciprocal are three, in a chain). Checked against the plain sum in
// tests/test_bidirectional.cpp.
struct MisFraction {
    double num, den;
};
inline MisFraction misSumPathTracer(const PathPdfs& pdfs, int base) {
    const int n = pdfs.n;
    const bool valid0 = n >= 2 && pdfs.lightHittable;
    const bool valid1 = n >= 3 && !pdfs.delta[0] && !pdfs.delta[1];
    const double p1 = remapDensity(pdfs.fromLight[0]), p0 = remapDensity(pdfs.fromCamera[0]);
    const double a = p1 * p1, b = p0 * p0;
    return {base == 0 ? b : a, (valid1 ? a : 0.0) + (valid0 ? b : 0.0)};
}

// Area density at `to` of the emission of light endpoint `lv` travelling in direction travelDir
// (unit; dist2: squared distance between the two).
inline AreaPdf emissionDensity(const Scene& scene, const PathVertex& lv, const Vec3& travelDir, const PathVertex& to,
                              float dist2) {
    const Light& l = *lv.light;
    if (l.isInfinite())  // position on the scene's disk, projected onto the receiving surface
        return AreaPdf(l.pdfLePos(scene).value * (to.onSurface() ? std::abs(glm::dot(to.ng, travelDir)) : 1.f));
    return convertDensity(l.pdfLeDir(lv.ng, travelDir), to, travelDir, dist2);
}

// Whether a regularisation request can change v's BSDF at all: false for vertices without a
// BSDF, for Lambert and other lobes that are neither glossy nor delta (they ignore requests), and
// for a smooth BSDF that ctx leaves a delta (its eval is 0 either way). Where it is false, the
// BSDF with the request is the BSDF without it: one evaluation serves, and rho_hat / rho is 1.
inline bool requestCanChange(const PathVertex& v, const BsdfContext& ctx) {
    if (ctx.reg.empty() || v.kind != VertexKind::Surface || v.infinite || !v.bxdf || v.bxdf->lambert()) return false;
    if (!(v.bxdf->flags() & (kGlossy | kDelta))) return false;
    return !(v.deltaBsdf && v.bxdf->deltaUnder(ctx));
}

// The densities of an evaluation of v's BSDF as the walks would have them: times the roulette's
// factors (survival, path.h "Russian roulette") of the walk sampling wi (fwd) and of the one
// sampling wo (rev).
struct Survival {
    float fwd = 1.f, rev = 1.f;
};
inline void applySurvival(BsdfEval& e, Survival sv) {
    e.pdfFwd.value *= sv.fwd;
    e.pdfRev.value *= sv.rev;
}

// A connection (or merge) vertex's BSDF towards wi, evaluated with the technique's context
// (regularizer.h (1)): the value is the regularised one, the densities stay those of the
// material's own BSDF, which is what the walks sample (a request changes a technique's density in
// the MIS only through its per-technique factor, regularizer.h (2)), times the roulette's factors
// `sv` as the walks' densities ("Russian roulette", path.h). `ratio` receives
// rho_hat / rho (channel means; +inf when rho is 0 or a delta) and `regularisedPdf` the
// regularised BSDF's own density of wi (for a policy whose competing technique samples it: OPSR's
// regularised BSDF sample; not written for a value-only context). Where the request cannot change
// the BSDF (requestCanChange): one evaluation, as ever, ratio 1 and regularisedPdf left as it was.
// (mayRequest false: ctx carries no request, as reg::None's; see reg::kMayRequest.)
// (A smooth BSDF, a connection end only under a request: its plain value and densities are 0
// for every pair, and the request's evaluation says itself whether the request leaves it a delta,
// so neither the plain evaluation nor requestCanChange's question is asked.)
// (Inlined into each routine: as a call, the context and the evaluation went through memory;
// measured -0.8% instructions for BPT with OPSR on cornell-box-ggx, the same for plain BPT.)
template <bool mayRequest = true>
[[gnu::always_inline]] inline BsdfEval evalAtConnection(const PathVertex& v, const Vec3& wi, const BsdfContext& ctx,
                                                        Survival sv, float& ratio, float& regularisedPdf) {
    const bool request = mayRequest && !ctx.reg.empty();
    BsdfEval e;
    if (!(request && v.deltaBsdf)) e = v.bsdf().eval(v.wo, wi, plainContext(ctx.mode));
    if (request && (v.deltaBsdf || requestCanChange(v, ctx))) {
        const Color plain = e.f;
        // A glossy end read for its value only: the plain value times rho_hat / rho from the
        // pair's geometry (bsdf.h, PairGeometry), where the BSDF has that form and the quotient is
        // finite; the same value as the request's evaluation up to rounding.
        // Where the regularised BSDF's own density is read too (not value-only: OPSR's path tracer
        // with a light it can hit), it is the plain density times its own ratio, D' G1'(wo) /
        // (D G1(wo)) (Bxdf::requestPdfRatio).
        if (!v.deltaBsdf && !isBlack(plain)) {
            if (const PairGeometry pair = v.bsdf().pairGeometry(v.wo, wi); pair.available()) {
                const float r = v.bxdf->requestRatio(pair, ctx);
                const float p = ctx.valueOnly ? 1.f : v.bxdf->requestPdfRatio(pair, ctx.reg);
                if (r < kInf && p < kInf) {
                    e.f = plain * r;
                    ratio = r;
                    if (!ctx.valueOnly) regularisedPdf = e.pdfFwd.value * p;
                    applySurvival(e, sv);
                    return e;
                }
            }
        }
        const BsdfEval r = v.bsdf().eval(v.wo, wi, ctx);
        e.f = r.f;
        regularisedPdf = r.pdfFwd.value;
        ratio = regularisedRatio(e.f, plain);
    }
    applySurvival(e, sv);
    return e;
}

// After a routine has gathered a technique's densities: a policy with per-technique densities
// writes its factors if the path needs them (perTechnique, decided by the caller with
// needsPerTechnique), and whether the technique itself was regularised (regularizer.h (2)).
template <class Reg>
bool needsPerTechnique(const Reg& reg, const Technique& tech) {
    if constexpr (Reg::kPerTechnique) return reg.perTechnique(tech);
    return false;
}
template <class Reg>
void techniqueDensities(const Reg& reg, const Technique& tech, PathPdfs& pdfs, bool perTechnique) {
    pdfs.perTechnique = perTechnique;
    pdfs.regularised = false;
    if constexpr (Reg::kPerTechnique)
        if (perTechnique) reg.densities(tech, pdfs);
}

// regularizer.h (9): whether a connection survives the tail roulette of threshold T (> 0), with
// its contribution divided by the probability q it survived with; fCamera and fLight are the
// values of its camera and light ends (the regularised ones where tech's ratio there is +inf).
// The number comes from a stream split from `rng` by (s, t), drawn only where q < 1. A kept
// connection's value c / q, for c = K f cos (K the rest of its product), is K cos T / pi: what a
// Lambertian of albedo T would give there, so the roulette makes no fireflies.
inline float tailKeep(float threshold, const Color& f) {
    return std::min(1.f, (f.x + f.y + f.z) * (kPi / 3.f) / threshold);
}
inline bool tailRoulette(float threshold, const Technique& tech, const Color& fCamera, const Color& fLight,
                         const Rng& rng, Color& contrib) {
    if (!(threshold > 0.f)) return true;
    float q = 1.f;
    if (tech.ratioCamera == kInf) q *= tailKeep(threshold, fCamera);
    if (tech.ratioLight == kInf) q *= tailKeep(threshold, fLight);
    // (q below 1e-30, 0 where a value underflowed: kept as it is, which is unbiased too, and 1 / q
    // never overflows)
    if (!(q < 1.f) || !(q > 1e-30f)) return true;
    Rng side = rng.split((uint64_t(uint32_t(tech.s)) << 32 | uint32_t(tech.t)) ^ 0xd6e8feb86659fd93ull);
    if (!(side.uniform() < q)) return false;
    contrib /= q;
    return true;
}

// The stream the light sample of a connection at camera vertex v (index t of its walk) draws
// from: the walk's own where v is connectible without a regulariser; where only the regulariser
// makes it connectible (a smooth vertex), a stream split from it (Rng::split, held in `side`), so
// that the walk's numbers, and so every unregularised contribution, are as without a regulariser.
inline Rng& lightSampleStream(const PathVertex& v, int t, Rng& walk, std::optional<Rng>& side) {
    if (v.connectible()) return walk;
    side.emplace(walk.split(uint64_t(t)));
    return *side;
}

// The vertex at infinity a camera-side ray from prev reaches when it misses the scene (the scene has
// an environment light): on the scene's far sphere, its density in solid angle (see
// convertDensity). The camera walk and the path tracer's regularised BSDF sample both make it.
template <class Reg>
void initAtInfinity(const Scene& scene, const Reg& reg, PathVertex& v, PathVertex& prev, const Ray& ray,
                    const Color& beta, SolidAnglePdf pdf) {
    v.setPoint(ray.o + ray.d * (2.f * scene.boundsRadius()), Vec3(0.f), scene.infiniteLights().front(), 1.f);
    v.init(reg, VertexKind::Surface, &prev, -ray.d, kInf, beta, AreaPdf(0.f), AreaPdf(pdf.value), true);
}

// Value a light endpoint sends towards direction w (radiance, intensity or irradiance).
inline Color lightEndpointValue(const PathVertex& a, const Vec3& w) {
    const Light& l = *a.light;
    switch (l.type) {
        case LightType::Area:
        case LightType::Envmap: return l.Le(a.ng, w, a.uv);
        case LightType::Spot: return l.texture ? l.texturedIntensity(w) : l.value * l.spotFalloff(w);
        case LightType::Projector: return l.texturedIntensity(w);
        default: return l.value;
    }
}

}  // namespace detail

inline float misWeight(const PathPdfs& pdfs, int s, TechniqueSet set) {
    // The path tracer's closed form here (as misWeight(pdfs, s, cfg) takes it), the rest out of line.
    if (set == TechniqueSet::PathTracer && s <= 1 && pdfs.belowBase < 0.0 && pdfs.aboveBase < 0.0 &&
        !pdfs.perTechnique) {
        const detail::MisFraction f = detail::misSumPathTracer(pdfs, s);
        const double w = f.num / f.den;
        return f.den > 0.0 && w > 0.0 ? float(w) : 0.f;  // (as 1 / sum for sum > 0; 0 for NaN)
    }
    return misWeight(pdfs, s, MisConfig{set});
}

inline void gatherCameraPdfs(const PathVertex* z, int t, int s, int rrDepth, PathPdfs& pdfs, int readLimit) {
    pdfs.n = s + t;
    // Entries up to readLimit + 1: the density there is not read, the delta flag is (cheap to copy).
    const int limit = readLimit < kMaxPathVertices ? readLimit + 1 : readLimit;
    for (int j = std::max(0, s + t - 1 - limit); j < t; ++j) {
        int i = s + t - 1 - j;
        pdfs.fromCamera[i] = z[j].fromCamera.value;
        // (sampled from z[j+1] = x_{i-1} by a light walk; the two entries nearest the far end are
        // recomputed by every routine)
        pdfs.fromLight[i] = z[j].fromLight.value * (j + 1 < t ? survival(z[j + 1], i - 1, rrDepth) : 1.f);
        pdfs.delta[i] = z[j].delta;
    }
}

inline void gatherLightPdfs(const PathVertex* y, int s, int t, int rrDepth, PathPdfs& pdfs) {
    const int n = s + t;
    for (int i = 0; i < s; ++i) {
        pdfs.fromLight[i] = y[i].fromLight.value;
        // (sampled from y[i+1] = x_{i+1} by a camera walk, n - 2 - i segments from the camera)
        pdfs.fromCamera[i] = y[i].fromCamera.value * (i + 1 < s ? survival(y[i + 1], n - 2 - i, rrDepth) : 1.f);
        pdfs.delta[i] = y[i].delta;
    }
    pdfs.lightHittable = s > 0 && y[0].light && y[0].light->isHittable();
}

template <class Reg>
inline bool sampleLightVertex(const Scene& scene, const Reg& reg, const Vec3& refP, Rng& rng, PathVertex& out) {
    if (scene.lights().empty()) return false;
    float uSel = rng.uniform();
    Vec2 u = rng.uniform2();
    return lightEndpoint(scene, reg, scene.lightDistribution().sample(uSel), refP, u, out);
}

template <class Reg>
inline bool lightEndpoint(const Scene& scene, const Reg& reg, size_t li, const Vec3& refP, const Vec2& u,
                          PathVertex& out) {
    const Light& l = scene.lights()[li];
    float sel = scene.lightDistribution().probability(li);
    LightSampleLi ls = l.sampleLi(scene, refP, u);
    if (!(ls.pdfPos.value > 0.f) || !(sel > 0.f) || isBlack(ls.value)) return false;
    out.setPoint(ls.p, ls.n, &l, 1.f);  // ls.n: zero but for area lights
    out.uv = ls.uv;                     // (a textured area light's Le reads it)
    out.init(reg, VertexKind::Light, nullptr, Vec3(0.f), 0.f, Color(1.f / (sel * ls.pdfPos.value)),
             AreaPdf(sel * ls.pdfPos.value), AreaPdf(0.f), l.isInfinite());
    return true;
}

template <ConnectEnds ends, class Reg>
inline bool connect(const Scene& scene, const Reg& reg, const PathVertex* y, int s, const PathVertex* z, int t,
                    int rrDepth, Connection& c, WalkStats& stats, int readLimit, const Rng* roulette,
                    const guiding::WalkGuide* guide) {
    Technique tech{y, s, z, t};
    const PathVertex& a = y[s - 1];  // light side
    const PathVertex& b = z[t - 1];  // camera side
    // The vertex kinds, constant at a next-event estimation site (the tests on them fold away).
    constexpr bool nee = ends == ConnectEnds::LightToSurface;
    const bool aLight = nee || a.kind == VertexKind::Light;
    const bool aSurface = !nee && a.kind == VertexKind::Surface;
    const bool toCamera = !nee && b.kind == VertexKind::Camera;
    if (!nee && !toCamera && (b.kind != VertexKind::Surface || b.infinite || !reg.connectible(b))) return false;
    if (aSurface && !reg.connectible(a)) return false;
    if (toCamera && a.infinite) return false;
    // The camera's kind, read once: the pinhole takes its own forms (core/camera.h), a lens or an
    // orthographic film the general ones at camera vertex b.
    const SensorType camType = toCamera ? scene.camera().type() : SensorType::Perspective;
    const bool lensCamera = camType != SensorType::Perspective;
    // Light tracing: where a lands on the image, known before the policy chooses the path's
    // regularised vertices (JG19's choice is a loop over the path; with it, BPT on caustic-mirror
    // made it for 37,000 light-tracing connections that landed off the image, of 40,000).
    if (toCamera) {
        const std::optional<Vec2> raster =
            lensCamera ? scene.camera().rasterPosition(b.p, a.p) : scene.camera().rasterPosition(a.p);
        if (!raster) return false;
        c.raster = *raster;
    }
    if (!reg.select(tech)) return false;  // regularizer.h (5)
    // With nothing regularised both ends' contexts are the plain ones (regularizer.h (5)): the
    // evaluations then skip the policy's context and the request's tests (BPT and VCM, where
    // most connections are plain; the path tracer runs the plain routine at such vertices
    // already, regularizer.h (10), and its policy routine is left as it was).
    const bool request = reg::kMayRequest<Reg> && (nee || anyRegularised(tech));
    Vec3 d = a.p - b.p;
    const float abDist2 = glm::dot(d, d);  // the segment's squared length, for the densities
    if (!(abDist2 > 0.f)) return false;
    Vec3 wBA = d * (1.f / std::sqrt(abDist2));  // one division, not three
    // (an orthographic camera's end is a's own projection, along a delta direction: as a light at
    // infinity, no 1 / d^2; see the importance below)
    const float dist2 = a.infinite || camType == SensorType::Orthographic ? 1.f : abDist2;  // in the geometry term
    // The shadow ray first: it needs only the two points, and its square root and division are
    // then under way while the BSDF is evaluated, not on the chain to the ray cast.
    // (for the camera b.ng is zero: the shadow ray starts exactly at the camera vertex)
    const Ray shadow = a.infinite ? scene.shadowRayInfinite(b.p, b.ng, wBA) : scene.shadowRay(b.p, b.ng, a.p, a.ng);

    BsdfEval eb;
    float cosB;
    if (toCamera) {
        // Light tracing: the camera's importance (a's raster position is known from above).
        // b is the pinhole, a lens point or a's projection onto the orthographic film (the caller's).
        const Camera& cam = scene.camera();
        if (camType == SensorType::Orthographic) {
            // We = 1 / A_film per unit projected area at a (|cos_a| from the geometry term); the
            // camera walk's density of a, |cos_a| / A_film, as the solid-angle density that
            // convertDensity below turns into it.
            eb.f = Color(cam.filmDensity());
            eb.pdfFwd = SolidAnglePdf(cam.filmDensity() * abDist2);
            cosB = 1.f;
        } else {
            eb.f = Color(lensCamera ? cam.importance(b.p, wBA) : cam.importance(wBA));
            eb.pdfFwd = lensCamera ? cam.directionPdf(b.p, wBA) : cam.directionPdf(wBA);
            cosB = glm::dot(cam.forward(), wBA);
        }
    } else {
        // (b = x_s: the camera walk samples a from t - 1 segments, the light walk z[t-2] from s)
        const detail::Survival sv{survival(b, t - 1, rrDepth), survival(b, s, rrDepth)};
        eb = request ? detail::evalAtConnection<true>(b, wBA, reg.context(tech, End::Camera), sv, tech.ratioCamera,
                                                      tech.pdfCamera)
                     : detail::evalAtConnection<false>(b, wBA, kRadianceContext, sv, tech.ratioCamera, tech.pdfCamera);
        cosB = std::abs(glm::dot(b.shading.n, wBA));
        // A guided camera end: the walk samples the mixture there (walk_guide.h), so the camera
        // walk's density of a is the mixture's, before any policy scales it.
        if (guide && guide->guided(t - 1)) eb.pdfFwd = SolidAnglePdf(guide->mixture(t - 1, eb.pdfFwd.value, wBA, sv.fwd));
    }
    if (isBlack(eb.f)) return false;
    Color fa;
    BsdfEval ea;
    if (aLight) {
        fa = detail::lightEndpointValue(a, -wBA);
    } else {
        // (a = x_{s-1}: the light walk samples b from s - 1 segments, the camera walk y[s-2] from t)
        const detail::Survival sv{survival(a, s - 1, rrDepth), survival(a, t, rrDepth)};
        ea = request ? detail::evalAtConnection<true>(a, -wBA, reg.context(tech, End::Light), sv, tech.ratioLight,
                                                      tech.pdfLight)
                     : detail::evalAtConnection<false>(a, -wBA, kImportanceContext, sv, tech.ratioLight, tech.pdfLight);
        fa = ea.f;
    }
    if (isBlack(fa)) return false;
    float cosA = aSurface                                 ? std::abs(glm::dot(a.shading.n, wBA))
                 : aLight && a.ng != Vec3(0.f) ? std::abs(glm::dot(a.ng, wBA))  // a.onSurface()
                                                 : 1.f;
    Color contrib = a.beta * fa * (cosA * cosB / dist2) * eb.f * b.beta;
    if (isBlack(contrib)) return false;
    if constexpr (std::is_base_of_v<reg::TailRoulette, Reg>)
        if (roulette && !detail::tailRoulette(reg.tailThreshold, tech, eb.f, fa, *roulette, contrib)) return false;
    if (shadow.tMax > 0.f) {
        ++stats.rays;
        if (stats.log) stats.log->addShadow(shadow);
        if (scene.occludedRay(shadow)) return false;
    }

    // MIS pdfs: the path's own, with the four values at the connection recomputed.
    PathPdfs& P = c.pdfs;
    P.belowBase = P.aboveBase = -1.0;
    gatherLightPdfs(y, s, t, rrDepth, P);
    gatherCameraPdfs(z, t, s, rrDepth, P, readLimit);
    // The segments' directions and lengths are known: a-b here, and the walks' own segments
    // arriving at a and b (wo, segmentLength).
    // (Densities above readLimit are not read: the path tracer skips all but x_0's.)
    if (s - 1 <= readLimit) P.fromCamera[s - 1] = convertDensity(eb.pdfFwd, a, wBA, abDist2).value;
    if (s >= 2 && s - 2 <= readLimit)
        P.fromCamera[s - 2] = convertDensity(ea.pdfRev, y[s - 2], a.wo, sqr(a.segmentLength)).value;
    // The connection's ends evaluate their BSDFs' non-delta lobes, whichever lobe their walks
    // sampled next (a mixed BSDF such as plastic): neither end is a delta vertex of this path.
    P.delta[s - 1] = false;
    P.delta[s] = false;
    if (s <= readLimit)
        P.fromLight[s] = aLight ? detail::emissionDensity(scene, a, -wBA, b, abDist2).value
                                : convertDensity(ea.pdfFwd, b, wBA, abDist2).value;
    if (t >= 2 && s + 1 <= readLimit)
        P.fromLight[s + 1] = convertDensity(eb.pdfRev, z[t - 2], b.wo, sqr(b.segmentLength)).value;
    detail::techniqueDensities(reg, tech, P, detail::needsPerTechnique(reg, tech));
    c.contribution = contrib;
    return true;
}

}  // namespace lt
