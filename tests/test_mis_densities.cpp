// MIS weights of BPT, VCM and PT on paths through specular (delta) vertices, checked against an
// independent evaluation of every technique's path density in one common measure.
//
// The common measure is the product of the area measures of the path's non-delta vertices (the
// pinhole and a point light's position are fixed points, common to every technique). A delta
// vertex is not a coordinate: the specular law fixes it, given the rest of the path.
// Technique k (light vertices x_0..x_{k-1}, camera vertices x_k..x_{n-1}) samples two subpaths.
// Each subpath is a function X(u) of its random choices u: the light's point (area lights), then
// a direction at its endpoint and at every non-delta vertex; at a delta vertex only the lobe is
// chosen. The density of u is the product of the sampling densities (area for the light's point,
// solid angle for directions, the lobe's probability at a delta vertex), and the subpath's
// density in the common measure is p(u) / |det dX/du|, X = the tangent-plane coordinates of the
// subpath's non-delta vertices. dX/du is taken by central finite differences of a re-trace in
// double precision through the analytic geometry (planes, spheres), reflecting and refracting at
// the delta vertices as the path did. Nothing of the walks' stored densities, the gathers or the
// MIS routine is used here: only the positions of the path's vertices and the scene.
//
// Merges: the merge at x_i has density pL(x_0..x_i) pC(x_i..x_{n-1}) pi r^2 N (both subpaths
// reach x_i), connections n_VC = 1; weights by the power heuristic, as the renderer.
#include <catch2/catch.hpp>
#include <array>
#include <optional>
#include <vector>
#include "integrators/transport/light_paths.h"
#include "integrators/transport/path.h"
#include "scene_builders.h"

using namespace lt;
using namespace lt::test;

