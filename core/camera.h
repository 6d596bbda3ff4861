// Pinhole perspective camera (Mitsuba 3 conventions: looks along +Z of its frame, +X is image
// left, +Y up). Besides generating rays it provides what light tracing needs: the importance
// function We, the pdfs of its rays and the raster position of a world point.
#pragma once
#include <optional>
#include "core/math.h"
#include "core/ray.h"
#include "core/scene_desc.h"

namespace lt {

class Camera {
public:
    explicit Camera(const CameraDesc& desc);

    int width() const { return width_; }
    int height() const { return height_; }
    Vec3 position() const { return pos_; }
    Vec3 forward() const { return forward_; }

    // Raster positions are the image's, [0,W]x[0,H] (y down); with a crop window (CameraDesc) the
    // image is that window of the full film, whose size the field of view refers to.
    // Primary ray through raster position (x, y).
    Ray generateRay(const Vec2& raster) const {
        SolidAnglePdf pdf;
        return generateRay(raster, pdf);
    }
    // The same ray, and directionPdf of its direction (from the cosine the ray needs anyway).
    Ray generateRay(const Vec2& raster, SolidAnglePdf& pdf) const;

    // Importance We(p_camera, w) for a direction leaving the camera (per unit area of the
    // pinhole "lens" is a delta, so this is the directional part): 1 / (A cos^4) inside the
    // image, 0 outside. A is the image-plane area at distance 1.
    float importance(const Vec3& dirWorld) const;
    // Solid-angle pdf of generating direction w by uniform raster sampling: 1 / (A cos^3).
    SolidAnglePdf directionPdf(const Vec3& dirWorld) const;

    // Raster position of a world point seen through the pinhole, if it lands on the image
    // (in front of the camera, beyond near_clip).
    std::optional<Vec2> rasterPosition(const Vec3& pWorld) const;

    // Image-plane area at distance 1 from the pinhole (camera space).
    float imagePlaneArea() const { return area_; }

private:
    int width_, height_;
    float cropX_, cropY_;  // the window's offset in the full film (pixels)
    float fullW_, fullH_;  // the full film's size (pixels)
    Vec3 pos_, forward_, right_, up_;  // right_ = camera +X (image left) in world space
    float tanX_, tanY_;                // half extents of the full film's plane at distance 1
    float x0_, x1_, yTop_, yBottom_;   // the image's window on that plane (x: image right)
    float area_, invArea_;
    float rasterToX_, rasterToY_;  // 2 tanX / W, 2 tanY / H (W, H: the full film's)
    float nearClip_;
};

}  // namespace lt
