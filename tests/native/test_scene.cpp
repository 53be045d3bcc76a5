#include "support.h"

#include "raylab/mesh_io.h"
#include "raylab/scene.h"

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <random>
#include <span>
#include <thread>

using namespace raylab;
using namespace raylab::test;

namespace {

MeshPtr unit_square() {  // two triangles in z = 0 covering [0,1]^2
  auto mesh = std::make_shared<TriangleMesh>();
  mesh->vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  mesh->triangles = {{0, 1, 2}, {0, 2, 3}};
  return mesh;
}

glm::mat4 translation(float x, float y, float z) { return glm::translate(glm::mat4(1.0f), {x, y, z}); }

}  // namespace

TEST(Scene, EmptySceneMissesEveryRay) {
  Scene scene;
  scene.commit();
  Hit h;
  TraversalStats stats;
  EXPECT_FALSE(scene.closest(ray_of({0, 0, 0}, {0, 0, 1}), h, &stats));
  EXPECT_FALSE(scene.any(ray_of({0, 0, 0}, {1, 0, 0})));
  EXPECT_EQ(stats.rays, 1u);
  EXPECT_EQ(stats.rays_ignored, 1u);
}

TEST(Scene, RejectsUnknownIdsAndBadTransforms) {
  Scene scene;
  const uint32_t m = scene.add_mesh(unit_square());
  EXPECT_THROW(scene.add_instance(m + 1, glm::mat4(1.0f)), std::invalid_argument);
  EXPECT_THROW(scene.add_instance(m, glm::scale(glm::mat4(1.0f), {1.0f, 0.0f, 1.0f})), std::invalid_argument);
  glm::mat4 nan(1.0f);
  nan[3][0] = std::nanf("");
  EXPECT_THROW(scene.add_instance(m, nan), std::invalid_argument);
  const uint32_t i = scene.add_instance(m, glm::mat4(1.0f));
  EXPECT_THROW(scene.set_transform(i + 1, glm::mat4(1.0f)), std::invalid_argument);
  EXPECT_THROW(scene.set_transform(i, glm::mat4(0.0f)), std::invalid_argument);
  EXPECT_THROW(scene.replace_mesh(m + 1, unit_square()), std::invalid_argument);
  auto broken = std::make_shared<TriangleMesh>();
  broken->vertices = {{0, 0, 0}};
  broken->triangles = {{0, 0, 5}};
  EXPECT_THROW(scene.add_mesh(broken), std::invalid_argument);
  // A query on a scene changed since its last commit is refused rather than answered from stale data.
  Hit h;
  EXPECT_THROW(scene.closest(ray_of({0.5f, 0.5f, 1}, {0, 0, -1}), h), std::logic_error);
  scene.commit();
  EXPECT_TRUE(scene.closest(ray_of({0.5f, 0.5f, 1}, {0, 0, -1}), h));
}

TEST(Scene, RotatedAndScaledInstanceGivesWorldDistance) {
  Scene scene;
  const uint32_t m = scene.add_mesh(unit_square());
  // Scale by 3, turn the square to face +x (about y), move it to x = 10.
  const glm::mat4 transform = translation(10, 0, 0) * glm::rotate(glm::mat4(1.0f), glm::radians(90.0f), {0, 1, 0}) *
                              glm::scale(glm::mat4(1.0f), glm::vec3(3.0f));
  scene.add_instance(m, transform, 7);
  scene.commit();
  Hit h;
  // The square now spans y in [0,3], z in [-3,0] at x = 10; a direction of length 2 halves t.
  ASSERT_TRUE(scene.closest(ray_of({0, 1, -1}, {2, 0, 0}), h));
  EXPECT_NEAR(h.t, 5.0f, 1e-5f);
  EXPECT_EQ(h.instance, 0u);
  EXPECT_EQ(scene.instance(0).material, 7u);
  EXPECT_FALSE(scene.closest(ray_of({0, 1, 1}, {1, 0, 0}), h));  // beside it
}

