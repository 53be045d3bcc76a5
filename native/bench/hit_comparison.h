// Compares raylab's hits with Embree's on the same rays and explains each disagreement, with a few
// example rays per kind re-solved in double precision.
#pragma once

#include "arbitration.h"
#include "raylab/geometry.h"

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace raylab::bench {

// What a disagreement between two tracers on one ray is, most benign first. Tolerances are in
// world units where rounding is: a float coordinate carries about 1.2e-7 of its magnitude, and a
// test works on the corners minus the ray origin.
enum class Agreement {
  Same,              // both miss, or the same triangle at t within 1e-5 relative
  Rounding,          // the same triangle, t differs, but both hit points lie on its plane within 1e-6
                     // of the coordinates' magnitude: the difference is a slide along the face, which
                     // a short t (the origin's rounding) or a grazing ray magnifies
  SharedEdgeVertex,  // different triangles sharing a vertex at the same point, on an edge of both: an
                     // exact edge or vertex hit that both adjacent triangles own, broken differently
  CoincidentFaces,   // different triangles sharing no vertex at the same t: overlapping faces
  EdgeRay,           // raylab hits a triangle on its edge (1e-5 barycentric, or 1e-6 of the magnitude of
                     // the corners and the ray origin) where Embree misses or hits farther: Embree's
                     // default test is not watertight, and the ray slipped through the edge
  EdgeRayPassed,     // the reverse: Embree hits on an edge that raylab passes
  Grazing,           // the same triangle, t differs: the ray is almost parallel to the face
  EmbreeWrong,       // none of the above, and the float64 referee (arbitration.h) judges Embree's answer
                     // wrong and raylab's right: a hostile ray (tmax a hair past or short of the hit, a
                     // hair above a surface) that Embree's rounding gets wrong
  RaylabWrong,       // the reverse: raylab's answer wrong, Embree's right (never for the exact contract)
  RefereeTie,        // none of the above, and the referee finds both answers right: points within its tie
                     // distance of an edge or of tmax, where the tracers' barycentrics or t are too
                     // rounded for the classes above (a grazing ray at a vertex)
  Unexplained,
};
inline constexpr int kAgreementKinds = 11;
const char* agreement_name(Agreement a);

using AgreementCounts = std::array<uint64_t, kAgreementKinds>;

// One disagreeing ray, kept as evidence: both hits and, for each hit triangle, the ray's hit solved
// in double precision (t, u, v) as the referee.
struct Disagreement {
  Agreement kind;
  Ray ray;
  Hit ours, theirs;
};

struct Comparison {
  AgreementCounts counts{};
  std::vector<Disagreement> examples;  // the first few of each kind but Same
};

Agreement classify(const TriangleMesh& mesh, const Ray& ray, const Hit& ours, const Hit& theirs);

// What the float64 referee needs to settle what the classes above leave unexplained: the referee and,
// per ray, the triangle it was aimed at (or empty).
struct Arbiter {
  const Referee* referee = nullptr;
  std::span<const uint32_t> targets;
};

// Closest hits: every ray classified. Any-hit: a hit/miss difference is explained when the hit the
// occluding tracer saw as closest lies on an edge, else it counts as unexplained. With an arbiter, an
// unexplained difference is EmbreeWrong or RaylabWrong where the referee finds exactly one side wrong.
Comparison compare_closest(const TriangleMesh& mesh, std::span<const Ray> rays, std::span<const Hit> ours,
                           std::span<const Hit> theirs, const Arbiter& arbiter = {});
Comparison compare_any(const TriangleMesh& mesh, std::span<const Ray> rays, std::span<const uint8_t> ours,
                       std::span<const uint8_t> theirs, std::span<const Hit> our_closest,
                       std::span<const Hit> their_closest, const Arbiter& arbiter = {});

// JSON: {"same": n, ..., "rays": N, "examples": [...]}, each example with the ray, both hits and the
// double-precision referee for both triangles; keys in that order.
nlohmann::ordered_json comparison_json(const TriangleMesh& mesh, const Comparison& c);

}  // namespace raylab::bench
