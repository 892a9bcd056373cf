#pragma once
// std::allocator, except that a vector's resize() (or its size constructor) leaves new elements of
// a trivial type unwritten: a large buffer is then first touched by what fills it, on the threads
// that fill it, instead of being zeroed on one core before being written again. Used for the
// tables' planes (35 MB, formats/table.h) and the OpenCL order solver's input and output (tens of MB
// for a rough finish's batch, rte/cl_solver.cpp).

#include <memory>
#include <new>
#include <utility>

namespace brdf {

template <class T> struct UnwrittenAllocator : std::allocator<T> {
    template <class U> struct rebind { using other = UnwrittenAllocator<U>; };
    UnwrittenAllocator() = default;
    template <class U> UnwrittenAllocator(const UnwrittenAllocator<U>&) noexcept {}
    template <class U, class... Args> void construct(U* p, Args&&... args) {
        if constexpr (sizeof...(Args) == 0)
            ::new (static_cast<void*>(p)) U;
        else
            ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
};

} // namespace brdf
