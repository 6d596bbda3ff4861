// The path tracer and the bidirectional integrators with OPSR (integrators/transport/opsr.h), in a
// unit of their own (see integrators/path_tracer.h).
#include "integrators/bidirectional.h"
#include "integrators/path_tracer.h"

namespace lt {

std::unique_ptr<Integrator> makePathTracer(const RenderSettings& s, const reg::Opsr& reg) {
    return std::make_unique<PathTracer<reg::Opsr>>(s, reg);
}
std::unique_ptr<Integrator> makeBidirectional(const RenderSettings& s, const reg::Opsr& reg) {
    return std::make_unique<Bidirectional<reg::Opsr>>(s, reg);
}

}  // namespace lt
