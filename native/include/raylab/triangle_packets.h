// The triangle packets the BVH's and the octree's leaves share: four triangles' vertices, structure of
// arrays, tested against one ray four (SSE) or eight (AVX2) at a time.
// The triangle kernels are intersect_watertight's float filter, and the lanes it cannot reject are
// decided in double precision by the scalar test's decision (exact_lane), or by its lane-wise
// transcription (exact_packet, AVX2). All give bit-identical results: SIMD changes the speed, never the
// answer.
#pragma once

#include "raylab/triangle_intersection.h"

#include "raylab/simd.h"

#include <bit>
#include <cstddef>
#include <cstdint>
#include <type_traits>

namespace raylab {

// Four triangles' vertices, structure of arrays, in leaf order. Unused lanes repeat the packet's
// first triangle and carry kInvalidIndex; the leaf's count says which lanes are real.
struct alignas(16) TrianglePacket {
  float p[3][3][4];  // [corner][axis][lane]
  uint32_t triangle[4];
};
static_assert(sizeof(TrianglePacket) == 160);
// Triangles per packet: the SAH's leaf block (a leaf costs one test per packet), for the BVH's builder,
// sah_cost, Structure.tree() and _raylab.SAH_CONSTANTS.
inline constexpr uint32_t kPacketLanes = std::extent_v<decltype(TrianglePacket::triangle)>;

// The triangle in lane `lane` of a run of consecutive packets (lanes 0-3 the first packet's).
inline uint32_t packet_triangle(const TrianglePacket* packets, int lane) {
  return packets[lane / 4].triangle[lane % 4];
}

// One packet test's hits (`mask`, with their t, u, v) folded into `best` in lane order, as the scalar
// loop folds them (closer(): the nearer t, a tie to the lower triangle index), after every tested lane is
// recorded. The BVH's and the octree's leaves share it, so that their counters and stories agree.
template <class Recorder>
[[gnu::always_inline]] inline bool take_closest_lanes(const TrianglePacket* packets, int lanes, int mask,
                                                      const float* t, const float* u, const float* v, Recorder& record,
                                                      Hit& best) {
  if constexpr (Recorder::kActive)
    for (int lane = 0; lane < lanes; ++lane) record.triangle(packet_triangle(packets, lane), (mask >> lane) & 1);
  bool found = false;
  for (; mask != 0; mask &= mask - 1) {
    const int lane = std::countr_zero(unsigned(mask));
    const uint32_t triangle = packet_triangle(packets, lane);
    if (closer({t[lane], u[lane], v[lane]}, triangle, best)) {
      best.t = t[lane];
      best.u = u[lane];
      best.v = v[lane];
      best.triangle = triangle;
      found = true;
    }
  }
  return found;
}

// An any-hit packet test's lanes recorded as the scalar loop tests them: every triangle up to the first
// hit. Returns whether a lane hit.
template <class Recorder>
[[gnu::always_inline]] inline bool record_any_lanes(const TrianglePacket* packets, int lanes, int mask,
                                                    Recorder& record) {
  if constexpr (Recorder::kActive) {
    const int tested = mask != 0 ? std::countr_zero(unsigned(mask)) + 1 : lanes;
    for (int lane = 0; lane < tested; ++lane) record.triangle(packet_triangle(packets, lane), (mask >> lane) & 1);
  }
  return mask != 0;
}

// Whether this CPU runs the AVX2 kernels (asked once).
inline bool cpu_has_avx2() {
  static const bool has = RAYLAB_CPU_SUPPORTS("avx2");
  return has;
}

// The ray's origin in the shear frame's axis order (kx, ky, kz), and the byte offsets of those axes'
// rows in a TrianglePacket (Watertight4Ray::row): what both SIMD triangle tests take per ray.
inline void shear_frame(const WatertightRay& r, float origin[3], size_t row[3]) {
  const int k[3] = {r.kx, r.ky, r.kz};
  const float o[3] = {r.origin.x, r.origin.y, r.origin.z};  // not glm's operator[], a switch (branches)
  for (int a = 0; a < 3; ++a) {
    origin[a] = o[k[a]];
    row[a] = sizeof(float) * 4 * size_t(k[a]);
  }
}

// The per-ray constants of the 4-triangle watertight test.
struct Watertight4Ray {
  const WatertightRay& ray;
  __m128 origin[3];  // in the shear frame's order: kx, ky, kz
  __m128 sx, sy, sz;
  // Byte offsets in a TrianglePacket of the rows p[0][kx], p[0][ky], p[0][kz] (corner c's lie 48 c
  // bytes further, a constant displacement in the load's address), once per ray: indexed by kx, ky and
  // kz, GCC recomputed nine row addresses on every leaf and kept them on the stack.
  size_t row[3];

