// Scene loader: interprets the Mitsuba XML tree (core/loader_xml.*) into a SceneDesc. Meshes are
// read by core/mesh_io.*; materials are built through the factories of bsdf/bsdf.h.
#include "core/loader.h"

#include <fmt/format.h>

#include <algorithm>
#include <set>
#include "bsdf/roughness_bound.h"
#include "core/envmap.h"
#include "core/film.h"
#include "core/image.h"
#include "core/loader_materials.h"
#include "core/loader_xml.h"
#include "core/mesh_io.h"

namespace lt {

namespace {

using loader::Elem;
using loader::Props;
using loader::isIn;
using loader::noObjects;
using loader::nonNegColor;
using xml::joinList;

const std::vector<std::string> kShapeTypes = {"obj", "ply", "serialized", "rectangle", "cube", "disk", "sphere"};
const std::vector<std::string> kEmitterTypes = {"area (inside a shape)", "point", "spot", "directional", "constant",
                                                "envmap"};
const std::vector<std::string> kIntegratorTypes = {"path", "bdpt", "vcm", "ptracer", "ppm", "sppm (as ppm)",
                                                   "direct (as path with max_depth 2)", "moment (its nested integrator)"};

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
            else if (e.tag == "emitter") topEmitter(e);
            else if (e.tag == "sampler" && e.attr("id")) declaredSamplers_.push_back(&e);  // read where referenced
            else if (e.tag == "texture" && e.attr("id")) materials_.texture(e);  // checked now, used where referenced
            else
                xml::fail(e, fmt::format("unsupported element <{}> at the top level of the scene (supported: integrator, "
                                         "sensor, bsdf, shape, emitter, sampler or texture with an id, default, include, path)",
                                         e.tag));
        }
        for (const Elem* smp : declaredSamplers_)
            if (!referencedSamplers_.count(smp)) warn(*smp, "sampler declared with an id but used by no sensor: ignored");
        for (const Elem* a : declaredAreas_)
            if (!referencedAreas_.count(a)) warn(*a, "area emitter declared with an id but used by no shape: ignored");
        if (!sawSensor_) out_.warnings.push_back(fmt::format("{}: no <sensor>: using the default camera", out_.path));
        if (out_.emitters.empty()) out_.warnings.push_back(fmt::format("{}: the scene has no emitter", out_.path));
        return std::move(out_);
    }

