// `bvh`: a binned SAH hierarchy (bvh_build.h) collapsed into a wide BVH: 8-wide nodes tested with
// AVX2 where the CPU has it, else 4-wide nodes tested with SSE (one binary, x86-64-v2 as the floor;
// bvh_simd.h). Leaves hold triangles in packets of four for the SIMD watertight test, run on one
// packet at a time with SSE and on two with AVX2. Traversal is ordered: the nearest child first, and a
// node is skipped once the closest hit lies before it. The contract (contract.h) chooses the kernels
// of the one walk: the exact ones, or the fast ones (fast_contract.h) on packets of edges.
#pragma once

#include "box_intersection.h"
#include "bvh_simd.h"
#include "fast_contract.h"
#include "raylab/bvh_build.h"
#include "raylab/structure.h"
#include "raylab/tree.h"
#include "raylab/triangle_packets.h"
#include "triangle_loop.h"

#include <algorithm>
#include <bit>
#include <type_traits>

namespace raylab {

class Bvh final : public StructureBase<Bvh> {
 public:
  // The most entries a walk holds: a wide node spans at least one binary level and pushes at most its
  // W children (a packet pushes them all), and a ray that leaves its packet adds one node's children.
  // The collapse opens the largest child box, so most trees need far fewer (the bunny 28), but where
  // boxes tie (zero area: collinear or tiny triangles) it can open one side only and push W - 1 a
  // level (3,000 collinear triangles: 315).
  static constexpr int kStackSize = 8 * kMaxBinaryDepth + 8;

  // width: 8 (AVX2), 4 (SSE) or 0 for the widest this CPU runs; RAYLAB_BVH_WIDTH=4 in the environment
  // makes 0 mean 4 (to measure or test the SSE path on an AVX2 machine). 8 without AVX2 is an error.
  Bvh(MeshPtr mesh, const BuildSettings& settings, int width = 0);
  // Refit (bvh_refit.cpp): `source`'s nodes and leaves over `moved`, the same triangles at new
  // positions; every box is recomputed bottom-up, the packets from the new vertices, the width kept.
  Bvh(const Bvh& source, MeshPtr moved);

  // The tree's SAH cost (bvh_refit.cpp): what the builder minimises, on the wide tree the traversal
  // walks, normalised by the root box's area.
  double sah_cost() const;

  template <class Recorder>
  bool traverse_closest(const Ray& ray, Hit& hit, Recorder& record) const {
    return traverse<true>(ray, &hit, record);
  }

  template <class Recorder>
  bool traverse_any(const Ray& ray, Recorder& record) const {
    return traverse<false>(ray, nullptr, record);
  }

  // Packets (bvh_packets.h): the uncounted batch queries trace a coherent group of up to kPacketSize
  // consecutive rays through the tree at once, every ray with its own box and triangle tests (the
  // single walk's kernels, its own tmax, its own best hit), so every ray gets the hit its own walk
  // finds, bit for bit. The renderer's counted batches (closest_batch_counted, any_batch_counted) trace
  // packets too, each ray counting its own work and kept on its own order; stories walk alone.
  //
  // The coherence rule: a group starts at a ray and takes the next rays while each one's direction
  // lies within about 8 degrees of the first's (d . d0 >= kPacketCosine |d| |d0|) and its origin within
  // kPacketOriginSpread of the root box's diagonal of the first's origin, up to kPacketSize rays; a
  // group of fewer than kMinPacket rays (and any ray with a NaN) walks alone. Camera rays (one origin,
  // neighbouring pixels) and shadow rays from neighbouring hit points to a light form full groups;
  // random rays form none.
  static constexpr int kPacketSize = 8;
  static constexpr int kMinPacket = 2;
  static constexpr float kPacketCosine = 0.99f;
  static constexpr float kPacketOriginSpread = 1.0f / 32.0f;

  // What a batch did (for the tests): groups traced as packets and their rays, rays walked alone, and
  // the packets' rays that left their packet to finish alone (bvh_packets.h).
  struct PacketCounts {
    size_t packets = 0, packet_rays = 0, single_rays = 0, evicted = 0;
  };

