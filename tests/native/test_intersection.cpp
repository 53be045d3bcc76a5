#include "raylab/box_intersection.h"
#include "raylab/triangle_intersection.h"

#include <gtest/gtest.h>

using namespace raylab;

TEST(BoxIntersection, AxisParallelRayWithOriginOnSlabPlaneHitsFace) {
  const Bounds box({0, 0, 0}, {1, 1, 1});
  Ray ray;
  ray.origin = {0.0f, 0.5f, -1.0f};  // lies exactly on the x = 0 plane
  ray.direction = {0, 0, 1};
  float t = -1;
  EXPECT_TRUE(intersect_box(box, BoxRay(ray), ray.tmax, t));
  EXPECT_FLOAT_EQ(t, 1.0f);
}

TEST(BoxIntersection, AxisParallelRayBesideBoxMisses) {
  const Bounds box({0, 0, 0}, {1, 1, 1});
  Ray ray;
  ray.origin = {1.5f, 0.5f, -1.0f};
  ray.direction = {0, 0, 1};
  float t;
  EXPECT_FALSE(intersect_box(box, BoxRay(ray), ray.tmax, t));
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
    EXPECT_TRUE(intersect_box(below, BoxRay(ray), ray.tmax, t)) << "direction x = " << zero;
    EXPECT_TRUE(intersect_box(above, BoxRay(ray), ray.tmax, t)) << "direction x = " << zero;
  }
}
