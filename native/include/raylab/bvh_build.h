// The BVH's binary builders (bvh_builder.h names them; the binned SAH, Wald 2007, is the default),
// generic over primitive bounds: the mesh BVH builds over triangle boxes and the scene's top level
// over instance world boxes. explain_split shows one node's decision with the builder's own code.
#pragma once

#include "raylab/bvh_builder.h"
#include "raylab/geometry.h"
#include "raylab/huge_array.h"

#include <cstdint>
#include <cstdlib>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace raylab {

// The SAH's cost of one node visit, in units of one leaf block test: the builder's split decisions
// and sah_cost (refit.h) use it (its measurement: bvh_build.cpp).
inline constexpr float kSahTraversalCost = 2.0f;

// Every builder splits nodes deeper than kMaxSahDepth at the index median, so no binary tree over
// fewer than 2^32 triangles is deeper than kMaxBinaryDepth, whatever the input (the traversal stacks
// are sized from it: Bvh::kStackSize).
inline constexpr int kMaxSahDepth = 48;
inline constexpr int kMaxBinaryDepth = kMaxSahDepth + 32;

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
// The other builders split every node of more than `max_leaf_size` primitives and leave the rest leaves.
BinaryBvh build_binary_bvh(std::span<const Bounds> prim_bounds, uint32_t max_leaf_size, uint32_t leaf_block = 1,
                           BvhBuilder builder = BvhBuilder::Sah);

// The same over `count` primitives whose boxes bounds_of(begin, end, out) writes to out[0, end - begin)
// (called in parallel on disjoint ranges of at most 1024): the mesh BVH computes triangle boxes
// straight into the build's references, without an array of them.
using BoundsSource = std::function<void(uint32_t begin, uint32_t end, Bounds* out)>;
BinaryBvh build_binary_bvh(uint32_t count, const BoundsSource& bounds_of, uint32_t max_leaf_size,
                           uint32_t leaf_block = 1, BvhBuilder builder = BvhBuilder::Sah);

// How a builder decided one node: a leaf, or the split it made.
enum class SplitMethod { Leaf, SahBinned, SahSorted, IndexMedian, ObjectMedian, SpatialMedian, Morton };
struct SplitMethodInfo {
  SplitMethod method;
  const char* name;
  const char* description;
};
inline constexpr SplitMethodInfo kSplitMethods[] = {
    {SplitMethod::Leaf, "leaf", "kept as a leaf"},
    {SplitMethod::SahBinned, "sah_binned", "the cheapest of the binned SAH's candidates"},
    {SplitMethod::SahSorted, "sah_sorted", "the cheapest SAH split between the primitives sorted by centroid"},
    {SplitMethod::IndexMedian, "index_median",
     "half of the primitives each side in the order they came: their centroids coincide, or the tree is deep"},
    {SplitMethod::ObjectMedian, "object_median", "half of the primitives each side by centroid"},
    {SplitMethod::SpatialMedian, "spatial_median", "the middle of the centroids' box"},
    {SplitMethod::Morton, "morton", "where the highest bit of the Morton codes changes"},
};
inline const char* split_method_name(SplitMethod m) { return name_in(kSplitMethods, &SplitMethodInfo::method, m); }

// One node's decision (explain_split): the SAH's candidate splits, computed by the SAH builder's own
// binning and sweep (bins for nodes of more than 16 primitives, else every split between the primitives
// sorted by centroid), and the split the chosen builder made. Costs are in the SAH's units (leaf block
// tests): a split costs kSahTraversalCost + (A_L B_L + A_R B_R) / A (A: half surface areas of the
// sides' and the node's boxes, B: leaf blocks), a leaf B(count).
struct SplitCosts {
  uint32_t count = 0;                      // primitives of the node
  Bounds bounds;                           // the node's box
  float leaf_cost = 0.0f;                  // the SAH cost of keeping it a leaf
  bool sorted = false;                     // candidates between sorted primitives rather than bin borders
  std::vector<float> position[3];          // per axis, each candidate's plane (a centroid coordinate)
  std::vector<float> cost[3];              // its cost; infinite where a side is empty
  std::vector<uint32_t> left_count[3];     // primitives left of it
  SplitMethod method = SplitMethod::Leaf;  // the builder's decision
  int axis = -1;                           // its plane's axis and position (-1 and NaN without a plane)
  float position_chosen = 0.0f;
  int candidate = -1;                // for the SAH: the chosen candidate's index in position[axis]
  float cost_chosen = 0.0f;          // the SAH cost of the split made (of the leaf for a leaf)
  std::vector<uint32_t> left_prims;  // the primitives it put left, increasing
};

// Explains the node over `node_prims` (of the `count` primitives bounds_of describes), built by
// `builder` at binary depth `depth` with the build's settings. Reproduces the build's decision: every
// builder's decision depends only on the node's set of primitives (ties broken by primitive index),
// except a node of coincident centroids or beyond the depth limit (index_median), whose halves depend
// on the order the build left them in.
SplitCosts explain_split(uint32_t count, const BoundsSource& bounds_of, std::span<const uint32_t> node_prims, int depth,
                         uint32_t max_leaf_size, uint32_t leaf_block, BvhBuilder builder);

// The bytes build_binary_bvh needs at most for n primitives, for checking a memory budget first.
size_t binary_bvh_build_bytes(size_t n, BvhBuilder builder = BvhBuilder::Sah);

}  // namespace raylab