  explicit Watertight4Ray(const WatertightRay& r)
      : ray(r), sx(_mm_set1_ps(r.sx)), sy(_mm_set1_ps(r.sy)), sz(_mm_set1_ps(r.sz)) {
    float o[3];
    shear_frame(r, o, row);
    for (int a = 0; a < 3; ++a) origin[a] = _mm_set1_ps(o[a]);
  }
};

// Row `offset` (Watertight4Ray::row) of corner `corner` of a packet: that coordinate of its four triangles.
inline const float* packet_row(const TrianglePacket& p, int corner, size_t offset) {
  return reinterpret_cast<const float*>(reinterpret_cast<const char*>(p.p[corner]) + offset);
}

// The scalar watertight test of triangle `lane` of a packet, the decision every SIMD lane that the
// filters keep ends in; a hit sets bit `out` of the result and slot `out` of t, u, v.
inline int exact_lane(const WatertightRay& ray, const TrianglePacket& packet, int lane, int out, float tmin, float tmax,
                      float* t_out, float* u_out, float* v_out) {
  const glm::vec3 p0(packet.p[0][0][lane], packet.p[0][1][lane], packet.p[0][2][lane]);
  const glm::vec3 p1(packet.p[1][0][lane], packet.p[1][1][lane], packet.p[1][2][lane]);
  const glm::vec3 p2(packet.p[2][0][lane], packet.p[2][1][lane], packet.p[2][2][lane]);
  TriangleHit h;
  if (!intersect_watertight_exact(ray, p0, p1, p2, tmin, tmax, h)) return 0;
  t_out[out] = h.t;
  u_out[out] = h.u;
  v_out[out] = h.v;
  return 1 << out;
}

// Any hit needs no t, u or v, only whether some lane hits, and which lane first (the recorders count
// the triangles tested up to it, as the scalar loop does). A lane is `sure` when the float filter
// proves what the double decision would find: all three edge functions beyond the error bound with
// one sign (so the double ones share it, and the determinant, their sum, exceeds three times the
// bound's 8u(s + 2z)s margin over the error, far above the 2^-24 s^2 plane test), s below 2^60 (no
// product overflowed), and the corners' z range, widened by the pre-check's margins, finite and
// within (tmin, tmax] (t is a convex combination of the corners' z, so it lies there too, as does
// its rounding to float). Lanes before the first sure lane are decided in lane order; the mask
// returned has one bit, the first lane that hits, or none. Faster on any hit than deciding every
// candidate in double (docs/bench/history.md).
template <class Decide>
[[gnu::always_inline]] inline int first_hit_lane(int candidates, int sure, Decide decide) {
  const int first_sure = sure & -sure;
  for (int undecided = first_sure != 0 ? candidates & (first_sure - 1) : candidates; undecided != 0;
       undecided &= undecided - 1) {
    const int lane = std::countr_zero(unsigned(undecided));
    if (decide(lane)) return 1 << lane;
  }
  return first_sure;
}

// intersect_watertight on the four lanes of a packet: the float filter on all four at once, then
// intersect_watertight_exact on each lane the filter cannot reject. Returns the mask of lanes hit
// with tmin < t <= tmax and their t, u, v.
// kAny: as first_hit_lane says (t, u and v are not written for a sure lane).
template <bool kAny = false>
inline int intersect_watertight4(const Watertight4Ray& r, const TrianglePacket& packet, float tmin, float tmax,
                                 float t_out[4], float u_out[4], float v_out[4]) {
  const __m128 sign = _mm_set1_ps(-0.0f);
  __m128 x[3], y[3], ez[3], az = _mm_setzero_ps();  // per corner, sheared; az: max |p - o| along kz
  for (int c = 0; c < 3; ++c) {
    const __m128 ex = _mm_sub_ps(_mm_load_ps(packet_row(packet, c, r.row[0])), r.origin[0]);
    const __m128 ey = _mm_sub_ps(_mm_load_ps(packet_row(packet, c, r.row[1])), r.origin[1]);
    ez[c] = _mm_sub_ps(_mm_load_ps(packet_row(packet, c, r.row[2])), r.origin[2]);
    x[c] = _mm_sub_ps(ex, _mm_mul_ps(r.sx, ez[c]));
    y[c] = _mm_sub_ps(ey, _mm_mul_ps(r.sy, ez[c]));
    az = _mm_max_ps(az, _mm_andnot_ps(sign, ez[c]));
  }
  // Corners a, b, c = 0, 1, 2.
  const __m128 u = _mm_sub_ps(_mm_mul_ps(x[2], y[1]), _mm_mul_ps(y[2], x[1]));
  const __m128 v = _mm_sub_ps(_mm_mul_ps(x[0], y[2]), _mm_mul_ps(y[0], x[2]));
  const __m128 w = _mm_sub_ps(_mm_mul_ps(x[1], y[0]), _mm_mul_ps(y[1], x[0]));
  const __m128 mx =
      _mm_max_ps(_mm_andnot_ps(sign, x[0]), _mm_max_ps(_mm_andnot_ps(sign, x[1]), _mm_andnot_ps(sign, x[2])));
  const __m128 my =
      _mm_max_ps(_mm_andnot_ps(sign, y[0]), _mm_max_ps(_mm_andnot_ps(sign, y[1]), _mm_andnot_ps(sign, y[2])));
  // watertight_filter_bound, operation for operation.
  const __m128 s = _mm_add_ps(mx, my);
  const __m128 bound = _mm_add_ps(
      _mm_mul_ps(_mm_mul_ps(_mm_set1_ps(32.0f * 0x1p-24f), _mm_add_ps(s, _mm_mul_ps(_mm_set1_ps(2.0f), az))), s),
      _mm_set1_ps(0x1p-126f));
  const __m128 nbound = _mm_xor_ps(bound, sign);
  const __m128 un = _mm_cmplt_ps(u, nbound), vn = _mm_cmplt_ps(v, nbound), wn = _mm_cmplt_ps(w, nbound);
  const __m128 up = _mm_cmpgt_ps(u, bound), vp = _mm_cmpgt_ps(v, bound), wp = _mm_cmpgt_ps(w, bound);
  const __m128 negative = _mm_or_ps(_mm_or_ps(un, vn), wn);
  const __m128 positive = _mm_or_ps(_mm_or_ps(up, vp), wp);
  int candidates = ~_mm_movemask_ps(_mm_and_ps(negative, positive)) & 0xf;
  if (candidates == 0) return 0;  // the common case: the ray passes beside all four
  // The hit's t is a convex combination of the corners' sheared z (to a few ulp): a lane whose z
  // range lies wholly beyond tmax or at or before tmin cannot hit. The 2^-20 margin exceeds the float
  // z's relative rounding and the double t's many times over; the FLT_MIN term covers a z or t below
  // about 2^-130, whose rounding is absolute (2^-150, denormal) and where the relative margin
  // underflows to nothing (without it a lane hit at t = tmax was rejected: the float z came out one
  // denormal ulp above the t rounded from double). NaN compares false and keeps the lane.
  const __m128 z0 = _mm_mul_ps(r.sz, ez[0]), z1 = _mm_mul_ps(r.sz, ez[1]), z2 = _mm_mul_ps(r.sz, ez[2]);
  const __m128 zlo = _mm_min_ps(z0, _mm_min_ps(z1, z2)), zhi = _mm_max_ps(z0, _mm_max_ps(z1, z2));
  const __m128 margin = _mm_set1_ps(0x1p-20f), smallest = _mm_set1_ps(0x1p-126f);
  const __m128 below = _mm_sub_ps(zlo, _mm_add_ps(_mm_mul_ps(margin, _mm_andnot_ps(sign, zlo)), smallest));
  const __m128 above = _mm_add_ps(zhi, _mm_add_ps(_mm_mul_ps(margin, _mm_andnot_ps(sign, zhi)), smallest));
  candidates &=
      ~_mm_movemask_ps(_mm_or_ps(_mm_cmpgt_ps(below, _mm_set1_ps(tmax)), _mm_cmple_ps(above, _mm_set1_ps(tmin))));
  if (candidates == 0) return 0;
  const __m128 one_sign = _mm_or_ps(_mm_and_ps(_mm_and_ps(un, vn), wn), _mm_and_ps(_mm_and_ps(up, vp), wp));
  // Behind: a lane whose edge functions share one sign beyond the bound and whose hit lies at or
  // before tmin (tmin >= 0) cannot hit: a secondary ray's own triangle, which its tmin or its origin's
  // offset keeps it off, and which every such ray otherwise decided in double. The double t is
  // (u z0 + v z1 + w z2) / det, det of the lanes' one sign and |det| at least |u + v + w| less 3.01
  // bound (on a one-sign lane the float |u + v + w| is |u| + |v| + |w|, bit for bit); the float
  // numerator lies within 3.01 bound zmax + 2^-20 |u + v + w| zmax of the double one scaled to the
  // float z (each z within 3u of it: the subtraction, the quotient, the product; zmax = max(|zlo|,
  // |zhi|)). 4 bound, 2^-16 and 1 - 2^-16 leave room for these sums' own rounding (the float t rounded
  // from a double at most tmin is at most tmin), the FLT_MIN terms for products that underflow. An
  // overflow anywhere (an infinite numerator or limit) or a NaN keeps the lane.
  if (tmin >= 0.0f) {
    const __m128 infinity = _mm_set1_ps(kInfinity);
    const __m128 num = _mm_add_ps(_mm_add_ps(_mm_mul_ps(u, z0), _mm_mul_ps(v, z1)), _mm_mul_ps(w, z2));
    const __m128 det = _mm_add_ps(_mm_add_ps(u, v), w);
    const __m128 signed_num = _mm_xor_ps(num, _mm_and_ps(det, sign));
    const __m128 weights = _mm_andnot_ps(sign, det);
    const __m128 zmax = _mm_max_ps(_mm_andnot_ps(sign, zlo), _mm_andnot_ps(sign, zhi));
    const __m128 error = _mm_add_ps(
        _mm_mul_ps(_mm_add_ps(_mm_mul_ps(_mm_set1_ps(0x1p-16f), weights), _mm_mul_ps(_mm_set1_ps(4.0f), bound)),
                   _mm_add_ps(zmax, smallest)),
        smallest);
    const __m128 det_low =
        _mm_sub_ps(_mm_mul_ps(weights, _mm_set1_ps(1.0f - 0x1p-16f)), _mm_mul_ps(_mm_set1_ps(4.0f), bound));
    const __m128 limit = _mm_sub_ps(_mm_mul_ps(_mm_set1_ps(tmin), det_low), error);
    const __m128 finite =
        _mm_and_ps(_mm_cmplt_ps(_mm_andnot_ps(sign, signed_num), infinity), _mm_cmplt_ps(limit, infinity));
    candidates &= ~_mm_movemask_ps(_mm_and_ps(_mm_and_ps(one_sign, finite), _mm_cmple_ps(signed_num, limit)));
    if (candidates == 0) return 0;
  }
  if constexpr (kAny) {
    const __m128 in_range =
        _mm_and_ps(_mm_and_ps(_mm_cmpgt_ps(below, _mm_set1_ps(tmin)), _mm_cmple_ps(above, _mm_set1_ps(tmax))),
                   _mm_cmplt_ps(above, _mm_set1_ps(kInfinity)));
    const __m128 sure = _mm_and_ps(_mm_and_ps(one_sign, in_range), _mm_cmplt_ps(s, _mm_set1_ps(0x1p60f)));
    return first_hit_lane(candidates, _mm_movemask_ps(sure) & candidates, [&](int lane) {
      return exact_lane(r.ray, packet, lane, lane, tmin, tmax, t_out, u_out, v_out) != 0;
    });
  }
  int mask = 0;
  for (int lane = 0; lane < 4; ++lane)
    if (candidates >> lane & 1) mask |= exact_lane(r.ray, packet, lane, lane, tmin, tmax, t_out, u_out, v_out);
  return mask;
}

// The per-ray constants of the 8-triangle watertight test (AVX2).
struct Watertight8Ray {
  const WatertightRay& ray;
  __m256 origin[3];  // in the shear frame's order: kx, ky, kz
  __m256 sx, sy, sz;
  size_t row[3];  // as in Watertight4Ray

