// A Scene that follows an animation: refit_mesh refits a mesh's structure, moved instances refit the
// top level; every commit answers as a scene made afresh from the same state, and queries running
// during refit commits see one committed state whole.
#include "support.h"

#include "raylab/refit.h"
#include "raylab/scene.h"

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <atomic>
#include <numeric>
#include <random>
#include <thread>

using namespace raylab;
using namespace raylab::test;

namespace {

constexpr int kFrames = 12;  // the stress frames of animated_vertices are 8 and beyond: 8 is in

glm::mat4 translation(float x, float y, float z) { return glm::translate(glm::mat4(1.0f), {x, y, z}); }

// Instance k of frame f: spheres in a row that bob up and down.
glm::mat4 place(int k, int f) { return translation(3.0f * float(k), 0.3f * std::sin(0.4f * float(f + k)), 0.0f); }

// Rays from in front of the row into it: along -z through a grid, and from random points.
std::vector<Ray> rays_into_row(int instances) {
  std::vector<Ray> rays;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 12; ++j)
      rays.push_back(ray_of({-1.5f + 3.0f * float(instances) * float(i) / 60.0f, -1.5f + 0.25f * float(j), 5.0f},
                            {0.01f * float(j - 6), 0.003f * float(i % 7), -1.0f}));
  return rays;
}

void expect_same_hits(const Scene& a, const Scene& b, const std::vector<Ray>& rays) {
  for (const Ray& ray : rays) {
    Hit x, y;
    const bool hx = a.closest(ray, x), hy = b.closest(ray, y);
    ASSERT_EQ(hx, hy);
    EXPECT_EQ(a.any(ray), b.any(ray));
    if (!hx) continue;
    EXPECT_EQ(x.instance, y.instance);
    EXPECT_EQ(x.triangle, y.triangle);
    EXPECT_EQ(x.t, y.t);
    EXPECT_EQ(x.u, y.u);
    EXPECT_EQ(x.v, y.v);
  }
}

BuildSettings settings_of(StructureKind kind) {
  BuildSettings s;
  s.kind = kind;
  return s;
}

}  // namespace

TEST(SceneRefit, EveryFrameAnswersAsAFreshScene) {
  const MeshPtr rest = shipped("sphere.obj");
  constexpr int kInstances = 3;
  const std::vector<Ray> rays = rays_into_row(kInstances);
  for (const StructureInfo& info : structure_kinds()) {
    SCOPED_TRACE(info.name);
    Scene scene(settings_of(info.kind));
    const uint32_t m = scene.add_mesh(rest);
    const uint32_t still = scene.add_mesh(shipped("teapot.obj"));
    for (int k = 0; k < kInstances; ++k) scene.add_instance(m, place(k, 0));
    scene.add_instance(still, translation(0, 0, -6));
    scene.commit();
    EXPECT_EQ(scene.top_level_update(), TopLevelUpdate::Built);
    const Structure* teapot = &scene.structure(still);
    for (int f = 1; f < kFrames; ++f) {
      SCOPED_TRACE("frame " + std::to_string(f));
      const std::vector<glm::vec3> vertices = animated_vertices(*rest, f, kFrames);
      scene.refit_mesh(m, vertices);
      for (int k = 0; k < kInstances; ++k) scene.set_transform(uint32_t(k), place(k, f));
      scene.commit();
      EXPECT_EQ(scene.structure(m).refitted(), info.refit != nullptr);
      EXPECT_EQ(&scene.structure(still), teapot);  // an unchanged mesh keeps its structure
      // The same instances, moved a little: the top level is refitted, not rebuilt.
      EXPECT_EQ(scene.top_level_update(), TopLevelUpdate::Refitted);

      Scene fresh(settings_of(info.kind));
      auto mesh = std::make_shared<TriangleMesh>(*rest);
      mesh->vertices = vertices;
      const uint32_t fm = fresh.add_mesh(mesh);
      const uint32_t fs = fresh.add_mesh(scene.mesh(still));
      for (int k = 0; k < kInstances; ++k) fresh.add_instance(fm, place(k, f));
      fresh.add_instance(fs, translation(0, 0, -6));
      fresh.commit();
      expect_same_hits(scene, fresh, rays);
    }
    scene.commit();  // nothing changed
    EXPECT_EQ(scene.top_level_update(), TopLevelUpdate::Kept);
  }
}

TEST(SceneRefit, TheTopLevelIsRebuiltWhenInstancesChangeOrItsCostDegrades) {
  const MeshPtr sphere = shipped("sphere.obj");
  Scene scene;
  const uint32_t m = scene.add_mesh(sphere);
  for (int k = 0; k < 16; ++k) scene.add_instance(m, translation(3.0f * float(k), 0, 0));
  scene.commit();
  EXPECT_EQ(scene.top_level_update(), TopLevelUpdate::Built);
  const double built = scene.top_level_sah_cost();
  scene.set_transform(0, translation(0, 0.5f, 0));
  scene.commit();
  EXPECT_EQ(scene.top_level_update(), TopLevelUpdate::Refitted);
  EXPECT_LE(scene.top_level_sah_cost(), Scene::kTopLevelRefitLimit * built);

  // The row's places dealt out at random: neighbours in the tree are now far apart, its refitted
  // boxes span much of the row, and the refit would cost more than kTopLevelRefitLimit times the
  // built tree: rebuilt.
  std::vector<int> order(16);
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), std::mt19937(5));
  for (int k = 0; k < 16; ++k) scene.set_transform(uint32_t(k), translation(3.0f * float(order[k]), 0, 0));
  scene.commit();
  EXPECT_EQ(scene.top_level_update(), TopLevelUpdate::Built);
  EXPECT_LE(scene.top_level_sah_cost(), Scene::kTopLevelRefitLimit * built);

  scene.add_instance(m, translation(0, 5, 0));
  scene.commit();
  EXPECT_EQ(scene.top_level_update(), TopLevelUpdate::Built);
  scene.clear_instances();
  scene.add_instance(m, glm::mat4(1.0f));
  scene.commit();
  EXPECT_EQ(scene.top_level_update(), TopLevelUpdate::Built);
}

