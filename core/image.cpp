// Image file I/O: OpenEXR (read/write), PFM (read/write), Radiance HDR (read/write), PNG (write).
// Every failure is reported as an ImageError whose message starts with the file path.
#include "core/image.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfRgbaFile.h>
#include <OpenEXR/ImfArray.h>
#include <Imath/ImathBox.h>
#include <Imath/half.h>

#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <unistd.h>

namespace lt {

static_assert(sizeof(Color) == 3 * sizeof(float), "Color must be three tightly packed floats");

namespace {

// Largest accepted image: guards against absurd sizes in corrupt headers (w*h*12 bytes must
// stay allocatable). 2^28 pixels = 3 GiB of RGB float.
constexpr int64_t kMaxPixels = int64_t(1) << 28;

[[noreturn]] void fail(const std::string& path, const std::string& what) {
    throw ImageError(path + ": " + what);
}

// Writes the file `path` through a temporary file beside it (write(tmp) writes that), renamed
// over `path` at the end: a reader never sees a half-written file, and a write that fails leaves
// the previous file as it was (the temporary one is removed).
template <class Write>
void writeAtomically(const std::string& path, Write&& write) {
    const std::string tmp = path + ".tmp" + std::to_string(::getpid());
    try {
        write(tmp);
    } catch (...) {
        std::remove(tmp.c_str());
        throw;
    }
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
        const int e = errno;
        std::remove(tmp.c_str());
        fail(path, std::string("cannot replace the file: ") + std::strerror(e));
    }
}

std::string lowerExtension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return ext;
}

void requireReadableFile(const std::string& path) {
    std::error_code ec;
    auto st = std::filesystem::status(path, ec);
    if (ec || !std::filesystem::exists(st)) fail(path, "file not found");
    if (!std::filesystem::is_regular_file(st)) fail(path, "not a regular file");
}

void checkDimensions(const std::string& path, int64_t w, int64_t h) {
    if (w <= 0 || h <= 0) fail(path, "invalid image size " + std::to_string(w) + "x" + std::to_string(h));
    if (w > kMaxPixels || h > kMaxPixels || w * h > kMaxPixels)
        fail(path, "image size " + std::to_string(w) + "x" + std::to_string(h) + " is too large");
}

void checkWritable(const Image& img, const std::string& path) {
    if (img.width <= 0 || img.height <= 0)
        fail(path, "cannot write an empty image (" + std::to_string(img.width) + "x" + std::to_string(img.height) + ")");
    if (img.pixels.size() != size_t(img.width) * size_t(img.height))
        fail(path, "cannot write image: pixel buffer holds " + std::to_string(img.pixels.size()) +
                       " pixels but size is " + std::to_string(img.width) + "x" + std::to_string(img.height));
    // A NaN or infinite value is never written (a PNG would show it as black or white, silently).
    for (size_t i = 0; i < img.pixels.size(); ++i) {
        const Color& c = img.pixels[i];
        if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.z))
            fail(path, "refusing to write an image with a non-finite value (NaN or Inf) at pixel (" +
                           std::to_string(i % size_t(img.width)) + ", " + std::to_string(i / size_t(img.width)) + ")");
    }
}

// ---- OpenEXR -------------------------------------------------------------------------------

// Luminance/chroma or subsampled files: let the RGBA interface reconstruct RGB (half precision,
// which is what such files store anyway).
Image readExrViaRgba(const std::string& path) {
    Imf::RgbaInputFile file(path.c_str());
    Imath::Box2i dw = file.dataWindow();
    int64_t w = int64_t(dw.max.x) - dw.min.x + 1, h = int64_t(dw.max.y) - dw.min.y + 1;
    checkDimensions(path, w, h);
    Imf::Array2D<Imf::Rgba> buf(h, w);
    file.setFrameBuffer(&buf[0][0] - dw.min.x - int64_t(dw.min.y) * w, 1, size_t(w));
    file.readPixels(dw.min.y, dw.max.y);
    Image img{int(w), int(h)};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const Imf::Rgba& p = buf[y][x];
            img.at(x, y) = Color(float(p.r), float(p.g), float(p.b));
        }
    return img;
}