namespace {

using D3 = glm::dvec3;

enum class Mat { Diffuse, Mirror, Glass, Light };

// One analytic primitive: a parallelogram c + a u + b v (a, b in [0, 1]) or a sphere.
struct Prim {
    bool sphere = false;
    D3 c{0.0}, u{0.0}, v{0.0}, n{0.0};  // quad: corner, edges, unit normal cross(u, v)
    double r = 0.0;                      // sphere radius (normals outwards, glass inside)
    Mat mat = Mat::Diffuse;
    double eta = 1.5;                    // glass: int_ior / ext_ior
};

struct TestScene {
    SceneDesc desc;
    std::vector<Prim> prims;
    bool pointLight = false;
    D3 lightPos{0.0};
    int lightPrim = -1;
    double lightArea = 0.0;
};

D3 toD(const Vec3& v) { return D3(v.x, v.y, v.z); }

int bsdfFor(TestScene& ts, Mat m, double eta) {
    BxdfPtr b;
    switch (m) {
        case Mat::Diffuse: b = makeDiffuse(Color(0.7f)); break;
        case Mat::Mirror: b = makeConductor(Color(0.f), Color(1.f), Color(0.9f)); break;  // Fresnel 1, reflectance 0.9
        case Mat::Glass: b = makeDielectric(float(eta)); break;
        case Mat::Light: b = makeDiffuse(Color(0.f)); break;
    }
    ts.desc.bsdfs.push_back(b);
    return int(ts.desc.bsdfs.size()) - 1;
}

void addQuad(TestScene& ts, const Vec3& c, const Vec3& u, const Vec3& v, Mat m) {
    int emitter = -1;
    if (m == Mat::Light) {
        EmitterDesc e;
        e.type = EmitterType::Area;
        e.value = Color(10.f);
        ts.desc.emitters.push_back(e);
        emitter = int(ts.desc.emitters.size()) - 1;
        ts.lightPrim = int(ts.prims.size());
        ts.lightArea = glm::length(glm::cross(toD(u), toD(v)));
    }
    ts.desc.meshes.push_back(quad(c, u, v, bsdfFor(ts, m, 1.0), emitter));
    Prim p;
    p.c = toD(c), p.u = toD(u), p.v = toD(v), p.n = glm::normalize(glm::cross(p.u, p.v));
    p.mat = m;
    ts.prims.push_back(p);
}

void addSphere(TestScene& ts, const Vec3& c, float r, Mat m, double eta = 1.5) {
    SphereDesc s;
    s.center = c;
    s.radius = r;
    s.bsdf = bsdfFor(ts, m, eta);
    ts.desc.spheres.push_back(s);
    Prim p;
    p.sphere = true;
    p.c = toD(c), p.r = r, p.mat = m, p.eta = eta;
    ts.prims.push_back(p);
}

// The box of the bidirectional tests (floor, ceiling, back, left, right; open towards the camera).
TestScene box(bool areaLight) {
    TestScene ts;
    addQuad(ts, Vec3(-1, -1, -1), Vec3(0, 0, 2), Vec3(2, 0, 0), Mat::Diffuse);  // floor
    addQuad(ts, Vec3(-1, 1, -1), Vec3(2, 0, 0), Vec3(0, 0, 2), Mat::Diffuse);   // ceiling
    addQuad(ts, Vec3(-1, -1, -1), Vec3(2, 0, 0), Vec3(0, 2, 0), Mat::Diffuse);  // back
    addQuad(ts, Vec3(-1, -1, -1), Vec3(0, 2, 0), Vec3(0, 0, 2), Mat::Diffuse);  // left
    addQuad(ts, Vec3(1, -1, -1), Vec3(0, 0, 2), Vec3(0, 2, 0), Mat::Diffuse);   // right
    if (areaLight) addQuad(ts, Vec3(-0.3f, 0.99f, -0.3f), Vec3(0.6f, 0, 0), Vec3(0, 0, 0.6f), Mat::Light);
    ts.desc.camera = lookAt(Vec3(0, 0, 3.8f), Vec3(0, 0, 0), Vec3(0, 1, 0), 40.f, 16, 16);
    ts.desc.camera.nearClip = 1e-3f;
    return ts;
}

void setPointLight(TestScene& ts, const Vec3& p) {
    EmitterDesc e;
    e.type = EmitterType::Point;
    e.position = p;
    e.value = Color(3.f);
    ts.desc.emitters.push_back(e);
    ts.pointLight = true;
    ts.lightPos = toD(p);
}

// ---- Double-precision geometry ------------------------------------------------------------

// Distance of p from the primitive's surface (infinite for a point outside a quad's extent).
double surfaceDistance(const Prim& q, const D3& p) {
    if (q.sphere) return std::abs(glm::length(p - q.c) - q.r);
    const D3 d = p - q.c;
    const double h = glm::dot(d, q.n);
    const D3 inPlane = d - h * q.n;
    const double a = glm::dot(inPlane, q.u) / glm::dot(q.u, q.u), b = glm::dot(inPlane, q.v) / glm::dot(q.v, q.v);
    if (a < -1e-4 || a > 1 + 1e-4 || b < -1e-4 || b > 1 + 1e-4) return 1e30;
    return std::abs(h);
}

D3 normalAt(const Prim& q, const D3& p) { return q.sphere ? glm::normalize(p - q.c) : q.n; }

// The hit of the ray o + t d (t > 0) on primitive q nearest to `near` (the two roots of a sphere).
std::optional<D3> hitPrim(const Prim& q, const D3& o, const D3& d, const D3& near) {
    if (!q.sphere) {
        const double dn = glm::dot(d, q.n);
        if (dn == 0.0) return std::nullopt;
        const double t = glm::dot(q.c - o, q.n) / dn;
        if (!(t > 0.0)) return std::nullopt;
        return o + t * d;
    }
    const D3 oc = o - q.c;
    const double b = glm::dot(oc, d), c = glm::dot(oc, oc) - q.r * q.r;
    const double disc = b * b - c;
    if (disc < 0.0) return std::nullopt;
    const double s = std::sqrt(disc);
    std::optional<D3> best;
    for (double t : {-b - s, -b + s}) {
        if (!(t > 1e-9)) continue;
        const D3 p = o + t * d;
        if (!best || glm::length(p - near) < glm::length(*best - near)) best = p;
    }
    return best;
}

double fresnel(double cosI, double eta) {  // cosI > 0 on the side of the normal, eta = n_below / n_above
    if (cosI < 0.0) cosI = -cosI, eta = 1.0 / eta;
    const double sin2T = (1.0 - cosI * cosI) / (eta * eta);
    if (sin2T >= 1.0) return 1.0;
    const double cosT = std::sqrt(1.0 - sin2T);
    const double rs = (cosI - eta * cosT) / (cosI + eta * cosT), rp = (eta * cosI - cosT) / (eta * cosI + cosT);
    return 0.5 * (rs * rs + rp * rp);
}

// Scatter the travel direction d at a smooth surface (outward normal n): mirror reflection, or
// refraction into the other side (eta = inside / outside).
std::optional<D3> specular(const D3& d, const D3& n, bool reflect, double eta) {
    if (reflect) return d - 2.0 * glm::dot(d, n) * n;
    const double cosI = -glm::dot(d, n);  // > 0: arriving from outside
    const D3 nn = cosI > 0.0 ? n : -n;
    const double e = cosI > 0.0 ? 1.0 / eta : eta;  // n_from / n_to
    const double c = std::abs(cosI);
    const double k = 1.0 - e * e * (1.0 - c * c);
    if (k < 0.0) return std::nullopt;
    return glm::normalize(e * d + (e * c - std::sqrt(k)) * nn);
}

// Orthonormal tangents of a unit vector.
void tangents(const D3& n, D3& a, D3& b) {
    a = glm::normalize(std::abs(n.x) > 0.5 ? glm::cross(n, D3(0, 1, 0)) : glm::cross(n, D3(1, 0, 0)));
    b = glm::cross(n, a);
}

double determinant(std::vector<std::vector<double>> m) {
    const size_t n = m.size();
    double det = 1.0;
    for (size_t c = 0; c < n; ++c) {
        size_t piv = c;
        for (size_t r = c + 1; r < n; ++r)
            if (std::abs(m[r][c]) > std::abs(m[piv][c])) piv = r;
        if (m[piv][c] == 0.0) return 0.0;
        if (piv != c) std::swap(m[piv], m[c]), det = -det;
        det *= m[c][c];
        for (size_t r = c + 1; r < n; ++r) {
            const double f = m[r][c] / m[c][c];
            for (size_t k = c; k < n; ++k) m[r][k] -= f * m[c][k];
        }
    }
    return det;
}

// ---- The independent density of a subpath -------------------------------------------------

// A full path x_0 (light) .. x_{n-1} (pinhole): positions and the primitive of each vertex
// (-1 for the pinhole and a point light).
struct FullPath {
    std::vector<D3> p;
    std::vector<int> prim;
    int n() const { return int(p.size()); }
};

struct Evaluator {
    const TestScene& ts;
    const Scene& scene;
    int rrDepth;  // the walks' Russian roulette depth

