// The benchmark's explanation of a disagreement with Embree: each kind on a ray built to show it.
#include "hit_comparison.h"
#include "support.h"

#include <gtest/gtest.h>

using namespace raylab;
using namespace raylab::bench;

namespace {

// Two triangles sharing the edge (1,0,0)-(0,1,0) in z = 0, and a third far away sharing no vertex.
TriangleMesh two_triangles() {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {5, 5, 0}, {6, 5, 0}, {5, 6, 0}};
  mesh.triangles = {{0, 1, 2}, {1, 3, 2}, {4, 5, 6}};
  return mesh;
}

Ray down_from(float x, float y, float z) { return test::ray_of({x, y, z}, {0, 0, -1}); }

Hit hit(uint32_t triangle, float t, float u, float v) {
  Hit h;
  h.triangle = triangle;
  h.t = t;
  h.u = u;
  h.v = v;
  return h;
}

}  // namespace

TEST(HitComparison, AgreeingHitsAndMissesAreSame) {
  const TriangleMesh mesh = two_triangles();
  EXPECT_EQ(classify(mesh, down_from(0.2f, 0.2f, 1), hit(0, 1.0f, 0.2f, 0.2f), hit(0, 1.000001f, 0.2f, 0.2f)),
            Agreement::Same);
  EXPECT_EQ(classify(mesh, down_from(9, 9, 1), Hit{}, Hit{}), Agreement::Same);
}

TEST(HitComparison, AShortHitFarFromTheOriginIsRounding) {
  // t = 1e-4 at coordinates near 1000: the origin's rounding (6e-5) is most of t.
  TriangleMesh mesh;
  mesh.vertices = {{1000, 1000, 0}, {1001, 1000, 0}, {1000, 1001, 0}};
  mesh.triangles = {{0, 1, 2}};
  const Ray ray = down_from(1000.2f, 1000.2f, 1e-4f);
  EXPECT_EQ(classify(mesh, ray, hit(0, 1e-4f, 0.2f, 0.2f), hit(0, 1.3e-4f, 0.2f, 0.2f)), Agreement::Rounding);
  // The same difference at unit scale is far beyond rounding.
  const TriangleMesh unit = two_triangles();
  EXPECT_EQ(classify(unit, down_from(0.2f, 0.2f, 1e-4f), hit(0, 1e-4f, 0.2f, 0.2f), hit(0, 1.3e-4f, 0.2f, 0.2f)),
            Agreement::Unexplained);
}

TEST(HitComparison, ASlideAlongTheFaceOfAGrazingRayIsRounding) {
  // At 1 degree off the face, hits 2e-5 apart along the ray are 3.5e-7 apart across the face.
  const TriangleMesh mesh = two_triangles();
  Ray ray;
  ray.origin = {0.1f, 0.2f, 0.00873f};
  ray.direction = {0.99985f, 0.0f, -0.01745f};
  EXPECT_EQ(classify(mesh, ray, hit(0, 0.5f, 0.4f, 0.2f), hit(0, 0.50002f, 0.40002f, 0.2f)), Agreement::Rounding);
  // Head-on, the same difference leaves the face.
  EXPECT_EQ(classify(mesh, down_from(0.4f, 0.2f, 0.5f), hit(0, 0.5f, 0.4f, 0.2f), hit(0, 0.50002f, 0.4f, 0.2f)),
            Agreement::Unexplained);
}

TEST(HitComparison, AnEdgeHitOwnedByBothNeighboursIsSharedEdge) {
  const TriangleMesh mesh = two_triangles();
  EXPECT_EQ(classify(mesh, down_from(0.5f, 0.5f, 1), hit(0, 1.0f, 0.5f, 0.5f), hit(1, 1.0f, 0.0f, 0.5f)),
            Agreement::SharedEdgeVertex);
  EXPECT_EQ(classify(mesh, down_from(0.5f, 0.5f, 1), hit(0, 1.0f, 0.5f, 0.5f), hit(2, 1.0f, 0.3f, 0.3f)),
            Agreement::CoincidentFaces);
  // The neighbour claimed inside the other triangle, away from their edge: one of them is wrong.
  EXPECT_EQ(classify(mesh, down_from(0.2f, 0.2f, 1), hit(0, 1.0f, 0.2f, 0.2f), hit(1, 1.0f, 0.3f, 0.3f)),
            Agreement::Unexplained);
}