  void closest_batch(std::span<const Ray> rays, std::span<Hit> hits) const override {
    closest_batch(rays, hits, nullptr);
  }
  void any_batch(std::span<const Ray> rays, std::span<uint8_t> occluded) const override {
    any_batch(rays, occluded, nullptr);
  }
  // Counted (the renderer's rays): a packet counts each ray's work into its own per_ray[i] as its single
  // walk does, so the packet keeps every ray on its own order (a ray whose order differs leaves it).
  void closest_batch_counted(std::span<const Ray> rays, std::span<Hit> hits,
                             std::span<TraversalStats> per_ray) const override {
    closest_batch(rays, hits, nullptr, per_ray);
  }
  void any_batch_counted(std::span<const Ray> rays, std::span<uint8_t> occluded,
                         std::span<TraversalStats> per_ray) const override {
    any_batch(rays, occluded, nullptr, per_ray);
  }
  // per_ray: one per ray, counted as above; empty: uncounted.
  void closest_batch(std::span<const Ray> rays, std::span<Hit> hits, PacketCounts* counts,
                     std::span<TraversalStats> per_ray = {}) const;
  void any_batch(std::span<const Ray> rays, std::span<uint8_t> occluded, PacketCounts* counts,
                 std::span<TraversalStats> per_ray = {}) const;
  // Whether closest_batch traces packets: only where every ray may take the packet's order (the
  // exact contract's watertight test). Elsewhere (the fast contract, Möller–Trumbore) a packet keeps
  // each ray on its own order, and so many rays leave it to finish alone that the packets ran slower
  // than single rays (docs/bench/history.md); any_batch always traces packets.
  bool closest_packets() const {
    return settings_.contract == Contract::Exact && settings_.triangle_test == TriangleTest::Watertight;
  }
  // One packet of 1 to kPacketSize rays, coherent or not (the tests' way into the packet walk).
  void closest_packet(std::span<const Ray> rays, std::span<Hit> hits, PacketCounts* counts = nullptr,
                      std::span<TraversalStats> per_ray = {}) const;
  void any_packet(std::span<const Ray> rays, std::span<uint8_t> occluded, PacketCounts* counts = nullptr,
                  std::span<TraversalStats> per_ray = {}) const;
  // The rule above for a group that `first` starts: takes(ray), whether `ray` may join it (first's part
  // computed once); `origin_limit` is kPacketOriginSpread times the root box's diagonal, squared.
  struct Coherence {
    glm::vec3 origin, direction;
    float cone;  // kPacketCosine^2 |d0|^2
    float origin_limit;
    Coherence(const Ray& first, float limit)
        : origin(first.origin),
          direction(first.direction),
          cone(kPacketCosine * kPacketCosine * glm::dot(first.direction, first.direction)),
          origin_limit(limit) {}
    bool takes(const Ray& ray) const {
      const float d = glm::dot(direction, ray.direction);
      const glm::vec3 o = ray.origin - origin;
      return d > 0.0f && d * d >= cone * glm::dot(ray.direction, ray.direction) && glm::dot(o, o) <= origin_limit;
    }
    // takes() of rays[0..8) as bit r (four at a time, the same operations in the same order).
    uint32_t takes8(const Ray* rays) const {
      static_assert(sizeof(Ray) == 32 && offsetof(Ray, direction) == 16);
      uint32_t mask = 0;
      for (int half = 0; half < 2; ++half) {
        const Ray* r = rays + 4 * half;
        // Rows (x, y, z, tmin) and (x, y, z, tmax) of four rays to columns x, y, z.
        const auto columns = [](const float* r0, const float* r1, const float* r2, const float* r3, __m128* c) {
          const __m128 a = _mm_unpacklo_ps(_mm_loadu_ps(r0), _mm_loadu_ps(r1));  // x0 x1 y0 y1
          const __m128 b = _mm_unpacklo_ps(_mm_loadu_ps(r2), _mm_loadu_ps(r3));  // x2 x3 y2 y3
          c[0] = _mm_movelh_ps(a, b);
          c[1] = _mm_movehl_ps(b, a);
          c[2] = _mm_movelh_ps(_mm_unpackhi_ps(_mm_loadu_ps(r0), _mm_loadu_ps(r1)),
                               _mm_unpackhi_ps(_mm_loadu_ps(r2), _mm_loadu_ps(r3)));
        };
        __m128 o[3], d[3];
        columns(&r[0].origin.x, &r[1].origin.x, &r[2].origin.x, &r[3].origin.x, o);
        columns(&r[0].direction.x, &r[1].direction.x, &r[2].direction.x, &r[3].direction.x, d);
        const auto dot = [](__m128 ax, __m128 ay, __m128 az, __m128 bx, __m128 by, __m128 bz) {
          return _mm_add_ps(_mm_add_ps(_mm_mul_ps(ax, bx), _mm_mul_ps(ay, by)), _mm_mul_ps(az, bz));
        };
        const __m128 cos_d =
            dot(_mm_set1_ps(direction.x), _mm_set1_ps(direction.y), _mm_set1_ps(direction.z), d[0], d[1], d[2]);
        const __m128 ox = _mm_sub_ps(o[0], _mm_set1_ps(origin.x)), oy = _mm_sub_ps(o[1], _mm_set1_ps(origin.y)),
                     oz = _mm_sub_ps(o[2], _mm_set1_ps(origin.z));
        const __m128 in_cone =
            _mm_and_ps(_mm_cmpgt_ps(cos_d, _mm_setzero_ps()),
                       _mm_cmpge_ps(_mm_mul_ps(cos_d, cos_d),
                                    _mm_mul_ps(_mm_set1_ps(cone), dot(d[0], d[1], d[2], d[0], d[1], d[2]))));
        const __m128 near = _mm_cmple_ps(dot(ox, oy, oz, ox, oy, oz), _mm_set1_ps(origin_limit));
        mask |= uint32_t(_mm_movemask_ps(_mm_and_ps(in_cone, near))) << (4 * half);
      }
      return mask;
    }
  };

