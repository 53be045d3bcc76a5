#include "hit_comparison.h"

#include <algorithm>
#include <cmath>

namespace raylab::bench {

namespace {

constexpr double kSameT = 1e-5;           // relative: the same hit
constexpr double kExactTie = 1e-6;        // relative: the same point on two faces
constexpr double kNearEdge = 1e-5;        // barycentric distance to the nearest edge
constexpr double kCoordinateUlps = 1e-6;  // world distance, relative to the coordinates' magnitude
constexpr double kGrazingCos = 1e-3;      // |cos| between the ray and the face normal
constexpr size_t kExamplesPerKind = 3;

double relative_difference(float a, float b) {
  const double scale = std::max({std::abs(double(a)), std::abs(double(b)), 1e-30});
  return std::abs(double(a) - double(b)) / scale;
}

double magnitude(const glm::dvec3& p) { return std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}); }

struct Corners {
  glm::dvec3 p0, p1, p2;
};

Corners corners(const TriangleMesh& mesh, uint32_t triangle) {
  return {mesh.vertex(triangle, 0), mesh.vertex(triangle, 1), mesh.vertex(triangle, 2)};
}

// The magnitude the rounding of a ray/triangle test is relative to: tests translate the corners by
// the ray origin, so both count.
double rounding_scale(const Ray& ray, const Corners& c) {
  return std::max({magnitude(ray.origin), magnitude(c.p0), magnitude(c.p1), magnitude(c.p2)});
}

// The hit on the edge: by barycentrics, or by the distance from the hit point to the nearest edge
// against the rounding of the coordinates (small triangles, or far from the ray origin).
bool near_edge(const TriangleMesh& mesh, const Ray& ray, const Hit& h) {
  const double b[3] = {1.0 - double(h.u) - double(h.v), double(h.u), double(h.v)};
  if (std::min({b[0], b[1], b[2]}) < kNearEdge) return true;
  const Corners c = corners(mesh, h.triangle);
  const glm::dvec3 p[3] = {c.p0, c.p1, c.p2};
  const double twice_area = glm::length(glm::cross(c.p1 - c.p0, c.p2 - c.p0));
  const double scale = rounding_scale(ray, c);
  for (int i = 0; i < 3; ++i) {
    // b[i] times the height over the opposite edge is the distance to that edge.
    const double opposite = glm::length(p[(i + 2) % 3] - p[(i + 1) % 3]);
    if (opposite > 0.0 && b[i] * twice_area / opposite < kCoordinateUlps * scale) return true;
  }
  return false;
}

bool share_vertex(const TriangleMesh& mesh, uint32_t a, uint32_t b) {
  const glm::uvec3 ta = mesh.triangles[a], tb = mesh.triangles[b];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (ta[i] == tb[j] || mesh.vertices[ta[i]] == mesh.vertices[tb[j]]) return true;
  return false;
}

bool grazing(const TriangleMesh& mesh, const Ray& ray, uint32_t triangle) {
  const Corners c = corners(mesh, triangle);
  const glm::dvec3 n = glm::cross(c.p1 - c.p0, c.p2 - c.p0);
  const glm::dvec3 d = ray.direction;
  const double len = glm::length(n) * glm::length(d);
  return len == 0.0 || std::abs(glm::dot(n, d)) < kGrazingCos * len;
}

// Both hits on one triangle lie on its plane within rounding: the hit points' distance along the
// face normal. Along the face they may slide further: a short t carries the origin's rounding, and a
// grazing ray stretches any error along the face.
bool same_plane_point(const TriangleMesh& mesh, const Ray& ray, const Hit& a, const Hit& b) {
  const Corners c = corners(mesh, a.triangle);
  const glm::dvec3 n = glm::cross(c.p1 - c.p0, c.p2 - c.p0);
  const double len = glm::length(n);
  if (len == 0.0) return false;
  const double off_plane = std::abs((double(a.t) - double(b.t)) * glm::dot(glm::dvec3(ray.direction), n) / len);
  return off_plane <= kCoordinateUlps * rounding_scale(ray, c);
}

// Hits on two triangles at points closer than the rounding of the coordinates involved.
bool same_point(const Ray& ray, const Hit& a, const Hit& b) {
  const glm::dvec3 o = ray.origin, d = ray.direction;
  const glm::dvec3 pa = o + double(a.t) * d, pb = o + double(b.t) * d;
  const double scale = std::max({magnitude(o), magnitude(pa), magnitude(pb)});
  return glm::length(pa - pb) <= kCoordinateUlps * scale;
}