Image readExr(const std::string& path) {
    Imf::InputFile file(path.c_str());
    const Imf::Header& header = file.header();
    Imath::Box2i dw = header.dataWindow();
    int64_t w = int64_t(dw.max.x) - dw.min.x + 1, h = int64_t(dw.max.y) - dw.min.y + 1;
    checkDimensions(path, w, h);
    const Imf::ChannelList& channels = header.channels();
    const Imf::Channel* r = channels.findChannel("R");
    const Imf::Channel* g = channels.findChannel("G");
    const Imf::Channel* b = channels.findChannel("B");
    const Imf::Channel* y = channels.findChannel("Y");
    bool chroma = channels.findChannel("RY") || channels.findChannel("BY");
    auto subsampled = [](const Imf::Channel* c) { return c && (c->xSampling != 1 || c->ySampling != 1); };
    if (chroma || subsampled(r) || subsampled(g) || subsampled(b) || subsampled(y)) return readExrViaRgba(path);

    bool rgb = r || g || b;
    if (!rgb && !y) {
        std::string names;
        for (auto it = channels.begin(); it != channels.end(); ++it) names += std::string(names.empty() ? "" : ", ") + it.name();
        fail(path, "OpenEXR file has no R, G, B or Y channel (channels: " + (names.empty() ? std::string("none") : names) + ")");
    }
    Image img{int(w), int(h)};
    char* base = reinterpret_cast<char*>(img.pixels.data());
    const size_t xs = sizeof(Color), ys = sizeof(Color) * size_t(w);
    Imf::FrameBuffer fb;
    if (rgb) {
        // A missing one of R, G, B reads as 0 (fill value).
        fb.insert("R", Imf::Slice::Make(Imf::FLOAT, base + 0 * sizeof(float), dw, xs, ys, 1, 1, 0.0));
        fb.insert("G", Imf::Slice::Make(Imf::FLOAT, base + 1 * sizeof(float), dw, xs, ys, 1, 1, 0.0));
        fb.insert("B", Imf::Slice::Make(Imf::FLOAT, base + 2 * sizeof(float), dw, xs, ys, 1, 1, 0.0));
    } else {
        fb.insert("Y", Imf::Slice::Make(Imf::FLOAT, base, dw, xs, ys, 1, 1, 0.0));
    }
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    if (!rgb)
        for (Color& c : img.pixels) c.y = c.z = c.x;
    return img;
}

void writeExrImpl(const Image& img, const std::string& path, ExrPixelType type) {
    Imf::PixelType pt = type == ExrPixelType::Half ? Imf::HALF : Imf::FLOAT;
    Imf::Header header(img.width, img.height);
    header.compression() = Imf::ZIP_COMPRESSION;
    header.channels().insert("R", Imf::Channel(pt));
    header.channels().insert("G", Imf::Channel(pt));
    header.channels().insert("B", Imf::Channel(pt));
    Imf::OutputFile file(path.c_str(), header);
    Imf::FrameBuffer fb;
    std::vector<half> halves;  // OutputFile does not convert FLOAT buffers to HALF channels
    if (type == ExrPixelType::Half) {
        halves.resize(img.pixels.size() * 3);
        for (size_t i = 0; i < img.pixels.size(); ++i)
            for (int c = 0; c < 3; ++c) halves[3 * i + c] = half(img.pixels[i][c]);
        char* base = reinterpret_cast<char*>(halves.data());
        const size_t xs = 3 * sizeof(half), ys = xs * size_t(img.width);
        fb.insert("R", Imf::Slice(Imf::HALF, base + 0 * sizeof(half), xs, ys));
        fb.insert("G", Imf::Slice(Imf::HALF, base + 1 * sizeof(half), xs, ys));
        fb.insert("B", Imf::Slice(Imf::HALF, base + 2 * sizeof(half), xs, ys));
    } else {
        char* base = const_cast<char*>(reinterpret_cast<const char*>(img.pixels.data()));
        const size_t xs = sizeof(Color), ys = sizeof(Color) * size_t(img.width);
        fb.insert("R", Imf::Slice(Imf::FLOAT, base + 0 * sizeof(float), xs, ys));
        fb.insert("G", Imf::Slice(Imf::FLOAT, base + 1 * sizeof(float), xs, ys));
        fb.insert("B", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xs, ys));
    }
    file.setFrameBuffer(fb);
    file.writePixels(img.height);
}

