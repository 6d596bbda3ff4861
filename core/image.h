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

// ---- Additions (image I/O details) ------------------------------------------------------------
// readImage: .exr reads R,G,B as float (a missing one of the three reads as 0; a Y-only greyscale
// file is replicated to RGB; A and other channels are ignored; luminance/chroma files go through
// the RGBA interface). .pfm reads PF (RGB) and Pf (grey, replicated) in either byte order (negative
// scale = little endian; the scale's magnitude is ignored), rows stored bottom-to-top. .hdr reads
// Radiance RGBE. Errors (missing file, unknown extension, corrupt header, truncated raster) throw
// ImageError with a message of the form "<path>: <what is wrong>".
// writeImage also accepts .hdr (Radiance RGBE, negative values clamp to 0).
enum class ExrPixelType { Float, Half };
// writeExr(img, path) writes FLOAT channels R,G,B (ZIP compression); HALF on request.
void writeExr(const Image& img, const std::string& path, ExrPixelType type);
void writeHdr(const Image& img, const std::string& path);
// The sRGB transfer curve used by writePng: input clamped to [0,1], NaN maps to 0.
float linearToSrgb(float linear);

}  // namespace lt
