// `octree`: the root is the mesh's bounding box grown to a cube (depth 0 = the root alone). A node
// splits into its 8 octants while depth < max_depth and it holds more than leaf_size triangles; a
// triangle goes to every octant it truly overlaps (separating-axis test, triangle_box_overlap.h),
// never by "a vertex lies inside", so a large triangle is found in every leaf it crosses. Empty
// octants are not allocated. max_depth auto (the default) derives the depth from the triangle count
// and the memory budget (auto_max_depth). Traversal visits children front to back, stops as soon as
// the closest hit lies before the next child's entry, and tests a triangle met in several leaves once
// per ray (mailbox.h); the watertight test takes a leaf's triangles 8 (AVX2) or 4 (SSE) at a time
// (Octree::for_packets). Built in src/octree.cpp.
#pragma once

#include "box_intersection.h"
#include "raylab/huge_array.h"
#include "raylab/structure.h"
#include "raylab/triangle_packets.h"
#include "triangle_loop.h"

#include "raylab/simd.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <span>
#include <type_traits>

namespace raylab {

// One node in 8 bytes. The children of a node are stored next to each other in octant order, so an
// inner node needs only the index of its first child and a mask of the octants that exist; a leaf
// references a run of the octree's one triangle-index array.
struct OctreeNode {
  static constexpr uint32_t kLeaf = 0x80000000u;
  uint32_t first = 0;     // inner: index of the first child; leaf: first entry in the index array
  uint32_t bits = kLeaf;  // leaf: kLeaf | triangle count; inner: child mask (bit i: octant i exists)

  bool leaf() const { return (bits & kLeaf) != 0; }
  uint32_t triangle_count() const { return bits & ~kLeaf; }
  uint32_t child_mask() const { return bits & 0xffu; }
  // The node index of the child in `octant`, which must exist.
  uint32_t child(int octant) const { return first + uint32_t(std::popcount(child_mask() & ((1u << octant) - 1u))); }
};

// A triangle's three corners as 16-byte rows (x, y, z, 0), one triangle after another in index
// order: the leaf test transposes four triangles' rows into a TrianglePacket (Octree::gather).
// The build classifies from them too.
struct alignas(16) CornerRows {
  float p[3][4];  // [corner][axis, then 0]

  glm::vec3 corner(int c) const { return {p[c][0], p[c][1], p[c][2]}; }
};
static_assert(sizeof(CornerRows) == 48);

// Octant i of a box: bit 0 selects the upper half in x, bit 1 in y, bit 2 in z. Build and traversal
// both derive boxes with this one function, so octants share their splitting planes bit for bit and
// tile their parent exactly. Always inlined: GCC kept it a call inside the walk, a cost the walk
// felt (docs/bench/history.md).
[[gnu::always_inline]] inline Bounds octant_bounds(const Bounds& box, int octant) {
  const glm::vec3 mid = box.center();
  Bounds b;
  for (int axis = 0; axis < 3; ++axis) {
    const bool upper = (octant >> axis) & 1;
    b.lo[axis] = upper ? mid[axis] : box.lo[axis];
    b.hi[axis] = upper ? box.hi[axis] : mid[axis];
  }
  return b;
}

// The ray against all eight octants of a node at once: the parametric idea of Revelles, Ureña and
// Lastra (2000), where the distances to a node's planes are computed once and every child's interval
// is assembled from them. Per axis there are four planes (the node's two faces and, padded both
// ways, its mid-plane), computed for the three axes at once in one SSE register per plane; the eight
// octants' intervals are then assembled in two registers of four lanes (octants 0-3 and 4-7), without
// a branch. Each octant's result is intersect_box(octant_bounds(box, octant)) bit for bit, from the
// same expressions in the same order (box_intersection.h; _mm_min_ps(a, b) is `a < b ? a : b` and
// _mm_max_ps(a, b) is `a > b ? a : b`, NaN giving b, exactly the scalar selections), so the exactness
// pad, the NaN rules and the story's boxes are unchanged: the children are still box-tested, only
// without repeating the work they share. (Revelles' successor table, which enters only the children
// the ray pierces, would visit fewer than the padded boxes the exactness contract requires.)
// Against eight scalar box tests, and then with the walk entering the nearest child without the stack
// (Octree::walk), the octree's speed relative to the BVH rose on every mesh measured
// (docs/bench/history.md).
struct OctantRay {
  __m128 origin, inv_dir, pad, tmin;  // lane 3 unused (zero)

