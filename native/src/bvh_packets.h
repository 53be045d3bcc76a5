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

#include <cstddef>
#include <cstring>
#include <limits>
#include <new>

namespace raylab {

// The packet's rays in SIMD lanes: lane r holds the constants of ray r's own box test (Box4Ray's and
// Box8Ray's, or FastBox4Ray's and FastBox8Ray's, from the same BoxRay). One child box is tested
// against every lane with the operations of the single walk's kernel (intersect_box4, intersect_box8,
// fast_box4, fast_box8), in the same order with the same operands, so each lane computes bit for bit
// what that ray's own test computes for that box. The rays that hit a child and their entry distances
// come out as the stack takes them, with no transposition.
struct PacketLanes {
  alignas(32) float a[3][8];  // exact: origin; fast: reciprocal direction
  alignas(32) float b[3][8];  // exact: reciprocal direction; fast: origin x reciprocal
  alignas(32) float pad[8];   // exact only
  alignas(32) float tmin[8];
};

// One box (corner a at lo[a * stride], hi[a * stride]) against the eight lanes, each with its far
// limit in `limit`: the lanes that hit it, their entry distances in t_near. intersect_box8's operations:
RAYLAB_AVX2 [[gnu::always_inline]] inline uint32_t box_lanes_exact(const PacketLanes& p, const float* lo,
                                                                   const float* hi, size_t stride, __m256 limit,
                                                                   __m256& t_near) {
  const __m256 pad = _mm256_load_ps(p.pad);
  t_near = _mm256_load_ps(p.tmin);
  __m256 t_far = _mm256_set1_ps(kInfinity);
  for (int a = 0; a < 3; ++a) {
    const __m256 o = _mm256_load_ps(p.a[a]), inv = _mm256_load_ps(p.b[a]);
    const __m256 t0 = _mm256_mul_ps(_mm256_sub_ps(_mm256_sub_ps(_mm256_set1_ps(lo[a * stride]), o), pad), inv);
    const __m256 t1 = _mm256_mul_ps(_mm256_add_ps(_mm256_sub_ps(_mm256_set1_ps(hi[a * stride]), o), pad), inv);
    const __m256 near = _mm256_min_ps(t1, t0);
    const __m256 far = _mm256_max_ps(t0, t1);
    t_near = _mm256_max_ps(near, t_near);
    t_far = _mm256_min_ps(far, t_far);
  }
  t_far = _mm256_min_ps(_mm256_mul_ps(t_far, _mm256_set1_ps(kBoxFarScale)), limit);
  return uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(t_near, t_far, _CMP_LE_OQ)));
}

// fast_box8's:
RAYLAB_AVX2_FMA [[gnu::always_inline]] inline uint32_t box_lanes_fast(const PacketLanes& p, const float* lo,
                                                                      const float* hi, size_t stride, __m256 limit,
                                                                      __m256& t_near) {
  t_near = _mm256_load_ps(p.tmin);
  __m256 t_far = limit;
  for (int a = 0; a < 3; ++a) {
    const __m256 rdir = _mm256_load_ps(p.a[a]), org_rdir = _mm256_load_ps(p.b[a]);
    const __m256 t0 = _mm256_fmsub_ps(_mm256_set1_ps(lo[a * stride]), rdir, org_rdir);
    const __m256 t1 = _mm256_fmsub_ps(_mm256_set1_ps(hi[a * stride]), rdir, org_rdir);
    t_near = _mm256_max_ps(t_near, _mm256_min_ps(t0, t1));
    t_far = _mm256_min_ps(t_far, _mm256_max_ps(t0, t1));
  }
  return uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(t_near, t_far, _CMP_LE_OQ)));
}

// Tests the used children of `node` against the lanes of `lanes` (each lane's far limit in `tmax`):
// writes t_entry[child][lane] and hit_by[child] (the lanes among `lanes` that hit it) and returns the
// lanes that hit any child.
RAYLAB_AVX2 inline uint32_t packet_node_exact(const Bvh8Node& node, const PacketLanes& p, const float* tmax,
                                              uint32_t lanes, float (*t_entry)[8], uint32_t* hit_by) {
  const __m256 limit = _mm256_load_ps(tmax);
  uint32_t any = 0;
  for (int i = 0; i < 8; ++i) {
    hit_by[i] = 0;
    if (!node.used(i)) continue;
    __m256 t_near;
    hit_by[i] = box_lanes_exact(p, &node.lo[0][i], &node.hi[0][i], 8, limit, t_near) & lanes;
    _mm256_store_ps(t_entry[i], t_near);
    any |= hit_by[i];
  }
  return any;
}

