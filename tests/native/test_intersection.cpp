#include "box_intersection.h"
#include "raylab/triangle_intersection.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

using namespace raylab;

TEST(BoxIntersection, AxisParallelRayWithOriginOnSlabPlaneHitsFace) {
  const Bounds box({0, 0, 0}, {1, 1, 1});
  Ray ray;
  ray.origin = {0.0f, 0.5f, -1.0f};  // lies exactly on the x = 0 plane
  ray.direction = {0, 0, 1};
  float t = -1;
  EXPECT_TRUE(intersect_box(box, BoxRay(ray, Bounds{}), ray.tmax, t));
  EXPECT_FLOAT_EQ(t, 1.0f);
}

TEST(BoxIntersection, AxisParallelRayBesideBoxMisses) {
  const Bounds box({0, 0, 0}, {1, 1, 1});
  Ray ray;
  ray.origin = {1.5f, 0.5f, -1.0f};
  ray.direction = {0, 0, 1};
  float t;
  EXPECT_FALSE(intersect_box(box, BoxRay(ray, Bounds{}), ray.tmax, t));
}

TEST(TriangleIntersection, WatertightAndMollerTrumboreAgreeInTheInterior) {
  const glm::vec3 p0(0, 0, 0), p1(1, 0, 0), p2(0, 1, 0);
  Ray ray;
  ray.origin = {0.25f, 0.25f, 1.0f};
  ray.direction = {0, 0, -1};
  TriangleHit a, b;
  ASSERT_TRUE(intersect_watertight(WatertightRay(ray), p0, p1, p2, 0, kInfinity, a));
  ASSERT_TRUE(intersect_moller_trumbore(ray, p0, p1, p2, 0, kInfinity, b));
  EXPECT_FLOAT_EQ(a.t, 1.0f);
  EXPECT_FLOAT_EQ(a.u, 0.25f);
  EXPECT_FLOAT_EQ(a.v, 0.25f);
  EXPECT_FLOAT_EQ(b.t, a.t);
  EXPECT_FLOAT_EQ(b.u, a.u);
  EXPECT_FLOAT_EQ(b.v, a.v);
}

namespace {

// A height field z = f(x, y) of triangles all wound counter-clockwise seen from +z (facing the same
// way), with the triangles on either side of each edge and around each vertex.
struct Surface {
  std::vector<glm::vec3> vertices;
  std::vector<glm::uvec3> triangles;
  std::map<std::pair<uint32_t, uint32_t>, std::vector<uint32_t>> edges;  // (lower, higher index)
  std::vector<std::vector<uint32_t>> rings;

