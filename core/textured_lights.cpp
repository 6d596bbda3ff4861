// Textured emitters, after Mitsuba 3 (src/emitters/area.cpp, spot.cpp, projector.cpp; their
// documentation is the spec):
//  - area: `radiance` a texture of the surface point's uv (the shape's parameterisation). Points
//    are sampled uniformly by area, as for an untextured light (Mitsuba's direct sampling does the
//    same); the light's power for the choice between lights is pi x area x the texture's mean.
//  - spot: `texture` projected over the cone, uv = 0.5 + 0.5 (x, y) / (z tan(cutoff)) of the
//    direction in the emitter's frame, multiplying intensity and falloff. Emission directions stay
//    uniform in the cone, as Mitsuba's.
//  - projector: a pinhole projecting `irradiance` (an image on the plane z = 1 of its frame) with
//    the perspective camera's pixel-to-direction map: uv = (0.5 - 0.5 x / (z t), 0.5 - 0.5 a y / (z t))
//    with t = tan(fov_x / 2), a the image's aspect (width / height). Its intensity is
//    I(w) = pi scale E(uv) / cos^3(theta): the plane z = 1 then receives irradiance pi scale E
//    (Mitsuba's normalisation, the factor pi included). Emission directions are sampled by uv in
//    proportion to the image (UvDistribution), density p(uv) / (A cos^3 theta), A the image
//    rectangle's area on z = 1 (dw = cos^3 theta dA there); its power is pi scale A mean(E).
#include <algorithm>
#include <cmath>
#include "core/cylinder.h"
#include "core/lights.h"
#include "core/scene.h"

namespace lt {

// Piecewise constant over an nx x ny grid of [0, 1]^2, each cell weighted by the texture's channel
// sum averaged over 2 x 2 points inside it, mixed with the uniform density: a fraction kUniform of
// the samples is uniform, so the density is positive wherever the texture may be (a bilinear
// texel's footprint past its cell, a to_uv, a texture without texels) and the estimate unbiased.
// With the grid on the texels (a bitmap's resolution) the 2 x 2 points see every cell a texel's
// bilinear footprint reaches.
class UvDistribution {
public:
    static constexpr float kUniform = 0.1f;

    UvDistribution(const Texture* tex, int nx, int ny) : nx_(nx), ny_(ny) {
        std::vector<float> w(size_t(nx) * size_t(ny), 1.f), rowSums(size_t(ny), 0.f);
        if (tex)
            for (int y = 0; y < ny; ++y)
                for (int x = 0; x < nx; ++x) {
                    float sum = 0.f;
                    for (float oy : {0.25f, 0.75f})
                        for (float ox : {0.25f, 0.75f}) {
                            const Color c = tex->eval(Vec2((float(x) + ox) / float(nx), (float(y) + oy) / float(ny)));
                            sum += std::max(0.f, c.x) + std::max(0.f, c.y) + std::max(0.f, c.z);
                        }
                    w[size_t(y) * size_t(nx) + size_t(x)] = std::isfinite(sum) ? sum : 0.f;
                }
        double total = 0.0;
        for (int y = 0; y < ny; ++y) {
            std::vector<float> row(w.begin() + ptrdiff_t(y) * nx, w.begin() + ptrdiff_t(y + 1) * nx);
            for (float v : row) rowSums[size_t(y)] += v;
            total += rowSums[size_t(y)];
            cols_.emplace_back(row);
        }
        rows_ = Distribution1D(rowSums);
        // The tabulated density of each cell (over [0, 1]^2), 0 for an all-black texture.
        cellPdf_.resize(w.size());
        for (size_t i = 0; i < w.size(); ++i)
            cellPdf_[i] = total > 0.0 ? float(double(w[i]) / total * double(nx) * double(ny)) : 0.f;
        tabulated_ = total > 0.0;
        for (float p : cellPdf_) maxPdf_ = std::max(maxPdf_, mix(p));
        if (!tabulated_) maxPdf_ = 1.f;
    }

