// `bvh`: a binned SAH hierarchy (bvh_build.h) collapsed into a 4-wide BVH whose nodes test their four
// children at once with SSE and whose leaves hold triangles in packets of four for the SIMD
// watertight test (bvh_simd.h). Traversal is ordered: the nearest child first, and a node is skipped
// once the closest hit lies before it.
#pragma once

#include "raylab/box_intersection.h"
#include "raylab/bvh_build.h"
#include "raylab/bvh_simd.h"
#include "raylab/structure.h"
#include "raylab/triangle_loop.h"

#include <algorithm>
#include <bit>

namespace raylab {

// The far limit for the scene's top-level box tests (src/scene.cpp), whose boxes are not padded:
// about 1e-5 relative slack for the box and triangle tests rounding the same point differently. The
// structures themselves need none: their boxes are padded (box_intersection.h), and they open every
// box entered at or before the best hit (inclusive, for the index tie-break).
inline float box_limit(float best_t) { return best_t + std::abs(best_t) * 0x1p-16f; }

class Bvh final : public StructureBase<Bvh> {
 public:
  // The builder keeps the binary depth below 48 + log2(n); a 4-wide level pushes at most 3 entries
  // more than it pops.
  static constexpr int kStackSize = 256;

  Bvh(MeshPtr mesh, const BuildSettings& settings);

  template <class Recorder>
  bool traverse_closest(const Ray& ray, Hit& hit, Recorder& record) const {
    return traverse<true>(ray, &hit, record);
  }

  template <class Recorder>
  bool traverse_any(const Ray& ray, Recorder& record) const {
    return traverse<false>(ray, nullptr, record);
  }

  // Box ids, as in boxes() and the story: node n is id n (0 the root), leaf k (in packet order)
  // is id node_count + k.
  std::vector<BoxInfo> boxes() const override;
  size_t memory_bytes() const override;

  const std::vector<Bvh4Node>& nodes() const { return nodes_; }
  std::span<const TrianglePacket> packets() const { return {packets_.get(), packet_count_}; }

 private:
  struct Entry {
    uint32_t ref;    // node index, or first packet of a leaf
    uint32_t count;  // triangles of a leaf; 0 for a node
    float t_entry;
    int depth;
  };

  // One loop for both queries: closest hit prunes entries beyond the best hit so far; any hit stops
  // at the first triangle hit.
  template <bool kClosest, class Recorder>
  bool traverse(const Ray& ray, Hit* hit, Recorder& record) const {
    record.ray();
    const BoxRay box_ray(ray, root_bounds_);
    Entry stack[kStackSize];
    int size = 0;
    if (!enter_root(box_ray, record, stack, size)) return false;
    const TriangleTester tester(ray, settings_.triangle_test);
    const Box4Ray box4(box_ray);
    const Watertight4Ray tri4(tester.watertight);
    Hit best = initial_hit(ray);
    bool found = false;
    Entry e;
    bool descending = false;  // e is the nearest child of the node just visited, not yet on the stack
    for (;;) {
      if (!descending) {
        if (size == 0) break;
        e = stack[--size];
      }
      descending = false;
      if constexpr (kClosest) {
        if (e.t_entry > best.t) continue;
      }
      record_node(e, record);
      if (e.count == 0) {
        descending = visit_children<kClosest>(e, box4, kClosest ? best.t : ray.tmax, record, stack, size);
      } else if constexpr (kClosest) {
        found |= closest_in_leaf(tester, tri4, e, best, record);
      } else if (any_in_leaf(tester, tri4, e, record)) {
        return true;
      }
    }
    if (found) *hit = best;
    return found;
  }

  uint32_t leaf_id(uint32_t first_packet) const {
    return uint32_t(nodes_.size() +
                    (std::lower_bound(leaf_packets_.begin(), leaf_packets_.end(), first_packet) - leaf_packets_.begin()));
  }

  template <class Recorder>
  void record_node(const Entry& e, Recorder& record) const {
    if constexpr (Recorder::kActive) record.node(e.count != 0 ? leaf_id(e.ref) : e.ref, e.depth);
  }

  template <class Recorder>
  bool enter_root(const BoxRay& box_ray, Recorder& record, Entry* stack, int& size) const {
    float t_entry;
    if (!raylab::enter_root(root_bounds_, !nodes_.empty(), box_ray, box_ray.tmax, record, t_entry)) return false;
    stack[size++] = {0, 0, t_entry, 0};
    return true;
  }

