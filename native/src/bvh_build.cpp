#include "raylab/bvh_build.h"

#include <tbb/blocked_range.h>
#include <tbb/concurrent_vector.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_group.h>

#include "raylab/simd.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <memory>
#include <stdexcept>

namespace raylab {

namespace {

// Bins per axis. Embree's 4 + n / 20 (fewer for small nodes) built barely faster for a worse SAH cost
// and more bytes per triangle (docs/bench/history.md).
constexpr int kBins = 16;
// Nodes up to this size sort their primitives instead of binning them (sweep_objects): faster than
// binning them, with fuller leaves; 8 gives binning's tree, 32 is slower (docs/bench/history.md).
constexpr uint32_t kObjectSweepMax = 16;
constexpr uint32_t kTaskThreshold = 4096;              // smaller subtrees stay in the task that reaches them
constexpr uint32_t kParallelScanThreshold = 1u << 16;  // larger nodes bin their primitives in parallel
constexpr uint32_t kScanGrain = 1u << 13;
constexpr ptrdiff_t kPrefetchAhead = 16;  // references (of 32 bytes) ahead of a scan: prefetch_ref
// One node visit, in units of one leaf block test: 2 beats 1 (fuller packets, fewer nodes) and higher
// values change nothing more (docs/bench/history.md).
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
};

// A primitive's box; the index rides in lo's w lane (cleared before arithmetic: as a float it is a
// denormal, which would slow every operation on it).
struct PrimRef {
  __m128 lo, hi;

  uint32_t index() const { return uint32_t(_mm_extract_epi32(_mm_castps_si128(lo), 3)); }
  // Twice the centroid: the factor cancels in binning.
  __m128 centroid2() const { return _mm_add_ps(_mm_blend_ps(lo, _mm_setzero_ps(), 0x8), hi); }
};

// Asks for the reference `ahead` places after r (before it if negative) in the cache: the scans over
// nodes larger than the caches wait on memory otherwise (this machine's hardware prefetch does not
// keep up). A prefetch never faults, so the address may lie outside the array; it is computed as an
// integer, so that it need not be a valid pointer. It pays on meshes whose references pass the cache;
// 16 ahead, 8 and 32 about as good (docs/bench/history.md).
inline void prefetch_ref(const PrimRef* r, ptrdiff_t ahead) {
  _mm_prefetch(reinterpret_cast<const char*>(reinterpret_cast<uintptr_t>(r) + ahead * ptrdiff_t(sizeof(PrimRef))),
               _MM_HINT_T0);
}

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

// Half the surface area of three boxes at once (lane a: box a), for the SAH sweep over the three
// axes. The w lanes are cleared first: a box's lo.w may hold primitive index bits (a denormal).
inline __m128 half_areas(const Box& x, const Box& y, const Box& z) {
  const __m128 zero = _mm_setzero_ps();
  __m128 dx = _mm_sub_ps(_mm_blend_ps(x.hi, zero, 0x8), _mm_blend_ps(x.lo, zero, 0x8));
  __m128 dy = _mm_sub_ps(_mm_blend_ps(y.hi, zero, 0x8), _mm_blend_ps(y.lo, zero, 0x8));
  __m128 dz = _mm_sub_ps(_mm_blend_ps(z.hi, zero, 0x8), _mm_blend_ps(z.lo, zero, 0x8));
  __m128 dw = zero;
  _MM_TRANSPOSE4_PS(dx, dy, dz, dw);  // now dx holds the three boxes' x extents, and so on
  return _mm_add_ps(_mm_mul_ps(dx, _mm_add_ps(dy, dz)), _mm_mul_ps(dy, dz));
}

// The bins of one node along the three axes: bin i of axis a is box[i][a] and lane a of count[i].
struct Bins {
  Box box[kBins][3];
  alignas(16) uint32_t count[kBins][4];

  Bins() {
    for (int i = 0; i < kBins; ++i) {
      box[i][0] = box[i][1] = box[i][2] = Box();
      _mm_store_si128(reinterpret_cast<__m128i*>(count[i]), _mm_setzero_si128());
    }
  }
  void merge(const Bins& o) {
    for (int i = 0; i < kBins; ++i) {
      for (int a = 0; a < 3; ++a) box[i][a].extend(o.box[i][a]);
      _mm_store_si128(reinterpret_cast<__m128i*>(count[i]), _mm_add_epi32(counts(i), o.counts(i)));
    }
  }
  __m128i counts(int i) const { return _mm_load_si128(reinterpret_cast<const __m128i*>(count[i])); }
};

// Maps centroids to bins along the axes with a usable extent (the others get scale 0: one bin).
// Binning (bins_of) and partitioning (below) both map a centroid through raw_bins, so a primitive
// always lands on the side its bin was counted on (the partition relies on the bins' left count).
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
  // The plane between bins i - 1 and i along `axis`, as a centroid coordinate.
  float plane(int axis, int i) const {
    alignas(16) float o[4], s[4];
    _mm_store_ps(o, origin);
    _mm_store_ps(s, scale);
    return 0.5f * (o[axis] + float(i) / s[axis]);
  }
  // Per lane, the bin before clamping to [0, kBins - 1].
  __m128i raw_bins(const PrimRef& r) const {
    return _mm_cvttps_epi32(_mm_mul_ps(_mm_sub_ps(r.centroid2(), origin), scale));
  }
  __m128i bins_of(const PrimRef& r) const {
    return _mm_min_epi32(_mm_max_epi32(raw_bins(r), _mm_setzero_si128()), _mm_set1_epi32(kBins - 1));
  }
  // Per lane, all ones where bins_of(r) < split, for splits in [1, kBins - 1]: without the clamp,
  // which cannot change the comparison there (the partition's test; the clamp cost measurably).
  __m128i below(const PrimRef& r, __m128i split) const { return _mm_cmplt_epi32(raw_bins(r), split); }
};

