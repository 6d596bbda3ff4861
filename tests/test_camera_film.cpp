// Camera (rays, We, pdfs, raster positions) and film (filters, invalid samples, splats).
#include <catch2/catch.hpp>
#include <tbb/parallel_for.h>
#include "core/camera.h"
#include "core/film.h"
#include "core/rng.h"
#include "scene_builders.h"

using namespace lt;

TEST_CASE("camera: raster position inverts ray generation, with Mitsuba's axes", "[camera]") {
    for (FovAxis axis : {FovAxis::X, FovAxis::Y, FovAxis::Smaller, FovAxis::Larger, FovAxis::Diagonal}) {
        CameraDesc d = test::lookAt(Vec3(1, 2, 3), Vec3(0, 0, 0), Vec3(0, 1, 0), 50.f, 64, 48);
        d.fovAxis = axis;
        Camera cam(d);
        Rng rng(5, 6);
        for (int i = 0; i < 1000; ++i) {
            Vec2 r(rng.uniform() * 64, rng.uniform() * 48);
            Ray ray = cam.generateRay(r);
            auto back = cam.rasterPosition(ray.o + 3.7f * ray.d);
            REQUIRE(back);
            CHECK(back->x == Approx(r.x).margin(1e-3));
            CHECK(back->y == Approx(r.y).margin(1e-3));
        }
    }
    // Mitsuba: +X of the camera frame is the image left, +Y up.
    CameraDesc d;  // identity: looks along +z
    d.width = d.height = 10;
    Camera cam(d);
    CHECK(cam.rasterPosition(Vec3(0.1f, 0, 1))->x < 5.f);   // +x -> left half
    CHECK(cam.rasterPosition(Vec3(0, 0.1f, 1))->y < 5.f);   // +y -> top half
    CHECK_FALSE(cam.rasterPosition(Vec3(0, 0, -1)));        // behind
    // fov along x: the image edge is at tan(fov/2).
    float t = std::tan(glm::radians(45.f) / 2);
    CHECK(cam.rasterPosition(Vec3(-0.999f * t, 0, 1))->x == Approx(10 * (1 + 0.999f) / 2).epsilon(1e-4));
}

TEST_CASE("camera: generateRay's division-free forms equal the direct ones", "[camera]") {
    // generateRay takes the direction's length from the camera-space image-plane point and from it
    // the unit direction, near_clip / cos and the pdf 1 / (A cos^3): equal to normalising the world
    // direction and to directionPdf(d) only if the frame is orthonormal, so also a frame from a
    // scaled, slightly sheared matrix (the constructor re-orthonormalises it).
    CameraDesc a = test::lookAt(Vec3(1, 2, 3), Vec3(0, 0, 0), Vec3(0, 1, 0), 70.f, 64, 48);
    CameraDesc b = a;
    b.toWorld = a.toWorld * Mat4(Vec4(2.f, 0.01f, 0, 0), Vec4(0, 3.f, 0, 0), Vec4(0.02f, 0, 0.5f, 0), Vec4(0, 0, 0, 1));
    for (CameraDesc d : {a, b}) {
        d.nearClip = 0.5f;
        Camera cam(d);
        Rng rng(3, 1);
        for (int i = 0; i < 2000; ++i) {
            const Vec2 r(rng.uniform() * 64, rng.uniform() * 48);
            SolidAnglePdf pdf;
            const Ray ray = cam.generateRay(r, pdf);
            CHECK(glm::length(ray.d) == Approx(1.0).epsilon(1e-6));
            CHECK(pdf.value == Approx(cam.directionPdf(ray.d).value).epsilon(1e-5));
            CHECK(ray.tMin == Approx(0.5f / glm::dot(ray.d, cam.forward())).epsilon(1e-5));
            CHECK(ray.tMax == kInf);
            CHECK(ray.o == cam.position());
        }
    }
}

TEST_CASE("camera: We and the direction pdf integrate to one over the image", "[camera]") {
    // Integrate over the sphere of directions with a fine (theta, phi) grid around the view axis.
    CameraDesc d = test::lookAt(Vec3(0), Vec3(0, 0, 1), Vec3(0, 1, 0), 60.f, 40, 30);
    Camera cam(d);
    const int nt = 2000, np = 2000;
    double sumPdf = 0, sumWe = 0;
    for (int i = 0; i < nt; ++i) {
        double theta = (i + 0.5) / nt * (kPi / 2);
        for (int j = 0; j < np; ++j) {
            double phi = (j + 0.5) / np * 2 * kPi;
            Vec3 w(float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)), float(std::cos(theta)));
            double dw = std::sin(theta) * (kPi / 2 / nt) * (2 * kPi / np);
            sumPdf += cam.directionPdf(w).value * dw;
            sumWe += cam.importance(w) * std::cos(theta) * dw;  // We cos integrates to 1 (pinhole)
        }
    }
    CHECK(sumPdf == Approx(1.0).epsilon(2e-3));
    CHECK(sumWe == Approx(1.0).epsilon(2e-3));
    // pdf = We * cos for a pinhole sampled by raster position.
    Vec3 w = glm::normalize(Vec3(0.2f, -0.1f, 1.f));
    CHECK(cam.directionPdf(w).value == Approx(cam.importance(w) * w.z).epsilon(1e-5));
}

