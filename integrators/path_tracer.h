// Unidirectional path tracer with next-event estimation and MIS: the camera walk of the shared
// path-vertex store, evaluated with the two techniques s = 0 (emitter hit) and s = 1 (NEE).
// A class template on the regulariser policy (integrators/transport/regularizer.h), which the
// loop passes to the walk, emitterHit and connect without knowing which one runs.
// (A header: each regulariser policy instantiates it in its own unit, pt.cpp for None and JG19,
// kd13_integrators.cpp for KD13, opsr_integrators.cpp for OPSR, so that no unit grows past GCC's
// inlining limits: with KD13's instantiation in the same unit, BPT and VCM ran 1% more
// instructions.)
#pragma once
#include <fmt/format.h>
#include <algorithm>
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include "integrators/guiding/dump.h"
#include "integrators/guiding/serial.h"
#include "integrators/guiding/trainer.h"
#include "integrators/integrator.h"
#include "integrators/strategy_images.h"

namespace lt {

namespace {

template <class Reg>
class PathTracer final : public Integrator {
public:
    PathTracer(const RenderSettings& s, const Reg& reg) : settings_(s), reg_(reg) {
        if (s.ptStrategy == "mis") strategy_ = Strategy::Mis;
        else if (s.ptStrategy == "nee") strategy_ = Strategy::Nee;
        else if (s.ptStrategy == "bsdf") strategy_ = Strategy::Bsdf;
        else throw std::invalid_argument("unknown PT strategy '" + s.ptStrategy + "' (supported: mis, nee, bsdf)");
        guiding_ = guidingSettingsOf(s);
        rrDepth_ = rrDepthOf(s);
    }
    std::string name() const override { return "pt"; }
    void beginPass(const Scene& scene, Film&, uint32_t pass, WalkStats&) override {
        if (guiding_ && !trainer_) startGuiding(scene, pass > 0);  // (the first pass of this run)
        if (trainer_) trainer_->beginPass(pass);
        if (pass == 0 && !strategies_ && !settings_.strategyImages.empty())
            strategies_ = std::make_unique<StrategyImages>(scene.camera().width(), scene.camera().height(),
                                                           maxDepthOf(settings_));
        // The techniques a regulariser's choice may count on: next-event estimation's connection
        // (none when only BSDF sampling runs).
        // (With KD13's cone hits, BSDF sampling alone still samples next-event estimation's
        // mollified paths: kd13.h (5).)
        const MisConfig cfg{strategy_ == Strategy::Bsdf && !kConeHits ? TechniqueSet::None : TechniqueSet::PathTracer};
        reg_.beginIteration(uint64_t(pass) + 1, scene, cfg);
    }
    double regularisationTau() const override { return regularisationTauOf(reg_); }
    uint64_t invalidRegularisation() const override { return invalidRegularisationOf(reg_); }
    void finish(const Scene& scene, uint64_t passes) override {
        if (strategies_) strategies_->write(settings_.strategyImages, passes);
        // (a checkpoint of a finished render resumed: no pass ran, the image is the saved state's)
        if (guiding_ && !trainer_ && passes > 0) startGuiding(scene, true);
        if (trainer_ && !settings_.guidingDump.empty()) guiding::dumpGuide(scene, trainer_->tree(), settings_.guidingDump);
    }
    void endPass(const Scene&, Film&, uint32_t pass) override {
        if (!trainer_) return;
        const bool keep = ranks_ && trainer_->training();
        trainer_->endPass(pass);
        if (keep) kept_.emplace(pass, trainer_->takeDeferred());
    }