  explicit OctantRay(const BoxRay& r)
      : origin(_mm_setr_ps(r.origin.x, r.origin.y, r.origin.z, 0.0f)),
        inv_dir(_mm_setr_ps(r.inv_dir.x, r.inv_dir.y, r.inv_dir.z, 0.0f)),
        pad(_mm_set1_ps(r.pad)),
        tmin(_mm_set1_ps(r.tmin)) {}
};

// A box in two registers, x y z in lanes 0-2 and zero in lane 3 (a stray lane holding an integer's bits
// would be a denormal, which costs a microcode assist in every operation).
struct OctantBox {
  __m128 lo, hi;

  [[gnu::always_inline]] static OctantBox load(const glm::vec3& lo, const glm::vec3& hi) {
    return {_mm_setr_ps(lo.x, lo.y, lo.z, 0.0f), _mm_setr_ps(hi.x, hi.y, hi.z, 0.0f)};
  }
};

// intersect_box(octant_bounds(box, octant), r, tmax, t_entry[octant]) for the eight octants: returns
// the mask of octants hit (bit i: octant i) and writes every octant's entry distance (meaningful for
// the octants hit).
[[gnu::always_inline]] inline uint32_t intersect_octants(const OctantBox& box, const OctantRay& r, float tmax,
                                                         float t_entry[8]) {
  const __m128 mid = _mm_mul_ps(_mm_set1_ps(0.5f), _mm_add_ps(box.lo, box.hi));  // Bounds::center
  const __m128 lo = _mm_sub_ps(box.lo, r.origin), half = _mm_sub_ps(mid, r.origin), hi = _mm_sub_ps(box.hi, r.origin);
  // Per axis, the lower half [lo, mid] (0) and the upper half [mid, hi] (1): t0 and t1 as
  // intersect_box computes them, swapped into near and far, the far one widened.
  const __m128 a0 = _mm_mul_ps(_mm_sub_ps(lo, r.pad), r.inv_dir), b0 = _mm_mul_ps(_mm_add_ps(half, r.pad), r.inv_dir);
  const __m128 a1 = _mm_mul_ps(_mm_sub_ps(half, r.pad), r.inv_dir), b1 = _mm_mul_ps(_mm_add_ps(hi, r.pad), r.inv_dir);
  const __m128 scale = _mm_set1_ps(kBoxFarScale);
  const __m128 near0 = _mm_min_ps(b0, a0), far0 = _mm_mul_ps(_mm_max_ps(a0, b0), scale);
  const __m128 near1 = _mm_min_ps(b1, a1), far1 = _mm_mul_ps(_mm_max_ps(a1, b1), scale);
  // Lane i of a register is octant i (low register) or i + 4 (high): x from bit 0, y from bit 1, z
  // the same for all four lanes of a register.
  const auto by_x = [](__m128 h0, __m128 h1) {
    const __m128 xy = _mm_unpacklo_ps(h0, h1);  // h0.x h1.x h0.y h1.y
    return _mm_movelh_ps(xy, xy);
  };
  const auto by_y = [](__m128 h0, __m128 h1) { return _mm_shuffle_ps(h0, h1, _MM_SHUFFLE(1, 1, 1, 1)); };
  const auto z_of = [](__m128 h) { return _mm_shuffle_ps(h, h, _MM_SHUFFLE(2, 2, 2, 2)); };
  // intersect_box's order: x, then y, then z, from tmin and tmax.
  __m128 t_near = _mm_max_ps(by_x(near0, near1), r.tmin);
  __m128 t_far = _mm_min_ps(by_x(far0, far1), _mm_set1_ps(tmax));
  t_near = _mm_max_ps(by_y(near0, near1), t_near);
  t_far = _mm_min_ps(by_y(far0, far1), t_far);
  const __m128 near_low = _mm_max_ps(z_of(near0), t_near), near_high = _mm_max_ps(z_of(near1), t_near);
  const __m128 far_low = _mm_min_ps(z_of(far0), t_far), far_high = _mm_min_ps(z_of(far1), t_far);
  _mm_storeu_ps(t_entry, near_low);
  _mm_storeu_ps(t_entry + 4, near_high);
  // A hit is !(t_near > t_far), as intersect_box decides it (t_near is never NaN; tmax may be).
  return uint32_t(_mm_movemask_ps(_mm_cmpngt_ps(near_low, far_low)) |
                  (_mm_movemask_ps(_mm_cmpngt_ps(near_high, far_high)) << 4));
}

// The bits of `mask` reordered so that bit k is bit k ^ flip: octants in the order a walk visits them.
inline uint32_t xor_permute_octants(uint32_t mask, int flip) {
  if (flip & 1) mask = ((mask & 0x55u) << 1) | ((mask >> 1) & 0x55u);
  if (flip & 2) mask = ((mask & 0x33u) << 2) | ((mask >> 2) & 0x33u);
  if (flip & 4) mask = ((mask & 0x0fu) << 4) | ((mask >> 4) & 0x0fu);
  return mask;
}

class Octree final : public StructureBase<Octree> {
 public:
  // BuildSettings::validate's limit on max_depth; it sizes the traversal stack.
  static constexpr int kMaxDepth = BuildSettings::kMaxDepthLimit;

