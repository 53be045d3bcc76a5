#include "raylab/box_lines.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace raylab {

float fade_alpha(int depth, size_t box_count) {
  const float by_depth = 1.0f / (1.0f + 0.35f * float(depth));
  const float by_density = float(std::min(1.0, std::sqrt(200.0 / double(std::max<size_t>(box_count, 1)))));
  return std::max(by_depth * by_density, kFadeFloor);
}

std::vector<uint32_t> selected_boxes(std::span<const BoxInfo> boxes, const BoxLineOptions& options) {
  std::vector<uint32_t> kept;
  kept.reserve(boxes.size());
  for (uint32_t i = 0; i < boxes.size(); ++i) {
    const BoxInfo& b = boxes[i];
    if (b.depth >= options.depth_min && b.depth <= options.depth_max && (!options.leaves_only || b.leaf))
      kept.push_back(i);
  }
  return kept;
}

void write_box_lines(std::span<const BoxInfo> boxes, std::span<const uint32_t> selected, const BoxLineOptions& options,
                     std::span<glm::vec3> positions, std::span<glm::vec4> colors, std::span<glm::uvec2> indices) {
  if (options.palette.empty()) throw std::invalid_argument("palette must have at least one colour");
  const size_t n = selected.size();
  if (positions.size() != 8 * n || colors.size() != 8 * n || indices.size() != 12 * n)
    throw std::invalid_argument("write_box_lines: the arrays must hold 8, 8 and 12 entries per box");
  const size_t palette_size = options.palette.size();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t k = r.begin(); k != r.end(); ++k) {
      const BoxInfo& b = boxes[selected[k]];
      for (uint32_t c = 0; c < 8; ++c)
        positions[8 * k + c] = {(c & 1) ? b.bounds.hi.x : b.bounds.lo.x, (c & 2) ? b.bounds.hi.y : b.bounds.lo.y,
                                (c & 4) ? b.bounds.hi.z : b.bounds.lo.z};
      glm::vec4 color = options.palette[size_t(std::max(b.depth, 0)) % palette_size];
      if (options.fade) color.w *= fade_alpha(b.depth, n);
      color.w *= options.alpha_scale;
      for (size_t c = 0; c < 8; ++c) colors[8 * k + c] = color;
      const uint32_t base = uint32_t(8 * k);
      for (int e = 0; e < 12; ++e) indices[12 * k + e] = {base + kBoxEdges[e][0], base + kBoxEdges[e][1]};
    }
  });
}

}  // namespace raylab
