#include "core/scene.h"
#include "core/curves.h"
#include "core/mesh_attribute.h"
#include "bsdf/normal_perturbation.h"
#include <fmt/core.h>
#include <immintrin.h>
#include <bit>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <type_traits>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace lt {

namespace {

void sphereBounds(const RTCBoundsFunctionArguments* args) {
    const auto* s = static_cast<const SphereGeom*>(args->geometryUserPtr);
    float pad = float(s->r) * 1e-6f;
    args->bounds_o->lower_x = float(s->cx - s->r) - pad;
    args->bounds_o->lower_y = float(s->cy - s->r) - pad;
    args->bounds_o->lower_z = float(s->cz - s->r) - pad;
    args->bounds_o->upper_x = float(s->cx + s->r) + pad;
    args->bounds_o->upper_y = float(s->cy + s->r) + pad;
    args->bounds_o->upper_z = float(s->cz + s->r) + pad;
}

// Ray-sphere intersection in double precision (the geometric form, stable for small spheres far
// away). Returns the nearest root in [tnear, tfar], or a negative value.
double sphereHit(const SphereGeom& s, double ox, double oy, double oz, double dx, double dy, double dz,
                 double tnear, double tfar) {
    double lx = ox - s.cx, ly = oy - s.cy, lz = oz - s.cz;
    double a = dx * dx + dy * dy + dz * dz;
    double b = lx * dx + ly * dy + lz * dz;  // half b
    double c = lx * lx + ly * ly + lz * lz - s.r * s.r;
    // First, without a division, two rejections that give the answers of the test below, and
    // cheaply (called for every ray when the spheres are tested directly):
    // - the origin outside (c > 0) and the centre behind it (b > 0): then q < 0, so both roots
    //   (q / a and c / q) are negative, below tnear >= 0, as computed below too;
    // - the ray's line farther than r from the centre: ll a - b^2 is a times the squared
    //   distance, and the margin (1e-9 ll a) is far above its rounding error (about 1e-15 ll a).
    if (c > 0 && b > 0 && tnear >= 0) return -1;
    const double ll = lx * lx + ly * ly + lz * lz;
    if (ll * a - b * b > (s.r * s.r + 1e-9 * ll) * a) return -1;
    // Distance^2 of the closest approach computed without cancellation.
    double fx = lx - b / a * dx, fy = ly - b / a * dy, fz = lz - b / a * dz;
    double disc = a * (s.r * s.r - (fx * fx + fy * fy + fz * fz));
    if (disc < 0) return -1;
    double sq = std::sqrt(disc);
    double q = -(b + std::copysign(sq, b));
    double t0 = q / a, t1 = (q != 0) ? c / q : t0;
    if (t0 > t1) std::swap(t0, t1);
    if (t0 >= tnear && t0 <= tfar) return t0;
    if (t1 >= tnear && t1 <= tfar) return t1;
    return -1;
}

// sphereHit through the sphere's opacity mask (core/opacity.h): the nearest root in [tnear, tfar]
// that the mask accepts (the far one when it rejects the near one), or a negative value.
double sphereHitMasked(const SphereGeom& s, const RTCRay& r, unsigned geomId, unsigned instId) {
    const double t = sphereHit(s, r.org_x, r.org_y, r.org_z, r.dir_x, r.dir_y, r.dir_z, r.tnear, r.tfar);
    if (t < 0 || !s.mask) return t;
    const float o[3] = {r.org_x, r.org_y, r.org_z}, d[3] = {r.dir_x, r.dir_y, r.dir_z};
    const double c[3] = {s.cx, s.cy, s.cz};
    const Opacity& op = s.mask->opacity;
    if (acceptSphereHit(op, c, s.mask->toLocal, o, d, t, geomId, instId)) return t;
    const double t1 = sphereHit(s, r.org_x, r.org_y, r.org_z, r.dir_x, r.dir_y, r.dir_z, std::nextafter(t, kInf), r.tfar);
    return t1 >= 0 && acceptSphereHit(op, c, s.mask->toLocal, o, d, t1, geomId, instId) ? t1 : -1;
}

void sphereIntersect(const RTCIntersectFunctionNArguments* args) {
    if (!args->valid[0]) return;
    const auto* s = static_cast<const SphereGeom*>(args->geometryUserPtr);
    RTCRayHit* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);  // N == 1 (rtcIntersect1 only)
    RTCRay& r = rh->ray;
    double t = sphereHitMasked(*s, r, args->geomID, args->context->instID[0]);
    if (t < 0) return;
    r.tfar = float(t);
    double px = r.org_x + t * r.dir_x - s->cx, py = r.org_y + t * r.dir_y - s->cy, pz = r.org_z + t * r.dir_z - s->cz;
    rh->hit.Ng_x = float(px);
    rh->hit.Ng_y = float(py);
    rh->hit.Ng_z = float(pz);
    rh->hit.u = 0.f;
    rh->hit.v = 0.f;
    rh->hit.primID = args->primID;
    rh->hit.geomID = args->geomID;
    rh->hit.instID[0] = args->context->instID[0];  // (the instance it is in, if any: instancing.h)
}

void sphereOccluded(const RTCOccludedFunctionNArguments* args) {
    if (!args->valid[0]) return;
    const auto* s = static_cast<const SphereGeom*>(args->geometryUserPtr);
    RTCRay* r = reinterpret_cast<RTCRay*>(args->ray);
    double t = sphereHitMasked(*s, *r, args->geomID, args->context->instID[0]);
    if (t >= 0) r->tfar = -kInf;
}