// Reduces body(begin, end) over a range, starting from `identity`, in parallel when it is large.
// Box unions and integer counts are exact in any order, so the result does not depend on the split
// into tasks.
template <class Result, class Body>
Result reduce_range(uint32_t begin, uint32_t end, const Result& identity, Body body) {
  if (end - begin < kParallelScanThreshold) return body(begin, end);
  return tbb::parallel_reduce(
      tbb::blocked_range<uint32_t>(begin, end, kScanGrain), identity,
      [&](const tbb::blocked_range<uint32_t>& r, Result acc) {
        acc.merge(body(r.begin(), r.end()));
        return acc;
      },
      [](Result a, const Result& b) {
        a.merge(b);
        return a;
      });
}

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// How split() decided a node, for explain_split.
struct Choice {
  SplitMethod method = SplitMethod::Leaf;
  int axis = -1;
  float position = kNaN;  // the plane, a centroid coordinate
  int candidate = -1;     // the SAH's: the index of the chosen split among its candidates
};

// The LBVH's frame: centroids quantised to 10 bits per axis over the root's centroid box (in
// centroid2 units, as PrimRef gives them).
constexpr int kMortonBits = 10;
struct MortonFrame {
  float origin[3] = {0, 0, 0};
  float scale[3] = {0, 0, 0};  // cells per unit; 0 for an axis of no extent

  explicit MortonFrame(const Box& centroids = Box()) {
    const Bounds c = centroids.bounds();
    for (int a = 0; a < 3; ++a) {
      origin[a] = c.lo[a];
      const float s = float(1 << kMortonBits) / (c.hi[a] - c.lo[a]);
      scale[a] = c.hi[a] > c.lo[a] && std::isfinite(s) ? s : 0.0f;
    }
  }
  // x in bits 3k + 2, y in 3k + 1, z in 3k.
  uint32_t code(const PrimRef& r) const {
    alignas(16) float c[4];
    _mm_store_ps(c, r.centroid2());
    uint32_t code = 0;
    for (int a = 0; a < 3; ++a) {
      const float q = std::clamp((c[a] - origin[a]) * scale[a], 0.0f, float((1 << kMortonBits) - 1));
      code |= spread(uint32_t(q)) << (2 - a);
    }
    return code;
  }
  static uint32_t spread(uint32_t v) {  // bit k to bit 3k
    v = (v | (v << 16)) & 0x030000FFu;
    v = (v | (v << 8)) & 0x0300F00Fu;
    v = (v | (v << 4)) & 0x030C30C3u;
    return (v | (v << 2)) & 0x09249249u;
  }
};

// The quantised coordinate along `axis` of a Morton code.
inline uint32_t morton_axis(uint32_t code, int axis) {
  uint32_t v = 0;
  for (int k = 0; k < kMortonBits; ++k) v |= ((code >> (3 * k + 2 - axis)) & 1u) << k;
  return v;
}

// Sorts refs[0, n) by Morton code in `frame`, equal codes by position, and returns the codes in that
// order: the LBVH's one sort, before the tree is built over it.
HugeArray<uint32_t> sort_by_morton(HugeArray<PrimRef>& refs, uint32_t n, const MortonFrame& frame) {
  HugeArray<uint64_t> keys = make_huge_array<uint64_t>(n);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 4096), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t i = r.begin(); i != r.end(); ++i) keys[i] = (uint64_t(frame.code(refs[i])) << 32) | i;
  });
  tbb::parallel_sort(keys.get(), keys.get() + n);
  HugeArray<PrimRef> sorted = make_huge_array<PrimRef>(n);
  HugeArray<uint32_t> codes = make_huge_array<uint32_t>(n);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 4096), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t i = r.begin(); i != r.end(); ++i) {
      sorted[i] = refs[uint32_t(keys[i])];
      codes[i] = uint32_t(keys[i] >> 32);
    }
  });
  refs = std::move(sorted);
  return codes;
}

// A subtree built in one task: its nodes in the order they were made (the root, then each inner
// node's two children as it splits, depth first), an inner node's index counting from the root.
// Only the tree's top (nodes of kTaskThreshold primitives or more) lives in slots fixed by
// primitive ranges; these arrays are mostly untouched, so only the pages written are ever mapped.
using LocalTree = std::vector<BvhNode>;

template <class T>
HugeArray<T> make_sparse_array(size_t n) {
  T* p = static_cast<T*>(std::malloc(std::max<size_t>(n * sizeof(T), 1)));
  if (!p) throw std::bad_alloc();
  return HugeArray<T>(p);
}

class Builder {
 public:
  // `codes` and `morton`: the LBVH's (sort_by_morton), else unused.
  Builder(HugeArray<PrimRef>& refs, uint32_t n, uint32_t max_leaf_size, uint32_t leaf_block, BvhBuilder builder,
          const uint32_t* codes = nullptr, const MortonFrame& morton = MortonFrame())
      : refs_(refs),
        builder_(builder),
        codes_(codes),
        morton_(morton),
        slots_(make_sparse_array<BvhNode>(2 * size_t(n) - 1)),
        left_nodes_(make_sparse_array<uint32_t>(2 * size_t(n) - 1)),
        local_(make_sparse_array<const LocalTree*>(2 * size_t(n) - 1)),
        max_leaf_size_(max_leaf_size),
        leaf_block_(leaf_block),
        leaf_round_(_mm_set1_epi32(int32_t(leaf_block - 1))),
        leaf_shift_(_mm_cvtsi32_si128(std::countr_zero(leaf_block))) {}

  RangeInfo scan(uint32_t begin, uint32_t end) {
    return reduce_range(begin, end, RangeInfo{}, [&](uint32_t b, uint32_t e) {
      RangeInfo r;
      for (uint32_t i = b; i < e; ++i) r.extend(refs_[i]);
      return r;
    });
  }

