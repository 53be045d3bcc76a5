// The BVH's packet walk: up to Bvh::kPacketSize rays through the wide tree at once, for the uncounted
// batch queries (Bvh::closest_batch, any_batch; the coherence rule is in bvh.h). The packet shares the
// walk, the node and leaf loads and the stack; every ray keeps its own tests: its box test of a node's
// children (Width::test on its own BoxRayW, with its own best t), its triangle tests (closest_in_leaf
// and any_in_leaf on its own TriangleRayW) and its own best hit with the same closer() tie-break, and
// a node is skipped for a ray exactly when the single walk would skip it (its entry beyond the ray's
// best t). The packet enters a child when some ray hits it, and only those rays take part there.
//
// Why every ray gets its single walk's hit, bit for bit:
// - Any hit: a ray's box tests use its tmax, as alone, so it reaches exactly the leaves its own walk
//   can reach, in another order; whether one of them holds a hit does not depend on the order.
// - Closest hit, exact contract with the watertight test: the result is the brute force's (padded
//   boxes never cull a hit the triangle test reports), whatever the order: the packet's order is free.
// - Closest hit otherwise (the fast contract; the exact contract's Möller–Trumbore): a box may cull a
//   hit on its face, so the hit may depend on the order the nodes are visited in. There the packet
//   keeps each ray on its own order: at a node whose hit children the packet visits in an order other
//   than the ray's own (nearest entry first, a tie to the higher child index, as the single walk's
//   stack pops them), the ray leaves the packet and walks alone afterwards. A ray that stays sees
//   the same nodes in the same order with the same best t as alone, so the same hit.
#pragma once

#include "bvh.h"

#include <new>