void embreeError(void*, RTCError code, const char* str) {
    fmt::print(stderr, "embree error {}: {}\n", int(code), str ? str : "");
}

}  // namespace

float meanCurvature(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& n0, const Vec3& n1, const Vec3& n2) {
    const Vec3 p[3] = {p0, p1, p2};
    Vec3 n[3] = {n0, n1, n2};
    for (Vec3& v : n) {
        const float len = glm::length(v);
        if (!(len > 0.f) || !std::isfinite(len)) return 0.f;
        v /= len;
    }
    double sum = 0.0;
    for (int e = 0; e < 3; ++e) {
        const int i = e, j = (e + 1) % 3;
        const Vec3 dp = p[j] - p[i];
        const double len2 = double(glm::dot(dp, dp));
        if (!(len2 > 0.0)) return 0.f;
        sum += double(glm::dot(n[j] - n[i], dp)) / len2;
    }
    const double h = std::abs(sum / 3.0);
    return std::isfinite(h) ? float(h) : 0.f;
}

namespace {

// The weights of the choice between lights, shared by next-event estimation and the light walks
// (one Distribution1D: what is sampled and the probability read back agree), by `rule`, each times
// the light's sampling_weight: Uniform is Mitsuba 3's (its src/render/scene.cpp,
// update_emitter_sampling_distribution), Power in proportion to the power, Mixture half of each
// (normalised apart, so neither half depends on the other's scale). A light that emits nothing
// (power 0, e.g. black) is never chosen.
std::vector<float> lightSelectionWeights(const Scene& scene, const std::vector<Light>& lights,
                                         const std::vector<EmitterDesc>& emitters, LightSelection rule) {
    const size_t n = lights.size();
    std::vector<double> power(n, 0.0);
    double powerSum = 0.0, lit = 0.0;
    for (size_t i = 0; i < n; ++i) {
        const Light& l = lights[i];
        // (area emitters not attached to any shape, which the loader should not produce: power 0)
        const float p = l.type == LightType::Area && l.area <= 0.f ? 0.f : l.power(scene);
        power[i] = p > 0.f && std::isfinite(p) ? double(p) : 0.0;  // (NaN power: not chosen)
        powerSum += power[i];
        lit += power[i] > 0.0 ? 1.0 : 0.0;
    }
    std::vector<float> weight(n, 0.f);
    bool any = false;
    for (size_t i = 0; i < n; ++i) {
        if (!(power[i] > 0.0)) continue;
        double w = 1.0;
        if (rule == LightSelection::Power) w = power[i] / powerSum;
        else if (rule == LightSelection::Mixture) w = 0.5 * power[i] / powerSum + 0.5 / lit;
        weight[i] = float(w * double(emitters[i].samplingWeight));
        any = any || weight[i] > 0.f;
    }
    // No light with both power and weight (every light black): the weights alone, so that a
    // light of weight 0 is still never chosen.
    if (!any)
        for (size_t i = 0; i < n; ++i) weight[i] = emitters[i].samplingWeight;
    return weight;
}

}  // namespace

