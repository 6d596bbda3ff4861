// Consistency of the regularisers' bandwidth schedules (issue 16, item 1): on a small scene where
// the regulariser is active, renders at growing sample budgets with the schedule on show the bias
// falling at the log-log slope the schedule predicts, and the same renders with the bandwidth
// fixed show a bias that stays. A schedule that silently stays fixed, or shrinks at another rate,
// fails.
//
// The scene is the point light at the centre of the smooth glass sphere
// (scenes/cornell-box-point-in-glass.xml) seen by the path tracer with max depth 2: every
// contribution is the point seen through the glass (L S E), which no unregularised technique
// renders, so the truth is a point (a delta in the image) and the regularised image is a blob
// whose size is the bias. With the schedule on, the image after N passes averages the passes'
// blobs, each of the bandwidth of its own pass n. The blob's size is measured by a moment that
// is homogeneous in the bandwidth, so its value after N passes is predicted up to a constant by
// the mean of the bandwidth's power over n = 1..N, and its slope against N by that mean's.
// OPSR, which leaves that path unregularised (no rough vertex before the glass), has its own
// scene: a point light, a small mirror and a diffuse screen (L S D E; its test says why).
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>
#include "bsdf/roughness_bound.h"
#include "core/loader.h"
#include "integrators/integrator.h"
#include "integrators/transport/opsr.h"
#include "process.h"
#include "regularizer_paths.h"

using namespace lt;
using namespace lt::test;

namespace {

const std::vector<int> kBudgets = {64, 256, 1024, 4096};

// The channel mean of a pixel.
double value(const Image& img, int x, int y) {
    const Color c = img.pixels[size_t(y) * img.width + x];
    return (double(c.x) + c.y + c.z) / 3.0;
}

// An image's energy centroid (pixel coordinates, pixel centres at +0.5).
void centroid(const Image& img, double& cx, double& cy) {
    double sum = 0.0, sx = 0.0, sy = 0.0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const double v = value(img, x, y);
            sum += v, sx += v * (x + 0.5), sy += v * (y + 0.5);
        }
    cx = sx / sum, cy = sy / sum;
}

// The spread of an image's energy: its second moment about its centroid, in pixels^2, less the
// box pixel's own (1/12 per axis).
double secondMoment(const Image& img) {
    double cx, cy;
    centroid(img, cx, cy);
    double sum = 0.0, m2 = 0.0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const double v = value(img, x, y);
            sum += v;
            m2 += v * (sqr(x + 0.5 - cx) + sqr(y + 0.5 - cy));
        }
    return m2 / sum - 2.0 / 12.0;
}

// The effective area of an image's energy, in pixels^2: its total over its peak, the peak the mean
// of the pixels within 1.5 pixels of the centroid (for a blob many pixels wide, the value at its
// centre).
double effectiveArea(const Image& img) {
    double cx, cy;
    centroid(img, cx, cy);
    double sum = 0.0, peak = 0.0;
    int count = 0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const double v = value(img, x, y);
            sum += v;
            if (sqr(x + 0.5 - cx) + sqr(y + 0.5 - cy) <= 1.5 * 1.5) peak += v, ++count;
        }
    return sum / (peak / count);
}

// The least-squares slope of y against x.
double fittedSlope(const std::vector<double>& x, const std::vector<double>& y) {
    double mx = 0.0, my = 0.0;
    for (size_t i = 0; i < x.size(); ++i) mx += x[i] / x.size(), my += y[i] / x.size();
    double sxy = 0.0, sxx = 0.0;
    for (size_t i = 0; i < x.size(); ++i) sxy += (x[i] - mx) * (y[i] - my), sxx += sqr(x[i] - mx);
    return sxy / sxx;
}

// The slope of log((1/N) sum_{n <= N} h(n)) against log N over kBudgets: the slope of a measure
// that averages over the passes a per-pass value proportional to h(n).
double predictedSlope(const std::function<double(uint64_t)>& h) {
    std::vector<double> logN, logP;
    for (int spp : kBudgets) {
        double sum = 0.0;
        for (int n = 1; n <= spp; ++n) sum += h(uint64_t(n));
        logN.push_back(std::log(double(spp)));
        logP.push_back(std::log(sum / spp));
    }
    return fittedSlope(logN, logP);
}

