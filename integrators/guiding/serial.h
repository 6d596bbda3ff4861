// Bytes of the guiding state for checkpoints (render --checkpoint / --resume): plain values and
// vectors of them copied as they are in memory, so a resumed render continues bit for bit. A
// reader that runs out of bytes throws std::runtime_error.
#pragma once
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace lt::guiding {

struct ByteWriter {
    std::string out;
    template <class T>
    void put(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        out.append(reinterpret_cast<const char*>(&v), sizeof(T));
    }
    template <class T>
    void putVector(const std::vector<T>& v) {
        put(uint64_t(v.size()));
        if (!v.empty()) out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
    }
};

struct ByteReader {
    const char* p;
    const char* end;
    explicit ByteReader(const std::string& s) : p(s.data()), end(s.data() + s.size()) {}
    void need(size_t n) const {
        if (size_t(end - p) < n) throw std::runtime_error("the guiding state is truncated");
    }
    template <class T>
    T get() {
        static_assert(std::is_trivially_copyable_v<T>);
        need(sizeof(T));
        T v;
        std::memcpy(&v, p, sizeof(T));
        p += sizeof(T);
        return v;
    }
    template <class T>
    std::vector<T> getVector() {
        const uint64_t n = get<uint64_t>();
        if (n > uint64_t(end - p) / sizeof(T)) throw std::runtime_error("the guiding state is truncated");
        std::vector<T> v(n);
        if (n) std::memcpy(v.data(), p, n * sizeof(T));
        p += n * sizeof(T);
        return v;
    }
};

}  // namespace lt::guiding
