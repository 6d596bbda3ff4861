// An allocator for the large per-iteration arrays that are read at random (the photon grid, the
// light-path store): it asks Linux for transparent huge pages (madvise), because with 4 KiB pages
// nearly every random access to a 100 MB array also misses the TLB. Small arrays and other
// systems get ordinary memory.
#pragma once
#include <cstddef>
#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <type_traits>
#include <vector>
#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace lt {

template <class T>
struct HugePageAllocator {
    using value_type = T;
    static constexpr size_t kHuge = size_t(2) << 20;  // 2 MiB
    HugePageAllocator() = default;
    template <class U>
    HugePageAllocator(const HugePageAllocator<U>&) noexcept {}
    T* allocate(size_t n) {
        size_t bytes = n * sizeof(T);
        if (bytes < kHuge) {
            void* p = std::malloc(bytes ? bytes : 1);
            if (!p) throw std::bad_alloc();
            return static_cast<T*>(p);
        }
        bytes = (bytes + kHuge - 1) / kHuge * kHuge;
        void* p = std::aligned_alloc(kHuge, bytes);
        if (!p) throw std::bad_alloc();
#if defined(__linux__)
        madvise(p, bytes, MADV_HUGEPAGE);  // a hint: ignored where huge pages are off
#endif
        return static_cast<T*>(p);
    }
    void deallocate(T* p, size_t) noexcept { std::free(p); }
    template <class U>
    bool operator==(const HugePageAllocator<U>&) const noexcept { return true; }
};

template <class T>
using HugeVector = std::vector<T, HugePageAllocator<T>>;

// The same memory for records that are rewritten in full every iteration: resize() never
// initialises and keeps its capacity, so the caller's parallel writes are also the first touch of
// new pages (the kernel zeroes a page at its first touch: through a vector's serial resize or
// growth, that cost the first VCM iteration 0.2 s on one thread at 256x256).
template <class T>
class HugeArray {
    static_assert(std::is_trivially_copyable_v<T> && std::is_trivially_destructible_v<T>);

public:
    // Size n; beyond the capacity the contents are unspecified (those of the previous iteration,
    // or none; reserve first to keep them).
    void resize(size_t n) {
        if (n > capacity_) {
            const size_t cap = n + n / 4;  // headroom: the count varies a little per iteration
            data_.reset(HugePageAllocator<T>().allocate(cap));
            capacity_ = cap;
        }
        size_ = n;
    }
    // Capacity for at least n, the contents kept (for an array that grows by appending).
    void reserve(size_t n) {
        if (n <= capacity_) return;
        const size_t cap = std::max(n + n / 4, 2 * capacity_);
        T* p = HugePageAllocator<T>().allocate(cap);
        if (size_) std::memcpy(static_cast<void*>(p), data_.get(), size_ * sizeof(T));
        data_.reset(p);
        capacity_ = cap;
    }
    size_t size() const { return size_; }
    T* data() { return data_.get(); }
    const T* data() const { return data_.get(); }
    T& operator[](size_t i) { return data_.get()[i]; }
    const T& operator[](size_t i) const { return data_.get()[i]; }

private:
    struct Free {
        void operator()(T* p) const { HugePageAllocator<T>().deallocate(p, 0); }
    };
    std::unique_ptr<T[], Free> data_;
    size_t size_ = 0, capacity_ = 0;
};

}  // namespace lt