    // Several ranks: the call sequence of trainer.h ("Several ranks"), one Trainer per rank.
    void startRanks(const Scene& scene, dist::Cluster& cluster, uint64_t first) override {
        if (first == 0 && !settings_.strategyImages.empty())
            strategies_ = std::make_unique<StrategyImages>(scene.camera().width(), scene.camera().height(),
                                                           maxDepthOf(settings_));
        if (!guiding_) return;
        ranks_ = true;
        if (first > 0) settings_.resumeIntegrator = cluster.broadcast(settings_.resumeIntegrator, 0);
        startGuiding(scene, first > 0);
        trainer_->deferRecords(true);
        trainer_->beginPass(uint32_t(first));
        if (!cluster.root()) trainer_->takeIterationSums();  // (a resumed iteration's sums are rank 0's)
    }
    // A training iteration's passes share their records at most every kPassesPerRank passes a
    // rank (what a rank keeps between two segments), and always where the iteration ends.
    uint64_t segmentEnd(uint64_t first, int ranks) const override {
        if (!trainer_ || !trainer_->training()) return UINT64_MAX;
        return std::min(trainer_->iterationEnd(), first + kPassesPerRank * uint64_t(ranks));
    }
    void shareSegment(dist::Cluster& cluster, uint64_t passes, bool toRoot) override {
        if (strategies_ && toRoot) gatherOnRoot(*strategies_, cluster);
        if (!trainer_) return;
        if (trainer_->training()) shareRecords(cluster, passes);
        // The iteration's sums: on every rank where the iteration ends (its pixel estimate is
        // the next one's), else on rank 0 where it writes a state or the image.
        const bool iterationEnds = passes == trainer_->iterationEnd();
        if (!iterationEnds && !toRoot) return;
        const std::vector<std::string> sums = cluster.gatherBytes(cluster.root() ? std::string() : trainer_->takeIterationSums());
        for (size_t r = 1; r < sums.size(); ++r) trainer_->addIterationSums(sums[r]);
        if (!iterationEnds) return;
        const std::string total = cluster.broadcast(cluster.root() ? trainer_->iterationSums() : std::string(), 0);
        if (!cluster.root()) trainer_->addIterationSums(total);
    }
    void continueRanks(dist::Cluster& cluster, uint64_t passes) override {
        if (!trainer_ || passes != trainer_->iterationEnd()) return;
        if (settings_.spp <= 0)  // (a time budget: rank 0's clock decides whether the next iteration trains)
            trainer_->decideNextIteration(cluster.max(cluster.root() && trainer_->nextIterationTrains() ? 1 : 0) != 0);
        trainer_->beginPass(uint32_t(passes));
        // Every rank must now hold the same tree (else it renders another image than the single
        // process): its bytes' hashes compared, once per iteration.
        guiding::ByteWriter w;
        trainer_->tree().save(w);
        const std::vector<uint64_t> hashes = cluster.gather(std::hash<std::string>{}(w.out));
        if (std::adjacent_find(hashes.begin(), hashes.end(), std::not_equal_to<>()) != hashes.end())
            throw std::logic_error(fmt::format("guiding: the ranks' SD-trees differ after iteration {} (hashes {:x})",
                                               trainer_->iterations() - 1, fmt::join(hashes, " ")));
    }
    bool develop(Image& out) const override {
        if (!trainer_) return false;
        out = trainer_->develop();
        return true;
    }
    std::string state() const override { return trainer_ ? trainer_->state() : std::string(); }
    void guidingStats(RenderStats& st) const override {
        if (!trainer_) return;
        st.guidingIterations = trainer_->iterations();
        st.guidingTrainingSpp = trainer_->trainingPasses();
        const guiding::SDTree& tree = trainer_->tree();
        st.guidingNodes = tree.nodeCount();
        st.guidingLeaves = tree.leafCount();
        st.guidingDirectionalNodes = tree.directionalNodes();
        st.guidingBytes = tree.bytes();
    }

    void renderTile(const Scene& scene, Film& film, uint32_t pass, int x0, int y0, int x1, int y1,
                    WalkStats& stats) const override {
        // Camera subpath: the camera plus at most max_depth surface vertices.
        const int maxDepth = maxDepthOf(settings_);
        // Work records made once per tile (not per sample): the walk's vertices and the emitter hits'
        // pdfs (written before they are read).
        std::array<PathVertex, kMaxPathVertices> z;
        PathPdfs pdfs;
        guiding::WalkGuide guide;
        if (trainer_) guide = trainer_->walkGuide();
        for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x) {
                uint32_t pixel = uint32_t(y) * film.width() + x;
                Rng rng = Rng::forSample(settings_.seed, pixel, pass);
                Vec2 raster = Vec2(float(x), float(y)) + film.samplePixelOffset(rng.uniform2());
                Color L = radiance(scene, raster, pixel, rng, maxDepth, z.data(), pdfs, stats, trainer_ ? &guide : nullptr);
                if (film.addSample(x, y, L) && trainer_) trainer_->addSample(pixel, L);
                film.addSampleCount(x, y, 1);
            }
    }

