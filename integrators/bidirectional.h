// Bidirectional integrators on the shared path-vertex store, one class selected by flags
// (as SmallVCM): bpt = VCM without merging, vcm (Georgiev et al. 2012), lt (light tracing only),
// ppm (merging only: progressive photon mapping). PT is integrators/path_tracer.h: the same camera walk
// with only s = 0 and s = 1.
//
// One iteration (pass): (1) W x H light subpaths into the LightPathStore, each light vertex
// connected to the camera (t = 1) and splatted; (2) the photon hash grid over the light vertices
// (vcm, ppm); (3) per pixel one camera subpath, evaluated with every connection (s, t) against the
// pixel's own light subpath (n_VC = 1) and merges against all light subpaths (n_VM = W x H).
// (A header: each regulariser policy instantiates it in its own unit, vcm.cpp for None and JG19,
// kd13_integrators.cpp for KD13, so that no unit grows past GCC's inlining limits: with KD13's
// instantiation in the same unit, BPT and VCM ran 1% more instructions.)
#pragma once
#include <tbb/parallel_for.h>
#include <atomic>
#include <fmt/core.h>
#include <stdexcept>
#include "integrators/transport/light_paths.h"
#include "integrators/integrator.h"
#include "integrators/strategy_images.h"

namespace lt {

namespace {

// A class template on the regulariser policy (integrators/transport/regularizer.h), which the loops
// pass to the walks, connect, emitterHit and merge without knowing which one runs.
template <class Reg>
class Bidirectional final : public Integrator {
public:
    Bidirectional(const RenderSettings& s, const Reg& reg) : settings_(s), reg_(reg) {
        const std::string& m = s.integrator;
        useConnections_ = m == "bpt" || m == "vcm";
        useLightTracing_ = m == "bpt" || m == "vcm" || m == "lt";
        useMerging_ = m == "vcm" || m == "ppm";
        ppm_ = m == "ppm";
        cfg_.set = m == "lt" ? TechniqueSet::LightTracer : (ppm_ ? TechniqueSet::None : TechniqueSet::Bidirectional);
        cfg_.merging = m == "vcm";
        if (!(s.radiusAlpha > 0.f && s.radiusAlpha <= 1.f))
            throw std::invalid_argument(fmt::format("radius alpha must be in (0, 1], got {}", s.radiusAlpha));
        maxDepth_ = maxDepthOf(s);
        rrDepth_ = rrDepthOf(s);
    }
    std::string name() const override { return settings_.integrator; }
    double regularisationTau() const override { return regularisationTauOf(reg_); }
    uint64_t invalidRegularisation() const override { return invalidRegularisationOf(reg_); }