TEST(SceneRefit, BadVerticesAreRefusedAndChangeNothing) {
  const MeshPtr sphere = shipped("sphere.obj");
  Scene scene;
  const uint32_t m = scene.add_mesh(sphere);
  scene.add_instance(m, glm::mat4(1.0f));
  scene.commit();
  std::vector<glm::vec3> nan = sphere->vertices;
  nan[0].z = std::nanf("");
  EXPECT_THROW(scene.refit_mesh(m, nan), std::invalid_argument);
  EXPECT_THROW(scene.refit_mesh(m, {{0, 0, 0}}), std::invalid_argument);
  EXPECT_THROW(scene.refit_mesh(7, sphere->vertices), std::invalid_argument);
  EXPECT_EQ(scene.mesh(m), sphere);
  Hit h;
  EXPECT_TRUE(scene.closest(ray_of({0, 0, 5}, {0, 0, -1}), h));  // committed, unchanged: no commit needed
}

TEST(SceneRefit, RefitsNotCommittedChainAndNewSettingsBuild) {
  const MeshPtr rest = shipped("sphere.obj");
  Scene scene;
  const uint32_t m = scene.add_mesh(rest);
  scene.add_instance(m, glm::mat4(1.0f));
  scene.commit();
  scene.refit_mesh(m, animated_vertices(*rest, 2, kFrames));
  scene.refit_mesh(m, animated_vertices(*rest, 3, kFrames));  // two refits, one commit
  scene.commit();
  EXPECT_TRUE(scene.structure(m).refitted());
  EXPECT_EQ(scene.structure(m).mesh().vertices, animated_vertices(*rest, 3, kFrames));
  scene.refit_mesh(m, animated_vertices(*rest, 4, kFrames));
  scene.set_settings(settings_of(StructureKind::Bvh));  // new settings: a build, not a refit
  scene.commit();
  EXPECT_FALSE(scene.structure(m).refitted());
  EXPECT_EQ(scene.structure(m).mesh().vertices, animated_vertices(*rest, 4, kFrames));
}

// One thread refits the mesh between two poses and commits while two others query: every batch is
// the brute-force answer of one pose, never a mix, and the snapshot a query holds is never changed.
TEST(SceneRefitThreads, QueriesDuringRefitCommitsSeeTheOldOrTheNewStateWhole) {
  const MeshPtr rest = shipped("sphere.obj");
  std::vector<glm::vec3> poses[2] = {rest->vertices, rest->vertices};
  for (glm::vec3& v : poses[1]) v = 0.5f * v + glm::vec3(0.2f, 0, 0);
  std::vector<Ray> rays;
  for (int copy = 0; copy < 200; ++copy)
    for (int i = 0; i < 8; ++i) rays.push_back(ray_of({-0.6f + 0.15f * float(i), 0.05f, 5.0f}, {0, 0, -1}));
  std::vector<Hit> expected[2];
  for (int p = 0; p < 2; ++p) {
    auto mesh = std::make_shared<TriangleMesh>(*rest);
    mesh->vertices = poses[p];
    const std::unique_ptr<Structure> brute = build_structure(mesh, settings_of(StructureKind::None));
    expected[p].resize(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) brute->closest(rays[i], expected[p][i]);
  }
  Scene scene;
  const uint32_t m = scene.add_mesh(rest);
  scene.add_instance(m, glm::mat4(1.0f));
  scene.commit();
  std::atomic<int> done{0}, failed{0};
  std::vector<std::thread> readers;
  for (int r = 0; r < 2; ++r)
    readers.emplace_back([&] {
      for (int round = 0; round < 20; ++round) {
        try {
          std::vector<Hit> hits(rays.size());
          intersect_closest(scene, rays, hits, nullptr);
          bool whole = false;
          for (const auto& e : expected) {
            bool same = true;
            for (size_t i = 0; i < rays.size() && same; ++i)
              same = hits[i].valid() == e[i].valid() &&
                     (!e[i].valid() || (hits[i].t == e[i].t && hits[i].triangle == e[i].triangle));
            whole |= same;
          }
          if (!whole) ++failed;
        } catch (...) {
          ++failed;
        }
      }
      ++done;
    });
  int commits = 0;
  for (int k = 0; done.load() < 2; ++k, ++commits) {
    scene.refit_mesh(m, poses[(k + 1) % 2]);
    scene.commit();
  }
  for (std::thread& t : readers) t.join();
  EXPECT_EQ(failed.load(), 0);
  EXPECT_GT(commits, 0);
}
