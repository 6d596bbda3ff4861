// Test helpers shared by the tests that run the project's binaries and write files.
#pragma once
#include <catch2/catch.hpp>
#include <sys/wait.h>
#include <unistd.h>
#include <array>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace lt::test {

struct Run {
    int code = -1;
    std::string output;  // stdout and stderr
};

// Runs a shell command; returns its exit code (128 + signal when killed) and its output.
inline Run sh(const std::string& cmd) {
    Run r;
    FILE* p = popen((cmd + " 2>&1").c_str(), "r");
    REQUIRE(p);
    std::array<char, 4096> buf;
    size_t n;
    while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.output.append(buf.data(), n);
    int status = pclose(p);
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return r;
}

// A file's bytes ("" when it cannot be read).
inline std::string readText(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

// A fresh directory under the system temp dir, unique per process and call, removed at scope end.
struct TempDir {
    std::filesystem::path dir;
    explicit TempDir(const std::string& name = "lt_test") {
        static std::atomic<int> counter{0};
        dir = std::filesystem::temp_directory_path() /
              (name + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
        std::filesystem::remove_all(dir);
        std::filesystem::create_directories(dir);
    }
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(dir, ec);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    std::string file(const std::string& name) const { return (dir / name).string(); }
    // Writes `text` to the file `name` here; returns its path.
    std::string write(const std::string& name, const std::string& text) const {
        const std::string p = file(name);
        std::ofstream(p) << text;
        return p;
    }
};

// A directory for one test's files, kept after the test for inspection (recreated empty).
inline std::filesystem::path tempDir(const std::string& prefix, const std::string& name) {
    std::filesystem::path d =
        std::filesystem::temp_directory_path() / (prefix + "_" + name + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    return d;
}

}  // namespace lt::test
