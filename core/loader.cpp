// Scene loader: interprets the Mitsuba XML tree (core/loader_xml.*) into a SceneDesc. Meshes are
// read by core/mesh_io.*; materials are built through the factories of bsdf/bsdf.h.
#include "core/loader.h"

#include <fmt/format.h>

#include <algorithm>
#include <set>
#include "bsdf/roughness_bound.h"
#include "core/curves.h"
#include "core/envmap.h"
#include "core/film.h"
#include "core/image.h"
#include "core/lights.h"
#include "core/loader_emitters.h"
#include "core/loader_materials.h"
#include "core/loader_xml.h"
#include "core/mesh_io.h"
#include "core/mesh_attribute.h"

namespace lt {

namespace {

using loader::Elem;
using loader::Props;
using loader::isIn;
using loader::noObjects;
using loader::nonNegColor;
using xml::joinList;

const std::vector<std::string> kShapeTypes = {"obj", "ply", "serialized", "rectangle", "cube", "disk", "sphere",
                                             "cylinder", "shapegroup", "instance", "linearcurve",
                                             "bsplinecurve"};
const std::vector<std::string> kIntegratorTypes = {"path", "bdpt", "vcm", "ptracer", "ppm", "sppm (as ppm)",
                                                   "direct (as path with max_depth 2)", "moment (its nested integrator)",
                                                   "stokes (its nested integrator)"};

// Inverse transpose of the linear part, up to a positive factor; defined for singular matrices too
// (e.g. a rectangle scaled to zero along its normal keeps its normal).
glm::mat3 normalMatrix(const Mat4& m) {
    glm::mat3 l(m);
    glm::mat3 cof(glm::cross(l[1], l[2]), glm::cross(l[2], l[0]), glm::cross(l[0], l[1]));
    return glm::determinant(l) < 0.f ? -cof : cof;
}

class Builder {
public:
    Builder(xml::Document& d, const std::string& path) : doc_(d) {
        out_.path = path;
        out_.warnings = doc_.warnings;
    }

    SceneDesc run() {
        for (auto& cp : doc_.root->children) {
            const Elem& e = *cp;
            if (e.tag == "integrator") integrator(e);
            else if (e.tag == "sensor") sensor(e);
            else if (e.tag == "bsdf") bsdfIndex(e);
            else if (e.tag == "shape") shape(e);
            else if (e.tag == "emitter") emitters_.topEmitter(e);
            else if (e.tag == "sampler" && e.attr("id")) declaredSamplers_.push_back(&e);  // read where referenced
            else if (e.tag == "texture" && e.attr("id")) materials_.texture(e);  // checked now, used where referenced
            else
                xml::fail(e, fmt::format("unsupported element <{}> at the top level of the scene (supported: integrator, "
                                         "sensor, bsdf, shape, emitter, sampler or texture with an id, default, include, path)",
                                         e.tag));
        }
        for (const Elem* smp : declaredSamplers_)
            if (!referencedSamplers_.count(smp)) warn(*smp, "sampler declared with an id but used by no sensor: ignored");
        for (const Elem* a : emitters_.declaredAreas)
            if (!referencedAreas_.count(a)) warn(*a, "area emitter declared with an id but used by no shape: ignored");
        for (const auto& [g, index] : groupIndex_)
            if (!instancedGroups_.count(g)) warn(*g, "shapegroup used by no instance: not rendered");
        if (!sawSensor_) out_.warnings.push_back(fmt::format("{}: no <sensor>: using the default camera", out_.path));
        if (out_.emitters.empty()) out_.warnings.push_back(fmt::format("{}: the scene has no emitter", out_.path));
        return std::move(out_);
    }

private:
    xml::Document& doc_;
    SceneDesc out_;
    loader::Materials materials_{doc_, out_.warnings};
    loader::Emitters emitters_{doc_, materials_, out_.emitters, out_.warnings};
    std::map<const Elem*, int> bsdfIndices_;
    std::set<const Elem*> referencedAreas_;
    std::vector<const Elem*> declaredSamplers_;
    std::set<const Elem*> referencedSamplers_;
    int defaultBsdf_ = -1;
    bool sawSensor_ = false, sawIntegrator_ = false;
    int currentGroup_ = -1;                     // the shapegroup whose shapes are being read
    std::map<const Elem*, int> groupIndex_;     // shapegroups read (index: MeshDesc::group)
    std::set<const Elem*> instancedGroups_;

    void warn(const Elem& e, const std::string& msg) {
        out_.warnings.push_back(fmt::format("{}: {}: {}", e.where(), e.describe(), msg));
    }

    const Elem& deref(const Elem& e) { return loader::deref(doc_, e); }