  // Adds a triangle with its corners rotated by `rotation` (the winding stays): shared edges then
  // take every corner position, and Möller–Trumbore's three edge tests (u < 0, v < 0, u + v > 1) all
  // meet the shared edges.
  void add(uint32_t a, uint32_t b, uint32_t c, int rotation) {
    const uint32_t k[3] = {a, b, c};
    triangles.push_back({k[rotation % 3], k[(rotation + 1) % 3], k[(rotation + 2) % 3]});
  }
  void finish() {
    rings.assign(vertices.size(), {});
    for (uint32_t t = 0; t < triangles.size(); ++t)
      for (int c = 0; c < 3; ++c) {
        const uint32_t a = triangles[t][c], b = triangles[t][(c + 1) % 3];
        edges[{std::min(a, b), std::max(a, b)}].push_back(t);
        rings[a].push_back(t);
      }
  }
  const glm::vec3& corner(uint32_t t, int c) const { return vertices[triangles[t][c]]; }
  bool interior(uint32_t vertex) const {
    for (uint32_t t : rings[vertex])
      for (int c = 0; c < 3; ++c) {
        const uint32_t a = triangles[t][c], b = triangles[t][(c + 1) % 3];
        if ((a == vertex || b == vertex) && edges.at({std::min(a, b), std::max(a, b)}).size() != 2) return false;
      }
    return true;
  }
};

// A jittered n x n grid over [-1, 1]^2, heights within +-0.05, cells split along alternating
// diagonals: vertices of valence 4 to 8, slopes below 1.
Surface jittered_grid(std::mt19937& rng, int n) {
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  Surface s;
  const float cell = 2.0f / float(n);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const bool inner = i > 0 && j > 0 && i < n && j < n;
      const float jx = inner ? 0.3f * cell * unit(rng) : 0.0f, jy = inner ? 0.3f * cell * unit(rng) : 0.0f;
      s.vertices.push_back({-1.0f + float(i) * cell + jx, -1.0f + float(j) * cell + jy, 0.05f * unit(rng)});
    }
  std::uniform_int_distribution<int> rotation(0, 2);
  auto at = [&](int i, int j) { return uint32_t(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const uint32_t a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
      if ((i + j) % 2 == 0) {
        s.add(a, b, c, rotation(rng));
        s.add(a, c, d, rotation(rng));
      } else {
        s.add(a, b, d, rotation(rng));
        s.add(b, c, d, rotation(rng));
      }
    }
  s.finish();
  return s;
}

// A fan of k thin triangles around a raised centre: one vertex of valence k.
Surface fan(std::mt19937& rng, int k) {
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  Surface s;
  s.vertices.push_back({0.01f * unit(rng), 0.01f * unit(rng), 0.1f + 0.05f * unit(rng)});
  for (int i = 0; i < k; ++i) {
    const float angle = 6.2831853f * (float(i) + 0.2f * unit(rng)) / float(k), r = 1.0f + 0.3f * unit(rng);
    s.vertices.push_back({r * std::cos(angle), r * std::sin(angle), 0.05f * unit(rng)});
  }
  std::uniform_int_distribution<int> rotation(0, 2);
  for (int i = 0; i < k; ++i) s.add(0, uint32_t(1 + i), uint32_t(1 + (i + 1) % k), rotation(rng));
  s.finish();
  return s;
}

// The hit's barycentric weight of corner c of triangle t, read exactly: the corners are rotated so
// that c comes second, whose weight the test returns as u (the edge function of the opposite edge,
// the same double as in the unrotated order, times 1/det). NaN if the rotated test misses.
float corner_weight(const Surface& s, uint32_t t, int c, const WatertightRay& w) {
  TriangleHit h;
  if (!intersect_watertight(w, s.corner(t, (c + 2) % 3), s.corner(t, c), s.corner(t, (c + 1) % 3), 0.0f, kInfinity, h))
    return std::numeric_limits<float>::quiet_NaN();
  return h.u;
}

// The corner of triangle t that is not on edge (a, b).
int opposite_corner(const Surface& s, uint32_t t, uint32_t a, uint32_t b) {
  for (int c = 0; c < 3; ++c)
    if (s.triangles[t][c] != a && s.triangles[t][c] != b) return c;
  return -1;
}

}  // namespace

