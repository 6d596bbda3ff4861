#include "core/camera.h"

namespace lt {

Camera::Camera(const CameraDesc& desc) : width_(desc.width), height_(desc.height), nearClip_(desc.nearClip) {
    pos_ = transformPoint(desc.toWorld, Vec3(0.f));
    forward_ = glm::normalize(transformVector(desc.toWorld, Vec3(0, 0, 1)));
    right_ = glm::normalize(transformVector(desc.toWorld, Vec3(1, 0, 0)));
    up_ = glm::normalize(transformVector(desc.toWorld, Vec3(0, 1, 0)));
    // Re-orthonormalise (matrices from files carry rounding).
    right_ = glm::normalize(right_ - glm::dot(right_, forward_) * forward_);
    up_ = glm::cross(forward_, right_);
    float aspect = float(width_) / float(height_);
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
    area_ = 4.f * tanX_ * tanY_;
    invArea_ = 1.f / area_;
    rasterToX_ = 2.f * tanX_ / float(width_);
    rasterToY_ = 2.f * tanY_ / float(height_);
}

// The division-free form (one sqrt and one reciprocal on the chain to the ray): the camera-space
// direction (-sx, sy, 1) has length len = sqrt(sx^2 + sy^2 + 1), the frame is orthonormal, so the
// world direction is its image over len, cos = 1 / len, near_clip / cos = near_clip len and
// 1 / (A cos^3) = len^3 / A.
Ray Camera::generateRay(const Vec2& raster, SolidAnglePdf& pdf) const {
    const float sx = raster.x * rasterToX_ - tanX_;  // (2 x / W - 1) tanX; +sx = image right = camera -X
    const float sy = tanY_ - raster.y * rasterToY_;  // (1 - 2 y / H) tanY
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
    if (std::abs(x) > tanX_ || std::abs(y) > tanY_) return 0.f;
    return 1.f / (area_ * c * c * c * c);
}

SolidAnglePdf Camera::directionPdf(const Vec3& d) const {
    float c = glm::dot(d, forward_);
    if (c <= 0.f) return SolidAnglePdf(0.f);
    Vec3 onPlane = d / c;
    float x = -glm::dot(onPlane, right_), y = glm::dot(onPlane, up_);
    if (std::abs(x) > tanX_ || std::abs(y) > tanY_) return SolidAnglePdf(0.f);
    return SolidAnglePdf(1.f / (area_ * c * c * c));
}

std::optional<Vec2> Camera::rasterPosition(const Vec3& p) const {
    Vec3 v = p - pos_;
    float z = glm::dot(v, forward_);
    if (z <= nearClip_) return std::nullopt;
    float x = -glm::dot(v, right_) / z, y = glm::dot(v, up_) / z;
    Vec2 r((x / tanX_ + 1.f) * 0.5f * float(width_), (1.f - y / tanY_) * 0.5f * float(height_));
    if (r.x < 0.f || r.y < 0.f || r.x >= float(width_) || r.y >= float(height_)) return std::nullopt;
    return r;
}

}  // namespace lt
