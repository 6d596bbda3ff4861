// What the guide learned, as images (render --guiding-dump DIR): for a grid of pixels, the
// directional density of the spatial leaf the pixel's first hit falls in, over the equal-area
// square (log scale), and the spatial leaves seen from the camera.
#pragma once
#include <string>
#include "core/scene.h"
#include "integrators/guiding/sd_tree.h"

namespace lt::guiding {

// Writes into `dir` (created if missing):
//   leaves.png        every pixel coloured by the spatial leaf its first hit falls in;
//   dir_X_Y.png       for pixels (X, Y) of a grid x grid lattice over the image: the sampling
//                     density of that leaf over the square (u = (cos theta + 1) / 2 across,
//                     v = phi / 2 pi down), log10 scale from 1e-3 to 1e3 of the uniform 1 / (4 pi);
//   points.txt        one line per dumped pixel: X Y, the hit point, the leaf's bounds, its BSDF
//                     fraction, and its directional nodes.
// Throws std::runtime_error naming a file that cannot be written.
void dumpGuide(const Scene& scene, const SDTree& tree, const std::string& dir, int grid = 4, int size = 128);

}  // namespace lt::guiding
