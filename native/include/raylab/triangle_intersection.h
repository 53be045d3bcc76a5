// Ray/triangle tests. The watertight test (Woop, Benthin, Wald, JCGT 2013) is the default: two
// triangles sharing an edge can never both miss a ray through that edge. Möller–Trumbore stays as a
// named option because showing where it leaks is part of the teaching.
#pragma once

#include "raylab/geometry.h"

#include <cmath>
#include <utility>

namespace raylab {

enum class TriangleTest { Watertight, MollerTrumbore };

// The per-ray part of the watertight test: the shear that maps the ray onto the +z axis.
struct WatertightRay {
  glm::vec3 origin;
  int kx, ky, kz;
  float sx, sy, sz;

  explicit WatertightRay(const Ray& ray) : origin(ray.origin) {
    const glm::vec3 a = glm::abs(ray.direction);
    kz = (a.x > a.y) ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
    kx = (kz + 1) % 3;
    ky = (kx + 1) % 3;
    // Swap to keep the winding, so that the sign of the determinant stays meaningful.
    if (ray.direction[kz] < 0.0f) std::swap(kx, ky);
    sx = ray.direction[kx] / ray.direction[kz];
    sy = ray.direction[ky] / ray.direction[kz];
    sz = 1.0f / ray.direction[kz];
  }
};

// A candidate hit on one triangle: t and the barycentric weights of vertices 1 and 2.
struct TriangleHit {
  float t, u, v;
};

// Returns true and fills `out` when the ray hits the triangle with tmin < t <= tmax (inclusive, so
// that a closest-hit search can see a tie at the current best t and break it by index).
inline bool intersect_watertight(const WatertightRay& r, const glm::vec3& p0, const glm::vec3& p1,
                                 const glm::vec3& p2, float tmin, float tmax, TriangleHit& out) {
  const glm::vec3 a = p0 - r.origin;
  const glm::vec3 b = p1 - r.origin;
  const glm::vec3 c = p2 - r.origin;
  const float ax = a[r.kx] - r.sx * a[r.kz], ay = a[r.ky] - r.sy * a[r.kz];
  const float bx = b[r.kx] - r.sx * b[r.kz], by = b[r.ky] - r.sy * b[r.kz];
  const float cx = c[r.kx] - r.sx * c[r.kz], cy = c[r.ky] - r.sy * c[r.kz];
  float u = cx * by - cy * bx;
  float v = ax * cy - ay * cx;
  float w = bx * ay - by * ax;
  // An edge function of exactly zero may be a rounding artefact: decide it in double precision.
  if (u == 0.0f || v == 0.0f || w == 0.0f) {
    u = float(double(cx) * double(by) - double(cy) * double(bx));
    v = float(double(ax) * double(cy) - double(ay) * double(cx));
    w = float(double(bx) * double(ay) - double(by) * double(ax));
  }
  if ((u < 0.0f || v < 0.0f || w < 0.0f) && (u > 0.0f || v > 0.0f || w > 0.0f)) return false;
  const float det = u + v + w;
  if (det == 0.0f) return false;
  const float az = r.sz * a[r.kz], bz = r.sz * b[r.kz], cz = r.sz * c[r.kz];
  const float scaled_t = u * az + v * bz + w * cz;
  const float inv_det = 1.0f / det;
  const float t = scaled_t * inv_det;
  if (!(t > tmin && t <= tmax)) return false;
  out = {t, v * inv_det, w * inv_det};
  return true;
}

inline bool intersect_moller_trumbore(const Ray& ray, const glm::vec3& p0, const glm::vec3& p1,
                                      const glm::vec3& p2, float tmin, float tmax, TriangleHit& out) {
  const glm::vec3 e1 = p1 - p0;
  const glm::vec3 e2 = p2 - p0;
  const glm::vec3 p = glm::cross(ray.direction, e2);
  const float det = glm::dot(e1, p);
  if (det == 0.0f) return false;
  const float inv_det = 1.0f / det;
  const glm::vec3 s = ray.origin - p0;
  const float u = glm::dot(s, p) * inv_det;
  if (u < 0.0f || u > 1.0f) return false;
  const glm::vec3 q = glm::cross(s, e1);
  const float v = glm::dot(ray.direction, q) * inv_det;
  if (v < 0.0f || u + v > 1.0f) return false;
  const float t = glm::dot(e2, q) * inv_det;
  if (!(t > tmin && t <= tmax)) return false;
  out = {t, u, v};
  return true;
}

// Everything a traversal needs to test triangles of one mesh against one ray.
struct TriangleTester {
  const Ray& ray;
  WatertightRay watertight;
  TriangleTest test;

  TriangleTester(const Ray& r, TriangleTest kind) : ray(r), watertight(r), test(kind) {}

  bool operator()(const TriangleMesh& mesh, uint32_t triangle, float tmax, TriangleHit& out) const {
    const glm::uvec3 idx = mesh.triangles[triangle];
    const glm::vec3& p0 = mesh.vertices[idx.x];
    const glm::vec3& p1 = mesh.vertices[idx.y];
    const glm::vec3& p2 = mesh.vertices[idx.z];
    return test == TriangleTest::Watertight
               ? intersect_watertight(watertight, p0, p1, p2, ray.tmin, tmax, out)
               : intersect_moller_trumbore(ray, p0, p1, p2, ray.tmin, tmax, out);
  }
};

// Closest-hit update with a deterministic tie-break: at equal t the lower triangle index wins, so
// every structure returns exactly the hit of the brute-force loop whatever order it tests in.
inline bool closer(const TriangleHit& candidate, uint32_t triangle, const Hit& best) {
  return candidate.t < best.t || (candidate.t == best.t && triangle < best.triangle);
}

}  // namespace raylab