  RAYLAB_AVX2 explicit Watertight8Ray(const WatertightRay& r)
      : ray(r), sx(_mm256_set1_ps(r.sx)), sy(_mm256_set1_ps(r.sy)), sz(_mm256_set1_ps(r.sz)) {
    float o[3];
    shear_frame(r, o, row);
    for (int a = 0; a < 3; ++a) origin[a] = _mm256_set1_ps(o[a]);
  }
};

// One packet_row of two packets: `a`'s four triangles in lanes 0-3, `b`'s in lanes 4-7.
RAYLAB_AVX2 inline __m256 load_packet_pair(const TrianglePacket& a, const TrianglePacket& b, int corner,
                                           size_t offset) {
  return _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(packet_row(a, corner, offset))),
                              _mm_load_ps(packet_row(b, corner, offset)), 1);
}

// exact_lane on the four lanes of one packet at once, in doubles (AVX2): every lane runs
// intersect_watertight_exact's operations in its order (no FMA in this target; the maxima pick as
// std::max does, NaN included; each compare is the scalar one or its negation, NaN falling the same
// way), so it rounds as the scalar decision does, bit for bit. Returns the mask of lanes hit among
// `lanes`, and writes t, u, v of all four lanes at t_out[0..3] (results only where hit).
// Branch-free, four lanes for about the instructions of one; any hit keeps deciding lane by lane up to
// the first hit (docs/bench/history.md).
RAYLAB_AVX2 inline int exact_packet(const Watertight8Ray& r, const TrianglePacket& packet, int lanes, float tmin,
                                    float tmax, float* t_out, float* u_out, float* v_out) {
  const WatertightRay& ray = r.ray;
  // The origin's float lanes in the shear frame's order, widened exactly to double.
  const __m256d ox = _mm256_cvtps_pd(_mm256_castps256_ps128(r.origin[0])),
                oy = _mm256_cvtps_pd(_mm256_castps256_ps128(r.origin[1])),
                oz = _mm256_cvtps_pd(_mm256_castps256_ps128(r.origin[2]));
  const __m256d dsx = _mm256_set1_pd(ray.dsx), dsy = _mm256_set1_pd(ray.dsy);
  const __m256d abs_mask = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffffLL));
  const __m256d zero = _mm256_setzero_pd();
  __m256d x[3], y[3], z[3], sx = zero, sy = zero;
  for (int c = 0; c < 3; ++c) {
    const __m256d ax = _mm256_sub_pd(_mm256_cvtps_pd(_mm_load_ps(packet_row(packet, c, r.row[0]))), ox);
    const __m256d ay = _mm256_sub_pd(_mm256_cvtps_pd(_mm_load_ps(packet_row(packet, c, r.row[1]))), oy);
    const __m256d az = _mm256_sub_pd(_mm256_cvtps_pd(_mm_load_ps(packet_row(packet, c, r.row[2]))), oz);
    x[c] = _mm256_sub_pd(ax, _mm256_mul_pd(dsx, az));
    y[c] = _mm256_sub_pd(ay, _mm256_mul_pd(dsy, az));
    z[c] = az;
    // std::max(sx, |x|) is `sx < |x| ? |x| : sx`: _mm256_max_pd(|x|, sx), which gives sx for a NaN.
    sx = _mm256_max_pd(_mm256_and_pd(x[c], abs_mask), sx);
    sy = _mm256_max_pd(_mm256_and_pd(y[c], abs_mask), sy);
  }
  const __m256d u = _mm256_sub_pd(_mm256_mul_pd(x[2], y[1]), _mm256_mul_pd(y[2], x[1]));
  const __m256d v = _mm256_sub_pd(_mm256_mul_pd(x[0], y[2]), _mm256_mul_pd(y[0], x[2]));
  const __m256d w = _mm256_sub_pd(_mm256_mul_pd(x[1], y[0]), _mm256_mul_pd(y[1], x[0]));
  const __m256d negative =
      _mm256_or_pd(_mm256_or_pd(_mm256_cmp_pd(u, zero, _CMP_LT_OQ), _mm256_cmp_pd(v, zero, _CMP_LT_OQ)),
                   _mm256_cmp_pd(w, zero, _CMP_LT_OQ));
  const __m256d positive =
      _mm256_or_pd(_mm256_or_pd(_mm256_cmp_pd(u, zero, _CMP_GT_OQ), _mm256_cmp_pd(v, zero, _CMP_GT_OQ)),
                   _mm256_cmp_pd(w, zero, _CMP_GT_OQ));
  const __m256d det = _mm256_add_pd(_mm256_add_pd(u, v), w);
  const __m256d s = _mm256_add_pd(sx, sy);
  const __m256d plane = _mm256_mul_pd(_mm256_mul_pd(_mm256_set1_pd(0x1p-24), s), s);
  // Inside every edge, and off the triangle's plane: |det| >= 2^-24 s^2 (false for NaN), det != 0.
  const __m256d through = _mm256_andnot_pd(_mm256_and_pd(negative, positive),
                                           _mm256_and_pd(_mm256_cmp_pd(_mm256_and_pd(det, abs_mask), plane, _CMP_GE_OQ),
                                                         _mm256_cmp_pd(det, zero, _CMP_NEQ_UQ)));
  const __m256d inv_det = _mm256_div_pd(_mm256_set1_pd(1.0), det);
  const __m256d num =
      _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(u, z[0]), _mm256_mul_pd(v, z[1])), _mm256_mul_pd(w, z[2]));
  const __m128 t = _mm256_cvtpd_ps(_mm256_mul_pd(_mm256_mul_pd(num, _mm256_set1_pd(ray.dsz)), inv_det));
  // tmin < t <= tmax (false for NaN), t not infinite.
  const __m128 in_range =
      _mm_and_ps(_mm_and_ps(_mm_cmp_ps(t, _mm_set1_ps(tmin), _CMP_GT_OQ), _mm_cmp_ps(t, _mm_set1_ps(tmax), _CMP_LE_OQ)),
                 _mm_cmp_ps(_mm_andnot_ps(_mm_set1_ps(-0.0f), t), _mm_set1_ps(kInfinity), _CMP_NEQ_UQ));
  _mm_storeu_ps(t_out, t);
  _mm_storeu_ps(u_out, _mm256_cvtpd_ps(_mm256_mul_pd(v, inv_det)));
  _mm_storeu_ps(v_out, _mm256_cvtpd_ps(_mm256_mul_pd(w, inv_det)));
  return _mm_movemask_ps(in_range) & _mm256_movemask_pd(through) & lanes;
}

