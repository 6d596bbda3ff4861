// The regulariser seam's contract between select() and context() (integrators/transport/
// regularizer.h (5)): a policy's context carries a request only at the vertices select() wrote
// into Technique::regularised. connect relies on it: a connection with nothing regularised
// evaluates both ends with the plain contexts, without asking the policy (path_inline.h). Here,
// for every policy and setting the render CLI offers, on the BPT and VCM walks of four scenes
// with smooth and glossy vertices: at every connection select() accepts, each end it left
// unregularised must have the plain context (no request). A policy that puts a request at an
// end it did not name fails here (the seam's test policy that requests everywhere did, until
// its select() named both ends).
#include <catch2/catch.hpp>
#include <array>
#include <string>
#include "core/loader.h"
#include "integrators/transport/jg19.h"
#include "integrators/transport/kd13.h"
#include "integrators/transport/opsr.h"
#include "integrators/transport/path.h"

using namespace lt;

namespace {

struct Counts {
    int plainEnds = 0, regularisedEnds = 0;
};

template <class Reg>
Counts checkContexts(const Scene& scene, Reg reg, bool merging, int walks) {
    const MisConfig cfg{TechniqueSet::Bidirectional, merging, kPi * 0.01f * 0.01f, 256.f};
    reg.beginIteration(1, scene, cfg);
    Counts n;
    std::array<PathVertex, kMaxPathVertices> y, z;
    for (int i = 0; i < walks; ++i) {
        Rng rng(uint64_t(i), 23);
        WalkStats ws;
        const int ny = lightWalk(scene, reg, rng, 8, 100, y.data(), ws);
        const Vec2 raster(rng.uniform() * float(scene.camera().width()), rng.uniform() * float(scene.camera().height()));
        const int nz = cameraWalk(scene, reg, raster, rng, 8, 100, z.data(), ws);
        for (int s = 1; s <= ny; ++s)
            for (int t = 1; t <= nz; ++t) {
                const PathVertex &a = y[s - 1], &b = z[t - 1];
                // (the ends connect checks, and the integrators' own: regularizer.h (5))
                if (a.kind == VertexKind::Surface && (a.infinite || !reg.connectible(a))) continue;
                if (b.kind == VertexKind::Surface && (b.infinite || !reg.connectible(b))) continue;
                if (b.kind == VertexKind::Camera && a.infinite) continue;
                Technique tech{y.data(), s, z.data(), t};
                if (!reg.select(tech)) continue;
                for (const End end : {End::Light, End::Camera}) {
                    const int j = end == End::Light ? s - 1 : s;
                    const bool named = tech.regularised[0] == j || tech.regularised[1] == j;
                    if (named) {
                        ++n.regularisedEnds;
                        continue;
                    }
                    INFO("walk " << i << " s=" << s << " t=" << t << " end " << (end == End::Light ? "light" : "camera"));
                    CHECK(reg.context(tech, end).reg.empty());
                    ++n.plainEnds;
                }
            }
    }
    return n;
}

}  // namespace

TEST_CASE("A policy's context is plain at every connection end select() leaves unregularised", "[regularizer]") {
    Counts total;
    for (const char* name : {"cornell-box-point-in-glass", "hard/amber", "cornell-box-ggx", "hard/caustic-mirror"}) {
        const Scene scene(loadScene(std::string(LT_SOURCE_DIR) + "/scenes/" + name + ".xml", {{"res", "16"}}));
        INFO(name);
        reg::OpsrSettings o;  // --reg opsr in BPT and VCM
        o.bidirectional = true;
        reg::OpsrSettings b = o;  // --reg jg19,opsr
        b.boundTau0 = 30.0;
        reg::Jg19Settings noHeuristics;
        noHeuristics.quality = noHeuristics.diffusion = false;
        reg::Kd13Settings cone;
        for (const bool merging : {false, true}) {
            INFO("merging " << merging);
            const Counts c[] = {checkContexts(scene, reg::Opsr(o), merging, 150),
                                checkContexts(scene, reg::Opsr(b), merging, 150),
                                checkContexts(scene, reg::Jg19(reg::Jg19Settings{}), merging, 150),
                                checkContexts(scene, reg::Jg19(noHeuristics), merging, 150),
                                checkContexts(scene, reg::Kd13(cone), merging, 150)};
            for (const Counts& k : c) {
                total.plainEnds += k.plainEnds;
                total.regularisedEnds += k.regularisedEnds;
            }
        }
    }
    // (both kinds of end met: the check is not vacuous)
    CHECK(total.plainEnds > 10000);
    CHECK(total.regularisedEnds > 100);
    WARN(total.plainEnds << " plain ends, " << total.regularisedEnds << " regularised");
}
