#include "raylab/huge_array.h"

#include <algorithm>
#include <new>

#ifndef _WIN32
#include <sys/mman.h>
#endif

namespace raylab {

void* allocate_huge(size_t bytes) {
#ifndef _WIN32
  constexpr size_t kHugePage = size_t(2) << 20;
  if (bytes >= kHugePage) {
    const size_t rounded = (bytes + kHugePage - 1) / kHugePage * kHugePage;
    void* p = std::aligned_alloc(kHugePage, rounded);
    if (!p) throw std::bad_alloc();
    madvise(p, rounded, MADV_HUGEPAGE);  // advice only: failure just means small pages
    return p;
  }
#endif
  // Windows has no transparent huge pages (large pages need a privilege) and no aligned_alloc whose
  // memory std::free releases: every size from malloc there.
  void* p = std::malloc(std::max<size_t>(bytes, 1));
  if (!p) throw std::bad_alloc();
  return p;
}

}  // namespace raylab
