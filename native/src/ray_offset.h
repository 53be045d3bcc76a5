// Where a secondary ray (shadow, reflection, refraction) starts. A hit point computed in floating
// point lies a few ulps off its surface, on either side; a ray started there can hit its own surface
// again ("shadow acne"). A fixed epsilon along the normal fails at large coordinates (the epsilon is
// below one ulp and vanishes) and leaks at small scales (it jumps over thin geometry).
// Wächter and Binder (Ray Tracing Gems, ch. 6, "A Fast and Robust Method for Avoiding
// Self-Intersection") move the point a fixed number of ulps along the normal instead, which scales
// with the coordinate, and fall back to a tiny absolute offset near the origin where ulps vanish.
#pragma once

#include <glm/vec3.hpp>

#include <bit>
#include <cmath>
#include <cstdint>

namespace raylab {

namespace ray_offset_constants {
inline constexpr float kOrigin = 1.0f / 32.0f;         // below this |coordinate| use the float offset
inline constexpr float kFloatScale = 1.0f / 65536.0f;  // absolute offset near the origin
inline constexpr float kIntScale = 256.0f;             // ulps per unit of normal component
}  // namespace ray_offset_constants

// `p` is a hit point, `n` the geometric normal on the side the new ray leaves towards (unit length).
inline glm::vec3 offset_ray(const glm::vec3& p, const glm::vec3& n) {
  using namespace ray_offset_constants;
  glm::vec3 out;
  for (int i = 0; i < 3; ++i) {
    const int32_t of = static_cast<int32_t>(kIntScale * n[i]);
    const int32_t bits = std::bit_cast<int32_t>(p[i]);
    // Adding to the integer representation moves away from zero for either sign of p, so the step
    // is subtracted for negative coordinates to move along +n.
    const float stepped = std::bit_cast<float>(bits + (p[i] < 0.0f ? -of : of));
    out[i] = std::fabs(p[i]) < kOrigin ? p[i] + kFloatScale * n[i] : stepped;
  }
  return out;
}

// The naive method, kept to show where it fails.
inline glm::vec3 offset_ray_fixed(const glm::vec3& p, const glm::vec3& n, float epsilon) { return p + epsilon * n; }

}  // namespace raylab
