#include "integrators/strategy_images.h"

#include <algorithm>
#include <filesystem>
#include <stdexcept>
#include <fmt/core.h>
#include "core/image.h"
#include "integrators/distributed/cluster.h"
#include "integrators/guiding/serial.h"

namespace lt {

StrategyImages::StrategyImages(int width, int height, int maxLen) : w_(width), h_(height), maxLen_(maxLen) {
    conn_.resize(size_t(maxLen + 2) * (maxLen + 2));
    merge_.resize(size_t(maxLen + 2));
}

void StrategyImages::add(bool isMerge, int s, int t, uint32_t pixel, const Color& c, bool regularised, bool singular) {
    if (s > maxLen_ + 1 || t > maxLen_ + 1) return;
    if (!ExactColorSum::representable(c)) return;
    auto& img = isMerge ? merge_[s] : conn_[size_t(s) * (maxLen_ + 2) + t];
    std::lock_guard<std::mutex> lock(m_);
    if (img.empty()) img.assign(size_t(w_) * h_, ExactColorSum{});
    img[pixel].add(c);
    for (auto [on, part] : {std::pair{regularised, &regularised_}, std::pair{singular, &singular_}}) {
        if (!on) continue;
        if (part->empty()) part->assign(size_t(w_) * h_, ExactColorSum{});
        (*part)[pixel].add(c);
    }
}

std::vector<StrategyImages::Sums*> StrategyImages::all() {
    std::vector<Sums*> out;
    for (Sums& img : conn_) out.push_back(&img);
    for (Sums& img : merge_) out.push_back(&img);
    out.push_back(&regularised_);
    out.push_back(&singular_);
    return out;
}

std::string StrategyImages::takeState() {
    guiding::ByteWriter w;
    w.put(int32_t(w_));
    w.put(int32_t(h_));
    w.put(int32_t(maxLen_));
    std::lock_guard<std::mutex> lock(m_);
    for (Sums* img : all()) {
        w.putVector(*img);
        img->clear();
    }
    return std::move(w.out);
}

void StrategyImages::addState(const std::string& bytes) {
    guiding::ByteReader r(bytes);
    if (r.get<int32_t>() != w_ || r.get<int32_t>() != h_ || r.get<int32_t>() != maxLen_)
        throw std::runtime_error("strategy images of another image size or depth");
    std::lock_guard<std::mutex> lock(m_);
    for (Sums* img : all()) {
        const Sums in = r.getVector<ExactColorSum>();
        if (in.empty()) continue;
        if (in.size() != size_t(w_) * h_) throw std::runtime_error("the strategy images' sums are damaged");
        if (img->empty()) img->assign(in.size(), ExactColorSum{});
        for (size_t i = 0; i < in.size(); ++i) (*img)[i].add(in[i]);
    }
    if (r.p != r.end) throw std::runtime_error("the strategy images' sums have trailing bytes");
}

void StrategyImages::write(const std::string& dir, uint64_t passes) const {
    std::filesystem::create_directories(dir);
    auto save = [&](const Sums& img, const std::string& name) {
        if (img.empty()) return;
        Image out(w_, h_);
        for (size_t i = 0; i < img.size(); ++i) out.pixels[i] = Color(img[i].value() / double(std::max<uint64_t>(passes, 1)));
        writeExr(out, dir + "/" + name);
    };
    for (int s = 0; s <= maxLen_ + 1; ++s) {
        for (int t = 0; t <= maxLen_ + 1; ++t) save(conn_[size_t(s) * (maxLen_ + 2) + t], fmt::format("s{}_t{}.exr", s, t));
        save(merge_[s], fmt::format("merge_s{}.exr", s));
    }
    save(regularised_, "regularised.exr");
    save(singular_, "singular.exr");
}

void gatherOnRoot(StrategyImages& images, dist::Cluster& cluster) {
    const std::vector<std::string> parts = cluster.gatherBytes(cluster.root() ? std::string() : images.takeState());
    for (size_t r = 1; r < parts.size(); ++r) images.addState(parts[r]);
}

}  // namespace lt
