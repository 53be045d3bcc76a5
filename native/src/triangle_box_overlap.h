// Triangle/box overlap by the separating-axis theorem (Akenine-Möller, "Fast 3D Triangle-Box
// Overlap Testing", 2001): a triangle and a box are disjoint if and only if one of 13 axes separates
// their projections: the 3 box face normals, the triangle's normal, and the 9 cross products of a
// box edge direction with a triangle edge.
//
// Touching counts as overlap, and the test is conservative: it works in double precision and calls
// an axis separating only when the gap exceeds a tolerance of 1e-10 of the magnitudes involved
// (about a million times double rounding), so an overlapping triangle is never reported disjoint.
// A triangle that misses by less than that is reported as overlapping, which costs a test, never a
// hit. Degenerate triangles (segments, points) need no special case: a zero axis separates nothing.
#pragma once

#include "raylab/geometry.h"

#include <algorithm>
#include <bit>
#include <cmath>

namespace raylab {

namespace detail {

// The test against the 8 cells of a 2x2x2 grid at once: `planes` holds lo <= mid <= hi per
// dimension, and bit i of `cells` stands for the cell whose k-th interval is [mid, hi] when bit k of
// i is set, else [lo, mid]. Returns the cells of `cells` that neither the triangle's normal nor an
// edge axis separates from the triangle; the callers have decided the box face normals already,
// exactly, on the triangle's bounds.
// A box projects onto an axis as the sum of its three edges' projections, so the 8 cells share
// nearly all the work.
inline uint32_t triangle_grid_overlaps(const glm::dvec3 planes[3], const glm::vec3& a, const glm::vec3& b,
                                       const glm::vec3& c, uint32_t cells) {
  constexpr double kTolerance = 1e-10;
  const glm::dvec3 v[3] = {glm::dvec3(a), glm::dvec3(b), glm::dvec3(c)};
  auto norm_inf = [](const glm::dvec3& x) { return std::max({std::abs(x.x), std::abs(x.y), std::abs(x.z)}); };
  auto norm1 = [](const glm::dvec3& x) { return std::abs(x.x) + std::abs(x.y) + std::abs(x.z); };
  // Every projection below sums products of coordinates of at most this size with axis components.
  const double magnitude =
      std::max({norm_inf(v[0]), norm_inf(v[1]), norm_inf(v[2]), norm_inf(planes[0]), norm_inf(planes[2])});

  // Drops the cells that `axis` separates; `weight` bounds the size of the axis's components and of
  // their rounding error, which scales the tolerance.
  auto separate = [&](const glm::dvec3& axis, double weight) {
    const double p0 = glm::dot(v[0], axis), p1 = glm::dot(v[1], axis), p2 = glm::dot(v[2], axis);
    const double slack = kTolerance * magnitude * weight;
    const double tri_lo = std::min({p0, p1, p2}) - slack, tri_hi = std::max({p0, p1, p2}) + slack;
    double lo[3][2], hi[3][2];  // [dimension][lower/upper cell]: the projected cell edge
    for (int k = 0; k < 3; ++k) {
      const double x0 = planes[0][k] * axis[k], x1 = planes[1][k] * axis[k], x2 = planes[2][k] * axis[k];
      lo[k][0] = std::min(x0, x1), hi[k][0] = std::max(x0, x1);
      lo[k][1] = std::min(x1, x2), hi[k][1] = std::max(x1, x2);
    }
    for (uint32_t m = cells; m != 0; m &= m - 1) {
      const int i = std::countr_zero(m), x = i & 1, y = (i >> 1) & 1, z = (i >> 2) & 1;
      const double box_lo = lo[0][x] + lo[1][y] + lo[2][z], box_hi = hi[0][x] + hi[1][y] + hi[2][z];
      if (tri_lo > box_hi || tri_hi < box_lo) cells &= ~(1u << i);
    }
  };

  const glm::dvec3 e[3] = {v[1] - v[0], v[2] - v[1], v[0] - v[2]};
  // The triangle's plane first: it rejects most cells smaller than the triangle. Its normal cancels
  // heavily for a sliver, so its rounding error is bounded by the product of the edges, not by its
  // own length.
  separate(glm::cross(e[0], e[1]), norm1(e[0]) * norm1(e[1]));
  for (int j = 0; j < 3 && cells; ++j) {
    const glm::dvec3& f = e[j];
    const double w = norm1(f);
    separate({0.0, -f.z, f.y}, w);  // x cross f
    separate({f.z, 0.0, -f.x}, w);  // y cross f
    separate({-f.y, f.x, 0.0}, w);  // z cross f
  }
  return cells;
}

}  // namespace detail

// The closed triangle abc against the closed box.
inline bool triangle_box_overlap(const Bounds& box, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
  // The box face normals: the triangle's bounds against the box.
  const glm::vec3 lo = glm::min(a, glm::min(b, c)), hi = glm::max(a, glm::max(b, c));
  if (glm::any(glm::greaterThan(lo, box.hi)) || glm::any(glm::lessThan(hi, box.lo))) return false;
  // The box is cell 0 of a grid whose upper cells are empty.
  const glm::dvec3 planes[3] = {glm::dvec3(box.lo), glm::dvec3(box.hi), glm::dvec3(box.hi)};
  return detail::triangle_grid_overlaps(planes, a, b, c, 1u) != 0;
}

// The octants of `box` split at `mid` (bit i: the octant whose k-th interval is the upper one when
// bit k of i is set) that the triangle overlaps, for a triangle that overlaps `box` itself.
inline uint32_t triangle_octant_overlaps(const Bounds& box, const glm::vec3& mid, const glm::vec3& a,
                                         const glm::vec3& b, const glm::vec3& c) {
  // The box face normals first, exactly, on the triangle's bounds: most triangles stay in one octant.
  const glm::vec3 lo = glm::min(a, glm::min(b, c)), hi = glm::max(a, glm::max(b, c));
  constexpr uint32_t kUpper[3] = {0xaa, 0xcc, 0xf0};  // octants with bit k set
  uint32_t candidates = 0xff;
  for (int k = 0; k < 3; ++k) {
    if (lo[k] > mid[k]) candidates &= kUpper[k];
    if (hi[k] < mid[k]) candidates &= ~kUpper[k];
  }
  // The octants tile the box, which the triangle overlaps: when its bounds reach a single octant,
  // that octant is the one it overlaps.
  if (std::has_single_bit(candidates)) return candidates;
  const glm::dvec3 planes[3] = {glm::dvec3(box.lo), glm::dvec3(mid), glm::dvec3(box.hi)};
  return detail::triangle_grid_overlaps(planes, a, b, c, candidates);
}

}  // namespace raylab