// intersect_watertight4 on two packets at once: lanes 0-3 are packet `a`'s, lanes 4-7 packet `b`'s
// (two consecutive packets of a leaf: the layout stays the 4-wide one). The same operations in the
// same order on eight lanes, then the exact decision on the lanes of `lanes` (a bit mask) the filter
// cannot reject (exact_packet, one packet at a time). Returns the mask of lanes hit with
// tmin < t <= tmax and their t, u, v.
// kAny: as first_hit_lane says.
template <bool kAny = false>
RAYLAB_AVX2 inline int intersect_watertight8(const Watertight8Ray& r, const TrianglePacket& a, const TrianglePacket& b,
                                             int lanes, float tmin, float tmax, float t_out[8], float u_out[8],
                                             float v_out[8]) {
  const __m256 sign = _mm256_set1_ps(-0.0f);
  __m256 x[3], y[3], ez[3], az = _mm256_setzero_ps();
  for (int c = 0; c < 3; ++c) {
    const __m256 ex = _mm256_sub_ps(load_packet_pair(a, b, c, r.row[0]), r.origin[0]);
    const __m256 ey = _mm256_sub_ps(load_packet_pair(a, b, c, r.row[1]), r.origin[1]);
    ez[c] = _mm256_sub_ps(load_packet_pair(a, b, c, r.row[2]), r.origin[2]);
    x[c] = _mm256_sub_ps(ex, _mm256_mul_ps(r.sx, ez[c]));
    y[c] = _mm256_sub_ps(ey, _mm256_mul_ps(r.sy, ez[c]));
    az = _mm256_max_ps(az, _mm256_andnot_ps(sign, ez[c]));
  }
  const __m256 u = _mm256_sub_ps(_mm256_mul_ps(x[2], y[1]), _mm256_mul_ps(y[2], x[1]));
  const __m256 v = _mm256_sub_ps(_mm256_mul_ps(x[0], y[2]), _mm256_mul_ps(y[0], x[2]));
  const __m256 w = _mm256_sub_ps(_mm256_mul_ps(x[1], y[0]), _mm256_mul_ps(y[1], x[0]));
  const __m256 mx = _mm256_max_ps(_mm256_andnot_ps(sign, x[0]),
                                  _mm256_max_ps(_mm256_andnot_ps(sign, x[1]), _mm256_andnot_ps(sign, x[2])));
  const __m256 my = _mm256_max_ps(_mm256_andnot_ps(sign, y[0]),
                                  _mm256_max_ps(_mm256_andnot_ps(sign, y[1]), _mm256_andnot_ps(sign, y[2])));
  const __m256 s = _mm256_add_ps(mx, my);
  const __m256 bound = _mm256_add_ps(
      _mm256_mul_ps(
          _mm256_mul_ps(_mm256_set1_ps(32.0f * 0x1p-24f), _mm256_add_ps(s, _mm256_mul_ps(_mm256_set1_ps(2.0f), az))),
          s),
      _mm256_set1_ps(0x1p-126f));
  const __m256 nbound = _mm256_xor_ps(bound, sign);
  const __m256 un = _mm256_cmp_ps(u, nbound, _CMP_LT_OQ), vn = _mm256_cmp_ps(v, nbound, _CMP_LT_OQ),
               wn = _mm256_cmp_ps(w, nbound, _CMP_LT_OQ);
  const __m256 up = _mm256_cmp_ps(u, bound, _CMP_GT_OQ), vp = _mm256_cmp_ps(v, bound, _CMP_GT_OQ),
               wp = _mm256_cmp_ps(w, bound, _CMP_GT_OQ);
  const __m256 negative = _mm256_or_ps(_mm256_or_ps(un, vn), wn);
  const __m256 positive = _mm256_or_ps(_mm256_or_ps(up, vp), wp);
  int candidates = ~_mm256_movemask_ps(_mm256_and_ps(negative, positive)) & lanes;
  if (candidates == 0) return 0;
  // The z-range pre-check of intersect_watertight4, with its margins.
  const __m256 z0 = _mm256_mul_ps(r.sz, ez[0]), z1 = _mm256_mul_ps(r.sz, ez[1]), z2 = _mm256_mul_ps(r.sz, ez[2]);
  const __m256 zlo = _mm256_min_ps(z0, _mm256_min_ps(z1, z2)), zhi = _mm256_max_ps(z0, _mm256_max_ps(z1, z2));
  const __m256 margin = _mm256_set1_ps(0x1p-20f), smallest = _mm256_set1_ps(0x1p-126f);
  const __m256 below = _mm256_sub_ps(zlo, _mm256_add_ps(_mm256_mul_ps(margin, _mm256_andnot_ps(sign, zlo)), smallest));
  const __m256 above = _mm256_add_ps(zhi, _mm256_add_ps(_mm256_mul_ps(margin, _mm256_andnot_ps(sign, zhi)), smallest));
  candidates &= ~_mm256_movemask_ps(_mm256_or_ps(_mm256_cmp_ps(below, _mm256_set1_ps(tmax), _CMP_GT_OQ),
                                                 _mm256_cmp_ps(above, _mm256_set1_ps(tmin), _CMP_LE_OQ)));
  if (candidates == 0) return 0;
  const __m256 one_sign =
      _mm256_or_ps(_mm256_and_ps(_mm256_and_ps(un, vn), wn), _mm256_and_ps(_mm256_and_ps(up, vp), wp));
  // The behind test of intersect_watertight4, operation for operation.
  if (tmin >= 0.0f) {
    const __m256 infinity = _mm256_set1_ps(kInfinity);
    const __m256 num = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(u, z0), _mm256_mul_ps(v, z1)), _mm256_mul_ps(w, z2));
    const __m256 det = _mm256_add_ps(_mm256_add_ps(u, v), w);
    const __m256 signed_num = _mm256_xor_ps(num, _mm256_and_ps(det, sign));
    const __m256 weights = _mm256_andnot_ps(sign, det);
    const __m256 zmax = _mm256_max_ps(_mm256_andnot_ps(sign, zlo), _mm256_andnot_ps(sign, zhi));
    const __m256 error = _mm256_add_ps(_mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(0x1p-16f), weights),
                                                                   _mm256_mul_ps(_mm256_set1_ps(4.0f), bound)),
                                                     _mm256_add_ps(zmax, smallest)),
                                       smallest);
    const __m256 det_low = _mm256_sub_ps(_mm256_mul_ps(weights, _mm256_set1_ps(1.0f - 0x1p-16f)),
                                         _mm256_mul_ps(_mm256_set1_ps(4.0f), bound));
    const __m256 limit = _mm256_sub_ps(_mm256_mul_ps(_mm256_set1_ps(tmin), det_low), error);
    const __m256 finite = _mm256_and_ps(_mm256_cmp_ps(_mm256_andnot_ps(sign, signed_num), infinity, _CMP_LT_OQ),
                                        _mm256_cmp_ps(limit, infinity, _CMP_LT_OQ));
    candidates &= ~_mm256_movemask_ps(
        _mm256_and_ps(_mm256_and_ps(one_sign, finite), _mm256_cmp_ps(signed_num, limit, _CMP_LE_OQ)));
  }
  if constexpr (kAny) {
    if (candidates == 0) return 0;
    const __m256 in_range = _mm256_and_ps(_mm256_and_ps(_mm256_cmp_ps(below, _mm256_set1_ps(tmin), _CMP_GT_OQ),
                                                        _mm256_cmp_ps(above, _mm256_set1_ps(tmax), _CMP_LE_OQ)),
                                          _mm256_cmp_ps(above, _mm256_set1_ps(kInfinity), _CMP_LT_OQ));
    const __m256 sure =
        _mm256_and_ps(_mm256_and_ps(one_sign, in_range), _mm256_cmp_ps(s, _mm256_set1_ps(0x1p60f), _CMP_LT_OQ));
    return first_hit_lane(candidates, _mm256_movemask_ps(sure) & candidates, [&](int lane) {
      return exact_lane(r.ray, lane < 4 ? a : b, lane & 3, lane, tmin, tmax, t_out, u_out, v_out) != 0;
    });
  }
  int mask = 0;
  if (candidates & 0xf) mask = exact_packet(r, a, candidates & 0xf, tmin, tmax, t_out, u_out, v_out);
  if (candidates >> 4) mask |= exact_packet(r, b, candidates >> 4, tmin, tmax, t_out + 4, u_out + 4, v_out + 4) << 4;
  return mask;
}

}  // namespace raylab
