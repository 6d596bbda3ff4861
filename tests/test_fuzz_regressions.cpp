// Replays every input kept from fuzzing the loaders (tests/fuzz/regressions/TARGET/*, issue 17
// item 1) without libFuzzer, through the same entry point as the fuzz targets
// (tests/fuzz/fuzz_loaders.h), and then through the render command:
// - the loader refuses it with its own error (SceneError or MeshError) naming the file; any
//   other exception (std::bad_alloc from a declared size, std::length_error, ...) fails here;
// - render on a scene holding it exits with code 2 and names the scene file and line (for a
//   mesh: the line of the <shape> that refers to it) and the mesh file.
// An input named loads_* is a finding whose file is good once the bug is fixed (the undefined
// behaviour was on a line we now leave out): it must load, through the same entry point.
// A crash or a sanitizer report of the fuzz build shows here as a crashed test process (the
// ordinary build has no sanitizers: the fuzz build is where such an input was found).
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "fuzz/fuzz_loaders.h"
#include "process.h"

namespace fs = std::filesystem;
using namespace lt;

namespace {

std::vector<fs::path> inputsOf(fuzz::Target t) {
    std::vector<fs::path> v;
    fs::path dir = fs::path(LT_SOURCE_DIR) / "tests/fuzz/regressions" / fuzz::targetName(t);
    if (fs::is_directory(dir))
        for (const auto& e : fs::directory_iterator(dir))
            if (e.is_regular_file()) v.push_back(e.path());
    std::sort(v.begin(), v.end());
    return v;
}

// A scene whose only shape is the mesh file (line 6 refers to it).
std::string sceneFor(fuzz::Target t, const std::string& meshPath) {
    std::string type = t == fuzz::Target::Obj ? "obj" : t == fuzz::Target::Ply ? "ply" : "serialized";
    return "<scene version=\"3.0.0\">\n"
           "    <sensor type=\"perspective\">\n"
           "        <film type=\"hdrfilm\"><integer name=\"width\" value=\"4\"/><integer name=\"height\" value=\"4\"/></film>\n"
           "    </sensor>\n"
           "    <shape type=\"" + type + "\">\n"
           "        <string name=\"filename\" value=\"" + meshPath + "\"/>\n"
           "    </shape>\n"
           "</scene>\n";
}

}  // namespace

TEST_CASE("Every input kept from fuzzing the loaders is refused with a clear error, exit code 2, file and line", "[fuzz]") {
    int total = 0;
    for (fuzz::Target t : fuzz::allTargets()) {
        for (const fs::path& input : inputsOf(t)) {
            INFO(fuzz::targetName(t) << " input " << input.string());
            ++total;
            std::string bytes = test::readText(input);
            std::string error;
            bool loaded = true;
            REQUIRE_NOTHROW(loaded = fuzz::loadInput(t, reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), &error));
            INFO("loader says: " << error);
            if (input.filename().string().rfind("loads_", 0) == 0) {
                CHECK(loaded);
                continue;
            }
            CHECK_FALSE(loaded);
            // The loader's message names the file it could not read (a scene error may name an
            // included piece instead of scene.xml: the folder is the same).
            fs::path written = fuzz::inputPath(t);
            std::string named = t == fuzz::Target::Scene ? written.parent_path().string() : written.string();
            CHECK(error.find(named) != std::string::npos);

            // The same through render: exit 2, and "file:line:" of the scene (or fragment) in the message.
            test::TempDir tmp("lt_fuzz_regression");
            std::string scene = written.string();
            if (t != fuzz::Target::Scene) {
                scene = tmp.file("scene.xml");
                std::ofstream(scene) << sceneFor(t, written.string());
            }
            test::Run r = test::sh(std::string(LT_RENDER_BIN) + " '" + scene + "' --spp 1 -o '" + tmp.file("out.exr") + "'");
            INFO("render says: " << r.output);
            CHECK(r.code == 2);
            CHECK(std::regex_search(r.output, std::regex("\\.xml:[0-9]+:")));
            if (t != fuzz::Target::Scene) {
                CHECK(r.output.find(scene + ":6:") != std::string::npos);
                CHECK(r.output.find(written.string()) != std::string::npos);
            }
            CHECK_FALSE(fs::exists(tmp.file("out.exr")));
        }
    }
    // Every target has at least one kept input (the hand-made ones of tests/fuzz/README.md).
    CHECK(total >= 4);
}

// The seeds are inputs that load (tests/fuzz/make_seeds.py writes the same kinds): the entry
// point itself must not refuse a good file, or every fuzz finding above would be vacuous.
TEST_CASE("The fuzz entry point loads good scene and mesh files", "[fuzz]") {
    const std::string src = LT_SOURCE_DIR;
    std::string xml = test::readText(src + "/scenes/hard/specular-point-view.xml");  // no includes, no meshes
    std::string error;
    CHECK(fuzz::loadInput(fuzz::Target::Scene, reinterpret_cast<const uint8_t*>(xml.data()), xml.size(), &error));
    INFO(error);
    std::string obj = test::readText(src + "/scenes/hard/meshes/ring.obj");
    CHECK(fuzz::loadInput(fuzz::Target::Obj, reinterpret_cast<const uint8_t*>(obj.data()), obj.size(), &error));
    std::string ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                      "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    CHECK(fuzz::loadInput(fuzz::Target::Ply, reinterpret_cast<const uint8_t*>(ply.data()), ply.size(), &error));
    // A scene of several pieces: the include and the PLY piece resolve beside scene.xml.
    std::string multi = "<scene version=\"3.0.0\"><include filename=\"inc.xml\"/>"
                        "<shape type=\"ply\"><string name=\"filename\" value=\"mesh.ply\"/></shape></scene>"
                        "\n--8<--\n<scene version=\"3.0.0\"><sensor type=\"perspective\"/></scene>"
                        "\n--8<--\n\n--8<--\n" + ply;
    CHECK(fuzz::loadInput(fuzz::Target::Scene, reinterpret_cast<const uint8_t*>(multi.data()), multi.size(), &error));
    // Without the PLY piece the mesh is a missing file: refused.
    std::string cut = multi.substr(0, multi.rfind("\n--8<--\n"));
    CHECK_FALSE(fuzz::loadInput(fuzz::Target::Scene, reinterpret_cast<const uint8_t*>(cut.data()), cut.size(), &error));
    CHECK(error.find("mesh.ply") != std::string::npos);
}
