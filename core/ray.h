// A ray (origin, unit direction, parametric range), and the SSE helpers that build rays and the
// vectors they are made of. A Ray is built as two whole 16-byte stores (o.xyz d.x | d.y d.z tMin
// tMax) and read back the same way (Scene's fillRay): a 16-byte load can be forwarded from one
// 16-byte store, not from scalar stores or from parts of two stores (a stall of a dozen cycles
// or more on the chain to every ray cast).
#pragma once
#include <immintrin.h>
#include <cstring>
#include "core/math.h"

namespace lt {

struct Ray {
    Vec3 o, d;
    float tMin = 0.f, tMax = kInf;
};

// Vec3 on SSE lanes (x, y, z, 0), computing what the glm expressions named compute, float for float.
namespace sse {
// Reads exactly the Vec3's 12 bytes (it may be the last thing in its allocation).
inline __m128 load3(const Vec3& v) {
    return _mm_movelh_ps(_mm_castpd_ps(_mm_load_sd(reinterpret_cast<const double*>(&v.x))), _mm_load_ss(&v.z));
}
inline Vec3 toVec3(__m128 v) {
    alignas(16) float f[4];
    _mm_store_ps(f, v);
    return Vec3(f[0], f[1], f[2]);
}
// maxAbs: std::max(|x|, std::max(|y|, |z|)); std::max(u, v) is maxss(v, u), NaN cases included.
inline float maxAbs3(__m128 v) {
    const __m128 a = _mm_and_ps(v, _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff)));
    return _mm_cvtss_f32(_mm_max_ss(_mm_max_ss(_mm_movehl_ps(a, a), _mm_shuffle_ps(a, a, 1)), a));
}
// glm::dot's order: (x + y) + z of the products.
inline float dot3(__m128 a, __m128 b) {
    const __m128 m = _mm_mul_ps(a, b);
    return _mm_cvtss_f32(_mm_add_ss(_mm_add_ss(m, _mm_shuffle_ps(m, m, 1)), _mm_movehl_ps(m, m)));
}
// v == Vec3(0) (+0 or -0 in x, y and z) for v from load3 (lane 3 is 0).
inline bool isZero3(__m128 v) { return _mm_movemask_ps(_mm_cmpeq_ps(v, _mm_setzero_ps())) == 15; }
// Ray{o, d, tMin, tMax} as two whole vectors (o.xyz d.x) and (d.y d.z tMin tMax): no trip
// through scalar stores and reloads.
inline Ray makeRay(__m128 o, __m128 d, float tMin = 0.f, float tMax = kInf) {
    const __m128 ozdx = _mm_shuffle_ps(o, d, _MM_SHUFFLE(0, 0, 2, 2));                   // o.z o.z d.x d.x
    const __m128 t = _mm_setr_ps(tMin, tMax, 0.f, 0.f);
    const __m128 v[2] = {_mm_shuffle_ps(o, ozdx, _MM_SHUFFLE(2, 0, 1, 0)),             // o.x o.y o.z d.x
                         _mm_shuffle_ps(d, t, _MM_SHUFFLE(1, 0, 2, 1))};               // d.y d.z tMin tMax
    static_assert(sizeof(Ray) == sizeof(v));
    Ray r;
    std::memcpy(&r, v, sizeof(r));
    return r;
}
}  // namespace sse

}  // namespace lt
