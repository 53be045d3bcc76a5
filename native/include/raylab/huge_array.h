// HugeArray: the large arrays the BVH's builder and the octree size once and then write.
#pragma once

#include <cstddef>
#include <cstdlib>
#include <memory>
#include <type_traits>

namespace raylab {

// Small sizes from malloc, large ones aligned to 2 MiB pages with MADV_HUGEPAGE (on Linux); throws std::bad_alloc;
// free with std::free.
void* allocate_huge(size_t bytes);

// Large arrays a build writes once (trivial types, left uninitialised), on transparent huge pages
// where the kernel allows it: a build touches every page once, and 4 KiB page faults cost a large
// share of it (docs/bench/history.md).
struct FreeDeleter {
  void operator()(void* p) const { std::free(p); }
};
template <class T>
using HugeArray = std::unique_ptr<T[], FreeDeleter>;
template <class T>
HugeArray<T> make_huge_array(size_t n) {
  static_assert(std::is_trivially_default_constructible_v<T> && std::is_trivially_destructible_v<T>);
  return HugeArray<T>(static_cast<T*>(allocate_huge(n * sizeof(T))));
}

}  // namespace raylab
