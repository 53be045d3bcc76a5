#include "raylab/bvh_build.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <cmath>
#include <memory>

namespace raylab {

namespace {

constexpr int kBins = 16;
constexpr uint32_t kTaskThreshold = 4096;           // smaller subtrees stay in the task that reaches them
constexpr uint32_t kParallelScanThreshold = 1u << 16;  // larger nodes scan their primitives in parallel
constexpr uint32_t kScanGrain = 1u << 13;
// Deeper nodes split at the index median, so the depth stays below kMaxSahDepth + log2(n) whatever
// the input (the traversal stacks rely on it).
constexpr int kMaxSahDepth = 48;
constexpr float kTraversalCost = 1.0f;  // one node visit, in units of one primitive test

struct PrimRef {
  glm::vec3 lo;
  uint32_t index;
  glm::vec3 hi;
  uint32_t unused;

  glm::vec3 centroid2() const { return lo + hi; }  // twice the centroid: the factor cancels in binning
};

struct RangeInfo {
  Bounds bounds;
  Bounds centroids;  // of centroid2()

  void merge(const RangeInfo& o) {
    bounds.extend(o.bounds);
    centroids.extend(o.centroids);
  }
};

struct Bin {
  Bounds bounds;
  uint32_t count = 0;
};

struct Bins {
  Bin bin[3][kBins];

  void merge(const Bins& o) {
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i < kBins; ++i) {
        bin[a][i].bounds.extend(o.bin[a][i].bounds);
        bin[a][i].count += o.bin[a][i].count;
      }
  }
};

// Maps centroids to bins along the axes with a usable extent. Binning and partitioning both go
// through bin_of, so a primitive always lands on the side its bin was counted on.
struct Binning {
  glm::vec3 origin;
  glm::vec3 scale;
  bool usable[3];

  explicit Binning(const Bounds& centroids) : origin(centroids.lo) {
    const glm::vec3 extent = centroids.extent();
    for (int a = 0; a < 3; ++a) {
      scale[a] = float(kBins) / extent[a];
      usable[a] = extent[a] > 0.0f && std::isfinite(scale[a]);
    }
  }
  int bin_of(const PrimRef& r, int axis) const {
    const int b = int((r.centroid2()[axis] - origin[axis]) * scale[axis]);
    return std::clamp(b, 0, kBins - 1);
  }
};

// Reduces body(begin, end) over a range, in parallel when it is large. Bounds unions and integer
// counts are exact in any order, so the result does not depend on the split into tasks.
template <class Result, class Body>
Result reduce_range(uint32_t begin, uint32_t end, Body body) {
  if (end - begin < kParallelScanThreshold) return body(begin, end);
  return tbb::parallel_reduce(
      tbb::blocked_range<uint32_t>(begin, end, kScanGrain), Result{},
      [&](const tbb::blocked_range<uint32_t>& r, Result acc) {
        acc.merge(body(r.begin(), r.end()));
        return acc;
      },
      [](Result a, const Result& b) {
        a.merge(b);
        return a;
      });
}

class Builder {
 public:
  Builder(std::vector<PrimRef>& refs, BvhNode* slots, uint32_t max_leaf_size)
      : refs_(refs), slots_(slots), max_leaf_size_(max_leaf_size) {}

  // Builds the subtree over refs_[begin, end) with its root in `slot`. A subtree over n primitives
  // needs at most 2n - 2 descendant slots, which it takes from `first_descendant` on: its children
  // there, then the left child's descendants, then the right child's. Fixed slots make the tree
  // independent of task scheduling.
  void build(uint32_t slot, uint32_t first_descendant, uint32_t begin, uint32_t end, int depth) {
    const RangeInfo info = reduce_range<RangeInfo>(begin, end, [&](uint32_t b, uint32_t e) {
      RangeInfo r;
      for (uint32_t i = b; i < e; ++i) {
        r.bounds.extend(Bounds(refs_[i].lo, refs_[i].hi));
        r.centroids.extend(refs_[i].centroid2());
      }
      return r;
    });
    BvhNode& node = slots_[slot];
    node.lo = info.bounds.lo;
    node.hi = info.bounds.hi;
    const uint32_t mid = split(info, begin, end, depth);
    if (mid == begin) {
      node.index = begin;
      node.count = end - begin;
      return;
    }
    node.index = first_descendant;
    node.count = 0;
    const uint32_t left_count = mid - begin;
    auto left = [&] { build(first_descendant, first_descendant + 2, begin, mid, depth + 1); };
    auto right = [&] { build(first_descendant + 1, first_descendant + 2 * left_count, mid, end, depth + 1); };
    if (end - begin >= kTaskThreshold) {
      tbb::task_group group;
      group.run(left);
      right();
      group.wait();
    } else {
      left();
      right();
    }
  }

