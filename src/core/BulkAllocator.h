// BulkAllocator.h: storage for the large arrays a render fills once (brick pools, light caches,
// film planes): growing one does not zero it, and big ones sit on transparent huge pages.
//
// Why: these arrays are written in full right after they are sized, often from many threads.
// std::vector<float>::resize zero-fills them first, on one thread, and each fresh 4 KiB page costs
// a kernel fault on that thread (~2 us on the build VM, 3,000-9,000 pages a frame). A 2 MiB
// aligned block advised MADV_HUGEPAGE faults once per 2 MiB (measured: 2.0 -> 0.6 us per 4 KiB
// of touched memory, most of it the kernel's zeroing). Where the kernel has transparent huge
// pages off, the advice is ignored and the memory behaves as usual.
//
// The owner writes every element before reading it: resize(n) leaves new elements
// default-initialised (indeterminate for float); assign(n, v) and resize(n, v) still fill.
#pragma once

#include <sys/mman.h>

#include <cstddef>
#include <cstdint>
#include <new>
#include <utility>
#include <vector>

namespace nimbus {

template <class T>
struct BulkAllocator {
    using value_type = T;
    static constexpr size_t kHugePage = size_t(2) << 20;

    BulkAllocator() = default;
    template <class U>
    BulkAllocator(const BulkAllocator<U>&) noexcept
    {
    }

    T* allocate(size_t n)
    {
        const size_t bytes = n * sizeof(T);
        if (bytes < kHugePage)
            return std::allocator<T>().allocate(n);
        // Over-map by one huge page and trim the ends, so the block starts on a 2 MiB boundary.
        const size_t rounded = roundUp(bytes);
        void* raw = mmap(nullptr, rounded + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (raw == MAP_FAILED)
            throw std::bad_alloc();
        const uintptr_t base = reinterpret_cast<uintptr_t>(raw);
        const uintptr_t aligned = (base + kHugePage - 1) & ~uintptr_t(kHugePage - 1);
        if (aligned > base)
            munmap(raw, aligned - base);
        if (const size_t tail = base + rounded + kHugePage - (aligned + rounded))
            munmap(reinterpret_cast<void*>(aligned + rounded), tail);
        madvise(reinterpret_cast<void*>(aligned), rounded, MADV_HUGEPAGE);
        return reinterpret_cast<T*>(aligned);
    }

    void deallocate(T* p, size_t n) noexcept
    {
        const size_t bytes = n * sizeof(T);
        if (bytes < kHugePage)
            std::allocator<T>().deallocate(p, n);
        else
            munmap(p, roundUp(bytes));
    }

    // Value-less construction default-initialises (no zeroing); anything else as usual.
    template <class U>
    void construct(U* p) noexcept(noexcept(::new (static_cast<void*>(p)) U))
    {
        ::new (static_cast<void*>(p)) U;
    }
    template <class U, class... Args>
    void construct(U* p, Args&&... args)
    {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }

    template <class U>
    bool operator==(const BulkAllocator<U>&) const noexcept
    {
        return true;
    }
    template <class U>
    bool operator!=(const BulkAllocator<U>&) const noexcept
    {
        return false;
    }

private:
    static size_t roundUp(size_t bytes) { return (bytes + kHugePage - 1) & ~(kHugePage - 1); }
};

template <class T>
using BulkVector = std::vector<T, BulkAllocator<T>>;

}  // namespace nimbus