// ---- PFM -----------------------------------------------------------------------------------

bool isSpace(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; }

// Reads the next whitespace-delimited header token starting at pos; leaves pos on the single
// whitespace character that ends it.
std::string nextToken(const std::string& path, const std::vector<char>& data, size_t& pos, const char* what) {
    while (pos < data.size() && isSpace(data[pos])) ++pos;
    size_t start = pos;
    while (pos < data.size() && !isSpace(data[pos]) && pos - start < 64) ++pos;
    if (start == pos || pos >= data.size()) fail(path, std::string("corrupt PFM header: missing ") + what);
    return std::string(data.data() + start, data.data() + pos);
}

int64_t parseDim(const std::string& path, const std::string& tok, const char* what) {
    if (tok.empty() || !std::all_of(tok.begin(), tok.end(), [](unsigned char c) { return std::isdigit(c); }) || tok.size() > 10)
        fail(path, std::string("corrupt PFM header: invalid ") + what + " '" + tok + "'");
    return std::stoll(tok);
}

uint32_t byteswap32(uint32_t v) {
    return (v >> 24) | ((v >> 8) & 0xff00u) | ((v << 8) & 0xff0000u) | (v << 24);
}

Image readPfm(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) fail(path, std::string("cannot open file: ") + std::strerror(errno));
    in.seekg(0, std::ios::end);
    const std::streamoff fileSize = in.tellg();
    in.seekg(0, std::ios::beg);
    if (fileSize < 0) fail(path, "cannot determine file size");
    std::vector<char> data(static_cast<size_t>(fileSize));
    if (!data.empty() && !in.read(data.data(), std::streamsize(data.size()))) fail(path, "read error");

    size_t pos = 0;
    if (data.size() < 2 || data[0] != 'P' || (data[1] != 'F' && data[1] != 'f') || (data.size() > 2 && !isSpace(data[2])))
        fail(path, "corrupt PFM header: expected magic 'PF' or 'Pf'");
    const int nc = data[1] == 'F' ? 3 : 1;
    pos = 2;
    int64_t w = parseDim(path, nextToken(path, data, pos, "width"), "width");
    int64_t h = parseDim(path, nextToken(path, data, pos, "height"), "height");
    std::string scaleTok = nextToken(path, data, pos, "scale");
    char* end = nullptr;
    double scale = std::strtod(scaleTok.c_str(), &end);
    if (end != scaleTok.c_str() + scaleTok.size() || !std::isfinite(scale) || scale == 0.0)
        fail(path, "corrupt PFM header: invalid scale '" + scaleTok + "' (must be a nonzero number)");
    ++pos;  // exactly one whitespace character separates the header from the raster
    checkDimensions(path, w, h);

    const bool fileLittle = scale < 0.0;
    const bool swap = fileLittle != (std::endian::native == std::endian::little);
    const size_t expected = size_t(w) * size_t(h) * size_t(nc) * sizeof(float);
    const size_t available = data.size() - pos;
    if (available < expected)
        fail(path, "PFM raster size mismatch: header says " + std::to_string(w) + "x" + std::to_string(h) + "x" +
                       std::to_string(nc) + " floats (" + std::to_string(expected) + " bytes) but only " +
                       std::to_string(available) + " bytes follow the header");

    Image img{int(w), int(h)};
    const char* src = data.data() + pos;
    for (int64_t row = 0; row < h; ++row) {
        int y = int(h - 1 - row);  // PFM stores rows bottom-to-top
        for (int64_t x = 0; x < w; ++x) {
            float v[3];
            for (int c = 0; c < nc; ++c) {
                uint32_t bits;
                std::memcpy(&bits, src, 4);
                src += 4;
                if (swap) bits = byteswap32(bits);
                std::memcpy(&v[c], &bits, 4);
            }
            img.at(int(x), y) = nc == 3 ? Color(v[0], v[1], v[2]) : Color(v[0]);
        }
    }
    return img;
}

// ---- Radiance HDR --------------------------------------------------------------------------