RAYLAB_AVX2_FMA inline uint32_t packet_node_fast(const Bvh8Node& node, const PacketLanes& p, const float* tmax,
                                                 uint32_t lanes, float (*t_entry)[8], uint32_t* hit_by) {
  const __m256 limit = _mm256_load_ps(tmax);
  uint32_t any = 0;
  for (int i = 0; i < 8; ++i) {
    hit_by[i] = 0;
    if (!node.used(i)) continue;
    __m256 t_near;
    hit_by[i] = box_lanes_fast(p, &node.lo[0][i], &node.hi[0][i], 8, limit, t_near) & lanes;
    _mm256_store_ps(t_entry[i], t_near);
    any |= hit_by[i];
  }
  return any;
}

// The lanes among `lanes` that hit the root box `root`, tested as its children are (a ray that misses
// it misses every child: their padded boxes lie inside its padded box, and every step of the test is
// monotonic in the box's corners).
RAYLAB_AVX2 inline uint32_t packet_root_exact(const Bounds& root, const PacketLanes& p, const float* tmax,
                                              uint32_t lanes) {
  __m256 t_near;
  return box_lanes_exact(p, &root.lo[0], &root.hi[0], 1, _mm256_load_ps(tmax), t_near) & lanes;
}
RAYLAB_AVX2_FMA inline uint32_t packet_root_fast(const Bounds& root, const PacketLanes& p, const float* tmax,
                                                 uint32_t lanes) {
  __m256 t_near;
  return box_lanes_fast(p, &root.lo[0], &root.hi[0], 1, _mm256_load_ps(tmax), t_near) & lanes;
}

// intersect_box4's, on the eight lanes four at a time (SSE):
inline uint32_t packet_node_exact(const Bvh4Node& node, const PacketLanes& p, const float* tmax, uint32_t lanes,
                                  float (*t_entry)[8], uint32_t* hit_by) {
  const __m128 scale = _mm_set1_ps(kBoxFarScale);
  uint32_t any = 0;
  for (int i = 0; i < 4; ++i) {
    hit_by[i] = 0;
    if (!node.used(i)) continue;
    for (int h = 0; h < 8; h += 4) {
      const __m128 pad = _mm_load_ps(p.pad + h);
      __m128 t_near = _mm_load_ps(p.tmin + h);
      __m128 t_far = _mm_set1_ps(kInfinity);
      for (int a = 0; a < 3; ++a) {
        const __m128 o = _mm_load_ps(p.a[a] + h), inv = _mm_load_ps(p.b[a] + h);
        const __m128 t0 = _mm_mul_ps(_mm_sub_ps(_mm_sub_ps(_mm_set1_ps(node.lo[a][i]), o), pad), inv);
        const __m128 t1 = _mm_mul_ps(_mm_add_ps(_mm_sub_ps(_mm_set1_ps(node.hi[a][i]), o), pad), inv);
        const __m128 near = _mm_min_ps(t1, t0);
        const __m128 far = _mm_max_ps(t0, t1);
        t_near = _mm_max_ps(near, t_near);
        t_far = _mm_min_ps(far, t_far);
      }
      t_far = _mm_min_ps(_mm_mul_ps(t_far, scale), _mm_load_ps(tmax + h));
      _mm_store_ps(t_entry[i] + h, t_near);
      hit_by[i] |= uint32_t(_mm_movemask_ps(_mm_cmple_ps(t_near, t_far))) << h;
    }
    hit_by[i] &= lanes;
    any |= hit_by[i];
  }
  return any;
}