  // Levels added to log4(triangles / leaf_size) by max_depth auto (auto_max_depth).
  static constexpr int kAutoDepthMargin = 2;

  // Throws BuildError as soon as the build would need more than settings.memory_budget bytes; with
  // max_depth auto (BuildSettings::kAutoDepth) it ends the tree at the last level that fits instead.
  // leaf_lanes: how many triangles the watertight leaf test takes at once, 8 (AVX2) or 4 (SSE), or 0
  // for the most this CPU runs (4 exists to test the SSE path on an AVX2 machine); 8 without AVX2 is
  // an error.
  Octree(MeshPtr mesh, const BuildSettings& settings, int leaf_lanes = 0);

  // The depth max_depth auto allows a mesh of `triangle_count` triangles before the budget is
  // counted: log4(triangle_count / leaf_size), rounded up, plus kAutoDepthMargin, at most kMaxDepth.
  static int auto_max_depth(size_t triangle_count, int leaf_size);
  // The depth limit the tree was built with: settings().max_depth, or what auto chose (lowered to
  // the last level that fitted the memory budget, where that stopped the build).
  int max_depth() const { return max_depth_; }

  template <class Recorder>
  bool traverse_closest(const Ray& ray, Hit& hit, Recorder& record) const {
    return traverse<true>(ray, &hit, record);
  }

  template <class Recorder>
  bool traverse_any(const Ray& ray, Recorder& record) const {
    return traverse<false>(ray, nullptr, record);
  }

  // Every node in index order (parents before children). A leaf's triangle_count is its own; an
  // inner node's is the number of distinct triangles referenced by the leaves below it.
  std::vector<BoxInfo> boxes() const override;
  // The nodes, the triangle-index array and the corner rows.
  size_t memory_bytes() const override;

  const Bounds& root_bounds() const { return root_; }
  std::span<const OctreeNode> nodes() const { return nodes_; }
  // The triangles of a leaf, in ascending index order.
  std::span<const uint32_t> leaf_triangles(uint32_t node) const { return triangles_of(nodes_[node]); }

