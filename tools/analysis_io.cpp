// Shared code of the analysis tools, part 2 (see analysis.h): plots through gnuplot, running
// programs, SHA-256 and scene hashing.
#include "tools/analysis.h"

#include <fmt/format.h>
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include "core/loader_xml.h"

namespace fs = std::filesystem;

namespace lt::analysis {

// ---------------------------------------------------------------------------------------------
// Plots

namespace {

const std::array<const char*, 8> kPalette = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e",
                                             "#9467bd", "#8c564b", "#e377c2", "#17becf"};

std::string gpString(const std::string& s) {  // gnuplot single-quoted string
    std::string r = "'";
    for (char c : s) r += c == '\'' ? std::string("''") : std::string(1, c);
    return r + "'";
}

std::string findInPath(const std::string& exe) {
    if (exe.find('/') != std::string::npos) return access(exe.c_str(), X_OK) == 0 ? exe : "";
    const char* path = std::getenv("PATH");
    std::stringstream ss(path ? path : "/usr/bin:/bin");
    std::string dir;
    while (std::getline(ss, dir, ':')) {
        std::string p = (dir.empty() ? "." : dir) + "/" + exe;
        if (access(p.c_str(), X_OK) == 0) return p;
    }
    return "";
}

std::string gnuplotPath() {
    const char* env = std::getenv("LT_GNUPLOT");
    return findInPath(env && *env ? env : "gnuplot");
}

}  // namespace

bool gnuplotAvailable() { return !gnuplotPath().empty(); }

PlotFiles plot(const std::string& base, const std::vector<Panel>& panels, int panelWidth, int height) {
    PlotFiles out{base + ".png", base + ".svg", base + ".gp", base + ".dat", false, ""};
    std::string data, body;
    int block = 0;
    const int n = std::max<int>(1, int(panels.size()));
    body += fmt::format("set multiplot layout 1,{}\n", n);
    for (const Panel& p : panels) {
        body += "reset\nset grid xtics ytics mxtics mytics lc rgb '#dddddd'\n";
        // Many curves: the key goes below the plot, in columns, so it never hides data.
        body += p.curves.size() > 4 ? "set key outside below center box noenhanced samplen 3 maxcols 2\n"
                                    : "set key top right box opaque noenhanced samplen 2\n";
        body += fmt::format("set title {} noenhanced\nset xlabel {} noenhanced\nset ylabel {} noenhanced\n",
                            gpString(p.title), gpString(p.xlabel), gpString(p.ylabel));
        body += "set format x '%g'\nset format y '%.0e'\n";
        if (p.logx) body += "set logscale x\n";
        if (p.logy) body += "set logscale y\n";
        std::vector<std::string> items;
        int next = 0;
        for (const Curve& c : p.curves) {
            std::string rows;
            for (size_t i = 0; i < std::min(c.x.size(), c.y.size()); ++i) {
                double x = c.x[i], y = c.y[i];
                if (!std::isfinite(x) || !std::isfinite(y) || (p.logx && x <= 0) || (p.logy && y <= 0)) continue;
                rows += fmt::format("{:.9g} {:.9g}\n", x, y);
            }
            int col = c.color >= 0 ? c.color : next;
            next = col + 1;
            if (rows.empty()) continue;
            data += fmt::format("# block {}: {}\n{}\n\n", block, c.title, rows);
            std::string style = c.dashed   ? "with lines dt 2 lw 1.5"
                                : c.dotted ? "with lines dt 3 lw 2"
                                           : fmt::format("with linespoints pt {} ps 0.7 lw 1.5", c.pointType);
            items.push_back(fmt::format("{} index {} using 1:2 {} lc rgb '{}' title {}", gpString(out.data), block, style,
                                        kPalette[size_t(col) % kPalette.size()], gpString(c.title)));
            ++block;
        }
        if (items.empty()) {
            body += "unset logscale\nset label 1 'no data' at graph 0.5,0.5 center\nplot [0:1][0:1] NaN notitle\n";
        } else {
            body += "plot ";
            for (size_t i = 0; i < items.size(); ++i) body += (i ? ", \\\n     " : "") + items[i];
            body += "\n";
        }
    }
    body += "unset multiplot\nset output\n";
    int w = panelWidth * n;
    std::string script = "# Written by the lighttransport analysis tools; run: gnuplot " + fs::path(out.script).filename().string() + "\n";
    script += fmt::format("set terminal pngcairo size {},{} noenhanced font 'sans,10'\nset output {}\n{}", w, height,
                          gpString(out.png), body);
    script += fmt::format("set terminal svg size {},{} dynamic noenhanced font 'sans,10' background '#ffffff'\nset output {}\n{}",
                          w, height, gpString(out.svg), body);
    writeTextFile(out.data, data.empty() ? "# no data\n" : data);
    writeTextFile(out.script, script);
    std::string gp = gnuplotPath();
    if (gp.empty()) {
        out.message = "gnuplot not found (install the Debian package gnuplot-nox); wrote " + out.script;
        return out;
    }
    std::error_code ec;
    fs::remove(out.png, ec);
    fs::remove(out.svg, ec);
    std::string log = base + ".gnuplot.log";
    int rc = runProgram({gp, out.script}, log);
    bool files = fs::exists(out.png) && fs::file_size(out.png) > 0 && fs::exists(out.svg) && fs::file_size(out.svg) > 0;
    if (rc != 0 || !files) {
        std::string msg;
        try {
            msg = readFile(log);
        } catch (...) {
        }
        out.message = fmt::format("gnuplot failed (exit {}) on {}: {}", rc, out.script, msg.substr(0, 2000));
        return out;
    }
    fs::remove(log, ec);
    out.ok = true;
    return out;
}