TEST(Scene, InstancesShareOneStructurePerMesh) {
  const MeshPtr mesh = shipped("bunny.obj");
  Scene one, many;
  one.add_instance(one.add_mesh(mesh), glm::mat4(1.0f));
  const uint32_t m = many.add_mesh(mesh);
  for (int i = 0; i < 20; ++i) many.add_instance(m, translation(float(i), 0, 0));
  one.commit();
  many.commit();
  EXPECT_EQ(many.mesh_count(), 1u);
  EXPECT_EQ(many.instance_count(), 20u);
  const size_t structure_bytes = many.structure(m).memory_bytes();
  ASSERT_GT(structure_bytes, 0u);
  // Twenty instances cost a small top level, not twenty structures.
  EXPECT_LT(many.memory_bytes() - one.memory_bytes(), structure_bytes / 4);
}

TEST(Scene, OnlyWhatChangedIsRebuilt) {
  Scene scene;
  const uint32_t a = scene.add_mesh(unit_square());
  const uint32_t b = scene.add_mesh(shipped("sphere.obj"));
  const uint32_t ia = scene.add_instance(a, glm::mat4(1.0f));
  scene.add_instance(b, translation(5, 0, 0));
  scene.commit();
  const Structure* sa = &scene.structure(a);
  const Structure* sb = &scene.structure(b);

  // Moving an instance rebuilds no mesh structure, and rays see it at its new place.
  scene.set_transform(ia, translation(0, 0, -4));
  scene.commit();
  EXPECT_EQ(&scene.structure(a), sa);
  EXPECT_EQ(&scene.structure(b), sb);
  Hit h;
  ASSERT_TRUE(scene.closest(ray_of({0.5f, 0.5f, 1}, {0, 0, -1}), h));
  EXPECT_FLOAT_EQ(h.t, 5.0f);

  // Replacing a mesh rebuilds its own structure alone.
  const MeshPtr replacement = shipped("teapot.obj");
  scene.replace_mesh(b, replacement);
  scene.commit();
  EXPECT_EQ(&scene.structure(a), sa);
  EXPECT_EQ(scene.structure(b).mesh_ptr(), replacement);

  // New settings rebuild everything.
  BuildSettings settings;
  settings.kind = StructureKind::Aabb;
  scene.set_settings(settings);
  scene.commit();
  EXPECT_EQ(scene.structure(a).kind(), StructureKind::Aabb);
  EXPECT_EQ(scene.structure(b).kind(), StructureKind::Aabb);
}

TEST(Scene, InstanceHitsEqualBruteForceOnTransformedVertices) {
  const MeshPtr mesh = shipped("spot_low_resolution.obj");
  Scene scene;
  const uint32_t m = scene.add_mesh(mesh);
  const std::vector<glm::mat4> transforms = {
      glm::mat4(1.0f),
      translation(2.5f, 0, 0) * glm::rotate(glm::mat4(1.0f), 0.7f, glm::normalize(glm::vec3(1, 2, 3))),
      translation(-2, 1, 0.5f) * glm::scale(glm::mat4(1.0f), {0.5f, 2.0f, 1.5f}),
  };
  for (const glm::mat4& t : transforms) scene.add_instance(m, t);
  scene.commit();

  // The oracle: each instance's vertices moved to world space, brute-forced.
  BuildSettings brute;
  brute.kind = StructureKind::None;
  std::vector<std::unique_ptr<Structure>> world;
  for (const glm::mat4& t : transforms) {
    auto moved = std::make_shared<TriangleMesh>(*mesh);
    for (glm::vec3& v : moved->vertices) v = glm::vec3(t * glm::vec4(v, 1.0f));
    world.push_back(build_structure(moved, brute));
  }

  const Bounds box = scene.bounds();
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  auto point_in = [&](glm::vec3 lo, glm::vec3 size) { return lo + glm::vec3(unit(rng), unit(rng), unit(rng)) * size; };
  int compared = 0, hits = 0, agree = 0;
  for (int i = 0; i < 1000; ++i) {
    const Ray ray = [&] {
      Ray r;
      r.origin = point_in(box.lo - box.extent(), 3.0f * box.extent());
      r.direction = point_in(box.lo, box.extent()) - r.origin;
      return r;
    }();
    Hit expected;
    for (uint32_t k = 0; k < world.size(); ++k) {
      Hit h;
      if (world[k]->closest(ray, h) && h.t < expected.t) {
        expected = h;
        expected.instance = k;
      }
    }
    Hit got;
    const bool found = scene.closest(ray, got);
    EXPECT_EQ(found, scene.any(ray));
    ++compared;
    if (found != expected.valid()) continue;  // a graze that rounding in either space may decide
    ++agree;
    if (!found) continue;
    ++hits;
    EXPECT_EQ(got.instance, expected.instance) << "ray " << i;
    EXPECT_NEAR(got.t, expected.t, 1e-4f * expected.t) << "ray " << i;
    if (got.triangle != expected.triangle) {
      // Only a ray through a shared edge or vertex may pick a neighbour, at the same distance.
      EXPECT_NEAR(got.t, expected.t, 1e-5f * expected.t) << "ray " << i;
    }
  }
  EXPECT_GE(agree, compared - 5);
  EXPECT_GT(hits, 200);
}