 private:
  // Both queries, one walk: the closest hit (kClosest, into *hit) or any hit before ray.tmax.
  template <bool kClosest, class Recorder>
  bool traverse(const Ray& ray, Hit* hit, Recorder& record) const {
    if (settings_.triangle_test != TriangleTest::Watertight) {
      const auto leaves = [&](auto limit, auto visit) {
        walk(ray, record, limit, [&](const OctreeNode& leaf) { return visit(prefetched(triangles_of(leaf))); });
      };
      if constexpr (kClosest)
        return closest_over_leaves(*mesh_, settings_.triangle_test, ray, *hit, record, leaves, Mailbox{});
      else return any_over_leaves(*mesh_, settings_.triangle_test, ray, record, leaves, Mailbox{});
    }
    record.ray();
    const TriangleTester tester(ray, TriangleTest::Watertight);
    const Watertight4Ray ray4(tester.watertight);
    Hit best = initial_hit(ray);
    bool found = false;
    Mailbox mailbox;
    walk(
        ray, record, [&] { return kClosest ? best.t : ray.tmax; },
        [&](const OctreeNode& leaf) {
          return for_packets(leaf, mailbox, [&](const TrianglePacket* packets, int lanes) {
            alignas(32) float t[kLeafLanes], u[kLeafLanes], v[kLeafLanes];
            const float limit = kClosest ? best.t : tester.ray.tmax;
            const int mask = test_packets<!kClosest>(tester, ray4, packets, lanes, limit, t, u, v);
            if constexpr (kClosest) {
              found |= take_closest_lanes(packets, lanes, mask, t, u, v, record, best);
              return false;
            } else {
              return found = record_any_lanes(packets, lanes, mask, record);
            }
          });
        });
    if (kClosest && found) *hit = best;
    return found;
  }
  std::span<const uint32_t> triangles_of(const OctreeNode& leaf) const {
    return {triangles_.data() + leaf.first, leaf.triangle_count()};
  }

  // Starts loading the vertex indices of a leaf's triangles, all at once before the first is tested:
  // each is a cache miss on a large mesh, and the tests one after another waited on them in turn.
  std::span<const uint32_t> prefetched(std::span<const uint32_t> leaf) const {
    for (const uint32_t t : leaf) _mm_prefetch(reinterpret_cast<const char*>(&mesh_->triangles[t]), _MM_HINT_T0);
    return leaf;
  }

  // The watertight test's leaf loop: the leaf's triangles this ray has not tested yet (mailbox.h),
  // in leaf order, up to kLeafLanes at a time in two packets, their corners gathered from corners_
  // for the SIMD test of the BVH (triangle_packets.h; bit for bit the scalar test's results).
  // `test(packets, lanes)` gets `lanes` real triangles (a packet's other lanes repeat its first) and
  // returns true to stop the walk. Faster than the scalar loop through the mesh's index array on every
  // mesh measured, for 48 bytes per triangle more (corners_; docs/bench/history.md).
  static constexpr int kLeafLanes = 8;

  template <class Test>
  [[gnu::always_inline]] bool for_packets(const OctreeNode& leaf, Mailbox& mailbox, Test test) const {
    const std::span<const uint32_t> triangles = triangles_of(leaf);
    for (const uint32_t t : triangles) {
      const char* rows = reinterpret_cast<const char*>(&corners_[t]);
      _mm_prefetch(rows, _MM_HINT_T0);
      _mm_prefetch(rows + sizeof(CornerRows) - 1, _MM_HINT_T0);
    }
    TrianglePacket packets[2];
    int lanes = 0;
    for (const uint32_t t : triangles) {
      if (!mailbox.first_test(t)) continue;
      packets[lanes / 4].triangle[lanes % 4] = t;
      if (++lanes == kLeafLanes) {
        gather(packets[0]);
        gather(packets[1]);
        if (test(packets, kLeafLanes)) return true;
        lanes = 0;
      }
    }
    if (lanes == 0) return false;
    TrianglePacket& last = packets[(lanes - 1) / 4];
    for (int lane = lanes % 4; lane != 0 && lane < 4; ++lane) last.triangle[lane] = last.triangle[0];
    gather(packets[0]);
    if (lanes > 4) gather(packets[1]);
    return test(packets, lanes);
  }

