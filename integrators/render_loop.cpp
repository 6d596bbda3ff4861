#include <fmt/format.h>
#include <tbb/blocked_range2d.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <atomic>
#include <cstdint>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include "integrators/integrator.h"

namespace lt {

std::unique_ptr<Integrator> makePathTracer(const RenderSettings& s, const reg::None& reg);
std::unique_ptr<Integrator> makeBidirectional(const RenderSettings& s, const reg::None& reg);
std::unique_ptr<Integrator> makePathTracer(const RenderSettings& s, const reg::Jg19& reg);
std::unique_ptr<Integrator> makeBidirectional(const RenderSettings& s, const reg::Jg19& reg);
std::unique_ptr<Integrator> makePathTracer(const RenderSettings& s, const reg::Kd13& reg);
std::unique_ptr<Integrator> makeBidirectional(const RenderSettings& s, const reg::Kd13& reg);
std::unique_ptr<Integrator> makePathTracer(const RenderSettings& s, const reg::Opsr& reg);
std::unique_ptr<Integrator> makeBidirectional(const RenderSettings& s, const reg::Opsr& reg);

double regTauDefault(const std::string& integrator) {
    return integrator == "vcm" || integrator == "ppm" ? 1000.0 : 30.0;
}

int rrDepthOf(const RenderSettings& s) {
    if (s.rrDepth > 0) return s.rrDepth;
    return s.integrator == "pt" ? 5 : 1;
}

LightSelection lightSelectionFor(const std::string& integrator) {
    return integrator == "pt" ? LightSelection::Uniform : LightSelection::Mixture;
}

std::string supportedIntegrators() { return "pt, bpt, vcm, lt, ppm"; }

std::string integratorForSceneType(const std::string& t) {
    if (t == "path") return "pt";
    if (t == "bdpt") return "bpt";
    if (t == "ptracer") return "lt";
    if (t == "sppm") return "ppm";
    return t;
}

// The one place that chooses the regulariser (regularizer.h): its policy type here, and an
// instantiation of the integrators and of path_templates.h (integrators/transport/path.cpp).
namespace {
template <class Reg>
std::unique_ptr<Integrator> makeWith(const RenderSettings& s, Reg reg) {
    if constexpr (std::is_base_of_v<reg::TailRoulette, Reg>) {  // regularizer.h (9)
        if (std::isnan(s.regTailRr) || s.regTailRr > kMaxRegTailRr)  // (< 0: the default)
            throw std::invalid_argument(
                fmt::format("--reg-tail-rr must be in [0, {:g}], got {}", kMaxRegTailRr, s.regTailRr));
        reg.tailThreshold = float(s.regTailRr < 0.0 ? reg::kDefaultTailThreshold : s.regTailRr);
    } else if (s.regTailRr >= 0.0) {
        throw std::invalid_argument("--reg-tail-rr culls the connections a regulariser makes: it needs --reg jg19, kd13, "
                                    "opsr or jg19,opsr");
    }
    if (s.guiding != "off" && s.integrator != "pt")
        throw std::invalid_argument("--guiding guides the path tracer's walks: it needs --integrator pt (got '" +
                                    s.integrator + "')");
    if (s.integrator == "pt") return makePathTracer(s, reg);
    if (s.integrator == "bpt" || s.integrator == "vcm" || s.integrator == "lt" || s.integrator == "ppm")
        return makeBidirectional(s, reg);
    throw std::invalid_argument("unknown integrator '" + s.integrator + "' (supported: " + supportedIntegrators() + ")");
}

BoundForm boundFormOf(const RenderSettings& s) {
    if (s.regBound == "tight") return BoundForm::Tight;
    if (s.regBound == "published") return BoundForm::Published;
    throw std::invalid_argument(
        fmt::format("unknown regularisation bound '{}' (supported: {})", s.regBound, fmt::join(kRegBoundNames, ", ")));
}
bool compensateOf(const RenderSettings& s) {
    if (s.regEnergy == "compensate") return true;
    if (s.regEnergy == "none") return false;
    throw std::invalid_argument(
        fmt::format("unknown regularisation energy '{}' (supported: {})", s.regEnergy, fmt::join(kRegEnergyNames, ", ")));
}
}  // namespace

std::unique_ptr<Integrator> makeIntegrator(const RenderSettings& s) {
    if (s.regularizer == "none") return makeWith(s, reg::None{});
    if (s.regularizer == "jg19") {
        reg::Jg19Settings j;
        j.tau0 = s.regTau > 0.0 ? s.regTau : regTauDefault(s.integrator);
        if (s.regSchedule == "consistent") j.schedule = reg::Schedule::Consistent;
        else if (s.regSchedule == "fixed") j.schedule = reg::Schedule::Fixed;
        else throw std::invalid_argument(fmt::format("unknown regularisation schedule '{}' (supported: {})", s.regSchedule,
                                                     fmt::join(kRegScheduleNames, ", ")));
        if (s.regMis == "regularised") j.mis = reg::MisDensities::Regularised;
        else if (s.regMis == "sampling") j.mis = reg::MisDensities::Sampling;
        else throw std::invalid_argument(fmt::format("unknown regularisation MIS '{}' (supported: {})", s.regMis,
                                                     fmt::join(kRegMisNames, ", ")));
        j.quality = s.regQuality;
        if (s.regSpecular == "ggx") j.specular = reg::SpecularMode::Ggx;
        else if (s.regSpecular == "cone") j.specular = reg::SpecularMode::Cone;
        else throw std::invalid_argument(fmt::format("unknown smooth-lobe regularisation '{}' (supported: {})",
                                                     s.regSpecular, fmt::join(kRegSpecularNames, ", ")));
        j.diffusion = regDiffusionOf(s);
        j.bound = boundFormOf(s);
        j.compensate = compensateOf(s);
        if (j.diffusion && !j.quality)
            throw std::invalid_argument("the JG19 diffusion heuristic (reg_diffusion, --reg-diffusion on) needs the quality "
                                        "heuristic (reg_quality, --reg-quality on): it scales the bound at the vertices "
                                        "that heuristic chooses per path");
        return makeWith(s, reg::Jg19(j));
    }
    if (s.regularizer == "kd13") {
        if (s.integrator == "pt" && s.ptStrategy == "nee")
            throw std::invalid_argument("--reg kd13 needs --pt-strategy mis or bsdf: 'nee' drops the emitter hits after a "
                                        "smooth vertex, where KD13 lets next-event estimation contribute only for a point "
                                        "light (the light of an area light behind glass would be lost)");
        reg::Kd13Settings k;
        k.r0 = s.regR0;
        k.lambda = s.regLambda;
        return makeWith(s, reg::Kd13(k));
    }
    if (s.regularizer == "opsr" || s.regularizer == "jg19,opsr") {
        if (s.integrator == "ppm")
            throw std::invalid_argument("--reg opsr regularises connection vertices; ppm makes no connections (use pt, bpt, "
                                        "vcm or lt)");
        if (s.integrator == "pt" && s.ptStrategy == "nee")
            throw std::invalid_argument("--reg opsr needs --pt-strategy mis or bsdf: 'nee' drops the emitter hits after a "
                                        "smooth vertex, where OPSR's next-event estimation needs roughness accumulated "
                                        "before it (after only smooth vertices the light would be lost)");
        reg::OpsrSettings o;
        if (!s.regOpsrTable.empty()) {
            if (s.regOpsrGamma >= 0.0)
                throw std::invalid_argument("give either --reg-opsr-gamma (one constant factor) or --reg-opsr-table "
                                            "(per-class factors), not both");
            const auto [file, set] = splitOpsrTableSpec(s.regOpsrTable);
            o.attenuation.table = opsr::loadAttenuationTable(file, set);
        } else {
            o.attenuation.gamma = s.regOpsrGamma >= 0.0 ? float(s.regOpsrGamma) : opsr::kDefaultGamma;
        }
        o.consistent = s.regOpsrConsistent;
        if (s.regOpsrAlwaysSample && s.integrator != "pt")
            throw std::invalid_argument("--reg-opsr-always-sample chooses the path tracer's emitter-hit sample: it "
                                        "applies to --integrator pt only");
        if (s.regOpsrAlwaysSample) o.walkSampleBound = 0.f;
        o.bidirectional = s.integrator != "pt";
        o.bound = boundFormOf(s);
        o.compensate = compensateOf(s);
        o.lambda = s.regLambda;
        if (s.regLambda >= 0.0 && !s.regOpsrConsistent)
            throw std::invalid_argument("--reg-lambda with --reg opsr sets the consistent offset's exponent: it needs "
                                        "--reg-opsr-consistent");
        if (s.regularizer == "jg19,opsr") {
            // (opsr.h (6)) JG19's bound and its schedule; its heuristics and MIS modes are OPSR's here.
            o.boundTau0 = s.regTau > 0.0 ? s.regTau : regTauDefault(s.integrator);
            if (s.regSchedule != "consistent" && s.regSchedule != "fixed")
                throw std::invalid_argument(fmt::format("unknown regularisation schedule '{}' (supported: {})",
                                                        s.regSchedule, fmt::join(kRegScheduleNames, ", ")));
            o.boundConsistent = s.regSchedule == "consistent";
            if (s.regSpecular != "ggx" || s.regMis != "regularised" || s.regDiffusion.value_or(false))
                throw std::invalid_argument("--reg jg19,opsr takes JG19's bound and schedule only (--reg-tau, "
                                            "--reg-schedule): OPSR chooses the vertices and the MIS, so "
                                            "--reg-specular cone, --reg-mis sampling and --reg-diffusion on do not apply");
        }
        return makeWith(s, reg::Opsr(o));
    }
    throw std::invalid_argument(fmt::format("unknown regulariser '{}' (supported: {})", s.regularizer,
                                            fmt::join(kRegularizerNames, ", ")));
}

std::optional<guiding::GuidingSettings> guidingSettingsOf(const RenderSettings& s) {
    if (s.guiding == "off") return std::nullopt;
    guiding::GuidingSettings g;
    if (s.guiding == "radiance") g.target = guiding::Target::Radiance;
    else if (s.guiding == "variance") g.target = guiding::Target::Variance;
    else throw std::invalid_argument("unknown guiding '" + s.guiding + "' (supported: off, radiance, variance)");
    g.learnedFraction = s.guidingBsdfFraction < 0.0;
    if (!g.learnedFraction) {
        if (!(s.guidingBsdfFraction > 0.0 && s.guidingBsdfFraction <= 1.0))
            throw std::invalid_argument("--guiding-bsdf-fraction must be in (0, 1] or 'learned'");
        g.fixedFraction = float(s.guidingBsdfFraction);
    }
    if (s.guidingCombine == "inverse-variance") g.combine = guiding::Combine::InverseVariance;
    else if (s.guidingCombine == "last") g.combine = guiding::Combine::Last;
    else throw std::invalid_argument("unknown --guiding-combine '" + s.guidingCombine +
                                     "' (supported: inverse-variance, last)");
    if (!(s.guidingSpatialThreshold >= 1.0))
        throw std::invalid_argument("--guiding-spatial-threshold must be at least 1");
    g.tree.spatialThreshold = float(s.guidingSpatialThreshold);
    if (!(s.guidingMaxMb > 0.0 && s.guidingMaxMb <= 1e6))
        throw std::invalid_argument("--guiding-max-mb must be in (0, 1e6]");
    g.tree.maxBytes = size_t(s.guidingMaxMb * double(1 << 20));
    if (!s.strategyImages.empty())
        throw std::invalid_argument("--strategy-images with --guiding: the guided image combines its iterations, "
                                    "the strategy images would not sum to it");
    return g;
}

Image renderImage(const Scene& scene, const RenderSettings& settings, RenderStats& stats,
                  const std::function<void(const Progress&)>& progress) {
    dist::Cluster* cluster = settings.cluster;
    auto integrator = makeIntegrator(settings);
    const Camera& cam = scene.camera();
    Film film(cam.width(), cam.height(), scene.desc().camera.filter, scene.desc().camera.filterStddev);
    std::unique_ptr<tbb::global_control> limit;
    if (settings.threads > 0)
        limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, settings.threads);