// ---------------------------------------------------------------------------------------------
// SHA-256 (FIPS 180-4)

std::string sha256Hex(const std::string& bytes) {
    static const uint32_t k[64] = {
        0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5, 0xd807aa98,
        0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174, 0xe49b69c1, 0xefbe4786,
        0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da, 0x983e5152, 0xa831c66d, 0xb00327c8,
        0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967, 0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13,
        0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85, 0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819,
        0xd6990624, 0xf40e3585, 0x106aa070, 0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a,
        0x5b9cca4f, 0x682e6ff3, 0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7,
        0xc67178f2};
    uint32_t h[8] = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a, 0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
    std::string m = bytes;
    uint64_t bits = uint64_t(bytes.size()) * 8;
    m += char(0x80);
    while (m.size() % 64 != 56) m += char(0);
    for (int i = 7; i >= 0; --i) m += char((bits >> (8 * i)) & 0xff);
    auto rotr = [](uint32_t x, int n) { return (x >> n) | (x << (32 - n)); };
    for (size_t off = 0; off < m.size(); off += 64) {
        uint32_t w[64];
        for (int i = 0; i < 16; ++i)
            w[i] = uint32_t((unsigned char)m[off + 4 * i]) << 24 | uint32_t((unsigned char)m[off + 4 * i + 1]) << 16 |
                   uint32_t((unsigned char)m[off + 4 * i + 2]) << 8 | uint32_t((unsigned char)m[off + 4 * i + 3]);
        for (int i = 16; i < 64; ++i) {
            uint32_t s0 = rotr(w[i - 15], 7) ^ rotr(w[i - 15], 18) ^ (w[i - 15] >> 3);
            uint32_t s1 = rotr(w[i - 2], 17) ^ rotr(w[i - 2], 19) ^ (w[i - 2] >> 10);
            w[i] = w[i - 16] + s0 + w[i - 7] + s1;
        }
        uint32_t a = h[0], b = h[1], c = h[2], d = h[3], e = h[4], f = h[5], g = h[6], hh = h[7];
        for (int i = 0; i < 64; ++i) {
            uint32_t t1 = hh + (rotr(e, 6) ^ rotr(e, 11) ^ rotr(e, 25)) + ((e & f) ^ (~e & g)) + k[i] + w[i];
            uint32_t t2 = (rotr(a, 2) ^ rotr(a, 13) ^ rotr(a, 22)) + ((a & b) ^ (a & c) ^ (b & c));
            hh = g, g = f, f = e, e = d + t1, d = c, c = b, b = a, a = t1 + t2;
        }
        h[0] += a, h[1] += b, h[2] += c, h[3] += d, h[4] += e, h[5] += f, h[6] += g, h[7] += hh;
    }
    std::string hex;
    for (uint32_t v : h) hex += fmt::format("{:08x}", v);
    return hex;
}

SceneHash hashScene(const std::string& scenePath, const std::map<std::string, std::string>& defines) {
    xml::Document doc = xml::parseDocument(scenePath, defines);
    std::vector<std::string> files;
    auto add = [&](const std::string& f) {
        std::string n = fs::path(f).lexically_normal().string();
        if (std::find(files.begin(), files.end(), n) == files.end()) files.push_back(n);
    };
    add(scenePath);
    for (const auto& s : doc.sources) add(s->path);
    std::vector<const xml::Elem*> stack{doc.root.get()};
    while (!stack.empty()) {
        const xml::Elem* e = stack.back();
        stack.pop_back();
        for (auto it = e->children.rbegin(); it != e->children.rend(); ++it) stack.push_back(it->get());
        if (e->tag != "string") continue;
        const std::string* name = e->attr("name");
        const std::string* value = e->attr("value");
        if (!name || !value || *name != "filename") continue;
        std::string tried, found = xml::resolveFile(doc, *e, *value, tried);
        if (!found.empty()) add(found);
    }
    SceneHash h;
    std::string all;
    for (const auto& [k, v] : defines) all += "define " + k + "=" + v + "\n";
    fs::path dir = fs::absolute(fs::path(scenePath)).parent_path();
    for (const auto& f : files) {
        std::string digest = sha256Hex(readFile(f));
        std::string rel = fs::absolute(f).lexically_normal().lexically_relative(dir.lexically_normal()).string();
        h.files.emplace_back(f, digest);
        all += rel + " " + digest + "\n";
    }
    h.sha256 = sha256Hex(all);
    return h;
}


// ---------------------------------------------------------------------------------------------
// Processes

int runProgram(const std::vector<std::string>& args, const std::string& logPath) {
    if (args.empty()) return 127;
    std::string exe = findInPath(args[0]);
    if (exe.empty()) return 127;
    std::fflush(nullptr);  // keep the order of our output and the child's
    pid_t pid = fork();
    if (pid < 0) return 127;
    if (pid == 0) {
        if (!logPath.empty()) {
            int fd = open(logPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
            if (fd >= 0) {
                dup2(fd, 1);
                dup2(fd, 2);
                close(fd);
            }
        }
        std::vector<char*> argv;
        for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
        argv.push_back(nullptr);
        execv(exe.c_str(), argv.data());
        _exit(127);
    }
    int status = 0;
    if (waitpid(pid, &status, 0) < 0) return 127;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::string executableDir() {
    std::error_code ec;
    fs::path p = fs::read_symlink("/proc/self/exe", ec);
    return ec ? std::string(".") : p.parent_path().string();
}


}  // namespace lt::analysis