Scene::Scene(const SceneDesc& desc) : desc_(desc) {
    // One environment (a ray leaving the scene sees one light: the walks' vertex at infinity), as
    // Mitsuba 3 ("Only one environment emitter can be specified per scene"). Checked before any
    // Embree object exists (a constructor that throws runs no destructor).
    if (std::count_if(desc_.emitters.begin(), desc_.emitters.end(), [](const EmitterDesc& e) {
            return e.type == EmitterType::Constant || e.type == EmitterType::Envmap;
        }) > 1)
        throw std::invalid_argument("only one environment emitter (constant or envmap) per scene, as in Mitsuba 3");
    for (const EmitterDesc& e : desc_.emitters)
        if (e.type == EmitterType::Envmap && !e.envmap)
            throw std::invalid_argument("an envmap emitter without its map (" + e.source + ")");
    // sampling_weight (the loader checks each): the choice between lights needs one above 0, as
    // Mitsuba's emitter distribution does.
    for (const EmitterDesc& e : desc_.emitters)
        if (!(std::isfinite(e.samplingWeight) && e.samplingWeight >= 0.f))
            throw std::invalid_argument("sampling_weight must be finite and >= 0 (" + e.source + ")");
    if (!desc_.emitters.empty() && std::all_of(desc_.emitters.begin(), desc_.emitters.end(),
                                               [](const EmitterDesc& e) { return e.samplingWeight == 0.f; }))
        throw std::invalid_argument("every emitter has sampling_weight 0: no light can be chosen (" +
                                    desc_.emitters[0].source + ", ...)");
    device_ = rtcNewDevice("");
    if (!device_) throw std::runtime_error("could not create the Embree device");
    rtcSetDeviceErrorFunction(device_, embreeError, nullptr);
    scene_ = rtcNewScene(device_);
    rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
    for (int i = 0; i < desc_.groupCount; ++i) groupScenes_.push_back(rtcNewScene(device_));  // instancing.h

    Vec3 lo(kInf), hi(-kInf);
    meshLight_.assign(desc_.meshes.size(), -1);
    sphereLight_.assign(desc_.spheres.size(), -1);

    for (size_t i = 0; i < desc_.meshes.size(); ++i) {
        const MeshDesc& m = desc_.meshes[i];
        size_t nv = m.positions.size(), nt = m.indices.size() / 3;
        RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* vb = static_cast<float*>(
            rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), nv));
        for (size_t v = 0; v < nv; ++v) {
            vb[3 * v] = m.positions[v].x;
            vb[3 * v + 1] = m.positions[v].y;
            vb[3 * v + 2] = m.positions[v].z;
            if (m.group >= 0) continue;  // (a shapegroup's: bounded through its instances)
            lo = glm::min(lo, m.positions[v]);
            hi = glm::max(hi, m.positions[v]);
        }
        auto* ib = static_cast<uint32_t*>(
            rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), nt));
        std::copy(m.indices.begin(), m.indices.end(), ib);
        meshMasks_.attach(g, m.opacity, m.uvs.empty() ? nullptr : m.uvs.data(), m.indices.data());  // if masked
        rtcCommitGeometry(g);
        unsigned id = attach(g, m.group);
        GeomInfo& gi = geoms_[id];
        gi.mesh = int(i);
        gi.attributeKey = m.attributeKey;
        gi.uvs = m.uvs.empty() ? nullptr : m.uvs.data();
        gi.indices = m.indices.data();
        triangleCount_ += nt;
    }
    // The hit records (pointers set once the arrays no longer move).
    // Frames replace the normals of flat meshes only: a mesh without normals keeps computing
    // Frame(ng) per hit, as a frame per triangle would add 36 bytes (a second cache line) to each
    // of its triangles (the 1M-triangle bench mesh is one).
    auto flat = [](const MeshDesc& m) {  // are the three vertex normals of every triangle equal?
        if (m.normals.empty()) return false;
        for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
            const Vec3& n0 = m.normals[m.indices[t]];
            if (n0 != m.normals[m.indices[t + 1]] || n0 != m.normals[m.indices[t + 2]]) return false;
        }
        return true;
    };
    std::vector<char> useFrames(desc_.meshes.size());
    size_t withNormals = 0, withFrames = 0;
    for (size_t i = 0; i < desc_.meshes.size(); ++i) {
        const MeshDesc& m = desc_.meshes[i];
        useFrames[i] = flat(m);
        if (useFrames[i]) withFrames += m.indices.size() / 3;
        else if (!m.normals.empty()) withNormals += m.indices.size() / 3;
    }
    tris_.resize(triangleCount_ + 1);
    triNormals_.resize(withNormals + 1);
    triFrames_.resize(withFrames);
    std::vector<size_t> triStart(desc_.meshes.size()), normalStart(desc_.meshes.size(), size_t(-1)),
        frameStart(desc_.meshes.size(), size_t(-1));
    for (size_t i = 0, nTri = 0, nNormal = 0, nFrame = 0; i < desc_.meshes.size(); ++i) {
        const MeshDesc& m = desc_.meshes[i];
        const size_t nt = m.indices.size() / 3;
        triStart[i] = nTri;
        nTri += nt;
        if (useFrames[i]) frameStart[i] = nFrame, nFrame += nt;
        else if (!m.normals.empty()) normalStart[i] = nNormal, nNormal += nt;
        const Vec3* pos = m.positions.data();
        const Vec3* nrm = m.normals.empty() ? nullptr : m.normals.data();
        const uint32_t* idx = m.indices.data();
        MeshTri* tris = tris_.data() + triStart[i];
        MeshTriNormals* tn = nrm && !useFrames[i] ? triNormals_.data() + normalStart[i] : nullptr;
        Frame* tf = useFrames[i] ? triFrames_.data() + frameStart[i] : nullptr;
        tbb::parallel_for(tbb::blocked_range<size_t>(0, nt, 4096), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t t = r.begin(); t != r.end(); ++t) {
                const uint32_t i0 = idx[3 * t], i1 = idx[3 * t + 1], i2 = idx[3 * t + 2];
                const Vec3 p0 = pos[i0], p1 = pos[i1], p2 = pos[i2];
                const Vec3 ng = glm::normalize(glm::cross(p1 - p0, p2 - p0));
                tris[t] = {p0, p1, p2, ng};
                if (tn) tn[t] = {nrm[i0], nrm[i1], nrm[i2], meanCurvature(p0, p1, p2, nrm[i0], nrm[i1], nrm[i2])};
                if (tf) {
                    // What a hit computes from three equal normals, but normalising n itself
                    // (the interpolated b0 n + b1 n + b2 n differs from n by rounding only).
                    Vec3 ns = ng;
                    const float len = glm::length(nrm[i0]);
                    if (len > 0.f && std::isfinite(len)) ns = nrm[i0] / len;
                    if (glm::dot(ns, ng) < 0.f) ns = -ns;
                    tf[t] = Frame(ns);
                }
            }
        });
    }
    for (GeomInfo& gi : geoms_) {
        if (gi.mesh < 0) continue;
        gi.tris = tris_.data() + triStart[gi.mesh];
        gi.normals = normalStart[gi.mesh] == size_t(-1) ? nullptr : triNormals_.data() + normalStart[gi.mesh];
        gi.frames = frameStart[gi.mesh] == size_t(-1) ? nullptr : triFrames_.data() + frameStart[gi.mesh];
    }
    attachCylinders(lo, hi);
    attachCurves(lo, hi);
    spheres_.reserve(desc_.spheres.size());
    for (size_t i = 0; i < desc_.spheres.size(); ++i) {
        const SphereDesc& s = desc_.spheres[i];
        spheres_.push_back({s.center.x, s.center.y, s.center.z, s.radius});
        if (s.opacity.masked()) spheres_.back().mask = &s;
    }
    // A few spheres are tested directly after Embree's meshes (direct_): with Embree they are a
    // second BVH, traversed by every ray, whose leaves call back into sphereHit.
    direct_ = !desc_.spheres.empty() && desc_.spheres.size() <= kDirectSpheres && desc_.groupCount == 0;
    if (direct_) embreeGeoms_ = geoms_.size();
    for (size_t i = 0; i < desc_.spheres.size(); ++i) {
        const SphereDesc& s = desc_.spheres[i];
        unsigned id = unsigned(geoms_.size());
        if (!direct_) attachSphere(s.group < 0 ? scene_ : groupScenes_[size_t(s.group)], i, id);
        if (geoms_.size() <= id) geoms_.resize(id + 1);
        geoms_[id].sphere = int(i);
        geoms_[id].curvature = s.radius > 0.f ? 1.f / s.radius : 0.f;
        if (s.group >= 0) continue;
        lo = glm::min(lo, s.center - Vec3(s.radius));
        hi = glm::max(hi, s.center + Vec3(s.radius));
    }
    attachInstances(lo, hi);
    rtcCommitScene(scene_);

    camera_ = std::make_unique<Camera>(desc_.camera);
    geometryRadius_ = lo.x <= hi.x ? std::max(0.5f * glm::length(hi - lo), 1e-6f) : 0.f;
    geometryCenter_ = 0.5f * (lo + hi);
    // Bounds include the camera so that lights at infinity cover everything seen.
    lo = glm::min(lo, camera_->position());
    hi = glm::max(hi, camera_->position());
    center_ = 0.5f * (lo + hi);
    radius_ = std::max(0.5f * glm::length(hi - lo), 1e-6f);
    // Offsets scale with the scene: the same image for a scene scaled by 1e-3 or 1e3.
    offsetScale_ = radius_ * 2e-6f;
    if (geometryRadius_ == 0.f) geometryRadius_ = radius_, geometryCenter_ = center_;

    // Lights.
    lights_.reserve(desc_.emitters.size());
    std::vector<int> emitterToLight(desc_.emitters.size(), -1);
    for (size_t e = 0; e < desc_.emitters.size(); ++e) {
        const EmitterDesc& ed = desc_.emitters[e];
        Light l;
        l.value = ed.value;
        l.position = ed.position;
        switch (ed.type) {
            case EmitterType::Area: l.type = LightType::Area; break;
            case EmitterType::Point: l.type = LightType::Point; break;
            case EmitterType::Spot:
                l.type = LightType::Spot;
                l.direction = glm::normalize(ed.direction);
                l.cutoff = glm::radians(ed.cutoffAngleDeg);
                l.beamWidth = glm::radians(std::min(ed.beamWidthDeg, ed.cutoffAngleDeg));
                l.cosCutoff = std::cos(l.cutoff);
                break;
            case EmitterType::Directional:
                l.type = LightType::Directional;
                l.direction = glm::normalize(ed.direction);
                break;
            case EmitterType::Constant: l.type = LightType::Constant; break;
            case EmitterType::Envmap:
                l.type = LightType::Envmap;
                l.envmap = ed.envmap.get();
                break;
            case EmitterType::Projector: l.type = LightType::Projector; break;
        }
        l.setTextures(ed);  // textured area, spot and projector (core/textured_lights.cpp)
        emitterToLight[e] = int(lights_.size());
        lights_.push_back(l);
    }
    meshTriDist_.resize(desc_.meshes.size());
    std::vector<size_t> emitterTriStart(desc_.meshes.size());
    for (size_t i = 0; i < desc_.meshes.size(); ++i) {
        const MeshDesc& m = desc_.meshes[i];
        if (m.emitter < 0) continue;
        int li = emitterToLight.at(m.emitter);
        Light& l = lights_[li];
        l.meshIndex = int(i);
        // Each triangle ready for sampling, and its area for the choice between triangles.
        std::vector<float> areas(m.indices.size() / 3);
        emitterTriStart[i] = emitterTris_.size();
        double total = 0;
        for (size_t t = 0; t < areas.size(); ++t) {
            const Vec3& a = m.positions[m.indices[3 * t]];
            const Vec3& b = m.positions[m.indices[3 * t + 1]];
            const Vec3& c = m.positions[m.indices[3 * t + 2]];
            Vec3 n = glm::cross(b - a, c - a);
            float len = glm::length(n);
            total += (areas[t] = 0.5f * len);
            emitterTris_.push_back({a, b - a, c - a, len > 0.f ? n / len : Vec3(0.f)});
        }
        l.area = float(total);
        l.invArea = total > 0 ? float(1.0 / total) : 0.f;
        meshTriDist_[i] = Distribution1D(areas);
        meshLight_[i] = li;
    }
    for (Light& l : lights_) {  // (the arrays no longer move)
        if (l.meshIndex < 0) continue;
        l.tris = emitterTris_.data() + emitterTriStart[l.meshIndex];
        l.triDist = &meshTriDist_[l.meshIndex];
    }
    for (size_t i = 0; i < desc_.spheres.size(); ++i) {
        const SphereDesc& s = desc_.spheres[i];
        if (s.emitter < 0) continue;
        int li = emitterToLight.at(s.emitter);
        lights_[li].sphere = &s;
        lights_[li].area = 4.f * kPi * s.radius * s.radius;
        lights_[li].invArea = lights_[li].area > 0.f ? 1.f / lights_[li].area : 0.f;
        sphereLight_[i] = li;
    }
    cylinderLights(emitterToLight);
    // Bounding spheres of the emitting shapes (mayHitEmitter): a mesh's from its emitting
    // triangles' corners (the centre of their box, the largest distance to a corner), a sphere's
    // its own; each radius enlarged by 1e-3 of itself and 1e-5 of the scene's extent, far above
    // float rounding in the test.
    for (size_t i = 0; i < desc_.meshes.size(); ++i) {
        if (meshLight_[i] < 0) continue;
        const MeshDesc& m = desc_.meshes[i];
        Vec3 lo(kInf), hi(-kInf);
        for (uint32_t k : m.indices) lo = glm::min(lo, m.positions[k]), hi = glm::max(hi, m.positions[k]);
        const Vec3 c = 0.5f * (lo + hi);
        float r = 0.f;
        for (uint32_t k : m.indices) r = std::max(r, glm::length(m.positions[k] - c));
        emitterBounds_.push_back({c, r});
    }
    for (size_t i = 0; i < desc_.spheres.size(); ++i)
        if (sphereLight_[i] >= 0) emitterBounds_.push_back({desc_.spheres[i].center, desc_.spheres[i].radius});
    float extent = 0.f;
    for (const EmitterBound& b : emitterBounds_) extent = std::max(extent, glm::length(b.center) + b.radius);
    for (EmitterBound& b : emitterBounds_) b.radius = b.radius * (1.f + 1e-3f) + 1e-5f * extent;
    manyEmitters_ = emitterBounds_.size() > kMaxEmitterBounds;
    if (manyEmitters_) emitterBounds_.clear();
    lightDist_ = Distribution1D(lightSelectionWeights(*this, lights_, desc_.emitters, desc_.lightSelection));
    for (const Light& l : lights_)
        if (l.isEnvironment()) envLights_.push_back(&l);  // (at most one: checked above)
    // Materials and emitters per Embree geometry (lights_ no longer changes: pointers are stable).
    for (GeomInfo& gi : geoms_) {
        int bsdf = -1, light = -1;
        if (gi.mesh >= 0) bsdf = desc_.meshes[gi.mesh].bsdf, light = meshLight_[gi.mesh];
        else if (gi.sphere >= 0) bsdf = desc_.spheres[gi.sphere].bsdf, light = sphereLight_[gi.sphere];
        else if (gi.cylinder >= 0) bsdf = desc_.cylinders[gi.cylinder].bsdf, light = cylinderLight_[gi.cylinder];
        else if (gi.curve >= 0) bsdf = desc_.curves[gi.curve].bsdf;  // (never emitting: core/curves.h)
        gi.bxdf = bsdf >= 0 ? desc_.bsdfs[bsdf].get() : nullptr;
        gi.perturb = dynamic_cast<const NormalPerturbation*>(gi.bxdf);
        gi.tangentFrame = gi.perturb || (gi.bxdf && gi.bxdf->anisotropic());
        gi.light = light >= 0 ? &lights_[light] : nullptr;
        gi.deltaBsdf = gi.bxdf && gi.bxdf->isDelta();
        gi.textured = (gi.bxdf && gi.bxdf->textured()) || (gi.light && gi.light->texture);
        gi.roughness = gi.bxdf ? gi.bxdf->roughness() : 1.f;
    }
}

