// The path tracer's plain next-event estimation (integrators/transport/regularizer.h (10)): at a
// camera vertex where a policy's plainNextEvent holds, the path tracer runs reg::None's routine.
// On the camera walks of four scenes, next-event estimation at every such vertex is made twice,
// with the policy's routine and with None's, from the same light sample and the same numbers:
// the two must agree bit for bit (whether a connection is made, its contribution, its MIS weight,
// its rays and its regularised flag). The vertices where the predicate is false are counted too:
// a predicate widened to them fails (there the policy regularises, None has a delta).
#include <catch2/catch.hpp>
#include <array>
#include <cstring>
#include "core/loader.h"
#include "integrators/integrator.h"
#include "integrators/transport/jg19.h"
#include "integrators/transport/kd13.h"
#include "integrators/transport/opsr.h"
#include "integrators/transport/path.h"

using namespace lt;

namespace {

bool sameBits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }
bool sameBits(const Color& a, const Color& b) { return sameBits(a.x, b.x) && sameBits(a.y, b.y) && sameBits(a.z, b.z); }

struct Counts {
    int plain = 0, policy = 0, connected = 0;
};

// Walks `walks` camera paths with `reg` (after its first iteration's set-up, the tail roulette at
// its default) and compares the two routines at every vertex next-event estimation reaches where
// plainNextEvent holds.
template <class Reg>
Counts checkPlainVertices(const Scene& scene, Reg reg, int walks) {
    const MisConfig cfg{TechniqueSet::PathTracer};
    reg.beginIteration(1, scene, cfg);
    reg.tailThreshold = float(reg::kDefaultTailThreshold);
    const int readLimit = misReadLimit(cfg);
    Counts n;
    std::array<PathVertex, kMaxPathVertices> z;
    for (int i = 0; i < walks; ++i) {
        Rng rng = Rng::forSample(11, uint32_t(i), 0);
        WalkStats ws;
        const Vec2 raster(rng.uniform() * float(scene.camera().width()), rng.uniform() * float(scene.camera().height()));
        const int nz = cameraWalk(scene, reg, raster, rng, 9, 100, z.data(), ws, WalkPdfs::EmitterHits);
        for (int t = 2; t <= nz; ++t) {
            const PathVertex& v = z[t - 1];
            if (v.infinite || !reg.connectible(v)) continue;
            if (!reg.plainNextEvent(v)) {
                ++n.policy;
                continue;
            }
            ++n.plain;
            Rng a = Rng::forSample(13, uint32_t(i), uint32_t(t)), b = a;
            const Rng rouletteA = a, rouletteB = a;
            PathVertex ya, yb;
            Connection ca, cb;
            WalkStats sa, sb;
            const bool okA = sampleLightVertex(scene, reg, v.p, a, ya) &&
                             connect<ConnectEnds::LightToSurface>(scene, reg, &ya, 1, z.data(), t, 100, ca, sa, readLimit,
                                                                  &rouletteA);
            const bool okB = sampleLightVertex(scene, reg::kNone, v.p, b, yb) &&
                             connect<ConnectEnds::LightToSurface>(scene, reg::kNone, &yb, 1, z.data(), t, 100, cb, sb,
                                                                  readLimit, &rouletteB);
            INFO("walk " << i << ", vertex t = " << t);
            REQUIRE(okA == okB);
            CHECK(sa.rays == sb.rays);
            if (!okA) continue;
            ++n.connected;
            CHECK(sameBits(ca.contribution, cb.contribution));
            CHECK(sameBits(misWeight(ca.pdfs, 1, TechniqueSet::PathTracer), misWeight(cb.pdfs, 1, TechniqueSet::PathTracer)));
            CHECK(ca.pdfs.regularised == cb.pdfs.regularised);
        }
    }
    return n;
}

}  // namespace

TEST_CASE("Plain next-event estimation is the regulariser's own where the policy says so", "[regularizer]") {
    // Scenes whose walks meet both kinds of vertex: diffuse ones and smooth or glossy ones a
    // request changes (point-in-glass: a smooth glass sphere around the light; amber: a glass
    // block; cornell-box-ggx: glossy GGX walls; caustic-mirror: a smooth mirror).
    Counts total[4];  // opsr, jg19,opsr, jg19, kd13 over the scenes
    int policyVertices = 0;
    for (const char* name : {"cornell-box-point-in-glass", "hard/amber", "cornell-box-ggx", "hard/caustic-mirror"}) {
        SceneDesc desc = loadScene(std::string(LT_SOURCE_DIR) + "/scenes/" + name + ".xml", {{"res", "16"}});
        Scene scene(desc);
        INFO(name);
        reg::OpsrSettings o;
        o.attenuation.gamma = 0.01f;
        reg::OpsrSettings b = o;  // --reg jg19,opsr
        b.boundTau0 = 30.0;
        reg::Jg19Settings noQuality;
        noQuality.quality = noQuality.diffusion = false;
        const Counts c[4] = {checkPlainVertices(scene, reg::Opsr(o), 300), checkPlainVertices(scene, reg::Opsr(b), 300),
                             checkPlainVertices(scene, reg::Jg19(reg::Jg19Settings{}), 300),
                             checkPlainVertices(scene, reg::Kd13(reg::Kd13Settings{}), 300)};
        CHECK(checkPlainVertices(scene, reg::Jg19(noQuality), 50).plain == 0);  // (its MIS reads every ratio)
        for (int k = 0; k < 4; ++k) {
            total[k].plain += c[k].plain;
            total[k].connected += c[k].connected;
            policyVertices += c[k].policy;
        }
    }
    // Every policy took the plain routine at vertices where connections were made (the diffuse
    // ones of amber and cornell-box-ggx: on point-in-glass the light is inside the glass, on
    // caustic-mirror seen only in the mirror), and its own routine elsewhere.
    for (const Counts& c : total) {
        CHECK(c.plain > 0);
        CHECK(c.connected > 0);
    }
    CHECK(policyVertices > 0);  // (and its own routine at the others)
}
