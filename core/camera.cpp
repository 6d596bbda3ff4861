#include "core/camera.h"

namespace lt {

Camera::Camera(const CameraDesc& desc)
    : type_(desc.type), width_(desc.width), height_(desc.height), cropX_(float(desc.cropX)), cropY_(float(desc.cropY)),
      nearClip_(desc.nearClip), farClip_(desc.farClip) {
    const int fullW = desc.fullWidth > 0 ? desc.fullWidth : width_;
    const int fullH = desc.fullHeight > 0 ? desc.fullHeight : height_;
    fullW_ = float(fullW);
    fullH_ = float(fullH);
    pos_ = transformPoint(desc.toWorld, Vec3(0.f));
    forward_ = glm::normalize(transformVector(desc.toWorld, Vec3(0, 0, 1)));
    right_ = glm::normalize(transformVector(desc.toWorld, Vec3(1, 0, 0)));
    up_ = glm::normalize(transformVector(desc.toWorld, Vec3(0, 1, 0)));
    // Re-orthonormalise (matrices from files carry rounding).
    right_ = glm::normalize(right_ - glm::dot(right_, forward_) * forward_);
    up_ = glm::cross(forward_, right_);
    float aspect = float(fullW) / float(fullH);
    float t = std::tan(0.5f * glm::radians(desc.fovDeg));
    switch (desc.fovAxis) {
        case FovAxis::X: tanX_ = t; tanY_ = t / aspect; break;
        case FovAxis::Y: tanY_ = t; tanX_ = t * aspect; break;
        case FovAxis::Smaller:
            if (aspect > 1.f) { tanY_ = t; tanX_ = t * aspect; } else { tanX_ = t; tanY_ = t / aspect; }
            break;
        case FovAxis::Larger:
            if (aspect > 1.f) { tanX_ = t; tanY_ = t / aspect; } else { tanY_ = t; tanX_ = t * aspect; }
            break;
        case FovAxis::Diagonal: {
            float diag = std::sqrt(aspect * aspect + 1.f);
            tanX_ = t * aspect / diag;
            tanY_ = t / diag;
            break;
        }
    }
    rasterToX_ = 2.f * tanX_ / float(fullW);
    rasterToY_ = 2.f * tanY_ / float(fullH);
    // The window, as fractions of the full film (exactly -tan and tan without a crop).
    x0_ = tanX_ * (2.f * float(desc.cropX) / float(fullW) - 1.f);
    x1_ = tanX_ * (2.f * float(desc.cropX + width_) / float(fullW) - 1.f);
    yTop_ = tanY_ * (1.f - 2.f * float(desc.cropY) / float(fullH));
    yBottom_ = tanY_ * (1.f - 2.f * float(desc.cropY + height_) / float(fullH));
    area_ = (x1_ - x0_) * (yTop_ - yBottom_);
    invArea_ = 1.f / area_;
    if (!pinhole()) initLens(desc);
}

// The division-free form (one sqrt and one reciprocal on the chain to the ray): the camera-space
// direction (-sx, sy, 1) has length len = sqrt(sx^2 + sy^2 + 1), the frame is orthonormal, so the
// world direction is its image over len, cos = 1 / len, near_clip / cos = near_clip len and
// 1 / (A cos^3) = len^3 / A.
Ray Camera::generatePinholeRay(const Vec2& raster, SolidAnglePdf& pdf) const {
    const float sx = (raster.x + cropX_) * rasterToX_ - tanX_;  // (2 x / W - 1) tanX; +sx = image right = camera -X
    const float sy = tanY_ - (raster.y + cropY_) * rasterToY_;  // (1 - 2 y / H) tanY
    const float len2 = sx * sx + sy * sy + 1.f;
    const float len = std::sqrt(len2);
    const float invLen = 1.f / len;
    const Vec3 d = (right_ * -sx + up_ * sy + forward_) * invLen;
    // directionPdf(d) without its tests: d is inside the image by construction.
    pdf = SolidAnglePdf(len2 * len * invArea_);
    return sse::makeRay(sse::load3(pos_), _mm_setr_ps(d.x, d.y, d.z, 0.f), nearClip_ * len, kInf);
}

float Camera::importance(const Vec3& d) const {
    float c = glm::dot(d, forward_);
    if (c <= 0.f) return 0.f;
    Vec3 onPlane = d / c;
    float x = -glm::dot(onPlane, right_), y = glm::dot(onPlane, up_);
    if (x < x0_ || x > x1_ || y < yBottom_ || y > yTop_) return 0.f;
    return 1.f / (area_ * c * c * c * c);
}

SolidAnglePdf Camera::directionPdf(const Vec3& d) const {
    float c = glm::dot(d, forward_);
    if (c <= 0.f) return SolidAnglePdf(0.f);
    Vec3 onPlane = d / c;
    float x = -glm::dot(onPlane, right_), y = glm::dot(onPlane, up_);
    if (x < x0_ || x > x1_ || y < yBottom_ || y > yTop_) return SolidAnglePdf(0.f);
    return SolidAnglePdf(1.f / (area_ * c * c * c));
}

std::optional<Vec2> Camera::rasterPosition(const Vec3& p) const {
    Vec3 v = p - pos_;
    float z = glm::dot(v, forward_);
    if (z <= nearClip_) return std::nullopt;
    float x = -glm::dot(v, right_) / z, y = glm::dot(v, up_) / z;
    Vec2 r((x / tanX_ + 1.f) * 0.5f * fullW_ - cropX_, (1.f - y / tanY_) * 0.5f * fullH_ - cropY_);
    if (r.x < 0.f || r.y < 0.f || r.x >= float(width_) || r.y >= float(height_)) return std::nullopt;
    return r;
}

}  // namespace lt