    // ---- integrator ------------------------------------------------------------------------
    void integrator(const Elem& e) {
        if (sawIntegrator_) xml::fail(e, "more than one <integrator>");
        sawIntegrator_ = true;
        std::string t = e.type();
        IntegratorDesc& I = out_.integrator;
        if (t == "moment") {  // Mitsuba's moment wraps the integrator that renders: that one is ours
            Props m(e);
            if (m.objects.size() != 1 || deref(*m.objects[0]).tag != "integrator")
                xml::fail(e, "moment needs one nested <integrator> (the one that renders)");
            m.finish();
            warn(e, "moment: the nested integrator renders the image (no second moment is written)");
            sawIntegrator_ = false;
            integrator(deref(*m.objects[0]));
            return;
        }
        if (t == "stokes") {  // Mitsuba's stokes (polarised variants only): its image is the nested one's S0
            Props m(e);
            if (m.objects.size() != 1 || deref(*m.objects[0]).tag != "integrator")
                xml::fail(e, "stokes needs one nested <integrator> (the one that renders)");
            m.finish();
            warn(e, "stokes: the nested integrator renders the image, unpolarised (S0 without polarisation; "
                    "S1-S3 are not written; Mitsuba's rgb variants refuse stokes)");
            sawIntegrator_ = false;
            integrator(deref(*m.objects[0]));
            return;
        }
        if (t == "direct") {
            // Mitsuba's direct illumination: emitters seen directly and lit once, with next-event
            // estimation and BSDF sampling under MIS: the path tracer's paths of up to 2 segments.
            Props p(e);
            I.type = "path";
            I.maxDepth = 2;
            I.hideEmitters = p.getBool("hide_emitters", false);
            p.ignore({"shading_samples", "emitter_samples", "bsdf_samples"}, &out_.warnings);
            noObjects(p, "an integrator has no nested plugins here");
            p.finish();
            warn(e, "direct is rendered as path with max_depth 2 (the same paths and expected value)");
            return;
        }
        bool known = isIn({"path", "bdpt", "vcm", "ptracer", "ppm", "sppm"}, t);
        if (!known)
            warn(e, fmt::format("integrator type '{}' is not supported: falling back to 'path' (the CLI's integrator; "
                                "supported: {}); max_depth, rr_depth and hide_emitters are kept, other parameters "
                                "ignored", t, joinList(kIntegratorTypes)));
        Props p(e);
        if (t == "sppm") {
            warn(e, "sppm is mapped to ppm (progressive photon mapping)");
            p.ignore({"photon_count", "granularity", "max_passes", "samples_per_pass"}, &out_.warnings);
        }
        I.type = !known ? "path" : t == "sppm" ? "ppm" : t;
        I.maxDepth = p.getInt("max_depth", -1);
        if (I.maxDepth < -1) p.failAt("max_depth", fmt::format("must be -1 (unlimited) or >= 0 (got {})", I.maxDepth));
        if (p.has("rr_depth")) {  // absent: the integrator's default (rrDepthOf)
            I.rrDepth = p.getInt("rr_depth", 1);
            if (I.rrDepth < 1) p.failAt("rr_depth", fmt::format("must be >= 1 (got {})", I.rrDepth));
        }
        I.hideEmitters = p.getBool("hide_emitters", false);
        if (!known) return;
        // Regularisation (integrators/transport/regularizer.h).
        I.regularizer = xml::lower(p.getString("regularizer", "none"));
        if (!isIn(kRegularizerNames, I.regularizer))
            p.failAt("regularizer", fmt::format("unknown regulariser '{}' (supported: {})", I.regularizer,
                                                joinList(kRegularizerNames)));
        if (p.has("reg_tau")) {
            I.regTau = p.getFloat("reg_tau", -1.f);
            if (!(I.regTau > kMinTau))
                p.failAt("reg_tau", fmt::format("must exceed 1/(2 pi) = 0.159 (got {})", I.regTau));
        }
        I.regSchedule = xml::lower(p.getString("reg_schedule", "consistent"));
        if (!isIn(kRegScheduleNames, I.regSchedule))
            p.failAt("reg_schedule", fmt::format("unknown schedule '{}' (supported: {})", I.regSchedule,
                                                 joinList(kRegScheduleNames)));
        I.regMis = xml::lower(p.getString("reg_mis", "regularised"));
        if (!isIn(kRegMisNames, I.regMis))
            p.failAt("reg_mis", fmt::format("unknown MIS densities '{}' (supported: {})", I.regMis, joinList(kRegMisNames)));
        I.regQuality = p.getBool("reg_quality", true);
        if (p.has("reg_diffusion")) {
            I.regDiffusion = p.getBool("reg_diffusion", true);
            if (*I.regDiffusion && !I.regQuality)
                p.failAt("reg_diffusion", "the diffusion heuristic needs reg_quality true (it scales the bound at the "
                                          "vertices the quality heuristic chooses per path)");
        }
        I.regSpecular = xml::lower(p.getString("reg_specular", "ggx"));
        if (!isIn(kRegSpecularNames, I.regSpecular))
            p.failAt("reg_specular", fmt::format("unknown smooth-lobe regularisation '{}' (supported: {})", I.regSpecular,
                                                 joinList(kRegSpecularNames)));
        I.regBound = xml::lower(p.getString("reg_bound", "tight"));
        if (!isIn(kRegBoundNames, I.regBound))
            p.failAt("reg_bound", fmt::format("unknown bound '{}' (supported: {})", I.regBound, joinList(kRegBoundNames)));
        I.regEnergy = xml::lower(p.getString("reg_energy", "compensate"));
        if (!isIn(kRegEnergyNames, I.regEnergy))
            p.failAt("reg_energy", fmt::format("unknown energy handling '{}' (supported: {})", I.regEnergy,
                                               joinList(kRegEnergyNames)));
        if (p.has("reg_r0")) {
            I.regR0 = p.getFloat("reg_r0", -1.f);
            if (!(I.regR0 > 0.0) || !std::isfinite(I.regR0))
                p.failAt("reg_r0", fmt::format("must be a positive length (got {})", I.regR0));
        }
        if (p.has("reg_lambda")) {
            I.regLambda = p.getFloat("reg_lambda", -1.f);
            if (!(I.regLambda >= 0.0 && I.regLambda < 0.5))
                p.failAt("reg_lambda", fmt::format("must be in [0, 0.5) (got {})", I.regLambda));
        }
        if (p.has("reg_opsr_gamma")) {
            I.regOpsrGamma = p.getFloat("reg_opsr_gamma", -1.f);
            if (!(I.regOpsrGamma >= 0.0 && I.regOpsrGamma <= 1.0))
                p.failAt("reg_opsr_gamma", fmt::format("must be in [0, 1] (got {})", I.regOpsrGamma));
        }
        I.regOpsrTable = p.getString("reg_opsr_table", "");
        if (p.has("reg_opsr_table") && I.regOpsrTable.empty()) p.failAt("reg_opsr_table", "must name a file (FILE[:SET])");
        if (p.has("reg_opsr_gamma") && !I.regOpsrTable.empty())
            p.failAt("reg_opsr_table", "give either reg_opsr_gamma or reg_opsr_table, not both");
        if (!I.regOpsrTable.empty()) {  // (the file relative to the scene, as mesh files)
            const auto [file, set] = splitOpsrTableSpec(I.regOpsrTable);
            std::string tried;
            const std::string path = xml::resolveFile(doc_, p.owner, file, tried);
            if (path.empty()) p.failAt("reg_opsr_table", fmt::format("attenuation file '{}' not found (looked for: {})", file, tried));
            I.regOpsrTable = path + ":" + set;
        }
        I.regOpsrConsistent = p.getBool("reg_opsr_consistent", false);
        I.regOpsrAlwaysSample = p.getBool("reg_opsr_always_sample", false);
        if (p.has("reg_tail_rr")) {
            I.regTailRr = p.getFloat("reg_tail_rr", -1.f);
            if (!(I.regTailRr >= 0.0 && I.regTailRr <= kMaxRegTailRr))
                p.failAt("reg_tail_rr", fmt::format("must be in [0, {:g}] (got {})", kMaxRegTailRr, I.regTailRr));
        }
        I.guiding = xml::lower(p.getString("guiding", "off"));
        if (I.guiding != "off" && I.guiding != "radiance" && I.guiding != "variance")
            p.failAt("guiding", fmt::format("unknown guiding '{}' (supported: off, radiance, variance)", I.guiding));
        if (p.has("guiding_bsdf_fraction")) {
            if (p.isString("guiding_bsdf_fraction")) {
                if (xml::lower(p.getString("guiding_bsdf_fraction", "")) != "learned")
                    p.failAt("guiding_bsdf_fraction", "must be a number in (0, 1] or the string 'learned'");
                I.guidingBsdfFraction = -1.0;
            } else {
                I.guidingBsdfFraction = p.getFloat("guiding_bsdf_fraction", 0.5f);
                if (!(I.guidingBsdfFraction > 0.0 && I.guidingBsdfFraction <= 1.0))
                    p.failAt("guiding_bsdf_fraction",
                             fmt::format("must be in (0, 1] or 'learned' (got {})", I.guidingBsdfFraction));
            }
        }
        // radius/alpha are read for every type (kept in IntegratorDesc for a --integrator override),
        // with a warning where the scene's own integrator does not use them.
        if (p.has("initial_radius") && p.has("radius")) p.failAt("radius", "give either radius or initial_radius");
        const char* rname = p.has("initial_radius") ? "initial_radius" : "radius";
        if (p.has(rname)) {
            float r = p.getFloat(rname, -1.f);
            p.requireNonNegative(rname, r);
            I.radius = r > 0.f ? r : -1.f;  // 0: derived from the scene size
        }
        I.radiusAlpha = p.getFloat("alpha", 0.75f);
        if (!(I.radiusAlpha > 0.f && I.radiusAlpha <= 1.f))
            p.failAt("alpha", fmt::format("must be in (0, 1] (got {})", I.radiusAlpha));
        if (I.type != "vcm" && I.type != "ppm" && (p.has(rname) || p.has("alpha")))
            warn(e, fmt::format("radius and alpha are used only by vcm and ppm: ignored by {}", I.type));
        if (I.type == "bdpt") p.ignore({"light_image", "sample_direct"}, &out_.warnings);
        // Mitsuba parameters that change nothing here (a pass is one sample per pixel; there is
        // no time-out per pass; normals are always checked for consistency, surface_bsdf.h).
        p.ignore({"samples_per_pass", "timeout", "strict_normals", "strictNormals"}, &out_.warnings);
        noObjects(p, "an integrator has no nested plugins here");
        p.finish();
    }

