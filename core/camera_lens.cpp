// The thin lens and the orthographic film of core/camera.h (Mitsuba 3's thinlens.cpp and
// orthographic.cpp: their film mappings, clip planes and defaults).
#include <glm/gtc/matrix_inverse.hpp>
#include "core/camera.h"
#include "core/sampling.h"

namespace lt {

void Camera::initLens(const CameraDesc& desc) {
    if (thinLens()) {
        lensRadius_ = desc.apertureRadius;
        focusDistance_ = desc.focusDistance;
        positionDensity_ = 1.f / (kPi * lensRadius_ * lensRadius_);
        return;
    }
    // Orthographic (Mitsuba's orthographic_projection): camera-space x in [-1, 1] spans the full
    // film's width (+x = image left), y in [-1/aspect, 1/aspect] its height; to_world maps them,
    // its scale included, and the rays leave the near plane z = near_clip along to_world's +Z.
    filmX_ = transformVector(desc.toWorld, Vec3(1, 0, 0));
    filmY_ = transformVector(desc.toWorld, Vec3(0, 1, 0));
    forward_ = glm::normalize(transformVector(desc.toWorld, Vec3(0, 0, 1)));
    filmOrigin_ = transformPoint(desc.toWorld, Vec3(0.f, 0.f, nearClip_));
    const glm::mat3 m(filmX_, filmY_, forward_);
    toFilm_ = glm::inverse(m);
    invAspect_ = fullH_ / fullW_;
    // The window's area in camera units, times the parallelogram's area perpendicular to forward.
    const float window = (2.f * float(width_) / fullW_) * (2.f * invAspect_ * float(height_) / fullH_);
    invFilmArea_ = 1.f / (window * std::abs(glm::determinant(m)));
    positionDensity_ = invFilmArea_;
}

float Camera::importanceBound() const {
    if (orthographic()) return kInvPi;
    return directionPdf(forward_).value;
}

Ray Camera::generateRay(const Vec2& raster, const Vec2& uLens, SolidAnglePdf& pdf, Vec3& origin) const {
    if (pinhole()) {
        origin = pos_;
        return generatePinholeRay(raster, pdf);
    }
    if (orthographic()) {
        const float x = 1.f - 2.f * (raster.x + cropX_) / fullW_;
        const float y = (1.f - 2.f * (raster.y + cropY_) / fullH_) * invAspect_;
        origin = filmOrigin_ + filmX_ * x + filmY_ * y;
        pdf = SolidAnglePdf(1.f);
        return Ray{origin, forward_, 0.f, farClip_ - nearClip_};
    }
    // Thin lens: the pixel's point on the plane at distance 1 (as the pinhole's), scaled onto the
    // focal plane, and the ray from the lens point towards it (camera space, +x = camera +X).
    const float sx = (raster.x + cropX_) * rasterToX_ - tanX_;  // image right
    const float sy = tanY_ - (raster.y + cropY_) * rasterToY_;
    const Vec2 l = lensRadius_ * sampleConcentricDisk(uLens);
    const Vec3 dc(-sx * focusDistance_ - l.x, sy * focusDistance_ - l.y, focusDistance_);
    const float len = glm::length(dc);
    const float cosT = focusDistance_ / len;
    const Vec3 d = glm::normalize(right_ * dc.x + up_ * dc.y + forward_ * dc.z);
    origin = pos_ + right_ * l.x + up_ * l.y;
    pdf = SolidAnglePdf(invArea_ / (cosT * cosT * cosT));
    return Ray{origin, d, nearClip_ / cosT, farClip_ / cosT};
}

Vec3 Camera::connectionPoint(const Vec3& p, const Vec2& u) const {
    switch (type_) {
        case SensorType::Perspective: return pos_;
        case SensorType::ThinLens: {
            const Vec2 l = lensRadius_ * sampleConcentricDisk(u);
            return pos_ + right_ * l.x + up_ * l.y;
        }
        case SensorType::Orthographic: {
            const Vec3 f = toFilm_ * (p - filmOrigin_);
            return filmOrigin_ + filmX_ * f.x + filmY_ * f.y;
        }
    }
    return pos_;
}

std::optional<Vec2> Camera::toRaster(float x, float y) const {
    // x: image right, y: up, on the plane at distance 1 (the pinhole's rasterPosition's mapping)
    Vec2 r((x / tanX_ + 1.f) * 0.5f * fullW_ - cropX_, (1.f - y / tanY_) * 0.5f * fullH_ - cropY_);
    if (!(r.x >= 0.f && r.y >= 0.f && r.x < float(width_) && r.y < float(height_))) return std::nullopt;
    return r;
}

float Camera::lensImportance(const Vec3& c, const Vec3& d, bool density) const {
    if (orthographic()) return density ? 0.f : invFilmArea_;
    // The ray from lens point c along d meets the focal plane at F; inside the image's window
    // there (F / d_f on the plane at distance 1) its importance is the pinhole's.
    const float cosT = glm::dot(d, forward_);
    if (cosT <= 0.f) return 0.f;
    const Vec3 lc = c - pos_;
    const float t = focusDistance_ / cosT;
    const float x = -(glm::dot(lc, right_) + glm::dot(d, right_) * t) / focusDistance_;
    const float y = (glm::dot(lc, up_) + glm::dot(d, up_) * t) / focusDistance_;
    if (x < x0_ || x > x1_ || y < yBottom_ || y > yTop_) return 0.f;
    const float c3 = cosT * cosT * cosT;
    return density ? invArea_ / c3 : invArea_ / (c3 * cosT);
}

std::optional<Vec2> Camera::lensRasterPosition(const Vec3& c, const Vec3& p) const {
    if (orthographic()) {
        const Vec3 f = toFilm_ * (p - filmOrigin_);  // (x, y, distance from the near plane)
        if (!(f.z > 0.f && f.z <= farClip_ - nearClip_)) return std::nullopt;
        const Vec2 r((1.f - f.x) * 0.5f * fullW_ - cropX_, (1.f - f.y / invAspect_) * 0.5f * fullH_ - cropY_);
        if (!(r.x >= 0.f && r.y >= 0.f && r.x < float(width_) && r.y < float(height_))) return std::nullopt;
        return r;
    }
    // Between the clip planes (camera space z, as Mitsuba's sample_direction), then the focal
    // plane's point of the ray from the lens point c through p.
    const float zc = glm::dot(p - pos_, forward_);
    if (!(zc >= nearClip_ && zc <= farClip_)) return std::nullopt;
    const Vec3 v = p - c;
    const float z = glm::dot(v, forward_);
    if (!(z > 0.f)) return std::nullopt;
    const Vec3 lc = c - pos_;
    const float t = focusDistance_ / z;
    const float x = -(glm::dot(lc, right_) + glm::dot(v, right_) * t) / focusDistance_;
    const float y = (glm::dot(lc, up_) + glm::dot(v, up_) * t) / focusDistance_;
    return toRaster(x, y);
}

}  // namespace lt