  // Box ids, as in boxes() and the story: node n is id n (0 the root), leaf k (in packet order)
  // is id node_count + k.
  std::vector<BoxInfo> boxes() const override;
  size_t memory_bytes() const override;

  // The tree (raylab/tree.h): the wide tree the traversal walks, and the builder's decision at the
  // binary node atop each wide node.
  StructureTree tree() const;
  SplitCosts split_costs(uint32_t id) const;
  // The triangles under box `id` (a node's subtree, or a leaf), each once, in no particular order.
  std::vector<uint32_t> triangles_of(uint32_t id) const;

  int width() const { return width_; }
  // The nodes of the width built (the other vector is empty).
  const std::vector<Bvh4Node>& nodes() const { return nodes4_; }
  const std::vector<Bvh8Node>& nodes8() const { return nodes8_; }
  std::span<const TrianglePacket> packets() const { return {packets_.get(), packet_count_}; }

 private:
  // 16 bytes; the depth is read only by recorders (dropping it was no faster: docs/bench/history.md).
  struct Entry {
    uint32_t ref;    // node index, or first packet of a leaf
    uint32_t count;  // triangles of a leaf; 0 for a node
    float t_entry;
    int depth;
  };

  // The kernels of one width and contract, as the traversal sees them: `test` tests a node's children;
  // `triangles` the next kLeafLanes triangles of a leaf (`lanes` of them real) from the packets at `p`:
  // one packet with SSE, two with AVX2. A leaf of four triangles or fewer also takes the 8-lane test
  // (its packet in both halves), faster there than the 4-lane test. TriangleRayW holds a ray's
  // constants of the triangle test; the exact ones keep the scalar tester (`tester`) for
  // triangle_test moller_trumbore, which the packets do not run.
  struct ExactTriangles {
    TriangleTester tester;
    explicit ExactTriangles(const Ray& ray, TriangleTest kind, const glm::vec3& d) : tester(ray, kind, d) {}
  };
  template <class W>
  struct ExactTrianglesW : ExactTriangles {
    W w;  // refers to tester.watertight: not copyable
    ExactTrianglesW(const Ray& ray, TriangleTest kind, const glm::vec3& d, float /*fast_scale*/)
        : ExactTriangles(ray, kind, d), w(tester.watertight) {}
    ExactTrianglesW(const ExactTrianglesW&) = delete;
  };
  struct Sse4 {
    using Node = Bvh4Node;
    using BoxRayW = Box4Ray;
    using TriangleRayW = ExactTrianglesW<Watertight4Ray>;
    static constexpr int kLeafLanes = 4;
    static int test(const Node& node, const BoxRayW& r, float tmax, float t[4]) {
      __m128 entry;
      const int mask = intersect_box4(node, r, tmax, entry);
      _mm_storeu_ps(t, entry);
      return mask;
    }
    template <bool kAny>
    static int triangles(const TriangleRayW& r, const TrianglePacket* p, int lanes, float tmin, float tmax, float* t,
                         float* u, float* v) {
      // The unused lanes repeat lane 0's triangle, so an any-hit mask's first lane is a real one.
      return intersect_watertight4<kAny>(r.w, p[0], tmin, tmax, t, u, v) & ((1 << lanes) - 1);
    }
  };
  struct Avx8 {
    using Node = Bvh8Node;
    using BoxRayW = Box8Ray;
    using TriangleRayW = ExactTrianglesW<Watertight8Ray>;
    static constexpr int kLeafLanes = 8;
    RAYLAB_AVX2 static int test(const Node& node, const BoxRayW& r, float tmax, float t[8]) {
      return intersect_box8(node, r, tmax, t);
    }
    template <bool kAny>
    RAYLAB_AVX2 static int triangles(const TriangleRayW& r, const TrianglePacket* p, int lanes, float tmin, float tmax,
                                     float* t, float* u, float* v) {
      return intersect_watertight8<kAny>(r.w, p[0], lanes > 4 ? p[1] : p[0], (1 << lanes) - 1, tmin, tmax, t, u, v);
    }
  };
  template <class R>
  struct FastTriangles {
    R r;
    FastTriangles(const Ray& ray, TriangleTest, const glm::vec3& d, float fast_scale) : r(ray.origin, d, fast_scale) {}
  };
  struct FastSse4 {
    using Node = Bvh4Node;
    using BoxRayW = FastBox4Ray;
    using TriangleRayW = FastTriangles<FastTriangle4Ray>;
    static constexpr int kLeafLanes = 4;
    static int test(const Node& node, const BoxRayW& r, float tmax, float t[4]) {
      __m128 entry;
      const int mask = fast_box4(node, r, tmax, entry);
      _mm_storeu_ps(t, entry);
      return mask;
    }
    template <bool kAny>
    static int triangles(const TriangleRayW& r, const TrianglePacket* p, int lanes, float tmin, float tmax, float* t,
                         float* u, float* v) {
      return intersect_fast4<kAny>(r.r, p[0], (1 << lanes) - 1, tmin, tmax, t, u, v);
    }
  };
  struct FastAvx8 {
    using Node = Bvh8Node;
    using BoxRayW = FastBox8Ray;
    using TriangleRayW = FastTriangles<FastTriangle8Ray>;
    static constexpr int kLeafLanes = 8;
    RAYLAB_AVX2_FMA static int test(const Node& node, const BoxRayW& r, float tmax, float t[8]) {
      return fast_box8(node, r, tmax, t);
    }
    template <bool kAny>
    RAYLAB_AVX2_FMA static int triangles(const TriangleRayW& r, const TrianglePacket* p, int lanes, float tmin,
                                         float tmax, float* t, float* u, float* v) {
      return intersect_fast8<kAny>(r.r, p[0], lanes > 4 ? p[1] : p[0], (1 << lanes) - 1, tmin, tmax, t, u, v);
    }
  };

