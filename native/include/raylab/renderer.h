// The Whitted-style ray tracer of VRT: Phong shading, point/sun/spot/area lights, hard shadows (soft
// from area lights), reflection, refraction with Schlick's Fresnel and total internal reflection, a
// recursion limit, NxN super-sampling and a solid background. Parallel over tiles; reports progress,
// can be cancelled, counts its rays by type and the structure's work.
#pragma once

#include "raylab/camera.h"
#include "raylab/cost_passes.h"
#include "raylab/light.h"
#include "raylab/material.h"
#include "raylab/scene.h"
#include "raylab/traversal_record.h"

#include <atomic>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace raylab {

struct RenderSettings {
  int super_sampling = 1;  // NxN stratified samples per pixel, 1..4
  int max_recursion = 3;   // reflection/refraction bounces after the primary hit
  bool shadows = true;
  glm::vec3 background{0.05f};
  glm::vec3 ambient{1.0f};      // scaled by each material's `ambient` and diffuse colour
  bool robust_offset = true;    // Wächter-Binder offset (ray_offset.h); false: fixed epsilon
  float fixed_epsilon = 1e-4f;  // along the normal, when robust_offset is false
  // Smooth-shaded hits: shadow rays start from the curved surface the shading normals imply (Hanika
  // 2021), and light behind the flat face but in front of the shading normal counts, so the
  // terminator follows the smooth normals instead of the facets.
  bool shadow_terminator = true;
  int threads = 0;  // 0: all
  int tile_size = 32;
  CostRays cost_rays = CostRays::All;           // which of a pixel's rays RenderResult::pixel_work counts
  size_t memory_budget = kDefaultMemoryBudget;  // for the render's buffers: see require_render_memory
  // Trace the camera rays of a tile's block of 8 x 8 pixels, and its hits' shadow rays towards each
  // light, in coherent batches
  // (the BVH's packets); false: one ray at a time. The image, the counters and the cost buffers are the
  // same bit for bit either way: the switch is there to compare them and their speed.
  bool batches = true;

  void validate() const;  // throws std::invalid_argument naming the bad setting
};

struct RenderStats {
  uint64_t rays_primary = 0;
  uint64_t rays_shadow = 0;
  uint64_t rays_reflection = 0;
  uint64_t rays_refraction = 0;
  TraversalStats traversal;  // of every ray above, summed over threads
  double build_seconds = 0.0;
  double render_seconds = 0.0;
  size_t memory_bytes = 0;
  std::string structure;  // of the scene's first mesh; empty for an empty scene
  int width = 0, height = 0;

  RenderStats& operator+=(const RenderStats& o);  // sums the ray and traversal counters
};

// Shared between the renderer and whoever waits for it (any thread). Counted in pixels, not tiles,
// and the cancel is read before every block of a tile (up to 8 x 8 pixels, traced together): a single
// tile in flight still moves the fraction, and a cancel stops any render, however large its tiles,
// within one such block's work per thread.
struct RenderProgress {
  std::atomic<uint64_t> pixels_done{0};
  std::atomic<uint64_t> pixels_total{0};
  std::atomic<bool> cancel_requested{false};

  float fraction() const {
    const uint64_t total = pixels_total.load();
    return total == 0 ? 0.0f : float(double(pixels_done.load()) / double(total));
  }
  void cancel() { cancel_requested.store(true); }
};

struct RenderResult {
  int width = 0, height = 0;
  std::vector<float> image;       // height x width x RGBA, linear, top row first
  std::vector<int32_t> instance;  // height x width: instance hit by the pixel-centre ray, -1 on miss
  std::vector<float> distance;    // height x width: |hit - ray origin| of that ray, inf on miss
  // height x width: the traversal work of each pixel's rays (settings.cost_rays: all of them, or the
  // primary ones), every sample's; with CostRays::All they add up to stats.traversal.
  std::vector<TraversalStats> pixel_work;
  // A cancelled render stops between pixels: each pixel is either finished or untouched, and an
  // untouched one keeps zero colour and alpha, instance -1, distance inf and no work.
  bool cancelled = false;
  RenderStats stats;
};

// Renders `scene` (committed) as seen by `camera`. Throws std::invalid_argument on bad settings,
// lights, materials, or an instance whose material index is out of range. The whole render reads
// one snapshot, taken when it starts: commits made meanwhile show in the next render.
RenderResult render(const Scene& scene, const CameraSettings& camera, std::span<const Light> lights,
                    std::span<const Material> materials, const RenderSettings& settings,
                    RenderProgress* progress = nullptr);
RenderResult render(const SceneSnapshot& scene, const CameraSettings& camera, std::span<const Light> lights,
                    std::span<const Material> materials, const RenderSettings& settings,
                    RenderProgress* progress = nullptr);

// The bytes RenderResult's buffers (image, instance, distance, pixel_work) take for a width x height
// render. Samples are not stored: super-sampling adds none.
size_t render_buffer_bytes(int width, int height);

// Throws std::invalid_argument, naming the resolution, super-sampling, the bytes needed and
// settings.memory_budget, when the render's buffers plus `caller_bytes_per_pixel` of the caller's own
// copies would not fit the budget. render() checks it (with no caller bytes) before it allocates.
void require_render_memory(int width, int height, const RenderSettings& settings, size_t caller_bytes_per_pixel = 0);

// The largest radiance the renderer computes, component by component: light closer to a point than
// floats resolve saturates here instead of overflowing, so finite accepted inputs give finite pixels.
inline constexpr float kRadianceLimit = 1e20f;

// Schlick's approximation of the Fresnel reflectance for light arriving with cos_incident (> 0)
// at an interface from a medium of index n1 into n2; 1 under total internal reflection.
float schlick_fresnel(float cos_incident, float n1, float n2);

// The refracted unit direction of unit `incident` through a surface with unit normal `n` facing the
// incident side, eta = n1 / n2; false on total internal reflection.
bool refract_direction(const glm::vec3& incident, const glm::vec3& n, float eta, glm::vec3& out);

}  // namespace raylab