    void beginPass(const Scene& scene, Film& film, uint32_t pass, WalkStats& stats) override {
        const Camera& cam = scene.camera();
        const size_t nPaths = size_t(cam.width()) * cam.height();
        if (pass == 0 && !strategies_ && !settings_.strategyImages.empty())
            strategies_ = std::make_unique<StrategyImages>(cam.width(), cam.height(), maxDepth_);
        // Default as SmallVCM: 0.003 x the radius of the geometry's bounding sphere.
        float r0 = settings_.radius > 0.f ? settings_.radius : 0.003f * scene.geometryRadius();
        radius_ = r0 * std::pow(float(pass + 1), 0.5f * (settings_.radiusAlpha - 1.f));
        cfg_.mergeArea = kPi * radius_ * radius_;
        cfg_.lightPaths = float(nPaths);
        reg_.beginIteration(uint64_t(pass) + 1, scene, cfg_);  // (before the walks)

        // (1) Light subpaths in the store's fixed chunks, each walk written into its chunk; chunk
        // order makes the store and the splats deterministic.
        store_.begin(nPaths, useMerging_);  // (merges read the compact densities)
        const size_t nChunks = store_.chunks();
        // (2, during (1)) The photon grid: each light path's records are made by the task that
        // walked it, from the light vertices a merge can use (PPM: non-delta ones, whatever the
        // regulariser; see radiance()); finish() below sorts them.
        if (useMerging_) grid_.begin(nChunks, radius_);
        splats_.resize(nChunks);
        std::atomic<uint64_t> rays{0}, contributions{0}, regularised{0};
        const int maxLight = useMerging_ || useConnections_ || useLightTracing_ ? maxDepth_ : 0;
        tbb::parallel_for(size_t(0), nChunks, [&](size_t c) {
            LightPathStore::Chunk& chunk = store_.chunk(c);
            SplatBuffer& splat = splats_[c];
            splat.clear();
            WalkStats ws;
            PathVertex camera = cameraEndpoint(scene, reg_);
            constexpr size_t kChunk = LightPathStore::kChunkPaths;
            for (size_t j = c * kChunk; j < std::min(nPaths, (c + 1) * kChunk); ++j) {
                Rng rng = Rng::forSample(settings_.seed, j, pass, /*domain=*/1);
                PathVertex* y = chunk.next();
                int ny = lightWalk(scene, reg_, rng, maxLight, rrDepth_, y, ws);
                if (useLightTracing_) lightTrace(scene, film, y, ny, camera, rng, splat, ws);
                chunk.commit(ny);
                if (useMerging_ && ppm_) grid_.add(c, uint32_t(j), store_.path(j), store_.pdfs(j), ny, cfg_, reg::kNone);
                else if (useMerging_) grid_.add(c, uint32_t(j), store_.path(j), store_.pdfs(j), ny, cfg_, reg_);
            }
            rays += ws.rays;
            contributions += ws.contributions;  // (light tracing's)
            regularised += ws.regularised;
        });
        for (size_t c = 0; c < nChunks; ++c) {
            film.mergeSplats(splats_[c]);
            if (strategies_)
                for (const auto& sp : splats_[c].splats)
                    strategies_->add(false, sp.strategyS, 1, sp.pixel, sp.value, sp.regularised, sp.singular);
        }
        stats.rays += rays.load();
        stats.contributions += contributions.load();
        stats.regularised += regularised.load();

        if (useMerging_) grid_.finish();
    }

    void renderTile(const Scene& scene, Film& film, uint32_t pass, int x0, int y0, int x1, int y1,
                    WalkStats& stats) const override {
        std::array<PathVertex, kMaxPathVertices> z;
        for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x) {
                uint32_t pixel = uint32_t(y) * film.width() + x;
                Rng rng = Rng::forSample(settings_.seed, pixel, pass, /*domain=*/0);
                Vec2 raster = Vec2(float(x), float(y)) + film.samplePixelOffset(rng.uniform2());
                Color L = radiance(scene, raster, pixel, rng, z.data(), stats);
                film.addSample(x, y, L);
                film.addSampleCount(x, y, 1);
            }
    }

    void finish(const Scene&, uint64_t passes) override {
        if (strategies_) strategies_->write(settings_.strategyImages, passes);
    }
    // Several ranks: the strategy images are added on rank 0, which writes them.
    void startRanks(const Scene& scene, dist::Cluster&, uint64_t first) override {
        if (first == 0 && !settings_.strategyImages.empty())
            strategies_ = std::make_unique<StrategyImages>(scene.camera().width(), scene.camera().height(), maxDepth_);
    }
    void shareSegment(dist::Cluster& cluster, uint64_t, bool toRoot) override {
        if (strategies_ && toRoot) gatherOnRoot(*strategies_, cluster);
    }

private:
    // t = 1: every light vertex connected to the camera and splatted.
    void lightTrace(const Scene& scene, Film& film, const PathVertex* y, int ny, const PathVertex& camera,
                    const Rng& rng, SplatBuffer& splat, WalkStats& ws) const {
        if (scene.camera().pinhole()) lightTraceTo<true>(scene, film, y, ny, camera, rng, splat, ws);
        else lightTraceTo<false>(scene, film, y, ny, camera, rng, splat, ws);
    }
    // A lens or an orthographic film (not pinhole): each connection's own camera vertex
    // (Camera::connectionPoint; the lens point from a stream split from the light path's).
    template <bool pinhole>
    void lightTraceTo(const Scene& scene, Film& film, const PathVertex* y, int ny, const PathVertex& camera,
                      const Rng& rng, SplatBuffer& splat, WalkStats& ws) const {
        [[maybe_unused]] PathVertex lensVertex;
        [[maybe_unused]] Rng lensRng;
        if constexpr (!pinhole) {
            lensVertex = camera;
            lensRng = rng.split(0x9e3779b97f4a7c15ull);
        }
        for (int s = 1; s <= ny && s <= maxDepth_; ++s) {
            if (s == 1 && (y[0].light->isDeltaPosition() || settings_.hideEmitters)) continue;  // as PT: point lights are not seen
            const PathVertex* z = &camera;
            if constexpr (!pinhole) {
                const Camera& cam = scene.camera();
                lensVertex.p = cam.connectionPoint(y[s - 1].p, cam.thinLens() ? lensRng.uniform2() : Vec2(0.5f));
                z = &lensVertex;
            }
            Connection c;
            if (!connect(scene, reg_, y, s, z, 1, rrDepth_, c, ws, kMaxPathVertices, &rng)) continue;
            const Color weighted = c.contribution * connectionWeight(c.pdfs, s, 1);
            film.splat(splat, c.raster, weighted, uint16_t(s), c.pdfs.regularised,
                       strategies_ && singularPath(y, s, z, 1));
            if constexpr (Reg::kPerTechnique) ws.countContribution(weighted, c.pdfs.regularised);
        }
    }

