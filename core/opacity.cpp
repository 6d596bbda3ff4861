// Opacity masks: the hash decision and Embree's filter functions of masked meshes (core/opacity.h).
#include "core/opacity.h"

#include <embree3/rtcore.h>
#include <algorithm>
#include <bit>
#include <cmath>

namespace lt {

namespace {

// SplitMix64's finaliser (Steele et al. 2014): a bijection of 64-bit words whose output bits each
// depend on every input bit.
inline uint64_t mix64(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

inline uint64_t pack(float a, float b) {
    return uint64_t(std::bit_cast<uint32_t>(a)) | (uint64_t(std::bit_cast<uint32_t>(b)) << 32);
}

// The triangle's filter, for rtcIntersect and rtcOccluded alike: a rejected hit's valid lane is
// cleared, and Embree continues as if the primitive were not there.
void meshFilter(const RTCFilterFunctionNArguments* args) {
    const auto* rec = static_cast<const MeshMasks::Record*>(args->geometryUserPtr);
    const unsigned n = args->N;
    for (unsigned i = 0; i < n; ++i) {
        if (args->valid[i] != -1) continue;
        const unsigned prim = RTCHitN_primID(args->hit, n, i);
        const float b1 = RTCHitN_u(args->hit, n, i), b2 = RTCHitN_v(args->hit, n, i), b0 = 1.f - b1 - b2;
        Vec2 uv(0.f);
        if (rec->uvs) {  // (as Scene::intersect interpolates the hit's uv)
            const uint32_t* idx = rec->indices + 3 * size_t(prim);
            uv = b0 * rec->uvs[idx[0]] + b1 * rec->uvs[idx[1]] + b2 * rec->uvs[idx[2]];
        }
        const float org[3] = {RTCRayN_org_x(args->ray, n, i), RTCRayN_org_y(args->ray, n, i),
                              RTCRayN_org_z(args->ray, n, i)};
        const float dir[3] = {RTCRayN_dir_x(args->ray, n, i), RTCRayN_dir_y(args->ray, n, i),
                              RTCRayN_dir_z(args->ray, n, i)};
        if (!acceptMaskedHit(*rec->opacity, uv, org, dir, RTCHitN_geomID(args->hit, n, i), prim,
                             RTCHitN_instID(args->hit, n, i, 0), 0))
            args->valid[i] = 0;
    }
}

}  // namespace

bool acceptMaskedHit(const Opacity& op, const Vec2& uv, const float org[3], const float dir[3], unsigned geomId,
                     unsigned primId, unsigned instId, unsigned root) {
    const float o = op.eval(uv);
    if (o >= 1.f) return true;
    if (!(o > 0.f)) return false;
    uint64_t h = 0x6a09e667f3bcc909ull;  // (an arbitrary non-zero start: sqrt(2)'s fraction bits)
    h = mix64(h ^ pack(org[0], org[1]));
    h = mix64(h ^ pack(org[2], dir[0]));
    h = mix64(h ^ pack(dir[1], dir[2]));
    h = mix64(h ^ (uint64_t(primId) | (uint64_t(geomId) << 32)));
    h = mix64(h ^ (uint64_t(root) | (uint64_t(instId) << 32)));
    const float u = float(h >> 40) * 0x1p-24f;  // 24 bits: exactly representable, in [0, 1)
    return u < o;
}

Vec2 sphereUv(const Vec3& d) {
    float phi = std::atan2(d.y, d.x);
    if (phi < 0.f) phi += 2.f * kPi;
    return Vec2(phi * (0.5f * kInvPi), std::acos(std::clamp(d.z, -1.f, 1.f)) * kInvPi);
}

bool acceptSphereHit(const Opacity& op, const double c[3], const glm::mat3& toLocal, const float org[3],
                     const float dir[3], double t, unsigned geomId, unsigned instId) {
    const double px = org[0] + t * dir[0] - c[0], py = org[1] + t * dir[1] - c[1], pz = org[2] + t * dir[2] - c[2];
    const double len = std::sqrt(px * px + py * py + pz * pz);
    const Vec3 n = len > 0.0 ? Vec3(float(px / len), float(py / len), float(pz / len)) : Vec3(0.f, 0.f, 1.f);
    // Which root: leaving the sphere where the direction points outwards (t0 enters, t1 leaves).
    const unsigned root = px * dir[0] + py * dir[1] + pz * dir[2] > 0.0 ? 1u : 0u;
    return acceptMaskedHit(op, op.texture ? sphereUv(glm::normalize(toLocal * n)) : Vec2(0.f), org, dir, geomId, 0,
                           instId, root);
}

void MeshMasks::attach(RTCGeometryTy* g, const Opacity& op, const Vec2* uvs, const uint32_t* indices) {
    if (!op.masked()) return;
    records_.push_back({&op, uvs, indices});
    rtcSetGeometryUserData(g, &records_.back());
    rtcSetGeometryIntersectFilterFunction(g, meshFilter);
    rtcSetGeometryOccludedFilterFunction(g, meshFilter);
}

}  // namespace lt