  // Builds the subtree over refs_[begin, end) (described by `info`) with its root in `slot`. A
  // subtree over n primitives needs at most 2n - 2 descendant slots, which it takes from
  // `first_descendant` on: its children there, then the left child's descendants, then the right
  // child's. Fixed slots make the tree independent of task scheduling. A subtree below
  // kTaskThreshold primitives becomes a LocalTree instead. Returns the subtree's node count.
  uint32_t build(uint32_t slot, uint32_t first_descendant, uint32_t begin, uint32_t end, const RangeInfo& info,
                 int depth) {
    if (end - begin < kTaskThreshold) {
      LocalTree& tree = *locals_.emplace_back();
      tree.reserve(2 * size_t(end - begin) - 1);
      tree.resize(1);
      build_local(tree, 0, begin, end, info, depth);
      local_[slot] = &tree;
      return uint32_t(tree.size());
    }
    local_[slot] = nullptr;
    BvhNode& node = slots_[slot];
    RangeInfo left_info, right_info;
    const uint32_t mid = split_node(node, info, begin, end, depth, left_info, right_info);
    if (mid == begin) return 1;
    node.index = first_descendant;
    const uint32_t left_count = mid - begin;
    uint32_t left_nodes = 0, right_nodes = 0;
    tbb::task_group group;
    group.run([&] { left_nodes = build(first_descendant, first_descendant + 2, begin, mid, left_info, depth + 1); });
    right_nodes = build(first_descendant + 1, first_descendant + 2 * left_count, mid, end, right_info, depth + 1);
    group.wait();
    left_nodes_[slot] = left_nodes;
    return 1 + left_nodes + right_nodes;
  }

  // explain_split over refs_[0, n): the SAH's candidates by the SAH builder's own binning and sweep,
  // then this builder's decision by split() itself.
  SplitCosts explain(uint32_t n, int depth) {
    SplitCosts out;
    const RangeInfo info = scan(0, n);
    out.count = n;
    out.bounds = info.bounds.bounds();
    out.leaf_cost = float(blocks(n));
    const float area = half_area(info.bounds);
    const auto normalised = [&](float raw) { return area > 0.0f ? kTraversalCost + raw / area : kInfinity; };
    const Binning binning(info.centroids);
    if (n > 1 && (binning.usable[0] || binning.usable[1] || binning.usable[2])) {
      Candidates c;
      uint8_t order[3][kObjectSweepMax];
      out.sorted = n <= kObjectSweepMax;
      if (out.sorted) {
        sort_centroids(0, n, order);
        c = sorted_candidates(0, n, order);
      } else {
        c = binned_candidates(bin(binning, 0, n));
      }
      for (int a = 0; a < 3; ++a)
        for (int i = 1; i < c.count; ++i) {
          out.position[a].push_back(out.sorted ? sorted_plane(0, order, a, uint32_t(i)) : binning.plane(a, i));
          out.cost[a].push_back(normalised(lane(c.cost[i], a)));
          out.left_count[a].push_back(lane(c.left[i], a));
        }
    }
    RangeInfo left, right;
    Choice why;
    const uint32_t mid = split(info, 0, n, depth, left, right, &why);
    out.method = mid == 0 ? SplitMethod::Leaf : why.method;
    out.axis = why.axis;
    out.position_chosen = why.position;
    out.candidate = why.candidate < 0 ? -1 : why.candidate - 1;  // candidates start at split 1
    if (mid == 0) {
      out.cost_chosen = out.leaf_cost;
      return out;
    }
    const __m128 areas = half_areas(left.bounds, right.bounds, Box());
    out.cost_chosen = normalised(lane(areas, 0) * float(blocks(mid)) + lane(areas, 1) * float(blocks(n - mid)));
    for (uint32_t i = 0; i < mid; ++i) out.left_prims.push_back(refs_[i].index());
    std::sort(out.left_prims.begin(), out.left_prims.end());
    return out;
  }

  // Copies the subtree in `slot` (of `nodes` nodes) to out[at], its descendants from out[first_free]
  // on, depth first with siblings adjacent (the order of a LocalTree), large subtrees in parallel.
  void compact(uint32_t slot, uint32_t nodes, uint32_t at, uint32_t first_free, BvhNode* out) const {
    if (const LocalTree* tree = local_[slot]) {
      const auto placed = [first_free](BvhNode node) {
        if (!node.leaf()) node.index += first_free - 1;
        return node;
      };
      out[at] = placed((*tree)[0]);
      for (size_t k = 1; k < tree->size(); ++k) out[first_free + k - 1] = placed((*tree)[k]);
      return;
    }
    BvhNode node = slots_[slot];
    if (!node.leaf()) {
      const uint32_t child = node.index, left = left_nodes_[slot], right = nodes - 1 - left;
      node.index = first_free;
      tbb::task_group group;
      group.run([&] { compact(child, left, first_free, first_free + 2, out); });
      compact(child + 1, right, first_free + 1, first_free + 2 + (left - 1), out);
      group.wait();
    }
    out[at] = node;
  }

 private:
  // Builds the subtree over refs_[begin, end) into tree[at], in this task.
  void build_local(LocalTree& tree, uint32_t at, uint32_t begin, uint32_t end, const RangeInfo& info, int depth) {
    BvhNode node;
    RangeInfo left_info, right_info;
    const uint32_t mid = split_node(node, info, begin, end, depth, left_info, right_info);
    if (mid == begin) {
      tree[at] = node;
      return;
    }
    node.index = uint32_t(tree.size());
    tree[at] = node;
    tree.resize(tree.size() + 2);
    build_local(tree, node.index, begin, mid, left_info, depth + 1);
    build_local(tree, node.index + 1, mid, end, right_info, depth + 1);
  }

