// A structure's boxes as line geometry ready for the GPU: the overlay's arrays, made in the core so
// that the add-on only hands them to a batch (the viewport goal: a depth-8 octree on the dragon
// built and drawn within 100 ms; numpy spent 140 ms on these arrays alone).
#pragma once

#include "raylab/structure.h"

#include <glm/vec4.hpp>

#include <climits>
#include <cstdint>
#include <span>
#include <vector>

namespace raylab {

// Which boxes to draw and how to colour them.
struct BoxLineOptions {
  int depth_min = 0, depth_max = INT_MAX;  // both inclusive
  bool leaves_only = false;
  // The colour of a box at depth d is palette[d % size]: one row gives every box that colour.
  std::vector<glm::vec4> palette{{1.0f, 1.0f, 1.0f, 1.0f}};
  // Alpha falls with depth and with the number of boxes drawn, never below kFadeFloor (fade_alpha).
  bool fade = false;
  float alpha_scale = 1.0f;  // every alpha times this (the overlay dims the boxes under the probe)
};

inline constexpr float kFadeFloor = 0.12f;

// The faded alpha factor of a box at `depth` among `box_count` drawn: 1 / (1 + 0.35 depth), times
// min(1, sqrt(200 / box_count)), at least kFadeFloor; computed in float as the overlay's numpy did.
float fade_alpha(int depth, size_t box_count);

// 8 corners per box (corner c takes hi on axis a where bit a of c is set, else lo), their colours,
// and 12 edges per box as pairs of corner indices.
struct BoxLines {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec4> colors;
  std::vector<glm::uvec2> indices;
  size_t box_count = 0;
};

// The edges of a box over its corners (the same corner numbering as BoxLines).
inline constexpr uint32_t kBoxEdges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                                              {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

BoxLines box_lines(std::span<const BoxInfo> boxes, const BoxLineOptions& options);

}  // namespace raylab