Image readHdr(const std::string& path) {
    if (!stbi_is_hdr(path.c_str())) fail(path, "not a Radiance HDR file (missing or invalid '#?RADIANCE'/'#?RGBE' header)");
    int w = 0, h = 0, n = 0;
    std::unique_ptr<float, void (*)(void*)> data(stbi_loadf(path.c_str(), &w, &h, &n, 3), stbi_image_free);
    if (!data) {
        const char* why = stbi_failure_reason();
        fail(path, std::string("cannot read Radiance HDR file: ") + (why ? why : "unknown error"));
    }
    checkDimensions(path, w, h);
    Image img(w, h);
    std::memcpy(img.pixels.data(), data.get(), size_t(w) * size_t(h) * sizeof(Color));
    return img;
}

}  // namespace

// ---- public API ----------------------------------------------------------------------------

Image readImage(const std::string& path) {
    const std::string ext = lowerExtension(path);
    if (ext != ".exr" && ext != ".pfm" && ext != ".hdr")
        fail(path, "unknown image extension '" + ext + "' (readable: .exr, .pfm, .hdr)");
    requireReadableFile(path);
    try {
        if (ext == ".exr") return readExr(path);
        if (ext == ".pfm") return readPfm(path);
        return readHdr(path);
    } catch (const ImageError&) {
        throw;
    } catch (const std::bad_alloc&) {
        fail(path, "out of memory while reading");
    } catch (const std::exception& e) {
        fail(path, std::string("cannot read ") + (ext == ".exr" ? "OpenEXR" : "image") + " file: " + e.what());
    }
}

void writeExr(const Image& img, const std::string& path) { writeExr(img, path, ExrPixelType::Float); }

void writeExr(const Image& img, const std::string& path, ExrPixelType type) {
    checkWritable(img, path);
    writeAtomically(path, [&](const std::string& tmp) {
        try {
            writeExrImpl(img, tmp, type);
        } catch (const std::exception& e) {
            fail(path, std::string("cannot write OpenEXR file: ") + e.what());
        }
    });
}

void writePfm(const Image& img, const std::string& path) {
    checkWritable(img, path);
    writeAtomically(path, [&](const std::string& tmp) {
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        if (!out) fail(path, std::string("cannot open for writing: ") + std::strerror(errno));
        // Negative scale = little endian. Data is written in the host's byte order, declared as such.
        out << "PF\n" << img.width << ' ' << img.height << '\n'
            << (std::endian::native == std::endian::little ? "-1.0" : "1.0") << '\n';
        for (int y = img.height - 1; y >= 0; --y)  // bottom row first
            out.write(reinterpret_cast<const char*>(&img.at(0, y)), std::streamsize(sizeof(Color) * size_t(img.width)));
        out.flush();
        if (!out) fail(path, "write error");
    });
}

void writeHdr(const Image& img, const std::string& path) {
    checkWritable(img, path);
    writeAtomically(path, [&](const std::string& tmp) {
        if (!stbi_write_hdr(tmp.c_str(), img.width, img.height, 3, reinterpret_cast<const float*>(img.pixels.data())))
            fail(path, "cannot write Radiance HDR file");
    });
}

float linearToSrgb(float c) {
    if (!(c > 0.f)) return 0.f;  // also maps NaN to 0
    if (c >= 1.f) return 1.f;
    return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.f / 2.4f) - 0.055f;
}

void writePng(const Image& img, const std::string& path, float exposure) {
    checkWritable(img, path);
    const float scale = std::exp2(exposure);
    std::vector<unsigned char> bytes(size_t(img.width) * size_t(img.height) * 3);
    for (size_t i = 0; i < img.pixels.size(); ++i)
        for (int c = 0; c < 3; ++c)
            bytes[3 * i + c] = (unsigned char)std::lround(255.f * linearToSrgb(img.pixels[i][c] * scale));
    writeAtomically(path, [&](const std::string& tmp) {
        if (!stbi_write_png(tmp.c_str(), img.width, img.height, 3, bytes.data(), img.width * 3))
            fail(path, "cannot write PNG file");
    });
}

void writeImage(const Image& img, const std::string& path) {
    const std::string ext = lowerExtension(path);
    if (ext == ".exr") return writeExr(img, path);
    if (ext == ".pfm") return writePfm(img, path);
    if (ext == ".png") return writePng(img, path);
    if (ext == ".hdr") return writeHdr(img, path);
    fail(path, "unknown image extension '" + ext + "' (writable: .exr, .pfm, .png, .hdr)");
}

}  // namespace lt