    // ---- sensor, film, sampler, filter -----------------------------------------------------
    void sensor(const Elem& e) {
        if (sawSensor_) {
            warn(e, "only the first <sensor> is used");
            return;
        }
        sawSensor_ = true;
        const std::string type = e.type();
        if (type != "perspective" && type != "thinlens" && type != "orthographic")
            xml::fail(e, fmt::format("unsupported sensor type '{}' (supported: perspective, thinlens, orthographic)", type));
        Props p(e);
        CameraDesc& C = out_.camera;
        C.type = type == "thinlens" ? SensorType::ThinLens : type == "orthographic" ? SensorType::Orthographic
                                                                                    : SensorType::Perspective;
        if (C.type != SensorType::Orthographic) perspectiveFov(p, C);
        C.nearClip = p.getFloat("near_clip", 0.01f);
        p.requirePositive("near_clip", C.nearClip);
        C.farClip = p.getFloat("far_clip", 10000.f);
        if (!(C.farClip > C.nearClip)) p.failAt("far_clip", fmt::format("must be > near_clip (got {})", C.farClip));
        if (C.type == SensorType::ThinLens) {
            // Mitsuba: aperture_radius has no default; 0 is replaced by float epsilon (with a
            // warning), which is the pinhole here. focus_distance defaults to far_clip.
            if (!p.has("aperture_radius")) p.failAt("aperture_radius", "is required by thinlens (Mitsuba has no default)");
            C.apertureRadius = p.getFloat("aperture_radius", 0.f);
            p.requireNonNegative("aperture_radius", C.apertureRadius);
            C.focusDistance = p.getFloat("focus_distance", C.farClip);
            p.requirePositive("focus_distance", C.focusDistance);
            if (C.apertureRadius == 0.f) {
                warn(e, "thinlens with aperture_radius 0: rendered as the pinhole (perspective)");
                C.type = SensorType::Perspective;
            }
        } else if (C.type == SensorType::Perspective) {
            p.requirePositive("focus_distance", p.getFloat("focus_distance", 1.f));  // pinhole: ignored
        }
        C.toWorld = p.getTransform("to_world");
        if (C.type == SensorType::Orthographic) {
            // Mitsuba's to_world scales the film (its x and y axes span the film rectangle); a
            // projective row or axes that span no plane with the viewing direction are refused.
            glm::mat3 l(C.toWorld);
            const float proj = std::abs(C.toWorld[0][3]) + std::abs(C.toWorld[1][3]) + std::abs(C.toWorld[2][3]) +
                               std::abs(C.toWorld[3][3] - 1.f);
            const float det = glm::length(l[2]) > 0.f ? glm::determinant(glm::mat3(l[0], l[1], glm::normalize(l[2]))) : 0.f;
            if (!(proj < 1e-3f) || !(std::abs(det) > 0.f) || !std::isfinite(det))
                p.failAt("to_world", "the orthographic camera's transform must be affine with x, y and z axes spanning space");
        } else {
            perspectiveFrame(e, p, C);
        }
        sensorChildren(p);
        p.finish();
    }

