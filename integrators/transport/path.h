// The shared path-vertex store of PT, BPT and VCM: one vertex record, one random walk, one
// connection routine, one MIS routine; and the seam where a regulariser changes them
// (regularizer.h: the walks, connect, emitterHit and merge are templates on its policy).
//
// Indexing of a full path (used by the MIS routine): x_0 is the light end, x_{n-1} the camera.
// A technique s takes x_0..x_{s-1} from a light subpath y and x_s..x_{n-1} from a camera
// subpath z (t = n - s camera vertices; z_0 = x_{n-1} is the camera). PT uses s = 0 (a camera
// walk hits an emitter) and s = 1 (next-event estimation); BPT every (s, t); VCM adds merges.
//
// ---- Names of the densities (one name per quantity, in every record) ------------------------
// Area densities of a path vertex are named by the side whose walk samples the vertex:
//   fromLight  pL: the density of the vertex when sampled from its neighbour on the light side
//              (by a light walk; for x_0, the light's own position density);
//   fromCamera pC: the density when sampled from its neighbour on the camera side (by a camera
//              walk; 1 for the pinhole).
// The same two names in every record that holds them: PathVertex (a vertex's own two densities:
// for a light-subpath vertex fromLight is its walk's, fromCamera is filled when the next vertex
// is known; the other way round on a camera subpath), VertexPdfs (the compact copy in the light
// store), Photon (fromLight of y[i], prevFromLight of y[i-1]) and PathPdfs (indexed by the
// position x_i on the full path: fromLight[i], fromCamera[i]). Solid-angle densities of one
// scattering event (BsdfEval, BsdfSample, the lights' and the camera's direction pdfs) keep the
// BSDF's names, pdfFwd (of the sampled direction wi given wo) and pdfRev (of wo given wi).
//
// Delta vertices. A vertex x_j continued through a delta lobe (smooth mirror or glass) cannot be
// a connection or merge vertex, but the techniques on its two sides compare densities that cross
// it: for technique k < j and technique k' > j + 1 the ratio p_k' / p_k contains
// pL[j] pL[j+1] / (pC[j-1] pC[j]), where pL[j+1] and pC[j-1] hold a Dirac delta. In projected solid
// angle the two deltas differ only by eta_out^2 / eta_in^2 (the transfer through a specular
// interface preserves eta^2 dA dw_perp), so the walk stores, for the vertex sampled through x_j,
// the generalised density P(lobe) |cos(w_out)| eta^2 cos(at the new vertex) / d^2, eta = n_wi / n_wo
// of the crossing (1 for reflection), and for the reverse direction P(lobe) |cos(w_in)| cos / d^2:
// the common delta divides out of every ratio. The ratio across x_j is then
// (p_dir,L cos_{j+1} / (p_dir,C cos_{j-1})) (eta_t / eta_i)^2 with p_dir the solid-angle densities
// that reached x_j, which is what SmallVCM's recursion computes (without the eta^2) and what
// tests/test_mis_densities.cpp checks against independently evaluated path densities. (Both
// values at a delta vertex come from the walk that passed through it, so the relative eta of that
// walk is consistent.) Storing them as 1, as before, dropped the cosines and left a ratio of
// squared segment lengths: fireflies from s = 0 on long paths through glass.
//
// Russian roulette. A walk leaves a surface vertex v with probability c_v = Bxdf::continuation()
// (the largest scale of the material's lobes, at most 1; SmallVCM's ContinuationProb) and divides
// the throughput by it where it is at least rrDepth segments from its endpoint; nearer, it always
// goes on. So c_v belongs to the density of a step from v exactly where the walk taking that step
// plays the roulette: on a full path x_0..x_{n-1}, pL[i+1] carries c_i iff i >= rrDepth and
// pC[i-1] carries c_i iff n-1-i >= rrDepth (survival() below). Both are properties of the path and
// rrDepth alone, the same for every technique, so the weights stay a partition of unity and the MIS
// sum compares the techniques' true densities. A walk knows its own side's depth, so its own
// densities carry the factor; the reverse densities it writes (of the previous vertex) depend on
// the full path's length, so they are stored without it and the gathers apply it (and a
// connection or merge vertex's recomputed densities apply it there). With rrDepth 1 every interior
// vertex carries c_v on both sides (SmallVCM's densities); with the path tracer's rrDepth 5 the
// first bounces' BSDF densities carry none, as the sampling that made them, and next-event
// estimation there is weighted against the BSDF's own density. Unlike a roulette on the
// throughput (which kept long paths' throughput near 1 and made those few that reached a light
// through glass into fireflies), the weight of a Lambert bounce over c_v is at most 1.
#pragma once
#include <array>
#include <optional>
#include <vector>
#include "bsdf/surface_bsdf.h"
#include "core/rng.h"
#include "core/scene.h"
#include "integrators/guiding/walk_guide.h"
#include "integrators/transport/regularizer.h"

