// The bidirectional integrators (integrators/bidirectional.h) without a regulariser and with JG19.
#include "integrators/bidirectional.h"

namespace lt {

std::unique_ptr<Integrator> makeBidirectional(const RenderSettings& s, const reg::None& reg) {
    return std::make_unique<Bidirectional<reg::None>>(s, reg);
}
std::unique_ptr<Integrator> makeBidirectional(const RenderSettings& s, const reg::Jg19& reg) {
    return std::make_unique<Bidirectional<reg::Jg19>>(s, reg);
}

}  // namespace lt