  template <bool kClosest, class Recorder>
  bool traverse(const Ray& ray, Hit* hit, Recorder& record) const {
    if (settings_.contract == Contract::Fast) {
      if (width_ == 8) return traverse8_fast<kClosest>(ray, hit, record);
      return traverse_wide<FastSse4, kClosest>(ray, hit, record);
    }
    if (width_ == 8) return traverse8<kClosest>(ray, hit, record);
    return traverse_wide<Sse4, kClosest>(ray, hit, record);
  }

  // The AVX2 instance of the one traversal: traverse_wide and everything it calls are inlined here,
  // so the 8-box test is too. Flattened: GCC will not inline an AVX2 kernel into the default-target
  // templates that call it (traverse_wide, packet_walk), only into this function once they are inlined,
  // so without `flatten` LTO's heuristics decided it. When the counted packets added call sites they
  // moved the packet node test and the per-ray setup out of line, and the any-hit packets ran slower
  // (docs/bench/history.md). The packet walks (bvh_packets.h) are flattened alike.
  template <bool kClosest, class Recorder>
  RAYLAB_AVX2 [[gnu::flatten]] bool traverse8(const Ray& ray, Hit* hit, Recorder& record) const {
    return traverse_wide<Avx8, kClosest>(ray, hit, record);
  }
  // The fast contract's, with FMA (which the exact instance must not have: its lanes round as the
  // scalar tests do).
  template <bool kClosest, class Recorder>
  RAYLAB_AVX2_FMA [[gnu::flatten]] bool traverse8_fast(const Ray& ray, Hit* hit, Recorder& record) const {
    return traverse_wide<FastAvx8, kClosest>(ray, hit, record);
  }

