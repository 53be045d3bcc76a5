#include "arbitration.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

namespace raylab::bench {

const char* verdict_name(Verdict verdict) {
  switch (verdict) {
    case Verdict::Right: return "right";
    case Verdict::OffTriangle: return "off_triangle";
    case Verdict::OutsideInterval: return "outside_interval";
    case Verdict::MissedInside: return "missed_inside";
    case Verdict::Leaked: return "leaked";
  }
  return "?";
}

namespace {

double magnitude(const glm::dvec3& p) { return std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}); }

enum class Place { Inside, Tie, Outside };

}  // namespace

// One triangle against the ray in double precision, the float inputs taken as exact.
struct Referee::Solution {
  bool parallel = true;  // the ray lies parallel to the plane: never a hit that must be found
  double t = INFINITY;   // along the ray's direction as stored
  double t_tie = 0.0;    // the tie distance in t
  Place position = Place::Outside, interval = Place::Outside;
  std::array<bool, 3> on_edge{};  // edge k (corner k to k + 1) within the tie distance
};

Referee::Referee(const TriangleMesh& mesh)
    : mesh_(mesh), corner_vertex_(mesh.triangle_count() * 3), neighbour_(mesh.triangle_count() * 3, kInvalidIndex) {
  // Vertices by position: a mesh split at its seams (normals, UVs) still shares the edges there.
  std::map<std::tuple<float, float, float>, uint32_t> by_position;
  for (uint32_t t = 0; t < mesh.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k) {
      const glm::vec3 v = mesh.vertex(t, k);
      const uint32_t id = by_position.try_emplace({v.x, v.y, v.z}, uint32_t(by_position.size())).first->second;
      corner_vertex_[size_t(t) * 3 + k] = id;
    }
  fan_.resize(by_position.size());
  std::map<std::pair<uint32_t, uint32_t>, std::vector<uint32_t>> edges;
  for (uint32_t t = 0; t < mesh.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = corner_vertex_[size_t(t) * 3 + k], b = corner_vertex_[size_t(t) * 3 + (k + 1) % 3];
      edges[{std::min(a, b), std::max(a, b)}].push_back(t);
      fan_[a].push_back(t);
    }
  for (uint32_t t = 0; t < mesh.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = corner_vertex_[size_t(t) * 3 + k], b = corner_vertex_[size_t(t) * 3 + (k + 1) % 3];
      const std::vector<uint32_t>& on = edges[{std::min(a, b), std::max(a, b)}];
      if (on.size() == 2) neighbour_[size_t(t) * 3 + k] = on[0] == t ? on[1] : on[0];
    }
  for (const auto& [edge, on] : edges) open_edges_ += on.size() != 2;
}

namespace {
// Corner k of a triangle lies on its edges k - 1 and k: the corner two marked edges meet at.
int shared_corner(const std::array<bool, 3>& on_edge) { return !on_edge[0] ? 2 : !on_edge[1] ? 0 : 1; }
}  // namespace

// Whether `other` holds the edge or vertex of `triangle` marked on_edge too: its neighbour there, or a
// triangle of the vertex's fan. A hit on it is the same point, the tie broken the other way (at a crease
// the two planes' t differ by more than the tie distance).
bool Referee::around(uint32_t triangle, const std::array<bool, 3>& on_edge, uint32_t other) const {
  const int edges = int(on_edge[0]) + int(on_edge[1]) + int(on_edge[2]);
  if (edges == 1) return neighbour_[size_t(triangle) * 3 + (on_edge[0] ? 0 : on_edge[1] ? 1 : 2)] == other;
  if (edges != 2) return false;
  const std::vector<uint32_t>& fan = fan_[corner_vertex_[size_t(triangle) * 3 + shared_corner(on_edge)]];
  return std::find(fan.begin(), fan.end(), other) != fan.end();
}

int Referee::facing(const Ray& ray, uint32_t triangle) const {
  const glm::dvec3 p0 = mesh_.vertex(triangle, 0), p1 = mesh_.vertex(triangle, 1), p2 = mesh_.vertex(triangle, 2);
  const double along = glm::dot(glm::cross(p1 - p0, p2 - p0), glm::dvec3(ray.direction));
  return (along > 0.0) - (along < 0.0);
}

