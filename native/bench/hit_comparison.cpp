#include "hit_comparison.h"

#include <algorithm>
#include <cmath>

namespace raylab::bench {

namespace {

constexpr double kSameT = 1e-5;      // relative: the same hit
constexpr double kExactTie = 1e-6;   // relative: the same point on two faces
constexpr double kNearEdge = 1e-5;   // barycentric distance to the nearest edge
constexpr double kGrazingCos = 1e-3; // |cos| between the ray and the face normal

double relative_difference(float a, float b) {
  const double scale = std::max({std::abs(double(a)), std::abs(double(b)), 1e-30});
  return std::abs(double(a) - double(b)) / scale;
}

bool near_edge(const Hit& h) {
  const double w = 1.0 - double(h.u) - double(h.v);
  return std::min({double(h.u), double(h.v), w}) < kNearEdge;
}

bool share_vertex(const TriangleMesh& mesh, uint32_t a, uint32_t b) {
  const glm::uvec3 ta = mesh.triangles[a], tb = mesh.triangles[b];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (ta[i] == tb[j] || mesh.vertices[ta[i]] == mesh.vertices[tb[j]]) return true;
  return false;
}

bool grazing(const TriangleMesh& mesh, const Ray& ray, uint32_t triangle) {
  const glm::dvec3 p0 = mesh.vertex(triangle, 0), p1 = mesh.vertex(triangle, 1), p2 = mesh.vertex(triangle, 2);
  const glm::dvec3 n = glm::cross(p1 - p0, p2 - p0);
  const glm::dvec3 d = ray.direction;
  const double len = glm::length(n) * glm::length(d);
  return len == 0.0 || std::abs(glm::dot(n, d)) < kGrazingCos * len;
}

}  // namespace

const char* agreement_name(Agreement a) {
  switch (a) {
    case Agreement::Same: return "same";
    case Agreement::SharedEdgeVertex: return "shared_edge_vertex";
    case Agreement::CoincidentFaces: return "coincident_faces";
    case Agreement::EdgeRay: return "edge_ray";
    case Agreement::Grazing: return "grazing";
    case Agreement::Unexplained: return "unexplained";
  }
  return "?";
}

Agreement classify(const TriangleMesh& mesh, const Ray& ray, const Hit& ours, const Hit& theirs) {
  if (!ours.valid() && !theirs.valid()) return Agreement::Same;
  if (ours.valid() != theirs.valid())
    return near_edge(ours.valid() ? ours : theirs) ? Agreement::EdgeRay : Agreement::Unexplained;
  const double dt = relative_difference(ours.t, theirs.t);
  if (ours.triangle == theirs.triangle) {
    if (dt <= kSameT) return Agreement::Same;
    return grazing(mesh, ray, ours.triangle) ? Agreement::Grazing : Agreement::Unexplained;
  }
  if (dt <= kExactTie)
    return share_vertex(mesh, ours.triangle, theirs.triangle) ? Agreement::SharedEdgeVertex
                                                              : Agreement::CoincidentFaces;
  // One tracer found a nearer hit the other passed by: explained when that hit is at an edge.
  const Hit& nearer = ours.t < theirs.t ? ours : theirs;
  return near_edge(nearer) ? Agreement::EdgeRay : Agreement::Unexplained;
}

AgreementCounts compare_closest(const TriangleMesh& mesh, std::span<const Ray> rays, std::span<const Hit> ours,
                                std::span<const Hit> theirs) {
  AgreementCounts counts{};
  for (size_t i = 0; i < rays.size(); ++i) ++counts[int(classify(mesh, rays[i], ours[i], theirs[i]))];
  return counts;
}

AgreementCounts compare_any(const TriangleMesh&, std::span<const Ray> rays, std::span<const uint8_t> ours,
                            std::span<const uint8_t> theirs, std::span<const Hit> our_closest,
                            std::span<const Hit> their_closest) {
  AgreementCounts counts{};
  for (size_t i = 0; i < rays.size(); ++i) {
    if (bool(ours[i]) == bool(theirs[i])) {
      ++counts[int(Agreement::Same)];
      continue;
    }
    // The tracer that saw an occluder saw it as its closest hit too; that hit tells whether the ray
    // only touched an edge.
    const Hit& seen = ours[i] ? our_closest[i] : their_closest[i];
    ++counts[int(seen.valid() && near_edge(seen) ? Agreement::EdgeRay : Agreement::Unexplained)];
  }
  return counts;
}

}  // namespace raylab::bench