TEST_CASE("film: Gaussian filter importance sampling has Mitsuba's gaussian's distribution", "[film]") {
    // Mitsuba's gaussian rfilter: exp(-x^2 / (2 s^2)) - exp(-r^2 / (2 s^2)) on [-r, r], r = 4 s.
    // 400000 offsets per stddev in 40 bins against the density's integral (Simpson per bin); each
    // bin within 5 binomial standard deviations (per-bin false alarm ~6e-7).
    for (const float sd : {0.5f, 0.3f}) {
        Film film(4, 4, FilterType::Gaussian, sd);
        const double r = 4.0 * sd, a = -1.0 / (2.0 * sd * sd), bias = std::exp(a * r * r);
        auto f = [&](double x) { return std::max(0.0, std::exp(a * x * x) - bias); };
        auto integral = [&](double x0, double x1) {
            double sum = 0.0;
            const int m = 64;
            for (int k = 0; k < m; ++k) {
                const double u = x0 + (x1 - x0) * k / m, v = u + (x1 - x0) / m;
                sum += (v - u) / 6.0 * (f(u) + 4.0 * f(0.5 * (u + v)) + f(v));
            }
            return sum;
        };
        const double total = integral(-r, r);
        Rng rng(7, 8);
        const int n = 400000, bins = 40;
        std::vector<int> hist(bins, 0);
        for (int i = 0; i < n; ++i) {
            const Vec2 o = film.samplePixelOffset(rng.uniform2());
            REQUIRE(std::abs(o.x - 0.5f) <= float(r) + 1e-5f);
            REQUIRE(std::abs(o.y - 0.5f) <= float(r) + 1e-5f);
            hist[std::clamp(int((o.x - 0.5 + r) / (2 * r) * bins), 0, bins - 1)]++;
        }
        for (int b = 0; b < bins; ++b) {
            const double x0 = -r + 2 * r * b / bins, x1 = x0 + 2 * r / bins;
            const double expected = n * integral(x0, x1) / total;
            INFO("stddev " << sd << " bin " << b);
            CHECK(std::abs(hist[b] - expected) <= 5 * std::sqrt(expected) + 1.0);
        }
    }
}

TEST_CASE("film: tent filter importance sampling has the tent's distribution", "[film]") {
    Film film(4, 4, FilterType::Tent);
    Rng rng(1, 1);
    const int n = 200000, bins = 20;
    std::vector<int> hist(bins, 0);
    for (int i = 0; i < n; ++i) {
        Vec2 o = film.samplePixelOffset(rng.uniform2());
        REQUIRE(o.x >= -0.5f);
        REQUIRE(o.x <= 1.5f);
        hist[std::min(bins - 1, int((o.x + 0.5f) / 2.f * bins))]++;
    }
    for (int b = 0; b < bins; ++b) {
        double x0 = -1 + 2.0 * b / bins, x1 = x0 + 2.0 / bins;
        auto cdf = [](double x) { return x < 0 ? 0.5 * (1 + x) * (1 + x) : 1 - 0.5 * (1 - x) * (1 - x); };
        double expected = n * (cdf(x1) - cdf(x0));
        // 5 standard deviations of a binomial count: per-bin false-alarm ~6e-7.
        CHECK(std::abs(hist[b] - expected) <= 5 * std::sqrt(expected));
    }
    Film box(4, 4, FilterType::Box);
    Vec2 u(0.3f, 0.7f);
    CHECK(box.samplePixelOffset(u) == u);
}