 private:
  // Partitions refs_[begin, end) and returns the start of the right part, or `begin` for a leaf.
  uint32_t split(const RangeInfo& info, uint32_t begin, uint32_t end, int depth) {
    const uint32_t n = end - begin;
    const uint32_t median = begin + n / 2;
    if (n == 1) return begin;
    const Binning binning(info.centroids);
    const bool can_bin = binning.usable[0] || binning.usable[1] || binning.usable[2];
    // Identical centroids (e.g. all triangles the same) or a runaway depth: SAH cannot help.
    if (!can_bin || depth >= kMaxSahDepth) return n <= max_leaf_size_ ? begin : median;

    const Bins bins = reduce_range<Bins>(begin, end, [&](uint32_t b, uint32_t e) {
      Bins r;
      for (uint32_t i = b; i < e; ++i)
        for (int a = 0; a < 3; ++a) {
          if (!binning.usable[a]) continue;
          Bin& bin = r.bin[a][binning.bin_of(refs_[i], a)];
          bin.bounds.extend(Bounds(refs_[i].lo, refs_[i].hi));
          ++bin.count;
        }
      return r;
    });

    int best_axis = -1, best_bin = 0;
    float best_cost = kInfinity;
    for (int a = 0; a < 3; ++a) {
      if (!binning.usable[a]) continue;
      float right_area[kBins];
      uint32_t right_count[kBins];
      Bounds acc;
      uint32_t count = 0;
      for (int i = kBins - 1; i > 0; --i) {
        acc.extend(bins.bin[a][i].bounds);
        count += bins.bin[a][i].count;
        right_area[i] = acc.surface_area();
        right_count[i] = count;
      }
      acc = Bounds();
      count = 0;
      for (int i = 1; i < kBins; ++i) {  // split between bins i - 1 and i
        acc.extend(bins.bin[a][i - 1].bounds);
        count += bins.bin[a][i - 1].count;
        if (count == 0 || right_count[i] == 0) continue;
        const float cost = acc.surface_area() * float(count) + right_area[i] * float(right_count[i]);
        if (cost < best_cost) {
          best_cost = cost;
          best_axis = a;
          best_bin = i;
        }
      }
    }
    const float area = info.bounds.surface_area();
    if (n <= max_leaf_size_) {
      const float split_cost = kTraversalCost + best_cost / area;
      if (best_axis < 0 || !(area > 0.0f) || !(split_cost < float(n))) return begin;
    }
    if (best_axis < 0) return median;
    PrimRef* first = refs_.data() + begin;
    PrimRef* last = refs_.data() + end;
    return begin + uint32_t(std::partition(first, last, [&](const PrimRef& r) {
                              return binning.bin_of(r, best_axis) < best_bin;
                            }) - first);
  }

  std::vector<PrimRef>& refs_;
  BvhNode* slots_;
  uint32_t max_leaf_size_;
};

}  // namespace

size_t binary_bvh_build_bytes(size_t n) {
  return n * (sizeof(PrimRef) + 2 * sizeof(BvhNode) + 2 * sizeof(BvhNode) + sizeof(uint32_t));
}

BinaryBvh build_binary_bvh(std::span<const Bounds> prim_bounds, uint32_t max_leaf_size) {
  std::vector<PrimRef> refs;
  refs.reserve(prim_bounds.size());
  for (size_t i = 0; i < prim_bounds.size(); ++i)
    if (!prim_bounds[i].empty()) refs.push_back({prim_bounds[i].lo, uint32_t(i), prim_bounds[i].hi, 0});
  BinaryBvh bvh;
  if (refs.empty()) return bvh;
  const uint32_t n = uint32_t(refs.size());
  // Uninitialised on purpose: only the slots the tree uses are written, and only those are read.
  std::unique_ptr<BvhNode[]> slots(new BvhNode[2 * size_t(n) - 1]);
  Builder(refs, slots.get(), std::max(max_leaf_size, 1u)).build(0, 1, 0, n, 0);

  // Compact the used slots, depth first, keeping siblings adjacent.
  bvh.nodes.push_back(slots[0]);
  std::vector<uint32_t> pending{0};
  while (!pending.empty()) {
    const uint32_t i = pending.back();
    pending.pop_back();
    if (bvh.nodes[i].leaf()) continue;
    const uint32_t children = uint32_t(bvh.nodes.size());
    bvh.nodes.push_back(slots[bvh.nodes[i].index]);
    bvh.nodes.push_back(slots[bvh.nodes[i].index + 1]);
    bvh.nodes[i].index = children;
    pending.push_back(children + 1);
    pending.push_back(children);
  }
  bvh.nodes.shrink_to_fit();
  bvh.prims.resize(n);
  for (uint32_t i = 0; i < n; ++i) bvh.prims[i] = refs[i].index;
  return bvh;
}

}  // namespace raylab