    // fov, fov_axis, focal_length of perspective and thinlens (Mitsuba's parse_fov).
    void perspectiveFov(Props& p, CameraDesc& C) {
        std::string axis = xml::lower(p.getString("fov_axis", "x"));
        static const std::pair<const char*, FovAxis> axes[] = {{"x", FovAxis::X}, {"y", FovAxis::Y},
            {"smaller", FovAxis::Smaller}, {"larger", FovAxis::Larger}, {"diagonal", FovAxis::Diagonal}};
        bool found = false;
        for (auto& [n, a] : axes)
            if (axis == n) C.fovAxis = a, found = true;
        if (!found) p.failAt("fov_axis", fmt::format("unknown value '{}' (supported: x, y, smaller, larger, diagonal)", axis));
        if (p.has("fov") && p.has("focal_length")) p.failAt("fov", "give either fov or focal_length");
        if (p.has("fov")) {
            C.fovDeg = p.getFloat("fov", 45.f);
            if (!(C.fovDeg > 0.f && C.fovDeg < 180.f))
                p.failAt("fov", fmt::format("must be in (0, 180) degrees (got {})", C.fovDeg));
        } else {
            // Mitsuba: 35 mm film equivalent focal length (default 50mm), along the diagonal.
            C.fovDeg = loader::focalLengthFovDeg(p);
            C.fovAxis = FovAxis::Diagonal;
        }
    }

    void perspectiveFrame(const Elem& e, Props& p, CameraDesc& C) {
        // Mitsuba refuses a camera frame with scale (an axis not of unit length) or a projective
        // row, and accepts a sheared one, which the camera orthonormalises (core/camera.cpp:
        // forward kept).
        glm::mat3 l(C.toWorld);
        float scaleErr = std::abs(C.toWorld[0][3]) + std::abs(C.toWorld[1][3]) + std::abs(C.toWorld[2][3]) +
                         std::abs(C.toWorld[3][3] - 1.f);
        float shearErr = 0.f;
        for (int i = 0; i < 3; ++i) {
            scaleErr += std::abs(glm::dot(l[i], l[i]) - 1.f);
            for (int j = i + 1; j < 3; ++j) shearErr += std::abs(glm::dot(l[i], l[j]));
        }
        if (!(scaleErr < 1e-3f))
            p.failAt("to_world", "the camera transform must be rigid up to shear: no scale factors (Mitsuba refuses "
                                 "them too)");
        if (!(shearErr < 1e-3f)) warn(e, "the camera transform is sheared: its axes are orthonormalised (forward kept)");
    }

    void sensorChildren(Props& p) {
        bool sawFilm = false, sawSampler = false;
        for (const Elem* r : p.objects) {
            const Elem* o = &deref(*r);  // a sampler may be declared at the top level and referenced
            if (o->tag == "film" && !sawFilm && o == r) film(*o), sawFilm = true;
            else if (o->tag == "sampler" && !sawSampler) {
                sampler(*o);
                sawSampler = true;
                referencedSamplers_.insert(o);
            } else
                xml::fail(*r, "unexpected element inside <sensor> (supported: one film, one sampler or a <ref> to one)");
        }
    }