namespace lt {

inline constexpr int kMaxPathVertices = 66;  // enough for max_depth 64

enum class VertexKind : uint8_t { Camera, Light, Surface };

// The surface fields (p, ng, shading, bxdf, light, deltaBsdf, roughness) come from SurfacePoint:
// the walk's Scene::intersect writes them in place, setPoint for the vertices that are not surface
// hits. At endpoints ng is zero for point lights, the camera and vertices at infinity.
struct PathVertex : SurfacePoint {
    VertexKind kind = VertexKind::Surface;
    // A smooth (delta) BSDF here that every request of the running regulariser makes rough, so a
    // connection may end here (its start/extend write it: Jg19::connectible; None leaves it).
    bool roughenedByRequest = false;
    Vec3 wo{0.f};        // unit direction towards the previous vertex (zero at an endpoint)
    Color beta{1.f};     // throughput of the subpath up to this vertex (not including its BSDF)
    AreaPdf fromLight, fromCamera;  // pL, pC of this vertex (names: see the top of this file)
    bool delta = false;     // continued through a delta lobe: no connection can use this vertex
    bool infinite = false;  // at infinity (environment hit, directional/constant light endpoint)
    uint16_t depth = 0;     // number of segments from the subpath's endpoint
    // Fields regularisation reads (JG19, OPSR), besides roughness.
    float segmentLength = 0.f;  // length of the segment arriving at this vertex
    float pathLength = 0.f;     // sum of segment lengths from the endpoint to here
    SubpathState regState;      // the regulariser's state (regularizer.h (3); None leaves it unset)

    // The one initialiser of a vertex record: every field but the surface point's, written once
    // with no default construction first (it runs per vertex), then the regulariser's state
    // (start at an endpoint, extend from prev). `prev` is the vertex the walk came from, `toPrev`
    // the unit direction to it and `segment` the distance (null, zero and 0 at an endpoint:
    // depth 0, path length 0).
    template <class Reg>
    void init(const Reg& reg, VertexKind k, PathVertex* prev, const Vec3& toPrev, float segment,
              const Color& throughput, AreaPdf pL, AreaPdf pC, bool atInfinity = false) {
        kind = k;
        wo = toPrev;
        beta = throughput;
        fromLight = pL;
        fromCamera = pC;
        delta = false;
        infinite = atInfinity;
        depth = prev ? uint16_t(prev->depth + 1) : uint16_t(0);
        segmentLength = segment;
        pathLength = prev ? prev->pathLength + segment : 0.f;
        if (prev) reg.extend(*this, *prev);
        else reg.start(*this);
    }
    // The surface-point fields of a vertex that is not a surface hit (the camera, a light endpoint,
    // a point at infinity): no BSDF and no shading frame.
    void setPoint(const Vec3& pos, const Vec3& normal, const Light* l, float rough) {
        p = pos;
        ng = normal;
        shading = Frame();
        bxdf = nullptr;
        light = l;
        deltaBsdf = false;
        roughness = rough;
        curvature = 0.f;
        uv = Vec2(0.f);
    }

