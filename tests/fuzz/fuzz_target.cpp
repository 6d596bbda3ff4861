// One libFuzzer target per loader: compiled once per target with LT_FUZZ_TARGET set to
// Scene, Obj, Ply or Serialized (tests/fuzz/CMakeLists.txt).
#include "fuzz_loaders.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    lt::fuzz::loadInput(lt::fuzz::Target::LT_FUZZ_TARGET, data, size);
    return 0;
}
