// Every structure's answers for fixed rays on shipped meshes, written as raw bytes: the same program
// built for another platform must write the same files, bit for bit (tools/same_hits.sh: Windows x64
// under wine, Linux arm64 under qemu, each against the host's build). The rays go to a file of their
// own, so that a difference in them (the C library's maths) is told apart from one in the answers.
//
//   raylab_hit_dump RAYS_FILE HITS_FILE
#include "hostile_rays.h"
#include "raylab/bvh_builder.h"
#include "raylab/contract.h"
#include "raylab/structure.h"
#include "raylab/triangle_packets.h"
#include "support.h"

#include <cstdio>
#include <cstring>
#include <vector>

using namespace raylab;
using namespace raylab::test;

namespace {

// The shipped meshes but the four largest (minutes each under emulation).
constexpr const char* kMeshes[] = {
    "sphere.obj", "plane_holes.obj", "spot_low_resolution.obj", "bunny.obj", "teapot.obj", "goathead.obj", "rod.obj"};
constexpr size_t kRays = 5000;                        // of each kind, random and hostile
constexpr int kCameraWidth = 64, kCameraHeight = 48;  // and a camera's, with its shadow rays
// Brute force and the AABB test every triangle per ray: they trace every kBruteForceStride-th ray
// (about 2,700 a mesh; every 4th, they took most of the run under qemu).
constexpr size_t kBruteForceStride = 8;

template <class T>
void put(std::FILE* f, const T& value) {
  std::fwrite(&value, sizeof value, 1, f);
}

void put_hit(std::FILE* f, const Hit& hit) { put(f, hit.t), put(f, hit.u), put(f, hit.v), put(f, hit.triangle); }

void put_stats(std::FILE* f, const TraversalStats& stats) {
  for (const CounterInfo& c : kCounters) put(f, stats.*c.field);
}

// One build, every query kind: the single-ray closest hit with its counters and any hit, then the
// batches (the BVH's packets for coherent runs: the camera and shadow rays), uncounted and counted
// per ray (the renderer's).
void dump(std::FILE* out, const Structure& s, const std::vector<Ray>& rays) {
  for (const Ray& ray : rays) {
    Hit hit;
    TraversalStats stats;
    const bool found = s.closest(ray, hit, stats);
    put(out, uint8_t(found));
    put_hit(out, hit);
    put_stats(out, stats);
    put(out, uint8_t(s.any(ray)));
  }
  std::vector<Hit> hits(rays.size());
  std::vector<uint8_t> occluded(rays.size());
  s.closest_batch(rays, hits);
  s.any_batch(rays, occluded);
  for (size_t i = 0; i < rays.size(); ++i) put_hit(out, hits[i]), put(out, occluded[i]);
  // Fresh answers: a counted batch that skipped a ray would otherwise show the uncounted one's.
  std::vector<Hit> counted_hits(rays.size());
  std::vector<uint8_t> counted_occluded(rays.size());
  std::vector<TraversalStats> closest_counts(rays.size()), any_counts(rays.size());
  s.closest_batch_counted(rays, counted_hits, closest_counts);
  s.any_batch_counted(rays, counted_occluded, any_counts);
  for (size_t i = 0; i < rays.size(); ++i) {
    put_hit(out, counted_hits[i]), put_stats(out, closest_counts[i]);
    put(out, counted_occluded[i]), put_stats(out, any_counts[i]);
  }
}

std::vector<Ray> every(const std::vector<Ray>& rays, size_t stride) {
  std::vector<Ray> out;
  for (size_t i = 0; i < rays.size(); i += stride) out.push_back(rays[i]);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: raylab_hit_dump RAYS_FILE HITS_FILE\n");
    return 2;
  }
  // Binary mode: Windows' text mode would write every byte 0x0a as 0d 0a.
  std::FILE* rays_out = std::fopen(argv[1], "wb");
  std::FILE* hits_out = std::fopen(argv[2], "wb");
  if (!rays_out || !hits_out) {
    std::perror("raylab_hit_dump");
    return 1;
  }
  size_t builds = 0, queries = 0;
  for (const char* name : kMeshes) {
    const MeshPtr mesh = shipped(name);
    std::vector<Ray> rays = random_rays(*mesh, kRays, 7);
    const std::vector<Ray> hostile = bench::hostile_rays(*mesh, kRays, 7).rays;
    const std::vector<Ray> camera = camera_rays(*mesh, kCameraWidth, kCameraHeight, glm::vec3(0, 0, 1));
    BuildSettings brute_force;
    brute_force.kind = StructureKind::None;
    const std::vector<Ray> shadow = shadow_rays(*mesh, *build_structure(mesh, brute_force), camera);
    for (const auto* set : {&hostile, &camera, &shadow}) rays.insert(rays.end(), set->begin(), set->end());
    for (const Ray& r : rays) put(rays_out, r);
    const std::vector<Ray> sparse = every(rays, kBruteForceStride);
    for (const StructureInfo& info : structure_kinds()) {
      // Every contract with every builder, where the kind has them.
      std::vector<BuildSettings> variants;
      for (const ContractInfo& c : kContracts)
        for (const BvhBuilderInfo& b : kBvhBuilders) {
          BuildSettings v;
          v.kind = info.kind;
          if ((c.contract != v.contract && !info.uses_contract) || (b.builder != v.builder && !info.uses_builder))
            continue;
          v.contract = c.contract, v.builder = b.builder;
          variants.push_back(v);
        }
      const bool brute = info.kind == StructureKind::None || info.kind == StructureKind::Aabb;
      for (const BuildSettings& v : variants) {
        dump(hits_out, *build_structure(mesh, v), brute ? sparse : rays);
        ++builds;
        queries += brute ? sparse.size() : rays.size();
      }
    }
  }
  // The counters differ between the BVH's widths: equal files also say both ran the AVX2 paths or neither.
  std::printf("raylab_hit_dump: %zu builds over %zu meshes, %zu rays, each traced 6 ways; AVX2 paths: %s\n", builds,
              std::size(kMeshes), queries, cpu_has_avx2() ? "yes" : "no");
  return std::fclose(rays_out) == 0 && std::fclose(hits_out) == 0 ? 0 : 1;
}
