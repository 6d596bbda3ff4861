#include "integrators/transport/opsr.h"

#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include "bsdf/roughness_bound.h"
#include "integrators/transport/path_templates.h"

namespace lt::opsr {

namespace {

std::runtime_error tableError(const std::string& file, const std::string& field, const std::string& what) {
    return std::runtime_error(fmt::format("{}: {}: {}", file, field, what));
}

}  // namespace

std::shared_ptr<const AttenuationTable> loadAttenuationTable(const std::string& path, const std::string& set) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error(fmt::format("{}: cannot open the OPSR attenuation file", path));
    std::stringstream text;
    text << in.rdbuf();
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(text.str());
    } catch (const nlohmann::json::parse_error& e) {
        throw std::runtime_error(fmt::format("{}: malformed JSON (truncated or not JSON): {}", path, e.what()));
    }
    if (!j.is_object() || !j.contains("sets") || !j["sets"].is_object())
        throw tableError(path, "sets", "missing (expected an object of named sets, each with 'tables')");
    const auto& sets = j["sets"];
    if (!sets.contains(set)) {
        std::vector<std::string> names;
        for (auto it = sets.begin(); it != sets.end(); ++it) names.push_back(it.key());
        throw tableError(path, "sets." + set, fmt::format("no such set (the file has: {})", fmt::join(names, ", ")));
    }
    const std::string setField = "sets." + set + ".tables";
    const auto& s = sets[set];
    if (!s.is_object() || !s.contains("tables") || !s["tables"].is_object())
        throw tableError(path, setField, "missing (expected an object with the keys \"2\" to \"5\")");
    auto table = std::make_shared<AttenuationTable>();
    table->file = path;
    table->set = set;
    table->interpolated = set.find("interp") != std::string::npos;
    for (int k = 2; k <= kMaxWindow; ++k) {
        const std::string key = std::to_string(k), field = setField + "." + key;
        if (!s["tables"].contains(key)) throw tableError(path, field, "missing");
        const auto& arr = s["tables"][key];
        const size_t expected = size_t(std::pow(kQ, k));
        if (!arr.is_array() || arr.size() != expected)
            throw tableError(path, field,
                             fmt::format("expected an array of Q^{} = {} factors, got {}", k, expected,
                                         arr.is_array() ? fmt::format("{} entries", arr.size()) : std::string(arr.type_name())));
        auto& out = table->tables[k];
        out.resize(expected);
        for (size_t i = 0; i < expected; ++i) {
            const auto& v = arr[i];
            // (JSON has no NaN literal: nlohmann reads a NaN written by a tool as null)
            const double x = v.is_number() ? v.get<double>() : std::nan("");
            if (!std::isfinite(x) || x < 0.0 || x > 1.0)
                throw tableError(path, fmt::format("{}[{}]", field, i),
                                 fmt::format("an attenuation factor must be a finite number in [0, 1], got {}", v.dump()));
            out[i] = float(x);
        }
    }
    return table;
}

int binByFormula(float a) {
    // (the commonest roughnesses, smooth 0 and Lambert 1, without exp2: exactly the formula's bins)
    if (a <= 0.f) return 0;
    if (a >= 1.f) return kQ - 1;
    const int i = int(std::floor((std::exp2(std::sqrt(a)) - 1.f) * float(kQ + 1)));
    return std::min(i, kQ - 1);
}

float binCoordinate(float a) {
    if (a <= 0.f) return 0.f;  // (as binByFormula: exactly the formula's values at 0 and 1)
    if (a >= 1.f) return float(kQ - 1);
    return std::min((std::exp2(std::sqrt(a)) - 1.f) * float(kQ + 1), float(kQ - 1));
}

int windowIndex(const float* a, int k) {
    int index = 0, scale = 1;
    for (int j = 0; j < k; ++j, scale *= kQ) index += scale * roughnessBin(a[j]);
    return index;
}

