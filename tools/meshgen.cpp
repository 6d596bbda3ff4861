// meshgen: writes a finely tessellated displaced sphere as a binary PLY, for benchmarks on large
// meshes (e.g. 1M+ triangles inside the Cornell box).
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <vector>
#include "tools/cli_checks.h"

int main(int argc, char** argv) {
    CLI::App app{"meshgen: displaced sphere as binary little-endian PLY (triangles = 2 * rings * segments)"};
    std::string out;
    int rings = 708, segments = 708;
    double amplitude = 0.08, frequency = 12;
    app.add_option("output", out, "Output .ply")->required();
    app.add_option("--rings", rings, "Rings (latitude)")->check(lt::cli::range(3, 100000));
    app.add_option("--segments", segments, "Segments (longitude)")->check(lt::cli::range(3, 100000));
    app.add_option("--amplitude", amplitude, "Relative displacement amplitude");
    app.add_option("--frequency", frequency, "Displacement frequency");
    CLI11_PARSE(app, argc, argv);

    std::vector<float> v;
    const double pi = 3.14159265358979323846;
    for (int i = 0; i <= rings; ++i) {
        double th = pi * i / rings;
        for (int j = 0; j <= segments; ++j) {
            double ph = 2 * pi * j / segments;
            double r = 1 + amplitude * std::sin(frequency * th) * std::sin(frequency * ph);
            v.push_back(float(r * std::sin(th) * std::cos(ph)));
            v.push_back(float(r * std::cos(th)));
            v.push_back(float(r * std::sin(th) * std::sin(ph)));
        }
    }
    std::vector<uint32_t> f;
    auto idx = [&](int i, int j) { return uint32_t(i * (segments + 1) + j); };
    for (int i = 0; i < rings; ++i)
        for (int j = 0; j < segments; ++j) {
            uint32_t a = idx(i, j), b = idx(i + 1, j), c = idx(i + 1, j + 1), d = idx(i, j + 1);
            f.insert(f.end(), {a, b, c, a, c, d});  // outward winding
        }
    std::ofstream o(out, std::ios::binary);
    if (!o) {
        fmt::print(stderr, "error: cannot write {}\n", out);
        return 2;
    }
    o << "ply\nformat binary_little_endian 1.0\nelement vertex " << v.size() / 3
      << "\nproperty float x\nproperty float y\nproperty float z\nelement face " << f.size() / 3
      << "\nproperty list uchar uint vertex_indices\nend_header\n";
    o.write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * sizeof(float)));
    for (size_t t = 0; t < f.size(); t += 3) {
        uint8_t n = 3;
        o.write(reinterpret_cast<const char*>(&n), 1);
        o.write(reinterpret_cast<const char*>(&f[t]), 12);
    }
    fmt::print("{}: {} vertices, {} triangles\n", out, v.size() / 3, f.size() / 3);
    return o ? 0 : 2;
}