TEST(Scene, CountsTheTopLevelWithTheMeshStructure) {
  Scene scene;
  const uint32_t m = scene.add_mesh(shipped("bunny.obj"));
  scene.add_instance(m, glm::mat4(1.0f));
  scene.commit();
  const Bounds box = scene.bounds();
  const Ray ray = ray_of(box.center() - glm::vec3(0, 0, 2 * box.extent().z), {0, 0, 1});
  TraversalStats scene_stats, mesh_stats;
  Hit a, b;
  ASSERT_TRUE(scene.closest(ray, a, &scene_stats));
  ASSERT_TRUE(scene.structure(m).closest(ray, b, mesh_stats));
  EXPECT_EQ(a.triangle, b.triangle);
  EXPECT_EQ(a.t, b.t);
  EXPECT_EQ(scene_stats.rays, 1u);
  // One instance: the top level is a single leaf box, tested and entered once.
  EXPECT_EQ(scene_stats.box_tests, mesh_stats.box_tests + 1);
  EXPECT_EQ(scene_stats.nodes_visited, mesh_stats.nodes_visited + 1);
  EXPECT_EQ(scene_stats.triangle_tests, mesh_stats.triangle_tests);
}

// VRT's counts: with `none` every ray tests every triangle of every object; with `aabb` a ray is
// ignored when it misses every object's box; with a top level it is ignored likewise.
TEST(Scene, RaysIgnoredAreRaysThatEnterNoObject) {
  for (StructureKind kind : {StructureKind::None, StructureKind::Aabb, StructureKind::Bvh}) {
    BuildSettings settings;
    settings.kind = kind;
    Scene scene(settings);
    const uint32_t m = scene.add_mesh(unit_square());
    scene.add_instance(m, glm::mat4(1.0f));
    scene.add_instance(m, translation(5, 0, 0));
    scene.commit();
    TraversalStats stats;
    Hit h;
    EXPECT_TRUE(scene.closest(ray_of({0.5f, 0.5f, 1}, {0, 0, -1}), h, &stats));  // hits the first square
    EXPECT_FALSE(scene.closest(ray_of({3, 0.5f, 1}, {0, 0, -1}), h, &stats));    // between the two
    EXPECT_FALSE(scene.any(ray_of({3, 0.5f, 1}, {0, 0, -1}), &stats));
    EXPECT_EQ(stats.rays, 3u);
    if (kind == StructureKind::None) {
      EXPECT_EQ(stats.rays_ignored, 0u);         // brute force ignores nothing...
      EXPECT_EQ(stats.triangle_tests, 3u * 4u);  // ...and tests all four triangles per ray
    } else {
      EXPECT_EQ(stats.rays_ignored, 2u) << structure_kind_name(kind);
    }
  }
}

