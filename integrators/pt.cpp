// The path tracer (integrators/path_tracer.h) without a regulariser and with JG19.
#include "integrators/path_tracer.h"

namespace lt {

std::unique_ptr<Integrator> makePathTracer(const RenderSettings& s, const reg::None& reg) {
    return std::make_unique<PathTracer<reg::None>>(s, reg);
}
std::unique_ptr<Integrator> makePathTracer(const RenderSettings& s, const reg::Jg19& reg) {
    return std::make_unique<PathTracer<reg::Jg19>>(s, reg);
}

}  // namespace lt
