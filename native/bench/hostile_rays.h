// Rays aimed where a ray/triangle test is most likely to be wrong: exactly at vertices and edges, almost
// parallel to a face, from a hair above a surface, and with tmax a hair past or short of the hit. Each ray
// knows the triangle it was aimed at, so the float64 referee (arbitration.h) can judge a miss.
#pragma once

#include "raylab/geometry.h"

#include <array>
#include <cstdint>
#include <vector>

namespace raylab::bench {

enum class HostileKind : uint8_t {
  Vertex,      // from a random point in the mesh's box at one of the triangle's vertices
  Edge,        // at a random point of one of its edges
  Grazing,     // at a point inside it, 1e-5 to 1e-2 (cosine) off its plane
  HairToward,  // from 1 to 100 float steps of the coordinates above a point inside it, towards it
  HairAway,    // from there, away from it (into the open half space)
  TmaxPast,    // at a point inside it with tmax 1e-6 (relative) past the hit: the hit counts
  TmaxShort,   // the same with tmax 1e-6 short of it: that triangle does not count
};
inline constexpr int kHostileKinds = 7;
const char* hostile_kind_name(HostileKind kind);

struct HostileRays {
  std::vector<Ray> rays;
  std::vector<uint32_t> target;   // the triangle each ray was aimed at
  std::vector<HostileKind> kind;  // ray i is of kind i % kHostileKinds
};

// `count` rays over the mesh's non-degenerate triangles, the kinds interleaved; the same for a seed.
HostileRays hostile_rays(const TriangleMesh& mesh, size_t count, uint32_t seed);

}  // namespace raylab::bench