float windowFactor(const AttenuationTable& table, const float* a, int k) {
    const std::vector<float>& t = table.tables[k];
    if (!table.interpolated) return t[size_t(windowIndex(a, k))];
    // Per vertex: the two nearest nodes (bin centres i + 1/2) and the weight of the upper one.
    int lo[kMaxWindow], hi[kMaxWindow];
    float w[kMaxWindow];
    for (int j = 0; j < k; ++j) {
        const float u = std::clamp(binCoordinate(a[j]) - 0.5f, 0.f, float(kQ - 1));
        lo[j] = std::min(int(u), kQ - 1);
        hi[j] = std::min(lo[j] + 1, kQ - 1);
        w[j] = u - float(lo[j]);
    }
    double sum = 0.0;
    for (int corner = 0; corner < (1 << k); ++corner) {
        double weight = 1.0;
        int index = 0, scale = 1;
        for (int j = 0; j < k; ++j, scale *= kQ) {
            const bool upper = (corner >> j) & 1;
            weight *= upper ? double(w[j]) : 1.0 - double(w[j]);
            index += scale * (upper ? hi[j] : lo[j]);
        }
        if (weight > 0.0) sum += weight * double(t[size_t(index)]);
    }
    return float(sum);
}

float accumulateWindow(const float* a, int k, float gamma) {
    if (k <= 1) return a[0];
    // 1 - (1 - a_last) P written as a_last + (1 - a_last)(1 - P): exactly a_last when P = 1 (gamma
    // 0, or only smooth vertices before), where 1 - (1 - a_last) may round above it.
    float keep = 1.f;
    for (int i = 0; i < k - 1; ++i) keep *= 1.f - gamma * a[i];
    return a[k - 1] + (1.f - a[k - 1]) * (1.f - keep);
}

float accumulatedRoughness(const float* a, int count, const Attenuation& att) {
    if (count <= 1) return count == 1 ? a[0] : 0.f;
    if (!att.table) {  // Eq. 11: one gamma for the whole subpath
        return accumulateWindow(a, count, att.gamma);
    }
    const AttenuationTable& table = *att.table;
    if (roughnessBin(a[count - 1]) == kQ - 1) return a[count - 1];  // the top bin keeps its own roughness
    // Eq. 14: windows of five collapse into a virtual roughness that stands in for their last vertex.
    float window[kMaxWindow];
    int start = 0;
    float virtualRoughness = a[0];
    while (count - start > kMaxWindow) {
        window[0] = virtualRoughness;
        for (int j = 1; j < kMaxWindow; ++j) window[j] = a[start + j];
        virtualRoughness = accumulateWindow(window, kMaxWindow, windowFactor(table, window, kMaxWindow));
        start += kMaxWindow - 1;
    }
    const int k = count - start;
    window[0] = virtualRoughness;
    for (int j = 1; j < k; ++j) window[j] = a[start + j];
    return accumulateWindow(window, k, windowFactor(table, window, k));
}

}  // namespace lt::opsr