void Scene::attachSphere(RTCScene scene, size_t i, unsigned id) {
    RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(g, 1);
    rtcSetGeometryUserData(g, &spheres_[i]);
    rtcSetGeometryBoundsFunction(g, sphereBounds, nullptr);
    rtcSetGeometryIntersectFunction(g, sphereIntersect);
    rtcSetGeometryOccludedFunction(g, sphereOccluded);
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(scene, g, id);
    rtcReleaseGeometry(g);
}

RTCScene Scene::embreeScene() const {
    if (!direct_) return scene_;
    // Every shape in Embree (raybench's bare casts): the meshes again, and the spheres as user
    // geometry, with the same geometry ids as the renderer's.
    std::call_once(fullOnce_, [&] {
        fullScene_ = rtcNewScene(device_);
        rtcSetSceneBuildQuality(fullScene_, RTC_BUILD_QUALITY_HIGH);
        for (unsigned id = 0; id < embreeGeoms_; ++id) rtcAttachGeometryByID(fullScene_, rtcGetGeometry(scene_, id), id);
        for (size_t i = 0; i < spheres_.size(); ++i)
            const_cast<Scene*>(this)->attachSphere(fullScene_, i, unsigned(embreeGeoms_ + i));
        rtcCommitScene(fullScene_);
    });
    return fullScene_;
}

