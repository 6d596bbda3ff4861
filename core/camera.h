// The camera: Mitsuba 3's perspective (a pinhole), thinlens and orthographic sensors (Mitsuba 3
// conventions: looks along +Z of its frame, +X is image left, +Y up). Besides generating rays it
// provides what light tracing needs: the camera vertex of a connection, the importance We, the
// densities of its rays and the raster position of a world point (pbrt-v3's Sample_Wi / Pdf_We,
// Veach's thesis Sec. 10.3 for the lens).
//
// The camera vertex z_0 of a camera walk: the pinhole (a delta position), a point of the lens
// disk (uniform, area density 1 / (pi r^2)) or a point of the orthographic film rectangle
// (uniform, area density 1 / A_film, with a delta direction along forward). Every sampled ray has
// throughput We cos / (p_pos p_dir) = 1. For the perspective types the directional importance
// over the position density is 1 / (A cos^4) and the direction density 1 / (A cos^3), A the
// image's area on the plane at distance 1: for the lens the direction through lens point L to the
// focal-plane point F is uniform over the image's window on the focal plane, so its density is
// |F - L|^2 / (cos A d_f^2) = 1 / (A cos^3) whatever L (pbrt-v3, PerspectiveCamera::Pdf_We).
// The orthographic camera is the mirror image of a directional light: its vertex is determined by
// the next one (the orthogonal projection onto the film), the first hit's area density is
// |cos| / A_film and light tracing weights a point by its projected area, We = 1 / A_film.
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
    SensorType type() const { return type_; }
    bool pinhole() const { return type_ == SensorType::Perspective; }
    bool orthographic() const { return type_ == SensorType::Orthographic; }
    bool thinLens() const { return type_ == SensorType::ThinLens; }
    // The camera frame's origin (the pinhole, the lens centre; orthographic: to_world's origin).
    Vec3 position() const { return pos_; }
    // The viewing direction (the lens normal; orthographic: every ray's direction).
    Vec3 forward() const { return forward_; }

    // Raster positions are the image's, [0,W]x[0,H] (y down); with a crop window (CameraDesc) the
    // image is that window of the full film, whose size the field of view refers to.
    // Primary ray through raster position (x, y) (thin lens: through the lens centre).
    Ray generateRay(const Vec2& raster) const {
        SolidAnglePdf pdf;
        return generateRay(raster, pdf);
    }
    // The same ray, and directionPdf of its direction (from the cosine the ray needs anyway).
    Ray generateRay(const Vec2& raster, SolidAnglePdf& pdf) const {
        if (pinhole()) return generatePinholeRay(raster, pdf);
        Vec3 origin;
        return generateRay(raster, Vec2(0.5f), pdf, origin);
    }
    // The camera walk's ray: thin lens: through the lens point sampled from uLens (the concentric
    // map of the unit square onto the aperture, as Mitsuba). `origin` receives the camera vertex
    // (pinhole, lens point, film point; the ray itself starts at the near clip plane) and pdf the
    // direction's density (orthographic: 1, a stand-in for the delta, which the camera walk replaces
    // by the first hit's area density, filmDensity()).
    Ray generateRay(const Vec2& raster, const Vec2& uLens, SolidAnglePdf& pdf, Vec3& origin) const;
    // Area density of the camera vertex: 1 for the pinhole (a delta), 1 / (pi r^2) for the lens,
    // 1 / A_film for the orthographic film. Every technique's density carries it (no technique hits
    // the camera), so the MIS weights never read it.
    float positionDensity() const { return positionDensity_; }
    // The camera vertex of a connection (light tracing, t = 1) to world point p: the pinhole, a
    // lens point sampled from u (density positionDensity()), the orthogonal projection of p onto
    // the film (orthographic: p's own camera vertex, a delta).
    Vec3 connectionPoint(const Vec3& p, const Vec2& u) const;

    // Importance We(c, w) / positionDensity() for a direction w leaving camera vertex c (the
    // pinhole's directional importance; the lens's over the lens point's density): 1 / (A cos^4)
    // inside the image, 0 outside. Orthographic: 1 / A_film, the film's importance per unit
    // projected area (its direction, a delta, is connect's to handle).
    float importance(const Vec3& c, const Vec3& dirWorld) const {
        if (pinhole()) return importance(dirWorld);
        return lensImportance(c, dirWorld, false);
    }
    // Solid-angle density of direction w from camera vertex c: 1 / (A cos^3) inside the image.
    // Orthographic: 0 (a delta: the camera walk writes its first hit's area density).
    SolidAnglePdf directionPdf(const Vec3& c, const Vec3& dirWorld) const {
        if (pinhole()) return directionPdf(dirWorld);
        return SolidAnglePdf(lensImportance(c, dirWorld, true));
    }
    // Raster position of world point p seen from camera vertex c (the pinhole; a lens point, the
    // ray from it through p meets the focal plane where the pixel's rays meet it; orthographic:
    // p's projection, c not read), if it lands on the image between the clip planes.
    std::optional<Vec2> rasterPosition(const Vec3& c, const Vec3& p) const {
        if (pinhole()) return rasterPosition(p);
        return lensRasterPosition(c, p);
    }
    // The orthographic film's importance per unit area perpendicular to the rays, 1 / A_film
    // (the area of the image's window of the film, projected perpendicular to forward).
    float filmDensity() const { return invFilmArea_; }
    // The largest directional importance (JG19's bound at the camera vertex): 1 / A at the image
    // centre for the perspective types; orthographic: 1 / pi, as a directional light's.
    float importanceBound() const;

    // The pinhole's forms of the above (from position(); perspective only).
    float importance(const Vec3& dirWorld) const;
    SolidAnglePdf directionPdf(const Vec3& dirWorld) const;
    std::optional<Vec2> rasterPosition(const Vec3& pWorld) const;

    // Image-plane area at distance 1 from the pinhole (camera space).
    float imagePlaneArea() const { return area_; }