  // Tests the four children of node `e` and replaces `e` with the child to visit next, returning
  // false when no child is hit. The other children hit go on the stack; `Ordered` puts the nearest
  // child in `e` and pushes the rest farthest first. A lone hit child, the common case, skips the stack.
  template <bool Ordered, class Recorder>
  bool visit_children(Entry& e, const Box4Ray& box4, float tmax, Recorder& record, Entry* stack, int& size) const {
    const Bvh4Node& node = nodes_[e.ref];
    __m128 entry;
    int mask = intersect_box4(node, box4, tmax, entry);
    alignas(16) float t[4];
    _mm_store_ps(t, entry);
    if constexpr (Recorder::kActive) {
      for (int i = 0; i < 4; ++i)
        if (node.used(i))
          record.box(node.leaf(i) ? leaf_id(node.child[i]) : node.child[i], node.bounds(i), e.depth + 1,
                     (mask >> i) & 1, t[i]);
    }
    if (mask == 0) return false;
    const int depth = e.depth + 1;
    if ((mask & (mask - 1)) == 0) {
      const int i = std::countr_zero(unsigned(mask));
      e = {node.child[i], node.count[i], t[i], depth};
      prefetch(e);
      return true;
    }
    const int first = size;
    for (; mask != 0; mask &= mask - 1) {
      const int i = std::countr_zero(unsigned(mask));
      Entry c{node.child[i], node.count[i], t[i], depth};
      prefetch(c);
      if constexpr (Ordered) {
        int j = size;  // insertion: the stack segment of this node stays sorted, farthest at the bottom
        while (j > first && stack[j - 1].t_entry < c.t_entry) {
          stack[j] = stack[j - 1];
          --j;
        }
        stack[j] = c;
      } else {
        stack[size] = c;
      }
      ++size;
    }
    e = stack[--size];
    return true;
  }

  // Starts loading a child while its siblings are tested: on large meshes traversal waits on memory.
  void prefetch(const Entry& e) const {
    const char* p = e.count != 0 ? reinterpret_cast<const char*>(&packets_[e.ref])
                                 : reinterpret_cast<const char*>(&nodes_[e.ref]);
    _mm_prefetch(p, _MM_HINT_T0);
    _mm_prefetch(p + 64, _MM_HINT_T0);
  }

  uint32_t triangle_at(const Entry& leaf, uint32_t i) const { return packets_[leaf.ref + i / 4].triangle[i % 4]; }

  template <class Recorder>
  bool closest_in_leaf(const TriangleTester& tester, const Watertight4Ray& tri4, const Entry& leaf, Hit& best,
                       Recorder& record) const {
    if (tester.test != TriangleTest::Watertight)
      return closest_in_triangles(*mesh_, tester, leaf.count, [&](uint32_t i) { return triangle_at(leaf, i); }, best,
                                  record);
    bool found = false;
    for (uint32_t p = 0; p * 4 < leaf.count; ++p) {
      const TrianglePacket& packet = packets_[leaf.ref + p];
      const int lanes = int(std::min(4u, leaf.count - 4 * p));
      float t[4], u[4], v[4];
      int mask = intersect_watertight4(tri4, packet, tester.ray.tmin, best.t, t, u, v) & ((1 << lanes) - 1);
      if constexpr (Recorder::kActive)
        for (int lane = 0; lane < lanes; ++lane) record.triangle(packet.triangle[lane], (mask >> lane) & 1);
      for (; mask != 0; mask &= mask - 1) {
        const int lane = std::countr_zero(unsigned(mask));
        const uint32_t triangle = packet.triangle[lane];
        if (closer({t[lane], u[lane], v[lane]}, triangle, best)) {
          best.t = t[lane];
          best.u = u[lane];
          best.v = v[lane];
          best.triangle = triangle;
          found = true;
        }
      }
    }
    return found;
  }

  template <class Recorder>
  bool any_in_leaf(const TriangleTester& tester, const Watertight4Ray& tri4, const Entry& leaf, Recorder& record) const {
    if (tester.test != TriangleTest::Watertight)
      return any_in_triangles(*mesh_, tester, leaf.count, [&](uint32_t i) { return triangle_at(leaf, i); },
                              tester.ray.tmax, record);
    for (uint32_t p = 0; p * 4 < leaf.count; ++p) {
      const TrianglePacket& packet = packets_[leaf.ref + p];
      const int lanes = int(std::min(4u, leaf.count - 4 * p));
      float t[4], u[4], v[4];
      const int mask =
          intersect_watertight4(tri4, packet, tester.ray.tmin, tester.ray.tmax, t, u, v) & ((1 << lanes) - 1);
      if constexpr (Recorder::kActive) {
        // As the scalar loop: every triangle up to the first hit is tested.
        const int tested = mask != 0 ? std::countr_zero(unsigned(mask)) + 1 : lanes;
        for (int lane = 0; lane < tested; ++lane) record.triangle(packet.triangle[lane], (mask >> lane) & 1);
      }
      if (mask != 0) return true;
    }
    return false;
  }

  Bounds root_bounds_;
  std::vector<Bvh4Node> nodes_;
  HugeArray<TrianglePacket> packets_;
  size_t packet_count_ = 0;
  std::vector<uint32_t> leaf_packets_;  // first packet of each leaf, increasing: leaf k's id
};

std::unique_ptr<Structure> build_bvh(MeshPtr mesh, const BuildSettings& settings);

}  // namespace raylab
