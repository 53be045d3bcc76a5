#include "raylab/mesh_io.h"
#include "raylab/scene.h"

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace raylab;

namespace {

MeshPtr load(const char* name) {
  return std::make_shared<const TriangleMesh>(load_mesh(std::string(RAYLAB_MESH_DIR) + "/" + name));
}

MeshPtr unit_square() {  // two triangles in z = 0 covering [0,1]^2
  auto mesh = std::make_shared<TriangleMesh>();
  mesh->vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  mesh->triangles = {{0, 1, 2}, {0, 2, 3}};
  return mesh;
}

glm::mat4 translation(float x, float y, float z) { return glm::translate(glm::mat4(1.0f), {x, y, z}); }

Ray ray_from(glm::vec3 origin, glm::vec3 direction) {
  Ray r;
  r.origin = origin;
  r.direction = direction;
  return r;
}

}  // namespace

TEST(Scene, EmptySceneMissesEveryRay) {
  Scene scene;
  scene.commit();
  Hit h;
  TraversalStats stats;
  EXPECT_FALSE(scene.closest(ray_from({0, 0, 0}, {0, 0, 1}), h, &stats));
  EXPECT_FALSE(scene.any(ray_from({0, 0, 0}, {1, 0, 0})));
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
  EXPECT_THROW(scene.closest(ray_from({0.5f, 0.5f, 1}, {0, 0, -1}), h), std::logic_error);
  scene.commit();
  EXPECT_TRUE(scene.closest(ray_from({0.5f, 0.5f, 1}, {0, 0, -1}), h));
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
  ASSERT_TRUE(scene.closest(ray_from({0, 1, -1}, {2, 0, 0}), h));
  EXPECT_NEAR(h.t, 5.0f, 1e-5f);
  EXPECT_EQ(h.instance, 0u);
  EXPECT_EQ(scene.instance(0).material, 7u);
  EXPECT_FALSE(scene.closest(ray_from({0, 1, 1}, {1, 0, 0}), h));  // beside it
}

TEST(Scene, InstancesShareOneStructurePerMesh) {
  const MeshPtr mesh = load("bunny.obj");
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
  const uint32_t b = scene.add_mesh(load("sphere.obj"));
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
  ASSERT_TRUE(scene.closest(ray_from({0.5f, 0.5f, 1}, {0, 0, -1}), h));
  EXPECT_FLOAT_EQ(h.t, 5.0f);

  // Replacing a mesh rebuilds its own structure alone.
  const MeshPtr replacement = load("teapot.obj");
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
  const MeshPtr mesh = load("spot_low_resolution.obj");
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
  const uint32_t m = scene.add_mesh(load("bunny.obj"));
  scene.add_instance(m, glm::mat4(1.0f));
  scene.commit();
  const Bounds box = scene.bounds();
  const Ray ray = ray_from(box.center() - glm::vec3(0, 0, 2 * box.extent().z), {0, 0, 1});
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
    EXPECT_TRUE(scene.closest(ray_from({0.5f, 0.5f, 1}, {0, 0, -1}), h, &stats));  // hits the first square
    EXPECT_FALSE(scene.closest(ray_from({3, 0.5f, 1}, {0, 0, -1}), h, &stats));    // between the two
    EXPECT_FALSE(scene.any(ray_from({3, 0.5f, 1}, {0, 0, -1}), &stats));
    EXPECT_EQ(stats.rays, 3u);
    if (kind == StructureKind::None) {
      EXPECT_EQ(stats.rays_ignored, 0u);  // brute force ignores nothing...
      EXPECT_EQ(stats.triangle_tests, 3u * 4u);  // ...and tests all four triangles per ray
    } else {
      EXPECT_EQ(stats.rays_ignored, 2u) << structure_kind_name(kind);
    }
  }
}