  // `node` over refs_[begin, end): its box, and either a leaf of them all (returns `begin`) or an inner
  // node (count 0, index left to the caller) whose parts split() describes (returns the right part's start).
  uint32_t split_node(BvhNode& node, const RangeInfo& info, uint32_t begin, uint32_t end, int depth,
                      RangeInfo& left_info, RangeInfo& right_info) {
    const Bounds box = info.bounds.bounds();
    node.lo = box.lo;
    node.hi = box.hi;
    const uint32_t mid = split(info, begin, end, depth, left_info, right_info);
    node.index = begin;
    node.count = mid == begin ? end - begin : 0;
    return mid;
  }

  // Partitions refs_[begin, end) and returns the start of the right part (describing both parts),
  // or `begin` for a leaf; `why`, when given, learns how (explain_split).
  uint32_t split(const RangeInfo& info, uint32_t begin, uint32_t end, int depth, RangeInfo& left_info,
                 RangeInfo& right_info, Choice* why = nullptr) {
    const uint32_t n = end - begin;
    if (n == 1) return begin;
    const Binning binning(info.centroids);
    const bool can_bin = binning.usable[0] || binning.usable[1] || binning.usable[2];
    // Identical centroids (e.g. all triangles the same) or a runaway depth: SAH cannot help.
    if (!can_bin || depth >= kMaxSahDepth) {
      if (n <= max_leaf_size_) return begin;
      note(why, SplitMethod::IndexMedian);
      return median(begin, end, left_info, right_info);
    }
    // The other builders split every node of more than max_leaf_size_ (the SAH weighs a leaf's cost).
    if (builder_ != BvhBuilder::Sah && n <= max_leaf_size_) return begin;
// Every builder is a case and there is no default: a builder missing here is a compile error, never
// a silent fallback to another builder's tree.
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic error "-Wswitch"
#endif
    switch (builder_) {
      case BvhBuilder::Sah: return sah_split(info, binning, begin, end, left_info, right_info, why);
      case BvhBuilder::Median: return object_median(info, begin, end, left_info, right_info, why);
      case BvhBuilder::SpatialMedian: return spatial_median(info, begin, end, left_info, right_info, why);
      case BvhBuilder::Lbvh: return morton_split(begin, end, left_info, right_info, why);
    }
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif
    throw std::logic_error("BVH builder " + std::to_string(int(builder_)) + " has no split");
  }

  // The binned SAH's split (every split, swept by centroid, for nodes of kObjectSweepMax or fewer).
  uint32_t sah_split(const RangeInfo& info, const Binning& binning, uint32_t begin, uint32_t end, RangeInfo& left_info,
                     RangeInfo& right_info, Choice* why) {
    const uint32_t n = end - begin;
    if (n <= kObjectSweepMax) return sweep_objects(info, begin, end, left_info, right_info, why);

    const Bins bins = bin(binning, begin, end);
    const Candidates candidates = binned_candidates(bins);
    const auto [best_axis, best_bin] = cheapest(candidates, binning.usable);
    const float cost = best_axis < 0 ? kInfinity : lane(candidates.cost[best_bin], best_axis);
    if (n <= max_leaf_size_ && !worth_splitting(info, n, cost)) return begin;
    if (best_axis < 0) {
      note(why, SplitMethod::IndexMedian);
      return median(begin, end, left_info, right_info);
    }
    note(why, SplitMethod::SahBinned, best_axis, binning.plane(best_axis, best_bin), best_bin);
    uint32_t left_count = 0;
    for (int i = 0; i < kBins; ++i) {
      (i < best_bin ? left_info : right_info).bounds.extend(bins.box[i][best_axis]);
      if (i < best_bin) left_count += bins.count[i][best_axis];
    }
    return partition(binning, best_axis, best_bin, begin, end, left_count, left_info.centroids, right_info.centroids);
  }

  // The SAH's candidates, the three axes at once (lane a: axis a). cost[i] is the split before
  // position i (bins [0, i), or the first i primitives sorted by centroid, on the left), as the builder
  // compares them: half areas times leaf blocks, not normalised by the node's area; infinite where a
  // side is empty. left[i] counts the primitives left of it. Valid for i in [1, count).
  static constexpr int kMaxCandidates = std::max<int>(kBins, kObjectSweepMax);
  struct Candidates {
    int count = 0;
    __m128 cost[kMaxCandidates];
    __m128i left[kMaxCandidates];
  };

  // The binning pass over refs_[begin, end): each primitive's box and count in its bin on each axis.
  Bins bin(const Binning& binning, uint32_t begin, uint32_t end) const {
    return reduce_range(begin, end, Bins(), [&](uint32_t b, uint32_t e) {
      Bins r;
      alignas(16) int32_t index[4];
      const PrimRef* const refs = refs_.get();
      for (uint32_t i = b; i < e; ++i) {
        prefetch_ref(refs + i, kPrefetchAhead);
        const PrimRef& ref = refs[i];
        _mm_store_si128(reinterpret_cast<__m128i*>(index), binning.bins_of(ref));
        for (int a = 0; a < 3; ++a) {
          r.box[index[a]][a].extend(ref.lo, ref.hi);
          ++r.count[index[a]][a];
        }
      }
      return r;
    });
  }