// The ray against the plane of a triangle in double precision: t and the barycentrics (u, v) of
// vertices 1 and 2, NaN when the ray is parallel to the plane.
glm::dvec3 solve_double(const TriangleMesh& mesh, const Ray& ray, uint32_t triangle) {
  const Corners c = corners(mesh, triangle);
  const glm::dvec3 o = ray.origin, d = ray.direction;
  const glm::dvec3 e1 = c.p1 - c.p0, e2 = c.p2 - c.p0, s = o - c.p0;
  const glm::dvec3 pv = glm::cross(d, e2);
  const double det = glm::dot(e1, pv);
  if (det == 0.0) return glm::dvec3(NAN);
  const glm::dvec3 qv = glm::cross(s, e1);
  return {glm::dot(e2, qv) / det, glm::dot(s, pv) / det, glm::dot(d, qv) / det};
}

nlohmann::ordered_json hit_json(const TriangleMesh& mesh, const Ray& ray, const Hit& h) {
  if (!h.valid()) return nullptr;
  const glm::dvec3 exact = solve_double(mesh, ray, h.triangle);
  return {{"triangle", h.triangle},
          {"t", h.t},
          {"u", h.u},
          {"v", h.v},
          {"double_t", exact.x},
          {"double_u", exact.y},
          {"double_v", exact.z},
          {"on_edge", near_edge(mesh, ray, h)}};
}

// An unexplained difference settled by the referee's verdicts on both answers.
Agreement arbitrated(bool ours_right, bool theirs_right) {
  if (ours_right && theirs_right) return Agreement::RefereeTie;
  if (ours_right) return Agreement::EmbreeWrong;
  if (theirs_right) return Agreement::RaylabWrong;
  return Agreement::Unexplained;
}

std::vector<uint32_t> candidates_of(const Arbiter& arbiter, size_t i, const Hit& ours, const Hit& theirs) {
  std::vector<uint32_t> candidates{ours.triangle, theirs.triangle};
  if (!arbiter.targets.empty()) candidates.push_back(arbiter.targets[i]);
  return candidates;
}

Agreement arbitrate(const Arbiter& arbiter, size_t i, const Ray& ray, const Hit& ours, const Hit& theirs) {
  if (!arbiter.referee) return Agreement::Unexplained;
  const std::vector<uint32_t> candidates = candidates_of(arbiter, i, ours, theirs);
  return arbitrated(arbiter.referee->judge(ray, ours, candidates).verdict == Verdict::Right,
                    arbiter.referee->judge(ray, theirs, candidates).verdict == Verdict::Right);
}

Agreement arbitrate_any(const Arbiter& arbiter, size_t i, const Ray& ray, bool ours, bool theirs,
                        const Hit& our_closest, const Hit& their_closest) {
  if (!arbiter.referee) return Agreement::Unexplained;
  const std::vector<uint32_t> candidates = candidates_of(arbiter, i, our_closest, their_closest);
  return arbitrated(arbiter.referee->judge_occlusion(ray, ours, candidates) == Verdict::Right,
                    arbiter.referee->judge_occlusion(ray, theirs, candidates) == Verdict::Right);
}

void keep(Comparison& c, Agreement kind, const Ray& ray, const Hit& ours, const Hit& theirs) {
  ++c.counts[int(kind)];
  if (kind != Agreement::Same && c.counts[int(kind)] <= kExamplesPerKind)
    c.examples.push_back({kind, ray, ours, theirs});
}

}  // namespace

const char* agreement_name(Agreement a) {
  switch (a) {
    case Agreement::Same: return "same";
    case Agreement::Rounding: return "rounding";
    case Agreement::SharedEdgeVertex: return "shared_edge_vertex";
    case Agreement::CoincidentFaces: return "coincident_faces";
    case Agreement::EdgeRay: return "edge_ray";
    case Agreement::EdgeRayPassed: return "edge_ray_passed";
    case Agreement::Grazing: return "grazing";
    case Agreement::EmbreeWrong: return "embree_wrong";
    case Agreement::RaylabWrong: return "raylab_wrong";
    case Agreement::RefereeTie: return "referee_tie";
    case Agreement::Unexplained: return "unexplained";
  }
  return "?";
}

