#include "raylab/bvh_build.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_group.h>

#include <immintrin.h>
#include <sys/mman.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <memory>

namespace raylab {

namespace {

constexpr int kBins = 16;
constexpr uint32_t kTaskThreshold = 4096;              // smaller subtrees stay in the task that reaches them
constexpr uint32_t kParallelScanThreshold = 1u << 16;  // larger nodes bin their primitives in parallel
constexpr uint32_t kScanGrain = 1u << 13;
// Deeper nodes split at the index median, so the depth stays below kMaxSahDepth + log2(n) whatever
// the input (the traversal stacks rely on it).
constexpr int kMaxSahDepth = 48;
// One node visit, in units of one leaf block test. Measured on bunny_hr, dragon and a 1.3M sphere:
// 2 beats 1 by a few percent (fuller packets, fewer nodes) and higher values change nothing more.
constexpr float kTraversalCost = kSahTraversalCost;

// A box in SSE registers (the w lanes are unused). Binning is the builder's inner loop: one min and
// one max per box instead of six scalar ones.
struct Box {
  __m128 lo = _mm_set1_ps(kInfinity);
  __m128 hi = _mm_set1_ps(-kInfinity);

  void extend(__m128 p_lo, __m128 p_hi) {
    lo = _mm_min_ps(lo, p_lo);
    hi = _mm_max_ps(hi, p_hi);
  }
  void extend(const Box& b) { extend(b.lo, b.hi); }
  Bounds bounds() const {
    alignas(16) float l[4], h[4];
    _mm_store_ps(l, lo);
    _mm_store_ps(h, hi);
    return {{l[0], l[1], l[2]}, {h[0], h[1], h[2]}};
  }
  float area() const { return bounds().surface_area(); }
};

// A primitive's box; the index rides in lo's w lane (cleared before arithmetic: as a float it is a
// denormal, which would slow every operation on it).
struct PrimRef {
  __m128 lo, hi;

  uint32_t index() const { return uint32_t(_mm_extract_epi32(_mm_castps_si128(lo), 3)); }
  // Twice the centroid: the factor cancels in binning.
  __m128 centroid2() const { return _mm_add_ps(_mm_blend_ps(lo, _mm_setzero_ps(), 0x8), hi); }
};

// What a node's build needs to know of its primitives, and what binning hands its children.
struct RangeInfo {
  Box bounds;
  Box centroids;  // of centroid2()

  void extend(const PrimRef& r) {
    bounds.extend(r.lo, r.hi);
    const __m128 c = r.centroid2();
    centroids.extend(c, c);
  }
  void merge(const RangeInfo& o) {
    bounds.extend(o.bounds);
    centroids.extend(o.centroids);
  }
};

struct Bin {
  Box bounds;
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

// Maps centroids to bins along the axes with a usable extent (the others get scale 0: one bin).
// Binning and partitioning both go through bins_of, so a primitive always lands on the side its
// bin was counted on.
struct Binning {
  __m128 origin, scale;
  bool usable[3];

  explicit Binning(const Box& centroids) : origin(centroids.lo) {
    const Bounds c = centroids.bounds();
    alignas(16) float s[4] = {0, 0, 0, 0};
    for (int a = 0; a < 3; ++a) {
      const float extent = c.hi[a] - c.lo[a];
      const float axis_scale = float(kBins) / extent;
      usable[a] = extent > 0.0f && std::isfinite(axis_scale);
      s[a] = usable[a] ? axis_scale : 0.0f;
    }
    scale = _mm_load_ps(s);
  }
  __m128i bins_of(const PrimRef& r) const {
    const __m128i b = _mm_cvttps_epi32(_mm_mul_ps(_mm_sub_ps(r.centroid2(), origin), scale));
    return _mm_min_epi32(_mm_max_epi32(b, _mm_setzero_si128()), _mm_set1_epi32(kBins - 1));
  }
  int bin_of(const PrimRef& r, int axis) const {
    alignas(16) int32_t b[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(b), bins_of(r));
    return b[axis];
  }
};

// Reduces body(begin, end) over a range, in parallel when it is large. Box unions and integer
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
  Builder(HugeArray<PrimRef>& refs, HugeArray<BvhNode>& slots, uint32_t max_leaf_size, uint32_t leaf_block)
      : refs_(refs), slots_(slots), max_leaf_size_(max_leaf_size), leaf_block_(leaf_block) {}

