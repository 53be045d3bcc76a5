// The float64 referee of the benchmark's price of exactness: each tracer's closest hit on a ray judged
// right or wrong in double precision, against the triangles any tracer reported or the ray was aimed at.
// A point within a few float steps of an edge or of the interval's ends is a tie: either answer is right
// there, as the float inputs cannot tell. Outside the ties, a wrong answer is one a user can see:
//   off_triangle      the hit point lies outside the triangle reported
//   outside_interval  the hit's t lies outside (tmin, tmax]: a self-hit of a ray from a hair above a
//                     surface, or a hit past tmax
//   missed_inside     a nearer hit inside a triangle was passed by (or the ray missed)
//   leaked            a nearer hit on an edge or vertex where the ray crosses the surface was passed by:
//                     the ray slipped between neighbours, out of a closed mesh. It crosses there when the
//                     edge's two triangles (the vertex's whole fan) face the ray alike; a ray that only
//                     touches a silhouette edge or vertex may hit or pass.
#pragma once

#include "raylab/geometry.h"

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace raylab::bench {

enum class Verdict : uint8_t { Right, OffTriangle, OutsideInterval, MissedInside, Leaked };
inline constexpr int kVerdicts = 5;
const char* verdict_name(Verdict verdict);

class Referee {
 public:
  // Float steps of the coordinates within which a point counts as on an edge (or t at tmin, tmax).
  static constexpr double kTieSteps = 4.0;

  explicit Referee(const TriangleMesh& mesh);  // finds each edge's neighbour and each vertex's fan (by position)

  struct Judgement {
    Verdict verdict = Verdict::Right;
    uint32_t witness = kInvalidIndex;  // missed_inside, leaked: the nearer triangle that was passed by
  };
  Judgement judge(const Ray& ray, const Hit& answer, std::span<const uint32_t> candidates) const;
  // An any-hit answer: occluded is right when a candidate may be hit (inside or a tie, t not outside the
  // interval); not occluded is judged as a closest-hit miss.
  Verdict judge_occlusion(const Ray& ray, bool occluded, std::span<const uint32_t> candidates) const;
  bool closed() const { return open_edges_ == 0; }  // every edge shared by exactly two triangles

 private:
  struct Solution;
  Solution solve(const Ray& ray, uint32_t triangle) const;
  bool crossing(const Ray& ray, uint32_t triangle, const std::array<bool, 3>& on_edge) const;
  bool around(uint32_t triangle, const std::array<bool, 3>& on_edge, uint32_t other) const;
  int facing(const Ray& ray, uint32_t triangle) const;  // the sign of its normal along the ray

  const TriangleMesh& mesh_;
  std::vector<uint32_t> corner_vertex_;     // per triangle corner: its vertex, equal positions merged
  std::vector<uint32_t> neighbour_;         // per triangle edge (corner k to k + 1): the other triangle
                                            // on it, kInvalidIndex on a boundary or non-manifold edge
  std::vector<std::vector<uint32_t>> fan_;  // per merged vertex: the triangles around it
  size_t open_edges_ = 0;
};

}  // namespace raylab::bench
