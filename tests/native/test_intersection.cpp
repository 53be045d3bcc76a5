#include "raylab/box_intersection.h"
#include "raylab/triangle_intersection.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

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

TEST(TriangleIntersection, RayThroughSharedEdgeHitsAtLeastOneTriangle) {
  // Two triangles sharing the diagonal edge (0,0)-(1,1) of a unit square; the ray goes through it.
  const glm::vec3 a(0, 0, 0), b(1, 0, 0), c(1, 1, 0), d(0, 1, 0);
  Ray ray;
  ray.origin = {0.3f, 0.3f, 1.0f};
  ray.direction = {0.0f, 0.0f, -1.0f};
  TriangleHit h;
  const WatertightRay w(ray);
  const bool first = intersect_watertight(w, a, b, c, 0, kInfinity, h);
  const bool second = intersect_watertight(w, a, c, d, 0, kInfinity, h);
  EXPECT_TRUE(first || second);
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