    bool isDelta(const FullPath& x, int i) const {
        const int q = x.prim[i];
        return q >= 0 && (ts.prims[q].mat == Mat::Mirror || ts.prims[q].mat == Mat::Glass);
    }

    // Density, in the common measure, of the subpath whose vertices in walk order are
    // x[idx[0]] (its endpoint: the light or the pinhole), ..., x[idx[m]].
    double subpathDensity(const FullPath& x, const std::vector<int>& idx, bool fromLight) const {
        const int m = int(idx.size()) - 1;
        const bool areaEnd = fromLight && !ts.pointLight;
        // The density of the random choices at the base path.
        double pu = 1.0;
        if (fromLight) {
            pu *= ts.pointLight ? 1.0 : 1.0 / ts.lightArea;  // one light: selection probability 1
            if (m >= 1) {
                const D3 w = glm::normalize(x.p[idx[1]] - x.p[idx[0]]);
                pu *= ts.pointLight ? 1.0 / (4.0 * M_PI)
                                    : std::max(0.0, glm::dot(ts.prims[ts.lightPrim].n, w)) / M_PI;
            }
        } else if (m >= 1) {
            // Pinhole: density 1 / (A cos^3) of the direction, A the image plane's area at distance 1.
            const D3 fwd = glm::normalize(toD(scene.camera().forward()));
            const double tanHalf = std::tan(0.5 * 40.0 * M_PI / 180.0);
            const double A = 4.0 * tanHalf * tanHalf;
            const double c = glm::dot(fwd, glm::normalize(x.p[idx[1]] - x.p[idx[0]]));
            pu *= 1.0 / (A * c * c * c);
        }
        for (int j = 1; j < m; ++j) {
            const Prim& q = ts.prims[x.prim[idx[j]]];
            const D3 n = normalAt(q, x.p[idx[j]]);
            const D3 wPrev = glm::normalize(x.p[idx[j - 1]] - x.p[idx[j]]);
            const D3 wNext = glm::normalize(x.p[idx[j + 1]] - x.p[idx[j]]);
            const bool reflect = glm::dot(wPrev, n) * glm::dot(wNext, n) > 0.0;
            // The Russian roulette's continuation probability where the walk plays it, j >= rrDepth
            // segments from its endpoint (the largest reflectance: 0.7 diffuse, 0.9 mirror, 1 glass;
            // path.h), then the choice.
            const bool roulette = j >= rrDepth;
            switch (q.mat) {
                case Mat::Diffuse: pu *= (roulette ? 0.7 : 1.0) * std::abs(glm::dot(wNext, n)) / M_PI; break;
                case Mat::Mirror: pu *= roulette ? 0.9 : 1.0; break;
                case Mat::Glass: {
                    const double F = fresnel(glm::dot(wPrev, n), q.eta);
                    pu *= reflect ? F : 1.0 - F;
                    break;
                }
                case Mat::Light: return 0.0;
            }
        }
        if (!(pu > 0.0)) return 0.0;

        // The parameters: the light's point (2), a direction (2) at the endpoint and at every
        // non-delta vertex before the last.
        struct Param {
            int vertex;  // position in idx
            bool position;
            D3 a, b;     // perturbation axes
        };
        std::vector<Param> params;
        if (areaEnd) {
            const Prim& q = ts.prims[ts.lightPrim];
            params.push_back({0, true, glm::normalize(q.u), glm::cross(q.n, glm::normalize(q.u))});
        }
        for (int j = 0; j < m; ++j) {
            if (j > 0 && isDelta(x, idx[j])) continue;
            D3 a, b;
            tangents(glm::normalize(x.p[idx[j + 1]] - x.p[idx[j]]), a, b);
            params.push_back({j, false, a, b});
        }
        // The coordinates: the tangent-plane position of every non-delta vertex that is not fixed,
        // except for a vertex b at the camera-side end of a specular chain a -> (delta ...) -> b
        // that lies inside this subpath: its coordinate is the direction at a into the chain
        // (tangent-plane coordinates on the sphere of directions). In area coordinates the chain's
        // Jacobian is singular at caustics, and the float positions of a stored path are not
        // exactly a specular chain: near a caustic 1e-6 of inconsistency changes a density by
        // O(1). The map (b, w_b) -> (a, w_a) through the chain preserves phase-space volume (up to
        // eta^2 and cosines) and is well conditioned. A change of coordinates shared by all
        // techniques leaves every ratio of densities, and so every weight, unchanged.
        const int nFull = x.n();
        auto fullIndex = [&](int j) { return idx[j]; };
        auto walkPos = [&](int i) { return fromLight ? i : nFull - 1 - i; };
        auto inSubpath = [&](int i) { int j = walkPos(i); return j >= 0 && j <= m && idx[j] == i; };
        struct Coord {
            int vertex;        // walk position of the vertex whose coordinate this is
            int dirFrom = -1;  // chain case: walk positions of a and of the chain's first vertex
            int dirTo = -1;
        };
        std::vector<Coord> coordVertex;
        for (int j = 0; j <= m; ++j) {
            if (j == 0 && !areaEnd) continue;
            const int i = fullIndex(j);
            if (j > 0 && isDelta(x, i)) continue;
            Coord c{j};
            if (i >= 1 && isDelta(x, i - 1) && inSubpath(i - 1)) {
                int a = i - 1;
                while (a > 0 && isDelta(x, a)) --a;
                REQUIRE(inSubpath(a));
                c.dirFrom = walkPos(a), c.dirTo = walkPos(a + 1);
            }
            coordVertex.push_back(c);
        }
        REQUIRE(coordVertex.size() == params.size());
        const size_t dim = 2 * params.size();
        if (dim == 0) return pu;

        // X(u): re-trace the subpath with parameter `which` (0 .. dim-1) offset by h.
        auto trace = [&](int which, double h, std::vector<double>& out) -> bool {
            std::vector<D3> pos(m + 1);
            pos[0] = x.p[idx[0]];
            D3 dir(0.0);
            size_t pi = 0;
            auto offset = [&](const Param& pr, size_t k) {
                double da = 0, db = 0;
                if (int(2 * k) == which) da = h;
                if (int(2 * k + 1) == which) db = h;
                return da * pr.a + db * pr.b;
            };
            if (areaEnd) pos[0] += offset(params[0], 0), pi = 1;
            for (int j = 0; j < m; ++j) {
                if (j == 0 || !isDelta(x, idx[j])) {
                    // Aimed at the next vertex of the stored path from the re-traced position
                    // (the stored path's specular chains are off by its ray offsets, ~1e-5):
                    // a shear of the parameters, so the density is unchanged.
                    const D3 aim = glm::normalize(x.p[idx[j + 1]] - pos[j]);
                    D3 ta, tb;
                    tangents(aim, ta, tb);
                    double da = 0, db = 0;
                    if (int(2 * pi) == which) da = h;
                    if (int(2 * pi + 1) == which) db = h;
                    dir = glm::normalize(aim + da * ta + db * tb);
                    ++pi;
                } else {
                    const Prim& q = ts.prims[x.prim[idx[j]]];
                    const D3 n = normalAt(q, pos[j]);
                    const D3 n0 = normalAt(q, x.p[idx[j]]);
                    const bool reflect = glm::dot(x.p[idx[j - 1]] - x.p[idx[j]], n0) *
                                             glm::dot(x.p[idx[j + 1]] - x.p[idx[j]], n0) > 0.0;
                    auto d = specular(dir, n, reflect, q.eta);
                    if (!d) return false;
                    dir = *d;
                }
                auto hit = hitPrim(ts.prims[x.prim[idx[j + 1]]], pos[j], dir, x.p[idx[j + 1]]);
                if (!hit) return false;
                pos[j + 1] = *hit;
            }
            out.clear();
            for (const Coord& c : coordVertex) {
                const int j = c.vertex;
                D3 a, b, delta;
                if (c.dirFrom >= 0) {
                    const D3 w0 = glm::normalize(x.p[idx[c.dirTo]] - x.p[idx[c.dirFrom]]);
                    tangents(w0, a, b);
                    delta = glm::normalize(pos[c.dirTo] - pos[c.dirFrom]) - w0;
                } else {
                    const D3 n0 = j == 0 ? ts.prims[ts.lightPrim].n : normalAt(ts.prims[x.prim[idx[j]]], x.p[idx[j]]);
                    tangents(n0, a, b);
                    delta = pos[j] - x.p[idx[j]];
                }
                out.push_back(glm::dot(delta, a));
                out.push_back(glm::dot(delta, b));
            }
            return true;
        };
        const double h = 1e-6;  // the result is the same to 1e-5 for h from 1e-5 to 1e-8 (checked)
        std::vector<std::vector<double>> J(dim, std::vector<double>(dim));
        std::vector<double> plus, minus;
        for (size_t c = 0; c < dim; ++c) {
            if (!trace(int(c), h, plus) || !trace(int(c), -h, minus)) return 0.0;
            for (size_t r = 0; r < dim; ++r) J[r][c] = (plus[r] - minus[r]) / (2 * h);
        }
        const double det = std::abs(determinant(J));
        return det > 0.0 ? pu / det : 0.0;
    }