  template <class Width>
  const std::vector<typename Width::Node>& wide_nodes() const {
    if constexpr (Width::kLeafLanes == 8) return nodes8_;
    else return nodes4_;
  }

  // One loop for both queries and both widths: closest hit prunes entries beyond the best hit so far;
  // any hit stops at the first triangle hit.
  // Where its instructions go against Embree's, and what was tried and not kept: docs/bench/history.md.
  template <class Width, bool kClosest, class Recorder>
  [[gnu::always_inline]] bool traverse_wide(const Ray& ray, Hit* hit, Recorder& record) const {
    record.ray();
    const glm::vec3 direction = effective_direction(ray.direction);  // once for both tests
    const BoxRay box_ray(ray, direction, root_bounds_);
    const typename Width::BoxRayW boxw(box_ray);
    Entry stack[kStackSize];
    int size = 0;
    Entry e;
    bool descending = false;  // e is the nearest child of the node just visited, not yet on the stack
    if constexpr (Recorder::kActive) {
      if (!enter_root(box_ray, record, stack, size)) return false;
    } else {
      // Unrecorded, the root box is not tested: its children's (padded alike) lie inside it, so a ray
      // that misses it misses them all, and its entry distance prunes nothing the ray's tmin does not.
      // The root node's children are tested before the triangle test's setup, which a miss skips.
      if (node_count() == 0) return false;
      e = {0, 0, ray.tmin, 0};
      if (!visit_children<Width, kClosest>(e, boxw, ray.tmax, record, stack, size)) return false;
      descending = true;
    }
    const typename Width::TriangleRayW triw(ray, settings_.triangle_test, direction, fast_scale_);
    Hit best = initial_hit(ray);
    bool found = false;
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
        descending = visit_children<Width, kClosest>(e, boxw, kClosest ? best.t : ray.tmax, record, stack, size);
      } else if constexpr (kClosest) {
        found |= closest_in_leaf<Width>(triw, ray, e, best, record);
      } else if (any_in_leaf<Width>(triw, ray, e, record)) {
        return true;
      }
    }
    if (found) *hit = best;
    return found;
  }

  // The packet walk (bvh_packets.h) and its instances. kSameOrder: a ray whose own order of a node's
  // children differs from the packet's leaves the packet there and finishes its walk alone.
  struct alignas(32) PacketEntry {
    float t_entry[kPacketSize];  // ray r's entry distance
    uint32_t ref, count;
    uint32_t rays;  // the rays that entered this node, bit r for ray r
  };
  // kCount: each ray counts its own work into lanes[r] (StatsRecord), as its single walk would.
  template <class Width, bool kClosest, bool kSameOrder, bool kCount>
  uint32_t packet_walk(const Ray* rays, int n, Hit* hits, uint8_t* out, TraversalStats* lanes) const;
  template <class Width, class Recorder>
  bool finish_alone(const Ray& ray, const glm::vec3& direction, const typename Width::TriangleRayW& triw,
                    const PacketEntry* packet_stack, int packet_size, int r, const Entry* children, int count,
                    Hit& best, Recorder& record) const;
  template <bool kClosest, bool kSameOrder, bool kCount>
  RAYLAB_AVX2 uint32_t packet8(const Ray* rays, int n, Hit* hits, uint8_t* out, TraversalStats* lanes) const;
  template <bool kClosest, bool kCount>
  RAYLAB_AVX2_FMA uint32_t packet8_fast(const Ray* rays, int n, Hit* hits, uint8_t* out, TraversalStats* lanes) const;
  template <bool kClosest>
  uint32_t packet(const Ray* rays, int n, Hit* hits, uint8_t* out, TraversalStats* lanes) const;
  template <bool kClosest>
  void trace_packet(const Ray* rays, int n, Hit* hits, uint8_t* out, PacketCounts* counts, TraversalStats* lanes) const;
  template <bool kClosest>
  void trace_batch(std::span<const Ray> rays, Hit* hits, uint8_t* out, PacketCounts* counts,
                   TraversalStats* per_ray) const;

  uint32_t leaf_id(uint32_t first_packet) const {
    return uint32_t(node_count() + (std::lower_bound(leaf_packets_.begin(), leaf_packets_.end(), first_packet) -
                                    leaf_packets_.begin()));
  }

  template <class Recorder>
  void record_node(const Entry& e, Recorder& record) const {
    // A leaf's id is a search (leaf_id): only for a recorder that reads it (a story). Counting alone
    // skips it: it was a large part of a counted render's samples (docs/bench/history.md).
    if constexpr (Recorder::kActive) record.node(Recorder::kIds && e.count != 0 ? leaf_id(e.ref) : e.ref, e.depth);
  }

  template <class Recorder>
  bool enter_root(const BoxRay& box_ray, Recorder& record, Entry* stack, int& size) const {
    float t_entry;
    if (!raylab::enter_root(root_bounds_, node_count() != 0, box_ray, box_ray.tmax, record, t_entry)) return false;
    stack[size++] = {0, 0, t_entry, 0};
    return true;
  }

  // Tests the children of node `e` and replaces `e` with the child to visit next, returning false
  // when no child is hit. The other children hit go on the stack; `Ordered` puts the nearest child in
  // `e` and pushes the rest farthest first. A lone hit child, the common case, skips the stack.
  // Ordered by the entry distances the box test computes anyway, not by the ray's direction signs.
  // Per-octant child tables, ordered any hit, sign-chosen planes and prefetching every child measured
  // slower (docs/bench/history.md).
  template <class Width, bool Ordered, class Recorder>
  [[gnu::always_inline]] bool visit_children(Entry& e, const typename Width::BoxRayW& boxw, float tmax,
                                             Recorder& record, Entry* stack, int& size) const {
    using Node = typename Width::Node;
    const Node& node = wide_nodes<Width>()[e.ref];
    alignas(32) float t[Node::kWidth];
    int mask = Width::test(node, boxw, tmax, t);
    if constexpr (Recorder::kActive) {
      for (int i = 0; i < Node::kWidth; ++i)
        if (node.used(i))
          record.box(Recorder::kIds && node.leaf(i) ? leaf_id(node.child[i]) : node.child[i], node.bounds(i),
                     e.depth + 1, (mask >> i) & 1, t[i]);
    }
    if (mask == 0) return false;
    const int depth = e.depth + 1;
    if ((mask & (mask - 1)) == 0) {
      const int i = std::countr_zero(unsigned(mask));
      e = {node.child[i], node.count[i], t[i], depth};
      prefetch<Width>(e);
      return true;
    }
    const int first = size;
    for (; mask != 0; mask &= mask - 1) {
      const int i = std::countr_zero(unsigned(mask));
      Entry c{node.child[i], node.count[i], t[i], depth};
      prefetch<Width>(c);
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
  // always_inline because GCC 12 otherwise emitted no prefetch at all in the AVX2 walk: this function
  // (default target) was not inlined into traverse8 (target "avx2") early, its only effect,
  // __builtin_prefetch, made it look const, and the calls were deleted as dead code. With the
  // prefetches back the walk is faster on large meshes (docs/bench/history.md).
  // A leaf is loaded whole, up to the two packets the 8-lane test reads first (160 bytes each, 16-byte
  // aligned: up to six cache lines). Prefetching only its first two lines left the 8-lane test
  // waiting on its second packet (docs/bench/history.md).
  template <class Width>
  [[gnu::always_inline]] void prefetch(const Entry& e) const {
    if (e.count != 0) {
      // One packet is 160 bytes (three or four lines), two are 320 (five or six): unrolled, the
      // second packet's lines only when the leaf has one, and the node's size known from the width.
      const char* p = reinterpret_cast<const char*>(&packets_[e.ref]);
      _mm_prefetch(p, _MM_HINT_T0);
      _mm_prefetch(p + 64, _MM_HINT_T0);
      _mm_prefetch(p + 128, _MM_HINT_T0);
      _mm_prefetch(p + sizeof(TrianglePacket) - 1, _MM_HINT_T0);
      if (e.count > 4) {
        _mm_prefetch(p + 192, _MM_HINT_T0);
        _mm_prefetch(p + 256, _MM_HINT_T0);
        _mm_prefetch(p + 2 * sizeof(TrianglePacket) - 1, _MM_HINT_T0);
      }
      return;
    }
    const char* p = reinterpret_cast<const char*>(&wide_nodes<Width>()[e.ref]);
    for (size_t offset = 0; offset < sizeof(typename Width::Node); offset += 64) _mm_prefetch(p + offset, _MM_HINT_T0);
  }

  uint32_t triangle_at(const Entry& leaf, uint32_t i) const { return packets_[leaf.ref + i / 4].triangle[i % 4]; }

  // The leaf's triangles kLeafLanes at a time, recorded in leaf order as the scalar loop would.
  template <class Width, class Recorder>
  [[gnu::always_inline]] bool closest_in_leaf(const typename Width::TriangleRayW& triw, const Ray& ray,
                                              const Entry& leaf, Hit& best, Recorder& record) const {
    if constexpr (std::is_base_of_v<ExactTriangles, typename Width::TriangleRayW>)
      if (triw.tester.test != TriangleTest::Watertight)
        return closest_in_triangles(
            *mesh_, triw.tester, leaf.count, [&](uint32_t i) { return triangle_at(leaf, i); }, best, record);
    bool found = false;
    for (uint32_t first = 0; first < leaf.count; first += Width::kLeafLanes) {
      const TrianglePacket* p = &packets_[leaf.ref + first / 4];
      const int lanes = int(std::min(uint32_t(Width::kLeafLanes), leaf.count - first));
      alignas(32) float t[8], u[8], v[8];
      const int mask = Width::template triangles<false>(triw, p, lanes, ray.tmin, best.t, t, u, v);
      found |= take_closest_lanes(p, lanes, mask, t, u, v, record, best);
    }
    return found;
  }

  template <class Width, class Recorder>
  [[gnu::always_inline]] bool any_in_leaf(const typename Width::TriangleRayW& triw, const Ray& ray, const Entry& leaf,
                                          Recorder& record) const {
    if constexpr (std::is_base_of_v<ExactTriangles, typename Width::TriangleRayW>)
      if (triw.tester.test != TriangleTest::Watertight)
        return any_in_triangles(
            *mesh_, triw.tester, leaf.count, [&](uint32_t i) { return triangle_at(leaf, i); }, ray.tmax, record);
    for (uint32_t first = 0; first < leaf.count; first += Width::kLeafLanes) {
      const TrianglePacket* p = &packets_[leaf.ref + first / 4];
      const int lanes = int(std::min(uint32_t(Width::kLeafLanes), leaf.count - first));
      alignas(32) float t[8], u[8], v[8];
      const int mask = Width::template triangles<true>(triw, p, lanes, ray.tmin, ray.tmax, t, u, v);
      if (record_any_lanes(p, lanes, mask, record)) return true;
    }
    return false;
  }

  size_t node_count() const { return width_ == 8 ? nodes8_.size() : nodes4_.size(); }

  Bounds root_bounds_;
  float fast_scale_ = 1.0f;  // the fast contract's packets and rays: fast_contract_scale of the mesh
  int width_ = 4;
  // One of the two, by width_. On 4 KiB pages: huge pages were no faster, page walks are not what the
  // node loads wait on.
  std::vector<Bvh4Node> nodes4_;
  std::vector<Bvh8Node> nodes8_;
  HugeArray<TrianglePacket> packets_;
  size_t packet_count_ = 0;
  std::vector<uint32_t> leaf_packets_;  // first packet of each leaf, increasing: leaf k's id
  std::vector<uint8_t> binary_depth_;   // per box id, the depth of its binary node in the build (split_costs)
};

std::unique_ptr<Structure> build_bvh(MeshPtr mesh, const BuildSettings& settings);
// StructureInfo::refit of the bvh (bvh_refit.cpp): `source` must be a Bvh over moved's triangles.
std::unique_ptr<Structure> refit_bvh(const Structure& source, MeshPtr moved);

}  // namespace raylab
