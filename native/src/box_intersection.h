// Ray/box slab test, robust for axis-parallel rays and under rounding, and conservative with respect
// to the triangle test's own error (the exactness contract: box culling never drops a hit the
// triangle test would report; see README "Exactness and its limits").
#pragma once

#include "raylab/geometry.h"

#include "raylab/simd.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace raylab {

// How far, relative to the ray origin's distance from the structure's root box, every box is grown
// before it is tested. The triangle test (triangle_intersection.h) decides its hits in double
// precision and refuses hits whose barycentrics are ill-conditioned, so a hit it reports at t lies
// within about 2^-18 of that distance of a point of the triangle, and its t is exact to a float
// rounding: a box grown by 2^-16 of it (in the spirit of pbrt-v4's error bounds, with a 4x margin)
// contains the ray at every t the triangle test can report for a triangle inside it. The same pad
// also covers the slab test's own rounding (Ize 2013's 2*gamma(3)) several hundred times over.
inline constexpr float kBoxPadScale = 0x1p-16f;

// pbrt's gamma(3) bound: widening the far distance by 1 + 2*gamma(3) (about 2 ulp) makes the test
// conservative under its own rounding (Ize 2013) even where the pad is zero (an origin inside a
// degenerate root box).
inline constexpr float kBoxFarScale = 1.0f + 2.0f * (3.0f * 0x1p-24f) / (1.0f - 3.0f * 0x1p-24f);

// The per-ray part of the slab test. The reciprocal of a zero component is +inf (IEEE), so
// axis-parallel rays need no special case; effective_direction() turns -0 and tiny components into
// +0, so the reciprocal is never -inf or a huge finite value, and the NaN of an origin on a slab plane
// (0 * inf) stays on the side that intersect_box ignores.
struct BoxRay {
  glm::vec3 origin;
  glm::vec3 inv_dir;
  float tmin, tmax;
  float pad;  // every box is grown by this much on each side

  // For a structure (or the scene's top level) whose boxes all lie inside `root`; an empty root
  // gives no pad (the bare slab test).
  BoxRay(const Ray& ray, const Bounds& root) : BoxRay(ray, effective_direction(ray.direction), root) {}
  // With the ray's effective_direction() already computed (a traversal shares it with its triangle
  // test: the per-ray setup is a measurable part of a ray that misses or hits early). Always inlined,
  // as FastBoxRay's: called out of line, the 4-wide walks' setup depended on LTO's choices.
  [[gnu::always_inline]] BoxRay(const Ray& ray, const glm::vec3& effective_dir, const Bounds& root)
      : origin(ray.origin), tmin(ray.tmin), tmax(ray.tmax), pad(box_pad(ray.origin, root)) {
    alignas(16) float inv[4];  // one packed division; each lane rounds as 1.0f / d[i]
    _mm_store_ps(inv,
                 _mm_div_ps(_mm_set1_ps(1.0f), _mm_setr_ps(effective_dir.x, effective_dir.y, effective_dir.z, 1.0f)));
    inv_dir = {inv[0], inv[1], inv[2]};
  }

  // kBoxPadScale times the largest distance, along any axis, from the origin to the root box.
  // Lane-wise, without branches: glm::max(p, q) and std::max's steps are `p < q ? q : p`, which is
  // _mm_max_ps(q, p).
  [[gnu::always_inline]] static float box_pad(const glm::vec3& origin, const Bounds& root) {
    if (root.empty()) return 0.0f;
    const __m128 o = _mm_setr_ps(origin.x, origin.y, origin.z, 0.0f), sign = _mm_set1_ps(-0.0f);
    const __m128 lo = _mm_andnot_ps(sign, _mm_sub_ps(_mm_setr_ps(root.lo.x, root.lo.y, root.lo.z, 0.0f), o));
    const __m128 hi = _mm_andnot_ps(sign, _mm_sub_ps(_mm_setr_ps(root.hi.x, root.hi.y, root.hi.z, 0.0f), o));
    const __m128 far = _mm_max_ps(hi, lo);
    const __m128 largest = _mm_max_ss(_mm_shuffle_ps(far, far, 2), _mm_max_ss(_mm_shuffle_ps(far, far, 1), far));
    return kBoxPadScale * _mm_cvtss_f32(largest);
  }
};

// Returns true when the ray meets the box, grown by r.pad, within [ray.tmin, tmax] (both inclusive);
// `t_entry` is where it enters (ray.tmin when the origin is inside). The comparisons are written so
// that a NaN slab distance (origin exactly on a slab plane of an axis-parallel ray: 0 * inf) is
// ignored rather than propagated: such a ray lies in the face plane, and touching counts as a hit.
inline bool intersect_box(const Bounds& box, const BoxRay& r, float tmax, float& t_entry) {
  float t_near = r.tmin;
  float t_far = tmax;
  for (int axis = 0; axis < 3; ++axis) {
    float t0 = ((box.lo[axis] - r.origin[axis]) - r.pad) * r.inv_dir[axis];
    float t1 = ((box.hi[axis] - r.origin[axis]) + r.pad) * r.inv_dir[axis];
    if (t0 > t1) std::swap(t0, t1);
    t1 *= kBoxFarScale;
    t_near = t0 > t_near ? t0 : t_near;
    t_far = t1 < t_far ? t1 : t_far;
    if (t_near > t_far) return false;
  }
  t_entry = t_near;
  return true;
}

// The root test every walk starts with: records it, and records the ray as ignored when it misses.
template <class Recorder>
inline bool enter_root(const Bounds& root, bool has_nodes, const BoxRay& r, float tmax, Recorder& record,
                       float& t_root) {
  t_root = r.tmin;
  const bool hit = has_nodes && intersect_box(root, r, tmax, t_root);
  record.box(0, root, 0, hit, t_root);
  if (!hit) record.ignored();
  return hit;
}

}  // namespace raylab