    // Flattened: sampleLightVertex, connect and the MIS weight (integrators/transport/path_inline.h)
    // are compiled into this loop, specialised for s = 1, readLimit = 0 and its known ends (ConnectEnds).
    // Each of the three measured alone against its plain form (PT, cornell-box and glass-sphere box;
    // paired whole-process runs, 1 thread, A/B medians): readLimit 0.94 of the time (every pair
    // faster) and -6.4% / -4.7% instructions; ConnectEnds and flatten 0.95-1.00 and 0.97-1.00 of the
    // time (within the shared machine's noise) and -2.2% / -1.6%, -2.4% / -1.7% instructions. All kept:
    // none touches the regulariser's hooks, and without the last two PT would run ~2% more
    // instructions than before the seam.
    // (`guide`: path guiding's walk state, null without guiding.)
    [[gnu::flatten]] Color radiance(const Scene& scene, const Vec2& raster, uint32_t pixel, Rng& rng, int maxDepth,
                                    PathVertex* z, PathPdfs& pdfs, WalkStats& stats,
                                    guiding::WalkGuide* guide = nullptr) const {
        int nz = cameraWalk(scene, reg_, raster, rng, maxDepth + 1, rrDepth_, z, stats, WalkPdfs::EmitterHits, guide);
        Color L(0.f);
        const int readLimit = misReadLimit(MisConfig{TechniqueSet::PathTracer});
        // Path guiding's training: what each vertex's techniques found (Trainer records).
        const bool recording = guide && trainer_->training();
        std::array<Color, kMaxPathVertices> found;
        for (int t = 2; t <= nz; ++t) {
            const PathVertex& v = z[t - 1];
            const Color before = L;
            // s = 0: the walk hit an emitter (t - 1 segments).
            // (a walk step through a delta lobe is not a path next-event estimation makes)
            bool neeImpossible = t == 2 || !reg_.connectible(z[t - 2]) || z[t - 2].delta;
            if (v.light && !(settings_.hideEmitters && t == 2) && (strategy_ != Strategy::Nee || neeImpossible)) {
                Color c = emitterHit(scene, reg_, z, t, rrDepth_, pdfs, readLimit);
                if (!isBlack(c)) {
                    const Color weighted =
                        c * (strategy_ == Strategy::Mis ? misWeight(pdfs, 0, TechniqueSet::PathTracer) : 1.f);
                    // (regularizer.h (6): the walk's own hit is a regularised technique where the
                    // regulariser lets the walk's sample stand for its own)
                    record(L, weighted, 0, t, pixel, kEmitterSample && pdfs.regularised, false, stats);
                }
            }
            // s = 1: next-event estimation (t segments).
            if (strategy_ != Strategy::Bsdf && t <= maxDepth && !v.infinite && reg_.connectible(v)) {
                // (regularizer.h (10): where the policy leaves every such connection plain, the
                // plain routine, whose records no out-of-line call sees)
                if (reg_.plainNextEvent(v))
                    nextEvent(scene, reg::kNone, z, t, rng, readLimit, L, pixel, stats, guide);
                else nextEvent(scene, reg_, z, t, rng, readLimit, L, pixel, stats, guide);
            }
            // s = 0 through z[t-1]: a delta light in the cone of a BSDF sample (regularizer.h (8): KD13).
            if constexpr (kConeHits) {
                if ((strategy_ == Strategy::Bsdf || (strategy_ == Strategy::Mis && reg_.coneHitsCompete())) &&
                    t <= maxDepth && !v.infinite && reg_.coneHitsAt(v))
                    coneHits(scene, z, t, rng, readLimit, L, pixel, stats);
            }
            // s = 0 through z[t-1] with the regulariser's own BSDF sample (regularizer.h (6): OPSR).
            if constexpr (kEmitterSample) {
                BsdfContext ctx;
                if (t <= maxDepth && !v.infinite && reg_.emitterSample(z, t, ctx))
                    regularisedEmitterHit(scene, z, t, ctx, rng, pdfs, readLimit, L, pixel, stats);
            }
            if (recording) found[t - 1] = L - before;
        }
        if (recording) recordGuiding(z, nz, found.data(), pixel, *guide);
        return L;
    }

private:
    // Next-event estimation at z[t-1] with policy `reg` (reg_, or reg::None where reg_ leaves it plain).
    template <class R>
    void nextEvent(const Scene& scene, const R& reg, const PathVertex* z, int t, Rng& rng, int readLimit, Color& L,
                   uint32_t pixel, WalkStats& stats, const guiding::WalkGuide* guide) const {
        // Locals no call sees where the chain is inline (reg::None's): their default
        // initialisation and the fields connect does not read are dropped by the compiler, the
        // rest stay in registers. (A policy's out-of-line select() sees them: regularizer.h (10).)
        PathVertex y;
        Connection conn;
        std::optional<Rng> side;  // (detail::lightSampleStream)
        if (sampleLightVertex(scene, reg, z[t - 1].p, detail::lightSampleStream(z[t - 1], t, rng, side), y) &&
            connect<ConnectEnds::LightToSurface>(scene, reg, &y, 1, z, t, rrDepth_, conn, stats, readLimit, &rng,
                                                 guide)) {
            const Color weighted =
                conn.contribution * (strategy_ == Strategy::Mis ? misWeight(conn.pdfs, 1, TechniqueSet::PathTracer) : 1.f);
            record(L, weighted, 1, t, pixel, conn.pdfs.regularised, strategies_ && singularPath(&y, 1, z, t), stats);
        }
    }

