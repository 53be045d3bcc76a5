// Ray/triangle tests. The watertight test (Woop, Benthin, Wald, JCGT 2013) is the default: two
// triangles sharing an edge can never both miss a ray through that edge. Möller–Trumbore stays as a
// named option because showing where it leaks is part of the teaching.
#pragma once

#include "raylab/geometry.h"
#include "raylab/named_table.h"

#include "raylab/simd.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace raylab {

enum class TriangleTest { Watertight, MollerTrumbore };

// The names of the tests, once: the bindings parse and print them and export the table to Python
// (_raylab.TRIANGLE_TESTS), where the add-on's menus and the leak experiment read it.
struct TriangleTestInfo {
  TriangleTest test;
  const char* name;
  const char* label;
  const char* description;
};

inline constexpr TriangleTestInfo kTriangleTests[] = {
    {TriangleTest::Watertight, "watertight", "Watertight",
     "Woop, Benthin and Wald (2013), decided in double precision: a ray through a shared edge never slips "
     "between its two triangles"},
    {TriangleTest::MollerTrumbore, "moller_trumbore", "Möller–Trumbore",
     "The classic test, fast but leaky: rays through shared edges and vertices can miss both triangles"},
};

inline const char* triangle_test_name(TriangleTest test) {
  return name_in(kTriangleTests, &TriangleTestInfo::test, test);
}

// Throws std::invalid_argument listing the known names.
inline TriangleTest triangle_test_from_name(const std::string& name) {
  return value_in(kTriangleTests, &TriangleTestInfo::test, name, "triangle_test");
}

// The per-ray part of the watertight test: the shear that maps the ray onto the +z axis, in float
// for the filter and in double for the decision.
struct WatertightRay {
  glm::vec3 origin;
  int kx, ky, kz;
  float sx, sy, sz;
  double dsx, dsy, dsz;

  explicit WatertightRay(const Ray& ray) : WatertightRay(ray, effective_direction(ray.direction)) {}
  // `d`: the ray's effective_direction(), when the caller has it already.
  WatertightRay(const Ray& ray, const glm::vec3& d) : origin(ray.origin) {
    // Branch-free: on incoherent rays the axis choice and the swap are coin flips, and the quotients
    // run as three packed divisions instead of six scalar ones (each lane rounds as the scalar one).
    // GCC compiled glm's operator[] (a switch) and the axis choice's ternaries to branches, so the
    // components are read from an array and the choice is arithmetic. The divisions are off the
    // critical path, so they stay as they are, and not lazy (docs/bench/history.md).
    const float dd[3] = {d.x, d.y, d.z};
    const float ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z);
    const int x_over_y = ax > ay, x_over_z = ax > az, y_over_z = ay > az;
    kz = 2 - 2 * (x_over_y & x_over_z) - (y_over_z & (x_over_y ^ 1));  // the largest, the first of equals
    kx = (kz + 1) & -int(kz != 2);
    ky = (kx + 1) & -int(kx != 2);
    // Swap to keep the winding, so that the sign of the determinant stays meaningful.
    const int swap = (kx ^ ky) & -int(dd[kz] < 0.0f);
    kx ^= swap;
    ky ^= swap;
    const float fx = dd[kx], fy = dd[ky], fz = dd[kz];
    alignas(16) float q[4];
    _mm_store_ps(q, _mm_div_ps(_mm_setr_ps(fx, fy, 1.0f, 1.0f), _mm_set1_ps(fz)));
    sx = q[0];
    sy = q[1];
    sz = q[2];
    alignas(16) double dq[2];
    _mm_store_pd(dq, _mm_div_pd(_mm_setr_pd(fx, fy), _mm_set1_pd(fz)));
    dsx = dq[0];
    dsy = dq[1];
    dsz = 1.0 / double(fz);
  }
};

// A candidate hit on one triangle: t and the barycentric weights of vertices 1 and 2.
struct TriangleHit {
  float t, u, v;
};

// The float filter's error bound on an edge function, from the sheared coordinates' magnitudes:
// s = max|x| + max|y| over the corners and z = max|p - o| along the ray's main axis. Each sheared
// coordinate is off by at most 2u(s + 2z) (u = 2^-24: the subtraction from the origin, the shear's
// quotient, product and difference), and an edge function cx*by - cy*bx by at most about
// 24u(s + 2z)s (pbrt-v4's gamma(n) accounting); 32u leaves room for the bound's own rounding, and the
// FLT_MIN term for products that underflow.
inline float watertight_filter_bound(float s, float z) { return (32.0f * 0x1p-24f * (s + 2.0f * z)) * s + 0x1p-126f; }