  // The first `lanes` triangles of `packets` against the ray, between tmin and `tmax`: the mask of
  // those hit, and their t, u, v. One 8-lane test (AVX2), or one or two 4-lane tests (SSE): eight lanes
  // were equal or slightly faster.
  // kAny: only the first lane hit (first_hit_lane, triangle_packets.h).
  template <bool kAny>
  [[gnu::always_inline]] int test_packets(const TriangleTester& tester, const Watertight4Ray& ray4,
                                          const TrianglePacket* packets, int lanes, float tmax, float* t, float* u,
                                          float* v) const {
    if (leaf_lanes_ == 8)
      return test_packets8<kAny>(tester.watertight, packets[0], lanes > 4 ? packets[1] : packets[0], (1 << lanes) - 1,
                                 tester.ray.tmin, tmax, t, u, v);
    int mask = intersect_watertight4<kAny>(ray4, packets[0], tester.ray.tmin, tmax, t, u, v);
    // The unused lanes repeat their packet's first triangle, so an any-hit mask's first lane is real.
    if (lanes > 4 && !(kAny && mask != 0))
      mask |= intersect_watertight4<kAny>(ray4, packets[1], tester.ray.tmin, tmax, t + 4, u + 4, v + 4) << 4;
    return mask & ((1 << lanes) - 1);
  }

  // Not inlined: the walk is compiled for SSE, this alone for AVX2.
  template <bool kAny>
  RAYLAB_AVX2 __attribute__((noinline)) static int test_packets8(const WatertightRay& ray, const TrianglePacket& a,
                                                                 const TrianglePacket& b, int lanes, float tmin,
                                                                 float tmax, float* t, float* u, float* v) {
    const Watertight8Ray ray8(ray);
    return intersect_watertight8<kAny>(ray8, a, b, lanes, tmin, tmax, t, u, v);
  }

  // The corners of packet.triangle[0..3] into packet.p: each triangle's rows, transposed.
  [[gnu::always_inline]] void gather(TrianglePacket& packet) const {
    const CornerRows* c = corners_.get();
    for (int corner = 0; corner < 3; ++corner) {
      __m128 r0 = _mm_load_ps(c[packet.triangle[0]].p[corner]), r1 = _mm_load_ps(c[packet.triangle[1]].p[corner]);
      __m128 r2 = _mm_load_ps(c[packet.triangle[2]].p[corner]), r3 = _mm_load_ps(c[packet.triangle[3]].p[corner]);
      _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
      _mm_store_ps(packet.p[corner][0], r0);
      _mm_store_ps(packet.p[corner][1], r1);
      _mm_store_ps(packet.p[corner][2], r2);
    }
  }

  // Trivially constructible (glm vectors, not a Bounds with its empty-box initialiser): the walk's
  // stack (then of 129 entries) was filled with empty boxes on every query, a cost the walk felt
  // (docs/bench/history.md).
  struct StackEntry {
    glm::vec3 lo, hi;
    uint32_t node;
    int depth;
    float t_entry;

    Bounds box() const { return {lo, hi}; }
  };
  static_assert(std::is_trivially_default_constructible_v<StackEntry>);