    // The emitter-hit technique through z[t-1] drawn with the regularised context ctx
    // (regularizer.h (6)): one BSDF sample on a stream split from the walk's (whose numbers, and so
    // every other contribution, stay as they were) and one ray; a light it hits is written into
    // z[t] for emitterHit (its density there is the regularised BSDF's, at the two vertex
    // positions, as next-event estimation evaluates it), and the walk's vertex is put back.
    void regularisedEmitterHit(const Scene& scene, PathVertex* z, int t, const BsdfContext& ctx, const Rng& rng,
                               PathPdfs& pdfs, int readLimit, Color& L, uint32_t pixel, WalkStats& stats) const {
        PathVertex& v = z[t - 1];
        Rng side = rng.split(uint64_t(t) + 0x9e3779b97f4a7c15ull);
        BsdfSample bs;
        const float uLobe = side.uniform();
        const Vec2 u = side.uniform2();
        // Only a light the ray hits counts: with none it can hit (and none at infinity) there is
        // nothing to write, so the direction is drawn first, and the densities, the weight and the
        // ray only where it may reach a light (the full sample draws the same direction).
        const bool lightsAtInfinity = !scene.infiniteLights().empty();
        if (!lightsAtInfinity && (!v.bsdf().sample(v.wo, uLobe, u, ctx.directionOnlyCopy(), bs) ||
                                  !scene.mayHitEmitter(scene.spawnRay(v.p, v.ng, bs.wi))))
            return;
        if (!v.bsdf().sample(v.wo, uLobe, u, ctx, bs) || isBlack(bs.weight) || (bs.lobe & kDelta)) return;
        // The hit goes into a vertex of its own; only a light's is copied into z[t] (the rare case).
        PathVertex e;
        const Ray ray = scene.spawnRay(v.p, v.ng, bs.wi);
        ++stats.rays;
        if (stats.log) stats.log->addClosest(ray, v.depth);
        if (scene.intersect(ray, e)) {
            if (!e.light) return;
            const Vec3 back = v.p - e.p;
            const float len = glm::length(back);
            const Vec3 wo = len > 0.f ? back * (1.f / len) : -ray.d;
            const BsdfEval ev = v.bsdf().eval(v.wo, -wo, ctx);
            const SolidAnglePdf pdf = ev.pdfFwd.value > 0.f ? ev.pdfFwd : bs.pdfFwd;
            e.init(reg_, VertexKind::Surface, &v, wo, len, v.beta * bs.weight, AreaPdf(0.f),
                   convertDensity(pdf, e, wo, sqr(len)));
        } else if (lightsAtInfinity) {
            detail::initAtInfinity(scene, reg_, e, v, ray, v.beta * bs.weight, bs.pdfFwd);
        } else {
            return;
        }
        const PathVertex saved = z[t];
        z[t] = e;
        const Color c = emitterHit(scene, reg_, z, t + 1, rrDepth_, pdfs, readLimit, true);
        z[t] = saved;
        if (!isBlack(c)) {
            const float w = strategy_ == Strategy::Mis ? misWeight(pdfs, 0, TechniqueSet::PathTracer) : 1.f;
            record(L, c * w, 0, t + 1, pixel, true, false, stats);
        }
    }

