// The inner loop every structure shares: test a run of triangles against one ray.
#pragma once

#include "mailbox.h"
#include "raylab/traversal_record.h"
#include "raylab/triangle_intersection.h"

#include <span>

namespace raylab {

// Tests triangles index(0..count-1) and keeps the closest in `best` (best.t bounds the search).
template <class Recorder, class IndexFn>
inline bool closest_in_triangles(const TriangleMesh& mesh, const TriangleTester& tester, uint32_t count, IndexFn index,
                                 Hit& best, Recorder& record) {
  bool found = false;
  for (uint32_t i = 0; i < count; ++i) {
    const uint32_t tri = index(i);
    TriangleHit th{};
    const bool hit = tester(mesh, tri, best.t, th);
    record.triangle(tri, hit);
    if (hit && closer(th, tri, best)) {
      best.t = th.t;
      best.u = th.u;
      best.v = th.v;
      best.triangle = tri;
      found = true;
    }
  }
  return found;
}

template <class Recorder, class IndexFn>
inline bool any_in_triangles(const TriangleMesh& mesh, const TriangleTester& tester, uint32_t count, IndexFn index,
                             float tmax, Recorder& record) {
  for (uint32_t i = 0; i < count; ++i) {
    const uint32_t tri = index(i);
    TriangleHit th{};
    const bool hit = tester(mesh, tri, tmax, th);
    record.triangle(tri, hit);
    if (hit) return true;
  }
  return false;
}

// The search state a closest-hit traversal starts from.
inline Hit initial_hit(const Ray& ray) {
  Hit h;
  h.t = ray.tmax;
  return h;
}

// Every triangle of the mesh, in index order: brute force, and the AABB structure once its box is hit.
template <class Recorder>
inline bool closest_in_mesh(const TriangleMesh& mesh, TriangleTest kind, const Ray& ray, Hit& hit, Recorder& record) {
  const TriangleTester tester(ray, kind);
  Hit best = initial_hit(ray);
  if (!closest_in_triangles(
          mesh, tester, uint32_t(mesh.triangle_count()), [](uint32_t i) { return i; }, best, record))
    return false;
  hit = best;
  return true;
}

template <class Recorder>
inline bool any_in_mesh(const TriangleMesh& mesh, TriangleTest kind, const Ray& ray, Recorder& record) {
  const TriangleTester tester(ray, kind);
  return any_in_triangles(
      mesh, tester, uint32_t(mesh.triangle_count()), [](uint32_t i) { return i; }, ray.tmax, record);
}

// The two queries of a structure that walks its leaves front to back (octree nodes, grid cells).
// `walk(limit, visit)` hands each leaf's triangle indices (a span) to `visit` in order; `visit`
// returns true to stop; `limit()` is how far the walk must still look (the closest hit so far, or
// ray.tmax for any hit). `mailbox` (mailbox.h), one per query, skips the triangles this ray has
// already tested in an earlier leaf; the search state is the whole ray's, which makes that exact.
template <class Recorder, class Walk, class Mailbox = NoMailbox>
inline bool closest_over_leaves(const TriangleMesh& mesh, TriangleTest kind, const Ray& ray, Hit& hit, Recorder& record,
                                Walk walk, Mailbox mailbox = {}) {
  record.ray();
  const TriangleTester tester(ray, kind);
  Hit best = initial_hit(ray);
  bool found = false;
  walk([&] { return best.t; },
       [&](std::span<const uint32_t> leaf) {
         for (const uint32_t tri : leaf)
           if (mailbox.first_test(tri))
             found |= closest_in_triangles(
                 mesh, tester, 1, [tri](uint32_t) { return tri; }, best, record);
         return false;
       });
  if (found) hit = best;
  return found;
}

template <class Recorder, class Walk, class Mailbox = NoMailbox>
inline bool any_over_leaves(const TriangleMesh& mesh, TriangleTest kind, const Ray& ray, Recorder& record, Walk walk,
                            Mailbox mailbox = {}) {
  record.ray();
  const TriangleTester tester(ray, kind);
  bool occluded = false;
  walk([&] { return ray.tmax; },
       [&](std::span<const uint32_t> leaf) {
         for (const uint32_t tri : leaf)
           if (mailbox.first_test(tri) && any_in_triangles(
                                              mesh, tester, 1, [tri](uint32_t) { return tri; }, ray.tmax, record))
             return occluded = true;
         return false;
       });
  return occluded;
}

}  // namespace raylab
