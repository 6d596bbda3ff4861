#include "integrators/transport/kd13.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include "integrators/transport/path_templates.h"

namespace lt::reg {

Kd13::Kd13(const Kd13Settings& settings) : settings_(settings) {
    if (!(settings.lambda < 0.5))
        throw std::invalid_argument("KD13: lambda must be in [0, 1/2) (r_N = r0 N^-lambda, consistent for lambda < 1/d, "
                                    "d = 2 per mollified vertex), got " + std::to_string(settings.lambda));
    if (!std::isfinite(settings.r0))
        throw std::invalid_argument("KD13: the initial radius r0 must be finite, got " + std::to_string(settings.r0));
    r0_ = settings.r0 > 0.0 ? settings.r0 : 0.01;  // (beginIteration: 1% of the geometry's radius)
    farLength_ = 2.0;
    setRadii();
}

void Kd13::beginIteration(uint64_t n, const Scene& scene, const MisConfig& cfg) {
    n_ = n;
    const double radius = double(scene.geometryRadius());
    r0_ = settings_.r0 > 0.0 ? settings_.r0 : 0.01 * radius;  // Sec. 6: 1% of the scene's bounding radius
    farLength_ = radius > 0.0 ? 2.0 * radius : 1.0;
    setRadii();
    set_ = cfg.set;
    merging_ = cfg.merging;
    deltaLights_.clear();
    for (size_t i = 0; i < scene.lights().size(); ++i)
        if (scene.lights()[i].isDelta()) deltaLights_.push_back(uint32_t(i));
    coneHitsCompete_ = scene.lights().size() > 1;
}

double Kd13::lambda(int mollified) const {
    if (settings_.lambda >= 0.0) return settings_.lambda;
    return mollified >= 2 ? 1.0 / 12.0 : 1.0 / 6.0;  // Sec. 5.1
}

void Kd13::setRadii() {
    for (int m : {1, 2}) radii_[m - 1] = r0_ * std::pow(double(std::max<uint64_t>(n_, 1)), -lambda(m));
}

double Kd13::radius(int mollified) const { return radii_[mollified >= 2 ? 1 : 0]; }

double Kd13::coneAngle(int mollified, double length) const {
    const double l = std::isinf(length) ? farLength_ : length;  // (a NaN stays NaN: regularizer.h (7))
    return std::atan2(radius(mollified), l);  // arctan(r / l), l >= 0
}

Kd13::Choice Kd13::choose(const Technique& tech) const {
    Choice c;
    const int s = tech.s, t = tech.t, n = s + t;
    auto vertex = [&](int j) -> const PathVertex& { return j < s ? tech.y[j] : tech.z[n - 1 - j]; };
    c.samplable = samplableUnregularised(tech, set_, merging_);
    if (c.samplable) return c;
    // The maximum-distance heuristic over the connections a cone makes samplable.
    for (int k = 1; k < n; ++k) {
        if (!allowsTechnique(set_, k, n - k)) continue;
        const PathVertex &a = vertex(k - 1), &b = vertex(k);
        int count = 0, ends[2] = {-1, -1};
        bool possible = true;
        for (int j : {k - 1, k}) {
            const PathVertex& v = vertex(j);
            if (plain(v)) continue;
            if (!mollifiable(v)) possible = false;
            else ends[count++] = j;
        }
        if (!possible) continue;
        const double length = a.infinite || b.infinite ? kInf : double(glm::length(a.p - b.p));
        if (c.technique < 0 || count < c.count || (count == c.count && length > c.length)) {
            c.technique = k;
            c.count = count;
            c.length = length;
            c.mollified[0] = ends[0];
            c.mollified[1] = ends[1];
        }
    }
    return c;
}

bool Kd13::selectMollified(Technique& tech) const {
    const Choice c = choose(tech);
    if (c.samplable || c.technique != tech.s) return false;  // another technique's path
    const float eps = float(coneAngle(c.count, c.length));
    if (std::isnan(eps)) {  // regularizer.h (7): refused and counted
        invalid_.add();
        return false;
    }
    if (!(eps > 0.f)) return false;  // (a cone too narrow for float: nothing to add)
    for (int m = 0; m < 2; ++m) {
        tech.regularised[m] = c.mollified[m];
        tech.bound[m] = eps;
    }
    return true;
}

void Kd13::densities(const Technique& tech, PathPdfs& P) const {
    // (2): the chosen technique alone; its own density decides nothing (weight 1).
    for (int j : tech.regularised)
        if (j >= 0) P.delta[j] = false;  // a smooth vertex mollified: a connection end now
    for (int k = 0; k <= P.n; ++k) P.connectionScale[k] = k == tech.s ? 1.f : 0.f;
    for (int i = 0; i < P.n; ++i) P.mergeScale[i] = 0.f;
    P.regularised = true;
    // (5): in the path tracer the cone hit competes with next-event estimation (the chosen
    // technique there, whose camera end is the mollified vertex).
    if (set_ == TechniqueSet::PathTracer && coneHitsCompete_ && tech.s == 1 && boundAt(tech, End::Camera) > 0.f) {
        const float p = coneHitDensity(tech);
        if (p > 0.f) {
            P.fromCamera[0] = p;
            P.lightHittable = true;
            P.connectionScale[0] = 1.f;
        }
    }
}

float Kd13::coneHitDensity(const Technique& tech) {
    const PathVertex& v = tech.z[tech.t - 1];
    const float lightSide = glm::dot(v.shading.n, tech.y[0].p - v.p);
    // The delta lobes' probabilities from the BSDF's own sampling (bsdf.h: a delta sample's pdfFwd
    // is the probability of its lobe): uLobe 0 and just below 1 reach both lobes of a dielectric.
    const SurfaceBsdf bsdf = v.bsdf();
    for (float uLobe : {0.f, 0x1.fffffep-1f}) {
        BsdfSample bs;
        if (bsdf.sample(v.wo, uLobe, Vec2(0.5f), kRadianceContext, bs) && (bs.lobe & kDelta) &&
            glm::dot(v.shading.n, bs.wi) * lightSide > 0.f)
            return bs.pdfFwd.value;
    }
    return 0.f;
}

}  // namespace lt::reg

namespace lt {

// The templates of path_templates.h for this policy (path.cpp has the unregularised ones).
LT_INSTANTIATE_TRANSPORT(reg::Kd13)

}  // namespace lt