// fast_box4's:
inline uint32_t packet_node_fast(const Bvh4Node& node, const PacketLanes& p, const float* tmax, uint32_t lanes,
                                 float (*t_entry)[8], uint32_t* hit_by) {
  uint32_t any = 0;
  for (int i = 0; i < 4; ++i) {
    hit_by[i] = 0;
    if (!node.used(i)) continue;
    for (int h = 0; h < 8; h += 4) {
      __m128 t_near = _mm_load_ps(p.tmin + h), t_far = _mm_load_ps(tmax + h);
      for (int a = 0; a < 3; ++a) {
        const __m128 rdir = _mm_load_ps(p.a[a] + h), org_rdir = _mm_load_ps(p.b[a] + h);
        const __m128 t0 = _mm_sub_ps(_mm_mul_ps(_mm_set1_ps(node.lo[a][i]), rdir), org_rdir);
        const __m128 t1 = _mm_sub_ps(_mm_mul_ps(_mm_set1_ps(node.hi[a][i]), rdir), org_rdir);
        t_near = _mm_max_ps(t_near, _mm_min_ps(t0, t1));
        t_far = _mm_min_ps(t_far, _mm_max_ps(t0, t1));
      }
      _mm_store_ps(t_entry[i] + h, t_near);
      hit_by[i] |= uint32_t(_mm_movemask_ps(_mm_cmple_ps(t_near, t_far))) << h;
    }
    hit_by[i] &= lanes;
    any |= hit_by[i];
  }
  return any;
}

// The lanes whose entry distance is not beyond their limit: the single walk's `t_entry > best.t`
// skip, lane-wise (not greater: a NaN limit keeps the lane, as the scalar comparison does).
inline uint32_t packet_keep(const float* t_entry, const float* limit) {
  const __m128 lo = _mm_cmpngt_ps(_mm_load_ps(t_entry), _mm_load_ps(limit));
  const __m128 hi = _mm_cmpngt_ps(_mm_load_ps(t_entry + 4), _mm_load_ps(limit + 4));
  return uint32_t(_mm_movemask_ps(lo)) | uint32_t(_mm_movemask_ps(hi)) << 4;
}

// Ray r's recorder in a packet: its own counters, or nothing.
template <bool kCount>
inline auto lane_record(TraversalStats* lanes, int r) {
  if constexpr (kCount) return StatsRecord{lanes[r]};
  else return NoRecord{};
}

// Lane r of the packet: ray r's box test constants, as its own walk makes them (BoxRay, FastBoxRay).
template <bool kFast>
[[gnu::always_inline]] inline void fill_lane(PacketLanes& lanes, int r, const BoxRay& box_ray) {
  if constexpr (kFast) {
    const FastBoxRay f(box_ray);
    for (int a = 0; a < 3; ++a) {
      lanes.a[a][r] = f.rdir[a];
      lanes.b[a][r] = f.org_rdir[a];
    }
    lanes.pad[r] = 0.0f;
    lanes.tmin[r] = f.tmin;
  } else {
    for (int a = 0; a < 3; ++a) {
      lanes.a[a][r] = box_ray.origin[a];
      lanes.b[a][r] = box_ray.inv_dir[a];
    }
    lanes.pad[r] = box_ray.pad;
    lanes.tmin[r] = box_ray.tmin;
  }
}