  RangeInfo scan(uint32_t begin, uint32_t end) {
    return reduce_range<RangeInfo>(begin, end, [&](uint32_t b, uint32_t e) {
      RangeInfo r;
      for (uint32_t i = b; i < e; ++i) r.extend(refs_[i]);
      return r;
    });
  }

  // Builds the subtree over refs_[begin, end) (described by `info`) with its root in `slot`. A
  // subtree over n primitives needs at most 2n - 2 descendant slots, which it takes from
  // `first_descendant` on: its children there, then the left child's descendants, then the right
  // child's. Fixed slots make the tree independent of task scheduling.
  void build(uint32_t slot, uint32_t first_descendant, uint32_t begin, uint32_t end, const RangeInfo& info,
             int depth) {
    node_count_.fetch_add(1, std::memory_order_relaxed);
    BvhNode& node = slots_[slot];
    const Bounds box = info.bounds.bounds();
    node.lo = box.lo;
    node.hi = box.hi;
    RangeInfo left_info, right_info;
    const uint32_t mid = split(info, begin, end, depth, left_info, right_info);
    if (mid == begin) {
      node.index = begin;
      node.count = end - begin;
      return;
    }
    node.index = first_descendant;
    node.count = 0;
    const uint32_t left_count = mid - begin;
    auto left = [&] { build(first_descendant, first_descendant + 2, begin, mid, left_info, depth + 1); };
    auto right = [&] {
      build(first_descendant + 1, first_descendant + 2 * left_count, mid, end, right_info, depth + 1);
    };
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

  uint32_t node_count() const { return node_count_.load(); }

 private:
  // Partitions refs_[begin, end) and returns the start of the right part (describing both parts),
  // or `begin` for a leaf.
  uint32_t split(const RangeInfo& info, uint32_t begin, uint32_t end, int depth, RangeInfo& left_info,
                 RangeInfo& right_info) {
    const uint32_t n = end - begin;
    if (n == 1) return begin;
    const Binning binning(info.centroids);
    const bool can_bin = binning.usable[0] || binning.usable[1] || binning.usable[2];
    // Identical centroids (e.g. all triangles the same) or a runaway depth: SAH cannot help.
    if (!can_bin || depth >= kMaxSahDepth) return n <= max_leaf_size_ ? begin : median(begin, end, left_info, right_info);

    const Bins bins = reduce_range<Bins>(begin, end, [&](uint32_t b, uint32_t e) {
      Bins r;
      alignas(16) int32_t index[4];
      for (uint32_t i = b; i < e; ++i) {
        const PrimRef& ref = refs_[i];
        _mm_store_si128(reinterpret_cast<__m128i*>(index), binning.bins_of(ref));
        for (int a = 0; a < 3; ++a) {
          Bin& bin = r.bin[a][index[a]];
          bin.bounds.extend(ref.lo, ref.hi);
          ++bin.count;
        }
      }
      return r;
    });

    int best_axis = -1, best_bin = 0;
    float best_cost = kInfinity;
    for (int a = 0; a < 3; ++a) {
      if (!binning.usable[a]) continue;
      float right_area[kBins];
      uint32_t right_count[kBins];
      Box acc;
      uint32_t count = 0;
      for (int i = kBins - 1; i > 0; --i) {
        acc.extend(bins.bin[a][i].bounds);
        count += bins.bin[a][i].count;
        right_area[i] = acc.area();
        right_count[i] = count;
      }
      acc = Box();
      count = 0;
      for (int i = 1; i < kBins; ++i) {  // split between bins i - 1 and i
        acc.extend(bins.bin[a][i - 1].bounds);
        count += bins.bin[a][i - 1].count;
        if (count == 0 || right_count[i] == 0) continue;
        const float cost = acc.area() * blocks(count) + right_area[i] * blocks(right_count[i]);
        if (cost < best_cost) {
          best_cost = cost;
          best_axis = a;
          best_bin = i;
        }
      }
    }
    const float area = info.bounds.area();
    if (n <= max_leaf_size_) {
      const float split_cost = kTraversalCost + best_cost / area;
      if (best_axis < 0 || !(area > 0.0f) || !(split_cost < blocks(n))) return begin;
    }
    if (best_axis < 0) return median(begin, end, left_info, right_info);
    for (int i = 0; i < kBins; ++i) (i < best_bin ? left_info : right_info).bounds.extend(bins.bin[best_axis][i].bounds);
    return partition(binning, best_axis, best_bin, begin, end, left_info.centroids, right_info.centroids);
  }

  // Hoare partition by bin that also gathers each side's centroid bounds on the way.
  uint32_t partition(const Binning& binning, int axis, int split_bin, uint32_t begin, uint32_t end, Box& left_centroids,
                     Box& right_centroids) {
    uint32_t i = begin, j = end;
    for (;;) {
      while (i < j && binning.bin_of(refs_[i], axis) < split_bin) {
        const __m128 c = refs_[i++].centroid2();
        left_centroids.extend(c, c);
      }
      while (i < j && binning.bin_of(refs_[j - 1], axis) >= split_bin) {
        const __m128 c = refs_[--j].centroid2();
        right_centroids.extend(c, c);
      }
      if (i >= j) return i;
      std::swap(refs_[i], refs_[j - 1]);
    }
  }

  uint32_t median(uint32_t begin, uint32_t end, RangeInfo& left_info, RangeInfo& right_info) {
    const uint32_t mid = begin + (end - begin) / 2;
    left_info = scan(begin, mid);
    right_info = scan(mid, end);
    return mid;
  }

  float blocks(uint32_t n) const { return float((n + leaf_block_ - 1) / leaf_block_); }

  HugeArray<PrimRef>& refs_;
  HugeArray<BvhNode>& slots_;
  uint32_t max_leaf_size_;
  uint32_t leaf_block_;
  std::atomic<uint32_t> node_count_{0};
};

}  // namespace

void* allocate_huge(size_t bytes) {
  constexpr size_t kHugePage = size_t(2) << 20;
  if (bytes < kHugePage) {
    void* p = std::malloc(std::max<size_t>(bytes, 1));
    if (!p) throw std::bad_alloc();
    return p;
  }
  const size_t rounded = (bytes + kHugePage - 1) / kHugePage * kHugePage;
  void* p = std::aligned_alloc(kHugePage, rounded);
  if (!p) throw std::bad_alloc();
  madvise(p, rounded, MADV_HUGEPAGE);  // advice only: failure just means small pages
  return p;
}

size_t binary_bvh_build_bytes(size_t n) {
  // References, the 2n slots, the compacted nodes (at most 2n) and the primitive order.
  return n * (sizeof(PrimRef) + 4 * sizeof(BvhNode) + sizeof(uint32_t));
}

BinaryBvh build_binary_bvh(std::span<const Bounds> prim_bounds, uint32_t max_leaf_size, uint32_t leaf_block) {
  uint32_t n = 0;
  for (const Bounds& b : prim_bounds) n += !b.empty();
  BinaryBvh bvh;
  if (n == 0) return bvh;
  HugeArray<PrimRef> refs = make_huge_array<PrimRef>(n);
  uint32_t next = 0;
  for (size_t i = 0; i < prim_bounds.size(); ++i) {
    const Bounds& b = prim_bounds[i];
    if (b.empty()) continue;
    const __m128 lo = _mm_setr_ps(b.lo.x, b.lo.y, b.lo.z, 0.0f);
    refs[next++] = {_mm_castsi128_ps(_mm_insert_epi32(_mm_castps_si128(lo), int32_t(i), 3)),
                    _mm_setr_ps(b.hi.x, b.hi.y, b.hi.z, 0.0f)};
  }
  // Only the slots the tree uses are written, and only those are read.
  HugeArray<BvhNode> slots = make_huge_array<BvhNode>(2 * size_t(n) - 1);
  Builder builder(refs, slots, std::max(max_leaf_size, 1u), std::max(leaf_block, 1u));
  builder.build(0, 1, 0, n, builder.scan(0, n), 0);

  // Compact the used slots, depth first, keeping siblings adjacent.
  bvh.nodes.reserve(builder.node_count());
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
  bvh.prims.resize(n);
  for (uint32_t i = 0; i < n; ++i) bvh.prims[i] = refs[i].index();
  return bvh;
}

}  // namespace raylab