// What the tests measure: a strategy image (`image`) of PT at max depth `maxDepth`. By default the
// image no unregularised technique produces (singular.exr) at max depth 2: on the point in glass,
// the whole image.
struct Target {
    int maxDepth = 2;
    std::string image = "singular.exr";
};

// Renders `s` (strategy images into dir/<spp>) at `spp` and returns `target`'s image.
Image singularImage(const Scene& scene, RenderSettings s, int spp, const std::filesystem::path& dir,
                    const Target& target = {}) {
    s.spp = spp;
    s.maxDepth = target.maxDepth;
    s.strategyImages = (dir / std::to_string(spp)).string();
    RenderStats st;
    renderImage(scene, s, st);
    return readImage((dir / std::to_string(spp) / target.image).string());
}

// Measures the blob over kBudgets with the schedule on and returns the fitted slope of log measure
// against log N; `fixed` gets the measure at 64 and at 1024 spp with the bandwidth fixed.
struct Measured {
    double slope = 0.0;
    std::vector<double> values;
    double fixed64 = 0.0, fixed1024 = 0.0;
};
Measured measureSchedule(const Scene& scene, const RenderSettings& scheduled, const RenderSettings& fixed,
                         const std::function<double(const Image&)>& measure, const std::filesystem::path& dir,
                         const Target& target = {}) {
    Measured m;
    std::vector<double> logN, logM;
    for (int spp : kBudgets) {
        const double v = measure(singularImage(scene, scheduled, spp, dir / "scheduled", target));
        m.values.push_back(v);
        logN.push_back(std::log(double(spp)));
        logM.push_back(std::log(v));
    }
    m.slope = fittedSlope(logN, logM);
    m.fixed64 = measure(singularImage(scene, fixed, 64, dir / "fixed", target));
    m.fixed1024 = measure(singularImage(scene, fixed, 1024, dir / "fixed", target));
    return m;
}

Scene pointInGlass() {
    return Scene(loadScene(std::string(LT_SOURCE_DIR) + "/scenes/cornell-box-point-in-glass.xml", {{"res", "96"}}));
}

// The same sphere and point (radius 0.3, bk7, intensity 5) alone, seen from 6.8 away through a
// 1.5 degree lens at 64^2: the sphere's image is 108 pixels in radius, so the frame shows its
// centre (the camera ray meets the glass within 17 degrees of the normal), and a lobe of a few
// hundredths of a radian images the point as a blob several pixels wide.
Scene pointInGlassCloseUp(const std::filesystem::path& dir, int res) {
    const std::filesystem::path file = dir / "close-up.xml";
    std::ofstream(file) << R"(<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="2"/></integrator>
    <default name="res" value="64"/>
    <sensor type="perspective">
        <float name="fov" value="1.5"/>
        <string name="fov_axis" value="x"/>
        <transform name="to_world"><lookat origin="0, 0, 6.8" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="1"/></sampler>
        <film type="hdrfilm"><integer name="width" value="$res"/><integer name="height" value="$res"/>
            <rfilter type="box"/></film>
    </sensor>
    <shape type="sphere">
        <point name="center" value="0, 0, 0"/>
        <float name="radius" value="0.3"/>
        <bsdf type="dielectric"><string name="int_ior" value="bk7"/></bsdf>
    </shape>
    <emitter type="point">
        <point name="position" value="0, 0, 0"/>
        <rgb name="intensity" value="5, 5, 5"/>
    </emitter>
</scene>
)";
    return Scene(loadScene(file.string(), {{"res", std::to_string(res)}}));
}

// The mean of an image (channel means).
double meanValue(const Image& img) {
    double sum = 0.0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) sum += value(img, x, y);
    return sum / (double(img.width) * img.height);
}