// The eight lanes at once: the rays transposed into one register per field, then each step of
// effective_direction, BoxRay and FastBoxRay on all lanes (the same operations on the same operands,
// so each lane holds the bits fill_lane gives it; tests/native/test_bvh_packets.cpp compares them).
// Unused lanes repeat ray 0, masked out.
template <bool kFast>
RAYLAB_AVX2 inline void fill_lanes8(const Ray* rays, int n, const Bounds& root, PacketLanes& lanes,
                                    glm::vec3* direction) {
  static_assert(sizeof(Ray) == 32 && offsetof(Ray, tmin) == 12 && offsetof(Ray, direction) == 16 &&
                offsetof(Ray, tmax) == 28);
  __m256 row[8];  // ray r: origin, tmin, direction, tmax
  for (int r = 0; r < 8; ++r) row[r] = _mm256_loadu_ps(reinterpret_cast<const float*>(&rays[r < n ? r : 0]));
  // An 8x8 transpose: col[f] holds field f of every ray.
  __m256 t[8], u[8], col[8];
  for (int k = 0; k < 4; ++k) {
    t[2 * k] = _mm256_unpacklo_ps(row[2 * k], row[2 * k + 1]);
    t[2 * k + 1] = _mm256_unpackhi_ps(row[2 * k], row[2 * k + 1]);
  }
  for (int k = 0; k < 2; ++k)
    for (int h = 0; h < 2; ++h) {
      u[4 * k + 2 * h] = _mm256_shuffle_ps(t[4 * k + h], t[4 * k + 2 + h], _MM_SHUFFLE(1, 0, 1, 0));
      u[4 * k + 2 * h + 1] = _mm256_shuffle_ps(t[4 * k + h], t[4 * k + 2 + h], _MM_SHUFFLE(3, 2, 3, 2));
    }
  for (int f = 0; f < 4; ++f) {
    col[f] = _mm256_permute2f128_ps(u[f], u[4 + f], 0x20);
    col[4 + f] = _mm256_permute2f128_ps(u[f], u[4 + f], 0x31);
  }
  const __m256 o[3] = {col[0], col[1], col[2]}, tmin = col[3];
  const __m256 sign = _mm256_set1_ps(-0.0f);
  // effective_direction: a component below 2^-40 of the largest, or denormal, becomes +0.
  const __m256 abs_d[3] = {_mm256_andnot_ps(sign, col[4]), _mm256_andnot_ps(sign, col[5]),
                           _mm256_andnot_ps(sign, col[6])};
  const __m256 largest = _mm256_max_ps(_mm256_max_ps(abs_d[2], abs_d[1]), abs_d[0]);
  const __m256 keep = _mm256_mul_ps(_mm256_set1_ps(0x1p-40f), largest);
  const __m256 normal = _mm256_set1_ps(std::numeric_limits<float>::min());
  __m256 d[3];
  for (int a = 0; a < 3; ++a) {
    const __m256 drop =
        _mm256_or_ps(_mm256_cmp_ps(abs_d[a], keep, _CMP_LT_OQ), _mm256_cmp_ps(abs_d[a], normal, _CMP_LT_OQ));
    d[a] = _mm256_andnot_ps(drop, col[4 + a]);
  }
  alignas(32) float dx[8], dy[8], dz[8];
  _mm256_store_ps(dx, d[0]);
  _mm256_store_ps(dy, d[1]);
  _mm256_store_ps(dz, d[2]);
  for (int r = 0; r < 8; ++r) direction[r] = {dx[r], dy[r], dz[r]};
  // BoxRay: the reciprocal direction and the pad, kBoxPadScale times the largest distance along an
  // axis from the origin to the root box.
  const __m256 one = _mm256_set1_ps(1.0f);
  const __m256 inv[3] = {_mm256_div_ps(one, d[0]), _mm256_div_ps(one, d[1]), _mm256_div_ps(one, d[2])};
  __m256 far[3];
  for (int a = 0; a < 3; ++a) {
    const __m256 lo = _mm256_andnot_ps(sign, _mm256_sub_ps(_mm256_set1_ps(root.lo[a]), o[a]));
    const __m256 hi = _mm256_andnot_ps(sign, _mm256_sub_ps(_mm256_set1_ps(root.hi[a]), o[a]));
    far[a] = _mm256_max_ps(hi, lo);
  }
  const __m256 pad =
      root.empty() ? _mm256_setzero_ps()
                   : _mm256_mul_ps(_mm256_set1_ps(kBoxPadScale), _mm256_max_ps(far[2], _mm256_max_ps(far[1], far[0])));
  for (int a = 0; a < 3; ++a) {
    if constexpr (kFast) {  // FastBoxRay: a zero component's infinite reciprocal becomes 2^60
      const __m256 infinite = _mm256_cmp_ps(_mm256_andnot_ps(sign, inv[a]), _mm256_set1_ps(kInfinity), _CMP_EQ_OQ);
      const __m256 rdir = _mm256_blendv_ps(inv[a], _mm256_set1_ps(kFastLargeReciprocal), infinite);
      _mm256_store_ps(lanes.a[a], rdir);
      _mm256_store_ps(lanes.b[a], _mm256_mul_ps(o[a], rdir));
    } else {
      _mm256_store_ps(lanes.a[a], o[a]);
      _mm256_store_ps(lanes.b[a], inv[a]);
    }
  }
  _mm256_store_ps(lanes.pad, kFast ? _mm256_setzero_ps() : pad);
  _mm256_store_ps(lanes.tmin, tmin);
}