    // The emitter-hit technique through the mollified smooth vertex z[t-1] (regularizer.h (8),
    // kd13.h (5)): one sample of z[t-1]'s delta BSDF on a stream split from the walk's (so every
    // other contribution stays as it was), and each delta light on the side of the sampled lobe
    // goes through connect, which evaluates the cone of next-event estimation's connection to it
    // (nothing outside the cone, before the shadow ray) and writes the path's densities with the
    // cone hit's among them. The value is next-event estimation's for that light times
    // sel / P(lobe): the light found by the lobe's cone instead of picked with probability sel.
    void coneHits(const Scene& scene, const PathVertex* z, int t, const Rng& rng, int readLimit, Color& L,
                  uint32_t pixel, WalkStats& stats) const {
        const PathVertex& v = z[t - 1];
        Rng side = rng.split(uint64_t(t) + 0x632be59bd9b4e019ull);
        BsdfSample bs;
        const float uLobe = side.uniform();
        if (!v.bsdf().sample(v.wo, uLobe, side.uniform2(), kRadianceContext, bs) || !(bs.lobe & kDelta) ||
            !(bs.pdfFwd.value > 0.f))
            return;
        const float sampleSide = glm::dot(v.shading.n, bs.wi);
        for (const uint32_t li : reg_.deltaLights()) {
            PathVertex y;
            if (!lightEndpoint(scene, reg_, li, v.p, Vec2(0.5f), y)) continue;  // (a delta light ignores u)
            if (!(glm::dot(v.shading.n, y.p - v.p) * sampleSide > 0.f)) continue;  // the other lobe's cone
            Connection conn;
            if (!connect<ConnectEnds::LightToSurface>(scene, reg_, &y, 1, z, t, rrDepth_, conn, stats, readLimit, &rng))
                continue;
            const float sel = scene.lightDistribution().probability(li);
            const Color c = conn.contribution * (sel / bs.pdfFwd.value);
            const float w = strategy_ == Strategy::Mis ? misWeight(conn.pdfs, 0, TechniqueSet::PathTracer) : 1.f;
            record(L, c * w, 0, t + 1, pixel, true, strategies_ && singularPath(&y, 1, z, t), stats);
        }
    }

    // A weighted contribution of technique (s, t), with whether its own technique was regularised
    // and whether no unregularised technique could produce it (singularPath; with strategy images).
    void record(Color& L, const Color& c, int s, int t, uint32_t pixel, bool regularised, bool singular,
                WalkStats& stats) const {
        L += c;
        if (strategies_) strategies_->add(false, s, t, pixel, c, regularised, singular);
        if constexpr (Reg::kPerTechnique) stats.countContribution(c, regularised);
    }

    // Path guiding's records of one camera sample (Trainer): for each vertex j where guiding
    // applies (guided, or not yet because its leaf has learned nothing) and the walk went on to
    // z[j+1], with S the contributions found from z[j+1] on (S = beta_j f cos L_i / p, p the
    // density the direction was drawn with: the mixture's times the roulette's survival):
    //   radiance target (Mueller 2017): L_i / p, L_i = S / beta_{j+1};
    //   variance target (Rath 2020 Eqs. 21, 25, 28): (beta_j f cos L_i w_g / I~)^2 / p
    //     = (S w_g / I~)^2 p, w_g the guide's balance weight (1 before the leaf is guided) and I~
    //     the pixel estimate;
    //   and for the learned fraction (Rath Eq. 27) the integrand weighted by the relative pixel
    //   contribution, f cos L_i beta_j / I~ = S p / I~, with the three densities.
    // (Channel means throughout.)
    [[gnu::noinline]] void recordGuiding(const PathVertex* z, int nz, const Color* found, uint32_t pixel,
                                         const guiding::WalkGuide& guide) const {
        auto& out = trainer_->buffer();
        const bool variance = trainer_->settings().target == guiding::Target::Variance;
        const float pixelEstimate = trainer_->pixelEstimate(pixel);
        Color S(0.f);
        for (int j = nz - 2; j >= 1; --j) {
            S += found[j + 1];
            const PathVertex& v = z[j];
            if (!guide.leaf[j] || v.delta) continue;
            const bool guided = guide.guided(j);
            const float alpha = guided ? guide.alpha[j] : 1.f;
            const float pBsdf = guide.pdfBsdf[j], pGuide = guide.pdfGuide[j];
            const float pMix = guided ? guide.mix(j, pBsdf, pGuide) : pBsdf;
            const float p = pMix * survival(v, v.depth, rrDepth_);
            if (!(p > 0.f)) continue;
            const float s = (S.x + S.y + S.z) / 3.f;
            guiding::Record r;
            r.p = v.p;
            r.d = -z[j + 1].wo;
            if (variance) {
                const float c = s * (guided ? (1.f - alpha) * pGuide / pMix : 1.f) / pixelEstimate;
                r.value = c * c * p;
            } else {
                const Color& b = z[j + 1].beta;
                float li = 0.f;
                int n = 0;
                for (int c = 0; c < 3; ++c)
                    if (b[c] > 0.f) li += S[c] / b[c], ++n;
                r.value = n > 0 ? li / float(n) / p : 0.f;
            }
            r.product = s * p / pixelEstimate;
            r.bsdfPdf = pBsdf;
            r.guidePdf = pGuide;
            r.mixturePdf = p;
            r.learnFraction = guided;
            out.emplace_back(pixel, r);
        }
    }

