// The Phong material of the Whitted renderer (VRT's material model).
#pragma once

#include <glm/vec3.hpp>

namespace raylab {

// The accepted ranges of the gains that multiply light. Within them every product of the shading
// stays far inside float's range (renderer.h, kRadianceLimit): a highlight of specular x (shininess
// + 2) / 2pi times the largest irradiance, a mirror's tint times the largest radiance, a refraction
// ratio squared.
inline constexpr float kMaxDiffuse = 1e3f;  // each component, either sign
inline constexpr float kMaxSpecular = 1e3f;
inline constexpr float kMaxShininess = 1e6f;
inline constexpr float kIorRange[2] = {1e-3f, 1e3f};

struct Material {
  glm::vec3 diffuse{0.8f};
  float specular = 0.5f;    // weight of the Phong highlight
  float shininess = 32.0f;  // Phong exponent
  float metallic = 0.0f;    // raises the reflectivity to 1, tints the reflection, removes diffuse
  float reflectivity = 0.0f;
  float transmission = 0.0f;  // fraction refracted (split again by Fresnel)
  float ior = 1.45f;
  float ambient = 0.05f;  // weight of the settings' ambient colour

  void validate() const;  // throws std::invalid_argument naming the bad value
};

}  // namespace raylab