Scene::~Scene() {
    if (fullScene_) rtcReleaseScene(fullScene_);
    for (RTCScene s : groupScenes_) rtcReleaseScene(s);
    if (scene_) rtcReleaseScene(scene_);
    if (device_) rtcReleaseDevice(device_);
}

// The probability with which a light sample picks l, as the emitter-hit technique's MIS reads it.
// A light the distribution never picks (sampling_weight 0) reads kUnchosenSelection instead of 0:
// the MIS sums count a stored density of 0 as 1 (an entry a walk could not fill:
// integrators/transport/path_inline.h, remapDensity), which would weight the emitter hit, this
// light's only technique, below 1. With a positive stand-in the light techniques' share is of order
// (1e-12 pdf_light / pdf_bsdf)^2 (next-event estimation's term; the light walks' carry the same
// factor), below 1e-12 of the image for any density ratio below 1e6. Nothing samples with it.
constexpr float kUnchosenSelection = 1e-12f;

float Scene::lightSelectionProb(const Light* l) const {
    if (lights_.empty()) return 0.f;
    const float p = lightDist_.probability(size_t(l - lights_.data()));
    return p > 0.f ? p : kUnchosenSelection;
}

// Fills an Embree ray with whole 16-byte stores: Embree loads (org, tnear) and (dir, time) as
// 16-byte vectors, and a vector load from four separate scalar stores cannot be forwarded from
// the store buffer (a stall of about a dozen cycles per ray, measured with perf).
// The Ray is read as its two 16-byte halves (o.xyz d.x | d.y d.z tMin tMax), the two stores
// sse::makeRay and Scene::shadowRay build it with: a load that spans both stores cannot be
// forwarded either.
static void fillRay(RTCRay& r, const Ray& ray) {
    static_assert(offsetof(RTCRay, tnear) == 12 && offsetof(RTCRay, time) == 28 && offsetof(RTCRay, flags) == 44);
    static_assert(offsetof(Ray, d) == 12 && offsetof(Ray, tMin) == 24 && offsetof(Ray, tMax) == 28 && sizeof(Ray) == 32);
    auto* f = reinterpret_cast<float*>(&r);
    const float* src = &ray.o.x;
    const __m128 h0 = _mm_loadu_ps(src);      // o.x o.y o.z d.x
    const __m128 h1 = _mm_loadu_ps(src + 4);  // d.y d.z tMin tMax
    const __m128 zt = _mm_shuffle_ps(h0, h1, _MM_SHUFFLE(2, 2, 2, 2));  // o.z o.z tMin tMin
    _mm_storeu_ps(f, _mm_shuffle_ps(h0, zt, _MM_SHUFFLE(2, 0, 1, 0)));   // o.x o.y o.z tMin
    const __m128 dd = _mm_shuffle_ps(h0, h1, _MM_SHUFFLE(1, 0, 3, 3));  // d.x d.x d.y d.z
    _mm_storeu_ps(f + 4, _mm_and_ps(_mm_shuffle_ps(dd, dd, _MM_SHUFFLE(3, 3, 2, 0)),  // d, time 0
                                    _mm_castsi128_ps(_mm_setr_epi32(-1, -1, -1, 0))));
    _mm_storeu_ps(f + 8, _mm_or_ps(_mm_and_ps(_mm_shuffle_ps(h1, h1, _MM_SHUFFLE(3, 3, 3, 3)),  // tfar, mask, id, flags
                                              _mm_castsi128_ps(_mm_setr_epi32(-1, 0, 0, 0))),
                                   _mm_castsi128_ps(_mm_setr_epi32(0, -1, 0, 0))));
}