    void film(const Elem& e) {
        Props p(e);
        std::string t = e.type();
        CameraDesc& C = out_.camera;
        if (t != "hdrfilm")
            warn(e, fmt::format("film type '{}' is not supported: using hdrfilm (the renderer writes the HDR image and a "
                                "PNG beside it)", t));
        C.width = p.getInt("width", 768);
        C.height = p.getInt("height", 576);
        if (C.width <= 0 || C.width > 65536) p.failAt("width", fmt::format("must be in 1..65536 (got {})", C.width));
        if (C.height <= 0 || C.height > 65536) p.failAt("height", fmt::format("must be in 1..65536 (got {})", C.height));
        // Mitsuba's crop window: the image is the window, the field of view the full film's.
        if (p.has("crop_offset_x") || p.has("crop_offset_y") || p.has("crop_width") || p.has("crop_height")) {
            C.fullWidth = C.width;
            C.fullHeight = C.height;
            C.cropX = p.getInt("crop_offset_x", 0);
            C.cropY = p.getInt("crop_offset_y", 0);
            if (C.cropX < 0 || C.cropX >= C.fullWidth)
                p.failAt("crop_offset_x", fmt::format("must be in 0..{} (the film's width - 1; got {})", C.fullWidth - 1, C.cropX));
            if (C.cropY < 0 || C.cropY >= C.fullHeight)
                p.failAt("crop_offset_y", fmt::format("must be in 0..{} (the film's height - 1; got {})", C.fullHeight - 1, C.cropY));
            C.width = p.getInt("crop_width", C.fullWidth - C.cropX);
            C.height = p.getInt("crop_height", C.fullHeight - C.cropY);
            if (C.width < 1 || C.cropX + C.width > C.fullWidth)
                p.failAt("crop_width", fmt::format("must be in 1..{} (the film's width - crop_offset_x; got {})",
                                                   C.fullWidth - C.cropX, C.width));
            if (C.height < 1 || C.cropY + C.height > C.fullHeight)
                p.failAt("crop_height", fmt::format("must be in 1..{} (the film's height - crop_offset_y; got {})",
                                                    C.fullHeight - C.cropY, C.height));
        }
        // A film no machine of ours can hold is refused here, before anything is allocated.
        if (int64_t(C.width) * C.height > Film::kMaxPixels)
            p.failAt("width", fmt::format("the film of {} x {} pixels is too large: at most {} pixels (8192 x 8192), "
                                          "since the film keeps {} bytes a pixel ({:.1f} GB here)",
                                          C.width, C.height, Film::kMaxPixels, Film::kBytesPerPixel,
                                          double(C.width) * C.height * double(Film::kBytesPerPixel) / 1e9));
        bool sawFilter = false;
        for (const Elem* o : p.objects) {
            if (o->tag == "rfilter" && !sawFilter) rfilter(*o), sawFilter = true;
            else xml::fail(*o, "unexpected element inside <film> (supported: one rfilter)");
        }
        if (!sawFilter) {  // Mitsuba's default
            C.filter = FilterType::Gaussian;
            C.filterStddev = 0.5f;
        }
        if (t != "hdrfilm") return;  // parameters of other films are not checked
        p.ignore({"file_format", "pixel_format", "component_format", "banner", "high_quality_edges"});
        p.finish();
    }

    void rfilter(const Elem& e) {
        Props p(e);
        std::string t = e.type();
        if (t == "box" || t == "tent") {
            out_.camera.filter = t == "box" ? FilterType::Box : FilterType::Tent;
            float r = p.getFloat("radius", t == "box" ? 0.5f : 1.f);
            if (r != (t == "box" ? 0.5f : 1.f))
                warn(e, fmt::format("filter radius {} is not supported: using {}", r, t == "box" ? "0.5" : "1"));
            noObjects(p, "a filter has no nested plugins");
            p.finish();
        } else if (t == "gaussian") {
            out_.camera.filter = FilterType::Gaussian;
            out_.camera.filterStddev = p.getFloat("stddev", 0.5f);
            if (!(out_.camera.filterStddev > 0.f && out_.camera.filterStddev <= 64.f))
                p.failAt("stddev", fmt::format("must be in (0, 64] pixels (got {})", out_.camera.filterStddev));
            noObjects(p, "a filter has no nested plugins");
            p.finish();
        } else {
            warn(e, fmt::format("rfilter type '{}' is not supported: using box (supported: box, tent, gaussian)", t));
            out_.camera.filter = FilterType::Box;
        }
    }

    void sampler(const Elem& e) {
        Props p(e);
        std::string t = e.type();
        if (t != "independent")
            warn(e, fmt::format("sampler type '{}' is not supported: using independent (sample_count is kept)", t));
        out_.sampleCount = p.getInt("sample_count", 4);
        if (out_.sampleCount <= 0) p.failAt("sample_count", fmt::format("must be >= 1 (got {})", out_.sampleCount));
        int seed = p.getInt("seed", 0);
        if (seed < 0) p.failAt("seed", fmt::format("must be >= 0 (got {})", seed));
        out_.seed = uint64_t(seed);
        if (t == "independent") {
            noObjects(p, "a sampler has no nested plugins");
            p.finish();
        }
    }

    // ---- bsdfs -----------------------------------------------------------------------------
    int bsdfIndex(const Elem& e) {
        auto it = bsdfIndices_.find(&e);
        if (it != bsdfIndices_.end()) return it->second;
        BxdfPtr b = materials_.bxdf(e);
        int idx = int(out_.bsdfs.size());
        out_.bsdfs.push_back(b);
        bsdfIndices_[&e] = idx;
        return idx;
    }