// The rays among rays[0..n) (1 <= n <= 8) whose own box test of `root` (intersect_box with
// BoxRay(ray, root), within [tmin, tmax]; kFast: fast_box8's on FastBoxRay) hits it: bit r for ray r,
// the lanes computing what each ray's test computes. The scene's batches let a group of rays that all
// miss its top level go with one test per eight rays, and the BVH's closest hits without packets a ray
// that misses the root. Needs AVX2 (cpu_has_avx2; kFast also FMA): instanced by the two below.
template <bool kFast>
[[gnu::always_inline]] inline uint32_t lanes_entering(const Ray* rays, int n, const Bounds& root) {
  PacketLanes lanes;
  glm::vec3 direction[8];
  fill_lanes8<kFast>(rays, n, root, lanes, direction);
  alignas(32) float tmax[8];
  for (int r = 0; r < 8; ++r) tmax[r] = rays[r < n ? r : 0].tmax;
  if constexpr (kFast) return packet_root_fast(root, lanes, tmax, (1u << n) - 1);
  else return packet_root_exact(root, lanes, tmax, (1u << n) - 1);
}
RAYLAB_AVX2 [[gnu::flatten]] inline uint32_t rays_entering(const Ray* rays, int n, const Bounds& root) {
  return lanes_entering<false>(rays, n, root);
}
RAYLAB_AVX2_FMA [[gnu::flatten]] inline uint32_t rays_entering_fast(const Ray* rays, int n, const Bounds& root) {
  return lanes_entering<true>(rays, n, root);
}

