// The path tracer's plain next-event estimation (integrators/transport/regularizer.h (10)): at a
// camera vertex where a policy's plainNextEvent says select() leaves the connection plain, the
// path tracer runs reg::None's routine. The renders must be those of the policy's own routine
// at every vertex (the test hook reg::gTestNoPlainNextEvent), bit for bit, and so must the
// counts of regularised contributions.
#include <catch2/catch.hpp>
#include <map>
#include "core/loader.h"
#include "integrators/integrator.h"
#include "integrators/transport/regularizer.h"
#include "regularizer_paths.h"

using namespace lt;
using namespace lt::test;

namespace {

struct HookOff {
    ~HookOff() { reg::gTestNoPlainNextEvent = false; }
};

// Returns the regularised contributions of the render.
uint64_t checkSame(const Scene& scene, const RenderSettings& s, const std::string& what) {
    HookOff restore;
    RenderStats a, b;
    reg::gTestNoPlainNextEvent = false;
    const Image plain = renderImage(scene, s, a);
    reg::gTestNoPlainNextEvent = true;
    const Image full = renderImage(scene, s, b);
    INFO(what);
    CHECK(differingPixels(plain, full) == 0);
    CHECK(a.rays == b.rays);
    CHECK(a.contributions == b.contributions);
    CHECK(a.regularisedContributions == b.regularisedContributions);
    return b.regularisedContributions;
}

}  // namespace

TEST_CASE("Plain next-event estimation renders as the regulariser's own routine", "[regularizer]") {
    // Scenes where next-event estimation meets both kinds of vertex: diffuse ones (plain) and
    // smooth or glossy ones a request changes (the policy's routine): point-in-glass (a smooth
    // glass sphere around the light), amber (glass block), cornell-box-ggx (glossy GGX walls) and
    // caustic-mirror (a smooth mirror).
    std::map<std::string, uint64_t> regularised;  // per configuration, over the scenes
    for (const char* name : {"cornell-box-point-in-glass", "hard/amber", "cornell-box-ggx", "hard/caustic-mirror"}) {
        SceneDesc desc = loadScene(std::string(LT_SOURCE_DIR) + "/scenes/" + name + ".xml", {{"res", "24"}});
        Scene scene(desc);
        for (const char* reg : {"opsr", "jg19", "kd13", "jg19,opsr"}) {
            RenderSettings s = settingsFor("pt", 4);
            s.regularizer = reg;
            s.maxDepth = 8;
            regularised[reg] += checkSame(scene, s, std::string(name) + " --reg " + reg);
        }
        RenderSettings s = settingsFor("pt", 4);
        s.regularizer = "jg19";
        s.regQuality = false;  // (JG19 without the quality heuristic: plainNextEvent never)
        s.maxDepth = 8;
        regularised["jg19 quality off"] += checkSame(scene, s, std::string(name) + " --reg jg19 --reg-quality off");
    }
    // Each configuration regularised some contributions (the comparison is not of plain renders).
    for (const auto& [config, count] : regularised) {
        INFO(config);
        CHECK(count > 0);
    }
}