    int defaultBsdf() {
        if (defaultBsdf_ < 0) {
            defaultBsdf_ = int(out_.bsdfs.size());
            out_.bsdfs.push_back(makeDiffuse(Color(0.5f)));
        }
        return defaultBsdf_;
    }


    // ---- shapes ----------------------------------------------------------------------------
    MeshDesc loadMeshFile(Props& p, const std::string& t, MeshAttributes* attributes = nullptr) {
        std::string filename = p.getString("filename", "");
        if (!p.has("filename")) xml::fail(p.owner, fmt::format("parameter 'filename' is required for a {} shape", t));
        std::string tried;
        std::string path = xml::resolveFile(doc_, p.owner, filename, tried);
        if (path.empty()) p.failAt("filename", fmt::format("mesh file '{}' not found (looked for: {})", filename, tried));
        bool flipTex = t == "obj" ? p.getBool("flip_tex_coords", true) : false;
        int shapeIndex = t == "serialized" ? p.getInt("shape_index", 0) : 0;
        if (shapeIndex < 0) p.failAt("shape_index", fmt::format("must be >= 0 (got {})", shapeIndex));
        try {
            bool fileFaceNormals = false;
            MeshDesc m = t == "obj"   ? readObj(path, flipTex)
                         : t == "ply" ? readPly(path, attributes)
                                      : readSerialized(path, shapeIndex, &fileFaceNormals);
            validateMesh(m, path);
            if (m.indices.empty()) throw MeshError(fmt::format("{}: the file contains no triangles", path));
            if (fileFaceNormals) m.normals.clear();
            else if (m.normals.empty()) computeVertexNormals(m);  // as Mitsuba does
            return m;
        } catch (const MeshError& ex) {
            p.failAt(t == "serialized" && std::string(ex.what()).find("shape_index") != std::string::npos ? "shape_index"
                                                                                                         : "filename",
                     ex.what());
        }
    }

    int shapeEmitter(const Elem* emitter) {
        if (!emitter) return -1;
        if (emitter->type() != "area")
            xml::fail(*emitter, fmt::format("only area emitters can be attached to a shape (got '{}')", emitter->type()));
        out_.emitters.push_back(emitters_.areaDesc(*emitter));
        return int(out_.emitters.size()) - 1;
    }

    void shape(const Elem& e) {
        std::string t = e.type();
        if (!isIn(kShapeTypes, t))
            xml::fail(e, fmt::format("unsupported shape type '{}' (supported: {})", t, joinList(kShapeTypes)));
        if (t == "shapegroup" || t == "instance") return t == "instance" ? instance(e) : (void)shapeGroup(e);
        Props p(e);
        Mat4 M = p.getTransform("to_world");
        bool flip = p.getBool("flip_normals", false);
        bool faceNormals = p.getBool("face_normals", false);
        int bsdf = -1;
        Opacity opacity;  // a mask bsdf's (core/opacity.h)
        const Elem* emitter = nullptr;
        const Elem* attributeBsdf = nullptr;  // a material that reads a mesh attribute: built per mesh
        for (const Elem* o : p.objects) {
            const Elem& target = deref(*o);
            if (target.tag == "bsdf") {
                if (bsdf >= 0 || attributeBsdf) xml::fail(*o, "a shape can have only one bsdf");
                if (loader::usesMeshAttribute(doc_, target)) attributeBsdf = &target;
                else bsdf = bsdfIndex(target);
                opacity = materials_.opacity(target);
            } else if (target.tag == "emitter") {
                if (currentGroup_ >= 0)
                    xml::fail(*o, "an emitter inside a shapegroup is not supported (as in Mitsuba 3): attach it to a "
                                  "shape outside the group");
                if (emitter) xml::fail(*o, "a shape can have only one emitter");
                emitter = &target;
                if (&target != o) referencedAreas_.insert(&target);
            } else {
                xml::fail(*o, fmt::format("unsupported element inside <shape> (supported: bsdf, emitter, or a ref to "
                                          "either; this is a <{}>)", target.tag));
            }
        }
        // (an emitter seen through its own cut-outs would need the mask in the light's sampling too)
        if (emitter && opacity.masked()) xml::fail(e, "a mask bsdf on an emitting shape is not supported");
        std::string name = e.attr("id") ? *e.attr("id") : t;
        if (attributeBsdf && t != "ply")
            xml::fail(*attributeBsdf, fmt::format("a mesh_attribute texture reads a PLY mesh's attributes: this {} "
                                                  "shape has none", t));
        if (t == "cylinder") {
            if (opacity.masked()) xml::fail(e, "a mask bsdf on a cylinder is not supported (meshes and spheres take one)");
            return cylinder(p, M, flip, name, bsdf, emitter);
        }
        if (t == "linearcurve" || t == "bsplinecurve") return curve(p, t, M, flip, opacity, name, bsdf, emitter);
        if (t == "sphere") {
            Vec3 c = p.getPoint("center", Vec3(0.f));
            float r = p.getFloat("radius", 1.f);
            p.requirePositive("radius", r);
            p.finish();
            glm::mat3 l(M);
            float s = glm::length(l[0]);
            float err = std::abs(M[0][3]) + std::abs(M[1][3]) + std::abs(M[2][3]) + std::abs(M[3][3] - 1.f);
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j) err += std::abs(glm::dot(l[i], l[j]) - (i == j ? s * s : 0.f)) / (s * s);
            if (!(s > 0.f) || !(err < 1e-3f))
                p.failAt("to_world", "a sphere's to_world may only translate, rotate and scale uniformly");
            SphereDesc sd;
            sd.name = name;
            sd.center = transformPoint(M, c);
            sd.radius = r * s;
            sd.toLocal = glm::transpose(l / s);  // (l / s is a rotation: checked above)
            sd.flipNormals = flip;
            sd.bsdf = bsdf >= 0 ? bsdf : defaultBsdf();
            sd.emitter = shapeEmitter(emitter);
            sd.group = currentGroup_;
            sd.opacity = opacity;
            out_.spheres.push_back(sd);
            return;
        }
        MeshAttributes attributes;
        MeshDesc m = (t == "rectangle") ? makeRectangle()
                     : (t == "cube")    ? makeCube()
                     : (t == "disk")    ? makeDisk(128)
                                        : loadMeshFile(p, t, &attributes);
        p.finish();
        if (faceNormals) m.normals.clear();
        glm::mat3 N = normalMatrix(M);
        for (auto& v : m.positions) v = transformPoint(M, v);
        bool badNormal = false;
        for (auto& n : m.normals) {
            n = N * n;
            float len = glm::length(n);
            badNormal = badNormal || !(len > 0.f) || !std::isfinite(len);
            n = len > 0.f ? n / len : n;
        }
        if (badNormal) {
            warn(e, "some vertex normals are zero: recomputed from the geometry");
            m.normals.clear();
            computeVertexNormals(m);
        }
        if (flip) {
            for (size_t i = 0; i + 2 < m.indices.size(); i += 3) std::swap(m.indices[i + 1], m.indices[i + 2]);
            for (auto& n : m.normals) n = -n;
        }
        if (emitter) {
            double area = meshArea(m);
            if (!(area > 0.0))
                xml::fail(e, fmt::format("zero-area emitter shape: the area light on this {} has area {}", t, area));
        }
        if (m.indices.empty()) {
            warn(e, "the mesh has no triangles: ignored");
            return;
        }
        m.name = e.attr("id") ? name : m.name;
        m.bsdf = bsdf >= 0 ? bsdf : defaultBsdf();
        if (attributeBsdf) m.bsdf = attributeMaterial(*attributeBsdf, m, attributes, e);
        m.group = currentGroup_;
        m.emitter = shapeEmitter(emitter);
        m.opacity = opacity;
        out_.meshes.push_back(std::move(m));
    }