// The story is recorded by the same traversal as closest(): the same hit and counters ray by ray,
// the top level's boxes and nodes in it, and each queried instance's own story.
TEST(Scene, StoryTellsWhatClosestDid) {
  for (const StructureInfo& info : structure_kinds()) {
    BuildSettings settings;
    settings.kind = info.kind;
    Scene scene(settings);
    const uint32_t m = scene.add_mesh(shipped("bunny.obj"));
    scene.add_instance(m, glm::mat4(1.0f));
    scene.add_instance(m, glm::rotate(translation(0.1f, 0, 0), 0.7f, glm::vec3(0, 1, 0)));
    scene.commit();
    const Bounds box = scene.bounds();
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    int hits = 0;
    for (int i = 0; i < 200; ++i) {
      const glm::vec3 origin = box.center() + 2.0f * box.extent() * glm::vec3(unit(rng), unit(rng), unit(rng));
      const glm::vec3 target = box.center() + 0.6f * box.extent() * glm::vec3(unit(rng), unit(rng), unit(rng));
      const Ray ray = ray_of(origin, target - origin);
      TraversalStats stats;
      Hit h;
      const bool found = scene.closest(ray, h, &stats);
      const SceneStory st = scene.story(ray);
      ASSERT_EQ(st.hit.valid(), found) << info.name << " ray " << i;
      hits += found;
      if (found) {
        EXPECT_EQ(st.hit.t, h.t);
        EXPECT_EQ(st.hit.triangle, h.triangle);
        EXPECT_EQ(st.hit.instance, h.instance);
      }
      for (const CounterInfo& c : kCounters) EXPECT_EQ(st.stats.*c.field, stats.*c.field) << info.name << " " << c.name;
      EXPECT_EQ(
          st.top_boxes.size() +
              [&] {
                size_t n = 0;
                for (const SceneStory::Part& p : st.instances) n += p.story.boxes.size();
                return n;
              }(),
          stats.box_tests);
      EXPECT_EQ(st.top_boxes.empty(), !info.uses_top_level);
      EXPECT_EQ(st.status, ray_status(found, stats.rays_ignored > 0, stats.triangle_tests > 0));
    }
    EXPECT_GT(hits, 20) << info.name;
  }
}

// Threads: one thread changes the scene and commits while others query. Every answer must be the
// brute-force answer of one committed state, the old or the new, never a mix (nor a crash).
namespace {

constexpr int kAdditions = 200;  // instances added one commit at a time

// Rays along +z from z = -10 through each centre shifted by each (dx, dy), `copies` times over: a
// batch long enough for commits to overlap it.
std::vector<Ray> rays_through(std::span<const glm::vec2> centres, std::span<const glm::vec2> offsets,
                              int copies = 300) {
  std::vector<Ray> rays;
  for (int copy = 0; copy < copies; ++copy)
    for (const glm::vec2 c : centres)
      for (const glm::vec2 o : offsets) rays.push_back(ray_of({c.x + o.x, c.y + o.y, -10}, {0, 0, 1}));
  return rays;
}

// Well inside the silhouette of a sphere of radius 0.5: no ray grazes either state's spheres.
const std::vector<glm::vec2> kNearAxis = {{-0.25f, -0.2f}, {0, 0}, {0.25f, 0.1f}, {0.1f, 0.3f}};

struct Placed {
  MeshPtr mesh;
  glm::mat4 transform;
};

// The closest hits over world-space copies of the placed meshes, each brute-forced.
std::vector<Hit> brute_force(const std::vector<Placed>& placed, std::span<const Ray> rays) {
  BuildSettings brute;
  brute.kind = StructureKind::None;
  std::vector<Hit> best(rays.size());
  for (uint32_t k = 0; k < placed.size(); ++k) {
    auto moved = std::make_shared<TriangleMesh>(*placed[k].mesh);
    for (glm::vec3& v : moved->vertices) v = glm::vec3(placed[k].transform * glm::vec4(v, 1.0f));
    const std::unique_ptr<Structure> s = build_structure(moved, brute);
    for (size_t i = 0; i < rays.size(); ++i) {
      Hit h;
      if (s->closest(rays[i], h) && h.t < best[i].t) {
        best[i] = h;
        best[i].instance = k;
      }
    }
  }
  return best;
}

bool same_hits(std::span<const Hit> got, std::span<const Hit> expected) {
  for (size_t i = 0; i < got.size(); ++i) {
    if (got[i].valid() != expected[i].valid()) return false;
    if (got[i].valid() &&
        (got[i].instance != expected[i].instance || std::abs(got[i].t - expected[i].t) > 1e-5f * expected[i].t))
      return false;
  }
  return true;
}

bool same_occlusion(std::span<const uint8_t> got, std::span<const Hit> expected) {
  for (size_t i = 0; i < got.size(); ++i)
    if (bool(got[i]) != expected[i].valid()) return false;
  return true;
}

// One closest-hit batch and one any-hit batch: true when each is the answer of one of `states`.
bool answers_from_one_state(const Scene& scene, std::span<const Ray> rays,
                            const std::vector<std::vector<Hit>>& states) {
  std::vector<Hit> hits(rays.size());
  std::vector<uint8_t> occluded(rays.size());
  intersect_closest(scene, rays, hits, nullptr);
  intersect_any(scene, rays, occluded, nullptr);
  const auto any_state = [&](auto same) { return std::any_of(states.begin(), states.end(), same); };
  return any_state([&](const std::vector<Hit>& s) { return same_hits(hits, s); }) &&
         any_state([&](const std::vector<Hit>& s) { return same_occlusion(occluded, s); });
}

// Two threads run query() `rounds` times each while this one runs change(k) for k = 0, 1, ... until
// they are done (or `most_changes` ran); returns how many queries failed (false or an exception).
template <class Change, class Query>
int queries_failed_during(Change change, Query query, int most_changes = std::numeric_limits<int>::max()) {
  constexpr int rounds = 20;
  std::atomic<int> readers_done{0}, failed{0};
  std::vector<std::thread> readers;
  for (int r = 0; r < 2; ++r)
    readers.emplace_back([&] {
      for (int round = 0; round < rounds; ++round) {
        try {
          if (!query()) ++failed;
        } catch (...) {
          ++failed;
        }
      }
      ++readers_done;
    });
  for (int k = 0; k < most_changes && readers_done.load() < 2; ++k) change(k);
  for (std::thread& t : readers) t.join();
  return failed.load();
}

}  // namespace

