// The fast contract's kernels (contract.h): Embree's default tests, for measuring what exactness costs.
// The slab test on origin x reciprocal with one fused multiply-add per plane, unpadded and unwidened; a
// zero direction component gets the reciprocal 2^60 instead of infinity (Embree's rcp_safe), so no slab
// distance is NaN for a ray inside the slab. The triangle test is Möller–Trumbore on precomputed edges
// (a packet under this contract holds v0, e1 = v1 - v0 and e2 = v2 - v0: write_packet_lane), four
// triangles at a time with SSE and eight with AVX2 and FMA, as Embree's Triangle4 and Triangle8 are.
// No double precision and no error bounds: a ray through a shared edge or vertex may miss both
// triangles, a grazing ray may hit off its triangle, and a box may cull a hit that lies on its face.
//
// Unlike Embree's, the triangle test works at every scale the coordinate limit accepts: its products
// are cubes of the coordinates, which overflow float beyond meshes of about 1e12 and fall into
// denormals (or flush to zero) below about 1e-13. So the packets and each ray's origin and interval
// are scaled by the power of two that brings the mesh's extent into [1, 2) (fast_contract_scale), and
// the t found is scaled back: exact operations, so a mesh of ordinary size gets the bits it would
// unscaled.
#pragma once

#include "box_intersection.h"
#include "bvh_simd.h"
#include "raylab/contract.h"
#include "raylab/triangle_packets.h"

#include "raylab/simd.h"

#include <algorithm>
#include <cmath>

namespace raylab {

// The reciprocal a zero direction component gets (effective_direction makes tiny components +0).
inline constexpr float kFastLargeReciprocal = 0x1p60f;

// The power of two the fast contract's triangle test scales a mesh of these bounds by: its largest
// extent into [1, 2); 1 for an empty or one-point mesh.
inline float fast_contract_scale(const Bounds& mesh_bounds) {
  const glm::vec3 extent = mesh_bounds.hi - mesh_bounds.lo;
  const float largest = std::max({extent.x, extent.y, extent.z});
  if (!(largest > 0.0f) || !std::isfinite(largest)) return 1.0f;
  return std::ldexp(1.0f, std::clamp(-std::ilogb(largest), -126, 126));
}

// Writes one triangle into lane `lane` of a packet as the contract's kernels read it: its corners
// (exact), or v0, e1 and e2 times `fast_scale` (fast_contract_scale).
inline void write_packet_lane(TrianglePacket& packet, int lane, Contract contract, float fast_scale,
                              const glm::vec3& v0, const glm::vec3& v1, const glm::vec3& v2) {
  const bool edges = contract == Contract::Fast;
  const float scale = edges ? fast_scale : 1.0f;
  const glm::vec3 corners[3] = {v0 * scale, (edges ? v1 - v0 : v1) * scale, (edges ? v2 - v0 : v2) * scale};
  for (int c = 0; c < 3; ++c)
    for (int a = 0; a < 3; ++a) packet.p[c][a][lane] = corners[c][a];
}

// The per-ray constants of the fast slab test, from the exact test's BoxRay (its pad is not used).
struct FastBoxRay {
  float rdir[3], org_rdir[3];
  float tmin;

