// The regularisers' guard on their own per-vertex values (regularizer.h (7), issue 17 item 5):
// a value that is not a number (JG19's tau', KD13's cone half-angle, OPSR's roughness) refuses
// its technique and is counted; it is never read as "no request" and evaluated as if
// unregularised. Hand paths (regularizer_paths.h) with one NaN put where the value comes from.
#include <catch2/catch.hpp>
#include <limits>
#include "bsdf/bsdf.h"
#include "integrators/transport/jg19.h"
#include "integrators/transport/kd13.h"
#include "integrators/transport/opsr.h"
#include "regularizer_paths.h"

using namespace lt;
using namespace lt::test;

namespace {

const float kNaN = std::numeric_limits<float>::quiet_NaN();

// Every technique of the path through select(): the ones that contribute, and whether every
// regularised vertex of those carries a bound that is a number.
template <class Reg>
std::vector<int> contributing(HandPath& h, const Reg& r, bool& boundsAreNumbers) {
    std::vector<int> out;
    boundsAreNumbers = true;
    for (int s = 0; s < int(h.x.size()); ++s) {
        if (s == 0 && !h.x[0].light->isHittable()) continue;
        Technique t = h.technique(r, s);
        if (!r.select(t)) continue;
        out.push_back(s);
        for (int m = 0; m < 2; ++m)
            if (t.regularised[m] >= 0 && std::isnan(t.bound[m])) boundsAreNumbers = false;
    }
    return out;
}

}  // namespace

TEST_CASE("A regulariser's value that is not a number refuses its technique and is counted", "[regularizer][errors]") {
    const BxdfPtr glass = makeDielectric(1.5f), diffuse = makeDiffuse(Color(0.5f));
    Light point;
    point.type = LightType::Point;
    bool numbers = true;

    SECTION("KD13: the cone half-angle of a connection whose length is NaN") {
        reg::Kd13Settings k;
        k.r0 = 0.01;
        reg::Kd13 kd(k);
        kd.setScale(0.01, 10.0);
        kd.setTechniques(TechniqueSet::Bidirectional, false);
        kd.setIteration(1);
        // L S S E: light tracing (s = 3) mollifies x2 with eps = arctan(r / 3.5).
        HandPath a = HandPath::onAxis(point, {{1.f, glass.get()}, {1.5f, glass.get()}});
        CHECK(contributing(a, kd, numbers) == std::vector<int>{3});
        CHECK(numbers);
        CHECK(kd.invalidValues() == 0);
        // L S E with the glass at z = NaN: both connections (next-event estimation and light
        // tracing, each mollifying x1) have a NaN length, so the chosen one's cone is NaN.
        HandPath one = HandPath::onAxis(point, {{1.f, glass.get()}});
        CHECK(contributing(one, kd, numbers).size() == 1);
        CHECK(kd.invalidValues() == 0);
        HandPath b = HandPath::onAxis(point, {{kNaN, glass.get()}});
        std::vector<int> got = contributing(b, kd, numbers);
        CHECK(numbers);
        CHECK(got.empty());
        CHECK(kd.invalidValues() >= 1);
    }
    SECTION("JG19: the bound tau' = tau / sigma where the diffusion heuristic's spread sigma is NaN") {
        // L S D E of a point light in glass (test_jg19_heuristics's hand computation): with tau
        // under sqrt(q), BPT regularises the glass, x1, and the connection S-D (s = 2) contributes.
        Scene scene(mixedScene(16));
        const double camBound = scene.camera().directionPdf(scene.camera().forward()).value;
        const double q = 0.5 / kPi * camBound * sqr(5.0 / (5.0 - double(4.9f)));
        reg::Jg19Settings js;
        js.tau0 = std::sqrt(q) * 0.999;
        js.schedule = reg::Schedule::Fixed;
        js.diffusion = true;
        reg::Jg19 jg(js);
        jg.beginIteration(1, scene, MisConfig{TechniqueSet::Bidirectional});
        HandPath h = HandPath::onAxis(point, {{1.f, glass.get()}, {4.9f, diffuse.get()}});
        auto select = [&](int s, bool nanSpread) {
            Technique t = h.technique(jg, s);
            if (nanSpread)  // (after technique(), whose extend() writes the camera walk's spreads)
                for (int k = 0; k < t.t; ++k) h.z[k].regState.jg.spread = kNaN;
            const bool answer = jg.select(t);
            for (int m = 0; m < 2; ++m)
                if (t.regularised[m] >= 0) CHECK_FALSE(std::isnan(t.bound[m]));
            return std::make_pair(answer, t.regularised[0]);
        };
        CHECK(select(2, false) == std::make_pair(true, 1));
        CHECK(jg.invalidValues() == 0);
        CHECK(select(2, true).first == false);
        CHECK(jg.invalidValues() >= 1);
    }
    SECTION("OPSR: the accumulated roughness after a vertex whose roughness is NaN") {
        reg::OpsrSettings o;
        o.attenuation.gamma = 0.2f;
        o.bidirectional = true;
        reg::Opsr op(o);
        op.setTechniques(TechniqueSet::Bidirectional, false);
        // L S D S E: next-event estimation at x1 with g = 0.2 from the camera side (opsr tests).
        auto path = [&](float diffuseRoughness) {
            HandPath h = HandPath::onAxis(point, {{0.5f, glass.get()}, {2.f, diffuse.get()}, {2.5f, glass.get()}});
            for (PathVertex& v : h.x)
                if (v.bxdf) v.roughness = v.bxdf->roughness();
            h.x[2].roughness = diffuseRoughness;
            return h;
        };
        HandPath a = path(1.f);
        CHECK(contributing(a, op, numbers) == std::vector<int>{1});
        CHECK(numbers);
        CHECK(op.invalidValues() == 0);
        HandPath b = path(kNaN);
        std::vector<int> got = contributing(b, op, numbers);
        CHECK(numbers);
        CHECK(std::find(got.begin(), got.end(), 1) == got.end());  // not as if unregularised
        CHECK(op.invalidValues() >= 1);
    }
}
