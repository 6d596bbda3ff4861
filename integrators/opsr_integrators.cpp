// The path tracer with OPSR (integrators/transport/opsr.h), in a unit of its own (see
// integrators/path_tracer.h). BPT and VCM with OPSR are not built yet (makeIntegrator refuses them).
#include "integrators/path_tracer.h"

namespace lt {

std::unique_ptr<Integrator> makePathTracer(const RenderSettings& s, const reg::Opsr& reg) {
    return std::make_unique<PathTracer<reg::Opsr>>(s, reg);
}

}  // namespace lt