TEST(SceneThreads, QueriesDuringMovesAndCommitsSeeTheOldOrTheNewStateWhole) {
  const MeshPtr sphere = shipped("sphere.obj");
  const glm::mat4 old_place = glm::mat4(1.0f), new_place = translation(100, 0, 0), still = translation(3, 0, 0);
  Scene scene;
  const uint32_t m = scene.add_mesh(sphere);
  scene.add_instance(m, old_place);
  scene.add_instance(m, still);
  scene.commit();
  const std::vector<glm::vec2> centres = {{0, 0}, {100, 0}, {3, 0}};
  const std::vector<Ray> rays = rays_through(centres, kNearAxis);
  const std::vector<std::vector<Hit>> states = {brute_force({{sphere, old_place}, {sphere, still}}, rays),
                                                brute_force({{sphere, new_place}, {sphere, still}}, rays)};
  ASSERT_FALSE(same_hits(states[0], states[1]));
  ASSERT_TRUE(answers_from_one_state(scene, rays, {states[0]}));

  EXPECT_EQ(queries_failed_during(
                [&](int k) {
                  scene.set_transform(0, k % 2 == 0 ? new_place : old_place);
                  scene.commit();
                },
                [&] { return answers_from_one_state(scene, rays, states); }),
            0);
}

TEST(SceneThreads, QueriesDuringMeshReplacementsSeeTheOldOrTheNewStateWhole) {
  const MeshPtr sphere = shipped("sphere.obj");
  auto half = std::make_shared<TriangleMesh>(*sphere);
  for (glm::vec3& v : half->vertices) v *= 0.5f;  // t along the axis: 9.5 instead of 9
  const MeshPtr small = half;
  Scene scene;
  const uint32_t m = scene.add_mesh(sphere);
  const uint32_t other = scene.add_mesh(sphere);
  scene.add_instance(m, glm::mat4(1.0f));
  scene.add_instance(other, translation(3, 0, 0));
  scene.commit();
  std::vector<glm::vec2> offsets = kNearAxis;
  offsets.push_back({0.7f, 0});  // meets the old sphere only
  const std::vector<glm::vec2> centres = {{0, 0}, {3, 0}};
  const std::vector<Ray> rays = rays_through(centres, offsets);
  const glm::mat4 identity(1.0f);
  const std::vector<std::vector<Hit>> states = {brute_force({{sphere, identity}, {sphere, translation(3, 0, 0)}}, rays),
                                                brute_force({{small, identity}, {sphere, translation(3, 0, 0)}}, rays)};
  ASSERT_FALSE(same_hits(states[0], states[1]));
  ASSERT_TRUE(answers_from_one_state(scene, rays, {states[0]}));

  EXPECT_EQ(queries_failed_during(
                [&](int k) {
                  scene.replace_mesh(m, k % 2 == 0 ? small : sphere);
                  scene.commit();
                },
                [&] { return answers_from_one_state(scene, rays, states); }),
            0);
}