// Traces rays[0..n) (1 <= n <= kPacketSize) and writes out[r] (found / occluded) and, closest, hits[r]
// where found. Returns the rays that left the packet (kSameOrder) and finished alone.
// Counted (kCount), every ray records what its recorded single walk records: its query, the root box
// (a ray that misses it leaves at once, ignored), each node it enters, every used child box of those
// nodes and its triangle tests. Its visits are its own walk's only where it keeps its own order of the
// children: any hit's order is the single walk's for every ray (the highest child first), and closest
// hit needs kSameOrder.
template <class Width, bool kClosest, bool kSameOrder, bool kCount>
[[gnu::always_inline]] inline uint32_t Bvh::packet_walk(const Ray* rays, int n, Hit* hits, uint8_t* out,
                                                        TraversalStats* counted) const {
  using Node = typename Width::Node;
  using TriangleRayW = typename Width::TriangleRayW;
  constexpr int K = kPacketSize;
  constexpr int W = Node::kWidth;
  constexpr bool kFast = std::is_same_v<Width, FastSse4> || std::is_same_v<Width, FastAvx8>;
  static_assert(K == 8);
  static_assert(!kCount || !kClosest || kSameOrder);
  uint32_t all = (1u << n) - 1;
  if constexpr (kCount)
    for (int r = 0; r < n; ++r) {
      auto record = lane_record<kCount>(counted, r);
      record.ray();
      float t_root;
      const BoxRay box_ray(rays[r], effective_direction(rays[r].direction), root_bounds_);
      if (!raylab::enter_root(root_bounds_, node_count() != 0, box_ray, box_ray.tmax, record, t_root))
        all &= ~(1u << r);
    }
  if (node_count() == 0 || all == 0) {
    for (int r = 0; r < n; ++r) out[r] = 0;
    return 0;
  }
  PacketLanes lanes;
  alignas(32) float limit[K];  // closest: the best t so far; any: tmax
  glm::vec3 direction[K];
  Hit best[K];
  alignas(32) PacketEntry e;
  e.ref = 0;
  e.count = 0;
  e.rays = all;
  if constexpr (Node::kWidth == 8) {
    fill_lanes8<kFast>(rays, n, root_bounds_, lanes, direction);
  } else {
    for (int r = 0; r < K; ++r) {
      const Ray& ray = rays[r < n ? r : 0];  // unused lanes repeat ray 0, masked out
      direction[r] = effective_direction(ray.direction);
      fill_lane<kFast>(lanes, r, BoxRay(ray, direction[r], root_bounds_));
    }
  }
  for (int r = 0; r < K; ++r) limit[r] = rays[r < n ? r : 0].tmax;
  if constexpr (Node::kWidth == 8 && !kCount) {
    // Uncounted, the single walk does not test the root box (bvh.h): a packet that misses it whole,
    // the camera's sky, leaves here after one box test instead of the root's eight.
    uint32_t entered;
    if constexpr (kFast) entered = packet_root_fast(root_bounds_, lanes, limit, all);
    else entered = packet_root_exact(root_bounds_, lanes, limit, all);
    if (entered == 0) {
      for (int r = 0; r < n; ++r) out[r] = 0;
      return 0;
    }
    all = entered;
    e.rays = all;
  }
  for (int r = 0; r < K; ++r) {
    const Ray& ray = rays[r < n ? r : 0];
    best[r] = initial_hit(ray);
    e.t_entry[r] = ray.tmin;
  }
  // Each ray's triangle constants, made when it first reaches a leaf (most rays of a camera miss).
  alignas(TriangleRayW) unsigned char triangle_storage[K][sizeof(TriangleRayW)];
  uint32_t ready = 0;
  const auto triangles_of = [&](int r) -> const TriangleRayW& {
    if (!((ready >> r) & 1)) {
      new (triangle_storage[r]) TriangleRayW(rays[r], settings_.triangle_test, direction[r], fast_scale_);
      ready |= 1u << r;
    }
    return *std::launder(reinterpret_cast<const TriangleRayW*>(triangle_storage[r]));
  };
  uint32_t alive = all, found = 0, left = 0;
  alignas(32) PacketEntry stack[kStackSize];
  int size = 0;
  bool root = true;  // the root is entered as the single walk enters it, without the skip test
  for (;;) {
    if (!root) {
      if (size == 0) break;
      e = stack[--size];
    }
    uint32_t active = e.rays & alive;
    if constexpr (kClosest)
      if (!root) active &= packet_keep(e.t_entry, limit);
    root = false;
    if (active == 0) continue;
    if constexpr (kCount)
      for (uint32_t a = active; a != 0; a &= a - 1) {
        auto record = lane_record<kCount>(counted, std::countr_zero(a));
        record.node(e.ref, 0);  // only counted: no leaf id needed
      }
    if (e.count != 0) {
      const Entry leaf{e.ref, e.count, 0.0f, 0};
      for (uint32_t a = active; a != 0; a &= a - 1) {
        const int r = std::countr_zero(a);
        auto record = lane_record<kCount>(counted, r);
        if constexpr (kClosest) {
          if (closest_in_leaf<Width>(triangles_of(r), rays[r], leaf, best[r], record)) {
            found |= 1u << r;
            limit[r] = best[r].t;
          }
        } else if (any_in_leaf<Width>(triangles_of(r), rays[r], leaf, record)) {
          found |= 1u << r;
          alive &= ~(1u << r);
        }
      }
      if (!kClosest && alive == 0) break;
      continue;
    }
    const Node& node = wide_nodes<Width>()[e.ref];
    alignas(32) float t[W][8];  // [child][ray]
    uint32_t hit_by[W];
    uint32_t any;
    if constexpr (kFast) any = packet_node_fast(node, lanes, limit, active, t, hit_by);
    else any = packet_node_exact(node, lanes, limit, active, t, hit_by);
    if constexpr (kCount) {
      // Each ray tests every used child, as alone (only the count is recorded: StatsRecord reads no
      // argument, and the single walk's box ids would cost a search per leaf child).
      int used = 0;
      for (int i = 0; i < W; ++i) used += node.used(i);
      for (uint32_t a = active; a != 0; a &= a - 1) {
        auto record = lane_record<kCount>(counted, std::countr_zero(a));
        for (int i = 0; i < used; ++i) record.box(0, Bounds{}, 0, false, 0.0f);
      }
    }
    if (any == 0) continue;
    // The children hit, in the order the packet visits them: for the closest hit the first ray's own
    // order (nearest first, a tie to the higher index, as the single walk's stack pops them); for any
    // hit every ray's own, the highest index first (the single walk's unordered stack pops them so):
    // the answer does not depend on it, each ray's counts do.
    const int leader = std::countr_zero(any);
    int order[W];
    int k = 0;
    if constexpr (kClosest) {
      for (int i = 0; i < W; ++i) {
        if (hit_by[i] == 0) continue;
        int j = k++;
        for (; j > 0 && t[order[j - 1]][leader] >= t[i][leader]; --j) order[j] = order[j - 1];
        order[j] = i;
      }
    } else {
      for (int i = W - 1; i >= 0; --i)
        if (hit_by[i] != 0) order[k++] = i;
    }
    if constexpr (kClosest && kSameOrder) {
      if (k > 1)
        for (uint32_t a = any & ~(1u << leader); a != 0; a &= a - 1) {
          const int r = std::countr_zero(a);
          int previous = -1;
          bool same = true;
          for (int j = 0; j < k && same; ++j) {
            const int i = order[j];
            if (!((hit_by[i] >> r) & 1)) continue;
            same = previous < 0 || t[previous][r] < t[i][r] || (t[previous][r] == t[i][r] && previous > i);
            previous = i;
          }
          if (same) continue;
          // Its own order: the single walk's stack segment for this node (insertion, farthest at
          // the bottom), under the entries of the packet's stack it is in.
          Entry children[W];
          int count = 0;
          for (int i = 0; i < W; ++i) {
            if (!((hit_by[i] >> r) & 1)) continue;
            const Entry c{node.child[i], node.count[i], t[i][r], 0};
            int j = count++;
            for (; j > 0 && children[j - 1].t_entry < c.t_entry; --j) children[j] = children[j - 1];
            children[j] = c;
          }
          auto record = lane_record<kCount>(counted, r);
          if (finish_alone<Width>(rays[r], direction[r], triangles_of(r), stack, size, r, children, count, best[r],
                                  record))
            found |= 1u << r;
          left |= 1u << r;
          alive &= ~(1u << r);
        }
    }
    for (int j = k - 1; j >= 0; --j) {  // farthest first, so that the nearest is popped next
      const int i = order[j];
      const uint32_t in = hit_by[i] & alive;
      if (in == 0) continue;
      PacketEntry& c = stack[size++];
      std::memcpy(c.t_entry, t[i], sizeof(c.t_entry));
      c.ref = node.child[i];
      c.count = node.count[i];
      c.rays = in;
      prefetch<Width>(Entry{c.ref, c.count, 0.0f, 0});
    }
  }
  for (int r = 0; r < n; ++r) {
    out[r] = (found >> r) & 1;
    if constexpr (kClosest)
      if ((found >> r) & 1) hits[r] = best[r];
  }
  return left;
}