// A diffuse screen (z = 0, reflectance 0.8), a smooth mirror of 1 x 1 facing it from 1.2 above
// (centred over the origin) and a point light (intensity 10) low beside it at (-2, 0, 0.2): the
// mirror throws the light's sharp reflection onto the screen at x in [1.3, 3.5]. The camera (32^2,
// 20.6 degrees, looking straight down from (-0.4, 0, 1.1), under the mirror, which it does not
// see) frames the screen at x in [-0.6, -0.2], |y| < 0.2, where no reflection of the light lands.
Scene mirrorLeak(const std::filesystem::path& dir) {
    const std::filesystem::path file = dir / "mirror-leak.xml";
    std::ofstream(file) << R"(<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="3"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="20.6"/>
        <transform name="to_world"><lookat origin="-0.4, 0, 1.1" target="-0.4, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="1"/></sampler>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/>
            <rfilter type="box"/></film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><scale value="4"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.8"/></bsdf>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.5"/><rotate x="1" angle="180"/><translate z="1.2"/></transform>
        <bsdf type="conductor"/>
    </shape>
    <emitter type="point">
        <point name="position" value="-2, 0, 0.2"/>
        <rgb name="intensity" value="10, 10, 10"/>
    </emitter>
</scene>
)";
    return Scene(loadScene(file.string()));
}

// PT+JG19 with the diffusion heuristic off (so the bound at the glass is tau_n itself), tau_0 and
// smooth lobes as `specular`, with the consistent schedule; and the same with tau fixed.
void jg19Settings(double tau0, const std::string& specular, RenderSettings& scheduled, RenderSettings& fixed) {
    scheduled = settingsFor("pt", 1);
    scheduled.regularizer = "jg19";
    scheduled.regSpecular = specular;
    scheduled.regDiffusion = false;
    scheduled.regTau = tau0;
    scheduled.regSchedule = "consistent";
    fixed = scheduled;
    fixed.regSchedule = "fixed";
}

// The checks of every test here: the fitted slope within `tolerance` of the predicted one, and
// with the bandwidth fixed the measure the same at 64 and 1024 spp (within 5%).
void checkSchedule(const Measured& m, double predicted, double tolerance, const std::string& measure) {
    INFO(measure << " " << m.values[0] << " " << m.values[1] << " " << m.values[2] << " " << m.values[3] << "; slope "
                 << m.slope << ", predicted " << predicted << "; fixed bandwidth: " << measure << " " << m.fixed64
                 << " at 64 spp, " << m.fixed1024 << " at 1024");
    CHECK(m.slope == Approx(predicted).margin(tolerance));
    CHECK(std::abs(std::log(m.fixed1024 / m.fixed64)) < 0.05);
}

}  // namespace

TEST_CASE("KD13 consistency: the blur of the point's image shrinks as r_N = r0 N^-lambda, and not with lambda 0", "[kd13][render][consistency]") {
    // PT on the point in glass (96^2), r0 0.1: the cone images the point as a disc some pixels
    // wide (at 64 spp ~ 2.5 pixels in radius), whose second moment M2 (pixels^2) is the bias of
    // the image as a point spread (any smooth measurement of it is off by ~ M2; the bias^2 of a
    // pixel ~ M2^2). After N passes the image averages the passes' discs: M2 ~ (1/N) sum_{n <= N}
    // r_n^2, with r_n = r0 n^-lambda (KD13 Sec. 5.1) ~ N^(-2 lambda). Predicted slope of log M2
    // against log N over 64, 256, 1024 and 4096 spp, from that sum, for lambda 1/6: -0.325.
    // Measured -0.314 (r0 0.1; with r0 0.3 the cones start at 45 degrees, where eps =
    // arctan(r / l) and the image of the cone are no longer linear in r, and the slope was
    // -0.27). Tolerance 0.03. With lambda 0 (a fixed radius) M2 stays (measured 17.26 at 64 and
    // 1024 spp): within 5%. A schedule that does not shrink, or shrinks at twice the rate, fails.
    const std::filesystem::path dir = lt::test::tempDir("lt_consistency", "kd13");
    const Scene scene = pointInGlass();
    RenderSettings s = settingsFor("pt", 1);
    s.regularizer = "kd13";
    s.regR0 = 0.1;
    s.regLambda = 1.0 / 6.0;
    RenderSettings fixed = s;
    fixed.regLambda = 0.0;
    const Measured m = measureSchedule(scene, s, fixed, secondMoment, dir);
    const double predicted = predictedSlope([](uint64_t n) { return std::pow(double(n), -1.0 / 3.0); });
    CHECK(predicted == Approx(-0.325).margin(0.002));
    checkSchedule(m, predicted, 0.03, "M2");
    std::filesystem::remove_all(dir);
}