  // The sweep over the bins' borders, the three axes at once: a fraction of a scalar sweep's cost (a third
  // of the build on small nodes).
  Candidates binned_candidates(const Bins& bins) const {
    Candidates c;
    c.count = kBins;
    __m128 right_area[kBins], right_blocks[kBins];
    __m128i right_count[kBins];
    {
      Box x, y, z;
      __m128i count = _mm_setzero_si128();
      for (int i = kBins - 1; i > 0; --i) {
        x.extend(bins.box[i][0]);
        y.extend(bins.box[i][1]);
        z.extend(bins.box[i][2]);
        count = _mm_add_epi32(count, bins.counts(i));
        right_area[i] = half_areas(x, y, z);
        right_count[i] = count;
        right_blocks[i] = blocks(count);
      }
    }
    Box x, y, z;
    __m128i count = _mm_setzero_si128();
    const __m128i zero = _mm_setzero_si128();
    const __m128 inf = _mm_set1_ps(kInfinity);
    for (int i = 1; i < kBins; ++i) {
      x.extend(bins.box[i - 1][0]);
      y.extend(bins.box[i - 1][1]);
      z.extend(bins.box[i - 1][2]);
      count = _mm_add_epi32(count, bins.counts(i - 1));
      const __m128 cost =
          _mm_add_ps(_mm_mul_ps(half_areas(x, y, z), blocks(count)), _mm_mul_ps(right_area[i], right_blocks[i]));
      // An empty side would make inf * 0: no split.
      const __m128i empty = _mm_or_si128(_mm_cmpeq_epi32(count, zero), _mm_cmpeq_epi32(right_count[i], zero));
      c.cost[i] = _mm_blendv_ps(cost, inf, _mm_castsi128_ps(empty));
      c.left[i] = count;
    }
    return c;
  }

  // The sweep over the n <= kObjectSweepMax primitives of refs_[begin, ...) in sort_centroids' order.
  Candidates sorted_candidates(uint32_t begin, uint32_t n, const uint8_t (&order)[3][kObjectSweepMax]) const {
    Candidates c;
    c.count = int(n);
    auto ref = [&](int a, uint32_t i) -> const PrimRef& { return refs_[begin + order[a][i]]; };
    __m128 right_cost[kObjectSweepMax];  // area times blocks of the right side of split i
    {
      Box x, y, z;
      for (uint32_t i = n - 1; i > 0; --i) {
        x.extend(ref(0, i).lo, ref(0, i).hi);
        y.extend(ref(1, i).lo, ref(1, i).hi);
        z.extend(ref(2, i).lo, ref(2, i).hi);
        right_cost[i] = _mm_mul_ps(half_areas(x, y, z), _mm_set1_ps(float(blocks(n - i))));
      }
    }
    Box x, y, z;
    for (uint32_t i = 1; i < n; ++i) {
      x.extend(ref(0, i - 1).lo, ref(0, i - 1).hi);
      y.extend(ref(1, i - 1).lo, ref(1, i - 1).hi);
      z.extend(ref(2, i - 1).lo, ref(2, i - 1).hi);
      c.cost[i] = _mm_add_ps(_mm_mul_ps(half_areas(x, y, z), _mm_set1_ps(float(blocks(i)))), right_cost[i]);
      c.left[i] = _mm_set1_epi32(int32_t(i));
    }
    return c;
  }

  // The cheapest candidate as (axis, index), or axis -1 when none is finite: on each axis the lowest
  // split wins ties, then the lowest of the `usable` axes.
  static std::pair<int, int> cheapest(const Candidates& c, const bool (&usable)[3]) {
    __m128 best_cost = _mm_set1_ps(kInfinity);
    __m128i best_split = _mm_setzero_si128();
    for (int i = 1; i < c.count; ++i) {
      const __m128 better = _mm_cmplt_ps(c.cost[i], best_cost);
      best_cost = _mm_blendv_ps(best_cost, c.cost[i], better);
      best_split = _mm_blendv_epi8(best_split, _mm_set1_epi32(i), _mm_castps_si128(better));
    }
    alignas(16) float axis_cost[4];
    alignas(16) int32_t axis_split[4];
    _mm_store_ps(axis_cost, best_cost);
    _mm_store_si128(reinterpret_cast<__m128i*>(axis_split), best_split);
    int best_axis = -1;
    for (int a = 0; a < 3; ++a)
      if (usable[a] && axis_cost[a] < (best_axis < 0 ? kInfinity : axis_cost[best_axis])) best_axis = a;
    return {best_axis, best_axis < 0 ? 0 : axis_split[best_axis]};
  }

  static float lane(__m128 v, int a) {
    alignas(16) float x[4];
    _mm_store_ps(x, v);
    return x[a];
  }
  static uint32_t lane(__m128i v, int a) {
    alignas(16) uint32_t x[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(x), v);
    return x[a];
  }

  static void note(Choice* why, SplitMethod method, int axis = -1, float position = kNaN, int candidate = -1) {
    if (why) *why = {method, axis, position, candidate};
  }