    Vec2 sample(Vec2 u, float& pdfOut) const {
        Vec2 uv;
        if (!tabulated_ || u.x < kUniform) {
            uv = Vec2(tabulated_ ? u.x / kUniform : u.x, u.y);
        } else {
            u.x = std::min((u.x - kUniform) / (1.f - kUniform), 0x1.fffffep-1f);
            float ry, rx;
            const size_t iy = rows_.sample(u.x, &ry);
            const size_t ix = cols_[iy].sample(u.y, &rx);
            uv = Vec2((float(ix) + rx) / float(nx_), (float(iy) + ry) / float(ny_));
        }
        uv = glm::clamp(uv, Vec2(0.f), Vec2(1.f));
        pdfOut = pdf(uv);
        return uv;
    }
    float pdf(const Vec2& uv) const {
        if (!tabulated_) return 1.f;
        const int x = std::clamp(int(uv.x * float(nx_)), 0, nx_ - 1), y = std::clamp(int(uv.y * float(ny_)), 0, ny_ - 1);
        return mix(cellPdf_[size_t(y) * size_t(nx_) + size_t(x)]);
    }
    float maxPdf() const { return maxPdf_; }

private:
    static float mix(float p) { return kUniform + (1.f - kUniform) * p; }
    int nx_, ny_;
    Distribution1D rows_;
    std::vector<Distribution1D> cols_;
    std::vector<float> cellPdf_;
    bool tabulated_ = false;
    float maxPdf_ = 1.f;
};

float horizontalFovDeg(float fovDeg, FovAxis axis, float aspect) {
    // Mitsuba's parse_fov (sensor.h): smaller and larger by the aspect, then converted to x.
    if (axis == FovAxis::Smaller) axis = aspect > 1.f ? FovAxis::Y : FovAxis::X;
    if (axis == FovAxis::Larger) axis = aspect > 1.f ? FovAxis::X : FovAxis::Y;
    const float half = glm::radians(0.5f * fovDeg);
    switch (axis) {
        case FovAxis::Y: return glm::degrees(2.f * std::atan(std::tan(half) * aspect));
        case FovAxis::Diagonal: {
            const float width = 2.f * std::tan(half) / std::sqrt(1.f + 1.f / (aspect * aspect));
            return glm::degrees(2.f * std::atan(0.5f * width));
        }
        default: return fovDeg;
    }
}

void Light::setTextures(const EmitterDesc& ed) {
    texture = ed.texture.get();
    if ((type == LightType::Spot && texture) || type == LightType::Projector) {
        const glm::mat3 m(ed.toWorld);  // a rotation (the loader checks)
        axisX = glm::normalize(m[0]);
        axisY = glm::normalize(m[1]);
        direction = glm::normalize(m[2]);
    }
    if (type == LightType::Spot) tanCutoff = std::tan(cutoff);
    if (type != LightType::Projector) return;
    position = transformPoint(ed.toWorld, Vec3(0.f));
    const glm::ivec2 res = texture ? texture->resolution() : glm::ivec2(1);
    aspect = float(res.x) / float(res.y);
    tanHalfFovX = std::tan(glm::radians(0.5f * ed.fovXDeg));
    sensorArea = 4.f * tanHalfFovX * tanHalfFovX / aspect;
    scale = ed.scale;
    // The sampling grid: the texels of a bitmap (at most 2048 a side), 64 x 64 cells of another
    // texture, one cell for a constant.
    int nx = 1, ny = 1;
    if (texture) {
        nx = res.x * res.y > 1 ? std::min(res.x, 2048) : 64;
        ny = res.x * res.y > 1 ? std::min(res.y, 2048) : 64;
    }
    uvDist = std::make_shared<const UvDistribution>(texture, nx, ny);
}

// Projector: uv of a direction in the frame (z > 0), Mitsuba's perspective_projection.
static Vec2 projectorUv(const Vec3& local, float tanHalfFovX, float aspect) {
    const float k = 0.5f / (local.z * tanHalfFovX);
    return Vec2(0.5f - k * local.x, 0.5f - k * aspect * local.y);
}
static bool inUnitSquare(const Vec2& uv) { return uv.x >= 0.f && uv.x <= 1.f && uv.y >= 0.f && uv.y <= 1.f; }

Color Light::texturedIntensity(const Vec3& w) const {
    const Vec3 local(glm::dot(w, axisX), glm::dot(w, axisY), glm::dot(w, direction));
    if (type == LightType::Spot) {
        const float f = spotFalloff(w);
        if (!(f > 0.f)) return Color(0.f);  // (no look-up outside the cone, as Mitsuba)
        const float k = 0.5f / (local.z * tanCutoff);
        return value * f * texture->eval(Vec2(0.5f + k * local.x, 0.5f + k * local.y));
    }
    if (type != LightType::Projector || !(local.z > 0.f)) return Color(0.f);
    const Vec2 uv = projectorUv(local, tanHalfFovX, aspect);
    if (!inUnitSquare(uv)) return Color(0.f);
    const float c = local.z / glm::length(local);
    return (kPi * scale / (c * c * c)) * (texture ? texture->eval(uv) : value);
}

LightSampleLe Light::projectorSampleLe(const Vec2& uDir) const {
    LightSampleLe s;
    float pUv = 0.f;
    const Vec2 uv = uvDist->sample(uDir, pUv);
    const Vec3 local = glm::normalize(Vec3((1.f - 2.f * uv.x) * tanHalfFovX, (1.f - 2.f * uv.y) * tanHalfFovX / aspect, 1.f));
    const float c3 = local.z * local.z * local.z;
    s.p = position;
    s.dir = glm::normalize(local.x * axisX + local.y * axisY + local.z * direction);
    s.value = (kPi * scale / c3) * (texture ? texture->eval(uv) : value);
    s.pdfPos = AreaPdf(1.f);
    s.pdfDir = SolidAnglePdf(pUv / (sensorArea * c3));
    return s;
}

SolidAnglePdf Light::projectorPdfDir(const Vec3& dir) const {
    const Vec3 local(glm::dot(dir, axisX), glm::dot(dir, axisY), glm::dot(dir, direction));
    if (!(local.z > 0.f)) return SolidAnglePdf(0.f);
    const Vec2 uv = projectorUv(local, tanHalfFovX, aspect);
    if (!inUnitSquare(uv)) return SolidAnglePdf(0.f);
    const float c = local.z / glm::length(local);
    return SolidAnglePdf(uvDist->pdf(uv) / (sensorArea * c * c * c));
}

float Light::projectorDirBound() const {
    // The largest density: the largest uv density at the image's corner, where cos theta is least.
    const float r2 = tanHalfFovX * tanHalfFovX * (1.f + 1.f / (aspect * aspect));
    const float c = 1.f / std::sqrt(1.f + r2);
    return uvDist ? uvDist->maxPdf() / (sensorArea * c * c * c) : 0.f;
}

float Light::texturedPower() const {
    if (type == LightType::Spot)
        return coneSolidAngle(0.5f * (cutoff + beamWidth)) * luminance(value * texture->meanValue());
    return kPi * scale * sensorArea * luminance(texture ? texture->meanValue() : value);
}

Light::TexturedPoint Light::sampleTexturedArea(const Scene& scene, const Vec2& uIn) const {
    if (sphere) {  // as sampleSphere; uv: Mitsuba's sphere in its own frame (the hit's, core/scene.cpp)
        const Vec3 d = sampleUniformSphere(uIn);
        const Vec3 dl = glm::normalize(sphere->toLocal * d);
        float phi = std::atan2(dl.y, dl.x);
        if (phi < 0.f) phi += 2.f * kPi;
        return {sphere->center + sphere->radius * d, sphere->flipNormals ? -d : d,
                Vec2(phi * (0.5f * kInvPi), std::acos(std::clamp(dl.z, -1.f, 1.f)) * kInvPi)};
    }
    if (cylinder) {  // sampleCylinder: phi = 2 pi u.y, z = u.x, so Mitsuba's uv is (u.y, u.x)
        TexturedPoint t;
        sampleCylinder(*cylinder, uIn, t.p, t.n);
        t.uv = Vec2(uIn.y, uIn.x);
        return t;
    }
    // As sampleMesh, with the triangle's index kept: uv interpolated as a hit's.
    Vec2 u = uIn;
    const size_t tri = triDist->sample(u.x, &u.x);
    const EmitterTriangle& et = tris[tri];
    const Vec2 bc = sampleUniformTriangle(u);
    Vec2 uv(0.f);
    const MeshDesc& m = scene.desc().meshes[size_t(meshIndex)];
    if (!m.uvs.empty()) {
        const uint32_t* idx = m.indices.data() + 3 * tri;
        uv = (1.f - bc.x - bc.y) * m.uvs[idx[0]] + bc.x * m.uvs[idx[1]] + bc.y * m.uvs[idx[2]];
    }
    return {et.p0 + bc.x * et.e1 + bc.y * et.e2, et.n, uv};
}

LightSampleLi Light::texturedAreaSampleLi(const Scene& scene, const Vec3& refP, const Vec2& u) const {
    const TexturedPoint a = sampleTexturedArea(scene, u);
    const Vec3 d = refP - a.p;
    if (!(glm::dot(d, d) > 0.f)) return {};
    return {a.p, a.n, Vec3(0.f), glm::dot(a.n, d) > 0.f ? texture->eval(a.uv) : Color(0.f), AreaPdf(invArea), a.uv};
}

}  // namespace lt
