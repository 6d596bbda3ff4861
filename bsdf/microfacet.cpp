#include "bsdf/microfacet.h"

#include <cmath>
#include <limits>

namespace lt {

namespace {

constexpr double kSqrtPiD = 1.77245385090551602730;
constexpr double kPiD = 3.14159265358979323846;
constexpr float kOneMinusEps = 0x1.fffffep-1f;

// Inverse error function in double precision: rational initial guess (Giles 2010) refined by
// Newton steps on erf(y) - z.
double erfInv(double z) {
    z = std::clamp(z, -1.0 + 1e-15, 1.0 - 1e-15);
    double w = -std::log((1.0 - z) * (1.0 + z));
    double p;
    if (w < 5.0) {
        w -= 2.5;
        p = 2.81022636e-08;
        p = 3.43273939e-07 + p * w;
        p = -3.5233877e-06 + p * w;
        p = -4.39150654e-06 + p * w;
        p = 0.00021858087 + p * w;
        p = -0.00125372503 + p * w;
        p = -0.00417768164 + p * w;
        p = 0.246640727 + p * w;
        p = 1.50140941 + p * w;
    } else {
        w = std::sqrt(w) - 3.0;
        p = -0.000200214257;
        p = 0.000100950558 + p * w;
        p = 0.00134934322 + p * w;
        p = -0.00367342844 + p * w;
        p = 0.00573950773 + p * w;
        p = -0.0076224613 + p * w;
        p = 0.00943887047 + p * w;
        p = 1.00167406 + p * w;
        p = 2.83297682 + p * w;
    }
    double y = p * z;
    for (int i = 0; i < 3; ++i) {
        double err = std::erf(y) - z;
        double deriv = 2.0 / kSqrtPiD * std::exp(-y * y);
        if (deriv <= 0.0) break;
        y -= err / deriv;
    }
    return y;
}

// Visible-slope x-coordinate for the isotropic Beckmann distribution (alpha = 1) seen from a
// direction at polar angle theta in the xz plane (Heitz & d'Eon 2014). The unnormalised CDF is
//   C(x) = cos(theta) (1 + erf(x)) / 2 + sin(theta) exp(-x^2) / (2 sqrt(pi)),  x <= cot(theta),
// inverted with a bracketed Newton iteration in double precision.
double sampleBeckmannVisibleSlopeX(double cosT, double sinT, double u) {
    const double cotT = cosT / sinT;
    auto C = [&](double x) { return cosT * std::erfc(-x) + sinT * std::exp(-x * x) / kSqrtPiD; };  // 2 * CDF
    auto dC = [&](double x) { return 2.0 * std::exp(-x * x) * (cosT - x * sinT) / kSqrtPiD; };
    const double total = C(cotT);
    const double target = u * total;
    double lo = std::min(cotT, 0.0) - 1.0, hi = cotT;
    while (C(lo) > target && lo > -40.0) lo -= 2.0;
    if (C(lo) >= target) return lo;
    double x = 0.5 * (lo + hi);
    for (int it = 0; it < 100; ++it) {
        double v = C(x) - target;
        if (std::abs(v) <= 1e-15 * total) break;
        if (v > 0) hi = x; else lo = x;
        double d = dC(x);
        double xn = d > 0 ? x - v / d : 0.5 * (lo + hi);
        if (!(xn > lo && xn < hi)) xn = 0.5 * (lo + hi);
        if (hi - lo < 1e-14 * std::max(1.0, std::abs(x))) { x = xn; break; }
        x = xn;
    }
    return x;
}

}  // namespace

Microfacet::Microfacet(MicrofacetType type, float alphaU, float alphaV, MaskingModel masking)
    : type_(type), masking_(masking), au_(std::max(alphaU, kMinAlpha)), av_(std::max(alphaV, kMinAlpha)) {}

float Microfacet::D(const Vec3& m) const {
    if (!(m.z > 0.f)) return 0.f;
    const double x = double(m.x) / au_, y = double(m.y) / av_, z = m.z;
    if (type_ == MicrofacetType::GGX) {
        const double t = x * x + y * y + z * z;
        return float(1.0 / (kPiD * double(au_) * av_ * t * t));
    }
    const double z2 = z * z;
    const double e = (x * x + y * y) / z2;
    if (e > 700.0) return 0.f;
    return float(std::exp(-e) / (kPiD * double(au_) * av_ * z2 * z2));
}

float Microfacet::lambda(const Vec3& w) const {
    const double ax = double(au_) * w.x, ay = double(av_) * w.y;
    const double r2 = ax * ax + ay * ay;  // alpha^2 sin^2(theta) (azimuth-dependent alpha)
    const double z = std::abs(double(w.z));
    if (r2 == 0.0) return 0.f;
    if (z == 0.0) return kInf;
    if (type_ == MicrofacetType::GGX) {
        const double a2t2 = r2 / (z * z);
        if (!(a2t2 < 1e300)) return kInf;
        return float(a2t2 / (2.0 * (1.0 + std::sqrt(1.0 + a2t2))));  // (sqrt(1 + a2t2) - 1) / 2
    }
    const double a = z / std::sqrt(r2);  // 1 / (alpha tan(theta))
    const double l = 0.5 * (std::exp(-a * a) / (a * kSqrtPiD) - std::erfc(a));
    return float(std::max(0.0, l));
}

float Microfacet::G1Smith(const Vec3& w, const Vec3& m) const {
    if (!(glm::dot(w, m) * w.z > 0.f)) return 0.f;
    return 1.f / (1.f + lambda(w));
}

float Microfacet::G1VCavity(const Vec3& w, const Vec3& m) const {
    const float wm = glm::dot(w, m);
    if (!(wm * w.z > 0.f)) return 0.f;
    return std::min(1.f, 2.f * std::abs(m.z) * std::abs(w.z) / std::abs(wm));
}

float Microfacet::G1(const Vec3& w, const Vec3& m) const {
    return masking_ == MaskingModel::Smith ? G1Smith(w, m) : G1VCavity(w, m);
}

float Microfacet::G2(const Vec3& wo, const Vec3& wi, const Vec3& m) const {
    return G2(wo, wi, G1(wo, m), G1(wi, m));
}

float Microfacet::G2(const Vec3& wo, const Vec3& wi, float go, float gi) const {
    if (masking_ == MaskingModel::Smith) return go * gi;
    if (wo.z * wi.z > 0.f) return std::min(go, gi);
    return std::max(0.f, go + gi - 1.f);
}

float Microfacet::pdfVisible(const Vec3& w, const Vec3& m) const {
    if (!(w.z > 0.f) || !(m.z > 0.f)) return 0.f;
    const float wm = glm::dot(w, m);
    if (!(wm > 0.f)) return 0.f;
    return G1(w, m) * wm * D(m) / w.z;
}

Vec3 Microfacet::sampleD(const Vec2& u) const {
    const float ux = std::min(u.x, kOneMinusEps);
    const float r2 = type_ == MicrofacetType::GGX ? ux / (1.f - ux) : -std::log1p(-ux);
    const float r = std::sqrt(r2);
    const float phi = 2.f * kPi * u.y;
    const float sx = au_ * r * std::cos(phi), sy = av_ * r * std::sin(phi);
    return glm::normalize(Vec3(-sx, -sy, 1.f));
}

Vec3 Microfacet::sampleVisibleSmith(const Vec3& w, const Vec2& u) const {
    if (type_ == MicrofacetType::GGX) {
        // Heitz 2018, "Sampling the GGX distribution of visible normals".
        const Vec3 vh = glm::normalize(Vec3(au_ * w.x, av_ * w.y, w.z));
        const float lensq = vh.x * vh.x + vh.y * vh.y;
        const Vec3 t1v = lensq > 0.f ? Vec3(-vh.y, vh.x, 0.f) / std::sqrt(lensq) : Vec3(1.f, 0.f, 0.f);
        const Vec3 t2v = glm::cross(vh, t1v);
        const float r = std::sqrt(u.x), phi = 2.f * kPi * u.y;
        const float t1 = r * std::cos(phi);
        float t2 = r * std::sin(phi);
        const float s = 0.5f * (1.f + vh.z);
        t2 = (1.f - s) * safeSqrt(1.f - t1 * t1) + s * t2;
        const Vec3 nh = t1 * t1v + t2 * t2v + safeSqrt(1.f - t1 * t1 - t2 * t2) * vh;
        return glm::normalize(Vec3(au_ * nh.x, av_ * nh.y, std::max(0.f, nh.z)));
    }
    // Beckmann: stretch to alpha = 1, sample the visible slope, rotate, unstretch.
    const double wx = double(au_) * w.x, wy = double(av_) * w.y, wz = w.z;
    const double len = std::sqrt(wx * wx + wy * wy + wz * wz);
    const double sinT = std::sqrt(wx * wx + wy * wy) / len, cosT = wz / len;
    double sx, sy;
    if (sinT < 1e-9) {
        const double r = std::sqrt(-std::log1p(-std::min(double(u.x), 1.0 - 1e-16)));
        const double phi = 2.0 * kPiD * u.y;
        sx = r * std::cos(phi);
        sy = r * std::sin(phi);
    } else {
        const double x = sampleBeckmannVisibleSlopeX(cosT, sinT, u.x);
        const double y = erfInv(2.0 * u.y - 1.0);
        const double rl = std::sqrt(wx * wx + wy * wy);
        const double cp = wx / rl, sp = wy / rl;
        sx = x * cp - y * sp;
        sy = x * sp + y * cp;
    }
    sx *= au_;
    sy *= av_;
    const double n = std::sqrt(sx * sx + sy * sy + 1.0);
    return Vec3(float(-sx / n), float(-sy / n), float(1.0 / n));
}

Vec3 Microfacet::sampleVisible(const Vec3& w, const Vec2& u, float& uExtra) const {
    if (masking_ == MaskingModel::Smith) return sampleVisibleSmith(w, u);
    // V-cavity (Heitz & d'Eon 2014): choose between m and its groove partner by visible area.
    Vec3 m = sampleD(u);
    const Vec3 mp(-m.x, -m.y, m.z);
    const float a = std::max(0.f, glm::dot(w, m)), b = std::max(0.f, glm::dot(w, mp));
    const float q = a + b > 0.f ? b / (a + b) : 0.f;
    if (uExtra < q) {
        m = mp;
        uExtra = std::min(uExtra / q, kOneMinusEps);
    } else {
        uExtra = q < 1.f ? std::min((uExtra - q) / (1.f - q), kOneMinusEps) : 0.f;
    }
    return m;
}

namespace {

// The one body of microfacetReflection and microfacetReflectionTerms (inlined into both: the
// value alone, for the dielectric, is not to pay for a call returning the terms).
[[gnu::always_inline]] inline MicrofacetReflectionTerms reflectionTerms(const Microfacet& mf, const Vec3& wo,
                                                                        const Vec3& wi) {
    MicrofacetReflectionTerms r;
    if (!(wo.z * wi.z > 0.f)) return r;
    Vec3 h = wo + wi;
    const float l2 = glm::dot(h, h);
    if (!(l2 > 0.f)) return r;
    h /= std::sqrt(l2);
    if (h.z < 0.f) h = -h;
    r.h = h;
    r.d = mf.D(h);
    if (r.d == 0.f) return r;
    r.gO = mf.G1(wo, h);
    r.gI = mf.G1(wi, h);
    r.value = r.d * mf.G2(wo, wi, r.gO, r.gI) / (4.f * std::abs(wo.z) * std::abs(wi.z));
    return r;
}

}  // namespace

float microfacetReflection(const Microfacet& mf, const Vec3& wo, const Vec3& wi) {
    return reflectionTerms(mf, wo, wi).value;
}

MicrofacetReflectionTerms microfacetReflectionTerms(const Microfacet& mf, const Vec3& wo, const Vec3& wi) {
    return reflectionTerms(mf, wo, wi);
}

float MicrofacetReflectionTerms::reflectDensity(const Vec3& w, float gW) const {
    // pdfVisible(w, h) / (4 w.h), with pdfVisible's tests and expression.
    const float wh = glm::dot(w, h);
    if (!(wh > 0.f) || !(w.z > 0.f) || !(h.z > 0.f)) return 0.f;
    return gW * wh * d / w.z / (4.f * wh);
}

float microfacetTransmission(const Microfacet& mf, const Vec3& wo, const Vec3& wi, float eta, TransportMode mode) {
    if (!(wo.z * wi.z < 0.f) || eta == 1.f) return 0.f;
    // Written symmetrically in (wo, wi) so that swapping them changes only the mode factor:
    // with n_upper = 1, n_lower = eta, h = normalize(w_up + eta w_down) and
    //   base = D G2 |wi.h| |wo.h| / (|wi.z| |wo.z| (w_up.h + eta w_down.h)^2),
    // Walter's f(wi -> wo) = base n_wo^2 (Radiance) and f(wo -> wi) = base n_wi^2 (Importance).
    const Vec3& up = wo.z > 0.f ? wo : wi;
    const Vec3& dn = wo.z > 0.f ? wi : wo;
    Vec3 h = up + dn * eta;
    const float l2 = glm::dot(h, h);
    if (!(l2 > 0.f)) return 0.f;
    h /= std::sqrt(l2);
    if (h.z < 0.f) h = -h;
    const float dUp = glm::dot(up, h), dDn = glm::dot(dn, h);
    const float denom = dUp + eta * dDn;
    if (denom == 0.f) return 0.f;
    const float d = mf.D(h);
    if (d == 0.f) return 0.f;
    const float g = mf.G2(wo, wi, h);
    if (g == 0.f) return 0.f;
    const float base = d * g * std::abs(dUp * dDn) / (std::abs(wi.z) * std::abs(wo.z) * denom * denom);
    const bool woUp = wo.z > 0.f;
    const float nOut = (mode == TransportMode::Radiance) == woUp ? 1.f : eta;  // n_wo (Radiance) or n_wi
    return base * nOut * nOut;
}

PairGeometry microfacetPairGeometry(const Vec3& wo, const Vec3& wi, float eta, MaskingModel masking) {
    PairGeometry g{};
    g.lobe = PairGeometry::Lobe::Zero;
    const bool reflection = wo.z * wi.z > 0.f;
    if (!reflection && !(wo.z * wi.z < 0.f)) return g;
    Vec3 h;
    if (reflection) {
        h = wo + wi;
    } else {
        if (eta == 1.f) return g;
        const Vec3& up = wo.z > 0.f ? wo : wi;
        const Vec3& dn = wo.z > 0.f ? wi : wo;
        h = up + dn * eta;
    }
    const float l2 = glm::dot(h, h);
    if (!(l2 > 0.f)) return g;
    h /= std::sqrt(l2);
    if (h.z < 0.f) h = -h;
    if (!(h.z > 0.f)) return g;  // D = 0
    const float oh = glm::dot(wo, h), ih = glm::dot(wi, h);
    if (!reflection) {  // (DielectricBxdf::refractionGeometry's test, and the Jacobian's denominator)
        const float up = wo.z > 0.f ? oh : ih, dn = wo.z > 0.f ? ih : oh;
        if (!(up > 0.f && dn < 0.f) || up + eta * dn == 0.f) return g;
    }
    if (!(oh * wo.z > 0.f) || !(ih * wi.z > 0.f)) return g;  // masking's chi (both models)
    if (masking == MaskingModel::VCavity && !reflection) {  // G2 = max(0, G1(wo) + G1(wi) - 1)
        auto g1 = [&](const Vec3& w, float wm) { return std::min(1.f, 2.f * h.z * std::abs(w.z) / std::abs(wm)); };
        if (!(g1(wo, oh) + g1(wi, ih) - 1.f > 0.f)) return g;
    }
    auto tan2 = [](const Vec3& w) { return (w.x * w.x + w.y * w.y) / (w.z * w.z); };
    g.tanH2 = tan2(h);
    g.tanO2 = tan2(wo);
    g.tanI2 = tan2(wi);
    g.woAbove = wo.z > 0.f;
    g.lobe = reflection ? PairGeometry::Lobe::Reflection : PairGeometry::Lobe::Transmission;
    return g;
}

namespace {

// Smith's Lambda (Microfacet::lambda) of an isotropic lobe at alpha^2 tan^2(theta) = a2t2.
double smithLambda(MicrofacetType type, double a2t2) {
    if (a2t2 == 0.0) return 0.0;
    if (!(a2t2 < 1e300)) return kInf;
    if (type == MicrofacetType::GGX) return a2t2 / (2.0 * (1.0 + std::sqrt(1.0 + a2t2)));
    const double a = 1.0 / std::sqrt(a2t2);
    return std::max(0.0, 0.5 * (std::exp(-a * a) / (a * kSqrtPiD) - std::erfc(a)));
}

}  // namespace

float microfacetAlphaRatio(MicrofacetType type, MaskingModel masking, float a, float b, const PairGeometry& g,
                           bool density) {
    if (a == b || (g.lobe != PairGeometry::Lobe::Reflection && g.lobe != PairGeometry::Lobe::Transmission)) return 1.f;
    // (Microfacet clamps its alphas to kMinAlpha.) D(h) = alpha^2 / (pi cos^4 (alpha^2 + tan^2)^2)
    // for GGX, exp(-tan^2 / alpha^2) / (pi alpha^2 cos^4) for Beckmann: the cosines cancel.
    const double aa = std::max(a, kMinAlpha), bb = std::max(b, kMinAlpha);
    const double a2 = aa * aa, b2 = bb * bb, t = g.tanH2;
    const double q = (a2 + t) / (b2 + t);
    double r = type == MicrofacetType::GGX ? (b2 / a2) * (q * q)
                                           : (a2 / b2) * std::exp(t / a2 - t / b2);
    if (masking == MaskingModel::Smith) {  // G2 = G1(wo) G1(wi), G1 = chi / (1 + Lambda)
        // (GGX: 1 + Lambda = (1 + sqrt(1 + alpha^2 tan^2)) / 2, and the halves cancel)
        auto g1Inverse = [&](double a2t2) {
            return type == MicrofacetType::GGX ? 1.0 + std::sqrt(1.0 + a2t2) : 1.0 + smithLambda(type, a2t2);
        };
        r *= density ? g1Inverse(a2 * g.tanO2) / g1Inverse(b2 * g.tanO2)
                     : g1Inverse(a2 * g.tanO2) * g1Inverse(a2 * g.tanI2) /
                           (g1Inverse(b2 * g.tanO2) * g1Inverse(b2 * g.tanI2));
    }
    // (NaN: both masking terms 0, a direction grazing to rounding, tan^2 = +inf; eval's value is
    // then 0 under both alphas, whose quotient regularisedRatio takes as 1)
    if (std::isnan(r)) return 1.f;
    return r < double(std::numeric_limits<float>::max()) ? float(r) : kInf;
}

float microfacetAlphaRatioBound(MicrofacetType type, float a, float b) {
    const double aa = std::max(a, kMinAlpha), bb = std::max(b, kMinAlpha);
    if (!(bb > aa)) return bb == aa ? 1.f : kInf;  // (a request only raises alphas; NaN: no bound)
    if (type != MicrofacetType::GGX) return kInf;
    const double r = (bb / aa) * (bb / aa);
    return r < double(std::numeric_limits<float>::max()) ? float(r) : kInf;
}

}  // namespace lt
