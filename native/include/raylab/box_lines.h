// A structure's boxes as line geometry ready for the GPU: the overlay's arrays, made in the core so
// that the add-on only hands them to a batch (a deep octree must be built and drawn at the viewport's
// pace, which numpy alone missed on these arrays: docs/bench/history.md).
#pragma once

#include "raylab/structure.h"

#include <glm/vec2.hpp>
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

// The arrays are numpy's (N,3) f32, (N,4) f32 and (N,2) u32 rows seen as glm vectors.
static_assert(sizeof(glm::vec3) == 12 && sizeof(glm::vec4) == 16 && sizeof(glm::uvec2) == 8);

// The faded alpha factor of a box at `depth` among `box_count` drawn: 1 / (1 + 0.35 depth), times
// min(1, sqrt(200 / box_count)), at least kFadeFloor; computed in float as the overlay's numpy did.
float fade_alpha(int depth, size_t box_count);

// The edges of a box over its corners (corner c takes hi on axis a where bit a of c is set, else lo).
inline constexpr uint32_t kBoxEdges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                                              {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

// The indices of the boxes the options' filters keep (depth range, leaves only), in order.
std::vector<uint32_t> selected_boxes(std::span<const BoxInfo> boxes, const BoxLineOptions& options);

// The selected boxes' lines, written straight into the caller's arrays (the bindings' numpy arrays:
// writing them into vectors and copying them again cost as much as the writing, docs/bench/history.md):
// 8 corners and their 8 colours per box, 12 edges as pairs of corner indices.
// positions, colors: 8 * selected.size(); indices: 12 * selected.size().
void write_box_lines(std::span<const BoxInfo> boxes, std::span<const uint32_t> selected, const BoxLineOptions& options,
                     std::span<glm::vec3> positions, std::span<glm::vec4> colors, std::span<glm::uvec2> indices);

}  // namespace raylab
