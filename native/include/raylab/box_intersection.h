// Ray/box slab test, robust for axis-parallel rays and under rounding.
#pragma once

#include "raylab/geometry.h"

#include <utility>

namespace raylab {

// The per-ray part of the slab test. A zero direction component gives an infinite reciprocal
// (IEEE), so axis-parallel rays need no special case. Adding +0 turns a -0 component into +0: the
// reciprocal is then +inf, never -inf, which keeps the NaN of an origin on a slab plane (0 * inf)
// on the side that intersect_box ignores (with -inf the far distance of that slab became -inf and
// a ray lying in a face plane missed the box).
struct BoxRay {
  glm::vec3 origin;
  glm::vec3 inv_dir;
  float tmin, tmax;

  explicit BoxRay(const Ray& ray)
      : origin(ray.origin), inv_dir(1.0f / (ray.direction + 0.0f)), tmin(ray.tmin), tmax(ray.tmax) {}
};

// pbrt's gamma(3) bound: widening the far distance by 1 + 2*gamma(3) (about 2 ulp) makes the test
// conservative under rounding (Ize 2013), so a box is never missed that the exact ray hits.
inline constexpr float kBoxFarScale = 1.0f + 2.0f * (3.0f * 0x1p-24f) / (1.0f - 3.0f * 0x1p-24f);

// Returns true when the ray meets the box within [ray.tmin, tmax]; `t_entry` is where it enters
// (ray.tmin when the origin is inside). The comparisons are written so that a NaN slab distance
// (origin exactly on a slab plane of an axis-parallel ray: 0 * inf) is ignored rather than
// propagated: such a ray lies in the face plane, and touching counts as a hit.
inline bool intersect_box(const Bounds& box, const BoxRay& r, float tmax, float& t_entry) {
  float t_near = r.tmin;
  float t_far = tmax;
  for (int axis = 0; axis < 3; ++axis) {
    float t0 = (box.lo[axis] - r.origin[axis]) * r.inv_dir[axis];
    float t1 = (box.hi[axis] - r.origin[axis]) * r.inv_dir[axis];
    if (t0 > t1) std::swap(t0, t1);
    t1 *= kBoxFarScale;
    t_near = t0 > t_near ? t0 : t_near;
    t_far = t1 < t_far ? t1 : t_far;
    if (t_near > t_far) return false;
  }
  t_entry = t_near;
  return true;
}

}  // namespace raylab