TEST_CASE("JG19 consistency with cones: the blur of the point's image shrinks as 1 / tau_N (Eq. 16), and not with a fixed tau", "[jg19][render][consistency]") {
    // PT+JG19 with --reg-specular cone (the quality heuristic regularises next-event estimation at
    // the glass: no technique samples L S E; diffusion off, so the bound is tau_n itself): the
    // glass becomes KD13's cone with 1 / Omega = tau_n, Omega = 4 pi sin^2(eps/2) ~ pi eps^2, so
    // each pass's disc has M2 ~ eps^2 ~ 1 / tau_n, and after N passes M2 ~ (1/N) sum 1 / tau_n.
    // tau_n grows like n^(1/3) (Eq. 16), so the predicted slope (from consistentTau, whose values
    // test_regularization_schedule checks against the printed formula) is -0.3253 for tau0 100
    // over 64..4096 spp. On the close-up (64^2) the disc is 9 pixels in radius at n = 1 (eps
    // 0.056 rad; the sphere's image is 108 pixels in radius, the disc's r ~ 108 eta eps), well
    // inside the frame and linear in eps. Measured: M2 15.14, 9.75, 6.18, 3.95 pixels^2, slope
    // -0.3238; fixed tau: 41.75 at 64 and 1024 spp (0.08% apart). Tolerance 0.02 on the slope
    // (the measurement's noise is ~ 0.1% per point: the residual is the disc's rounding to the
    // pixel grid, which the box correction removes only to first order); 5% on the fixed M2.
    // With the renderer's tau_N replaced by tau0 (tried: jg19.cpp beginIteration) the slope is
    // 0.0003 and the test fails.
    const std::filesystem::path dir = lt::test::tempDir("lt_consistency", "jg19cone");
    const Scene scene = pointInGlassCloseUp(dir, 64);
    const double tau0 = 100.0;
    RenderSettings s, fixed;
    jg19Settings(tau0, "cone", s, fixed);
    const Measured m = measureSchedule(scene, s, fixed, secondMoment, dir);
    checkSchedule(m, predictedSlope([&](uint64_t n) { return 1.0 / consistentTau(tau0, n); }), 0.02, "M2");
    std::filesystem::remove_all(dir);
}

