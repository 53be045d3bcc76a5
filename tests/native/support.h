// What the C++ tests share: meshes made from arrays or read from the shipped files, and rays.
#pragma once

#include "raylab/geometry.h"
#include "raylab/mesh_io.h"
#include "raylab/structure.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include <memory>
#include <random>
#include <string>
#include <vector>

namespace raylab::test {

// Sets an environment variable for its lifetime, then puts back what was there (POSIX setenv, or the
// Windows C runtime's _putenv_s: the tests run on both).
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    const char* before = std::getenv(name);
    had_ = before != nullptr;
    if (had_) before_ = before;
    set(value);
  }
  ~ScopedEnv() { set(had_ ? before_.c_str() : nullptr); }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  void set(const char* value) {
#ifdef _WIN32
    _putenv_s(name_.c_str(), value ? value : "");  // an empty value removes it
#else
    if (value) setenv(name_.c_str(), value, 1);
    else unsetenv(name_.c_str());
#endif
  }
  std::string name_, before_;
  bool had_ = false;
};

inline MeshPtr mesh_of(std::vector<glm::vec3> vertices, std::vector<glm::uvec3> triangles) {
  auto mesh = std::make_shared<TriangleMesh>();
  mesh->vertices = std::move(vertices);
  mesh->triangles = std::move(triangles);
  return mesh;
}

// A mesh of addon/raylab/meshes/, e.g. "bunny.obj".
// A flat grid of 2 n^2 triangles in z = 0: centroids tie along every axis (degenerate boxes, the median
// and Morton builders' ties).
inline MeshPtr flat_grid(int n) {
  auto mesh = std::make_shared<TriangleMesh>();
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) mesh->vertices.push_back({float(x) / n, float(y) / n, 0.0f});
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const uint32_t a = y * (n + 1) + x, b = a + 1, c = a + n + 1, d = c + 1;
      mesh->triangles.push_back({a, b, d});
      mesh->triangles.push_back({a, d, c});
    }
  return mesh;
}

inline MeshPtr shipped(const std::string& name) {
  return std::make_shared<TriangleMesh>(load_mesh(std::string(RAYLAB_MESH_DIR) + "/" + name));
}

inline Ray ray_of(glm::vec3 origin, glm::vec3 direction, float tmin = 0.0f, float tmax = kInfinity) {
  Ray r;
  r.origin = origin;
  r.direction = direction;
  r.tmin = tmin;
  r.tmax = tmax;
  return r;
}

// Three draws as a vector, drawn z first. C++ leaves the order of a call's arguments open: x86-64 GCC
// evaluates glm::vec3(draw(), draw(), draw()) last argument first, arm64 GCC first argument first. A
// fixed order, x86's, gives every architecture the rays the tests' counts were chosen with.
template <class Draw>
glm::vec3 draw_vec3(Draw&& draw) {
  const float z = draw(), y = draw(), x = draw();
  return {x, y, z};
}

// Random rays around and inside a mesh, half of them aimed exactly at a vertex (the hard case: the
// hit lies on edges shared by several triangles, often on a cell or octant boundary).
inline std::vector<Ray> random_rays(const TriangleMesh& mesh, size_t count, uint32_t seed) {
  std::mt19937 rng(seed);
  const Bounds b = mesh.bounds();
  std::uniform_real_distribution<float> unit(0.0f, 1.0f), signed_unit(-1.0f, 1.0f);
  std::uniform_int_distribution<uint32_t> vertex(0, uint32_t(mesh.vertices.size() - 1));
  std::vector<Ray> rays(count);
  for (size_t i = 0; i < count; ++i) {
    const glm::vec3 f = draw_vec3([&] { return unit(rng); });
    rays[i].origin = b.lo - 0.5f * b.extent() + 2.0f * f * b.extent();
    rays[i].direction =
        i % 2 ? mesh.vertices[vertex(rng)] - rays[i].origin : draw_vec3([&] { return signed_unit(rng); });
  }
  return rays;
}

// A pinhole camera's rays, row by row, looking at the mesh from `side` (a unit axis, +-x or +-z),
// the image a little wider than the mesh.
inline std::vector<Ray> camera_rays(const TriangleMesh& mesh, int width, int height, glm::vec3 side) {
  const Bounds b = mesh.bounds();
  const glm::vec3 c = b.center(), e = b.extent();
  const float size = std::max({e.x, e.y, e.z});
  const glm::vec3 eye = c + 2.5f * size * side;
  const glm::vec3 forward = -side, up(0.0f, 1.0f, 0.0f);
  const glm::vec3 right = glm::normalize(glm::cross(forward, up));
  std::vector<Ray> rays;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float px = (float(x) + 0.5f) / float(width) * 2.0f - 1.0f;
      const float py = 1.0f - (float(y) + 0.5f) / float(height) * 2.0f;
      const float aspect = float(width) / float(height);
      rays.push_back(ray_of(eye, forward + 0.3f * (px * aspect * right + py * up)));
    }
  return rays;
}