// Whether a ray through the edges of `triangle` marked on_edge (one edge, or the vertex two of them meet
// at) crosses the surface there: every triangle that holds the point faces the ray as this one does, and
// the edges around the point are shared by two triangles each.
bool Referee::crossing(const Ray& ray, uint32_t triangle, const std::array<bool, 3>& on_edge) const {
  const int edges = int(on_edge[0]) + int(on_edge[1]) + int(on_edge[2]);
  const int side = facing(ray, triangle);
  if (side == 0 || edges == 0) return false;
  if (edges == 1) {
    const int k = on_edge[0] ? 0 : on_edge[1] ? 1 : 2;
    const uint32_t other = neighbour_[size_t(triangle) * 3 + k];
    return other != kInvalidIndex && facing(ray, other) == side;
  }
  if (edges > 2) return false;  // a triangle smaller than the tie distance: no verdict
  const int k = shared_corner(on_edge);
  for (const uint32_t t : fan_[corner_vertex_[size_t(triangle) * 3 + k]]) {
    if (facing(ray, t) != side) return false;
    for (int e = 0; e < 3; ++e)
      if (neighbour_[size_t(t) * 3 + e] == kInvalidIndex) {
        // an open edge at this vertex: the fan does not close around it
        const uint32_t v = corner_vertex_[size_t(triangle) * 3 + k];
        if (corner_vertex_[size_t(t) * 3 + e] == v || corner_vertex_[size_t(t) * 3 + (e + 1) % 3] == v) return false;
      }
  }
  return true;
}

Referee::Solution Referee::solve(const Ray& ray, uint32_t triangle) const {
  Solution s;
  const glm::dvec3 p[3] = {mesh_.vertex(triangle, 0), mesh_.vertex(triangle, 1), mesh_.vertex(triangle, 2)};
  const glm::dvec3 o = ray.origin, d = ray.direction;
  const glm::dvec3 n = glm::cross(p[1] - p[0], p[2] - p[0]);
  const double twice_area = glm::length(n), along = glm::dot(n, d);
  if (twice_area == 0.0 || along == 0.0) return s;
  s.parallel = false;
  s.t = glm::dot(n, p[0] - o) / along;
  const glm::dvec3 x = o + s.t * d;
  const double scale = std::max({magnitude(o), magnitude(p[0]), magnitude(p[1]), magnitude(p[2]), magnitude(x)});
  const double tie = kTieSteps * std::ldexp(scale, -23);
  // Signed distance in the plane from x to edge k (positive inside).
  double nearest = INFINITY;
  for (int k = 0; k < 3; ++k) {
    const glm::dvec3 a = p[k], b = p[(k + 1) % 3];
    const double length = glm::length(b - a);
    const double distance = length == 0.0 ? 0.0 : glm::dot(glm::cross(b - a, x - a), n) / (twice_area * length);
    s.on_edge[k] = std::abs(distance) <= tie;
    nearest = std::min(nearest, distance);
  }
  s.position = nearest > tie ? Place::Inside : nearest < -tie ? Place::Outside : Place::Tie;
  s.t_tie = tie / glm::length(d);
  const double t_tie = s.t_tie;
  const bool above_min = s.t > double(ray.tmin) + t_tie, below_max = s.t < double(ray.tmax) - t_tie;
  const bool below_min = s.t<double(ray.tmin) - t_tie, above_max = s.t> double(ray.tmax) + t_tie;
  s.interval = above_min && below_max ? Place::Inside : below_min || above_max ? Place::Outside : Place::Tie;
  return s;
}

Referee::Judgement Referee::judge(const Ray& ray, const Hit& answer, std::span<const uint32_t> candidates) const {
  double answer_t = INFINITY;
  if (answer.valid()) {
    const Solution s = solve(ray, answer.triangle);
    if (!s.parallel) {
      if (s.position == Place::Outside) return {Verdict::OffTriangle};
      if (s.interval == Place::Outside) return {Verdict::OutsideInterval};
      answer_t = s.t;
    } else {
      answer_t = double(answer.t);  // a ray in the triangle's plane: no verdict on the hit itself
    }
  }
  // A nearer hit that had to be found: inside a triangle, or where the ray crosses the surface at an
  // edge or vertex, its t clearly inside the interval.
  Judgement missed;
  for (const uint32_t c : candidates) {
    if (c == kInvalidIndex || (answer.valid() && c == answer.triangle)) continue;
    const Solution s = solve(ray, c);
    if (s.parallel || s.interval != Place::Inside || s.position == Place::Outside) continue;
    if (!(s.t < answer_t - s.t_tie)) continue;
    if (s.position == Place::Inside) return {Verdict::MissedInside, c};
    if (crossing(ray, c, s.on_edge) && !(answer.valid() && around(c, s.on_edge, answer.triangle)))
      missed = {Verdict::Leaked, c};
  }
  return missed;
}

Verdict Referee::judge_occlusion(const Ray& ray, bool occluded, std::span<const uint32_t> candidates) const {
  if (!occluded) return judge(ray, Hit{}, candidates).verdict;
  for (const uint32_t c : candidates) {
    if (c == kInvalidIndex) continue;
    const Solution s = solve(ray, c);
    if (!s.parallel && s.position != Place::Outside && s.interval != Place::Outside) return Verdict::Right;
  }
  return Verdict::OffTriangle;  // occluded by nothing any tracer found
}

}  // namespace raylab::bench