private:
    xml::Document& doc_;
    SceneDesc out_;
    loader::Materials materials_{doc_, out_.warnings};
    std::map<const Elem*, int> bsdfIndices_;
    std::vector<const Elem*> declaredAreas_;
    std::set<const Elem*> referencedAreas_;
    std::vector<const Elem*> declaredSamplers_;
    std::set<const Elem*> referencedSamplers_;
    int defaultBsdf_ = -1;
    bool sawSensor_ = false, sawIntegrator_ = false;

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
        if (e.type() != "perspective")
            xml::fail(e, fmt::format("unsupported sensor type '{}' (supported: perspective)", e.type()));
        Props p(e);
        CameraDesc& C = out_.camera;
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
            float f = 50.f;
            if (p.isString("focal_length")) {
                std::string s = p.getString("focal_length", "50mm");
                if (s.size() > 2 && s.substr(s.size() - 2) == "mm") s.resize(s.size() - 2);
                auto n = xml::parseNumbers(s);
                if (!n || n->size() != 1) p.failAt("focal_length", "expected a length like \"50mm\"");
                f = float((*n)[0]);
            } else {
                f = p.getFloat("focal_length", 50.f);
            }
            p.requirePositive("focal_length", f);
            C.fovDeg = glm::degrees(2.f * std::atan(std::sqrt(36.f * 36.f + 24.f * 24.f) / (2.f * f)));
            C.fovAxis = FovAxis::Diagonal;
        }
        C.nearClip = p.getFloat("near_clip", 0.01f);
        p.requirePositive("near_clip", C.nearClip);
        float farClip = p.getFloat("far_clip", 10000.f);
        if (!(farClip > C.nearClip)) p.failAt("far_clip", fmt::format("must be > near_clip (got {})", farClip));
        p.requirePositive("focus_distance", p.getFloat("focus_distance", 1.f));  // pinhole: ignored
        C.toWorld = p.getTransform("to_world");
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
        p.finish();
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


    // ---- emitters --------------------------------------------------------------------------
    EmitterDesc areaDesc(const Elem& e) {
        Props p(e);
        EmitterDesc d;
        d.type = EmitterType::Area;
        d.source = e.where();
        d.value = nonNegColor(p, "radiance", Color(1.f));
        p.ignore({"sampling_weight"});
        noObjects(p, "textures are not supported");
        p.finish();
        return d;
    }

    void topEmitter(const Elem& e) {
        std::string t = e.type();
        if (t == "area") {
            if (!e.attr("id"))
                xml::fail(e, "an area emitter must be inside a <shape> (or have an id and be referenced by shapes)");
            areaDesc(e);  // checks it now
            declaredAreas_.push_back(&e);
            return;
        }
        if (!isIn({"point", "spot", "directional", "constant", "envmap"}, t))
            xml::fail(e, fmt::format("unsupported emitter type '{}' (supported: {})", t, joinList(kEmitterTypes)));
        if (t == "constant" || t == "envmap")  // a ray leaving the scene sees one light (core/scene.cpp)
            for (const EmitterDesc& o : out_.emitters)
                if (o.type == EmitterType::Constant || o.type == EmitterType::Envmap)
                    xml::fail(e, fmt::format("only one environment emitter (constant or envmap) per scene, as in "
                                             "Mitsuba 3 (the other one: {})", o.source));
        Props p(e);
        EmitterDesc d;
        d.source = e.where();
        if (t == "point" || t == "spot") {
            d.type = t == "point" ? EmitterType::Point : EmitterType::Spot;
            d.value = nonNegColor(p, "intensity", Color(1.f));
            Mat4 m = p.getTransform("to_world");
            if (t == "point" && p.has("position")) {
                if (p.has("to_world")) p.failAt("position", "give either position or to_world");
                d.position = p.getPoint("position", Vec3(0.f));
            } else {
                d.position = transformPoint(m, Vec3(0.f));
            }
            if (t == "spot") {
                d.cutoffAngleDeg = p.getFloat("cutoff_angle", 20.f);
                if (!(d.cutoffAngleDeg > 0.f && d.cutoffAngleDeg <= 90.f))
                    p.failAt("cutoff_angle", fmt::format("must be in (0, 90] degrees (got {})", d.cutoffAngleDeg));
                d.beamWidthDeg = p.getFloat("beam_width", 0.75f * d.cutoffAngleDeg);
                p.requirePositive("beam_width", d.beamWidthDeg);
                if (d.beamWidthDeg > d.cutoffAngleDeg) {
                    warn(e, "beam_width > cutoff_angle: clamped to cutoff_angle");
                    d.beamWidthDeg = d.cutoffAngleDeg;
                }
                Vec3 dir = transformVector(m, Vec3(0, 0, 1));
                if (!(glm::length(dir) > 0.f)) p.failAt("to_world", "the transform maps +Z to zero");
                d.direction = glm::normalize(dir);
            }
        } else if (t == "directional") {
            d.type = EmitterType::Directional;
            d.value = nonNegColor(p, "irradiance", Color(1.f));
            Mat4 m = p.getTransform("to_world");
            Vec3 dir = transformVector(m, Vec3(0, 0, 1));
            if (p.has("direction")) {
                if (p.has("to_world")) p.failAt("direction", "give either direction or to_world");
                dir = p.getPoint("direction", Vec3(0, 0, 1));
            }
            if (!(glm::length(dir) > 0.f)) p.failAt(p.has("direction") ? "direction" : "to_world", "zero direction");
            d.direction = glm::normalize(dir);
        } else if (t == "envmap") {
            // Mitsuba 3's envmap (core/envmap.h): filename, scale, to_world, mis_compensation
            // (its `bitmap` and `data` exist only through its Python/C++ API).
            d.type = EmitterType::Envmap;
            if (!p.has("filename")) xml::fail(e, "parameter 'filename' is required for an envmap emitter");
            const std::string filename = p.getString("filename", "");
            std::string tried;
            d.filename = xml::resolveFile(doc_, e, filename, tried);
            if (d.filename.empty())
                p.failAt("filename", fmt::format("environment map '{}' not found (looked for: {})", filename, tried));
            d.scale = p.getFloat("scale", 1.f);
            if (!(std::isfinite(d.scale) && d.scale >= 0.f))
                p.failAt("scale", fmt::format("must be finite and >= 0 (got {})", d.scale));
            d.toWorld = p.getTransform("to_world");
            if (!isOrthonormal(d.toWorld))
                p.failAt("to_world", "must be a rotation (Mitsuba applies it to unit directions: no scale or shear; "
                                     "a translation is ignored)");
            if (p.getBool("mis_compensation", false))
                warn(e, "mis_compensation is ignored: the map is sampled in proportion to its luminance times "
                        "sin(theta), as with mis_compensation false");
        } else {
            d.type = EmitterType::Constant;
            d.value = nonNegColor(p, "radiance", Color(1.f));
        }
        p.ignore({"sampling_weight"});
        noObjects(p, "textures and nested plugins are not supported");
        p.finish();
        if (d.type == EmitterType::Envmap) {  // (read once the parameters are known to be valid)
            try {
                d.envmap = loadEnvironmentMap(d.filename, d.toWorld, d.scale);
            } catch (const ImageError& ex) {
                p.failAt("filename", ex.what());
            } catch (const EnvmapError& ex) {
                p.failAt("filename", ex.what());
            }
        }
        out_.emitters.push_back(d);
    }

    // ---- shapes ----------------------------------------------------------------------------
    MeshDesc loadMeshFile(Props& p, const std::string& t) {
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
                         : t == "ply" ? readPly(path)
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
        out_.emitters.push_back(areaDesc(*emitter));
        return int(out_.emitters.size()) - 1;
    }

    void shape(const Elem& e) {
        std::string t = e.type();
        if (!isIn(kShapeTypes, t))
            xml::fail(e, fmt::format("unsupported shape type '{}' (supported: {})", t, joinList(kShapeTypes)));
        Props p(e);
        Mat4 M = p.getTransform("to_world");
        bool flip = p.getBool("flip_normals", false);
        bool faceNormals = p.getBool("face_normals", false);
        int bsdf = -1;
        const Elem* emitter = nullptr;
        for (const Elem* o : p.objects) {
            const Elem& target = deref(*o);
            if (target.tag == "bsdf") {
                if (bsdf >= 0) xml::fail(*o, "a shape can have only one bsdf");
                bsdf = bsdfIndex(target);
            } else if (target.tag == "emitter") {
                if (emitter) xml::fail(*o, "a shape can have only one emitter");
                emitter = &target;
                if (&target != o) referencedAreas_.insert(&target);
            } else {
                xml::fail(*o, fmt::format("unsupported element inside <shape> (supported: bsdf, emitter, or a ref to "
                                          "either; this is a <{}>)", target.tag));
            }
        }
        std::string name = e.attr("id") ? *e.attr("id") : t;
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
            sd.flipNormals = flip;
            sd.bsdf = bsdf >= 0 ? bsdf : defaultBsdf();
            sd.emitter = shapeEmitter(emitter);
            out_.spheres.push_back(sd);
            return;
        }
        MeshDesc m = (t == "rectangle") ? makeRectangle()
                     : (t == "cube")    ? makeCube()
                     : (t == "disk")    ? makeDisk(128)
                                        : loadMeshFile(p, t);
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
        m.emitter = shapeEmitter(emitter);
        out_.meshes.push_back(std::move(m));
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
