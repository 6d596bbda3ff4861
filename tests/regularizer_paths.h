// Fixtures shared by the regularisers' tests (test_jg19*.cpp, test_kd13.cpp, test_opsr*.cpp and
// others): a box with glossy, smooth glass and mirror surfaces, paths built by hand on a line, and
// every connection of two walked subpaths.
#pragma once
#include <array>
#include <catch2/catch.hpp>
#include <string>
#include <vector>
#include "core/image.h"
#include "integrators/integrator.h"
#include "integrators/transport/light_paths.h"
#include "integrators/transport/path_templates.h"
#include "scene_builders.h"

namespace lt::test {

// The OPSR authors' reference attenuation file, beside the project (loaded by path, never copied;
// a test that needs it skips with a warning where a clone lacks ../shared/data/opsr).
inline const std::string kOpsrReferenceFile =
    std::string(LT_SHARED_DIR) + "/data/opsr/opsr-reference-attenuation.json";

// Glossy panel (GGX alpha 0.05), a smooth glass sphere and a smooth mirror ball in the box.
inline SceneDesc mixedScene(int res) {
    SceneDesc d = cornellBox(res, makeRoughConductor(MicrofacetType::GGX, 0.05f, 0.05f, Color(0.2f, 0.9f, 1.1f),
                                                     Color(3.9f, 2.4f, 2.1f), Color(1.f)));
    d.bsdfs.push_back(makeDielectric(1.5f));
    d.spheres[0].bsdf = int(d.bsdfs.size()) - 1;  // the box's sphere: glass
    d.bsdfs.push_back(makeConductor(Color(0.2f), Color(3.f), Color(1.f)));
    d.meshes.push_back(smoothSphere(Vec3(-0.45f, -0.65f, 0.2f), 0.3f, 8, 12, int(d.bsdfs.size()) - 1));
    return d;
}

// The same with a point light inside the glass sphere besides the area light: its paths
// (L S ...) are the ones no connection samples well.
inline SceneDesc mixedSceneWithPointInGlass(int res) {
    SceneDesc d = mixedScene(res);
    EmitterDesc point;
    point.type = EmitterType::Point;
    point.position = d.spheres[0].center;
    point.value = Color(3.f);
    d.emitters.push_back(point);
    // Lights chosen by power: the point light, whose paths only a regulariser renders, starts most
    // light walks and gets most light samples (the tests' floors on regularised paths count on it).
    d.lightSelection = LightSelection::Power;
    return d;
}

// The Russian roulette depth of the callers' walks (100: beyond every path here, so no roulette);
// the routines below must be given the same (path.h, "Russian roulette").
inline constexpr int kWalkRrDepth = 100;

// Every connection (s, t), s + t >= 3, of a light subpath y[0..ny-1] with a camera subpath
// z[0..nz-1] (t = 1: with the camera endpoint cam) that carries something: fn(s, t, zz, c), zz the
// camera side used.
template <class Reg, class Fn>
void forEachConnection(const Scene& scene, const Reg& jg, const PathVertex* y, int ny, const PathVertex* z,
                       int nz, const PathVertex& cam, WalkStats& ws, Fn&& fn) {
    for (int s = 1; s <= ny; ++s)
        for (int t = 1; t <= nz; ++t) {
            if (s + t < 3) continue;
            const PathVertex* zz = t == 1 ? &cam : z;
            Connection c;
            if (connect(scene, jg, y, s, zz, t, kWalkRrDepth, c, ws)) fn(s, t, zz, c);
        }
}

// Every merge of a light vertex y[m] (m >= 1, on a surface a merge may use: smooth ones made
// rough included) at a camera vertex z[t-1] (t >= 2) that carries something: fn(m, t, photon, c,
// xs), xs the merged path's vertices x_0..x_{n-1} (y[0..m-1], then z[t-1]..z[0]).
template <class Reg, class Fn>
void forEachMerge(const Reg& jg, const PathVertex* y, int ny, const PathVertex* z, int nz, Fn&& fn) {
    for (int m = 1; m < ny; ++m) {
        if (!jg.connectible(y[m]) || y[m].kind != VertexKind::Surface) continue;
        std::vector<VertexPdfs> lp;
        for (int k = 0; k <= m; ++k) lp.push_back(VertexPdfs::of(y[k]));
        Photon ph;
        ph.set(0, y[m], y[m - 1], y[0].light->isHittable(), 0.0);
        for (int t = 2; t <= nz; ++t) {
            Connection c;
            if (!merge(jg, ph, y, lp.data(), z, t, kWalkRrDepth, c)) continue;
            std::vector<const PathVertex*> xs;
            for (int k = 0; k < m; ++k) xs.push_back(&y[k]);
            for (int k = t - 1; k >= 0; --k) xs.push_back(&z[k]);
            fn(m, t, ph, c, std::move(xs));
        }
    }
}

// What the regularisers' brute-force MIS weights share: a path's vertices, its gathered sampling
// densities (tested elsewhere), and the power heuristic over the running integrator's techniques
// from each technique's factor on its density.
struct PathWeights {
    std::vector<const PathVertex*> x;  // x_0 (light) .. x_{n-1} (camera)
    const PathPdfs& P;
    MisConfig cfg;
    // A merge at x_i: the light vertex y[i] merged at the camera vertex x_i. The light subpath's
    // own vertex is x_{i-1}'s neighbour (as its walk saw it), and the camera vertex looks towards
    // y[i-1] along y[i].wo (as merge evaluates it).
    int mergeAt = -1;
    const PathVertex* mergeLight = nullptr;

