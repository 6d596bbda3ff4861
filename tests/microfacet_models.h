// The microfacet models the BSDF tests sweep, and their names for messages.
#pragma once
#include "bsdf/bsdf.h"

namespace lt::test {

inline constexpr MicrofacetType kDists[] = {MicrofacetType::GGX, MicrofacetType::Beckmann};
inline constexpr MaskingModel kMasks[] = {MaskingModel::Smith, MaskingModel::VCavity};
inline const char* distName(MicrofacetType t) { return t == MicrofacetType::GGX ? "GGX" : "Beckmann"; }
inline const char* maskName(MaskingModel m) { return m == MaskingModel::Smith ? "Smith" : "VCavity"; }

}  // namespace lt::test
