// Fuzz entry points for the scene and mesh loaders (issue 17 item 1): see fuzz_loaders.h.
#include "fuzz_loaders.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string_view>

#include <zlib.h>

#include "core/loader.h"
#include "core/mesh_io.h"

namespace lt::fuzz {

namespace fs = std::filesystem;

const char* targetName(Target t) {
    switch (t) {
        case Target::Scene: return "scene";
        case Target::Obj: return "obj";
        case Target::Ply: return "ply";
        case Target::Serialized: return "serialized";
    }
    return "?";
}

std::vector<Target> allTargets() { return {Target::Scene, Target::Obj, Target::Ply, Target::Serialized}; }

std::vector<std::string> pieceNames() {
    return {"scene.xml", "inc.xml", "mesh.obj", "mesh.ply", "mesh.serialized"};
}

namespace {

// One private folder per process (the fuzzer may run several jobs side by side).
const fs::path& workDir() {
    static const fs::path dir = [] {
        const char* base = std::getenv("TMPDIR");
        std::string tmpl = std::string(base && *base ? base : "/tmp") + "/lt-fuzz-XXXXXX";
        if (!mkdtemp(tmpl.data())) {
            std::perror("lt fuzz: mkdtemp");
            std::abort();
        }
        return fs::path(tmpl);
    }();
    return dir;
}

void writeFile(const fs::path& p, std::string_view bytes) {
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), std::streamsize(bytes.size()));
    if (!out) {
        std::perror("lt fuzz: write");
        std::abort();
    }
}

// The serialized target's input: byte 0 = 0 is the file as it is; byte 0 = 1 is followed by the
// version (2 bytes) and the uncompressed body of one shape, which is written compressed, so that
// the fuzzer's mutations reach the mesh parser behind zlib.
std::string serializedFile(std::string_view in) {
    if (in.empty() || in[0] != 1 || in.size() < 3) return std::string(in.empty() ? in : in.substr(1));
    std::string_view body = in.substr(3);
    uLongf n = compressBound(uLong(body.size()));
    std::string out("\x1c\x04", 2);
    out += in.substr(1, 2);
    size_t head = out.size();
    out.resize(head + n);
    if (compress(reinterpret_cast<Bytef*>(out.data() + head), &n, reinterpret_cast<const Bytef*>(body.data()),
                 uLong(body.size())) != Z_OK)
        std::abort();
    out.resize(head + n);
    return out;
}

}  // namespace

std::string inputPath(Target t) {
    switch (t) {
        case Target::Scene: return (workDir() / "scene.xml").string();
        case Target::Obj: return (workDir() / "input.obj").string();
        case Target::Ply: return (workDir() / "input.ply").string();
        case Target::Serialized: return (workDir() / "input.serialized").string();
    }
    return {};
}

bool loadInput(Target t, const uint8_t* data, size_t size, std::string* error) {
    std::string_view all(reinterpret_cast<const char*>(data), size);
    try {
        if (t == Target::Scene) {
            std::vector<std::string> names = pieceNames();
            size_t at = 0;
            for (size_t k = 0; k < names.size(); ++k) {
                fs::path p = workDir() / names[k];
                if (at > all.size()) {  // fewer pieces than names: the rest are missing files
                    std::error_code ec;
                    fs::remove(p, ec);
                    continue;
                }
                size_t end = k + 1 < names.size() ? all.find(kPieceSeparator, at) : std::string_view::npos;
                if (end == std::string_view::npos) end = all.size();
                writeFile(p, all.substr(at, end - at));
                at = end == all.size() ? all.size() + 1 : end + std::string_view(kPieceSeparator).size();
            }
            loadScene(inputPath(t));
            return true;
        }
        std::string path = inputPath(t);
        writeFile(path, t == Target::Serialized ? serializedFile(all) : std::string(all));
        if (t == Target::Obj) validateMesh(readObj(path, true), path);
        else if (t == Target::Ply) validateMesh(readPly(path), path);
        else {
            bool faceNormals = false;
            validateMesh(readSerialized(path, 0, &faceNormals), path);
            validateMesh(readSerialized(path, 1, &faceNormals), path);
        }
        return true;
    } catch (const SceneError& e) {
        if (error) *error = e.what();
    } catch (const MeshError& e) {
        if (error) *error = e.what();
    }
    return false;
}

}  // namespace lt::fuzz
