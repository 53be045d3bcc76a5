// Batch queries over rays read in place from a caller's arrays (the Python API's numpy door): no array
// of Ray is made. Each chunk of rays is built on the tracing thread's stack, checked, traced by the
// structure's or the scene's batch query (the BVH's packets) and its answers written straight into
// the caller's columns, so that a ray costs the door a few loads and stores beyond its walk.
#pragma once

#include "raylab/geometry.h"
#include "raylab/scene_snapshot.h"
#include "raylab/structure.h"

#include <cstddef>
#include <cstdint>
#include <span>

namespace raylab {

// Origins and directions as consecutive rows of three floats (stride 3), or one row shared by every ray
// (stride 0).
struct RayRows {
  const float* origins = nullptr;
  size_t origin_stride = 3;
  const float* directions = nullptr;
  size_t direction_stride = 3;
  float tmin = 0.0f, tmax = kInfinity;
  size_t count = 0;

  const float* origin(size_t i) const { return origins + origin_stride * i; }
  const float* direction(size_t i) const { return directions + direction_stride * i; }
  // What a query accepts: finite coordinates and a direction that is not zero. usable_range checks a
  // run of rays in loops the compiler vectorizes (a float is NaN or infinite exactly when its exponent
  // bits are all ones): the door's check costs a ray a few instructions; usable(i) is its run of one.
  bool usable_range(size_t first, size_t last) const;
  bool usable(size_t i) const { return usable_range(i, i + 1); }
  Ray ray(size_t i) const {
    const float *o = origin(i), *d = direction(i);
    Ray r;
    r.origin = {o[0], o[1], o[2]};
    r.direction = {d[0], d[1], d[2]};
    r.tmin = tmin;
    r.tmax = tmax;
    return r;
  }
};

// Where closest hits go, one column each (the Python API's Hits): t (infinity on a miss), u, v (0 on a
// miss), triangle and instance (-1 on a miss; instance 0 for every hit when `single_instance`, a lone
// structure), hit.
struct HitColumns {
  float *t, *u, *v;
  int32_t *triangle, *instance;
  bool* hit;
  bool single_instance;
};

// Writes hits[k] into row first + k of every column.
void write_hits(const HitColumns& out, size_t first, std::span<const Hit> hits);

// The batch queries, uncounted, on at most `threads` threads (0: all cores). Each returns rows.count
// when every ray was usable; else the index of the first ray that is not (and the columns hold nothing
// promised), found before or while tracing.
size_t closest_rows(const Structure& s, const RayRows& rows, const HitColumns& out, int threads);
size_t closest_rows(const SceneSnapshot& scene, const RayRows& rows, const HitColumns& out, int threads);
size_t any_rows(const Structure& s, const RayRows& rows, bool* occluded, int threads);
size_t any_rows(const SceneSnapshot& scene, const RayRows& rows, bool* occluded, int threads);

}  // namespace raylab