namespace {
using sse::dot3;
using sse::toVec3;
// loadPadded3 reads 16 bytes: the caller guarantees 4 readable bytes after the Vec3.
inline __m128 loadPadded3(const Vec3& v) { return _mm_loadu_ps(&v.x); }
inline __m128 set3(const Vec3& v) { return _mm_setr_ps(v.x, v.y, v.z, 0.f); }
// w0 a + w1 b + w2 c, per lane in the order glm's `b0 * p0 + b1 * p1 + b2 * p2` evaluates it
// (the same floats).
inline __m128 blend3(float w0, __m128 a, float w1, __m128 b, float w2, __m128 c) {
    return _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_set1_ps(w0), a), _mm_mul_ps(_mm_set1_ps(w1), b)),
                      _mm_mul_ps(_mm_set1_ps(w2), c));
}
}  // namespace

template <class Hit>
bool Scene::intersectImpl(const Ray& ray, Hit& hit) const {
    constexpr bool kFull = std::is_same_v<Hit, SurfaceHit>;  // also t, uv and the ids
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh;
    fillRay(rh.ray, ray);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_, &ctx, &rh);
    if (direct_)  // the spheres after the meshes, as Embree's callback would test them
        for (size_t i = 0; i < spheres_.size(); ++i) {
            const RTCRay& r = rh.ray;
            const double t = sphereHitMasked(spheres_[i], r, unsigned(embreeGeoms_ + i), RTC_INVALID_GEOMETRY_ID);
            if (t < 0) continue;
            rh.ray.tfar = float(t);
            rh.hit.geomID = unsigned(embreeGeoms_ + i);
            rh.hit.primID = 0;
        }
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
    const GeomInfo& gi = geoms_[rh.hit.geomID];
    // A hit inside an instance (never with direct_): on the group's shape, in the group's space.
    const InstanceXf* ix = rh.hit.instID[0] == RTC_INVALID_GEOMETRY_ID
                               ? nullptr
                               : &instances_[size_t(geoms_[rh.hit.instID[0]].instance)];
    if constexpr (kFull) {
        hit.t = rh.ray.tfar;
        hit.geomId = int(rh.hit.geomID);
        hit.primId = int(rh.hit.primID);
    }
    hit.bxdf = gi.bxdf;
    hit.light = gi.light;
    hit.deltaBsdf = gi.deltaBsdf;
    hit.roughness = gi.roughness;
    hit.curvature = gi.curvature;
    __m128 p, ng, ns;
    const Frame* frame = nullptr;  // the triangle's constant shading frame, if it has one
    if (gi.mesh >= 0) {
        const size_t prim = rh.hit.primID;
        const MeshTri& tri = gi.tris[prim];  // the record after it (or the padding one) is readable
        const float b1 = rh.hit.u, b2 = rh.hit.v, b0 = 1.f - b1 - b2;
        p = blend3(b0, loadPadded3(tri.p0), b1, loadPadded3(tri.p1), b2, loadPadded3(tri.p2));  // barycentric: more accurate than o + t d
        ns = ng = loadPadded3(tri.ng);
        if (gi.frames) {
            frame = &gi.frames[prim];
        } else if (gi.normals) {
            const MeshTriNormals& tn = gi.normals[prim];
            __m128 n = blend3(b0, loadPadded3(tn.n0), b1, loadPadded3(tn.n1), b2, loadPadded3(tn.n2));
            float len = std::sqrt(dot3(n, n));
            if (len > 0.f && std::isfinite(len)) ns = _mm_div_ps(n, _mm_set1_ps(len));
            hit.curvature = tn.curvature;
        }
        if (kFull || gi.textured) {
            if (gi.attributeKey) {
                hit.uv = attributeKey(uint32_t(prim), b1, b2);
            } else if (gi.uvs) {
                const uint32_t* idx = gi.indices + 3 * prim;
                hit.uv = b0 * gi.uvs[idx[0]] + b1 * gi.uvs[idx[1]] + b2 * gi.uvs[idx[2]];
            } else {
                hit.uv = Vec2(0.f);
            }
        }
    } else if (gi.cylinder >= 0) {
        const CylinderSurface c = ix ? cylinderSurface(cylinders_[size_t(gi.cylinder)], toObjectRay(*ix, ray).o,
                                                       toObjectRay(*ix, ray).d, rh.ray.tfar)
                                     : cylinderSurface(cylinders_[size_t(gi.cylinder)], ray.o, ray.d, rh.ray.tfar);
        p = set3(c.p);
        ns = ng = set3(c.n);
        if (kFull || gi.textured) hit.uv = c.uv;
    } else if (gi.curve >= 0) {
        const Ray lr = ix ? toObjectRay(*ix, ray) : ray;  // (the group's space)
        const CurveSurface c = curveSurface(desc_.curves[size_t(gi.curve)], rh.hit.primID, rh.hit.u,
                                            Vec3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z), lr.o, lr.d, rh.ray.tfar);
        p = set3(c.p);
        ns = ng = set3(c.n);
        hit.curvature = c.curvature;
        if (kFull || gi.textured) hit.uv = c.uv;
    } else {
        const SphereDesc& s = desc_.spheres[gi.sphere];
        const Ray lr = ix ? toObjectRay(*ix, ray) : ray;  // (the group's space)
        Vec3 d = lr.o + rh.ray.tfar * lr.d - s.center;
        Vec3 n = glm::normalize(d);
        p = set3(s.center + s.radius * n);  // re-project onto the sphere
        if (s.flipNormals) n = -n;
        ns = ng = set3(n);
        if (kFull || gi.textured) {
            // Mitsuba's sphere: u = phi / (2 pi) with phi in [0, 2 pi), v = theta / pi, about the
            // sphere's local z (SphereDesc::toLocal: the rotation of its to_world undone).
            const Vec3 dl = glm::normalize(s.toLocal * d);
            float phi = std::atan2(dl.y, dl.x);
            if (phi < 0.f) phi += 2.f * kPi;
            hit.uv = Vec2(phi * (0.5f * kInvPi), std::acos(std::clamp(dl.z, -1.f, 1.f)) * kInvPi);
        }
    }
    // p and ng as whole 16-byte stores, in this order (each spills one float into the next field,
    // which the next store overwrites): the caller's 8- and 4-byte loads of them are then each
    // inside one store and forwarded from the store buffer.
    static_assert(offsetof(SurfacePoint, ng) == offsetof(SurfacePoint, p) + 12 &&
                  offsetof(SurfacePoint, shading) == offsetof(SurfacePoint, ng) + 12);
    if (ix) {
        if (frame) ns = set3(frame->n), frame = nullptr;
        instanceToWorld(*ix, p, ng, ns);
        hit.curvature *= ix->curvatureScale;
    }
    SurfacePoint& sp = hit;
    _mm_storeu_ps(&sp.p.x, p);
    _mm_storeu_ps(&sp.ng.x, ng);
    if (gi.tangentFrame) [[unlikely]] {
        if (dot3(ns, ng) < 0.f) ns = _mm_xor_ps(ns, _mm_set1_ps(-0.f));
        sp.shading = perturbedFrame(gi, rh.hit.primID, rh.hit.u, rh.hit.v, ray, ix, sp.p, sp.ng,
                                    frame ? frame->n : toVec3(ns));
        return true;
    }
    if (frame) {
        sp.shading = *frame;
        return true;
    }
    // The shading normal lives on the same side as the geometric one.
    if (dot3(ns, ng) < 0.f) ns = _mm_xor_ps(ns, _mm_set1_ps(-0.f));
    sp.shading = Frame(toVec3(ns));
    return true;
}