// The decision, in double precision: sheared coordinates from the float vertices and origin (their
// differences are exact in double unless their magnitudes differ by more than 2^29), edge functions
// and t. An edge function of exactly zero is a hit on the edge, for both triangles sharing it.
// Refused as "lying in the triangle's plane": a hit whose determinant is below 2^-24 s^2 (the ray
// within about 2^-24 of the plane, or a needle triangle). Its barycentrics would carry no digits, and
// the point they name could lie anywhere on the triangle, far from the ray; above the threshold the
// reported point lies within 2^-18 (relative to the origin's distance to the mesh) of the ray, which
// the box pad covers. No hit is ever reported at an infinite or NaN t.
inline bool intersect_watertight_exact(const WatertightRay& r, const glm::vec3& p0, const glm::vec3& p1,
                                       const glm::vec3& p2, float tmin, float tmax, TriangleHit& out) {
  double x[3], y[3], z[3];
  // Arrays indexed by the ray's axes: glm's operator[] is a switch, which GCC compiles to branches
  // that mispredict on the first triangle of each incoherent ray.
  const float p[3][3] = {{p0.x, p0.y, p0.z}, {p1.x, p1.y, p1.z}, {p2.x, p2.y, p2.z}};
  const float o[3] = {r.origin.x, r.origin.y, r.origin.z};
  double sx = 0.0, sy = 0.0;
  for (int c = 0; c < 3; ++c) {
    const double ax = double(p[c][r.kx]) - double(o[r.kx]);
    const double ay = double(p[c][r.ky]) - double(o[r.ky]);
    const double az = double(p[c][r.kz]) - double(o[r.kz]);
    x[c] = ax - r.dsx * az;
    y[c] = ay - r.dsy * az;
    z[c] = az;
    sx = std::max(sx, std::abs(x[c]));
    sy = std::max(sy, std::abs(y[c]));
  }
  const double u = x[2] * y[1] - y[2] * x[1];
  const double v = x[0] * y[2] - y[0] * x[2];
  const double w = x[1] * y[0] - y[1] * x[0];
  if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) return false;
  const double det = u + v + w;
  const double s = sx + sy;
  if (!(std::abs(det) >= 0x1p-24 * s * s) || det == 0.0) return false;
  const double inv_det = 1.0 / det;
  const float t = float((u * z[0] + v * z[1] + w * z[2]) * r.dsz * inv_det);
  if (!(t > tmin && t <= tmax) || std::isinf(t)) return false;
  out = {t, float(v * inv_det), float(w * inv_det)};
  return true;
}

// Returns true and fills `out` when the ray hits the triangle with tmin < t <= tmax (inclusive, so
// that a closest-hit search can see a tie at the current best t and break it by index). A float
// filter rejects the triangles that certainly miss (two edge functions of opposite sign, each beyond
// its error bound: Shewchuk's filtered predicates); the rest are decided in double precision by
// intersect_watertight_exact, so the answer does not depend on which path, or which SIMD lane, ran.
inline bool intersect_watertight(const WatertightRay& r, const glm::vec3& p0, const glm::vec3& p1, const glm::vec3& p2,
                                 float tmin, float tmax, TriangleHit& out) {
  const glm::vec3 a = p0 - r.origin;
  const glm::vec3 b = p1 - r.origin;
  const glm::vec3 c = p2 - r.origin;
  const float ax = a[r.kx] - r.sx * a[r.kz], ay = a[r.ky] - r.sy * a[r.kz];
  const float bx = b[r.kx] - r.sx * b[r.kz], by = b[r.ky] - r.sy * b[r.kz];
  const float cx = c[r.kx] - r.sx * c[r.kz], cy = c[r.ky] - r.sy * c[r.kz];
  const float u = cx * by - cy * bx;
  const float v = ax * cy - ay * cx;
  const float w = bx * ay - by * ax;
  const float s = std::max(std::abs(ax), std::max(std::abs(bx), std::abs(cx))) +
                  std::max(std::abs(ay), std::max(std::abs(by), std::abs(cy)));
  const float z = std::max(std::abs(a[r.kz]), std::max(std::abs(b[r.kz]), std::abs(c[r.kz])));
  const float bound = watertight_filter_bound(s, z);
  // Written so that an overflowed (inf or NaN) filter never rejects: such a triangle goes to double.
  const bool negative = u < -bound || v < -bound || w < -bound;
  const bool positive = u > bound || v > bound || w > bound;
  if (negative && positive) return false;
  return intersect_watertight_exact(r, p0, p1, p2, tmin, tmax, out);
}

inline bool intersect_moller_trumbore(const Ray& ray, const glm::vec3& p0, const glm::vec3& p1, const glm::vec3& p2,
                                      float tmin, float tmax, TriangleHit& out) {
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
  // The teaching option keeps its leaks, but never a hit at t <= tmin or at an infinite or NaN t.
  if (!(t > tmin && t <= tmax) || std::isinf(t)) return false;
  out = {t, u, v};
  return true;
}

// Everything a traversal needs to test triangles of one mesh against one ray.
struct TriangleTester {
  Ray ray;  // with effective_direction(): tiny components are zero for Möller–Trumbore too
  WatertightRay watertight;
  TriangleTest test;

  TriangleTester(const Ray& r, TriangleTest kind) : TriangleTester(r, kind, effective_direction(r.direction)) {}
  // `effective_dir`: the ray's effective_direction(), when the caller has it already.
  TriangleTester(const Ray& r, TriangleTest kind, const glm::vec3& effective_dir)
      : ray(r), watertight(r, effective_dir), test(kind) {
    ray.direction = effective_dir;
  }

  bool operator()(const TriangleMesh& mesh, uint32_t triangle, float tmax, TriangleHit& out) const {
    const glm::uvec3 idx = mesh.triangles[triangle];
    const glm::vec3& p0 = mesh.vertices[idx.x];
    const glm::vec3& p1 = mesh.vertices[idx.y];
    const glm::vec3& p2 = mesh.vertices[idx.z];
    return test == TriangleTest::Watertight ? intersect_watertight(watertight, p0, p1, p2, ray.tmin, tmax, out)
                                            : intersect_moller_trumbore(ray, p0, p1, p2, ray.tmin, tmax, out);
  }
};

// Closest-hit update with a deterministic tie-break: at equal t the lower triangle index wins, so
// every structure returns exactly the hit of the brute-force loop whatever order it tests in.
inline bool closer(const TriangleHit& candidate, uint32_t triangle, const Hit& best) {
  return candidate.t < best.t || (candidate.t == best.t && triangle < best.triangle);
}

}  // namespace raylab