  [[gnu::always_inline]] explicit FastBoxRay(const BoxRay& r) : tmin(r.tmin) {
    for (int a = 0; a < 3; ++a) {
      rdir[a] = std::isinf(r.inv_dir[a]) ? kFastLargeReciprocal : r.inv_dir[a];
      org_rdir[a] = r.origin[a] * rdir[a];
    }
  }
};

struct FastBox4Ray {
  __m128 rdir[3], org_rdir[3], tmin;
  explicit FastBox4Ray(const BoxRay& box_ray) {
    const FastBoxRay r(box_ray);
    for (int a = 0; a < 3; ++a) {
      rdir[a] = _mm_set1_ps(r.rdir[a]);
      org_rdir[a] = _mm_set1_ps(r.org_rdir[a]);
    }
    tmin = _mm_set1_ps(r.tmin);
  }
};

// Four boxes (SSE, no FMA in the x86-64-v2 floor: a product and a difference).
inline int fast_box4(const Bvh4Node& node, const FastBox4Ray& r, float tmax, __m128& t_entry) {
  __m128 t_near = r.tmin, t_far = _mm_set1_ps(tmax);
  for (int a = 0; a < 3; ++a) {
    const __m128 t0 = _mm_sub_ps(_mm_mul_ps(_mm_load_ps(node.lo[a]), r.rdir[a]), r.org_rdir[a]);
    const __m128 t1 = _mm_sub_ps(_mm_mul_ps(_mm_load_ps(node.hi[a]), r.rdir[a]), r.org_rdir[a]);
    t_near = _mm_max_ps(t_near, _mm_min_ps(t0, t1));
    t_far = _mm_min_ps(t_far, _mm_max_ps(t0, t1));
  }
  t_entry = t_near;
  const __m128i unused =
      _mm_cmpeq_epi32(_mm_load_si128(reinterpret_cast<const __m128i*>(node.child)), _mm_set1_epi32(int(kInvalidIndex)));
  return _mm_movemask_ps(_mm_andnot_ps(_mm_castsi128_ps(unused), _mm_cmple_ps(t_near, t_far)));
}

struct FastBox8Ray {
  __m256 rdir[3], org_rdir[3], tmin;
  RAYLAB_AVX2_FMA explicit FastBox8Ray(const BoxRay& box_ray) {
    const FastBoxRay r(box_ray);
    for (int a = 0; a < 3; ++a) {
      rdir[a] = _mm256_set1_ps(r.rdir[a]);
      org_rdir[a] = _mm256_set1_ps(r.org_rdir[a]);
    }
    tmin = _mm256_set1_ps(r.tmin);
  }
};

// Eight boxes: one FMA per plane.
RAYLAB_AVX2_FMA inline int fast_box8(const Bvh8Node& node, const FastBox8Ray& r, float tmax, float t_entry[8]) {
  __m256 t_near = r.tmin, t_far = _mm256_set1_ps(tmax);
  for (int a = 0; a < 3; ++a) {
    const __m256 t0 = _mm256_fmsub_ps(_mm256_load_ps(node.lo[a]), r.rdir[a], r.org_rdir[a]);
    const __m256 t1 = _mm256_fmsub_ps(_mm256_load_ps(node.hi[a]), r.rdir[a], r.org_rdir[a]);
    t_near = _mm256_max_ps(t_near, _mm256_min_ps(t0, t1));
    t_far = _mm256_min_ps(t_far, _mm256_max_ps(t0, t1));
  }
  _mm256_storeu_ps(t_entry, t_near);
  const __m256i unused = _mm256_cmpeq_epi32(_mm256_load_si256(reinterpret_cast<const __m256i*>(node.child)),
                                            _mm256_set1_epi32(int(kInvalidIndex)));
  return _mm256_movemask_ps(_mm256_andnot_ps(_mm256_castsi256_ps(unused), _mm256_cmp_ps(t_near, t_far, _CMP_LE_OQ)));
}

// The per-ray constants of the fast triangle test: the origin in the packets' scale
// (fast_contract_scale), the (effective) direction, and the scale to bring an interval in and a t back.
struct FastTriangle4Ray {
  __m128 org[3], dir[3];
  float scale, unscale;
  FastTriangle4Ray(const glm::vec3& origin, const glm::vec3& direction, float scale)
      : scale(scale), unscale(1.0f / scale) {
    for (int a = 0; a < 3; ++a) {
      org[a] = _mm_set1_ps(origin[a] * scale);
      dir[a] = _mm_set1_ps(direction[a]);
    }
  }
};

// Möller–Trumbore in Embree's arrangement: with T = o - v0, the geometric normal N = e1 x e2 and
// R = T x d, the determinant is -d.N and the unnormalised t, u, v are T.N, R.e2 and -R.e1; each is
// compared against the determinant before the one division, which only a lane that hits pays.
// Returns the mask of lanes among `lanes` hit with tmin < t <= tmax (t finite) and their t, u, v;
// kAny: only the first such lane, and no t, u, v. Both decide by the same t (the division's), so
// that closest and any hit never disagree.
template <bool kAny = false>
inline int intersect_fast4(const FastTriangle4Ray& r, const TrianglePacket& packet, int lanes, float tmin, float tmax,
                           float* t_out, float* u_out, float* v_out) {
  __m128 v0[3], e1[3], e2[3], tv[3];
  for (int a = 0; a < 3; ++a) {
    v0[a] = _mm_load_ps(packet.p[0][a]);
    e1[a] = _mm_load_ps(packet.p[1][a]);
    e2[a] = _mm_load_ps(packet.p[2][a]);
    tv[a] = _mm_sub_ps(r.org[a], v0[a]);
  }
  const auto cross = [](const __m128* x, const __m128* y, int a) {
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    return _mm_sub_ps(_mm_mul_ps(x[b], y[c]), _mm_mul_ps(x[c], y[b]));
  };
  const auto dot = [](const __m128* x, const __m128* y) {
    return _mm_add_ps(_mm_add_ps(_mm_mul_ps(x[0], y[0]), _mm_mul_ps(x[1], y[1])), _mm_mul_ps(x[2], y[2]));
  };
  const __m128 n[3] = {cross(e1, e2, 0), cross(e1, e2, 1), cross(e1, e2, 2)};
  const __m128 rr[3] = {cross(tv, r.dir, 0), cross(tv, r.dir, 1), cross(tv, r.dir, 2)};
  const __m128 sign_mask = _mm_set1_ps(-0.0f);
  const __m128 den = _mm_xor_ps(dot(r.dir, n), sign_mask);
  const __m128 sign = _mm_and_ps(den, sign_mask);
  const __m128 abs_den = _mm_andnot_ps(sign_mask, den);
  const __m128 u = _mm_xor_ps(dot(rr, e2), sign);
  const __m128 v = _mm_xor_ps(_mm_xor_ps(dot(rr, e1), sign_mask), sign);
  const __m128 t = _mm_xor_ps(dot(tv, n), sign);
  const __m128 zero = _mm_setzero_ps();
  __m128 valid = _mm_and_ps(_mm_cmpgt_ps(abs_den, zero), _mm_and_ps(_mm_cmpge_ps(u, zero), _mm_cmpge_ps(v, zero)));
  valid = _mm_and_ps(valid, _mm_cmple_ps(_mm_add_ps(u, v), abs_den));
  valid = _mm_and_ps(valid, _mm_and_ps(_mm_cmpgt_ps(t, _mm_mul_ps(abs_den, _mm_set1_ps(tmin * r.scale))),
                                       _mm_cmple_ps(t, _mm_mul_ps(abs_den, _mm_set1_ps(tmax * r.scale)))));
  int mask = _mm_movemask_ps(valid) & lanes;
  if (mask == 0) return 0;
  const __m128 inv = _mm_div_ps(_mm_set1_ps(1.0f), abs_den);
  const __m128 th = _mm_mul_ps(_mm_mul_ps(t, inv), _mm_set1_ps(r.unscale));
  // The division can round t past tmax or to infinity: the range holds for the t reported.
  const __m128 in_range =
      _mm_and_ps(_mm_and_ps(_mm_cmpgt_ps(th, _mm_set1_ps(tmin)), _mm_cmple_ps(th, _mm_set1_ps(tmax))),
                 _mm_cmplt_ps(th, _mm_set1_ps(kInfinity)));
  mask &= _mm_movemask_ps(in_range);
  if constexpr (kAny) return mask & -mask;
  _mm_storeu_ps(t_out, th);
  _mm_storeu_ps(u_out, _mm_mul_ps(u, inv));
  _mm_storeu_ps(v_out, _mm_mul_ps(v, inv));
  return mask;
}

struct FastTriangle8Ray {
  __m256 org[3], dir[3];
  float scale, unscale;
  RAYLAB_AVX2_FMA FastTriangle8Ray(const glm::vec3& origin, const glm::vec3& direction, float scale)
      : scale(scale), unscale(1.0f / scale) {
    for (int a = 0; a < 3; ++a) {
      org[a] = _mm256_set1_ps(origin[a] * scale);
      dir[a] = _mm256_set1_ps(direction[a]);
    }
  }
};

// Lambdas do not take their function's target: intersect_fast8's helpers.
RAYLAB_AVX2_FMA inline __m256 fast8_row(const TrianglePacket& a, const TrianglePacket& b, int corner, int axis) {
  return _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(a.p[corner][axis])), _mm_load_ps(b.p[corner][axis]),
                              1);
}
RAYLAB_AVX2_FMA inline __m256 fast8_cross(const __m256* x, const __m256* y, int k) {
  const int i = (k + 1) % 3, j = (k + 2) % 3;
  return _mm256_fmsub_ps(x[i], y[j], _mm256_mul_ps(x[j], y[i]));
}
RAYLAB_AVX2_FMA inline __m256 fast8_dot(const __m256* x, const __m256* y) {
  return _mm256_fmadd_ps(x[2], y[2], _mm256_fmadd_ps(x[1], y[1], _mm256_mul_ps(x[0], y[0])));
}