Agreement classify(const TriangleMesh& mesh, const Ray& ray, const Hit& ours, const Hit& theirs) {
  if (!ours.valid() && !theirs.valid()) return Agreement::Same;
  // One tracer found a hit (or a nearer one) the other passed by: explained when that hit is on an edge.
  auto passed_edge = [&](bool ours_nearer) {
    if (!near_edge(mesh, ray, ours_nearer ? ours : theirs)) return Agreement::Unexplained;
    return ours_nearer ? Agreement::EdgeRay : Agreement::EdgeRayPassed;
  };
  if (ours.valid() != theirs.valid()) return passed_edge(ours.valid());
  const double dt = relative_difference(ours.t, theirs.t);
  if (ours.triangle == theirs.triangle) {
    if (dt <= kSameT) return Agreement::Same;
    if (same_plane_point(mesh, ray, ours, theirs)) return Agreement::Rounding;
    return grazing(mesh, ray, ours.triangle) ? Agreement::Grazing : Agreement::Unexplained;
  }
  if (dt <= kExactTie || same_point(ray, ours, theirs)) {
    if (!share_vertex(mesh, ours.triangle, theirs.triangle)) return Agreement::CoincidentFaces;
    // Neighbours own a point together only on their common edge: elsewhere one of them is wrong.
    return near_edge(mesh, ray, ours) && near_edge(mesh, ray, theirs) ? Agreement::SharedEdgeVertex
                                                                      : Agreement::Unexplained;
  }
  return passed_edge(ours.t < theirs.t);
}

Comparison compare_closest(const TriangleMesh& mesh, std::span<const Ray> rays, std::span<const Hit> ours,
                           std::span<const Hit> theirs, const Arbiter& arbiter) {
  Comparison c;
  for (size_t i = 0; i < rays.size(); ++i) {
    Agreement kind = classify(mesh, rays[i], ours[i], theirs[i]);
    if (kind == Agreement::Unexplained) kind = arbitrate(arbiter, i, rays[i], ours[i], theirs[i]);
    keep(c, kind, rays[i], ours[i], theirs[i]);
  }
  return c;
}

Comparison compare_any(const TriangleMesh& mesh, std::span<const Ray> rays, std::span<const uint8_t> ours,
                       std::span<const uint8_t> theirs, std::span<const Hit> our_closest,
                       std::span<const Hit> their_closest, const Arbiter& arbiter) {
  Comparison c;
  for (size_t i = 0; i < rays.size(); ++i) {
    if (bool(ours[i]) == bool(theirs[i])) {
      ++c.counts[int(Agreement::Same)];
      continue;
    }
    // The tracer that saw an occluder saw it as its closest hit too; that hit tells whether the ray
    // only touched an edge.
    const Hit& seen = ours[i] ? our_closest[i] : their_closest[i];
    Agreement kind = !seen.valid() || !near_edge(mesh, rays[i], seen) ? Agreement::Unexplained
                     : ours[i]                                        ? Agreement::EdgeRay
                                                                      : Agreement::EdgeRayPassed;
    if (kind == Agreement::Unexplained)
      kind = arbitrate_any(arbiter, i, rays[i], ours[i], theirs[i], our_closest[i], their_closest[i]);
    keep(c, kind, rays[i], our_closest[i], their_closest[i]);
  }
  return c;
}

nlohmann::ordered_json comparison_json(const TriangleMesh& mesh, const Comparison& c) {
  nlohmann::ordered_json m = nlohmann::ordered_json::object();
  uint64_t total = 0;
  for (int k = 0; k < kAgreementKinds; ++k) {
    m[agreement_name(Agreement(k))] = c.counts[k];
    total += c.counts[k];
  }
  m["rays"] = total;
  nlohmann::ordered_json examples = nlohmann::ordered_json::array();
  for (const Disagreement& e : c.examples) {
    const Ray& r = e.ray;
    examples.push_back({{"kind", agreement_name(e.kind)},
                        {"origin", {r.origin.x, r.origin.y, r.origin.z}},
                        {"direction", {r.direction.x, r.direction.y, r.direction.z}},
                        {"tmin", r.tmin},
                        {"tmax", r.tmax},
                        {"raylab", hit_json(mesh, r, e.ours)},
                        {"embree", hit_json(mesh, r, e.theirs)}});
  }
  m["examples"] = std::move(examples);
  return m;
}

}  // namespace raylab::bench