  // Moves the primitives of refs_[begin, end) in bins below split_bin (left_count of them, as the
  // bins counted) before the others and returns where the others start, gathering each side's
  // centroid bounds on the way. The order is a Hoare partition's: the k-th primitive bound right
  // from the left part swaps with the k-th bound left from the right part (counting from the ends
  // inwards). Here the scans find them a block at a time without a branch per primitive, a faster build
  // on every mesh measured (docs/bench/history.md).
  uint32_t partition(const Binning& binning, int axis, int split_bin, uint32_t begin, uint32_t end, uint32_t left_count,
                     Box& left_centroids, Box& right_centroids) {
    constexpr uint32_t kBlock = 64;
    PrimRef* const refs = refs_.get();
    const uint32_t mid = begin + left_count;
    const __m128i split = _mm_set1_epi32(split_bin);
    const __m128i broadcast = _mm_set1_epi32(0x03020100 + 0x04040404 * axis);  // lane `axis` to every lane
    const __m128 inf = _mm_set1_ps(kInfinity), neg_inf = _mm_set1_ps(-kInfinity);
    Box left, right;  // in registers: through the references each update waited for the last one's store
    // 1 if r goes left, else 0; its centroid joins its side's bounds.
    const auto goes_left = [&](const PrimRef& r) {
      const __m128 c = r.centroid2();
      const __m128 is_left = _mm_castsi128_ps(_mm_shuffle_epi8(binning.below(r, split), broadcast));
      left.lo = _mm_min_ps(left.lo, _mm_blendv_ps(inf, c, is_left));
      left.hi = _mm_max_ps(left.hi, _mm_blendv_ps(neg_inf, c, is_left));
      right.lo = _mm_min_ps(right.lo, _mm_blendv_ps(c, inf, is_left));
      right.hi = _mm_max_ps(right.hi, _mm_blendv_ps(c, neg_inf, is_left));
      return uint32_t(_mm_movemask_ps(is_left) & 1);
    };
    uint32_t up = begin, down = end;  // the next to scan in the left part (upwards), in the right part (below it)
    uint32_t misplaced_left[kBlock], misplaced_right[kBlock];  // positions found, from [first, count) not yet swapped
    uint32_t first_left = 0, count_left = 0, first_right = 0, count_right = 0;
    while (up < mid || down > mid) {
      bool scanned = false;
      if (first_left == count_left && up < mid) {
        first_left = count_left = 0;
        for (const uint32_t stop = std::min(mid, up + kBlock); up < stop; ++up) {
          prefetch_ref(refs + up, kPrefetchAhead);
          misplaced_left[count_left] = up;
          count_left += 1 - goes_left(refs[up]);
        }
        scanned = true;
      }
      if (first_right == count_right && down > mid) {
        first_right = count_right = 0;
        for (const uint32_t stop = down - std::min(kBlock, down - mid); down > stop;) {
          prefetch_ref(refs + down, -kPrefetchAhead);
          misplaced_right[count_right] = --down;
          count_right += goes_left(refs[down]);
        }
        scanned = true;
      }
      const uint32_t swaps = std::min(count_left - first_left, count_right - first_right);
      for (uint32_t k = 0; k < swaps; ++k)
        std::swap(refs[misplaced_left[first_left + k]], refs[misplaced_right[first_right + k]]);
      first_left += swaps;
      first_right += swaps;
      if (!scanned && swaps == 0) break;  // unreachable while left_count is the bins' count
    }
    left_centroids = left;
    right_centroids = right;
    return mid;
  }

  // Whether splitting a node that may be a leaf beats the leaf, by the SAH.
  bool worth_splitting(const RangeInfo& info, uint32_t n, float best_cost) const {
    const float area = half_area(info.bounds);
    return area > 0.0f && kTraversalCost + best_cost / area < float(blocks(n));
  }

  // order[a] lists refs_[begin, begin + n) (n <= kObjectSweepMax) by centroid along axis a, equal
  // keys by primitive index (so that the order depends on the node's primitives, not on where earlier
  // partitions left them: explain_split repeats it). Each primitive's place is its rank, counted for the
  // three axes at once without a branch. The insertion sort it replaces (the same order) lost much of
  // the build to mispredicted compares (docs/bench/history.md).
  void sort_centroids(uint32_t begin, uint32_t n, uint8_t (&order)[3][kObjectSweepMax]) const {
    // Keys as integers ordered as the floats are (+0 for -0, so that the two stay equal): a total
    // order, so that even NaN keys give a permutation.
    __m128i key[kObjectSweepMax], rank[kObjectSweepMax];
    for (uint32_t i = 0; i < n; ++i) {
      const __m128i bits = _mm_castps_si128(_mm_add_ps(refs_[begin + i].centroid2(), _mm_setzero_ps()));
      key[i] = _mm_xor_si128(bits, _mm_and_si128(_mm_srai_epi32(bits, 31), _mm_set1_epi32(0x7fffffff)));
      rank[i] = _mm_setzero_si128();
    }
    uint32_t index[kObjectSweepMax];
    for (uint32_t i = 0; i < n; ++i) index[i] = refs_[begin + i].index();
    // A pair i < j: i goes after j if key i > key j, or the keys are equal and index i > index j;
    // else j goes after i.
    const __m128i one = _mm_set1_epi32(1);
    for (uint32_t i = 0; i < n; ++i)
      for (uint32_t j = i + 1; j < n; ++j) {
        const __m128i later = _mm_set1_epi32(-int32_t(index[i] > index[j]));
        const __m128i after = _mm_or_si128(_mm_cmpgt_epi32(key[i], key[j]),
                                           _mm_and_si128(_mm_cmpeq_epi32(key[i], key[j]), later));  // -1: i after j
        rank[i] = _mm_sub_epi32(rank[i], after);
        rank[j] = _mm_add_epi32(rank[j], _mm_add_epi32(one, after));
      }
    for (uint32_t i = 0; i < n; ++i) {
      alignas(16) int32_t r[4];
      _mm_store_si128(reinterpret_cast<__m128i*>(r), rank[i]);
      for (int a = 0; a < 3; ++a) order[a][r[a]] = uint8_t(i);
    }
  }

  // The SAH over every split of the primitives sorted by centroid along each axis (ties by primitive
  // index): for small nodes this costs no more than binning, and it considers every split binning could.
  uint32_t sweep_objects(const RangeInfo& info, uint32_t begin, uint32_t end, RangeInfo& left_info,
                         RangeInfo& right_info, Choice* why) {
    const uint32_t n = end - begin;
    uint8_t order[3][kObjectSweepMax];
    sort_centroids(begin, n, order);
    const Candidates candidates = sorted_candidates(begin, n, order);
    static constexpr bool kAllAxes[3] = {true, true, true};
    auto [best_axis, split] = cheapest(candidates, kAllAxes);
    const float cost = best_axis < 0 ? kInfinity : lane(candidates.cost[split], best_axis);
    if (n <= max_leaf_size_ && !worth_splitting(info, n, cost)) return begin;
    // An infinite cost (overflowing areas) still splits somewhere: at the middle of the order.
    if (best_axis < 0) {
      best_axis = 0;
      split = int(n / 2);
    }
    note(why, SplitMethod::SahSorted, best_axis, sorted_plane(begin, order, best_axis, uint32_t(split)), split);
    PrimRef sorted[kObjectSweepMax];
    for (uint32_t i = 0; i < n; ++i) sorted[i] = refs_[begin + order[best_axis][i]];
    for (uint32_t i = 0; i < n; ++i) {
      refs_[begin + i] = sorted[i];
      (i < uint32_t(split) ? left_info : right_info).extend(sorted[i]);
    }
    return begin + uint32_t(split);
  }