    // Power-heuristic weights of every technique for path x: conn[k] for connection k (k light
    // vertices), merge[i] for the merge at x_i; -1 where the technique cannot sample the path.
    struct Weights {
        std::vector<double> conn, merge;
    };
    Weights weights(const FullPath& x, const MisConfig& cfg) const {
        const int n = x.n();
        std::vector<int> light, camera;
        auto pL = [&](int k) {  // light subpath x_0..x_{k-1}
            std::vector<int> idx;
            for (int i = 0; i < k; ++i) idx.push_back(i);
            return idx.empty() ? 1.0 : subpathDensity(x, idx, true);
        };
        auto pC = [&](int k) {  // camera subpath x_{n-1}..x_k
            std::vector<int> idx;
            for (int i = n - 1; i >= k; --i) idx.push_back(i);
            return subpathDensity(x, idx, false);
        };
        Weights w;
        w.conn.assign(n + 1, -1.0);
        w.merge.assign(n, -1.0);
        std::vector<double> pConn(n + 1, 0.0), pMerge(n, 0.0);
        double sum = 0.0;
        for (int k = 0; k < n; ++k) {
            bool valid = allowsTechnique(cfg.set, k, n - k) &&
                         (k == 0 ? !ts.pointLight : !isDelta(x, k - 1) && !isDelta(x, k));
            if (!valid) continue;
            pConn[k] = pL(k) * pC(k);
            w.conn[k] = 0.0;
            sum += pConn[k] * pConn[k];
        }
        if (cfg.merging)
            for (int i = 1; i <= n - 2; ++i) {
                if (isDelta(x, i)) continue;
                pMerge[i] = pL(i + 1) * pC(i) * double(cfg.mergeArea) * double(cfg.lightPaths);
                w.merge[i] = 0.0;
                sum += pMerge[i] * pMerge[i];
            }
        for (int k = 0; k <= n; ++k)
            if (w.conn[k] >= 0.0) w.conn[k] = pConn[k] * pConn[k] / sum;
        for (int i = 0; i < n; ++i)
            if (w.merge[i] >= 0.0) w.merge[i] = pMerge[i] * pMerge[i] / sum;
        return w;
    }
};

// The primitive of a path vertex, found from its position.
int primOf(const TestScene& ts, const PathVertex& v) {
    if (v.kind == VertexKind::Camera) return -1;
    if (v.kind == VertexKind::Light && ts.pointLight) return -1;
    int best = -1;
    double bestD = 1e-4;
    for (size_t q = 0; q < ts.prims.size(); ++q) {
        const double d = surfaceDistance(ts.prims[q], toD(v.p));
        if (d < bestD) bestD = d, best = int(q);
    }
    return best;
}

struct Tally {
    int checked = 0, withDelta = 0, merges = 0, emitterHits = 0;
    double worst = 0.0, worstWithoutDelta = 0.0;
};

// Compares our weight `ours` of a technique with the independent one; `x` for the message.
void compare(double ours, double indep, const char* what, int k, const FullPath& x, bool delta, Tally& tally) {
    INFO(what << " k=" << k << " n=" << x.n() << " ours " << ours << " independent " << indep);
    // Tolerance. On paths without delta vertices the two evaluations agree to 1e-4 (float
    // densities, finite differences good to ~1e-9). Through specular chains the stored vertices
    // are not an exact chain: the walks' rays leave from offset origins (~1e-5 of the scene
    // size), and the independent densities belong to the exact chain through the same
    // neighbours; over 30,000 weights through chains of up to four delta vertices the largest
    // difference measured is 2.1e-3. 5e-3 is above that and far below what a wrong density does:
    // dropping the cosine and distance factors at delta vertices (storing them as 1) changes
    // weights by up to 0.98, leaving out eta^2 by up to 0.38 (both measured with this test).
    CHECK(std::abs(ours - indep) <= 5e-3);
    tally.worst = std::max(tally.worst, std::abs(ours - indep));
    if (!delta) tally.worstWithoutDelta = std::max(tally.worstWithoutDelta, std::abs(ours - indep));
}

// Walks light and camera subpaths in `ts`, connects every pair (s, t) and checks the weight of
// that technique, and of every merge on the same path, against the independent evaluation.
Tally checkScene(const TestScene& ts, const MisConfig& cfg, int pairs, int maxVertices, int rrDepth) {
    Scene scene(ts.desc);
    Evaluator ev{ts, scene, rrDepth};
    WalkStats ws;
    std::array<PathVertex, kMaxPathVertices> y, z;
    PathVertex cam = cameraEndpoint(scene, reg::kNone);
    Tally tally;
    auto fullPath = [&](const PathVertex* yy, int s, const PathVertex* zz, int t, FullPath& x) {
        x.p.clear(), x.prim.clear();
        for (int i = 0; i < s; ++i) x.p.push_back(toD(yy[i].p)), x.prim.push_back(primOf(ts, yy[i]));
        for (int j = t - 1; j >= 0; --j) x.p.push_back(toD(zz[j].p)), x.prim.push_back(primOf(ts, zz[j]));
        for (int i = 0; i < x.n(); ++i)
            if (x.prim[i] < 0 && !(i == x.n() - 1 || (i == 0 && ts.pointLight))) return false;
        return true;
    };
    auto checkAll = [&](const PathPdfs& pdfs, int s, const FullPath& x, const char* what) {
        const auto w = ev.weights(x, cfg);
        REQUIRE(w.conn[s] >= 0.0);
        bool delta = false;
        for (int i = 0; i < x.n(); ++i) delta |= ev.isDelta(x, i);
        compare(misWeight(pdfs, s, cfg), w.conn[s], what, s, x, delta, tally);
        for (int i = 0; i < x.n(); ++i)
            if (w.merge[i] >= 0.0) {
                compare(misWeightMerge(pdfs, i, cfg), w.merge[i], "merge", i, x, delta, tally);
                ++tally.merges;
            }
        tally.withDelta += delta;
        ++tally.checked;
    };
    const int res = ts.desc.camera.width;
    FullPath x;
    for (int i = 0; i < pairs; ++i) {
        Rng rng(uint64_t(i), 77);
        const int ny = lightWalk(scene, reg::kNone, rng, maxVertices, rrDepth, y.data(), ws);
        const int nz = cameraWalk(scene, reg::kNone, Vec2(rng.uniform() * res, rng.uniform() * res), rng, maxVertices,
                                  rrDepth, z.data(), ws);
        // s = 0: the camera walk hits the light.
        for (int t = 2; t <= nz; ++t) {
            PathPdfs pdfs;
            if (!allowsTechnique(cfg.set, 0, t) || isBlack(emitterHit(scene, reg::kNone, z.data(), t, rrDepth, pdfs))) continue;
            if (!fullPath(nullptr, 0, z.data(), t, x) || x.prim[0] != ts.lightPrim) continue;
            checkAll(pdfs, 0, x, "emitter hit");
            ++tally.emitterHits;
        }
        for (int s = 1; s <= ny; ++s)
            for (int t = 1; t <= nz; ++t) {
                if (s + t < 3 || !allowsTechnique(cfg.set, s, t)) continue;
                const PathVertex* zz = t == 1 ? &cam : z.data();
                PathVertex lv;
                const PathVertex* yy = y.data();
                if (s == 1 && cfg.set == TechniqueSet::PathTracer) {  // NEE: a fresh light sample
                    if (!sampleLightVertex(scene, reg::kNone, z[t - 1].p, rng, lv)) continue;
                    yy = &lv;
                }
                Connection c;
                if (!connect(scene, reg::kNone, yy, s, zz, t, rrDepth, c, ws)) continue;
                if (!fullPath(yy, s, zz, t, x)) continue;
                checkAll(c.pdfs, s, x, "connection");
            }
    }
    return tally;
}

// The scenes: specular vertices alone and in chains, a delta light, and lights enclosed in glass.
struct NamedScene {
    std::string name;
    TestScene ts;
    int ptPaths;  // paths the path tracer must find (0 where it cannot sample the light's paths)
};
std::vector<NamedScene> specularScenes() {
    std::vector<NamedScene> v;
    {
        TestScene ts = box(true);
        addSphere(ts, Vec3(0.1f, -0.45f, 0.1f), 0.5f, Mat::Glass);
        v.push_back({"glass sphere (two-vertex chains)", ts, 100});
    }
    {
        TestScene ts = box(true);
        addSphere(ts, Vec3(-0.45f, -0.6f, -0.2f), 0.4f, Mat::Mirror);
        addSphere(ts, Vec3(0.45f, -0.55f, 0.3f), 0.4f, Mat::Glass, 1.33);
        v.push_back({"mirror and glass spheres (chains of up to four)", ts, 100});
    }
    {
        TestScene ts = box(false);
        addSphere(ts, Vec3(0.f, -0.3f, 0.f), 0.5f, Mat::Glass);
        setPointLight(ts, Vec3(0.f, -0.3f, 0.1f));
        v.push_back({"point light inside a glass sphere", ts, 0});
    }
    {
        TestScene ts = box(false);
        addQuad(ts, Vec3(-0.1f, 0.5f, -0.1f), Vec3(0.2f, 0, 0), Vec3(0, 0, 0.2f), Mat::Light);
        addSphere(ts, Vec3(0.f, 0.45f, 0.f), 0.35f, Mat::Glass);
        v.push_back({"area light inside a glass sphere", ts, 5});
    }
    {
        // Diffuse vertices on both sides of the interface: techniques compared across one
        // crossing, where the eta^2 of the generalised densities matters.
        TestScene ts = box(false);
        addSphere(ts, Vec3(0.f, -0.35f, 0.f), 0.6f, Mat::Glass);
        addSphere(ts, Vec3(0.f, -0.65f, 0.f), 0.25f, Mat::Diffuse);
        setPointLight(ts, Vec3(0.1f, -0.1f, 0.15f));
        v.push_back({"point light and diffuse ball inside a glass sphere", ts, 20});
    }
    {
        TestScene ts = box(false);
        addSphere(ts, Vec3(0.3f, -0.5f, 0.f), 0.45f, Mat::Mirror);
        setPointLight(ts, Vec3(-0.4f, 0.6f, 0.2f));
        v.push_back({"point light and mirror sphere", ts, 100});
    }
    return v;
}

}  // namespace