private:
    Ray generatePinholeRay(const Vec2& raster, SolidAnglePdf& pdf) const;
    // camera_lens.cpp: the thin lens and the orthographic film.
    void initLens(const CameraDesc& desc);
    float lensImportance(const Vec3& c, const Vec3& d, bool density) const;
    std::optional<Vec2> lensRasterPosition(const Vec3& c, const Vec3& p) const;
    std::optional<Vec2> toRaster(float x, float y) const;  // plane-at-distance-1 coordinates -> raster

    SensorType type_;
    int width_, height_;
    float cropX_, cropY_;  // the window's offset in the full film (pixels)
    float fullW_, fullH_;  // the full film's size (pixels)
    Vec3 pos_, forward_, right_, up_;  // right_ = camera +X (image left) in world space
    float tanX_, tanY_;                // half extents of the full film's plane at distance 1
    float x0_, x1_, yTop_, yBottom_;   // the image's window on that plane (x: image right)
    float area_, invArea_;
    float rasterToX_, rasterToY_;  // 2 tanX / W, 2 tanY / H (W, H: the full film's)
    float nearClip_, farClip_;
    float positionDensity_ = 1.f;
    // thin lens
    float lensRadius_ = 0.f, focusDistance_ = 1.f;
    // orthographic: film point (x, y) in [-1,1] x [-1/aspect, 1/aspect] is filmOrigin_ + filmX_ x +
    // filmY_ y (to_world's columns, scale included; filmOrigin_ on the near plane); toFilm_ inverts
    // [filmX_ filmY_ forward_].
    Vec3 filmOrigin_{0.f}, filmX_{0.f}, filmY_{0.f};
    glm::mat3 toFilm_{1.f};
    float invAspect_ = 1.f, invFilmArea_ = 1.f;
};

}  // namespace lt
