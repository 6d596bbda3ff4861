// The path tracer and the bidirectional integrators with KD13 (integrators/transport/kd13.h), in a
// unit of their own (see integrators/path_tracer.h).
#include "integrators/bidirectional.h"
#include "integrators/path_tracer.h"

namespace lt {

std::unique_ptr<Integrator> makePathTracer(const RenderSettings& s, const reg::Kd13& reg) {
    return std::make_unique<PathTracer<reg::Kd13>>(s, reg);
}
std::unique_ptr<Integrator> makeBidirectional(const RenderSettings& s, const reg::Kd13& reg) {
    return std::make_unique<Bidirectional<reg::Kd13>>(s, reg);
}

}  // namespace lt
