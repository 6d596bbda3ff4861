// Entry points shared by the libFuzzer targets (tests/fuzz/fuzz_target.cpp, built with
// -DLT_FUZZ=ON) and the regression test that replays every kept input without libFuzzer
// (tests/test_fuzz_regressions.cpp). See tests/fuzz/README.md.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace lt::fuzz {

enum class Target { Scene, Obj, Ply, Serialized };

// "scene", "obj", "ply", "serialized" (the folder names under tests/fuzz/regressions and seeds).
const char* targetName(Target t);
std::vector<Target> allTargets();

// A scene input is several files in one: the pieces between lines "--8<--" are written as
// scene.xml, inc.xml, mesh.obj, mesh.ply, mesh.serialized (in that order), so that includes and
// meshes are fuzzed with the XML that refers to them.
inline constexpr const char* kPieceSeparator = "\n--8<--\n";
std::vector<std::string> pieceNames();

// Writes the input into a private temporary folder (one per process, made on first use) and
// loads it with the loader under test: loadScene for Scene, readObj / readPly / readSerialized
// (shape 0 and 1) followed by validateMesh for the mesh targets.
// Returns true if it loaded, false if the loader refused it with its own error (SceneError or
// MeshError; the message goes to *error). Any other exception propagates: for the fuzzer that
// is a finding, like a crash or a sanitizer report.
bool loadInput(Target t, const uint8_t* data, size_t size, std::string* error = nullptr);

// The path of the file the input of target t is written to (for a scene: scene.xml).
std::string inputPath(Target t);

}  // namespace lt::fuzz