    // ---- cylinder, shapegroup, instance, mesh attributes (core/cylinder.h, core/instancing.h,
    // core/mesh_attribute.h) ------------------------------------------------------------------
    // Mitsuba's cylinder: to_world * translate(p0) * to_frame(p1 - p0) * scale(r, r, |p1 - p0|),
    // in double precision. Its intersection assumes a circular, right cylinder (Mitsuba warns
    // otherwise and then samples with the wrong area): shear and unequal x/y scales are refused.
    void cylinder(Props& p, const Mat4& M, bool flip, const std::string& name, int bsdf, const Elem* emitter) {
        const Vec3 p0 = p.getPoint("p0", Vec3(0.f)), p1 = p.getPoint("p1", Vec3(0.f, 0.f, 1.f));
        const float r = p.getFloat("radius", 1.f);
        p.requirePositive("radius", r);
        p.ignore({"silhouette_sampling_weight"});  // (differentiable rendering only)
        p.finish();
        const glm::dvec3 d = glm::dvec3(p1) - glm::dvec3(p0);
        const double len = glm::length(d);
        if (!(len > 0.0)) p.failAt("p1", "p0 and p1 coincide: the cylinder has no length");
        const glm::dvec3 n = d / len;  // Mitsuba's Frame3f(n) (core/math.h's Frame: the same basis)
        const double sign = std::copysign(1.0, n.z), a = -1.0 / (sign + n.z), b = n.x * n.y * a;
        const glm::dvec3 s(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), t(b, sign + n.y * n.y * a, -n.y);
        glm::dmat4 local(1.0);
        local[0] = glm::dvec4(s * double(r), 0.0);
        local[1] = glm::dvec4(t * double(r), 0.0);
        local[2] = glm::dvec4(d, 0.0);
        local[3] = glm::dvec4(glm::dvec3(p0), 1.0);
        CylinderDesc c;
        c.toWorld = glm::dmat4(M) * local;
        const glm::dvec3 c0(c.toWorld[0]), c1(c.toWorld[1]), c2(c.toWorld[2]);
        const double r0 = glm::length(c0), r1 = glm::length(c1), l = glm::length(c2);
        const double tol = 1e-5 * std::max({r0, r1, l});
        if (!(r0 > 0.0 && l > 0.0) || std::abs(r0 - r1) > 1e-5 * r0 || std::abs(glm::dot(c0, c1)) > tol * r0 ||
            std::abs(glm::dot(c0, c2)) > tol * l || std::abs(glm::dot(c1, c2)) > tol * l ||
            std::abs(c.toWorld[0][3]) + std::abs(c.toWorld[1][3]) + std::abs(c.toWorld[2][3]) > 0.0)
            p.failAt("to_world", "a cylinder's to_world may rotate, translate, scale uniformly across its axis and "
                                 "along it; no shear or unequal scales across the axis (as Mitsuba 3 requires)");
        c.radius = r0;
        c.length = l;
        c.name = name;
        c.flipNormals = flip;
        c.bsdf = bsdf >= 0 ? bsdf : defaultBsdf();
        c.emitter = shapeEmitter(emitter);
        c.group = currentGroup_;
        out_.cylinders.push_back(c);
    }

