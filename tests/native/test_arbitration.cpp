// The benchmark's float64 referee (arbitration.h) and its hostile rays (hostile_rays.h): each verdict on a
// ray built to show it, and the exact contract judged right on every hostile ray of a shipped mesh, where
// the fast contract is caught.
#include "arbitration.h"
#include "hostile_rays.h"
#include "support.h"

#include <gtest/gtest.h>

using namespace raylab;
using namespace raylab::bench;

namespace {

// A square of two triangles sharing the edge (1,0,0)-(0,1,0) in z = 0, both facing +z; and a tent over
// the x axis whose two faces meet at a ridge along y = 0, z = 1.
TriangleMesh square_and_tent() {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0},  {1, 0, 0}, {0, 1, 0}, {1, 1, 0},  // the square
                   {5, -1, 0}, {5, 0, 1}, {5, 1, 0},             // the tent's near end
                   {8, -1, 0}, {8, 0, 1}, {8, 1, 0}};            // its far end
  mesh.triangles = {{0, 1, 2}, {1, 3, 2}, {4, 7, 8}, {4, 8, 5}, {5, 8, 9}, {5, 9, 6}};
  return mesh;
}

Hit hit(uint32_t triangle, float t) {
  Hit h;
  h.triangle = triangle;
  h.t = t;
  return h;
}

Ray down_at(float x, float y, float tmin = 0.0f, float tmax = kInfinity) {
  return test::ray_of({x, y, 1.0f}, {0, 0, -1}, tmin, tmax);
}

Verdict verdict(const Referee& referee, const Ray& ray, const Hit& answer, std::vector<uint32_t> candidates) {
  return referee.judge(ray, answer, candidates).verdict;
}

}  // namespace

TEST(Referee, AHitInsideItsTriangleAndAMissOfNothingAreRight) {
  const TriangleMesh mesh = square_and_tent();
  const Referee referee(mesh);
  EXPECT_EQ(verdict(referee, down_at(0.2f, 0.2f), hit(0, 1.0f), {0}), Verdict::Right);
  EXPECT_EQ(verdict(referee, down_at(3, 3), Hit{}, {kInvalidIndex}), Verdict::Right);
  EXPECT_FALSE(referee.closed());
}

TEST(Referee, AHitOffItsTriangleOrOutsideTheIntervalIsWrong) {
  const TriangleMesh mesh = square_and_tent();
  const Referee referee(mesh);
  EXPECT_EQ(verdict(referee, down_at(0.9f, 0.9f), hit(0, 1.0f), {0, 1}), Verdict::OffTriangle);
  EXPECT_EQ(verdict(referee, down_at(0.2f, 0.2f, 0.0f, 0.999f), hit(0, 1.0f), {0}), Verdict::OutsideInterval);
  // From a hair above the square, going up: its own triangle lies behind (a self-hit).
  const Ray up = test::ray_of({0.2f, 0.2f, 1e-5f}, {0, 0, 1});
  EXPECT_EQ(verdict(referee, up, hit(0, 1e-5f), {0}), Verdict::OutsideInterval);
}

TEST(Referee, APassedHitInsideATriangleIsMissed) {
  const TriangleMesh mesh = square_and_tent();
  const Referee referee(mesh);
  const Referee::Judgement j = referee.judge(down_at(0.2f, 0.2f), Hit{}, std::vector<uint32_t>{0});
  EXPECT_EQ(j.verdict, Verdict::MissedInside);
  EXPECT_EQ(j.witness, 0u);
  // Beyond tmax it did not have to be found.
  EXPECT_EQ(verdict(referee, down_at(0.2f, 0.2f, 0.0f, 0.5f), Hit{}, {0}), Verdict::Right);
}

TEST(Referee, AMissThroughASharedEdgeLeaksAndAHitOnEitherSideIsRight) {
  const TriangleMesh mesh = square_and_tent();
  const Referee referee(mesh);
  const Ray edge = down_at(0.5f, 0.5f);  // on the square's diagonal, both triangles' edge
  EXPECT_EQ(verdict(referee, edge, Hit{}, {0, 1}), Verdict::Leaked);
  EXPECT_EQ(verdict(referee, edge, hit(0, 1.0f), {0, 1}), Verdict::Right);
  EXPECT_EQ(verdict(referee, edge, hit(1, 1.0f), {0, 1}), Verdict::Right);
  // The square's outer edge belongs to one triangle: passing it is no leak.
  EXPECT_EQ(verdict(referee, down_at(0.5f, 0.0f), Hit{}, {0}), Verdict::Right);
}

TEST(Referee, ARayTouchingASilhouetteRidgeMayPassIt) {
  const TriangleMesh mesh = square_and_tent();
  const Referee referee(mesh);
  // Level with the ridge, across it: the two faces meeting there face the ray oppositely, so it only
  // touches the tent's top.
  const Ray touching = test::ray_of({6.5f, -1.0f, 1.0f}, {0, 1, 0});
  EXPECT_EQ(verdict(referee, touching, Hit{}, {2, 3, 4, 5}), Verdict::Right);
  // Straight down onto the ridge it crosses the surface: passing it leaks.
  EXPECT_EQ(verdict(referee, test::ray_of({6.5f, 0.0f, 2.0f}, {0, 0, -1}), Hit{}, {2, 3, 4, 5}), Verdict::Leaked);
}

TEST(HostileRays, InterleaveTheirKindsAimAtUsableTrianglesAndRepeatForASeed) {
  const MeshPtr mesh = test::shipped("goathead.obj");
  const HostileRays a = hostile_rays(*mesh, 700, 3), b = hostile_rays(*mesh, 700, 3);
  ASSERT_EQ(a.rays.size(), 700u);
  for (size_t i = 0; i < a.rays.size(); ++i) {
    EXPECT_EQ(int(a.kind[i]), int(i % kHostileKinds));
    EXPECT_LT(a.target[i], mesh->triangle_count());
    EXPECT_EQ(a.rays[i].origin, b.rays[i].origin);
    EXPECT_EQ(a.rays[i].direction, b.rays[i].direction);
  }
  EXPECT_THROW(hostile_rays(*test::mesh_of({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}, {{0, 1, 2}}), 10, 1),
               std::invalid_argument);
}

TEST(HostileRays, TheExactContractIsRightOnEveryOneAndTheFastContractIsCaught) {
  const MeshPtr mesh = test::shipped("bunny.obj");
  const HostileRays hostile = hostile_rays(*mesh, 7000, 11);
  const Referee referee(*mesh);
  std::array<std::vector<Hit>, 2> hits;
  std::array<std::array<int, kVerdicts>, 2> counts{};
  for (int c = 0; c < 2; ++c) {
    BuildSettings s;
    s.kind = StructureKind::Bvh;
    s.contract = c == 0 ? Contract::Exact : Contract::Fast;
    hits[c].resize(hostile.rays.size());
    intersect_closest(*build_structure(mesh, s), hostile.rays, hits[c], nullptr);
  }
  for (size_t r = 0; r < hostile.rays.size(); ++r) {
    const std::vector<uint32_t> candidates{hits[0][r].triangle, hits[1][r].triangle, hostile.target[r]};
    for (int c = 0; c < 2; ++c) ++counts[c][int(referee.judge(hostile.rays[r], hits[c][r], candidates).verdict)];
  }
  EXPECT_EQ(counts[0][int(Verdict::Right)], int(hostile.rays.size()));
  // Möller–Trumbore in float lets rays through the edges it is aimed at, as Embree's test does.
  EXPECT_GT(counts[1][int(Verdict::Leaked)] + counts[1][int(Verdict::MissedInside)], 0);
}
