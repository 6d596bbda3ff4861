#include "integrators/guiding/dump.h"
#include <cmath>
#include <filesystem>
#include <fstream>
#include <unordered_map>
#include <fmt/format.h>
#include "core/image.h"
#include "core/rng.h"

namespace lt::guiding {

namespace {

// A colour per leaf, fixed by its address in the leaf order.
Color leafColour(size_t index) {
    Rng r(index * 0x9e3779b97f4a7c15ull + 1, 7);
    return Color(0.15f + 0.85f * r.uniform(), 0.15f + 0.85f * r.uniform(), 0.15f + 0.85f * r.uniform());
}

// Perceptual-enough ramp for t in [0, 1]: black, blue, red, yellow, white.
Color ramp(float t) {
    t = std::fmin(std::fmax(t, 0.f), 1.f);
    const Color stops[5] = {Color(0.f), Color(0.1f, 0.1f, 0.8f), Color(0.9f, 0.1f, 0.1f), Color(1.f, 0.9f, 0.1f),
                            Color(1.f)};
    const float x = t * 4.f;
    const int i = std::min(int(x), 3);
    return stops[i] + (stops[i + 1] - stops[i]) * (x - float(i));
}

}  // namespace

void dumpGuide(const Scene& scene, const SDTree& tree, const std::string& dir, int grid, int size) {
    std::filesystem::create_directories(dir);
    const Camera& cam = scene.camera();
    const std::vector<SDTree::LeafView> leaves = tree.leaves();
    std::unordered_map<const GuideLeaf*, size_t> index;
    for (size_t i = 0; i < leaves.size(); ++i) index.emplace(leaves[i].leaf, i);
    auto leafIndex = [&](const GuideLeaf* l) { return index.at(l); };
    Image map(cam.width(), cam.height());
    for (int y = 0; y < cam.height(); ++y)
        for (int x = 0; x < cam.width(); ++x) {
            SurfacePoint hit;
            if (scene.intersect(cam.generateRay(Vec2(x + 0.5f, y + 0.5f)), hit))
                map.at(x, y) = leafColour(leafIndex(&tree.leaf(hit.p)));
        }
    writePng(map, dir + "/leaves.png");
    std::ofstream txt(dir + "/points.txt");
    if (!txt) throw std::runtime_error(fmt::format("cannot write '{}'", dir + "/points.txt"));
    txt << "# x y  hit_x hit_y hit_z  leaf_lo(3) leaf_hi(3)  bsdf_fraction  directional_nodes\n";
    constexpr float kUniform = 0.25f / 3.14159265f;
    for (int gy = 0; gy < grid; ++gy)
        for (int gx = 0; gx < grid; ++gx) {
            const int x = int((gx + 0.5f) * cam.width() / grid), y = int((gy + 0.5f) * cam.height() / grid);
            SurfacePoint hit;
            if (!scene.intersect(cam.generateRay(Vec2(x + 0.5f, y + 0.5f)), hit)) continue;
            const GuideLeaf& l = tree.leaf(hit.p);
            const SDTree::LeafView& v = leaves[leafIndex(&l)];
            Image img(size, size);
            for (int j = 0; j < size; ++j)
                for (int i = 0; i < size; ++i) {
                    const Vec3 d = squareToDirection(Vec2((i + 0.5f) / size, (j + 0.5f) / size));
                    const float p = l.sampling.pdf(d).value / kUniform;
                    img.at(i, j) = p > 0.f ? ramp((std::log10(p) + 3.f) / 6.f) : Color(0.f);
                }
            writePng(img, fmt::format("{}/dir_{}_{}.png", dir, x, y));
            txt << fmt::format("{} {}  {} {} {}  {} {} {} {} {} {}  {}  {}\n", x, y, hit.p.x, hit.p.y, hit.p.z, v.lo.x,
                               v.lo.y, v.lo.z, v.hi.x, v.hi.y, v.hi.z, l.bsdfFraction, l.sampling.nodeCount());
        }
    if (!txt) throw std::runtime_error(fmt::format("cannot write '{}'", dir + "/points.txt"));
}

}  // namespace lt::guiding