// Rays through the shared edges and vertices of two closed surfaces (a jittered grid of 128
// triangles, a fan of 24 around one vertex), all triangles facing +z. Each ray comes down from above,
// steeper than any slope, aimed at a float point of a shared edge or at a shared vertex, so it crosses
// the surface exactly once, within rounding of its target, and must hit one of the triangles there.
// Möller–Trumbore computes each triangle's edges on its own and misses every triangle on some rays (the
// test asserts that it does, so it cannot pass for a leaky test); the watertight test hits on every
// ray, only the triangles at the target, and follows its documented tie rule: it reports both
// triangles of an edge only when the ray passes exactly through the edge (the vertex opposite the
// edge has barycentric weight exactly 0 in both), and on rays built to pass exactly through an edge
// or a vertex it reports every triangle there.
TEST(TriangleIntersection, RaysThroughSharedEdgesAndVerticesLeakWithMollerTrumboreButNeverWatertight) {
  std::mt19937 rng(20131);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f), fraction(0.05f, 0.95f), distance(1.0f, 4.0f);
  const Surface surfaces[2] = {jittered_grid(rng, 8), fan(rng, 24)};
  int rays = 0, mt_leaks = 0, mt_edge_leaks = 0, mt_vertex_leaks = 0, double_hits = 0, exact_edges = 0;
  for (const Surface& s : surfaces) {
    std::vector<std::pair<uint32_t, uint32_t>> shared;
    for (const auto& [edge, tris] : s.edges)
      if (tris.size() == 2) shared.push_back(edge);
    std::vector<uint32_t> inner;
    for (uint32_t v = 0; v < s.vertices.size(); ++v)
      if (s.interior(v)) inner.push_back(v);
    ASSERT_FALSE(shared.empty());
    ASSERT_FALSE(inner.empty());

    // Random rays: three in four through an edge, one in four through a vertex.
    for (int i = 0; i < 6000; ++i, ++rays) {
      const bool through_vertex = i % 4 == 3;
      glm::vec3 target;
      std::vector<uint32_t> expected;
      std::pair<uint32_t, uint32_t> edge{};
      if (through_vertex) {
        const uint32_t v = inner[rng() % inner.size()];
        target = s.vertices[v];
        expected = s.rings[v];
      } else {
        edge = shared[rng() % shared.size()];
        const glm::vec3 a = s.vertices[edge.first], b = s.vertices[edge.second];
        target = a + fraction(rng) * (b - a);
        expected = s.edges.at(edge);
      }
      Ray ray;
      ray.direction = {0.5f * unit(rng), 0.5f * unit(rng), -1.0f};
      const float far = distance(rng);
      ray.origin = target - far * ray.direction;
      const WatertightRay w(ray);
      std::vector<uint32_t> wt_hits;
      bool mt_hit = false;
      for (uint32_t t = 0; t < s.triangles.size(); ++t) {
        const glm::vec3 &p0 = s.corner(t, 0), &p1 = s.corner(t, 1), &p2 = s.corner(t, 2);
        TriangleHit h;
        if (intersect_watertight(w, p0, p1, p2, 0.0f, kInfinity, h)) {
          wt_hits.push_back(t);
          EXPECT_NEAR(h.t, far, 1e-4f * far) << "ray " << rays << " triangle " << t;
        }
        mt_hit |= intersect_moller_trumbore(ray, p0, p1, p2, 0.0f, kInfinity, h);
      }
      if (!mt_hit) {
        ++mt_leaks;
        ++(through_vertex ? mt_vertex_leaks : mt_edge_leaks);
      }
      ASSERT_FALSE(wt_hits.empty()) << "the watertight test leaks: ray " << rays
                                    << (through_vertex ? " (vertex)" : " (edge)");
      for (uint32_t t : wt_hits)
        ASSERT_NE(std::find(expected.begin(), expected.end(), t), expected.end())
            << "ray " << rays << " hits triangle " << t << ", away from its target";
      if (!through_vertex && wt_hits.size() == 2) {
        ++double_hits;
        for (uint32_t t : wt_hits)
          EXPECT_EQ(corner_weight(s, t, opposite_corner(s, t, edge.first, edge.second), w), 0.0f)
              << "ray " << rays << ": both triangles hit, but not on their shared edge";
      }
    }

    // Rays along -z exactly through a shared edge (its midpoint, where that is a float) and exactly
    // through each inner vertex: the shear is the identity, the edge functions are exact, and the
    // tie rule gives every triangle there, with weight exactly 0 for the corners off the ray's edge.
    for (const auto& edge : shared) {
      const glm::vec3 a = s.vertices[edge.first], b = s.vertices[edge.second];
      const glm::vec3 m = 0.5f * (a + b);
      if (2.0 * double(m.x) != double(a.x) + double(b.x) || 2.0 * double(m.y) != double(a.y) + double(b.y)) continue;
      ++exact_edges;
      Ray ray;
      ray.origin = {m.x, m.y, 2.0f};
      ray.direction = {0.0f, 0.0f, -1.0f};
      const WatertightRay w(ray);
      for (uint32_t t = 0; t < s.triangles.size(); ++t) {
        TriangleHit h;
        const bool on_edge = std::find(s.edges.at(edge).begin(), s.edges.at(edge).end(), t) != s.edges.at(edge).end();
        EXPECT_EQ(intersect_watertight(w, s.corner(t, 0), s.corner(t, 1), s.corner(t, 2), 0.0f, kInfinity, h), on_edge)
            << "edge " << edge.first << "-" << edge.second << ", triangle " << t;
        if (on_edge) {
          EXPECT_EQ(corner_weight(s, t, opposite_corner(s, t, edge.first, edge.second), w), 0.0f);
        }
      }
    }
    for (uint32_t v : inner) {
      Ray ray;
      ray.origin = {s.vertices[v].x, s.vertices[v].y, 2.0f};
      ray.direction = {0.0f, 0.0f, -1.0f};
      const WatertightRay w(ray);
      for (uint32_t t = 0; t < s.triangles.size(); ++t) {
        TriangleHit h;
        const bool around = std::find(s.rings[v].begin(), s.rings[v].end(), t) != s.rings[v].end();
        EXPECT_EQ(intersect_watertight(w, s.corner(t, 0), s.corner(t, 1), s.corner(t, 2), 0.0f, kInfinity, h), around)
            << "vertex " << v << ", triangle " << t;
        if (around) {
          for (int c = 0; c < 3; ++c)
            if (s.triangles[t][c] != v) {
              EXPECT_EQ(corner_weight(s, t, c, w), 0.0f) << "vertex " << v << ", triangle " << t;
            }
          EXPECT_NEAR(h.t, 2.0f - s.vertices[v].z, 1e-6f);
        }
      }
    }
  }
  std::printf(
      "[ counts   ] %d rays; Möller–Trumbore misses every triangle on %d (%d through an edge, %d through a "
      "vertex); watertight on none, both triangles of the edge on %d; %d exact edge midpoints\n",
      rays, mt_leaks, mt_edge_leaks, mt_vertex_leaks, double_hits, exact_edges);
  EXPECT_GT(mt_leaks, 0) << "Möller–Trumbore no longer leaks here: the test would pass for a leaky test";
  EXPECT_GT(exact_edges, 10);
}

