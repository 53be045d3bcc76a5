// The SIMD box kernels of the wide BVH: one ray against four boxes (SSE) or eight (AVX2) at once. The
// box kernel is a lane-wise transcription of intersect_box with the same NaN handling and the same
// result bit for bit (the far widening applied once to the minimum, which rounds the same). Its leaves'
// triangle packets are triangle_packets.h.
#pragma once

#include "box_intersection.h"

#include "raylab/simd.h"

#include <cstdint>

namespace raylab {

// The children of a W-wide node (4: 128 bytes, two cache lines; 8: 256 bytes, four). A leaf child
// has count > 0 and its triangles in packets[child .. child + ceil(count / 4)); an inner child has
// count 0 and its node index in `child`. Unused slots have count 0 and child kInvalidIndex; no box
// value is missed by every ray under IEEE rules (a ray with tmax = inf reaches +inf), so the test
// masks them out. Bounds are plain floats, not quantised: a quantised node, half the size, was slower
// on trees that fit the cache and gained only on trees far beyond it (docs/bench/history.md).
template <int W>
struct alignas(64) BvhWideNode {
  static constexpr int kWidth = W;
  float lo[3][W];  // [axis][child]
  float hi[3][W];
  uint32_t child[W];
  uint32_t count[W];

  bool used(int i) const { return count[i] != 0 || child[i] != kInvalidIndex; }
  bool leaf(int i) const { return count[i] != 0; }
  Bounds bounds(int i) const { return {{lo[0][i], lo[1][i], lo[2][i]}, {hi[0][i], hi[1][i], hi[2][i]}}; }
};
using Bvh4Node = BvhWideNode<4>;
using Bvh8Node = BvhWideNode<8>;
static_assert(sizeof(Bvh4Node) == 128);
static_assert(sizeof(Bvh8Node) == 256);

// The per-ray constants of the 4-box test.
struct Box4Ray {
  __m128 origin[3], inv_dir[3];
  __m128 tmin, pad;

  explicit Box4Ray(const BoxRay& r) : tmin(_mm_set1_ps(r.tmin)), pad(_mm_set1_ps(r.pad)) {
    for (int a = 0; a < 3; ++a) {
      origin[a] = _mm_set1_ps(r.origin[a]);
      inv_dir[a] = _mm_set1_ps(r.inv_dir[a]);
    }
  }
};

// intersect_box on four boxes: returns the hit mask (bit i for child i, used slots only) and the
// entry distances.
// _mm_min_ps(a, b) is `a < b ? a : b` and _mm_max_ps(a, b) is `a > b ? a : b`, NaN giving b: exactly
// the scalar swaps and selections, so NaN slab distances are ignored the same way.
inline int intersect_box4(const Bvh4Node& node, const Box4Ray& r, float tmax, __m128& t_entry) {
  __m128 t_near = r.tmin;
  __m128 t_far = _mm_set1_ps(kInfinity);  // unscaled; see intersect_box8
  for (int a = 0; a < 3; ++a) {
    const __m128 t0 = _mm_mul_ps(_mm_sub_ps(_mm_sub_ps(_mm_load_ps(node.lo[a]), r.origin[a]), r.pad), r.inv_dir[a]);
    const __m128 t1 = _mm_mul_ps(_mm_add_ps(_mm_sub_ps(_mm_load_ps(node.hi[a]), r.origin[a]), r.pad), r.inv_dir[a]);
    const __m128 near = _mm_min_ps(t1, t0);
    const __m128 far = _mm_max_ps(t0, t1);
    t_near = _mm_max_ps(near, t_near);
    t_far = _mm_min_ps(far, t_far);
  }
  t_far = _mm_min_ps(_mm_mul_ps(t_far, _mm_set1_ps(kBoxFarScale)), _mm_set1_ps(tmax));
  t_entry = t_near;
  const __m128i unused =
      _mm_cmpeq_epi32(_mm_load_si128(reinterpret_cast<const __m128i*>(node.child)), _mm_set1_epi32(int(kInvalidIndex)));
  return _mm_movemask_ps(_mm_andnot_ps(_mm_castsi128_ps(unused), _mm_cmple_ps(t_near, t_far)));
}

// The 8-wide node test (AVX2), chosen at run time where the CPU has AVX2 (cpu_has_avx2): the binary
// stays x86-64-v2. Only "avx2", never "fma": with FMA enabled GCC may contract a product and a sum
// into one rounding (-ffp-contract=fast is its default), and every lane must round as the scalar
// test does.
// Embree's form, one FMA per slab with a pad widened for its rounding, visited the same nodes but was
// no faster (docs/bench/history.md): the test waits on the node's load, not on arithmetic.
struct Box8Ray {
  __m256 origin[3], inv_dir[3];
  __m256 tmin, pad;

  RAYLAB_AVX2 explicit Box8Ray(const BoxRay& r) : tmin(_mm256_set1_ps(r.tmin)), pad(_mm256_set1_ps(r.pad)) {
    for (int a = 0; a < 3; ++a) {
      origin[a] = _mm256_set1_ps(r.origin[a]);
      inv_dir[a] = _mm256_set1_ps(r.inv_dir[a]);
    }
  }
};

// intersect_box4 on eight boxes, operation for operation (the AVX min, max and ordered compare treat
// NaN as the SSE ones do). Returns the hit mask and writes the entry distances.
RAYLAB_AVX2 inline int intersect_box8(const Bvh8Node& node, const Box8Ray& r, float tmax, float t_entry[8]) {
  __m256 t_near = r.tmin;
  // The far distances' widening (kBoxFarScale) is applied once, to their minimum, instead of to each
  // axis: x -> x * scale rounds monotonically, so min(x_i) * scale == min(x_i * scale) bit for bit, and
  // a NaN slab distance is skipped by the min as before (t_far starts at +inf, not at a NaN). Two
  // multiplications fewer per node.
  __m256 t_far = _mm256_set1_ps(kInfinity);
  for (int a = 0; a < 3; ++a) {
    const __m256 t0 =
        _mm256_mul_ps(_mm256_sub_ps(_mm256_sub_ps(_mm256_load_ps(node.lo[a]), r.origin[a]), r.pad), r.inv_dir[a]);
    const __m256 t1 =
        _mm256_mul_ps(_mm256_add_ps(_mm256_sub_ps(_mm256_load_ps(node.hi[a]), r.origin[a]), r.pad), r.inv_dir[a]);
    const __m256 near = _mm256_min_ps(t1, t0);
    const __m256 far = _mm256_max_ps(t0, t1);
    t_near = _mm256_max_ps(near, t_near);
    t_far = _mm256_min_ps(far, t_far);
  }
  t_far = _mm256_min_ps(_mm256_mul_ps(t_far, _mm256_set1_ps(kBoxFarScale)), _mm256_set1_ps(tmax));
  _mm256_storeu_ps(t_entry, t_near);
  const __m256i unused = _mm256_cmpeq_epi32(_mm256_load_si256(reinterpret_cast<const __m256i*>(node.child)),
                                            _mm256_set1_epi32(int(kInvalidIndex)));
  return _mm256_movemask_ps(_mm256_andnot_ps(_mm256_castsi256_ps(unused), _mm256_cmp_ps(t_near, t_far, _CMP_LE_OQ)));
}

}  // namespace raylab