namespace lt::reg {

Opsr::Opsr(const OpsrSettings& settings) : settings_(settings) {
    const float g = settings.attenuation.gamma;
    if (!settings.attenuation.table && !(g >= 0.f && g <= 1.f))
        throw std::invalid_argument(fmt::format("OPSR: the attenuation factor gamma must be in [0, 1], got {}", g));
    if (settings.lambda >= 0.0 && !(settings.lambda > 0.0 && settings.lambda < 0.5))
        throw std::invalid_argument(
            fmt::format("OPSR: lambda of the consistent offset must be in (0, 1/2), got {}", settings.lambda));
    if (settings.boundTau0 != 0.0) {
        if (!(settings.boundTau0 > kMinTau))
            throw std::invalid_argument(fmt::format(
                "OPSR with JG19's bound: tau_0 must exceed 1/(2 pi) = 0.159, got {}", settings.boundTau0));
        tau_ = float(settings.boundConsistent ? consistentTau(settings.boundTau0, 1) : settings.boundTau0);
    }
}

void Opsr::beginIteration(uint64_t n, const Scene& scene, const MisConfig& cfg) {
    offsetScale_ = settings_.consistent ? std::pow(double(std::max<uint64_t>(n, 1)), -lambda()) : 1.0;
    if (settings_.boundTau0 != 0.0)
        tau_ = float(settings_.boundConsistent ? consistentTau(settings_.boundTau0, n) : settings_.boundTau0);
    hittableLight_ = false;
    bool allHittable = true;
    for (const Light& l : scene.lights()) {
        hittableLight_ = hittableLight_ || l.isHittable();
        allHittable = allHittable && l.isHittable();
    }
    set_ = cfg.set;
    merging_ = cfg.merging;
    // (5): with the emitter hit and only lights it can hit, every path is samplable.
    smoothEnds_ = !settings_.bidirectional || !(allowsTechnique(cfg.set, 0, 2) && allHittable);
}


namespace {

// Eq. 11 at a vertex of roughness a from keep, the product of (1 - gamma a_i) over the subpath's
// surface vertices before it (OpsrState::keep, or its continuation across a connection).
float accumulatedWithKeep(float a, float keep) { return a + (1.f - a) * (1.f - keep); }

}  // namespace

float Opsr::request(const PathVertex* path, int count) const {
    const PathVertex& v = path[count - 1];
    // The common answers first, in O(1): a vertex no request can change (mayChange: Lambert counts
    // roughness 1), and (tables) one in the top bin, which keeps its roughness.
    if (count < 2 || !mayChange(v)) return -1.f;
    if (!settings_.attenuation.table) {  // Eq. 11 from the walk's running product (OpsrState::keep)
        const float a = v.roughness;
        return requestFor(v, count == 2 ? a : accumulatedWithKeep(a, v.regState.opsr.keep));
    }
    if (opsr::roughnessBin(v.roughness) == opsr::kQ - 1) return boundOnly(v);
    std::array<float, kMaxPathVertices> a;
    for (int j = 1; j < count; ++j) a[j - 1] = path[j].roughness;
    return requestWith(v, a.data(), count - 1);
}

float Opsr::requestWith(const PathVertex& v, const float* a, int count) const {
    return requestFor(v, opsr::accumulatedRoughness(a, count, settings_.attenuation));
}
float Opsr::requestFor(const PathVertex& v, float g) const {
    const float own = v.roughness;
    if (settings_.consistent) g = own + float(double(g - own) * offsetScale());
    if (std::isnan(g)) return g;  // regularizer.h (7): select() refuses it and counts it
    if (!(g > own)) return boundOnly(v);
    return detail::requestCanChange(v, contextFor(TransportMode::Radiance, g)) ? g : -1.f;
}

float Opsr::boundOnly(const PathVertex& v) const {
    if (tau_ <= 0.f) return -1.f;
    // A smooth vertex is changed where the bound makes it rough (requestCanChange), a glossy one
    // where alpha_hat(tau_n) exceeds its alpha: its value bound falls.
    const BsdfContext ctx = contextFor(TransportMode::Radiance, v.roughness);
    if (!detail::requestCanChange(v, ctx)) return -1.f;
    if (!v.deltaBsdf && !(v.bxdf->valueBound(ctx) < v.bxdf->plainBound(settings_.bound)))
        return -1.f;
    return v.roughness;
}

void Opsr::walkRatio(PathVertex& v, const Vec3& wi) const {
    const PathVertex* path = &v - v.depth;  // (the walk's array: path[0] its endpoint)
    const float g = request(path, v.depth + 1);
    const TransportMode mode = path[0].kind == VertexKind::Camera ? TransportMode::Radiance : TransportMode::Importance;
    const SurfaceBsdf b = v.bsdf();
    // The pair's geometry where the BSDF has the form (bsdf.h, PairGeometry): its ratios, this
    // side's and the other side's (densitiesBidirectional), then need no evaluation.
    v.regState.opsr.pair = b.pairGeometry(v.wo, wi);
    if (v.regState.opsr.pair.available()) {
        if (g >= 0.f) v.regState.ratio = v.bxdf->requestRatio(v.regState.opsr.pair, contextFor(mode, g));
        return;
    }
    const Color plain = b.eval(v.wo, wi, BsdfContext(mode).valueOnlyCopy()).f;
    v.regState.rhoBar = plain.x + plain.y + plain.z;
    if (g >= 0.f)
        v.regState.ratio = detail::regularisedRatio(b.eval(v.wo, wi, contextFor(mode, g).valueOnlyCopy()).f, plain);
}

namespace {

// The vertices of the path a technique evaluates, x_0 (the light end) .. x_{n-1} (the camera);
// a merge's x_i is its camera vertex (the photon's vertex y[i] is not on the path).
struct PathView {
    const Technique& tech;
    int lightCount, n;
    explicit PathView(const Technique& t) : tech(t), lightCount(t.photon ? t.s - 1 : t.s), n(lightCount + t.t) {}
    const PathVertex& operator[](int j) const { return j < lightCount ? tech.y[j] : tech.z[n - 1 - j]; }
    // The direction from x_j to its path neighbour x_k (k = j +- 1); a merge joins x_{i-1} to the
    // photon's position, and its camera vertex x_i looks along the photon's wo (as merge() does).
    Vec3 direction(int j, int k) const {
        if (tech.photon && j == lightCount - 1 && k == lightCount) return glm::normalize(tech.y[tech.s - 1].p - (*this)[j].p);
        if (tech.photon && j == lightCount && k == lightCount - 1) return tech.y[tech.s - 1].wo;
        return glm::normalize((*this)[k].p - (*this)[j].p);
    }
};

// Eq. 11's accumulated roughness at an inner vertex x_j of a technique's path, from the light (over
// x_1..x_j) or from the camera (x_{n-2}..x_j), for one constant gamma, without a loop over the
// subpath: on x_j's own walk its running product (OpsrState::keep); across the connection, the
// other walk's product through its last vertex times the factors of the vertices in between.
// The factors are multiplied in the order accumulateWindow multiplies them, so the floats are
// those of accumulatedRoughness over the list.
float accumulatedFrom(const PathView& x, float gamma, int j, End side) {
    const int n = x.n, lc = x.lightCount;
    const float a = x[j].roughness;
    if (side == End::Light ? j == 1 : j == n - 2) return a;  // one surface vertex (Eq. 6)
    auto factor = [&](int i, float keep) { return keep * (1.f - gamma * x[i].roughness); };
    float keep = 1.f;
    if ((side == End::Light) == (j < lc)) {  // x_j on the walk from that side
        keep = x[j].regState.opsr.keep;
    } else if (side == End::Light) {  // x_j on the camera walk: x_1..x_{lc-1}, then x_lc..x_{j-1}
        int i = 1;
        if (lc >= 2) keep = factor(lc - 1, x[lc - 1].regState.opsr.keep), i = lc;
        for (; i < j; ++i) keep = factor(i, keep);
    } else {  // x_j on the light walk: x_{n-2}..x_lc, then x_{lc-1}..x_{j+1}
        int i = n - 2;
        if (lc <= n - 2) keep = factor(lc, x[lc].regState.opsr.keep), i = lc - 1;
        for (; i > j; --i) keep = factor(i, keep);
    }
    return accumulatedWithKeep(a, keep);
}

}  // namespace

float Opsr::requestFrom(const Technique& tech, int j, End side) const {
    const PathView x(tech);
    const PathVertex& v = x[j];
    if (j < 1 || j > x.n - 2 || !mayChange(v)) return -1.f;
    if (!settings_.attenuation.table) return requestFor(v, accumulatedFrom(x, settings_.attenuation.gamma, j, side));
    if (opsr::roughnessBin(v.roughness) == opsr::kQ - 1) return boundOnly(v);
    std::array<float, kMaxPathVertices> a;
    int count = 0;
    if (side == End::Light)
        for (int i = 1; i <= j; ++i) a[count++] = x[i].roughness;
    else
        for (int i = x.n - 2; i >= j; --i) a[count++] = x[i].roughness;
    return requestWith(v, a.data(), count);
}

bool Opsr::samplable(const Technique& tech) const {
    const int lc = tech.s;
    if (set_ != TechniqueSet::Bidirectional || !smoothEnds_ || tech.photon || lc < 1 || tech.t < 1 || !tech.y)
        return samplableUnregularised(tech, set_, merging_);
    // Every connection k and the emitter hit are techniques: a path is samplable where its light
    // can be hit, where two neighbouring vertices are plain connection ends (on either subpath,
    // or the joining pair), or (VCM) where a vertex after the endpoints is one.
    if (tech.y[0].light && tech.y[0].light->isHittable()) return true;
    const PathVertex &a = tech.y[lc - 1], &b = tech.z[tech.t - 1];
    const bool aPlain = plainConnectionEnd(a), bPlain = plainConnectionEnd(b);
    const OpsrState &sa = a.regState.opsr, &sb = b.regState.opsr;
    if (sa.plainPairBefore || sb.plainPairBefore || (sa.previousPlain && aPlain) || (sb.previousPlain && bPlain) ||
        (aPlain && bPlain))
        return true;
    return merging_ && (sa.plainInnerBefore || sb.plainInnerBefore || (a.kind == VertexKind::Surface && aPlain) ||
                        (b.kind == VertexKind::Surface && bPlain));
}
bool Opsr::smoothCandidate(const Technique& tech, int k, SmoothChoice& c, int& count) const {
    const PathView x(tech);
    c = SmoothChoice{};
    c.technique = k;
    count = 0;
    for (int j : {k - 1, k}) {
        const PathVertex& v = x[j];
        if (plainConnectionEnd(v)) continue;
        const float g = smooth(v) ? requestFrom(tech, j, j == k - 1 ? End::Light : End::Camera) : -1.f;
        if (g < 0.f) return false;  // (NaN: a candidate, refused later by (7))
        c.ends[count] = j;
        c.g[count++] = g;
    }
    return true;
}

Opsr::SmoothChoice Opsr::chooseSmooth(const Technique& tech) const {
    SmoothChoice best;
    if (samplable(tech)) return best;
    const int n = PathView(tech).n;
    int bestCount = 0;
    for (int k = 1; k < n; ++k) {
        if (!allowsTechnique(set_, k, n - k)) continue;
        SmoothChoice c;
        int count = 0;
        // The fewest smooth ends, then the one nearest the light (the first k). (On a path no
        // technique samples every candidate has a smooth end, so the first with one is the choice.)
        if (smoothCandidate(tech, k, c, count) && (best.technique < 0 || count < bestCount)) {
            best = c;
            bestCount = count;
            if (count == 1) break;
        }
    }
    return best;
}

bool Opsr::choosesOwnTechnique(const Technique& tech, SmoothChoice& choice) const {
    const int n = PathView(tech).n, s = tech.s;
    int count = 0;
    if (!allowsTechnique(set_, s, n - s) || !smoothCandidate(tech, s, choice, count) || samplable(tech)) return false;
    // (count >= 1: with no smooth end the technique is a plain one, and the path samplable.)
    // chooseSmooth's order: (count, k) lexicographic. Nearer the light, any candidate with as few
    // smooth ends wins; further, only one with fewer (so none where s has one).
    for (int k = 1; k < n; ++k) {
        if (k == s || !allowsTechnique(set_, k, n - k)) continue;
        if (k > s && count == 1) break;
        SmoothChoice c;
        int other = 0;
        if (smoothCandidate(tech, k, c, other) && (other < count || (other == count && k < s))) return false;
    }
    return true;
}

bool Opsr::selectRequest(Technique& tech) const {
    // regularizer.h (7): a roughness that is not a number in [0, 1] is refused and counted, never
    // read as "no request" (the selections below let a NaN through to tech.bound for this).
    return selectRoughness(tech) && boundsValid(tech, [](float g) { return g >= 0.f && g <= 1.f; }, invalid_);
}

bool Opsr::selectRoughness(Technique& tech) const {
    if (settings_.bidirectional) return selectBidirectional(tech);
    if (tech.s == 0) {
        // The emitter hit through z[t-2] (x_1): the regularised sample's where the request changes
        // it, the walk's own elsewhere.
        const float g = tech.t >= 3 ? request(tech.z, tech.t - 1) : -1.f;
        if (g < 0.f) return !tech.regularisedSample;
        if (!tech.regularisedSample) {  // the walk's own sample: the technique where it covers g
            const PathVertex& x1 = tech.z[tech.t - 2];
            if (std::isnan(g) || !walkCovers(x1, g)) return false;
            tech.walkSample = true;
            tech.hitRatio = detail::regularisedRatioAt(x1.bsdf(), x1.wo, -tech.z[tech.t - 1].wo,
                                                       contextFor(TransportMode::Radiance, g));
        }
        tech.regularised[0] = 1;
        tech.bound[0] = g;
        return true;
    }
    int m = 0;
    auto end = [&](const PathVertex* path, int count, int x) {
        const PathVertex& v = path[count - 1];
        if (v.kind != VertexKind::Surface) return true;  // an endpoint
        const float g = request(path, count);
        if (!(g < 0.f)) {  // (NaN too: (7))
            tech.regularised[m] = x;
            tech.bound[m++] = g;
            return true;
        }
        return v.connectible();
    };
    if (!end(tech.y, tech.s, tech.s - 1) || !end(tech.z, tech.t, tech.s)) return false;
    // (4) Next-event estimation competes with the walk's own sample where it covers the request.
    if (hittableLight_ && tech.s == 1)
        if (const float g = boundAt(tech, End::Camera); g >= 0.f) tech.walkSample = walkCovers(tech.z[tech.t - 1], g);
    return true;
}

bool Opsr::selectBidirectional(Technique& tech) const {
    // (5) A connection (select() answered emitter hits and merges).
    const PathVertex &a = tech.y[tech.s - 1], &b = tech.z[tech.t - 1];
    int m = 0;
    if (smooth(a) || smooth(b)) {
        SmoothChoice c;
        if (!choosesOwnTechnique(tech, c)) return false;  // samplable, or another technique's path
        for (int i = 0; i < 2; ++i)
            if (c.ends[i] >= 0) {
                tech.regularised[m] = c.ends[i];
                tech.bound[m++] = c.g[i];
            }
    }
    // Glossy ends: each with its own subpath's roughness.
    if (!smooth(a) && a.kind == VertexKind::Surface) {
        const float g = request(tech.y, tech.s);
        if (!(g < 0.f)) tech.regularised[m] = tech.s - 1, tech.bound[m++] = g;  // (NaN too: (7))
    }
    if (!smooth(b) && b.kind == VertexKind::Surface) {
        const float g = request(tech.z, tech.t);
        if (!(g < 0.f)) tech.regularised[m] = tech.s, tech.bound[m++] = g;
    }
    return (smooth(a) || a.connectible()) && (smooth(b) || b.connectible());
}

bool Opsr::emitterSampleRequest(const PathVertex* z, int t, BsdfContext& ctx) const {
    const float g = request(z, t);
    if (g < 0.f) return false;
    if (std::isnan(g)) {  // regularizer.h (7): no sample with it (the emitter hit is refused too)
        invalid_.add();
        return false;
    }
    if (walkCovers(z[t - 1], g)) return false;  // (4) the walk's own sample is the technique
    ctx = contextFor(TransportMode::Radiance, g);
    return true;
}

void Opsr::densities(const Technique& tech, PathPdfs& P) const {
    if (settings_.bidirectional) return densitiesBidirectional(tech, P);
    // (4): the path tracer's two techniques, both regularised at x_1 (the camera vertex next to
    // the light): x_1 is a connection end, and the emitter hit's density is the regularised BSDF
    // sample's. For that emitter hit the path tracer wrote it into x_0's fromCamera; for
    // next-event estimation it is connect's regularised evaluation at z[t-1] towards the light
    // sample (Technique::pdfCamera), in place of the material's own density there.
    for (int j : tech.regularised)
        if (j >= 0) P.delta[j] = false;
    for (int k = 0; k <= P.n; ++k) P.connectionScale[k] = k <= 1 ? 1.f : 0.f;
    for (int i = 0; i < P.n; ++i) P.mergeScale[i] = 0.f;
    // (select writes the vertices it regularises from slot 0 on: NEE's camera end is in slot 0)
    const bool neeRegularised = tech.regularised[0] == 1 || tech.regularised[1] == 1;
    if (tech.s == 1 && neeRegularised && P.lightHittable && !tech.walkSample) {
        const PathVertex& v = tech.z[tech.t - 1];
        const PathVertex& light = tech.y[0];
        const Vec3 d = light.p - v.p;
        const float d2 = glm::dot(d, d);
        const float pReg =
            d2 > 0.f ? convertDensity(SolidAnglePdf(tech.pdfCamera), light, d * (1.f / std::sqrt(d2)), d2).value : 0.f;
        P.connectionScale[0] = float(double(pReg) / detail::remapDensity(P.fromCamera[0]));
    }
    P.regularised = true;
}

void Opsr::densitiesBidirectional(const Technique& tech, PathPdfs& P) const {
    const PathView x(tech);
    const int n = P.n, s = tech.s;
    P.regularised = anyRegularised(tech);
    for (int j : tech.regularised)
        if (j >= 0 && smooth(x[j])) {
            // A smooth vertex regularised: the one technique chosen for this path (5).
            for (int i : tech.regularised)
                if (i >= 0) P.delta[i] = false;
            for (int k = 0; k <= n; ++k) P.connectionScale[k] = k == s ? 1.f : 0.f;
            for (int i = 0; i < n; ++i) P.mergeScale[i] = 0.f;
            return;
        }
    // Eq. 12: technique k's density is p_k / (R_L(x_{k-1}) R_C(x_k)). The base's own ratios are
    // connect's; the others are evaluated here, each with its side's roughness (1 where the
    // request changes nothing; +inf where rho is 0 or a delta: that technique is left out, as a
    // regularised value of 0 is, Eq. 12's 0/0).
    // Inner vertices of a subpath (both path neighbours on its walk) have their own side's ratio
    // and rho from the walk (SubpathState); the other side's rho_hat is evaluated in the walk's
    // mode and directions, over that rho.
    const int lc = x.lightCount;
    auto otherSide = [&](const PathVertex& v, int j, End side, bool onLightWalk, bool onCameraWalk) -> float {
        const float g = requestFrom(tech, j, side);
        if (g < 0.f) return 1.f;
        // (in the walk's mode and directions, as its pair was taken: a compensated lobe's ratio
        // depends on which of the two is the light side, energy_compensation.h)
        if (onLightWalk || onCameraWalk) {
            const TransportMode mode = onLightWalk ? TransportMode::Importance : TransportMode::Radiance;
            if (v.regState.opsr.pair.available()) return v.bxdf->requestRatio(v.regState.opsr.pair, contextFor(mode, g));
            const Vec3 wi = x.direction(j, onLightWalk ? j + 1 : j - 1);
            const Color hat = v.bsdf().eval(v.wo, wi, contextFor(mode, g).valueOnlyCopy()).f;
            return detail::regularisedRatio(hat.x + hat.y + hat.z, v.regState.rhoBar);
        }
        const Vec3 toLight = x.direction(j, j - 1), toCamera = x.direction(j, j + 1);
        const Vec3 wo = side == End::Light ? toLight : toCamera, wi = side == End::Light ? toCamera : toLight;
        return detail::regularisedRatioAt(v.bsdf(), wo, wi, contextFor(modeAt(side), g));
    };
    // R at the glossy inner vertex x_j with `side`'s roughness: its own walk's, or the other side's.
    auto glossyRatio = [&](const PathVertex& v, int j, End side) -> float {
        const bool onLightWalk = j < lc - 1, onCameraWalk = j > lc;
        if ((side == End::Light && onLightWalk) || (side == End::Camera && onCameraWalk)) return v.regState.ratio;
        return otherSide(v, j, side, onLightWalk, onCameraWalk);
    };
    // Technique k's ends are x_{k-1} (R from the light) and x_k (R from the camera). Each inner
    // vertex is classified once, as x_k, and the answer carried to technique k + 1 (measured:
    // -0.2% instructions, BPT with OPSR on cornell-box-ggx, against asking per end). R is 1 at
    // the endpoints and at vertices that are not glossy (a smooth one: its delta flag decides);
    // the technique's own ends have connect's ratios.
    const bool ownEnds = !tech.photon && s >= 1;
    constexpr float kMaxFactor = 1e30f;  // (two ratios near FLT_MIN would overflow the product)
    P.connectionScale[0] = 1.f;          // the emitter hit: no connection vertex
    const PathVertex* prev = nullptr;    // x_{k-1} where it is glossy and inner, else null
    for (int k = 1; k < n; ++k) {
        const PathVertex* v = k <= n - 2 && glossy(x[k]) ? &x[k] : nullptr;
        // (a technique the integrator does not run, or one ending at a delta vertex, is not
        // counted whatever its factor: path.cpp's sum skips it)
        if (!allowsTechnique(set_, k, n - k) || P.delta[k - 1] || P.delta[k]) {
            P.connectionScale[k] = 0.f;
        } else {
            const float rLight = ownEnds && k - 1 == s - 1 && k - 1 >= 1 ? tech.ratioLight
                                 : prev                                 ? glossyRatio(*prev, k - 1, End::Light)
                                                                        : 1.f;
            const float rCamera = ownEnds && k == s && k <= n - 2 ? tech.ratioCamera
                                  : v                             ? glossyRatio(*v, k, End::Camera)
                                                                  : 1.f;
            const float r = rLight * rCamera;
            P.connectionScale[k] = r > 0.f && r < kInf ? std::min(1.f / r, kMaxFactor) : 0.f;
        }
        prev = v;
    }
    P.connectionScale[n] = 0.f;  // (the pinhole: never valid)
    for (int i = 0; i < n; ++i) P.mergeScale[i] = 1.f;  // merges: not regularised
}

}  // namespace lt::reg

namespace lt {

// The templates of path_templates.h for this policy (path.cpp has the unregularised ones).
LT_INSTANTIATE_TRANSPORT(reg::Opsr)

}  // namespace lt