TEST_CASE("film: NaN, Inf and negative samples are rejected and counted", "[film]") {
    Film film(2, 1, FilterType::Box);
    CHECK(film.addSample(0, 0, Color(1.f)));
    CHECK_FALSE(film.addSample(0, 0, Color(std::nanf(""), 0, 0)));
    CHECK_FALSE(film.addSample(0, 0, Color(kInf, 0, 0)));
    CHECK_FALSE(film.addSample(1, 0, Color(-1.f, 0, 0)));
    film.addSampleCount(0, 0, 4);
    film.addSampleCount(1, 0, 1);
    CHECK(film.invalidSamples() == 3);
    SplatBuffer buf;
    CHECK_FALSE(film.splat(buf, Vec2(0.5f, 0.5f), Color(std::nanf(""))));
    CHECK(film.invalidSamples() == 4);
    Image img = film.develop(1);
    CHECK(img.at(0, 0).x == Approx(0.25f));
    CHECK(img.at(1, 0).x == 0.f);
    for (const Color& c : img.pixels) CHECK(isFinite(c));
}

TEST_CASE("film: splats merged in chunk order are independent of the thread schedule", "[film]") {
    auto renderSplats = [](int grain) {
        Film film(8, 8, FilterType::Box);
        const int chunks = 64;
        std::vector<SplatBuffer> bufs(chunks);
        tbb::parallel_for(tbb::blocked_range<int>(0, chunks, grain), [&](const tbb::blocked_range<int>& r) {
            for (int c = r.begin(); c != r.end(); ++c) {
                Rng rng(7, uint64_t(c));
                for (int i = 0; i < 1000; ++i)
                    film.splat(bufs[c], Vec2(rng.uniform() * 8, rng.uniform() * 8), Color(rng.uniform() * 1e3f));
            }
        });
        for (const auto& b : bufs) film.mergeSplats(b);
        return film.develop(3);
    };
    Image a = renderSplats(1), b = renderSplats(64);
    REQUIRE(a.pixels.size() == b.pixels.size());
    for (size_t i = 0; i < a.pixels.size(); ++i) CHECK(a.pixels[i] == b.pixels[i]);
}

TEST_CASE("camera: a crop window is that window of the full film", "[camera]") {
    // Rays, raster positions, importance and its density of the cropped camera are the full
    // camera's shifted by the window's offset, so every technique (camera rays, light tracing's
    // splats, BPT's and VCM's densities) sees the same window.
    CameraDesc full = test::lookAt(Vec3(1, 2, 3), Vec3(0, 0, 0), Vec3(0, 1, 0), 50.f, 40, 30);
    CameraDesc crop = full;
    crop.fullWidth = 40;
    crop.fullHeight = 30;
    crop.cropX = 10;
    crop.cropY = 5;
    crop.width = 20;
    crop.height = 12;
    const Camera a(full), b(crop);
    CHECK(b.width() == 20);
    CHECK(b.height() == 12);
    // The window's share of the image plane is its share of the pixels.
    CHECK(b.imagePlaneArea() == Approx(a.imagePlaneArea() * (20.0 * 12.0) / (40.0 * 30.0)).epsilon(1e-5));
    Rng rng(11, 12);
    for (int i = 0; i < 2000; ++i) {
        const Vec2 r(rng.uniform() * 20.f, rng.uniform() * 12.f);
        const Ray rb = b.generateRay(r), ra = a.generateRay(r + Vec2(10.f, 5.f));
        CHECK(glm::length(rb.d - ra.d) < 1e-5f);
        const Vec3 p = rb.o + 2.3f * rb.d;
        const auto back = b.rasterPosition(p);
        REQUIRE(back);
        CHECK(back->x == Approx(r.x).margin(1e-3));
        CHECK(back->y == Approx(r.y).margin(1e-3));
        // Importance is normalised over the window (1 / (A_window cos^4)): the full camera's over
        // the window's share.
        CHECK(b.importance(rb.d) == Approx(a.importance(rb.d) * (40.0 * 30.0) / (20.0 * 12.0)).epsilon(1e-4));
        CHECK(b.directionPdf(rb.d).value == Approx(a.directionPdf(rb.d).value * (40.0 * 30.0) / (20.0 * 12.0)).epsilon(1e-4));
    }
    // Outside the window: no raster position, no importance, no density.
    for (int i = 0; i < 2000; ++i) {
        const Vec2 r(rng.uniform() * 40.f, rng.uniform() * 30.f);
        const bool inside = r.x > 10.01f && r.x < 29.99f && r.y > 5.01f && r.y < 16.99f;
        const bool outside = r.x < 9.99f || r.x > 30.01f || r.y < 4.99f || r.y > 17.01f;
        const Ray ra = a.generateRay(r);
        if (outside) {
            CHECK_FALSE(b.rasterPosition(ra.o + 2.f * ra.d));
            CHECK(b.importance(ra.d) == 0.f);
            CHECK(b.directionPdf(ra.d).value == 0.f);
        } else if (inside) {
            CHECK(b.importance(ra.d) > 0.f);
        }
    }
}