    Color radiance(const Scene& scene, const Vec2& raster, uint32_t pixel, Rng& rng, PathVertex* z,
                   WalkStats& stats) const {
        int nz = cameraWalk(scene, reg_, raster, rng, maxDepth_ + 1, rrDepth_, z, stats);
        const PathVertex* y = store_.path(pixel);
        const int ny = store_.length(pixel);
        const float mergeNorm = 1.f / (cfg_.mergeArea * cfg_.lightPaths);
        Color L(0.f);
        PathPdfs pdfs;
        bool allDelta = true;  // z[1..t-2] all delta (PPM counts emitter hits only then)
        // Merging: the grid's cells for every camera vertex are located (and their table entries
        // prefetched) now, and each vertex's photon ranges fetched before its connections, so
        // that the memory latency of the queries overlaps the connection work.
        std::array<HashGrid::Cells, kMaxPathVertices> cells;
        // Connections and merges at the vertices the regulariser makes connectible and mergeable
        // (without one: not at infinity, not delta; JG19 adds the smooth vertices its request makes
        // rough to both, KD13 to connections). PPM, which has no MIS to share a path between
        // techniques, merges at non-delta vertices only, the first one of the camera walk.
        auto canMergeAt = [&](const PathVertex& v) {
            return useMerging_ && !v.infinite && (ppm_ ? v.connectible() : reg_.mergeable(v));
        };
        // And the camera side of the merge weights, once per camera vertex (cameraPrefixSum), so
        // that a merge's weight costs O(1) on both sides (tested against the gathered form). The
        // fast forms hold for rrDepth 1 (path.h, merge); with a larger one merges gather.
        const bool fastMerges = rrDepth_ == 1;
        std::array<double, kMaxPathVertices> cameraSums;
        if (useMerging_ && fastMerges) {
            for (int t = 2; t <= nz; ++t)
                if (canMergeAt(z[t - 1])) grid_.locate(z[t - 1].p, cells[t - 1]);
            double prev = 0.0;
            for (int m = 0; m + 1 < nz; ++m) cameraSums[m] = prev = cameraPrefixSum(z, m, cfg_, prev);
        }
        for (int t = 2; t <= nz; ++t) {
            const PathVertex& v = z[t - 1];
            const bool canConnect = !v.infinite && reg_.connectible(v);
            const bool canMerge = canMergeAt(v);
            if (canMerge) grid_.fetch(cells[t - 1]);
            // s = 0: emitter hit.
            if (v.light && !(settings_.hideEmitters && t == 2) && (useConnections_ || (ppm_ && allDelta))) {
                Color c = emitterHit(scene, reg_, z, t, rrDepth_, pdfs);
                if (!isBlack(c))
                    record(L, c * (ppm_ ? 1.f : connectionWeight(pdfs, 0, t)), false, 0, t, pixel, false, false, stats);
            }
            if (!canConnect && !canMerge) {
                allDelta = allDelta && v.delta;
                continue;
            }
            if (useConnections_ && canConnect) {
                // s = 1: next-event estimation with a fresh light sample.
                PathVertex lv;
                Connection c;
                std::optional<Rng> side;  // (detail::lightSampleStream)
                if (t <= maxDepth_ &&
                    sampleLightVertex(scene, reg_, v.p, detail::lightSampleStream(v, t, rng, side), lv) &&
                    connect(scene, reg_, &lv, 1, z, t, rrDepth_, c, stats, kMaxPathVertices, &rng))
                    record(L, c.contribution * connectionWeight(c.pdfs, 1, t), false, 1, t, pixel, c.pdfs.regularised,
                           strategies_ && singularPath(&lv, 1, z, t), stats);
                // s >= 2: the pixel's own light subpath.
                for (int s = 2; s <= ny && s + t - 1 <= maxDepth_; ++s)
                    if (connect(scene, reg_, y, s, z, t, rrDepth_, c, stats, kMaxPathVertices, &rng))
                        record(L, c.contribution * connectionWeight(c.pdfs, s, t), false, s, t, pixel,
                               c.pdfs.regularised, strategies_ && singularPath(y, s, z, t), stats);
            }
            if (!canMerge) continue;  // (a smooth vertex a regulariser lets connections end at, not merges)
            if (useMerging_) {
                Connection c;
                grid_.scan(v.p, cells[t - 1], [&](const Photon& ph) {
                    int i = ph.depth;
                    if (i + t - 1 > maxDepth_) return;
                    // The fast form (tested against the gathered); a regulariser with per-technique
                    // densities gets the light subpath for the paths it regularises.
                    const PathVertex* ly = nullptr;  // the photon's light subpath in the store
                    const VertexPdfs* lp = nullptr;
                    if (Reg::kPerTechnique || !fastMerges) {
                        ly = store_.path(ph.path);
                        lp = store_.pdfs(ph.path);
                    }
                    if (!merge(reg_, ph, ly, lp, z, t, rrDepth_, c, fastMerges ? cameraSums.data() : nullptr))
                        return;
                    float w = ppm_ ? 1.f : misWeightMerge(c.pdfs, i, cfg_);
                    // (singular: the light's delta position, smooth vertices up to y[i-1] and from
                    // the merge vertex z[t-1] to the camera)
                    record(L, c.contribution * (w * mergeNorm), true, i + 1, t, pixel, c.pdfs.regularised,
                           strategies_ && singularPath(store_.path(ph.path), i, z, t), stats);
                });
                if (ppm_) break;  // PPM merges at the first non-delta camera vertex only
            }
            allDelta = false;
        }
        return L;
    }