// The surface's dp/du and dp/dv as Mitsuba 3 computes them (meshes: from the triangle's uv
// differences, Frame(ng)'s tangents where it has no uv or they are degenerate; spheres and
// cylinders: their analytic parameterisations, u = phi / 2 pi and v = theta / pi or the height;
// curves: Frame(ng)'s), the unperturbed frame from them
// (tangentFrame), and the material's perturbation of it (bsdf/normal_perturbation.h).
Frame Scene::perturbedFrame(const GeomInfo& gi, unsigned prim, float b1, float b2, const Ray& ray,
                            const InstanceXf* ix, const Vec3& p, const Vec3& ng, const Vec3& n) const {
    TangentSpace ts;
    ts.ng = ng;
    ts.wo = -ray.d;
    ts.uv = Vec2(0.f);
    bool ok = false;
    if (gi.mesh >= 0) {
        const MeshTri& tri = gi.tris[prim];
        if (gi.uvs) {
            const uint32_t* idx = gi.indices + 3 * size_t(prim);
            const Vec2 uv0 = gi.uvs[idx[0]], uv1 = gi.uvs[idx[1]], uv2 = gi.uvs[idx[2]];
            ts.uv = (1.f - b1 - b2) * uv0 + b1 * uv1 + b2 * uv2;
            const Vec2 duv0 = uv1 - uv0, duv1 = uv2 - uv0;
            const Vec3 dp0 = tri.p1 - tri.p0, dp1 = tri.p2 - tri.p0;
            const float det = duv0.x * duv1.y - duv0.y * duv1.x;
            if (det != 0.f) {
                const float inv = 1.f / det;
                ts.dpdu = (duv1.y * dp0 - duv0.y * dp1) * inv;
                ts.dpdv = (duv0.x * dp1 - duv1.x * dp0) * inv;
                ok = isFinite(ts.dpdu) && isFinite(ts.dpdv);
            }
        }
    } else if (gi.sphere >= 0) {
        // (in the sphere's local frame, SphereDesc::toLocal, about its z as its uv; an instance's
        // hit point taken back to the group's space)
        const SphereDesc& s = desc_.spheres[gi.sphere];
        const Vec3 po = ix ? Vec3(ix->toObject * glm::vec4(p, 1.f)) : p;
        const Vec3 l = glm::normalize(s.toLocal * (po - s.center));
        float phi = std::atan2(l.y, l.x);
        if (phi < 0.f) phi += 2.f * kPi;
        ts.uv = Vec2(phi * (0.5f * kInvPi), std::acos(std::clamp(l.z, -1.f, 1.f)) * kInvPi);
        const float rd = std::sqrt(l.x * l.x + l.y * l.y);
        const glm::mat3 toSphereWorld = glm::transpose(s.toLocal);  // (a rotation)
        ts.dpdu = toSphereWorld * ((2.f * kPi * s.radius) * Vec3(-l.y, l.x, 0.f));
        ts.dpdv = toSphereWorld * (rd > 0.f ? (kPi * s.radius) * Vec3(l.z * l.x / rd, l.z * l.y / rd, -rd)
                                            : Vec3(kPi * s.radius, 0.f, 0.f));
        ok = isFinite(ts.dpdu) && isFinite(ts.dpdv);
    } else if (gi.cylinder >= 0) {
        // (Mitsuba's cylinder: dp/du = 2 pi (-y, x, 0) and dp/dv = (0, 0, 1) at the object-space
        // point of the unit cylinder, to the world by the shape's linear part; core/cylinder.h)
        const CylinderGeom& c = cylinders_[size_t(gi.cylinder)];
        const Vec3 po = ix ? Vec3(ix->toObject * glm::vec4(p, 1.f)) : p;
        double l[3];
        for (int r = 0; r < 3; ++r)
            l[r] = c.toObject[r][0] * po.x + c.toObject[r][1] * po.y + c.toObject[r][2] * po.z + c.toObject[r][3];
        const double du[3] = {-2.0 * double(kPi) * l[1], 2.0 * double(kPi) * l[0], 0.0};
        for (int r = 0; r < 3; ++r) {
            ts.dpdu[r] = float(c.toWorld[r][0] * du[0] + c.toWorld[r][1] * du[1]);
            ts.dpdv[r] = float(c.toWorld[r][2]);
        }
        double phi = std::atan2(l[1], l[0]);
        if (phi < 0.0) phi += 2.0 * double(kPi);
        ts.uv = Vec2(float(phi / (2.0 * double(kPi))), float(l[2]));
        ok = isFinite(ts.dpdu) && isFinite(ts.dpdv);
    }
    if (ok && ix) {  // (the group's space to the world: tangents map by the linear part)
        ts.dpdu = glm::mat3(ix->toWorld) * ts.dpdu;
        ts.dpdv = glm::mat3(ix->toWorld) * ts.dpdv;
    }
    if (!ok) {
        const Frame f(ng);
        ts.dpdu = f.s;
        ts.dpdv = f.t;
    }
    ts.shading = tangentFrame(n, ts.dpdu);
    return gi.perturb ? gi.perturb->frame(ts) : ts.shading;
}