  // The plane between the sorted primitives split - 1 and split: halfway between their centroids.
  float sorted_plane(uint32_t begin, const uint8_t (&order)[3][kObjectSweepMax], int axis, uint32_t split) const {
    return 0.25f * (lane(refs_[begin + order[axis][split - 1]].centroid2(), axis) +
                    lane(refs_[begin + order[axis][split]].centroid2(), axis));
  }

  uint32_t median(uint32_t begin, uint32_t end, RangeInfo& left_info, RangeInfo& right_info) {
    const uint32_t mid = begin + (end - begin) / 2;
    left_info = scan(begin, mid);
    right_info = scan(mid, end);
    return mid;
  }

  // The median builder: the lower half by centroid along the centroids' longest axis (ties by
  // primitive index) on the left.
  uint32_t object_median(const RangeInfo& info, uint32_t begin, uint32_t end, RangeInfo& left_info,
                         RangeInfo& right_info, Choice* why) {
    const int axis = info.centroids.bounds().longest_axis();
    const uint32_t mid = begin + (end - begin) / 2;
    PrimRef* const refs = refs_.get();
    std::nth_element(refs + begin, refs + mid, refs + end, [axis](const PrimRef& a, const PrimRef& b) {
      const float ka = lane(a.centroid2(), axis), kb = lane(b.centroid2(), axis);
      return ka < kb || (ka == kb && a.index() < b.index());
    });
    note(why, SplitMethod::ObjectMedian, axis, 0.5f * lane(refs[mid].centroid2(), axis));
    return median(begin, end, left_info, right_info);
  }

  // The spatial median builder: the centroids below the middle of their box's longest axis on the
  // left; where rounding leaves a side empty, the object median.
  uint32_t spatial_median(const RangeInfo& info, uint32_t begin, uint32_t end, RangeInfo& left_info,
                          RangeInfo& right_info, Choice* why) {
    const Bounds c = info.centroids.bounds();
    const int axis = c.longest_axis();
    const float middle = c.lo[axis] + 0.5f * (c.hi[axis] - c.lo[axis]);  // in centroid2 units
    PrimRef* const refs = refs_.get();
    const uint32_t mid = uint32_t(
        std::partition(refs + begin, refs + end, [&](const PrimRef& r) { return lane(r.centroid2(), axis) < middle; }) -
        refs);
    if (mid == begin || mid == end) return object_median(info, begin, end, left_info, right_info, why);
    note(why, SplitMethod::SpatialMedian, axis, 0.5f * middle);
    left_info = scan(begin, mid);
    right_info = scan(mid, end);
    return mid;
  }

  // The LBVH: refs_ sorted by Morton code (codes_), split where the highest bit that differs in the
  // range changes; a range of equal codes at its middle.
  uint32_t morton_split(uint32_t begin, uint32_t end, RangeInfo& left_info, RangeInfo& right_info, Choice* why) {
    const uint32_t* const codes = codes_;
    if (codes[begin] == codes[end - 1]) {
      note(why, SplitMethod::Morton);
      return median(begin, end, left_info, right_info);
    }
    const int bit = 31 - std::countl_zero(codes[begin] ^ codes[end - 1]);
    const uint32_t mid = uint32_t(
        std::partition_point(codes + begin, codes + end, [bit](uint32_t c) { return !((c >> bit) & 1); }) - codes);
    const int axis = 2 - bit % 3;
    const uint32_t level = uint32_t(bit / 3);
    const uint32_t cell = (morton_axis(codes[mid], axis) >> level) << level;
    note(why, SplitMethod::Morton, axis, 0.5f * (morton_.origin[axis] + float(cell) / morton_.scale[axis]));
    left_info = scan(begin, mid);
    right_info = scan(mid, end);
    return mid;
  }

  // Blocks of leaf_block_ primitives (a power of two): per lane, and for one count.
  __m128 blocks(__m128i n) const { return _mm_cvtepi32_ps(_mm_srl_epi32(_mm_add_epi32(n, leaf_round_), leaf_shift_)); }
  uint32_t blocks(uint32_t n) const { return (n + leaf_block_ - 1) >> std::countr_zero(leaf_block_); }

  static float half_area(const Box& b) {
    const Bounds c = b.bounds();
    if (c.empty()) return 0.0f;
    const glm::vec3 e = c.extent();
    return e.x * e.y + e.y * e.z + e.z * e.x;
  }

  HugeArray<PrimRef>& refs_;
  BvhBuilder builder_;
  const uint32_t* codes_;
  MortonFrame morton_;
  HugeArray<BvhNode> slots_;
  HugeArray<uint32_t> left_nodes_;     // an inner slot's left subtree node count
  HugeArray<const LocalTree*> local_;  // a slot's LocalTree, or null
  tbb::concurrent_vector<LocalTree> locals_;
  uint32_t max_leaf_size_;
  uint32_t leaf_block_;
  __m128i leaf_round_, leaf_shift_;
};

}  // namespace

size_t binary_bvh_build_bytes(size_t n, BvhBuilder builder) {
  // References, the local trees (at most 2n nodes), the compacted nodes (at most 2n) and the
  // primitive order; the slot arrays are mostly never touched. The LBVH's sort adds its keys, the
  // sorted references and their codes.
  const size_t morton = builder == BvhBuilder::Lbvh ? sizeof(uint64_t) + sizeof(PrimRef) + sizeof(uint32_t) : 0;
  return n * (sizeof(PrimRef) + 4 * sizeof(BvhNode) + sizeof(uint32_t) + morton);
}