// A direction component of -0 must behave as +0: the ray lies in the box's face plane either way.
TEST(BoxIntersection, NegativeZeroDirectionWithOriginOnFacePlaneHitsBothBoxesSharingThePlane) {
  const Bounds below({-1, -1, -1}, {0, 1, 1});  // x <= 0
  const Bounds above({0, -1, -1}, {1, 1, 1});   // x >= 0
  for (float zero : {0.0f, -0.0f}) {
    Ray ray;
    ray.origin = {0.0f, 0.0f, -5.0f};
    ray.direction = {zero, 0.1f, 1.0f};
    float t = -1;
    EXPECT_TRUE(intersect_box(below, BoxRay(ray, Bounds{}), ray.tmax, t)) << "direction x = " << zero;
    EXPECT_TRUE(intersect_box(above, BoxRay(ray, Bounds{}), ray.tmax, t)) << "direction x = " << zero;
  }
}

// Issue 10, finding 4: the old far-distance scaling (far *= 1 + 2 gamma(3)) moved a negative far
// distance towards -inf and lost a flat box behind the origin.
TEST(BoxIntersection, FlatBoxBehindTheOriginIsFoundWithANegativeTmin) {
  const Bounds box({0, 0, 0}, {1, 1, 0});
  Ray ray;
  ray.origin = {0.2f, 0.3f, 0.5f};
  ray.direction = {0, 0, 1};
  ray.tmin = -1.0f;
  float t;
  EXPECT_TRUE(intersect_box(box, BoxRay(ray, box), ray.tmax, t));
  EXPECT_LE(t, -0.5f);
}

// The pad grows with the origin's distance from the root box and covers the triangle test's error.
TEST(BoxIntersection, PadIsRelativeToTheOriginsDistanceFromTheRoot) {
  const Bounds root({0, 0, 0}, {1, 1, 1});
  EXPECT_EQ(BoxRay::box_pad({0.5f, 0.5f, -3.0f}, root), kBoxPadScale * 4.0f);
  Ray ray;
  ray.origin = {1.0f + 0.5f * kBoxPadScale, 0.5f, -1.0f};  // beside the box by less than the pad
  ray.direction = {0, 0, 1};
  float t;
  EXPECT_TRUE(intersect_box(root, BoxRay(ray, root), ray.tmax, t));
  ray.origin.x = 1.0f + 4.0f * kBoxPadScale;
  EXPECT_FALSE(intersect_box(root, BoxRay(ray, root), ray.tmax, t));
}

