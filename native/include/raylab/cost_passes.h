// The cost passes, once: which per-pixel work the renderer's cost buffers (RenderResult::pixel_work)
// offer as images, and which of a pixel's rays they count. Exported as _raylab.COST_PASSES and
// _raylab.COST_RAYS; the Python API, the render engine's View Layer passes, the heat map and the tests
// read them from there.
#pragma once

namespace raylab {

// Which of a pixel's rays its cost buffers count (RenderSettings::cost_rays).
enum class CostRays { All, Primary };

struct CostRaysInfo {
  CostRays value;
  const char* name;  // the settings key's value in Python
  const char* label;
  const char* description;  // for tooltips
};

inline constexpr CostRaysInfo kCostRays[] = {
    {CostRays::All, "all", "All rays",
     "Every ray the pixel traced: primary, shadow, reflection and refraction, over all its samples"},
    {CostRays::Primary, "primary", "Primary rays", "Only the camera rays of the pixel's samples"},
};

// A pass shows one counter (a kCounters name, traversal_record.h) per pixel.
struct CostPassInfo {
  const char* name;         // the render pass's name (Blender's pass menu, the EXR's layer)
  const char* counter;      // the kCounters row it shows
  const char* label;        // for checkboxes and legends
  const char* description;  // for tooltips
};

inline constexpr CostPassInfo kCostPasses[] = {
    {"raylab Rays", "rays", "Rays", "Rays the pixel traced (all, or primary only)"},
    {"raylab Box Tests", "box_tests", "Box tests", "Ray/box tests of the pixel's rays"},
    {"raylab Triangle Tests", "triangle_tests", "Triangle tests", "Ray/triangle tests of the pixel's rays"},
    {"raylab Nodes Visited", "nodes_visited", "Nodes visited", "Nodes the pixel's rays entered"},
};

}  // namespace raylab