    int n() const { return int(x.size()); }
    Vec3 dir(int from, int to) const {
        if (mergeLight && from == mergeAt - 1 && to == mergeAt) return glm::normalize(mergeLight->p - x[from]->p);
        if (mergeLight && from == mergeAt && to == mergeAt - 1) return mergeLight->wo;
        return glm::normalize(x[to]->p - x[from]->p);
    }
    // p_k / p_base of the gathered sampling densities (a delta vertex's 0 counts 1).
    double ratio(int k, int base) const {
        double r = 1.0;
        auto rm = [](float p) { return p != 0.f ? double(p) : 1.0; };
        for (int i = base; i < k; ++i) r *= rm(P.fromLight[i]) / rm(P.fromCamera[i]);
        for (int i = k; i < base; ++i) r *= rm(P.fromCamera[i]) / rm(P.fromLight[i]);
        return r;
    }
    // The power-heuristic weight of connection technique s, or of the merge at mergeAt (s then
    // ignored): connection(k) and merge(i) give technique k's (the merge at x_i's) factor on its
    // sampling density, < 0 where it cannot produce the path.
    template <class Connection, class Merge>
    double powerWeight(int s, Connection&& connection, Merge&& merge) const {
        const int N = n(), base = mergeAt >= 0 ? mergeAt : s;
        const double vm = double(cfg.mergeArea) * double(cfg.lightPaths);
        double sum = 0.0, own = 0.0;
        auto add = [&](double term, bool mine) {
            sum += term * term;
            if (mine) own = term * term;
        };
        for (int k = 0; k < N; ++k) {
            if (!allowsTechnique(cfg.set, k, N - k)) continue;
            if (k == 0 && !(x[0]->light && x[0]->light->isHittable())) continue;
            const double c = connection(k);
            if (c >= 0.0) add(ratio(k, base) * c, mergeAt < 0 && k == s);
        }
        for (int i = 1; cfg.merging && i <= N - 2; ++i) {
            const double c = merge(i);
            const double density = vm * (P.fromLight[i] != 0.f ? double(P.fromLight[i]) : 1.0);
            if (c >= 0.0) add(ratio(i, base) * density * c, i == mergeAt);
        }
        return sum > 0.0 ? own / sum : 0.0;
    }
};

// Render settings of the regularisers' render tests: 2 threads, seed 5, max depth 6.
inline RenderSettings settingsFor(const std::string& integrator, int spp) {
    RenderSettings s;
    s.integrator = integrator;
    s.spp = spp;
    s.threads = 2;
    s.seed = 5;
    s.maxDepth = 6;
    s.quiet = true;
    return s;
}

// The number of pixels in which two images of the same size differ (bit for bit).
inline size_t differingPixels(const Image& a, const Image& b) {
    size_t differ = 0;
    for (size_t i = 0; i < a.pixels.size(); ++i) differ += !(a.pixels[i] == b.pixels[i]);
    return differ;
}

// PT, BPT and VCM (3 spp) with the regulariser `setReg` sets on the settings, against without
// one: the images must not differ by a single bit, nothing may count as regularised, and the
// renders must have contributions to compare (Catch checks); check(stats) adds the caller's.
template <class SetReg, class Check>
void checkBitIdenticalToNone(const Scene& scene, SetReg setReg, Check check) {
    for (const char* integrator : {"pt", "bpt", "vcm"}) {
        INFO(integrator);
        RenderSettings plain = settingsFor(integrator, 3), reg = plain;
        setReg(reg);
        RenderStats a, b;
        const Image ia = renderImage(scene, plain, a), ib = renderImage(scene, reg, b);
        REQUIRE(ia.pixels.size() == ib.pixels.size());
        CHECK(differingPixels(ia, ib) == 0);
        CHECK(b.regularisedContributions == 0);
        CHECK(b.contributions > 1000);
        check(b);
    }
}

// The mean over channels and pixels of the crop (x0, y0, cw, ch) of an image of width w.
inline double cropMean(const Image& img, int w, int x0, int y0, int cw, int ch) {
    double sum = 0.0;
    for (int yy = y0; yy < y0 + ch; ++yy)
        for (int xx = x0; xx < x0 + cw; ++xx) {
            const Color c = img.pixels[size_t(yy) * w + xx];
            sum += (double(c.x) + c.y + c.z) / 3.0;
        }
    return sum / (cw * ch);
}

// A path built by hand (x_0 the light end), split into the records of any technique as the walks
// write them (the policy's start and extend included).
struct HandPath {
    std::vector<PathVertex> x;
    std::array<PathVertex, kMaxPathVertices> y, z;
    void add(VertexKind kind, const Vec3& p, const Bxdf* bxdf, const Light* light = nullptr,
             const Vec3& ng = Vec3(0.f, 0.f, 1.f)) {
        PathVertex v;
        v.p = p;
        v.ng = ng;
        v.shading = Frame(ng);
        v.bxdf = bxdf;
        v.light = light;
        v.deltaBsdf = bxdf && bxdf->isDelta();
        v.kind = kind;
        x.push_back(v);
    }
    // A path on the z axis: `light` at the origin, surfaces at (0, 0, z) (normals +z), the camera at
    // (0, 0, cameraZ), so every length is known.
    static HandPath onAxis(const Light& light, const std::vector<std::pair<float, const Bxdf*>>& surfaces,
                           float cameraZ = 5.f) {
        HandPath h;
        h.add(VertexKind::Light, Vec3(0.f), nullptr, &light);
        for (const auto& [zpos, b] : surfaces) h.add(VertexKind::Surface, Vec3(0.f, 0.f, zpos), b);
        h.add(VertexKind::Camera, Vec3(0.f, 0.f, cameraZ), nullptr);
        return h;
    }
    // The technique with s light vertices (s = 0: the emitter hit, x_0 on the light's surface).
    template <class Reg>
    Technique technique(const Reg& jg, int s) {
        const int n = int(x.size());
        // (wo, segmentLength and pathLength as PathVertex::init writes them.)
        auto link = [&](PathVertex& v, PathVertex* prev) {
            v.wo = prev ? glm::normalize(prev->p - v.p) : Vec3(0.f);
            v.segmentLength = prev ? glm::length(prev->p - v.p) : 0.f;
            v.pathLength = prev ? prev->pathLength + v.segmentLength : 0.f;
            if (prev) jg.extend(v, *prev);
            else jg.start(v);
        };
        for (int k = 0; k < s; ++k) {
            y[k] = x[k];
            link(y[k], k ? &y[k - 1] : nullptr);
        }
        for (int k = 0; k < n - s; ++k) {
            z[k] = x[n - 1 - k];
            link(z[k], k ? &z[k - 1] : nullptr);
        }
        if (s == 0) z[n - 1].kind = VertexKind::Surface;  // the camera walk's emitter hit
        return Technique{s ? y.data() : nullptr, s, z.data(), n - s};
    }
};

}  // namespace lt::test
