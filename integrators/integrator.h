// Integrators and the render loop shared by them.
#pragma once
#include <atomic>
#include <algorithm>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>
#include "core/film.h"
#include "integrators/distributed/cluster.h"
#include "integrators/guiding/trainer.h"
#include "integrators/transport/jg19.h"
#include "integrators/transport/kd13.h"
#include "integrators/transport/opsr.h"
#include "integrators/transport/path.h"
#include "core/scene.h"

namespace lt {

struct RenderSettings {
    // Set (e.g. by a signal handler) to stop after the pass in flight; RenderStats::interrupted.
    const std::atomic<bool>* stop = nullptr;
    // The processes rendering this image together (integrators/distributed/cluster.h; null: this
    // one alone). Every rank calls renderImage with the same settings; rank 0's image, stats and
    // checkpoints hold every rank's passes.
    dist::Cluster* cluster = nullptr;
    // Checkpoints: resume from `resumePasses` passes whose film state is `resumeFilm`
    // (Film::state) and integrator state `resumeIntegrator` (Integrator::state), and call
    // `checkpoint` with the passes done, the film and the integrator's state every
    // `checkpointEvery` seconds and after the last pass (--spp mode only).
    uint64_t resumePasses = 0;
    std::string resumeFilm, resumeIntegrator;
    std::function<void(uint64_t, const Film&, const std::string&)> checkpoint;
    double checkpointEvery = 0.0;
    std::string integrator = "pt";  // pt (bpt, vcm, lt, ppm: see issue 3)
    int spp = 0;                    // samples per pixel; 0 = until timeLimit
    double timeLimit = 0.0;         // seconds; 0 = no limit
    int threads = 0;                // 0 = all cores
    uint64_t seed = 0;
    int maxDepth = -1;              // segments (Mitsuba semantics); -1 = unlimited
    int rrDepth = 0;                // Russian roulette from this depth; 0: the integrator's (rrDepthOf)
    bool hideEmitters = false;
    bool quiet = false;             // no progress bar
    // PT only: "mis" (NEE and emitter hits, power heuristic), "nee" (emitter hits only where NEE
    // cannot connect: seen from the camera or after a delta lobe), "bsdf" (emitter hits only).
    std::string ptStrategy = "mis";
    std::string lightSelection = "auto";  // --light-selection: auto (lightSelectionFor), uniform, power, mix
    // VCM / PPM: initial merge radius (<= 0: 0.003 x the geometry's bounding radius, as SmallVCM)
    // and the radius reduction exponent: r_i = r_0 i^((alpha - 1) / 2).
    float radius = -1.f;
    float radiusAlpha = 0.75f;
    std::string strategyImages;  // directory for per-technique images ("" = none; integrators/strategy_images.h)
    // Debugging/tests: evaluate only connection technique (s, t), unweighted (-1 = all, weighted).
    int onlyS = -1, onlyT = -1;
    // Test hook: scales the MIS weights of connections with s >= 2 (1 = correct).
    float testMisScale = 1.f;
    // Path-space regularisation (integrators/transport/regularizer.h): none | jg19 | kd13 | opsr.
    std::string regularizer = "none";
    double regTau = -1.0;                    // JG19 tau_0; <= 0: the integrator's default (regTauDefault)
    std::string regSchedule = "consistent";  // consistent (JG19 Eq. 16) | fixed
    std::string regMis = "regularised";      // regularised (JG19 Eq. 13) | sampling (naive weights)
    bool regQuality = true;                  // JG19's sampler quality heuristic (Eqs. 17-18)
    // JG19's path diffusion heuristic (Eqs. 19-21); unset: on with the quality heuristic, off
    // without it (it scales the bound at the vertices the quality heuristic chooses; on with the
    // quality heuristic off is an error).
    std::optional<bool> regDiffusion;
    // JG19's smooth lobes: "ggx" (rough GGX with alpha_hat, JG19 Sec. 3.2) or "cone" (KD13's cone
    // with rho_cone = tau', JG19 Fig. 4).
    std::string regSpecular = "ggx";
    // JG19's bound (also with jg19,opsr): "tight" (the lobe's supremum) or "published" (Eqs. 8-9);
    // JG19's and OPSR's smooth lobes made rough: "compensate" (albedo kept) or "none".
    std::string regBound = "tight";
    std::string regEnergy = "compensate";
    // KD13 (integrators/transport/kd13.h): r_0 (<= 0: 1% of the geometry's bounding radius) and
    // lambda of r_N = r_0 N^-lambda (< 0: 1/6 for one mollified vertex, 1/12 for two).
    double regR0 = -1.0;
    double regLambda = -1.0;  // (also OPSR's consistent offset, h_N = h_0 N^-lambda; < 0: 1/6)
    // OPSR (integrators/transport/opsr.h): a constant attenuation factor (< 0: 0.01 unless a table
    // is given), a table "FILE[:SET]" ("": none), and the consistent offset.
    double regOpsrGamma = -1.0;
    std::string regOpsrTable;
    bool regOpsrConsistent = false;
    // OPSR's path tracer: a regularised BSDF sample for the emitter-hit technique at every vertex
    // the request changes, as the reference implementation (false: the walk's own sample stands
    // in where it covers the regularised lobe, opsr.h (4)).
    bool regOpsrAlwaysSample = false;
    // Every regulariser: the threshold of the roulette on the connections only it makes
    // (regularizer.h (9); < 0: reg::kDefaultTailThreshold, 0: every connection traced).
    double regTailRr = -1.0;
    // Path guiding of the path tracer (integrators/guiding/): off | radiance (Mueller et al. 2017's
    // target) | variance (Rath et al. 2020's, Eq. 21 with the MIS compensation of Eq. 25).
    std::string guiding = "off";
    double guidingBsdfFraction = 0.5;  // fixed alpha of the mixture; < 0: learned per leaf (Rath Eq. 27)
    std::string guidingCombine = "inverse-variance";  // inverse-variance | last
    double guidingSpatialThreshold = 4000.0;          // c of the spatial split c sqrt(2^k)
    double guidingMaxMb = 512.0;                      // cap on the trees' memory
    std::string guidingDump;                          // directory for the learned trees' images ("": none)
};

// Path guiding's settings (none: --guiding off); throws std::invalid_argument naming a bad one.
std::optional<guiding::GuidingSettings> guidingSettingsOf(const RenderSettings& s);

// Whether JG19's diffusion heuristic runs for these settings (unset: as the quality heuristic).
inline bool regDiffusionOf(const RenderSettings& s) { return s.regDiffusion.value_or(s.regQuality); }

// The bound tau of a regulariser's current iteration, for the statistics (0: none).
inline double regularisationTauOf(const reg::None&) { return 0.0; }
// regularizer.h (7): the policy's per-vertex values found not to be numbers (None has none).
inline uint64_t invalidRegularisationOf(const reg::None&) { return 0; }
template <class Reg>
uint64_t invalidRegularisationOf(const Reg& r) { return r.invalidValues(); }
inline double regularisationTauOf(const reg::Jg19& r) { return r.tau(); }
inline double regularisationTauOf(const reg::Kd13& r) { return r.radius(1); }  // (KD13: r_N of one vertex)
// (OPSR: N^-lambda or 1; with JG19's bound, --reg jg19,opsr: tau_N)
inline double regularisationTauOf(const reg::Opsr& r) { return r.tau() > 0.f ? double(r.tau()) : r.offsetScale(); }

// JG19's default tau_0 (Sec. 6): 30 for PT and BPT (and LT), 1000 for VCM (and PPM).
double regTauDefault(const std::string& integrator);

// The depth from which the walks play Russian roulette (path.h): s.rrDepth if set, else 1 for the
// bidirectional integrators (bpt, vcm, lt, ppm: as SmallVCM, and their MIS densities are then
// exactly the walks' densities) and 5 for the path tracer (its two techniques meet only at the
// last vertex; with the roulette from the first bounce it needed 2-20% more rays for the same
// error on SmallVCM's five boxes, docs/smallvcm-comparison.md).
int rrDepthOf(const RenderSettings& s);
// How light samples choose among the lights for `integrator` (core/scene_desc.h): uniformly (as
// Mitsuba 3) for the path tracer, the mixture of uniform and power for the bidirectional ones,
// whose light walks start where the power is. Each wins or nearly ties at equal time on the scenes
// of BENCHMARKS.md, "Light selection" (PT: uniform against power up to 86x on a spot beside an
// environment; BPT, VCM, LT: the mixture within 1.1-1.8x of the best rule on every scene, either
// pure rule up to 2.7x and 53x off).
LightSelection lightSelectionFor(const std::string& integrator);
// The longest subpath in surface vertices after its endpoint: max_depth (unset: as many as a
// path record holds).
inline int maxDepthOf(const RenderSettings& s) {
    return s.maxDepth < 0 ? kMaxPathVertices - 2 : std::min(s.maxDepth, kMaxPathVertices - 2);
}

struct RenderStats {
    uint64_t spp = 0;
    uint64_t samples = 0;
    uint64_t rays = 0;
    uint64_t invalidSamples = 0;
    double seconds = 0.0;
    // Regularisation: the contributions made (weighted, non-zero), those whose own technique
    // evaluated a regularised BSDF, and tau of the last iteration (0: no regulariser).
    uint64_t contributions = 0, regularisedContributions = 0;
    double tau = 0.0;
    // The regulariser's per-vertex values (tau', cone angle, roughness) that were not numbers:
    // their techniques were refused, nothing of them written (regularizer.h (7)).
    uint64_t invalidRegularisation = 0;
    bool interrupted = false;  // RenderSettings::stop was set: spp passes of those asked are done
    // Several MPI ranks (RenderSettings::cluster): the passes each rank rendered, and the seconds
    // rank 0 spent adding the films (every segment's reduction; its wait for the others included)
    // and, with path guiding, sharing the training's records and sums (shareSegment).
    std::vector<uint64_t> passesPerRank;
    double reduceSeconds = 0.0, guidingShareSeconds = 0.0;
    // Path guiding: iterations run (the final one included), passes spent training, and the
    // SD-tree's spatial nodes, spatial leaves, directional nodes and bytes at the end.
    int guidingIterations = 0;
    uint64_t guidingTrainingSpp = 0;
    uint64_t guidingNodes = 0, guidingLeaves = 0, guidingDirectionalNodes = 0, guidingBytes = 0;
};

// One iteration/pass of an integrator over the whole image. A pass with index `pass` draws the
// pixel samples with index `pass` (RNG streams depend only on seed, pixel, sample index).
class Integrator {
public:
    virtual ~Integrator() = default;
    virtual std::string name() const = 0;
    // Called once per pass before the tiles (light subpaths, light tracing, photon grid).
    virtual void beginPass(const Scene& scene, Film& film, uint32_t pass, WalkStats& stats) {}
    // Called once per pass after its tiles (path guiding applies the pass's records).
    virtual void endPass(const Scene& scene, Film& film, uint32_t pass) {}
    // Called once after the last pass (e.g. to write per-strategy images); with several ranks, on
    // rank 0 alone.
    virtual void finish(const Scene& scene, uint64_t passes) {}
    // The image of the passes done when it is not the film's average (path guiding combines its
    // iterations); false: the film's.
    virtual bool develop(Image& out) const { return false; }
    // Path guiding's statistics (nothing without guiding).
    virtual void guidingStats(RenderStats& stats) const {}
    // What a checkpoint must carry besides the film, between passes (path guiding's trainer; ""
    // for none); given back as RenderSettings::resumeIntegrator.
    virtual std::string state() const { return {}; }
    // The regulariser's bound tau of the current pass (0: none).
    virtual double regularisationTau() const { return 0.0; }
    // The regulariser's values found not to be numbers so far (regularizer.h (7)).
    virtual uint64_t invalidRegularisation() const { return 0; }
    // --- Several ranks (RenderSettings::cluster). An integrator whose passes read what earlier
    // passes learned (path guiding) renders in segments of passes and shares what each rank
    // learned between them. Each call is collective (every rank, the same arguments), in this
    // order: startRanks(first) before the first segment (a resumed state is rank 0's alone);
    // per segment, its passes [P, E) with E <= segmentEnd(P, ranks), then shareSegment(E, toRoot),
    // which leaves rank 0's state() the single process's after E passes where toRoot (a
    // checkpoint or the render's end follows); then, unless the render ends, continueRanks(E).
    virtual void startRanks(const Scene& scene, dist::Cluster& cluster, uint64_t first) {}
    virtual uint64_t segmentEnd(uint64_t first, int ranks) const { return UINT64_MAX; }
    virtual void shareSegment(dist::Cluster& cluster, uint64_t passes, bool toRoot) {}
    virtual void continueRanks(dist::Cluster& cluster, uint64_t passes) {}
    // Renders sample index `pass` of every pixel in rows [y0, y1) x cols [x0, x1).
    virtual void renderTile(const Scene& scene, Film& film, uint32_t pass, int x0, int y0, int x1, int y1,
                            WalkStats& stats) const = 0;
};

std::unique_ptr<Integrator> makeIntegrator(const RenderSettings& settings);
// The renderer's name for a Mitsuba integrator type (path -> pt, bdpt -> bpt, ptracer -> lt,
// sppm -> ppm); other names are returned unchanged.
std::string integratorForSceneType(const std::string& mitsubaType);
// Names accepted by makeIntegrator.
std::string supportedIntegrators();

// Runs passes until spp or timeLimit is reached, in parallel over tiles. Deterministic for a
// given seed whatever the thread count. `progress` (may be empty) is called after each pass.
// The callback may develop the image so far (developSoFar) for progressive error curves;
// time spent inside the callback is excluded from `seconds` and from the time limit.
struct Progress {
    uint64_t passesDone, passesTotal;  // passesTotal = 0 in time mode
    double seconds, timeLimit;
    uint64_t samples;
    const Film* film;
    const Integrator* integrator;
};
// The image of the passes done so far, as renderImage would return it now (a guided render's
// combination of its iterations, else the film's average).
inline Image developSoFar(const Progress& p) {
    Image img;
    if (p.integrator && p.integrator->develop(img)) return img;
    return p.film->develop(p.passesDone);
}
Image renderImage(const Scene& scene, const RenderSettings& settings, RenderStats& stats,
                  const std::function<void(const Progress&)>& progress = {});

}  // namespace lt