TEST(Direction, TinyAndNegativeZeroComponentsBecomePositiveZero) {
  const glm::vec3 d = effective_direction({1.0f, -1e-39f, -0.0f});
  EXPECT_EQ(d, glm::vec3(1, 0, 0));
  EXPECT_FALSE(std::signbit(d.y));
  EXPECT_FALSE(std::signbit(d.z));
  EXPECT_EQ(effective_direction({1e-37f, 1e-45f, 0.0f}), glm::vec3(1e-37f, 0, 0));
  EXPECT_EQ(effective_direction({1e-38f, 1e-45f, 0.0f}), glm::vec3(0.0f));  // all denormal: a zero direction
  EXPECT_EQ(effective_direction({1.0f, -1e-10f, 0.5f}), glm::vec3(1.0f, -1e-10f, 0.5f));  // kept: above 2^-40
}

// Finding 6: no hit is ever reported at an infinite t, with either test.
TEST(TriangleIntersection, NoHitAtAnInfiniteT) {
  const glm::vec3 p0(5, -1, -1), p1(5, 1, -1), p2(5, 0, 1);
  Ray ray;
  ray.origin = {0, 0, 0};
  ray.direction = {1e-38f, 1e-45f, 0.0f};  // t = 5e38 overflows float
  TriangleHit h;
  const TriangleTester wt(ray, TriangleTest::Watertight), mt(ray, TriangleTest::MollerTrumbore);
  TriangleMesh mesh;
  mesh.vertices = {p0, p1, p2};
  mesh.triangles = {{0, 1, 2}};
  EXPECT_FALSE(wt(mesh, 0, kInfinity, h));
  EXPECT_FALSE(mt(mesh, 0, kInfinity, h));
  // A ray lying in the triangle's plane does not hit it (and never at t = inf).
  ray.origin = {-1, 0.1f, 0};
  ray.direction = {1, 0.3f, 0};
  const TriangleTester in_plane(ray, TriangleTest::Watertight);
  TriangleMesh flat;
  flat.vertices = {{0, 0, 0}, {4, 0, 0}, {0, 4, 0}};
  flat.triangles = {{0, 1, 2}};
  EXPECT_FALSE(in_plane(flat, 0, kInfinity, h));
}

// The float filter only rejects what double precision also rejects: the scalar and SIMD tests give
// the double-precision answer, bit for bit, on rays through the vertices and edges of a fan.
TEST(TriangleIntersection, FilterNeverRejectsADoublePrecisionHit) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  int hits = 0;
  for (int i = 0; i < 20000; ++i) {
    const glm::vec3 p0(unit(rng), unit(rng), unit(rng)), p1(unit(rng), unit(rng), unit(rng)),
        p2(unit(rng), unit(rng), unit(rng));
    Ray ray;
    ray.origin = {3 * unit(rng), 3 * unit(rng), 3 * unit(rng)};
    // Aim at a vertex, an edge point or the interior.
    const float a = std::abs(unit(rng)), b = i % 3 == 0 ? 0.0f : (1 - a) * std::abs(unit(rng));
    ray.direction = p0 + a * (p1 - p0) + b * (p2 - p0) - ray.origin;
    const WatertightRay wr(ray);
    TriangleHit filtered{}, exact{};
    const bool f = intersect_watertight(wr, p0, p1, p2, 0.0f, kInfinity, filtered);
    const bool e = intersect_watertight_exact(wr, p0, p1, p2, 0.0f, kInfinity, exact);
    ASSERT_EQ(f, e) << "ray " << i;
    if (!f) continue;
    ++hits;
    ASSERT_EQ(filtered.t, exact.t);
  }
  EXPECT_GT(hits, 15000);
}

TEST(MeshValidation, CoordinatesBeyondTheLimitAreRefusedNamingTheVertex) {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1e19f, 0, 0}, {0, 1, 0}};
  mesh.triangles = {{0, 1, 2}};
  try {
    mesh.validate();
    FAIL() << "accepted a coordinate of 1e19";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("vertex 1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("2^61"), std::string::npos) << e.what();
  }
  mesh.vertices[1].x = kMaxCoordinate;
  EXPECT_NO_THROW(mesh.validate());
}