TEST_CASE("JG19 consistency with GGX lobes: the point's image sharpens as alpha_hat(tau_N)^2, and not with a fixed tau", "[jg19][render][consistency]") {
    // PT+JG19 (GGX, diffusion off): the glass at next-event estimation becomes a rough GGX
    // dielectric with alpha_n = alpha_hat(tau_n). The point's image through it is the
    // transmission lobe seen from the camera: its value at the centre (normal incidence, where
    // the ideal refraction is the straight line to the point) is proportional to D(n) = 1 / (pi
    // alpha^2), so the blob's effective area (energy over peak) scales as alpha^2. GGX's tails
    // make its second moment grow like alpha^2 log(1 / alpha), so the effective area is the
    // homogeneous measure here. After N passes the peak averages the passes' peaks: area(N) ~
    // 1 / ((1/N) sum alpha_n^-2), predicted from alphaForBound(consistentTau(tau0, n)). The
    // Smith transmission bound goes as 1 / alpha^4 (Eq. 9 with G_bar = 4 / alpha^2), so alpha_n
    // ~ tau_n^(-1/4) ~ n^(-1/12) and the predicted slope is only -0.165 (tau0 4e5: alpha 0.073
    // at n = 1, 0.037 at n = 4096). The close-up at 128^2 makes the blob 6 pixels in half-width
    // at n = 1 (tan theta_h ~ 2 theta_i for eta 1.5 at normal incidence, 216 pixels per unit of
    // sin theta_i); GGX's tail beyond the frame (theta_h > 0.3) holds ~ alpha^2 / 0.09 < 6% of
    // the energy. Measured: area 117.7, 95.0, 76.5, 61.7 pixels^2, slope -0.1556; fixed tau
    // 0.08% apart at 64 and 1024 spp. The residual +0.010 is the peak's average over the four
    // centre pixels, which lowers it by ~ (4/3) / r_h^2 (D ~ 1 - 2 r^2 / r_h^2 near the peak,
    // r_h^2 = area / pi): 3.6% at 64 spp, 6.8% at 4096, +0.008 on the slope. Tolerance 0.02; a
    // schedule at half the rate (-0.08) or none (0) fails. With the renderer's tau_N replaced by
    // tau0 the slope is 0.0001 and the test fails.
    // The paper's bound (--reg-bound published, uncompensated): its slow schedule keeps the blob
    // resolvable at this size over 4096 passes. The tight bound's alpha_hat ~ tau^(-1/2) shrinks
    // the blob's area as n^(-1/3), four times faster; its schedule is the same code (consistentTau).
    const std::filesystem::path dir = lt::test::tempDir("lt_consistency", "jg19ggx");
    const Scene scene = pointInGlassCloseUp(dir, 128);
    const double tau0 = 4e5;
    RenderSettings s, fixed;
    jg19Settings(tau0, "ggx", s, fixed);
    for (RenderSettings* r : {&s, &fixed}) {
        r->regBound = "published";
        r->regEnergy = "none";
    }
    const Measured m = measureSchedule(scene, s, fixed, effectiveArea, dir);
    auto alpha = [&](uint64_t n) {
        return double(alphaForBound(MicrofacetType::GGX, MaskingModel::Smith, float(consistentTau(tau0, n)), true, 1.5f));
    };
    INFO("alpha_1 " << alpha(1) << ", alpha_4096 " << alpha(4096));
    checkSchedule(m, -predictedSlope([&](uint64_t n) { return 1.0 / sqr(alpha(n)); }), 0.02, "area");
    std::filesystem::remove_all(dir);
}