    using Clock = std::chrono::steady_clock;
    auto start = Clock::now();
    double excluded = 0.0;  // seconds spent in the progress callback
    auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count() - excluded; };
    std::atomic<uint64_t> rays{0}, contributions{0}, regularised{0};
    uint64_t passes = settings.resumePasses;
    // (with several ranks the resumed film is rank 0's alone: the reduction adds the others')
    if (passes > 0 && (!cluster || cluster->root())) film.restore(settings.resumeFilm);
    double lastCheckpoint = 0.0;
    uint64_t savedPasses = UINT64_MAX;  // the passes the last periodic checkpoint holds
    const uint64_t totalPasses = settings.spp > 0 ? uint64_t(settings.spp) : 0;
    constexpr int kTile = 16;
    // Sample index `pass` of every pixel (a pass index is rendered by exactly one process).
    auto renderPass = [&](uint32_t pass) {
        {
            WalkStats ws;
            integrator->beginPass(scene, film, pass, ws);
            rays += ws.rays;
            contributions += ws.contributions;
            regularised += ws.regularised;
        }
        tbb::parallel_for(tbb::blocked_range2d<int>(0, cam.height(), kTile, 0, cam.width(), kTile),
                          [&](const tbb::blocked_range2d<int>& r) {
                              WalkStats ws;
                              integrator->renderTile(scene, film, pass, r.cols().begin(), r.rows().begin(),
                                                     r.cols().end(), r.rows().end(), ws);
                              rays += ws.rays;
                              if (ws.contributions) contributions += ws.contributions, regularised += ws.regularised;
                          });
        integrator->endPass(scene, film, pass);
    };
    auto report = [&](uint64_t done) {
        if (!progress) return;
        auto c0 = Clock::now();
        progress(Progress{done, totalPasses, elapsed(), settings.timeLimit, done * uint64_t(cam.width()) * cam.height(),
                          &film, integrator.get()});
        excluded += std::chrono::duration<double>(Clock::now() - c0).count();
    };
    double tau = 0.0;
    if (!cluster) {
        while (true) {
            if (totalPasses > 0 && passes >= totalPasses) break;
            if (settings.stop && settings.stop->load(std::memory_order_relaxed)) {
                stats.interrupted = true;
                break;
            }
            if (totalPasses == 0 && (settings.timeLimit <= 0.0 || elapsed() >= settings.timeLimit)) break;
            renderPass(uint32_t(passes));
            ++passes;
            report(passes);
            if (settings.checkpoint && settings.checkpointEvery > 0.0 &&
                elapsed() - lastCheckpoint >= settings.checkpointEvery) {
                settings.checkpoint(passes, film, integrator->state());
                savedPasses = passes;
                lastCheckpoint = elapsed();
            }
            if (totalPasses > 0 && settings.timeLimit > 0.0 && elapsed() >= settings.timeLimit) break;
        }
        tau = integrator->regularisationTau();
    } else {
        // Segments of passes [passes, P): the ranks take passes from the shared counter until it
        // runs out (--spp, or the integrator's segmentEnd: path guiding shares its training
        // there) or a rank closes it (rank 0: the time limit or a periodic checkpoint; any rank:
        // a stop signal). Where a checkpoint follows or the render ends, the films are added on
        // rank 0, which writes the checkpoint; the other ranks start again from an empty film
        // (the sums are exact, so the bits are the same).
        const std::string emptyFilm = film.state();  // (what the ranks other than 0 start from: nothing)
        uint64_t lastPass = 0, local = 0;  // this rank's last pass and its count
        integrator->startRanks(scene, *cluster, passes);
        while (true) {
            cluster->startPasses(passes);
            const uint64_t end =
                std::min(totalPasses > 0 ? totalPasses : UINT64_MAX, integrator->segmentEnd(passes, cluster->size()));
            uint64_t closedAt = 0;  // 1 + what this rank's close() returned; 0: it did not close
            bool checkpointDue = false, interrupted = false;
            while (true) {
                const bool stop = settings.stop && settings.stop->load(std::memory_order_relaxed);
                const bool root = cluster->root();
                const bool timeUp =
                    root && (settings.timeLimit > 0.0 ? elapsed() >= settings.timeLimit : totalPasses == 0);
                checkpointDue = root && !timeUp && !stop && settings.checkpoint && settings.checkpointEvery > 0.0 &&
                                elapsed() - lastCheckpoint >= settings.checkpointEvery;
                if (stop || timeUp || checkpointDue) {
                    const uint64_t handed = cluster->close();
                    if (handed < dist::Cluster::kClosed) closedAt = handed + 1;
                    interrupted = stop;
                    break;
                }
                const uint64_t next = cluster->nextPass();
                if (next >= std::min(end, dist::Cluster::kClosed)) break;
                renderPass(uint32_t(next));
                lastPass = next;
                ++local;
                if (root) report(next + 1);
            }
            // The passes done: every pass handed out before the counter closed (or all of the segment's).
            const uint64_t closed = cluster->max(closedAt);
            passes = closed > 0 ? std::min(end, closed - 1) : end;
            stats.interrupted = cluster->max(interrupted ? 1 : 0) != 0;
            const bool checkpoint = cluster->max(checkpointDue ? 1 : 0) != 0;
            // (a counter closed by the time limit or a signal ends the render)
            const bool more = !stats.interrupted && !(totalPasses > 0 && passes >= totalPasses) &&
                              (checkpoint || closed == 0);
            const auto s0 = Clock::now();
            integrator->shareSegment(*cluster, passes, checkpoint || !more);
            stats.guidingShareSeconds += std::chrono::duration<double>(Clock::now() - s0).count();
            if (checkpoint || !more) {
                const auto r0 = Clock::now();
                cluster->reduceFilm(film);
                stats.reduceSeconds += std::chrono::duration<double>(Clock::now() - r0).count();
            }
            if (!more) break;
            if (checkpoint) {
                if (cluster->root()) {
                    settings.checkpoint(passes, film, integrator->state());
                    savedPasses = passes;
                    lastCheckpoint = elapsed();
                } else {
                    film.restore(emptyFilm);
                }
            }
            integrator->continueRanks(*cluster, passes);
        }
        stats.passesPerRank = cluster->gather(local);
        rays = cluster->sum(rays.load());
        contributions = cluster->sum(contributions.load());
        regularised = cluster->sum(regularised.load());
        // (the bound of the last pass: its rank's)
        tau = cluster->valueAtLargest(local ? lastPass + 1 : 0, integrator->regularisationTau());
    }
    if (settings.checkpoint && passes != savedPasses && (!cluster || cluster->root()))
        settings.checkpoint(passes, film, integrator->state());  // (not twice the same)
    if (!cluster || cluster->root()) integrator->finish(scene, passes);  // (rank 0 writes every file)
    stats.seconds = elapsed();
    stats.spp = passes;
    stats.samples = passes * uint64_t(cam.width()) * cam.height();
    stats.rays = rays.load();
    stats.invalidSamples = film.invalidSamples();
    stats.contributions = contributions.load();
    stats.regularisedContributions = regularised.load();
    stats.tau = tau;
    stats.invalidRegularisation =
        cluster ? cluster->sum(integrator->invalidRegularisation()) : integrator->invalidRegularisation();
    integrator->guidingStats(stats);
    if (Image combined; integrator->develop(combined)) return combined;
    return film.develop(passes);
}

}  // namespace lt
