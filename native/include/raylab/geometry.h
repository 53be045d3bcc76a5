// Rays, hits, bounds and triangle meshes: the vocabulary every other header uses.
#pragma once

#include <glm/glm.hpp>

#include "raylab/simd.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace raylab {

inline constexpr float kInfinity = std::numeric_limits<float>::infinity();
inline constexpr uint32_t kInvalidIndex = 0xffffffffu;

// The largest |coordinate| a mesh vertex may have (2^61, about 2.3e18). Within it, vertex differences
// (<= 2^62), sheared coordinates (<= 2^63) and the float filter's edge products (<= 2^126), as well as
// the builders' surface areas, stay finite; past about 2^62 the products overflow float's 2^128 and
// the float tests stop being exact. TriangleMesh::validate refuses larger coordinates.
inline constexpr float kMaxCoordinate = 0x1p61f;

struct Ray {
  glm::vec3 origin{0.0f};
  float tmin = 0.0f;
  glm::vec3 direction{0.0f, 0.0f, 1.0f};
  float tmax = kInfinity;

  glm::vec3 at(float t) const { return origin + t * direction; }
};

// The direction every test uses: a denormal component, or one below 2^-40 of the largest, is
// replaced by +0, so that a tiny or -0 component behaves exactly like zero in the box test, the
// octant order and the triangle test alike. Over the part of the ray that can reach the mesh (a
// distance of at most a few times the mesh's size along the largest component), the dropped
// component moves the ray by under 2^-38 of that size, far inside the box padding (box_intersection.h).
// Lane-wise, without branches (every ray of a traversal pays it): the comparisons and selections of
// `a[i] < keep || a[i] < FLT_MIN ? 0 : d[i]` with keep = 2^-40 * std::max(a.x, std::max(a.y, a.z)),
// NaN handling included (a NaN component is kept, and compares false); GCC compiled the loop with a
// branch per component.
inline glm::vec3 effective_direction(const glm::vec3& d) {
  const __m128 v = _mm_setr_ps(d.x, d.y, d.z, 0.0f);
  const __m128 a = _mm_andnot_ps(_mm_set1_ps(-0.0f), v);
  // std::max(p, q) is `p < q ? q : p`, which is _mm_max_ss(q, p).
  const __m128 largest = _mm_max_ss(_mm_max_ss(_mm_shuffle_ps(a, a, 2), _mm_shuffle_ps(a, a, 1)), a);
  const __m128 scaled = _mm_mul_ss(_mm_set_ss(0x1p-40f), largest);
  const __m128 keep = _mm_shuffle_ps(scaled, scaled, 0);
  const __m128 drop = _mm_or_ps(_mm_cmplt_ps(a, keep), _mm_cmplt_ps(a, _mm_set1_ps(std::numeric_limits<float>::min())));
  alignas(16) float out[4];
  _mm_store_ps(out, _mm_andnot_ps(drop, v));
  return {out[0], out[1], out[2]};
}

struct Hit {
  float t = kInfinity;
  float u = 0.0f;  // barycentric weight of vertex 1
  float v = 0.0f;  // barycentric weight of vertex 2
  uint32_t triangle = kInvalidIndex;
  uint32_t instance = kInvalidIndex;

  bool valid() const { return triangle != kInvalidIndex; }
};

// Axis-aligned box; an empty box has lo > hi so that extending it by any point gives that point.
struct Bounds {
  glm::vec3 lo{kInfinity};
  glm::vec3 hi{-kInfinity};

  Bounds() = default;
  Bounds(const glm::vec3& a, const glm::vec3& b) : lo(a), hi(b) {}

  bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  void extend(const glm::vec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  void extend(const Bounds& b) {
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
  glm::vec3 extent() const { return hi - lo; }
  glm::vec3 center() const { return 0.5f * (lo + hi); }
  float surface_area() const {
    if (empty()) return 0.0f;
    glm::vec3 e = extent();
    return 2.0f * (e.x * e.y + e.y * e.z + e.z * e.x);
  }
  int longest_axis() const {
    glm::vec3 e = extent();
    return (e.x >= e.y && e.x >= e.z) ? 0 : (e.y >= e.z ? 1 : 2);
  }
  bool contains(const glm::vec3& p) const {
    return p.x >= lo.x && p.y >= lo.y && p.z >= lo.z && p.x <= hi.x && p.y <= hi.y && p.z <= hi.z;
  }
};

// Indexed triangle mesh in object space. Validation happens once, at construction from user data.
struct TriangleMesh {
  std::vector<glm::vec3> vertices;
  std::vector<glm::uvec3> triangles;

  size_t triangle_count() const { return triangles.size(); }
  glm::vec3 vertex(uint32_t triangle, int corner) const { return vertices[triangles[triangle][corner]]; }
  Bounds triangle_bounds(uint32_t triangle) const {
    Bounds b;
    for (int c = 0; c < 3; ++c) b.extend(vertex(triangle, c));
    return b;
  }
  Bounds bounds() const {
    Bounds b;
    for (const glm::uvec3& tri : triangles)
      for (int c = 0; c < 3; ++c) b.extend(vertices[tri[c]]);
    return b;
  }
  size_t memory_bytes() const {
    return vertices.capacity() * sizeof(glm::vec3) + triangles.capacity() * sizeof(glm::uvec3);
  }
  // Throws std::invalid_argument naming the first problem: an index out of range, a non-finite
  // coordinate or one beyond kMaxCoordinate.
  void validate() const;
};

using MeshPtr = std::shared_ptr<const TriangleMesh>;

}  // namespace raylab