TEST_CASE("OPSR consistent offset: the light a roughened mirror leaks beside its reflection fades as g_N^2, and not with a fixed offset", "[opsr][render][consistency]") {
    // PT+OPSR (constant gamma 0.02) on mirrorLeak, max depth 3. A camera path meets the screen
    // (roughness 1), then the mirror (0), where next-event estimation takes g = 1 - (1 - 0)(1 -
    // gamma) = gamma (Eq. 11), and with the consistent offset g_N = 0 + gamma N^-lambda (opsr.h
    // (3); the mirror's own roughness is 0). The mirror becomes a GGX lobe of alpha g, which
    // sends the framed screen light from every mirror point at half-vector angles theta_h >= 0.37
    // rad (computed over the mirror and the frame; the sharp reflection, theta_h = 0, lands
    // elsewhere): GGX's tail, D = alpha^2 / (pi cos^4 theta_h (alpha^2 + tan^2 theta_h)^2) =
    // alpha^2 / (pi sin^4 theta_h) up to 2 alpha^2 / tan^2 theta_h (< 0.6% at alpha 0.02), and
    // Smith masking is 1 within 2e-3 (tan theta <= 2.5). So the leak, the mean of
    // regularised.exr (the image of the regularised technique: the screen's direct light is not
    // in it; a path nothing renders without OPSR, whose truth here is 0), is proportional to g^2.
    // Measured with fixed offsets (1024 spp): 4.903e-6, 1.960e-5, 7.828e-5, 3.109e-4, 1.210e-3 at
    // gamma 0.005, 0.01, 0.02, 0.04, 0.08, local exponents 1.999, 1.997, 1.990, 1.960. After N
    // passes the image averages the passes' leaks: mean(N) ~ (1/N) sum_{n <= N} g_n^2, with g_n
    // from the renderer's offsetScale(); for lambda 1/6, g_n^2 ~ n^-1/3 and the predicted slope
    // over 64..4096 spp is -0.3254 (checked against the printed formula, so a schedule function
    // that returns 1 fails here too). Noise: one sample's leak has a relative deviation of ~3.8
    // (eight seeds at 64 spp: a scatter of 1.5%), so the four points carry 1.5%, 0.75%, 0.37%,
    // 0.19% and the fitted slope ~0.003 (1 sigma); the exponent below 2 moves it by < 0.001.
    // Measured: leak 2.859e-5, 1.821e-5, 1.161e-5, 7.350e-6, slope -0.3264 (seeds 0-4 with the
    // render tool: -0.3275, -0.3295, -0.3227, -0.3243, -0.3295). Tolerance 0.02 (6 sigma): a
    // constant offset (slope 0) or half the rate (-0.16) fails. Fixed offset: 7.899e-5 at 64 spp,
    // 7.834e-5 at 1024 (0.8% apart); checked within 5% (3 sigma of the 64-spp render). The law
    // itself, in the test: fixed gamma 0.01 against 0.02 at 64 spp (the same seed: the same walks,
    // the noise cancels in the ratio) has exponent log2 of the ratio within 0.02 of 2 (1.9975).
    // Tried: with the renderer's g_N replaced by the unshrunk g (requestWith without
    // offsetScale()) the leak is 7.90e-5, 7.80e-5, 7.83e-5, 7.84e-5, slope -0.0012, and the test
    // fails; with offsetScale() returning 1 the predicted slope is 0 and its check fails.
    const std::filesystem::path dir = lt::test::tempDir("lt_consistency", "opsr");
    const Scene scene = mirrorLeak(dir);
    const Target target{3, "regularised.exr"};
    RenderSettings s = settingsFor("pt", 1);
    s.regularizer = "opsr";
    s.regOpsrGamma = 0.02;
    s.regOpsrConsistent = true;
    // The leak is all tail (pi f ~ 0.01-0.04 at these half-vector angles): the tail roulette
    // (regularizer.h (9)) would put each of its connections to the vote, and the noise it adds
    // does not cancel between two renders of the same walks (the exponent above). Without it,
    // as measured above: the law of the regularised integrand, which the roulette leaves alone
    // in expectation (test_tail_roulette).
    s.regTailRr = 0.0;
    RenderSettings fixed = s;
    fixed.regOpsrConsistent = false;
    const Measured m = measureSchedule(scene, s, fixed, meanValue, dir, target);

    RenderSettings half = fixed;
    half.regOpsrGamma = 0.01;
    const double exponent = std::log2(m.fixed64 / meanValue(singularImage(scene, half, 64, dir / "half", target)));
    INFO("leak exponent in gamma " << exponent);
    CHECK(exponent == Approx(2.0).margin(0.02));

    // The schedule: the renderer's own, g_n = a + (g - a) offsetScale() in pass n, a = 0 the
    // mirror's roughness and g = gamma the accumulated roughness of (screen, mirror).
    reg::OpsrSettings os;
    os.attenuation.gamma = float(s.regOpsrGamma);
    os.consistent = true;
    os.lambda = s.regLambda;
    reg::Opsr opsr(os);
    const float a[2] = {1.f, 0.f};
    const double g = opsr::accumulatedRoughness(a, 2, os.attenuation);
    CHECK(g == Approx(0.02).epsilon(1e-5));
    const double predicted = predictedSlope([&](uint64_t n) {
        opsr.beginIteration(n, scene, MisConfig{});
        return sqr(g * opsr.offsetScale());
    });
    CHECK(predicted == Approx(-0.3254).margin(0.002));
    checkSchedule(m, predicted, 0.02, "leak");
    std::filesystem::remove_all(dir);
}
