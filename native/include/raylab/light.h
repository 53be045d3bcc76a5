// Lights as Blender defines them: point, sun, spot, area (square). Energies are Blender's: watts for
// point, spot and area lights, irradiance (W/m^2) for the sun.
#pragma once

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

namespace raylab {

enum class LightType { Point, Sun, Spot, Area };

struct Light {
  LightType type = LightType::Point;
  glm::vec3 color{1.0f};
  float energy = 1000.0f;
  glm::mat4 matrix_world{1.0f};  // light to world; sun, spot and area lights shine down local -Z
  float radius = 0.1f;           // Blender's soft size; shadows of point and spot lights stay hard
  float spot_size = 0.785398f;   // full cone angle, radians
  float spot_blend = 0.15f;      // 0..1, the smoothstep band inside the cone
  float size = 1.0f;             // area: side of the square
  int samples = 3;               // area: samples x samples stratified points
  bool shadows = true;

  void validate() const;  // throws std::invalid_argument naming the bad value
};

}  // namespace raylab
