// Cameras exactly as Blender models them (BKE_camera_params_compute_viewplane): perspective and
// orthographic, sensor fit, lens shift, resolution percentage and pixel aspect. The camera looks
// down its local -Z with +Y up; raster coordinates run from the top-left corner of the picture.
#pragma once

#include "raylab/geometry.h"

#include <glm/mat4x4.hpp>

namespace raylab {

enum class CameraType { Perspective, Orthographic };
enum class SensorFit { Auto, Horizontal, Vertical };

struct CameraSettings {
  CameraType type = CameraType::Perspective;
  glm::mat4 matrix_world{1.0f};  // camera to world
  float lens = 50.0f;            // mm
  float sensor_width = 36.0f;    // mm
  float sensor_height = 24.0f;   // mm
  SensorFit sensor_fit = SensorFit::Auto;
  float shift_x = 0.0f;  // in units of the fitted dimension of the view plane
  float shift_y = 0.0f;
  float ortho_scale = 7.0f;
  float clip_start = 0.1f;
  float clip_end = 1000.0f;
  int resolution_x = 1920;
  int resolution_y = 1080;
  int resolution_percentage = 100;
  float pixel_aspect_x = 1.0f;
  float pixel_aspect_y = 1.0f;

  void validate() const;  // throws std::invalid_argument naming the bad setting
};

class Camera {
 public:
  explicit Camera(const CameraSettings& settings);  // validates

  int width() const { return width_; }  // resolution * percentage / 100, as Blender rounds it
  int height() const { return height_; }

  // The world ray through raster point (x, y): x in [0, width] to the right, y in [0, height]
  // downwards (y = 0 is the top edge). Pixel (i, j) has its centre at (i + 0.5, j + 0.5).
  // Direction is unit length; tmin/tmax are the clip distances along it. A perspective ray starts at
  // the camera; an orthographic ray starts on the camera's plane (local z = 0).
  Ray ray(float x, float y) const;

 private:
  CameraSettings settings_;
  int width_, height_;
  // The view plane at unit distance (perspective) or at the camera (orthographic), in camera space.
  float xmin_, xmax_, ymin_, ymax_;
};

}  // namespace raylab