    bool onSurface() const { return kind == VertexKind::Surface || (kind == VertexKind::Light && ng != Vec3(0.f)); }
    // A surface vertex is a connection end where its BSDF has a non-delta lobe, whichever lobe its
    // walk sampled (a plastic's walk may leave through the coating's delta lobe: a connection
    // there evaluates the base); other vertices where the walk's own step was not a delta.
    bool connectible() const { return kind != VertexKind::Surface ? !delta : (bxdf && !deltaBsdf); }
    SurfaceBsdf bsdf() const { return SurfaceBsdf(bxdf, shading, ng, uv); }
};

// Area density at `to` of a solid-angle density sampled towards it (no conversion for a vertex at
// infinity), from the unit direction between the two vertices (either sign) and their squared
// distance, which every caller already has (the connection segment, or a walk's own segment:
// wo and segmentLength of the vertex it arrived at).
inline AreaPdf convertDensity(SolidAnglePdf pdf, const PathVertex& to, const Vec3& dir, float dist2) {
    if (to.infinite) return AreaPdf(pdf.value);
    if (!(dist2 > 0.f)) return AreaPdf(0.f);
    float c = to.onSurface() ? std::abs(glm::dot(to.ng, dir)) : 1.f;
    return AreaPdf(pdf.value * c / dist2);
}

// The roulette's factor on the density of a step a walk takes from v when v lies `segments` from
// that walk's endpoint: c_v from rrDepth on, else 1 (and 1 at a vertex without a BSDF: endpoints).
inline float survival(const PathVertex& v, int segments, int rrDepth) {
    return segments >= rrDepth && v.bxdf ? v.bxdf->continuation() : 1.f;
}

// The rays a walk or connection casts, logged when WalkStats::log is set (tools/raybench replays
// them: a bare Embree loop over exactly the renderer's rays). Closest-hit rays with depth 0 are
// camera rays when the walk started at the camera.
struct RayLog {
    std::vector<Ray> closest, shadow;
    std::vector<uint16_t> closestDepth;  // segments before the ray (0: the walk's first ray)
    std::vector<bool> shadowAt;          // the order of casting: entry k is true if the k-th ray was a shadow ray
    void addClosest(const Ray& r, uint16_t depth) { closest.push_back(r), closestDepth.push_back(depth), shadowAt.push_back(false); }
    void addShadow(const Ray& r) { shadow.push_back(r), shadowAt.push_back(true); }
};

struct WalkStats {
    uint64_t rays = 0;
    // Counted by the integrators under a regulariser only: weighted non-zero contributions, and
    // those whose own technique evaluated a regularised BSDF (PathPdfs::regularised).
    uint64_t contributions = 0, regularised = 0;
    RayLog* log = nullptr;  // usually null: one predictable branch per ray
    // The one place that counts them: a contribution as weighted, and whether its technique was.
    void countContribution(const Color& weighted, bool regularisedTechnique) {
        if (!isBlack(weighted)) ++contributions, regularised += regularisedTechnique;
    }
};

// Which vertex densities a walk computes. All: both densities of every vertex, re-evaluated at
// the vertex positions (BPT, VCM, any MIS over the whole path). EmitterHits: only the walk's own
// density (fromCamera of a camera walk) of vertices on emitters (all the path tracer's MIS reads,
// see misReadLimit); the others are NaN, so a reader that should not read them produces NaN
// samples, which are counted, not hidden.
enum class WalkPdfs { All, EmitterHits };

// The walks (path_templates.h; `reg` is the regulariser policy, regularizer.h, whose state each
// vertex carries). A walk fills its endpoint path[0] and extends the subpath by a random walk;
// it returns the number of vertices (including path[0]), at most maxVertices, and stops at misses
// (adding a vertex at infinity for camera walks when the scene has an environment light),
// absorption (Russian roulette after rrDepth segments) or failed BSDF sampling.
//
// Starts a light subpath: picks a light by power, samples an emitted ray. Returns the number of
// vertices (0 when no light can emit). path[0] is the light endpoint.
template <class Reg>
int lightWalk(const Scene& scene, const Reg& reg, Rng& rng, int maxVertices, int rrDepth, PathVertex* path,
              WalkStats& stats);

// The pinhole camera as a path endpoint (z_0 of camera subpaths, the t = 1 end of light tracing).
template <class Reg>
PathVertex cameraEndpoint(const Scene& scene, const Reg& reg);

// Starts a camera subpath through raster position `raster`. With `guide` (the path tracer's path
// guiding, integrators/guiding/walk_guide.h) the guided vertices sample the one-sample mixture of
// their BSDF and the guide, and the walk's densities are the mixture's; guide->leaf says which.
template <class Reg>
int cameraWalk(const Scene& scene, const Reg& reg, const Vec2& raster, Rng& rng, int maxVertices, int rrDepth,
               PathVertex* path, WalkStats& stats, WalkPdfs pdfs = WalkPdfs::All, guiding::WalkGuide* guide = nullptr);

// ---- MIS ----------------------------------------------------------------------------------
// Which connection techniques (s, t) an integrator uses.
enum class TechniqueSet { PathTracer, Bidirectional, LightTracer, None };
inline bool allowsTechnique(TechniqueSet set, int s, int t) {
    switch (set) {
        case TechniqueSet::PathTracer: return t >= 2 && (s == 0 || s == 1);
        case TechniqueSet::Bidirectional: return t >= 1;  // the pinhole cannot be hit (t = 0)
        case TechniqueSet::LightTracer: return t == 1;
        case TechniqueSet::None: return false;
    }
    return false;
}

// The techniques competing in the MIS sum: connections from `set`, and (VCM) merges at every
// interior non-delta vertex x_i (1 <= i <= n-2) with n_VM = lightPaths samples each, compared
// with the n_VC = 1 sample of each connection technique (Georgiev et al. 2012, Eq. 10-11).
struct MisConfig {
    TechniqueSet set = TechniqueSet::PathTracer;
    bool merging = false;
    float mergeArea = 0.f;   // pi r^2 of the current iteration
    float lightPaths = 0.f;  // N, light subpaths per iteration
};

// The pdfs of one full path, gathered from both subpaths (with the values at the technique's own
// connection vertices recomputed), and a regulariser's per-technique factors on them.
// Entries 0..n-1 are filled by the gathers (not at construction: the arrays are over 1 KB and
// a connection is made per vertex), except that a limited gather (see misReadLimit) fills
// only the entries its technique set reads.
struct PathPdfs {
    int n = 0;
    std::array<float, kMaxPathVertices> fromLight, fromCamera;  // pL[i], pC[i] (area measure)
    std::array<bool, kMaxPathVertices> delta;
    bool lightHittable = false;  // can a camera walk reach x_0 (technique s = 0)?
    // Fast form for merges: when >= 0, the sum over the techniques with fewer light vertices than
    // the base technique, precomputed per light vertex (lightPrefixSum) and scaled at the merge;
    // entries below base - 1 are then not read. Checked against the gathered form in tests.
    double belowBase = -1.0;
    // Fast form for merges, camera side: when >= 0, the sum over the techniques k >= base + 2
    // relative to p_VC(base + 2) (cameraPrefixSum of the camera vertex x_{base+2}); the upward
    // sum stops there and entries above base + 1 are not read. Checked against the gathered form.
    double aboveBase = -1.0;
    // Per-technique densities (regularizer.h (2)): when perTechnique, the density of connection
    // technique k (k light vertices, 0..n) is its product of the entries above times
    // connectionScale[k], that of the merge at x_i times mergeScale[i] (factors >= 0, written by
    // the regulariser; not read otherwise). A factor of 0 means the technique cannot sample the
    // path; the delta flags still apply (a regulariser that makes a delta vertex a connection
    // end clears its flag in the gathered pdfs).
    // `regularised`: the technique being weighted itself evaluated a regularised BSDF (for the
    // statistics; written with the factors).
    bool perTechnique = false;
    bool regularised = false;
    std::array<float, kMaxPathVertices + 1> connectionScale;
    std::array<float, kMaxPathVertices> mergeScale;
};

// Power-heuristic weight of connection technique s: p_s^2 / sum_k (n_k p_k)^2 over the techniques
// k that can sample this path, p_k = prod_{i<k} pL[i] * prod_{i>=k} pC[i] (a merge at x_i has
// p_VC(i) * pL[i] * pi r^2). Computed as the plain sum over techniques of the ratios p_k / p_s
// (no recursion), so changing one technique's pdfs changes only its own array entries.
float misWeight(const PathPdfs& pdfs, int s, const MisConfig& cfg);
// Weight of the merge technique at x_i.
float misWeightMerge(const PathPdfs& pdfs, int i, const MisConfig& cfg);
// (Inline, path_inline.h: the path tracer's closed form without a call.)
inline float misWeight(const PathPdfs& pdfs, int s, TechniqueSet set);
// misWeight and misWeightMerge with the plain sum over techniques always (they take a closed form
// for the path tracer's two techniques and loops for BPT's and VCM's); for the tests that check the
// fast forms against the plain one.
float misWeightGeneral(const PathPdfs& pdfs, int s, const MisConfig& cfg);
float misWeightMergeGeneral(const PathPdfs& pdfs, int i, const MisConfig& cfg);

// The highest index of a density (fromLight, fromCamera) the MIS sum of `cfg` can read (a
// regulariser with per-technique densities makes every routine read all of them); it reads
// delta flags up to one index higher (technique k compares the densities at x_{k-1} and needs
// both neighbours' flags). The path tracer's two techniques (s = 0 and s = 1, no merging) compare
// only x_0's two densities and read delta[0..1]: its gathers stop there, and its connections
// skip the densities they would recompute above x_0 (O(1) per connection instead of O(t)).
// Every other set reads the whole path. (Tested: weights from the limited gather equal those
// from the full gather, with the entries not filled poisoned.)
inline int misReadLimit(const MisConfig& cfg) {
    return cfg.set == TechniqueSet::PathTracer && !cfg.merging ? 0 : kMaxPathVertices;
}

// ---- Connection ----------------------------------------------------------------------------
// Each routine consults the regulariser `reg` (regularizer.h) with the technique's vertices: the
// BSDF context at its connection (merge) vertices, and the per-technique densities of the path.
//
// A light endpoint for next-event estimation (technique s = 1), sampled from the scene's lights.
template <class Reg>
inline bool sampleLightVertex(const Scene& scene, const Reg& reg, const Vec3& refP, Rng& rng, PathVertex& out);
// The same endpoint for light li of the scene's list, chosen by the caller (with u for its
// position: a delta light ignores it); its densities and throughput carry the probability with
// which sampleLightVertex picks li.
template <class Reg>
inline bool lightEndpoint(const Scene& scene, const Reg& reg, size_t li, const Vec3& refP, const Vec2& u,
                          PathVertex& out);

struct Connection {
    Color contribution{0.f};  // unweighted: beta_y * f_y * G * f_z * beta_z, visibility included
    Vec2 raster{0.f};         // t = 1 (light tracing): where to splat
    PathPdfs pdfs;
};

// Connects the light subpath y[0..s-1] with the camera subpath z[0..t-1] (s >= 1, t >= 1; t = 1 is
// light tracing: z[0] is the camera and the result carries the raster position).
// Returns false when the connection carries nothing.
// Only the densities up to index readLimit (misReadLimit) are gathered or recomputed, and the delta
// flags up to readLimit + 1.
// `ends` is what the call site knows at compile time (one routine; the tests it makes redundant
// fold away): LightToSurface is next-event estimation, s = 1 with y[0] a light endpoint
// (sampleLightVertex) and z[t-1] a surface vertex the caller found connectible and not at infinity.
// `roulette`: the sample's stream, from which the regulariser's tail roulette splits its number
// (regularizer.h (9)); null: every connection is traced. rrDepth: the walks' ("Russian roulette"
// above; it decides which densities carry c_v). The same in emitterHit and merge.
enum class ConnectEnds { Any, LightToSurface };
template <ConnectEnds ends = ConnectEnds::Any, class Reg>
inline bool connect(const Scene& scene, const Reg& reg, const PathVertex* y, int s, const PathVertex* z, int t,
                    int rrDepth, Connection& c, WalkStats& stats, int readLimit = kMaxPathVertices, const Rng* roulette = nullptr,
                    const guiding::WalkGuide* guide = nullptr);

// Technique s = 0: z[t-1] lies on an emitter (or at infinity). Returns Le * beta (unweighted) and
// fills the pdfs (path_templates.h).
// regularisedSample: z[t-1] was reached by the path tracer's regularised BSDF sample at z[t-2]
// (regularizer.h (6)), not by the walk.
template <class Reg>
Color emitterHit(const Scene& scene, const Reg& reg, const PathVertex* z, int t, int rrDepth, PathPdfs& pdfs,
                 int readLimit = kMaxPathVertices, bool regularisedSample = false);

// Merge (vertex merging) of light vertex y[i] (i >= 1; `photon` holds what is needed of y[i] and
// y[i-1], `y` the light subpath's vertices y[0..i] and `lightPdfs` their densities; y may be null
// unless the regulariser has per-technique densities) with camera vertex z[t-1] (t >= 2): the
// unweighted contribution f_z(z.wo, y.wo) * beta_y * beta_z (the caller divides by N pi r^2)
// and the pdfs of the merged path for misWeightMerge(pdfs, i).
// With lightPdfs == nullptr the fast form is used: only the camera side and the merge vertex's
// neighbours are gathered, and the light side comes from photon.misLight (lightPrefixSum).
// The fast forms hold for rrDepth 1 only (see lightPrefixSum): with a larger rrDepth the caller
// gives lightPdfs and no cameraSums.
struct Photon;
struct VertexPdfs;
// With cameraSums (cameraSums[m] = cameraPrefixSum of z[m]) the camera side is O(1) too.
// (path_templates.h)
template <class Reg>
bool merge(const Reg& reg, const Photon& photon, const PathVertex* y, const VertexPdfs* lightPdfs, const PathVertex* z,
           int t, int rrDepth, Connection& c, const double* cameraSums = nullptr);

// For light vertex y[m] of a light subpath (pdfs of y[0..m]): the sum over techniques k <= m of
// (p_k / p_VC(m+1))^2 / (pC[m] / pL[m])^2, i.e. what a merge at y[m+1] needs of the light side
// (SmallVCM's partial quantities in sum form). Recursive in m. Computed before the full path is
// known, it gives every reverse density the roulette's factor: right for rrDepth 1 (every interior
// vertex carries c_v on both sides), which is when the fast forms are used. So does cameraPrefixSum.
double lightPrefixSum(const VertexPdfs* y, int m, bool lightHittable, const MisConfig& cfg, double prev);

// The camera-side mirror of lightPrefixSum, for camera vertex z[m] (m + 1 < number of camera
// vertices): the sum over the techniques whose camera side is z[0..m'] with m' <= m, of
// (p_k / p_k(m))^2, p_k(m) the technique with camera side z[0..m]; merges included. Recursive in
// m (prev = the value for z[m-1], 0 for m = 0). Only for technique sets whose validity depends on
// the number of camera vertices alone (not PathTracer).
double cameraPrefixSum(const PathVertex* z, int m, const MisConfig& cfg, double prev);

// Gathers the pdfs of the camera subpath z[0..t-1] into pdfs (x indices s..s+t-1, those above
// readLimit + 1 skipped: see misReadLimit), n = s + t.
// The stored reverse densities get the roulette's factor here (survival: it depends on n and the
// walks' rrDepth).
inline void gatherCameraPdfs(const PathVertex* z, int t, int s, int rrDepth, PathPdfs& pdfs,
                             int readLimit = kMaxPathVertices);
inline void gatherLightPdfs(const PathVertex* y, int s, int t, int rrDepth, PathPdfs& pdfs);

inline bool reg::None::connectible(const PathVertex& v) const { return v.connectible(); }
inline bool reg::None::mergeable(const PathVertex& v) const { return v.connectible(); }

// Whether the path of connection technique (s, t) (light subpath y[0..s-1], camera subpath
// z[0..t-1]; t = 1: light tracing) is one no unregularised technique can produce: its light is a
// delta in position or direction (nothing can hit it), the camera a pinhole (nothing can hit it
// either), and every vertex between them is a smooth conductor or dielectric (nothing can
// connect there). A point light seen through glass, L S S E, is one: it reaches the image only
// through a regularised connection at a smooth vertex (--strategy-images: singular.exr).
inline bool singularPath(const PathVertex* y, int s, const PathVertex* z, int t) {
    if (s < 1 || t < 1 || !y[0].light || !y[0].light->isDelta()) return false;
    auto smooth = [](const PathVertex& v) { return v.kind == VertexKind::Surface && !v.infinite && v.deltaBsdf; };
    for (int i = 1; i < s; ++i)
        if (!smooth(y[i])) return false;
    for (int j = 1; j < t; ++j)
        if (!smooth(z[j])) return false;
    return true;
}

// A vertex where an unregularised connection can end: not a delta (a smooth BSDF, a delta light
// or camera position is one), not a surface point at infinity.
inline bool plainConnectionEnd(const PathVertex& v) {
    return v.connectible() && !(v.kind == VertexKind::Surface && v.infinite);
}

// Whether some technique of the running integrator (its connection set and whether it merges)
// produces the path of `tech` (a connection, s >= 1) without a regulariser (KD13 Theorem 1: an
// unbiased local technique needs two neighbouring non-delta vertices where it connects):
//   - the emitter hit (s = 0), where the set has it and the light can be hit (area lights, the
//     background; not a point, spot or directional light);
//   - connection k (x_{k-1} - x_k), where the set has it and both ends are plainConnectionEnd
//     (light and camera endpoints always qualify: next-event estimation, light tracing);
//   - with merging, the merge at a non-delta inner vertex x_i, 1 <= i <= n - 2 (a merge is itself
//     a regularisation that converges).
// The regularisers that touch smooth vertices only on paths nothing else samples (KD13, OPSR in
// BPT and VCM) ask this first.
bool samplableUnregularised(const Technique& tech, TechniqueSet set, bool merging);

}  // namespace lt

// The inline definitions of sampleLightVertex, connect, the gathers.
#include "integrators/transport/path_inline.h"