// The rest of ray r's single walk from where it left the packet: its stack is the packet's entries it
// is in, bottom to top, then `children` (its hit children of the node it left at, farthest first), and
// its best hit so far `best`. The single walk's loop (traverse_wide).
template <class Width, class Recorder>
[[gnu::always_inline]] inline bool Bvh::finish_alone(const Ray& ray, const glm::vec3& direction,
                                                     const typename Width::TriangleRayW& triw,
                                                     const PacketEntry* packet_stack, int packet_size, int r,
                                                     const Entry* children, int count, Hit& best,
                                                     Recorder& record) const {
  Entry stack[kStackSize];
  int size = 0;
  for (int j = 0; j < packet_size; ++j)
    if ((packet_stack[j].rays >> r) & 1)
      stack[size++] = {packet_stack[j].ref, packet_stack[j].count, packet_stack[j].t_entry[r], 0};
  for (int j = 0; j < count; ++j) stack[size++] = children[j];
  const typename Width::BoxRayW boxw(BoxRay(ray, direction, root_bounds_));
  bool found = false;
  while (size > 0) {
    Entry e = stack[--size];
    for (;;) {
      if (e.t_entry > best.t) break;
      record_node(e, record);
      if (e.count != 0) {
        found |= closest_in_leaf<Width>(triw, ray, e, best, record);
        break;
      }
      if (!visit_children<Width, true>(e, boxw, best.t, record, stack, size)) break;
    }
  }
  return found;
}

template <bool kClosest, bool kSameOrder, bool kCount>
RAYLAB_AVX2 [[gnu::flatten]] uint32_t Bvh::packet8(const Ray* rays, int n, Hit* hits, uint8_t* out,
                                                   TraversalStats* lanes) const {
  return packet_walk<Avx8, kClosest, kSameOrder, kCount>(rays, n, hits, out, lanes);
}

template <bool kClosest, bool kCount>
RAYLAB_AVX2_FMA [[gnu::flatten]] uint32_t Bvh::packet8_fast(const Ray* rays, int n, Hit* hits, uint8_t* out,
                                                            TraversalStats* lanes) const {
  return packet_walk<FastAvx8, kClosest, true, kCount>(rays, n, hits, out, lanes);
}

