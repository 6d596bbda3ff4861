// What the scene loader produces: a plain description, independent of Embree.
// Units and conventions follow Mitsuba 3 (see README): the camera looks along +Z of its frame with
// +X to the image left and +Y up; area emitters emit on the side their normal points to.
#pragma once
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>
#include "bsdf/bsdf.h"
#include "core/math.h"
#include "core/texture/texture.h"
#include "core/opacity.h"

namespace lt {

struct MeshDesc {
    std::string name;            // for messages (file or shape id)
    std::vector<Vec3> positions; // world space
    std::vector<Vec3> normals;   // world space, per vertex; empty = face normals
    std::vector<Vec2> uvs;       // per vertex; may be empty
    std::vector<uint32_t> indices;  // 3 per triangle (quads are split by the loader)
    int bsdf = -1;               // index into SceneDesc::bsdfs
    int emitter = -1;            // index into SceneDesc::emitters (type Area), or -1
    int group = -1;              // the shapegroup it belongs to (object space of its instances), -1: none
    // The material reads a mesh attribute (core/mesh_attribute.h): hits carry the attribute key
    // (primitive, barycentrics) in place of uv.
    bool attributeKey = false;
    Opacity opacity;             // a mask BSDF's opacity (core/opacity.h); opaque by default
};

// Mitsuba's cylinder (core/cylinder.h): the unit cylinder x^2 + y^2 = 1, 0 <= z <= 1, open, mapped
// by toWorld (which includes p0, p1 and radius); outward normals unless flipNormals.
struct CylinderDesc {
    std::string name;
    glm::dmat4 toWorld{1.0};
    double radius = 1.0, length = 1.0;  // world space
    bool flipNormals = false;
    int bsdf = -1;
    int emitter = -1;
    int group = -1;
};

// Mitsuba's linearcurve and bsplinecurve (core/curves.h): Embree's round curves through the
// control points (x, y, z, radius), positions mapped by the shape's to_world, radii not.
struct CurveDesc {
    std::string name;
    std::string file;                  // the control-point file (messages)
    bool bspline = false;              // cubic B-spline segments, else linear ones
    std::vector<glm::vec4> points;     // xyz in world (or the shapegroup's) space, w the radius
    std::vector<uint32_t> segments;    // the first control point of each segment
    int bsdf = -1;
    int group = -1;
};

// An <shape type="instance">: the shapes of shapegroup `group` mapped by toWorld.
struct InstanceDesc {
    int group = -1;
    Mat4 toWorld{1.f};
    std::string source;  // "file:line"
};

struct SphereDesc {
    std::string name;
    Vec3 center{0.f};
    float radius = 1.f;
    bool flipNormals = false;  // normals point inwards
    int bsdf = -1;
    int emitter = -1;
    int group = -1;            // as MeshDesc::group
    // The rotation of to_world, inverted: world -> the sphere's local frame, in which Mitsuba's uv
    // parameterisation is defined.
    glm::mat3 toLocal{1.f};
    Opacity opacity;           // as MeshDesc::opacity
};

enum class EmitterType { Area, Point, Spot, Directional, Constant, Envmap, Projector };

class EnvironmentMap;  // core/envmap.h

struct EmitterDesc {
    EmitterType type = EmitterType::Area;
    Color value{1.f};        // area/constant: radiance; point/spot: intensity (W/sr); directional: irradiance
    Vec3 position{0.f};      // point, spot
    Vec3 direction{0, 0, 1}; // spot: beam axis; directional: direction light travels (world space, unit)
    float cutoffAngleDeg = 20.f;  // spot
    float beamWidthDeg = 15.f;    // spot (default 3/4 of the cutoff)
    // envmap: the image file (as resolved), to_world and scale, and the map built from them
    // (immutable, shared by copies of the description; the scene's light points at it).
    std::string filename;
    Mat4 toWorld{1.f};
    float scale = 1.f;
    std::shared_ptr<const EnvironmentMap> envmap;
    // Textured emitters (core/textured_lights.cpp): an area light's `radiance`, a spot's `texture`,
    // a projector's `irradiance` (null: `value`, constant). Spot (with a texture) and projector
    // also read toWorld (a rotation and translation), the projector scale and its horizontal fov.
    TexturePtr texture;
    float fovXDeg = 0.f;     // projector
    // Mitsuba's sampling_weight (>= 0): scales the light's chance of being chosen among the
    // scene's lights (core/scene.cpp, lightSelectionWeights); 0: never chosen by a light sample.
    float samplingWeight = 1.f;
    std::string source;      // "file:line" for messages
};

enum class FovAxis { X, Y, Smaller, Larger, Diagonal };
enum class FilterType { Box, Tent, Gaussian };
// Mitsuba 3's sensors: perspective (the pinhole), thinlens, orthographic (core/camera.h).
enum class SensorType { Perspective, ThinLens, Orthographic };

struct CameraDesc {
    SensorType type = SensorType::Perspective;
    Mat4 toWorld{1.f};       // camera frame: +Z forward, +Y up, +X image left (orthographic: with its scale)
    float fovDeg = 45.f;
    FovAxis fovAxis = FovAxis::X;
    float nearClip = 0.01f;
    float farClip = 1e4f;          // thinlens, orthographic (the pinhole ignores it)
    float apertureRadius = 0.f;    // thinlens
    float focusDistance = 1e4f;    // thinlens: the focal plane's distance (Mitsuba's default: far_clip)
    int width = 768, height = 576;  // the image rendered: the crop window's size
    // hdrfilm's crop window (Mitsuba's crop_offset_x/y, crop_width/height): the image is the
    // window of width x height pixels at (cropX, cropY) of the full film fullWidth x fullHeight,
    // whose size the field of view refers to. 0: the full film is the image.
    int fullWidth = 0, fullHeight = 0, cropX = 0, cropY = 0;
    FilterType filter = FilterType::Box;  // tent and gaussian: filter importance sampling (core/film.h)
    float filterStddev = 0.5f;            // gaussian: Mitsuba's stddev in pixels (radius 4 stddev)
};

// The values the regularisation parameters accept: the loader (XML), render's options and the
// analysis tools' configurations check against these lists.
// "jg19,opsr": OPSR with JG19's bound (integrators/transport/opsr.h (6)).
inline const std::vector<std::string> kRegularizerNames{"none", "jg19", "kd13", "opsr", "jg19,opsr"};
inline const std::vector<std::string> kRegScheduleNames{"consistent", "fixed"};
inline const std::vector<std::string> kRegMisNames{"regularised", "sampling"};
inline const std::vector<std::string> kRegSpecularNames{"ggx", "cone"};
// JG19's bound on a lobe's value: the true supremum or the paper's Eqs. 8-9 (bsdf/roughness_bound.h);
// a smooth lobe made rough with or without its albedo kept (bsdf/energy_compensation.h).
inline const std::vector<std::string> kRegBoundNames{"tight", "published"};
inline const std::vector<std::string> kRegEnergyNames{"compensate", "none"};

// The largest threshold of the regularisers' tail roulette (reg_tail_rr, --reg-tail-rr; regularizer.h
// (9)) that the loader, render's command line, the analysis configurations and makeIntegrator take.
inline constexpr double kMaxRegTailRr = 1e6;

// OPSR's table argument "FILE[:SET]" -> (FILE, SET), SET "low" when not given (a colon followed by
// a path, or none, is part of FILE). The loader resolves FILE against the scene's folder.
inline std::pair<std::string, std::string> splitOpsrTableSpec(const std::string& spec) {
    const size_t colon = spec.rfind(':');
    if (colon == std::string::npos || colon == 0 || spec.find('/', colon) != std::string::npos) return {spec, "low"};
    return {spec.substr(0, colon), spec.substr(colon + 1)};
}

struct IntegratorDesc {
    std::string type = "path";  // path | bdpt | vcm | ptracer | ppm
    int maxDepth = -1;          // -1 = unlimited (Mitsuba); counts segments: 1 = direct emission only
    int rrDepth = 0;            // 0: the integrator's default (rrDepthOf, integrators/integrator.h)
    bool hideEmitters = false;
    float radius = -1.f;        // VCM/PPM initial radius (<=0: derived from scene size)
    float radiusAlpha = 0.75f;
    // Path-space regularisation (integrator parameters regularizer, reg_tau, reg_schedule, reg_mis,
    // reg_quality, reg_diffusion, reg_specular, reg_r0, reg_lambda; the render CLI's --reg,
    // --reg-tau, --reg-schedule, --reg-mis, --reg-quality, --reg-diffusion, --reg-specular,
    // --reg-r0, --reg-lambda override them).
    std::string regularizer = "none";    // none | jg19 | kd13
    double regTau = -1.0;                // <= 0: the integrator's default
    std::string regSchedule = "consistent";
    std::string regMis = "regularised";
    bool regQuality = true;              // JG19's sampler quality heuristic (reg_quality)
    std::optional<bool> regDiffusion;    // JG19's diffusion heuristic (reg_diffusion; unset: as regQuality)
    std::string regSpecular = "ggx";     // JG19's smooth lobes: ggx | cone (reg_specular)
    std::string regBound = "tight";      // JG19's bound: tight | published (reg_bound)
    std::string regEnergy = "compensate";  // smooth lobes made rough: compensate | none (reg_energy)
    double regR0 = -1.0;                 // KD13's r_0 (reg_r0; <= 0: the default)
    double regLambda = -1.0;             // KD13's lambda, OPSR's consistent offset's (reg_lambda; < 0: the default)
    double regOpsrGamma = -1.0;          // OPSR's constant gamma (reg_opsr_gamma; < 0: 0.01 unless a table)
    std::string regOpsrTable;            // OPSR's per-class factors, FILE[:SET] (reg_opsr_table; "": none)
    bool regOpsrConsistent = false;      // OPSR's consistent offset (reg_opsr_consistent)
    bool regOpsrAlwaysSample = false;    // OPSR's path tracer: the reference's sample everywhere (reg_opsr_always_sample)
    double regTailRr = -1.0;             // every regulariser: the tail roulette's threshold (reg_tail_rr; < 0: 0.1)
    // Path guiding of the path tracer (integrator parameters guiding, guiding_bsdf_fraction; the
    // render CLI's --guiding, --guiding-bsdf-fraction override them).
    std::string guiding = "off";         // off | radiance | variance
    double guidingBsdfFraction = 0.5;    // in (0, 1]; < 0: learned
};

// How a light sample chooses among the scene's lights (core/scene.cpp, lightSelectionWeights), each
// rule times the lights' sampling_weight: Uniform (Mitsuba 3's), in proportion to Power, or a
// Mixture of the two halves. The render tools take the integrator's (lightSelectionFor,
// integrators/integrator.h); BENCHMARKS.md, "Light selection", has the measurements.
enum class LightSelection { Uniform, Power, Mixture };

struct SceneDesc {
    std::string path;                  // the scene file
    std::vector<BxdfPtr> bsdfs;
    std::vector<MeshDesc> meshes;
    std::vector<SphereDesc> spheres;
    std::vector<CylinderDesc> cylinders;
    std::vector<CurveDesc> curves;
    std::vector<InstanceDesc> instances;
    int groupCount = 0;                // shapegroups (the group fields above index them)
    std::vector<EmitterDesc> emitters;
    LightSelection lightSelection = LightSelection::Uniform;
    CameraDesc camera;
    IntegratorDesc integrator;
    int sampleCount = 4;
    uint64_t seed = 0;
    std::vector<std::string> warnings;  // fallbacks taken (unsupported filter, sampler, ...)
};

}  // namespace lt