TEST(SceneThreads, QueriesDuringAddedInstancesSeeTheFirstNOfOneState) {
  const MeshPtr sphere = shipped("sphere.obj");
  Scene scene;
  const uint32_t m = scene.add_mesh(sphere);
  scene.add_instance(m, glm::mat4(1.0f));
  scene.commit();
  // Instance k at x = 10 k: its rays meet it alone, so each is brute-forced on its own rays.
  std::vector<Placed> placed;
  std::vector<glm::vec2> centres;
  for (int k = 0; k <= kAdditions; ++k) {
    placed.push_back({sphere, translation(10.0f * float(k), 0, 0)});
    centres.push_back({10.0f * float(k), 0});
  }
  const std::vector<glm::vec2> offset = {{0.1f, -0.2f}};
  constexpr int copies = 20;
  const std::vector<Ray> rays = rays_through(centres, offset, copies);
  std::vector<Hit> all(rays.size());
  for (size_t k = 0; k < placed.size(); ++k) {
    std::vector<Ray> mine;
    for (size_t i = k; i < rays.size(); i += placed.size()) mine.push_back(rays[i]);
    const std::vector<Hit> hits = brute_force({placed[k]}, mine);
    for (size_t j = 0; j < mine.size(); ++j) {
      all[k + j * placed.size()] = hits[j];
      all[k + j * placed.size()].instance = uint32_t(k);
    }
  }
  std::vector<std::vector<Hit>> states;  // states[n]: instances 0 to n
  for (size_t n = 0; n < placed.size(); ++n) {
    states.push_back(all);
    for (size_t i = 0; i < rays.size(); ++i)
      if (i % placed.size() > n) states.back()[i] = Hit{};
  }

  EXPECT_EQ(queries_failed_during(
                [&](int k) {
                  scene.add_instance(m, placed[size_t(k) + 1].transform);
                  scene.commit();
                },
                [&] { return answers_from_one_state(scene, rays, states); }, kAdditions),
            0);
  EXPECT_TRUE(answers_from_one_state(scene, rays, {states[scene.instance_count() - 1]}));
}

TEST(SceneThreads, AThreadThatChangedTheSceneMustCommitOthersSeeTheLastCommit) {
  Scene scene;
  scene.add_instance(scene.add_mesh(unit_square()), glm::mat4(1.0f));
  scene.commit();
  const SceneSnapshotPtr before = scene.snapshot();
  scene.set_transform(0, translation(0, 0, -4));  // not committed
  const Ray ray = ray_of({0.5f, 0.5f, 1}, {0, 0, -1});
  Hit h;
  EXPECT_THROW(scene.closest(ray, h), std::logic_error);  // it would not see its own change
  float t_elsewhere = 0.0f;
  std::thread([&] {
    Hit other;
    if (scene.closest(ray, other)) t_elsewhere = other.t;
  }).join();
  EXPECT_FLOAT_EQ(t_elsewhere, 1.0f);  // the last commit
  scene.commit();
  ASSERT_TRUE(scene.closest(ray, h));
  EXPECT_FLOAT_EQ(h.t, 5.0f);
  ASSERT_TRUE(before->closest(ray, h));  // a snapshot held keeps its state
  EXPECT_FLOAT_EQ(h.t, 1.0f);
}

// Thread ids are recycled once a thread ends: a new thread must not inherit the uncommitted change
// of an ended one (it made none, so it gets the last commit).
TEST(SceneThreads, ANewThreadNeverInheritsAnEndedThreadsChange) {
  Scene scene;
  scene.add_instance(scene.add_mesh(unit_square()), glm::mat4(1.0f));
  scene.commit();
  const Ray ray = ray_of({0.5f, 0.5f, 1}, {0, 0, -1});
  int refused = 0, hits = 0;
  for (int k = 0; k < 50; ++k) {
    std::thread([&] { scene.set_transform(0, translation(0, 0, -4.0f - float(k))); }).join();
    std::thread([&] {
      try {
        Hit h;
        hits += scene.closest(ray, h) && h.t == 1.0f;
      } catch (const std::logic_error&) {
        ++refused;
      }
    }).join();
  }
  EXPECT_EQ(refused, 0);
  EXPECT_EQ(hits, 50);
}
