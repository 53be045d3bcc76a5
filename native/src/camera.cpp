#include "raylab/camera.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace raylab {

namespace {

void require(bool ok, const char* what) {
  if (!ok) throw std::invalid_argument(std::string("camera: ") + what);
}

bool finite(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

}  // namespace

void CameraSettings::validate() const {
  require(finite(matrix_world), "matrix_world has a NaN or infinite entry");
  require(glm::determinant(glm::mat3(matrix_world)) != 0.0f, "matrix_world is singular");
  require(lens > 0.0f, "lens must be > 0");
  require(sensor_width > 0.0f, "sensor_width must be > 0");
  require(sensor_height > 0.0f, "sensor_height must be > 0");
  require(ortho_scale > 0.0f, "ortho_scale must be > 0");
  require(std::isfinite(shift_x) && std::isfinite(shift_y), "shift_x and shift_y must be finite");
  require(clip_start >= 0.0f, "clip_start must be >= 0");
  require(clip_end > clip_start, "clip_end must be > clip_start");
  require(resolution_x > 0, "resolution_x must be > 0");
  require(resolution_y > 0, "resolution_y must be > 0");
  require(resolution_percentage > 0, "resolution_percentage must be > 0");
  require(pixel_aspect_x > 0.0f && pixel_aspect_y > 0.0f, "pixel_aspect_x and pixel_aspect_y must be > 0");
  require(int64_t(resolution_x) * resolution_percentage / 100 > 0 &&
              int64_t(resolution_y) * resolution_percentage / 100 > 0,
          "resolution * resolution_percentage / 100 is zero");
  require(int64_t(resolution_x) * resolution_percentage / 100 <= 65536 &&
              int64_t(resolution_y) * resolution_percentage / 100 <= 65536,
          "resolution * resolution_percentage / 100 exceeds 65536");
}

// Follows Blender's BKE_camera_params_compute_viewplane, with the view plane taken at unit distance
// (perspective) instead of at clip_start, which only scales it.
Camera::Camera(const CameraSettings& s) : settings_(s) {
  s.validate();
  width_ = int(int64_t(s.resolution_x) * s.resolution_percentage / 100);
  height_ = int(int64_t(s.resolution_y) * s.resolution_percentage / 100);
  const float winx = float(width_), winy = float(height_);
  const float xasp = s.pixel_aspect_x, yasp = s.pixel_aspect_y;
  const float ycor = yasp / xasp;

  SensorFit fit = s.sensor_fit;
  if (fit == SensorFit::Auto) fit = (xasp * winx >= yasp * winy) ? SensorFit::Horizontal : SensorFit::Vertical;
  // AUTO measures the larger dimension against sensor_width, as Blender does.
  const float sensor = s.sensor_fit == SensorFit::Vertical ? s.sensor_height : s.sensor_width;
  float pixsize = s.type == CameraType::Orthographic ? s.ortho_scale : sensor / s.lens;
  const float viewfac = fit == SensorFit::Horizontal ? winx : ycor * winy;
  pixsize /= viewfac;

  const float dx = s.shift_x * viewfac, dy = s.shift_y * viewfac;
  xmin_ = (-0.5f * winx + dx) * pixsize;
  xmax_ = (0.5f * winx + dx) * pixsize;
  ymin_ = (-0.5f * ycor * winy + dy) * pixsize;
  ymax_ = (0.5f * ycor * winy + dy) * pixsize;
}

Ray Camera::ray(float x, float y) const {
  const float cx = xmin_ + (x / float(width_)) * (xmax_ - xmin_);
  const float cy = ymax_ - (y / float(height_)) * (ymax_ - ymin_);
  const bool ortho = settings_.type == CameraType::Orthographic;
  const glm::vec4 origin_cam = ortho ? glm::vec4(cx, cy, 0.0f, 1.0f) : glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);
  const glm::vec4 dir_cam = ortho ? glm::vec4(0.0f, 0.0f, -1.0f, 0.0f) : glm::vec4(cx, cy, -1.0f, 0.0f);
  // dir_cam advances one unit of camera depth per unit of parameter, so the clip distances are
  // parameters along it; normalising rescales them by its world length.
  const glm::vec3 d = glm::vec3(settings_.matrix_world * dir_cam);
  const float length = glm::length(d);
  Ray r;
  r.origin = glm::vec3(settings_.matrix_world * origin_cam);
  r.direction = d / length;
  r.tmin = settings_.clip_start * length;
  r.tmax = settings_.clip_end * length;
  return r;
}

}  // namespace raylab