    // Weight of connection technique (s, t), honouring the debugging options.
    float connectionWeight(const PathPdfs& pdfs, int s, int t) const {
        if (settings_.onlyS >= 0) return (s == settings_.onlyS && t == settings_.onlyT) ? 1.f : 0.f;
        float w = misWeight(pdfs, s, cfg_);
        return s >= 2 ? w * settings_.testMisScale : w;
    }

    // A weighted contribution, with whether its own technique was regularised and whether no
    // unregularised technique could produce it (singularPath; computed with strategy images only).
    void record(Color& L, const Color& c, bool isMerge, int s, int t, uint32_t pixel, bool regularised, bool singular,
                WalkStats& stats) const {
        L += c;
        if (strategies_) strategies_->add(isMerge, s, t, pixel, c, regularised, singular);
        if constexpr (Reg::kPerTechnique) stats.countContribution(c, regularised);
    }

    RenderSettings settings_;
    Reg reg_;
    MisConfig cfg_;
    bool useConnections_ = false, useLightTracing_ = false, useMerging_ = false, ppm_ = false;
    int maxDepth_ = 0;
    int rrDepth_ = 1;  // the walks' Russian roulette depth (rrDepthOf; path.h "Russian roulette")
    float radius_ = 0.f;
    LightPathStore store_;
    std::vector<SplatBuffer> splats_;
    HashGrid grid_;
    std::unique_ptr<StrategyImages> strategies_;
};

}  // namespace

}  // namespace lt