bool Scene::intersect(const Ray& ray, SurfaceHit& hit) const { return intersectImpl(ray, hit); }
bool Scene::intersect(const Ray& ray, SurfacePoint& hit) const { return intersectImpl(ray, hit); }

bool Scene::occludedRay(const Ray& r) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRay rr;
    fillRay(rr, r);
    if (direct_)  // the spheres first: a hit on one ends the query without Embree
        for (size_t i = 0; i < spheres_.size(); ++i)
            if (sphereHitMasked(spheres_[i], rr, unsigned(embreeGeoms_ + i), RTC_INVALID_GEOMETRY_ID) >= 0)
                return true;
    rtcOccluded1(scene_, &ctx, &rr);
    return rr.tfar < 0.f;
}

bool Scene::mayHitEmitter(const Ray& ray) const {
    if (manyEmitters_) return true;
    const float dd = glm::dot(ray.d, ray.d);
    for (const EmitterBound& b : emitterBounds_) {
        const Vec3 oc = b.center - ray.o;
        const float r2 = b.radius * b.radius;
        if (glm::dot(oc, oc) <= r2) return true;     // the origin inside
        if (glm::dot(oc, ray.d) < 0.f) continue;     // the sphere behind the origin
        const Vec3 x = glm::cross(oc, ray.d);        // |oc x d|^2 / |d|^2: the squared distance
        if (glm::dot(x, x) <= r2 * dd) return true;  // of the centre from the ray's line
    }
    return false;
}

}  // namespace lt