    // Several ranks: the records of this segment's passes [.., passes) applied on every rank in
    // pass order, each pass's broadcast by the rank that rendered it (one pass's records in
    // flight at a time).
    void shareRecords(dist::Cluster& cluster, uint64_t passes) {
        const uint64_t first = passes - std::min<uint64_t>(passes, kPassesPerRank * uint64_t(cluster.size()));
        std::vector<uint64_t> mine;
        for (const auto& [pass, bytes] : kept_) mine.push_back(pass);
        guiding::ByteWriter w;
        w.putVector(mine);
        const std::vector<std::string> lists = cluster.gatherBytes(w.out);
        // Rank 0 names the owner of each pass; every rank then takes part in each broadcast.
        std::vector<uint64_t> owner;
        if (cluster.root()) {
            for (size_t r = 0; r < lists.size(); ++r) {
                guiding::ByteReader rd(lists[r]);
                for (const uint64_t pass : rd.getVector<uint64_t>()) {
                    if (pass < first || pass >= passes)
                        throw std::logic_error("guiding: a rank kept pass " + std::to_string(pass) + " outside the segment");
                    owner.resize(std::max<size_t>(owner.size(), pass - first + 1), UINT64_MAX);
                    owner[pass - first] = r;
                }
            }
        }
        guiding::ByteWriter ow;
        ow.putVector(owner);
        const std::string owners = cluster.broadcast(ow.out, 0);
        owner = guiding::ByteReader(owners).getVector<uint64_t>();
        for (size_t i = 0; i < owner.size(); ++i) {
            if (owner[i] == UINT64_MAX) continue;  // (a pass before this segment's, applied already)
            const uint64_t pass = first + i;
            const bool own = owner[i] == uint64_t(cluster.rank());
            const std::string bytes = cluster.broadcast(own ? kept_.at(pass) : std::string(), int(owner[i]));
            trainer_->applyDeferred({bytes});
        }
        kept_.clear();
    }

    // The trainer of this run, from the checkpoint's state where the run resumes one.
    void startGuiding(const Scene& scene, bool resumed) {
        trainer_ = std::make_unique<guiding::Trainer>(
            *guiding_, scene.boundsCenter(), scene.boundsRadius() * 1.001f + 1e-4f, scene.camera().width(),
            scene.camera().height(), uint64_t(std::max(0, settings_.spp)), settings_.timeLimit, settings_.seed);
        if (resumed) trainer_->restore(settings_.resumeIntegrator);
    }

    static constexpr bool kConeHits = requires { Reg::kConeHits; };
    static constexpr bool kEmitterSample = requires { Reg::kEmitterSample; };
    enum class Strategy { Mis, Nee, Bsdf };
    RenderSettings settings_;
    int rrDepth_ = 1;  // the walks' Russian roulette depth (rrDepthOf; path.h "Russian roulette")
    Reg reg_;
    Strategy strategy_ = Strategy::Mis;
    std::unique_ptr<StrategyImages> strategies_;  // --strategy-images
    std::optional<guiding::GuidingSettings> guiding_;  // --guiding (none: off)
    std::unique_ptr<guiding::Trainer> trainer_;
    // Several ranks (startRanks): this rank's passes of the running segment, as Trainer::takeDeferred gives them.
    static constexpr uint64_t kPassesPerRank = 4;
    bool ranks_ = false;
    std::map<uint64_t, std::string> kept_;
};

}  // namespace

}  // namespace lt