  // The front-to-back walk both queries share. `limit()` is the far end of the search (the closest
  // hit so far, or ray.tmax); `visit_leaf(node)` tests a leaf's triangles and returns true to stop.
  template <class Recorder, class Limit, class VisitLeaf>
  void walk(const Ray& ray, Recorder& record, Limit limit, VisitLeaf visit_leaf) const {
    // Padded boxes (box_intersection.h): a box holding a triangle the triangle test hits at t is
    // entered at or before t, so the walk needs no slack of its own.
    const BoxRay box_ray(ray, root_);

    float t_root;
    if (!enter_root(root_, !nodes_.empty(), box_ray, limit(), record, t_root)) return;
    // Visiting octants in the order k ^ near_octant is front to back: along a ray each octant bit
    // can only turn on, so the octants a ray passes come in increasing order of k. The signs are the
    // box test's (effective_direction): a tiny or -0 component counts as +0 in both.
    const int near_octant =
        (box_ray.inv_dir.x < 0.0f ? 1 : 0) | (box_ray.inv_dir.y < 0.0f ? 2 : 0) | (box_ray.inv_dir.z < 0.0f ? 4 : 0);
    const OctantRay octant_ray(box_ray);

    // DFS keeps at most 7 children of one node per depth on the stack (the eighth is entered).
    StackEntry stack[7 * kMaxDepth + 1];
    int top = 0;
    StackEntry entry{root_.lo, root_.hi, 0, 0, t_root};
    for (;;) {
      // Unless the closest hit so far lies before this box: enter it.
      if (!(entry.t_entry > limit())) {
        record.node(entry.node, entry.depth);
        const OctreeNode node = nodes_[entry.node];
        if (node.leaf()) {
          if (visit_leaf(node)) return;
        } else if (enter_nearest_child(nodes_, entry, node, ray, octant_ray, near_octant, limit(), record, stack,
                                       top)) {
          continue;
        }
      }
      if (top == 0) return;
      entry = stack[--top];
    }
  }

  // Tests the children of inner node `entry` and replaces `entry` with the nearest child hit, pushing
  // the others hit farthest first (so the next nearest is on top); false when no child is hit.
  template <class Recorder>
  [[gnu::always_inline]] static bool enter_nearest_child(std::span<const OctreeNode> nodes, StackEntry& entry,
                                                         const OctreeNode& node, const Ray& ray,
                                                         const OctantRay& octant_ray, int near_octant, float far,
                                                         Recorder& record, StackEntry* stack, int& top) {
    alignas(16) float t[8];
    // The children (8 bytes each, side by side) are loaded while their boxes are tested: on large
    // meshes the walk waits on memory (with the leaves' prefetch: faster on dragon.obj,
    // docs/bench/history.md).
    _mm_prefetch(reinterpret_cast<const char*>(nodes.data() + node.first), _MM_HINT_T0);
    const uint32_t hit = intersect_octants(OctantBox::load(entry.lo, entry.hi), octant_ray, far, t) & node.child_mask();
    const Bounds box = entry.box();
    const int depth = entry.depth + 1;
    if constexpr (Recorder::kActive) {
      for (int k = 0; k < 8; ++k) {
        const int octant = k ^ near_octant;
        if ((node.child_mask() >> octant) & 1u) {
          const bool entered = (hit >> octant) & 1u;
          record.box(node.child(octant), octant_bounds(box, octant), depth, entered, entered ? t[octant] : ray.tmin);
        }
      }
    }
    uint32_t order = xor_permute_octants(hit, near_octant);  // bit k: the k-th octant front to back
    if (order == 0) return false;
    const int nearest = std::countr_zero(order);
    for (order &= order - 1; order != 0;) {
      const int k = 31 - std::countl_zero(order);
      order &= ~(1u << k);
      const int octant = k ^ near_octant;
      const Bounds b = octant_bounds(box, octant);
      stack[top++] = {b.lo, b.hi, node.child(octant), depth, t[octant]};
    }
    const int octant = nearest ^ near_octant;
    const Bounds b = octant_bounds(box, octant);
    entry = {b.lo, b.hi, node.child(octant), depth, t[octant]};
    return true;
  }

  void build();

  Bounds root_;
  bool automatic_depth_ = false;
  int max_depth_ = 0;
  std::vector<OctreeNode> nodes_;    // breadth first: node 0 is the root
  std::vector<uint32_t> triangles_;  // the leaves' runs, one after another
  HugeArray<CornerRows> corners_;    // per triangle of the mesh, for the watertight leaf test
  int leaf_lanes_ = 4;
};

std::unique_ptr<Structure> build_octree(MeshPtr mesh, const BuildSettings& settings);

}  // namespace raylab