    // Mitsuba's linearcurve and bsplinecurve (core/curves.h): positions mapped by to_world, radii
    // not. Not emitters (Mitsuba's curves cannot sample positions), no mask, no flip_normals.
    void curve(Props& p, const std::string& t, const Mat4& M, bool flip, const Opacity& opacity,
               const std::string& name, int bsdf, const Elem* emitter) {
        if (emitter)
            xml::fail(*emitter, fmt::format("a {} cannot be an area emitter (Mitsuba 3's curves cannot sample "
                                            "positions on themselves either)", t));
        if (flip) p.failAt("flip_normals", fmt::format("not supported on a {} (its back faces are culled)", t));
        if (opacity.masked()) xml::fail(p.owner, fmt::format("a mask bsdf on a {} is not supported", t));
        const std::string filename = p.getString("filename", "");
        if (!p.has("filename")) xml::fail(p.owner, fmt::format("parameter 'filename' is required for a {} shape", t));
        p.ignore({"silhouette_sampling_weight"});  // (differentiable rendering only)
        p.finish();
        std::string tried;
        const std::string path = xml::resolveFile(doc_, p.owner, filename, tried);
        if (path.empty()) p.failAt("filename", fmt::format("curve file '{}' not found (looked for: {})", filename, tried));
        CurveDesc c;
        try {
            readCurveFile(path, t == "bsplinecurve", M, c);
        } catch (const CurveError& ex) {
            p.failAt("filename", ex.what());
        }
        c.name = name;
        c.file = path;
        c.bspline = t == "bsplinecurve";
        c.bsdf = bsdf >= 0 ? bsdf : defaultBsdf();
        c.group = currentGroup_;
        out_.curves.push_back(std::move(c));
    }

    // Mitsuba's shapegroup: its shapes (no emitters) in the group's space, rendered only through
    // instances. Read where it is declared or first referenced, once.
    int shapeGroup(const Elem& e) {
        if (auto it = groupIndex_.find(&e); it != groupIndex_.end()) return it->second;
        if (currentGroup_ >= 0) xml::fail(e, "a shapegroup inside a shapegroup is not supported");
        Props p(e);
        const int index = out_.groupCount++;
        groupIndex_[&e] = index;
        currentGroup_ = index;
        for (const Elem* o : p.objects) {
            const Elem& target = deref(*o);
            if (target.tag != "shape")
                xml::fail(*o, fmt::format("a shapegroup holds shapes only (this is a <{}>)", target.tag));
            shape(target);
        }
        currentGroup_ = -1;
        p.finish();
        return index;
    }

    // Mitsuba's instance: a reference to a shapegroup and to_world.
    void instance(const Elem& e) {
        if (currentGroup_ >= 0) xml::fail(e, "an instance inside a shapegroup is not supported");
        Props p(e);
        InstanceDesc in;
        in.toWorld = p.getTransform("to_world");
        in.source = e.where();
        if (p.objects.size() != 1) xml::fail(e, "an instance needs one <ref> to a shapegroup");
        const Elem& g = deref(*p.objects[0]);
        if (g.tag != "shape" || g.type() != "shapegroup")
            xml::fail(*p.objects[0], fmt::format("an instance refers to a shapegroup (this is {})", g.describe()));
        if (!(std::abs(glm::determinant(glm::mat3(in.toWorld))) > 0.f))
            p.failAt("to_world", "the transform is singular");
        p.finish();
        in.group = shapeGroup(g);
        instancedGroups_.insert(&g);
        out_.instances.push_back(in);
    }

    // The material of a PLY mesh whose textures read its attributes: built for this mesh alone.
    int attributeMaterial(const Elem& bsdf, MeshDesc& m, const MeshAttributes& attributes, const Elem& shape) {
        if (m.indices.size() / 3 > kMaxAttributeTriangles)
            xml::fail(shape, fmt::format("a mesh read by a mesh_attribute texture may have at most {} triangles "
                                         "(this one has {})", kMaxAttributeTriangles, m.indices.size() / 3));
        const loader::Materials::ShapeAttributes sa{&attributes, &m.indices,
                                                    fmt::format("the mesh of {} ({})", shape.describe(), shape.where())};
        BxdfPtr b = materials_.bxdfForShape(bsdf, sa);
        m.attributeKey = true;
        out_.bsdfs.push_back(std::move(b));
        return int(out_.bsdfs.size()) - 1;
    }
};

}  // namespace

std::map<std::string, std::string> parseDefines(const std::vector<std::string>& defs) {
    std::map<std::string, std::string> m;
    for (const auto& d : defs) {
        auto eq = d.find('=');
        if (eq == std::string::npos || eq == 0) throw std::invalid_argument("-D expects name=value, got '" + d + "'");
        m[d.substr(0, eq)] = d.substr(eq + 1);
    }
    return m;
}

SceneDesc loadScene(const std::string& path, const std::map<std::string, std::string>& defines) {
    try {
        xml::Document doc = xml::parseDocument(path, defines);
        return Builder(doc, path).run();
    } catch (const SceneError&) {
        throw;
    } catch (const std::bad_alloc&) {
        throw SceneError(fmt::format("{}: out of memory while loading the scene (a corrupt mesh file?)", path));
    } catch (const std::exception& ex) {
        throw SceneError(fmt::format("{}: {}", path, ex.what()));
    }
}

}  // namespace lt
