// RGB float images and their file formats: OpenEXR (read/write), PFM (read/write),
// Radiance HDR (read), PNG (write, sRGB, for viewing).
#pragma once
#include <stdexcept>
#include <string>
#include <vector>
#include "core/math.h"

namespace lt {

struct ImageError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

struct Image {
    int width = 0, height = 0;
    std::vector<Color> pixels;  // row-major, row 0 at the top
    Image() = default;
    Image(int w, int h, Color fill = Color(0.f)) : width(w), height(h), pixels(size_t(w) * h, fill) {}
    Color& at(int x, int y) { return pixels[size_t(y) * width + x]; }
    const Color& at(int x, int y) const { return pixels[size_t(y) * width + x]; }
};

// By extension: .exr, .pfm, .hdr. Throws ImageError naming the file.
Image readImage(const std::string& path);
void writeExr(const Image& img, const std::string& path);
void writePfm(const Image& img, const std::string& path);
// sRGB transfer curve, clamped to [0,1], after multiplying by 2^exposure.
void writePng(const Image& img, const std::string& path, float exposure = 0.f);
// By extension (.exr, .pfm, .png).
void writeImage(const Image& img, const std::string& path);

}  // namespace lt