// The instance of the contract, the triangle test, the width and counting (`lanes`: ray r's counters,
// or null). Counted packets keep every ray on its own order.
template <bool kClosest>
uint32_t Bvh::packet(const Ray* rays, int n, Hit* hits, uint8_t* out, TraversalStats* lanes) const {
  if (lanes) {
    if (settings_.contract == Contract::Fast) {
      if (width_ == 8) return packet8_fast<kClosest, true>(rays, n, hits, out, lanes);
      return packet_walk<FastSse4, kClosest, true, true>(rays, n, hits, out, lanes);
    }
    if (width_ == 8) return packet8<kClosest, true, true>(rays, n, hits, out, lanes);
    return packet_walk<Sse4, kClosest, true, true>(rays, n, hits, out, lanes);
  }
  if (settings_.contract == Contract::Fast) {
    if (width_ == 8) return packet8_fast<kClosest, false>(rays, n, hits, out, nullptr);
    return packet_walk<FastSse4, kClosest, true, false>(rays, n, hits, out, nullptr);
  }
  if (settings_.triangle_test != TriangleTest::Watertight) {
    if (width_ == 8) return packet8<kClosest, true, false>(rays, n, hits, out, nullptr);
    return packet_walk<Sse4, kClosest, true, false>(rays, n, hits, out, nullptr);
  }
  if (width_ == 8) return packet8<kClosest, false, false>(rays, n, hits, out, nullptr);
  return packet_walk<Sse4, kClosest, false, false>(rays, n, hits, out, nullptr);
}

// One packet; hits[r] is a default Hit on a miss. `lanes`: the rays' own counters, or null.
template <bool kClosest>
void Bvh::trace_packet(const Ray* rays, int n, Hit* hits, uint8_t* out, PacketCounts* counts,
                       TraversalStats* lanes) const {
  Hit packet_hits[kPacketSize];
  uint8_t found[kPacketSize];
  const uint32_t left = packet<kClosest>(rays, n, packet_hits, found, lanes);
  if (counts) {
    ++counts->packets;
    counts->packet_rays += size_t(n);
    counts->evicted += size_t(std::popcount(left));
  }
  for (int r = 0; r < n; ++r) {
    if constexpr (kClosest) hits[r] = found[r] ? packet_hits[r] : Hit{};
    else out[r] = found[r];
  }
}

// A run of rays: each coherent group (bvh.h) as a packet, the other rays alone. `per_ray`: each ray's
// counters, or null.
template <bool kClosest>
void Bvh::trace_batch(std::span<const Ray> rays, Hit* hits, uint8_t* out, PacketCounts* counts,
                      TraversalStats* per_ray) const {
  const float spread =
      kPacketOriginSpread * glm::length(root_bounds_.empty() ? glm::vec3(0.0f) : root_bounds_.hi - root_bounds_.lo);
  const float origin_limit = spread * spread;
  for (size_t i = 0; i < rays.size();) {
    const Coherence group(rays[i], origin_limit);
    size_t n = 1;
    bool first_usable;  // a NaN makes takes() false, even of the first ray
    if (i + kPacketSize <= rays.size()) {
      const uint32_t takes = group.takes8(&rays[i]);
      n += size_t(std::countr_one(takes >> 1));
      first_usable = takes & 1;
    } else {
      while (n < size_t(kPacketSize) && i + n < rays.size() && group.takes(rays[i + n])) ++n;
      first_usable = group.takes(rays[i]);
    }
    if (n >= size_t(kMinPacket) && first_usable) {
      trace_packet<kClosest>(&rays[i], int(n), kClosest ? &hits[i] : nullptr, kClosest ? nullptr : &out[i], counts,
                             per_ray ? &per_ray[i] : nullptr);
      i += n;
      continue;
    }
    if constexpr (kClosest) {
      Hit h;
      if (per_ray) closest(rays[i], h, per_ray[i]);
      else closest(rays[i], h);
      hits[i] = h;
    } else {
      out[i] = per_ray ? any(rays[i], per_ray[i]) : any(rays[i]);
    }
    if (counts) ++counts->single_rays;
    ++i;
  }
}

}  // namespace raylab