namespace raylab {

// Traces rays[0..n) (1 <= n <= kPacketSize); writes hits[r] (closest: the best hit, set only when
// found) and out[r] (found / occluded) for every ray that stayed in the packet, and returns the mask of
// those that left it (kSameOrder), which the caller traces alone.
template <class Width, bool kClosest, bool kSameOrder>
[[gnu::always_inline]] inline uint32_t Bvh::packet_walk(const Ray* rays, int n, Hit* hits, uint8_t* out) const {
  using Node = typename Width::Node;
  using BoxRayW = typename Width::BoxRayW;
  using TriangleRayW = typename Width::TriangleRayW;
  constexpr int K = kPacketSize;
  const uint32_t all = (1u << n) - 1;
  if (node_count() == 0) {
    for (int r = 0; r < n; ++r) out[r] = 0;
    return 0;
  }
  // The rays' constants, built in place (the triangle constants refer to themselves: not copyable).
  alignas(BoxRayW) unsigned char box_storage[K][sizeof(BoxRayW)];
  alignas(TriangleRayW) unsigned char triangle_storage[K][sizeof(TriangleRayW)];
  const BoxRayW* boxw[K];
  const TriangleRayW* triw[K];
  Hit best[K];
  PacketEntry e;
  e.ref = 0;
  e.count = 0;
  e.rays = all;
  for (int r = 0; r < n; ++r) {
    const glm::vec3 direction = effective_direction(rays[r].direction);
    boxw[r] = new (box_storage[r]) BoxRayW(BoxRay(rays[r], direction, root_bounds_));
    triw[r] = new (triangle_storage[r]) TriangleRayW(rays[r], settings_.triangle_test, direction);
    best[r] = initial_hit(rays[r]);
    e.t_entry[r] = rays[r].tmin;
  }
  const auto& nodes = wide_nodes<Width>();
  uint32_t alive = all, found = 0, left = 0;
  PacketEntry stack[kStackSize];
  int size = 0;
  bool root = true;  // the root is entered as the single walk enters it, without the skip test
  NoRecord record;
  for (;;) {
    if (!root) {
      if (size == 0) break;
      e = stack[--size];
    }
    uint32_t active = e.rays & alive;
    if constexpr (kClosest) {
      if (!root)
        for (uint32_t a = active; a != 0; a &= a - 1) {
          const int r = std::countr_zero(a);
          if (e.t_entry[r] > best[r].t) active &= ~(1u << r);
        }
    }
    root = false;
    if (active == 0) continue;
    if (e.count != 0) {
      const Entry leaf{e.ref, e.count, 0.0f, 0};
      for (uint32_t a = active; a != 0; a &= a - 1) {
        const int r = std::countr_zero(a);
        if constexpr (kClosest) {
          if (closest_in_leaf<Width>(*triw[r], rays[r], leaf, best[r], record)) found |= 1u << r;
        } else if (any_in_leaf<Width>(*triw[r], rays[r], leaf, record)) {
          found |= 1u << r;
          alive &= ~(1u << r);
        }
      }
      if (!kClosest && alive == 0) break;
      continue;
    }
    const Node& node = nodes[e.ref];
    alignas(32) float t[K][Node::kWidth];
    uint32_t hit_by[Node::kWidth] = {};  // child i: the rays that hit it
    int leader = -1;                     // the first ray that hits a child: the packet's order is its own
    for (uint32_t a = active; a != 0; a &= a - 1) {
      const int r = std::countr_zero(a);
      int mask = Width::test(node, *boxw[r], kClosest ? best[r].t : rays[r].tmax, t[r]);
      if (mask != 0 && leader < 0) leader = r;
      for (; mask != 0; mask &= mask - 1) hit_by[std::countr_zero(unsigned(mask))] |= 1u << r;
    }
    if (leader < 0) continue;
    // The children hit, in the order they are visited: the leader's order for the closest hit (the
    // single walk's: nearest first, a tie to the higher index), index order for any hit.
    int order[Node::kWidth];
    int k = 0;
    for (int i = 0; i < Node::kWidth; ++i) {
      if (hit_by[i] == 0) continue;
      int j = k++;
      if constexpr (kClosest)
        for (; j > 0 && t[leader][order[j - 1]] >= t[leader][i]; --j) order[j] = order[j - 1];
      order[j] = i;
    }
    if constexpr (kClosest && kSameOrder) {
      if (k > 1)
        for (uint32_t a = active & ~(1u << leader); a != 0; a &= a - 1) {
          const int r = std::countr_zero(a);
          int previous = -1;
          for (int j = 0; j < k; ++j) {
            const int i = order[j];
            if (!((hit_by[i] >> r) & 1)) continue;
            if (previous >= 0 && !(t[r][previous] < t[r][i] || (t[r][previous] == t[r][i] && previous > i))) {
              left |= 1u << r;
              alive &= ~(1u << r);
              break;
            }
            previous = i;
          }
        }
    }
    // Pushed farthest first, so that the nearest is popped next.
    for (int j = k - 1; j >= 0; --j) {
      const int i = order[j];
      const uint32_t in = hit_by[i] & alive;
      if (in == 0) continue;
      PacketEntry& c = stack[size++];
      c.ref = node.child[i];
      c.count = node.count[i];
      c.rays = in;
      for (uint32_t a = in; a != 0; a &= a - 1) {
        const int r = std::countr_zero(a);
        c.t_entry[r] = t[r][i];
      }
      prefetch<Width>(Entry{c.ref, c.count, 0.0f, 0});
    }
  }
  for (int r = 0; r < n; ++r) {
    if ((left >> r) & 1) continue;
    out[r] = (found >> r) & 1;
    if constexpr (kClosest)
      if ((found >> r) & 1) hits[r] = best[r];
  }
  return left;
}

template <bool kClosest, bool kSameOrder>
__attribute__((target("avx2"))) uint32_t Bvh::packet8(const Ray* rays, int n, Hit* hits, uint8_t* out) const {
  return packet_walk<Avx8, kClosest, kSameOrder>(rays, n, hits, out);
}

template <bool kClosest>
__attribute__((target("avx2,fma"))) uint32_t Bvh::packet8_fast(const Ray* rays, int n, Hit* hits,
                                                               uint8_t* out) const {
  return packet_walk<FastAvx8, kClosest, true>(rays, n, hits, out);
}

// The instance of the contract, the triangle test and the width.
template <bool kClosest>
uint32_t Bvh::packet(const Ray* rays, int n, Hit* hits, uint8_t* out) const {
  if (settings_.contract == Contract::Fast) {
    if (width_ == 8) return packet8_fast<kClosest>(rays, n, hits, out);
    return packet_walk<FastSse4, kClosest, true>(rays, n, hits, out);
  }
  if (settings_.triangle_test != TriangleTest::Watertight) {
    if (width_ == 8) return packet8<kClosest, true>(rays, n, hits, out);
    return packet_walk<Sse4, kClosest, true>(rays, n, hits, out);
  }
  if (width_ == 8) return packet8<kClosest, false>(rays, n, hits, out);
  return packet_walk<Sse4, kClosest, false>(rays, n, hits, out);
}

// One packet and the rays that left it, each alone; hits[r] is a default Hit on a miss.
template <bool kClosest>
void Bvh::trace_packet(const Ray* rays, int n, Hit* hits, uint8_t* out, PacketCounts* counts) const {
  Hit packet_hits[kPacketSize];
  uint8_t found[kPacketSize];
  uint32_t left = packet<kClosest>(rays, n, packet_hits, found);
  if (counts) {
    ++counts->packets;
    counts->packet_rays += size_t(n);
    counts->evicted += size_t(std::popcount(left));
  }
  for (int r = 0; r < n; ++r) {
    if ((left >> r) & 1) {
      if constexpr (kClosest) {
        Hit h;
        closest(rays[r], h);
        hits[r] = h;
      } else {
        out[r] = any(rays[r]);
      }
    } else if constexpr (kClosest) {
      hits[r] = found[r] ? packet_hits[r] : Hit{};
    } else {
      out[r] = found[r];
    }
  }
}

// A run of rays: each coherent group (bvh.h) as a packet, the other rays alone.
template <bool kClosest>
void Bvh::trace_batch(std::span<const Ray> rays, Hit* hits, uint8_t* out, PacketCounts* counts) const {
  const float spread = kPacketOriginSpread * glm::length(root_bounds_.empty() ? glm::vec3(0.0f)
                                                                               : root_bounds_.hi - root_bounds_.lo);
  const float origin_limit = spread * spread;
  for (size_t i = 0; i < rays.size();) {
    size_t n = 1;
    while (n < size_t(kPacketSize) && i + n < rays.size() && coherent(rays[i], rays[i + n], origin_limit)) ++n;
    if (n >= size_t(kMinPacket) && coherent(rays[i], rays[i], origin_limit)) {
      trace_packet<kClosest>(&rays[i], int(n), kClosest ? &hits[i] : nullptr, kClosest ? nullptr : &out[i], counts);
      i += n;
      continue;
    }
    if constexpr (kClosest) {
      Hit h;
      closest(rays[i], h);
      hits[i] = h;
    } else {
      out[i] = any(rays[i]);
    }
    if (counts) ++counts->single_rays;
    ++i;
  }
}

}  // namespace raylab
