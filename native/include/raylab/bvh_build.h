// The binned SAH builder (Wald 2007), generic over primitive bounds: the mesh BVH builds it over
// triangle boxes and the scene's top level over instance world boxes.
#pragma once

#include "raylab/geometry.h"
#include "raylab/huge_array.h"

#include <cstdint>
#include <cstdlib>
#include <functional>
#include <memory>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>

namespace raylab {

// The SAH's cost of one node visit, in units of one leaf block test: the builder's split decisions
// and sah_cost (refit.h) use it (its measurement: bvh_build.cpp).
inline constexpr float kSahTraversalCost = 2.0f;

// A compact binary node (32 bytes). An inner node's children are nodes[index] and nodes[index + 1];
// a leaf (count > 0) holds prims[index .. index + count).
struct BvhNode {
  glm::vec3 lo;
  uint32_t index;
  glm::vec3 hi;
  uint32_t count;

  bool leaf() const { return count != 0; }
  Bounds bounds() const { return {lo, hi}; }
};
static_assert(sizeof(BvhNode) == 32);

// An allocator for arrays a build sizes once and then writes: on huge pages when large (see
// allocate_huge), elements default-initialised (left as they are) rather than zeroed first: for the
// binary tree's two arrays, half the page faults.
template <class T>
struct BuildAllocator {
  using value_type = T;
  BuildAllocator() = default;
  template <class U>
  BuildAllocator(const BuildAllocator<U>&) {}
  T* allocate(size_t n) { return static_cast<T*>(allocate_huge(n * sizeof(T))); }
  void deallocate(T* p, size_t) { std::free(p); }
  template <class U>
  void construct(U* p) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
  friend bool operator==(const BuildAllocator&, const BuildAllocator&) { return true; }
};
template <class T>
using BuildVector = std::vector<T, BuildAllocator<T>>;

// A binary tree, the Bvh's for a moment (the collapse reads it) and the scene's top level.
struct BinaryBvh {
  BuildVector<BvhNode> nodes;   // nodes[0] is the root; empty when there is no primitive
  BuildVector<uint32_t> prims;  // primitive indices in leaf order, each exactly once
};

// Leaves hold at most `max_leaf_size` primitives; below that the SAH decides whether to split. The
// SAH counts a leaf's cost in blocks of `leaf_block` primitives (4 for leaves tested four at a time
// with SIMD, where 1 and 4 triangles cost the same; a power of two, else std::invalid_argument).
// Primitives with empty bounds are left out (nothing can hit them). The result is the same for any
// number of threads: the tree's top is built in parallel into slots fixed by primitive ranges, each
// smaller subtree whole in one task, and the nodes are then placed by subtree sizes.
BinaryBvh build_binary_bvh(std::span<const Bounds> prim_bounds, uint32_t max_leaf_size, uint32_t leaf_block = 1);

// The same over `count` primitives whose boxes bounds_of(begin, end, out) writes to out[0, end - begin)
// (called in parallel on disjoint ranges of at most 1024): the mesh BVH computes triangle boxes
// straight into the build's references, without an array of them.
using BoundsSource = std::function<void(uint32_t begin, uint32_t end, Bounds* out)>;
BinaryBvh build_binary_bvh(uint32_t count, const BoundsSource& bounds_of, uint32_t max_leaf_size,
                           uint32_t leaf_block = 1);

// The bytes build_binary_bvh needs at most for n primitives, for checking a memory budget first.
size_t binary_bvh_build_bytes(size_t n);

}  // namespace raylab