TEST_CASE("MIS weights through specular vertices equal those of independently evaluated path densities",
          "[mis][delta]") {
    const MisConfig bpt{TechniqueSet::Bidirectional, false};
    // VCM: radius 0.02, 16 x 16 light paths: merges compete with connections (n_VM pi r^2 ~ 0.02).
    const MisConfig vcm{TechniqueSet::Bidirectional, true, float(kPi) * 0.02f * 0.02f, 256.f};
    const MisConfig pt{TechniqueSet::PathTracer, false};
    // Russian roulette from depth 2 (path.h): the densities of steps from the first vertex of
    // either walk carry no continuation probability, those from later ones do; and with none
    // (rrDepth beyond the paths' length).
    for (int rrDepth : {2, 1000})
    for (auto& [name, ts, ptPaths] : specularScenes())
        for (const auto& [cfgName, cfg] : {std::pair{"bpt", bpt}, std::pair{"vcm", vcm}, std::pair{"pt", pt}}) {
            INFO(name << ", " << cfgName << ", rr depth " << rrDepth);
            Tally t = checkScene(ts, cfg, rrDepth == 2 ? 600 : 400, 8, rrDepth);  // (the roulette ends walks)
            // Enough paths, enough of them through delta vertices, and (VCM) merges, so that
            // the test cannot pass vacuously. (PT cannot sample paths from a point light through
            // glass: NEE cannot pass the interface and the light cannot be hit.)
            const bool isPt = cfg.set == TechniqueSet::PathTracer;
            CHECK(t.checked >= (isPt ? ptPaths : 1000));
            CHECK(t.withDelta >= (isPt ? ptPaths / 10 : 300));
            if (cfg.merging) CHECK(t.merges >= 5000);
            if (!ts.pointLight) CHECK(t.emitterHits >= 5);
            WARN(name << ", " << cfgName << ", rr depth " << rrDepth << ": " << t.checked << " paths (" << t.withDelta << " through delta vertices, "
                      << t.merges << " merge weights, " << t.emitterHits << " emitter hits), largest weight difference "
                      << t.worst << " (" << t.worstWithoutDelta << " on paths without delta vertices)");
        }
}