// intersect_fast4 on two packets at once (lanes 0-3 `a`'s, 4-7 `b`'s), with FMA.
template <bool kAny = false>
RAYLAB_AVX2_FMA inline int intersect_fast8(const FastTriangle8Ray& r, const TrianglePacket& a, const TrianglePacket& b,
                                           int lanes, float tmin, float tmax, float* t_out, float* u_out,
                                           float* v_out) {
  __m256 e1[3], e2[3], tv[3];
  for (int x = 0; x < 3; ++x) {
    e1[x] = fast8_row(a, b, 1, x);
    e2[x] = fast8_row(a, b, 2, x);
    tv[x] = _mm256_sub_ps(r.org[x], fast8_row(a, b, 0, x));
  }
  const auto cross = fast8_cross;
  const auto dot = fast8_dot;
  const __m256 n[3] = {cross(e1, e2, 0), cross(e1, e2, 1), cross(e1, e2, 2)};
  const __m256 rr[3] = {cross(tv, r.dir, 0), cross(tv, r.dir, 1), cross(tv, r.dir, 2)};
  const __m256 sign_mask = _mm256_set1_ps(-0.0f);
  const __m256 den = _mm256_xor_ps(dot(r.dir, n), sign_mask);
  const __m256 sign = _mm256_and_ps(den, sign_mask);
  const __m256 abs_den = _mm256_andnot_ps(sign_mask, den);
  const __m256 u = _mm256_xor_ps(dot(rr, e2), sign);
  const __m256 v = _mm256_xor_ps(_mm256_xor_ps(dot(rr, e1), sign_mask), sign);
  const __m256 t = _mm256_xor_ps(dot(tv, n), sign);
  const __m256 zero = _mm256_setzero_ps();
  __m256 valid = _mm256_and_ps(_mm256_cmp_ps(abs_den, zero, _CMP_GT_OQ),
                               _mm256_and_ps(_mm256_cmp_ps(u, zero, _CMP_GE_OQ), _mm256_cmp_ps(v, zero, _CMP_GE_OQ)));
  valid = _mm256_and_ps(valid, _mm256_cmp_ps(_mm256_add_ps(u, v), abs_den, _CMP_LE_OQ));
  valid = _mm256_and_ps(
      valid, _mm256_and_ps(_mm256_cmp_ps(t, _mm256_mul_ps(abs_den, _mm256_set1_ps(tmin * r.scale)), _CMP_GT_OQ),
                           _mm256_cmp_ps(t, _mm256_mul_ps(abs_den, _mm256_set1_ps(tmax * r.scale)), _CMP_LE_OQ)));
  int mask = _mm256_movemask_ps(valid) & lanes;
  if (mask == 0) return 0;
  const __m256 inv = _mm256_div_ps(_mm256_set1_ps(1.0f), abs_den);
  const __m256 th = _mm256_mul_ps(_mm256_mul_ps(t, inv), _mm256_set1_ps(r.unscale));
  const __m256 in_range = _mm256_and_ps(_mm256_and_ps(_mm256_cmp_ps(th, _mm256_set1_ps(tmin), _CMP_GT_OQ),
                                                      _mm256_cmp_ps(th, _mm256_set1_ps(tmax), _CMP_LE_OQ)),
                                        _mm256_cmp_ps(th, _mm256_set1_ps(kInfinity), _CMP_LT_OQ));
  mask &= _mm256_movemask_ps(in_range);
  if constexpr (kAny) return mask & -mask;
  _mm256_storeu_ps(t_out, th);
  _mm256_storeu_ps(u_out, _mm256_mul_ps(u, inv));
  _mm256_storeu_ps(v_out, _mm256_mul_ps(v, inv));
  return mask;
}

// Whether this CPU runs the 8-wide fast kernels (AVX2 and FMA, asked once).
inline bool cpu_has_avx2_fma() {
  static const bool has = RAYLAB_CPU_SUPPORTS("avx2") && RAYLAB_CPU_SUPPORTS("fma");
  return has;
}

}  // namespace raylab
