// The shared path-vertex store of PT, BPT and VCM: one vertex record, one random walk, one
// connection routine, one MIS routine.
//
// Indexing of a full path (used by the MIS routine): x_0 is the light end, x_{n-1} the camera.
// A technique s takes x_0..x_{s-1} from a light subpath y and x_s..x_{n-1} from a camera
// subpath z (t = n - s camera vertices; z_0 = x_{n-1} is the camera). PT uses s = 0 (a camera
// walk hits an emitter) and s = 1 (next-event estimation); BPT every (s, t); VCM adds merges.
//
// Every vertex keeps two area densities:
//   pdfFwd: density of the vertex under the walk that created it (camera walk for z, light walk for y);
//   pdfRev: density under the walk in the other direction (filled when the next vertex is known).
#pragma once
#include <array>
#include "bsdf/surface_bsdf.h"
#include "core/rng.h"
#include "core/scene.h"

namespace lt {

inline constexpr int kMaxPathVertices = 66;  // enough for max_depth 64

enum class VertexKind : uint8_t { Camera, Light, Surface };

struct PathVertex {
    VertexKind kind = VertexKind::Surface;
    Vec3 p{0.f};
    Vec3 ng{0.f};        // geometric normal (zero for point lights, the camera, vertices at infinity)
    Frame shading;
    Vec3 wo{0.f};        // unit direction towards the previous vertex (zero at an endpoint)
    const Bxdf* bxdf = nullptr;
    const Light* light = nullptr;  // emitter at this vertex (light endpoint or emissive surface)
    Color beta{1.f};     // throughput of the subpath up to this vertex (not including its BSDF)
    AreaPdf pdfFwd, pdfRev;
    uint32_t lobe = kNone;  // lobe sampled at this vertex to continue the walk
    bool delta = false;     // continued through a delta lobe: no connection can use this vertex
    bool infinite = false;  // at infinity (environment hit, directional/constant light endpoint)
    uint16_t depth = 0;     // number of segments from the subpath's endpoint
    // Fields regularisation reads (JG19, OPSR).
    float roughness = 1.f;      // the material's scalar roughness in [0,1]
    float segmentLength = 0.f;  // length of the segment arriving at this vertex
    float pathLength = 0.f;     // sum of segment lengths from the endpoint to here

    bool onSurface() const { return kind == VertexKind::Surface || (kind == VertexKind::Light && ng != Vec3(0.f)); }
    bool connectible() const { return !delta && (kind != VertexKind::Surface || (bxdf && !bxdf->isDelta())); }
    SurfaceBsdf bsdf() const { return SurfaceBsdf(bxdf, shading, ng); }
};

// Area density at `to` of a solid-angle density at `from` (no conversion for a vertex at infinity).
AreaPdf convertDensity(SolidAnglePdf pdf, const PathVertex& from, const PathVertex& to);

struct WalkStats {
    uint64_t rays = 0;
};

// Extends a subpath whose vertex path[0] (endpoint) is filled in, starting with `ray` whose
// direction was sampled with solid-angle density pdfDir and throughput beta. Returns the number of
// vertices (including path[0]); at most maxVertices. Stops at misses (adding a vertex at infinity
// for camera walks when the scene has an environment light), absorption (Russian roulette after
// rrDepth segments) or failed BSDF sampling.
int randomWalk(const Scene& scene, Ray ray, Color beta, SolidAnglePdf pdfDir, Rng& rng, TransportMode mode,
               int maxVertices, int rrDepth, PathVertex* path, WalkStats& stats);

// Starts a camera subpath through raster position `raster`.
int cameraWalk(const Scene& scene, const Vec2& raster, Rng& rng, int maxVertices, int rrDepth,
               PathVertex* path, WalkStats& stats);

// ---- MIS ----------------------------------------------------------------------------------
// Which techniques an integrator uses; a technique is (s, t).
enum class TechniqueSet { PathTracer, Bidirectional };
inline bool allowsTechnique(TechniqueSet set, int s, int t) {
    switch (set) {
        case TechniqueSet::PathTracer: return t >= 2 && (s == 0 || s == 1);
        case TechniqueSet::Bidirectional: return t >= 1;  // the pinhole cannot be hit (t = 0)
    }
    return false;
}

// The pdfs of one full path, gathered from both subpaths (with the values at the technique's own
// connection vertices recomputed). Regularisation replaces entries here, per technique.
struct PathPdfs {
    int n = 0;
    std::array<float, kMaxPathVertices> fromLight{}, fromCamera{};  // pL[i], pC[i] (area measure)
    std::array<bool, kMaxPathVertices> delta{};
    bool lightHittable = false;  // can a camera walk reach x_0 (technique s = 0)?
};

// Power-heuristic weight of technique s: p_s^2 / sum_k p_k^2 over the techniques k of `set` that
// can sample this path, p_k = prod_{i<k} pL[i] * prod_{i>=k} pC[i]. Computed by the plain sum
// over techniques with ratios p_k / p_s (no recursion).
float misWeight(const PathPdfs& pdfs, int s, TechniqueSet set);

// ---- Connection ----------------------------------------------------------------------------
// A light endpoint for next-event estimation (technique s = 1), sampled from the scene's lights.
bool sampleLightVertex(const Scene& scene, const Vec3& refP, Rng& rng, PathVertex& out);

struct Connection {
    Color contribution{0.f};  // unweighted: beta_y * f_y * G * f_z * beta_z, visibility included
    PathPdfs pdfs;
};

// Connects the light subpath y[0..s-1] with the camera subpath z[0..t-1] (s >= 1, t >= 2 here;
// light tracing (t = 1) comes with BPT). Returns false when the connection carries nothing.
bool connect(const Scene& scene, const PathVertex* y, int s, const PathVertex* z, int t, Connection& c,
             WalkStats& stats);

// Technique s = 0: z[t-1] lies on an emitter (or at infinity). Returns Le * beta (unweighted) and
// fills the pdfs.
Color emitterHit(const Scene& scene, const PathVertex* z, int t, PathPdfs& pdfs);

// Gathers the pdfs of the camera subpath z[0..t-1] into pdfs (x indices s..s+t-1), n = s + t.
void gatherCameraPdfs(const PathVertex* z, int t, int s, PathPdfs& pdfs);
void gatherLightPdfs(const PathVertex* y, int s, PathPdfs& pdfs);

}  // namespace lt