// Shadow rays from each hit of `camera` to a point light (tmax 1: the direction reaches the light).
inline std::vector<Ray> shadow_rays(const TriangleMesh& mesh, const Structure& s, const std::vector<Ray>& camera) {
  const Bounds b = mesh.bounds();
  const glm::vec3 light = b.center() + glm::vec3(0.5f, 2.0f, 1.0f) * b.extent();
  std::vector<Ray> rays;
  for (const Ray& ray : camera) {
    Hit h;
    if (!s.closest(ray, h)) continue;
    const glm::vec3 p = ray.at(h.t);
    rays.push_back(ray_of(p, light - p, 1e-4f, 1.0f));
  }
  return rays;
}

// Frame f (of `frames`) of an animation of `rest` for the refit tests: a twist about z and a wave along x that grow
// with f, and three frames that stress the refit: f = 8 flattens the mesh onto z = 0 (coplanar overlaps, many triangles
// degenerate to segments), f = 12 collapses the vertices with x above the centre onto one point (degenerate triangles),
// f = 16 mirrors x (every triangle flips its winding).
inline std::vector<glm::vec3> animated_vertices(const TriangleMesh& rest, int f, int frames) {
  const Bounds b = rest.bounds();
  const glm::vec3 c = b.center(), e = b.extent();
  const float size = std::max({e.x, e.y, e.z});
  std::vector<glm::vec3> out(rest.vertices.size());
  for (size_t i = 0; i < out.size(); ++i) {
    glm::vec3 p = rest.vertices[i] - c;
    const float angle = 1.5f * float(f) / float(frames) * (p.z / size);
    p = {p.x * std::cos(angle) - p.y * std::sin(angle), p.x * std::sin(angle) + p.y * std::cos(angle), p.z};
    p.y += 0.1f * size * std::sin(6.0f * p.x / size + 0.5f * float(f));
    if (f == 8) p.z = 0.0f;
    if (f == 12 && p.x > 0.0f) p = {0.25f * size, 0.0f, 0.0f};
    if (f == 16) p.x = -p.x;
    out[i] = p + c;
  }
  return out;
}

// Sutherland–Hodgman: the part of the triangle inside the box grown by `grow`, in double. Independent
// of the separating-axis test the octree and the grid use; non-empty means the triangle overlaps the box.
inline std::vector<glm::dvec3> clip_to_box(const TriangleMesh& mesh, uint32_t triangle, const Bounds& box,
                                           double grow) {
  std::vector<glm::dvec3> poly = {mesh.vertex(triangle, 0), mesh.vertex(triangle, 1), mesh.vertex(triangle, 2)};
  for (int axis = 0; axis < 3; ++axis)
    for (double side : {-1.0, 1.0}) {
      const double plane = side < 0 ? double(box.lo[axis]) - grow : double(box.hi[axis]) + grow;
      std::vector<glm::dvec3> out;
      for (size_t i = 0; i < poly.size(); ++i) {
        const glm::dvec3& cur = poly[i];
        const glm::dvec3& prev = poly[(i + poly.size() - 1) % poly.size()];
        const double dc = side * (cur[axis] - plane), dp = side * (prev[axis] - plane);  // <= 0: inside
        if ((dc <= 0) != (dp <= 0)) out.push_back(prev + (cur - prev) * (dp / (dp - dc)));
        if (dc <= 0) out.push_back(cur);
      }
      poly = std::move(out);
      if (poly.empty()) return poly;
    }
  return poly;
}

// The same closest hit, bit for bit (triangle, t, u, v), or the same miss.
inline void expect_same_closest(const Structure& reference, const Structure& s, const Ray& ray) {
  Hit expected, got;
  const bool a = reference.closest(ray, expected);
  const bool b = s.closest(ray, got);
  ASSERT_EQ(a, b) << "origin " << ray.origin.x << " " << ray.origin.y << " " << ray.origin.z;
  if (!a) return;
  EXPECT_EQ(expected.triangle, got.triangle);
  EXPECT_EQ(expected.t, got.t);
  EXPECT_EQ(expected.u, got.u);
  EXPECT_EQ(expected.v, got.v);
}

}  // namespace raylab::test
