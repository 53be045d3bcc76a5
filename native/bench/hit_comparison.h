// Compares raylab's hits with Embree's on the same rays and explains each disagreement.
#pragma once

#include "raylab/geometry.h"

#include <array>
#include <cstdint>
#include <span>

namespace raylab::bench {

// What a disagreement between two tracers on one ray is, most benign first.
enum class Agreement {
  Same,              // both miss, or the same triangle at t within 1e-5 relative
  SharedEdgeVertex,  // different triangles sharing a vertex, t within 1e-6 relative: an exact edge or
                     // vertex hit that both adjacent triangles own, broken differently
  CoincidentFaces,   // different triangles sharing no vertex at the same t: overlapping faces
  EdgeRay,           // one hits and the other misses (or hits farther), and the nearer hit lies
                     // within 1e-5 (barycentric) of its triangle's edge: the ray grazes an edge
  Grazing,           // the same triangle, t differs: the ray is almost parallel to the face
  Unexplained,
};
inline constexpr int kAgreementKinds = 6;
const char* agreement_name(Agreement a);

using AgreementCounts = std::array<uint64_t, kAgreementKinds>;

Agreement classify(const TriangleMesh& mesh, const Ray& ray, const Hit& ours, const Hit& theirs);

// Closest hits: every ray classified. Any-hit: a hit/miss difference is explained when the same
// ray's closest hits already disagree as an edge ray (or agree on a hit at an edge), else it counts
// as unexplained.
AgreementCounts compare_closest(const TriangleMesh& mesh, std::span<const Ray> rays, std::span<const Hit> ours,
                                std::span<const Hit> theirs);
AgreementCounts compare_any(const TriangleMesh& mesh, std::span<const Ray> rays, std::span<const uint8_t> ours,
                            std::span<const uint8_t> theirs, std::span<const Hit> our_closest,
                            std::span<const Hit> their_closest);

}  // namespace raylab::bench
