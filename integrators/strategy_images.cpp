#include "integrators/strategy_images.h"

#include <algorithm>
#include <filesystem>
#include <fmt/core.h>
#include "core/image.h"

namespace lt {

StrategyImages::StrategyImages(int width, int height, int maxLen) : w_(width), h_(height), maxLen_(maxLen) {
    conn_.resize(size_t(maxLen + 2) * (maxLen + 2));
    merge_.resize(size_t(maxLen + 2));
}

void StrategyImages::add(bool isMerge, int s, int t, uint32_t pixel, const Color& c, bool regularised, bool singular) {
    if (s > maxLen_ + 1 || t > maxLen_ + 1) return;
    auto& img = isMerge ? merge_[s] : conn_[size_t(s) * (maxLen_ + 2) + t];
    std::lock_guard<std::mutex> lock(m_);
    if (img.empty()) img.assign(size_t(w_) * h_, glm::dvec3(0.0));
    img[pixel] += glm::dvec3(c);
    for (auto [on, part] : {std::pair{regularised, &regularised_}, std::pair{singular, &singular_}}) {
        if (!on) continue;
        if (part->empty()) part->assign(size_t(w_) * h_, glm::dvec3(0.0));
        (*part)[pixel] += glm::dvec3(c);
    }
}

void StrategyImages::write(const std::string& dir, uint64_t passes) const {
    std::filesystem::create_directories(dir);
    auto save = [&](const std::vector<glm::dvec3>& img, const std::string& name) {
        if (img.empty()) return;
        Image out(w_, h_);
        for (size_t i = 0; i < img.size(); ++i) out.pixels[i] = Color(img[i] / double(std::max<uint64_t>(passes, 1)));
        writeExr(out, dir + "/" + name);
    };
    for (int s = 0; s <= maxLen_ + 1; ++s) {
        for (int t = 0; t <= maxLen_ + 1; ++t) save(conn_[size_t(s) * (maxLen_ + 2) + t], fmt::format("s{}_t{}.exr", s, t));
        save(merge_[s], fmt::format("merge_s{}.exr", s));
    }
    save(regularised_, "regularised.exr");
    save(singular_, "singular.exr");
}

}  // namespace lt