TEST(HitComparison, HitAgainstMissIsExplainedOnlyOnAnEdge) {
  const TriangleMesh mesh = two_triangles();
  EXPECT_EQ(classify(mesh, down_from(0.5f, 0.5f, 1), hit(0, 1.0f, 0.5f, 0.5f), Hit{}), Agreement::EdgeRay);
  EXPECT_EQ(classify(mesh, down_from(0.5f, 0.5f, 1), Hit{}, hit(0, 1.0f, 0.5f, 0.5f)), Agreement::EdgeRayPassed);
  EXPECT_EQ(classify(mesh, down_from(0.2f, 0.2f, 1), Hit{}, hit(0, 1.0f, 0.2f, 0.2f)), Agreement::Unexplained);
  // A nearer hit the other passed by: explained when that nearer hit is on an edge.
  EXPECT_EQ(classify(mesh, down_from(0.5f, 0.5f, 1), hit(0, 1.0f, 0.5f, 0.5f), hit(2, 3.0f, 0.3f, 0.3f)),
            Agreement::EdgeRay);
  EXPECT_EQ(classify(mesh, down_from(0.2f, 0.2f, 1), hit(0, 1.0f, 0.2f, 0.2f), hit(2, 3.0f, 0.3f, 0.3f)),
            Agreement::Unexplained);
}

TEST(HitComparison, ExamplesKeepTheFirstFewOfEachKind) {
  const TriangleMesh mesh = two_triangles();
  std::vector<Ray> rays(10, down_from(0.2f, 0.2f, 1));
  std::vector<Hit> ours(10, hit(0, 1.0f, 0.2f, 0.2f)), theirs(10, Hit{});
  theirs[0] = ours[0];
  const Comparison c = compare_closest(mesh, rays, ours, theirs);
  EXPECT_EQ(c.counts[int(Agreement::Same)], 1u);
  EXPECT_EQ(c.counts[int(Agreement::Unexplained)], 9u);
  ASSERT_EQ(c.examples.size(), 3u);
  const nlohmann::ordered_json json = comparison_json(mesh, c);
  EXPECT_EQ(json["unexplained"], 9) << json;
  EXPECT_EQ(json["rays"], 10) << json;
  EXPECT_EQ(json["examples"].size(), 3u) << json;
  EXPECT_DOUBLE_EQ(json["examples"][0]["raylab"]["double_t"].get<double>(), 1.0) << json;  // re-solved
  EXPECT_TRUE(json["examples"][0]["embree"].is_null()) << json;                            // Embree missed
}

TEST(HitComparison, TheRefereeSettlesWhatTheClassesLeaveUnexplained) {
  const TriangleMesh mesh = two_triangles();
  const Referee referee(mesh);
  const Arbiter arbiter{&referee, {}};
  // tmax short of the hit: the miss is right, a hit there is not (tmax is exclusive of nothing beyond it).
  const std::vector<Ray> short_of{test::ray_of({0.2f, 0.2f, 1}, {0, 0, -1}, 0.0f, 0.9f)};
  const std::vector<Hit> miss{Hit{}}, beyond{hit(0, 1.0f, 0.2f, 0.2f)};
  EXPECT_EQ(compare_closest(mesh, short_of, miss, beyond, arbiter).counts[int(Agreement::EmbreeWrong)], 1u);
  EXPECT_EQ(compare_closest(mesh, short_of, beyond, miss, arbiter).counts[int(Agreement::RaylabWrong)], 1u);
  EXPECT_EQ(compare_closest(mesh, short_of, miss, beyond).counts[int(Agreement::Unexplained)], 1u);  // no referee
  // Any hit: occluded by a triangle beyond tmax is wrong, not occluded right.
  const std::vector<uint8_t> no{0}, yes{1};
  EXPECT_EQ(compare_any(mesh, short_of, no, yes, miss, beyond, arbiter).counts[int(Agreement::EmbreeWrong)], 1u);
  // Both right by the referee (tmax within its tie distance of the hit): a referee tie.
  const std::vector<Ray> at_tmax{test::ray_of({0.2f, 0.2f, 1}, {0, 0, -1}, 0.0f, 0.9999999f)};
  EXPECT_EQ(compare_closest(mesh, at_tmax, miss, beyond, arbiter).counts[int(Agreement::RefereeTie)], 1u);
}
