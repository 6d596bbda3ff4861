#include "core/lights.h"
#include "core/scene.h"
#include "core/cylinder.h"

namespace lt {

float Light::spotFalloff(const Vec3& w) const {
    float c = glm::dot(w, direction);
    if (c <= cosCutoff) return 0.f;
    float angle = std::acos(std::clamp(c, -1.f, 1.f));
    if (angle <= beamWidth) return 1.f;
    return std::clamp((cutoff - angle) / std::max(cutoff - beamWidth, 1e-7f), 0.f, 1.f);
}

inline Light::AreaPoint Light::sampleArea(const Vec2& u) const {
    return sphere ? sampleSphere(u) : cylinder ? sampleCylinderPoint(u) : sampleMesh(u);
}

Light::AreaPoint Light::sampleCylinderPoint(const Vec2& u) const {
    AreaPoint a;
    sampleCylinder(*cylinder, u, a.p, a.n);
    return a;
}

Light::AreaPoint Light::sampleSphere(const Vec2& u) const {
    const Vec3 d = sampleUniformSphere(u);
    return {sphere->center + sphere->radius * d, sphere->flipNormals ? -d : d};
}

// Each case returns its sample as one prvalue (constructed in place, every field once).
LightSampleLi Light::sampleLiOther(const Scene& scene, const Vec3& refP, const Vec2& u) const {
    switch (type) {
        case LightType::Area:
            return texture ? texturedAreaSampleLi(scene, refP, u) : areaSampleLi(sampleArea(u), refP);
        case LightType::Point:
        case LightType::Spot:
        case LightType::Projector: {
            const Vec3 d = position - refP;
            const float dist = glm::length(d);
            if (!(dist > 0.f)) return {};
            const Color I = type == LightType::Point                ? value
                            : type == LightType::Spot && !texture ? value * spotFalloff(-d / dist)
                                                                  : texturedIntensity(-d / dist);
            return {position, Vec3(0.f), Vec3(0.f), I, AreaPdf(1.f)};
        }
        case LightType::Directional: {
            const Vec3 wi = -direction;
            return {refP + wi * (2.f * scene.boundsRadius()), Vec3(0.f), wi, value, AreaPdf(1.f)};
        }
        case LightType::Constant: {
            const Vec3 wi = sampleUniformSphere(u);
            return {refP + wi * (2.f * scene.boundsRadius()), Vec3(0.f), wi, value, AreaPdf(kUniformSpherePdf)};
        }
        case LightType::Envmap: {
            const EnvironmentMap::Sample e = envmap->sample(u);
            if (!(e.pdf > 0.f)) return {};
            return {refP + e.toSky * (2.f * scene.boundsRadius()), Vec3(0.f), e.toSky, e.value, AreaPdf(e.pdf)};
        }
    }
    return {};
}

AreaPdf Light::pdfLi(const Scene&, const Vec3&, const Vec3&, const Vec3&, const Vec3& wi) const {
    switch (type) {
        case LightType::Area: return AreaPdf(invArea);
        case LightType::Constant: return AreaPdf(kUniformSpherePdf);
        case LightType::Envmap: return AreaPdf(envmap->pdf(wi));
        default: return AreaPdf(0.f);  // delta lights cannot be hit
    }
}

AreaPdf Light::pdfLePos(const Scene& scene) const {
    switch (type) {
        case LightType::Area: return AreaPdf(invArea);
        case LightType::Point:
        case LightType::Spot:
        case LightType::Projector: return AreaPdf(1.f);
        case LightType::Directional:
        case LightType::Constant:
        case LightType::Envmap: return AreaPdf(1.f / (kPi * sqr(scene.geometryRadius())));
    }
    return AreaPdf(0.f);
}

SolidAnglePdf Light::pdfLeDir(const Vec3& n, const Vec3& dir) const {
    switch (type) {
        case LightType::Area: return SolidAnglePdf(cosineHemispherePdf(glm::dot(n, dir)));
        case LightType::Point: return SolidAnglePdf(kUniformSpherePdf);
        case LightType::Spot:
            return SolidAnglePdf(glm::dot(dir, direction) > cosCutoff ? 1.f / coneSolidAngle(cutoff) : 0.f);
        case LightType::Directional: return SolidAnglePdf(1.f);  // delta direction
        case LightType::Constant: return SolidAnglePdf(kUniformSpherePdf);
        case LightType::Envmap: return SolidAnglePdf(envmap->pdf(-dir));  // dir travels from the sky
        case LightType::Projector: return projectorPdfDir(dir);
    }
    return SolidAnglePdf(0.f);
}

LightSampleLe Light::sampleLe(const Scene& scene, const Vec2& uPos, const Vec2& uDir) const {
    LightSampleLe s;
    switch (type) {
        case LightType::Area: {
            if (texture) {
                const TexturedPoint a = sampleTexturedArea(scene, uPos);
                s.p = a.p;
                s.n = a.n;
                s.uv = a.uv;
                s.value = texture->eval(a.uv);
            } else {
                const AreaPoint a = sampleArea(uPos);
                s.p = a.p;
                s.n = a.n;
                s.value = value;
            }
            Vec3 local = sampleCosineHemisphere(uDir);
            s.dir = Frame(s.n).toWorld(local);
            s.pdfPos = AreaPdf(invArea);
            s.pdfDir = SolidAnglePdf(cosineHemispherePdf(local.z));
            return s;
        }
        case LightType::Point:
            s.p = position;
            s.dir = sampleUniformSphere(uDir);
            s.value = value;
            s.pdfPos = AreaPdf(1.f);
            s.pdfDir = SolidAnglePdf(kUniformSpherePdf);
            return s;
        case LightType::Spot: {
            s.p = position;
            s.dir = Frame(direction).toWorld(sampleUniformCone(uDir, cosCutoff));
            s.value = texture ? texturedIntensity(s.dir) : value * spotFalloff(s.dir);
            s.pdfPos = AreaPdf(1.f);
            s.pdfDir = SolidAnglePdf(1.f / coneSolidAngle(cutoff));
            return s;
        }
        case LightType::Projector: return projectorSampleLe(uDir);
        case LightType::Directional:
        case LightType::Constant:
        case LightType::Envmap: {
            s.value = value;
            s.pdfDir = SolidAnglePdf(type == LightType::Directional ? 1.f : kUniformSpherePdf);
            if (type == LightType::Envmap) {
                const EnvironmentMap::Sample e = envmap->sample(uDir);
                if (!(e.pdf > 0.f)) return s;  // (pdfPos 0: no sample)
                s.dir = -e.toSky;
                s.value = e.value;
                s.pdfDir = SolidAnglePdf(e.pdf);
            } else {
                s.dir = type == LightType::Directional ? direction : -sampleUniformSphere(uDir);
            }
            Frame f(s.dir);
            // On the disk facing dir that covers the geometry's bounding sphere, behind it.
            Vec2 d = sampleConcentricDisk(uPos) * scene.geometryRadius();
            s.p = scene.geometryCenter() - s.dir * scene.geometryRadius() + f.s * d.x + f.t * d.y;
            s.n = s.dir;
            s.pdfPos = pdfLePos(scene);
            return s;
        }
    }
    return s;
}

float Light::power(const Scene& scene) const {
    float r2 = sqr(scene.geometryRadius());  // (lights at infinity: the flux onto the geometry's disk)
    switch (type) {
        case LightType::Area: return kPi * area * luminance(texture ? texture->meanValue() : value);
        case LightType::Point: return 4.f * kPi * luminance(value);
        case LightType::Spot:
            return texture ? texturedPower() : coneSolidAngle(0.5f * (cutoff + beamWidth)) * luminance(value);
        case LightType::Projector: return texturedPower();
        case LightType::Directional: return kPi * r2 * luminance(value);
        case LightType::Constant: return 4.f * kPi * kPi * r2 * luminance(value);
        case LightType::Envmap: return kPi * r2 * envmap->luminanceIntegral();
    }
    return 0.f;
}

}  // namespace lt