namespace {

constexpr uint32_t kRefGrain = 1024;  // primitives per task when making references

PrimRef make_ref(const Bounds& b, uint32_t index) {
  const __m128 lo = _mm_setr_ps(b.lo.x, b.lo.y, b.lo.z, 0.0f);
  return {_mm_castsi128_ps(_mm_insert_epi32(_mm_castps_si128(lo), int32_t(index), 3)),
          _mm_setr_ps(b.hi.x, b.hi.y, b.hi.z, 0.0f)};
}

}  // namespace

BinaryBvh build_binary_bvh(std::span<const Bounds> prim_bounds, uint32_t max_leaf_size, uint32_t leaf_block,
                           BvhBuilder builder) {
  return build_binary_bvh(
      uint32_t(prim_bounds.size()),
      [&](uint32_t begin, uint32_t end, Bounds* out) { std::copy(&prim_bounds[begin], &prim_bounds[end], out); },
      max_leaf_size, leaf_block, builder);
}

BinaryBvh build_binary_bvh(uint32_t count, const BoundsSource& bounds_of, uint32_t max_leaf_size, uint32_t leaf_block,
                           BvhBuilder kind) {
  if (!std::has_single_bit(leaf_block))
    throw std::invalid_argument("build_binary_bvh: leaf_block must be a power of two");
  BinaryBvh bvh;
  if (count == 0) return bvh;
  // Every primitive's reference in parallel, describing them on the way (the root's description
  // without another pass over them); then, only when some box is empty, a stable pass leaves those
  // out, and the root is described anew: a shorter build than a second pass (docs/bench/history.md).
  HugeArray<PrimRef> refs = make_huge_array<PrimRef>(count);
  struct Made {
    RangeInfo info;
    uint32_t empties = 0;
  };
  const Made made = tbb::parallel_reduce(
      tbb::blocked_range<uint32_t>(0, count, kRefGrain), Made{},
      [&](const tbb::blocked_range<uint32_t>& r, Made acc) {
        Bounds boxes[kRefGrain];
        for (uint32_t first = r.begin(); first < r.end(); first += kRefGrain) {
          const uint32_t last = std::min(r.end(), first + kRefGrain);
          bounds_of(first, last, boxes);
          for (uint32_t i = first; i < last; ++i) {
            const Bounds& b = boxes[i - first];
            acc.empties += b.empty();
            refs[i] = make_ref(b, i);
            acc.info.extend(refs[i]);
          }
        }
        return acc;
      },
      [](Made a, const Made& b) {
        a.info.merge(b.info);
        a.empties += b.empties;
        return a;
      });
  uint32_t n = count;
  if (made.empties != 0) {
    n = 0;
    for (uint32_t i = 0; i < count; ++i)
      if (!Box{refs[i].lo, refs[i].hi}.bounds().empty()) refs[n++] = refs[i];
    if (n == 0) return bvh;
  }
  const RangeInfo root = made.empties == 0 ? made.info : Builder(refs, 1, 1, leaf_block, kind).scan(0, n);
  const MortonFrame morton(root.centroids);
  HugeArray<uint32_t> codes;
  if (kind == BvhBuilder::Lbvh) codes = sort_by_morton(refs, n, morton);
  Builder builder(refs, n, std::max(max_leaf_size, 1u), leaf_block, kind, codes.get(), morton);
  const uint32_t nodes = builder.build(0, 1, 0, n, root, 0);
  bvh.nodes.resize(nodes);
  builder.compact(0, nodes, 0, 1, bvh.nodes.data());
  bvh.prims.resize(n);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 4 * kRefGrain), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t i = r.begin(); i != r.end(); ++i) bvh.prims[i] = refs[i].index();
  });
  return bvh;
}

SplitCosts explain_split(uint32_t count, const BoundsSource& bounds_of, std::span<const uint32_t> node_prims, int depth,
                         uint32_t max_leaf_size, uint32_t leaf_block, BvhBuilder kind) {
  if (!std::has_single_bit(leaf_block)) throw std::invalid_argument("explain_split: leaf_block must be a power of two");
  std::vector<uint32_t> ids(node_prims.begin(), node_prims.end());
  std::sort(ids.begin(), ids.end());  // positions in index order, as in the build (the LBVH's ties)
  if (ids.empty()) throw std::invalid_argument("explain_split: a node has at least one primitive");
  if (ids.back() >= count || std::adjacent_find(ids.begin(), ids.end()) != ids.end())
    throw std::invalid_argument("explain_split: the node's primitives must be distinct and below the count");
  const uint32_t n = uint32_t(ids.size());
  HugeArray<PrimRef> refs = make_huge_array<PrimRef>(n);
  for (uint32_t i = 0; i < n; ++i) {
    Bounds b;
    bounds_of(ids[i], ids[i] + 1, &b);
    refs[i] = make_ref(b, ids[i]);
  }
  MortonFrame morton;
  HugeArray<uint32_t> codes;
  if (kind == BvhBuilder::Lbvh) {  // the frame is the root's: every primitive's centroid
    RangeInfo all;
    Bounds boxes[kRefGrain];
    for (uint32_t first = 0; first < count; first += kRefGrain) {
      const uint32_t last = std::min(count, first + kRefGrain);
      bounds_of(first, last, boxes);
      for (uint32_t i = first; i < last; ++i)
        if (!boxes[i - first].empty()) all.extend(make_ref(boxes[i - first], i));
    }
    morton = MortonFrame(all.centroids);
    codes = sort_by_morton(refs, n, morton);
  }
  Builder builder(refs, n, std::max(max_leaf_size, 1u), leaf_block, kind, codes.get(), morton);
  return builder.explain(n, depth);
}

}  // namespace raylab
