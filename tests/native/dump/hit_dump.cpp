// Every structure's answers for fixed rays on shipped meshes, written as raw bytes: the same program
// built for Linux and for Windows (tools/cross_windows.sh --compare) must write the same files, bit
// for bit. The rays go to a file of their own, so that a difference in them (the C library's maths)
// is told apart from one in the answers.
//
//   raylab_hit_dump RAYS_FILE HITS_FILE
#include "hostile_rays.h"
#include "raylab/bvh_builder.h"
#include "raylab/structure.h"
#include "raylab/triangle_packets.h"
#include "support.h"

#include <cstdio>
#include <cstring>
#include <vector>

using namespace raylab;
using namespace raylab::test;

namespace {

constexpr const char* kMeshes[] = {"sphere.obj", "plane_holes.obj", "spot_low_resolution.obj", "bunny.obj",
                                   "teapot.obj"};
constexpr size_t kRays = 5000;  // of each kind, random and hostile

template <class T>
void put(std::FILE* f, const T& value) {
  std::fwrite(&value, sizeof value, 1, f);
}

// One build: the single-ray closest hit with its counters and the any-hit answer of every ray, then the
// batch closest hits (the BVH's packets for coherent chunks).
void dump(std::FILE* out, const Structure& s, const std::vector<Ray>& rays) {
  for (const Ray& ray : rays) {
    Hit hit;
    TraversalStats stats;
    const bool found = s.closest(ray, hit, stats);
    put(out, uint8_t(found));
    put(out, hit.t), put(out, hit.u), put(out, hit.v), put(out, hit.triangle);
    for (const CounterInfo& c : kCounters) put(out, stats.*c.field);
    put(out, uint8_t(s.any(ray)));
  }
  std::vector<Hit> hits(rays.size());
  intersect_closest(s, rays, hits, nullptr);
  for (const Hit& hit : hits) put(out, hit.t), put(out, hit.u), put(out, hit.v), put(out, hit.triangle);
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
  size_t builds = 0;
  for (const char* name : kMeshes) {
    const MeshPtr mesh = shipped(name);
    std::vector<Ray> rays = random_rays(*mesh, kRays, 7);
    const std::vector<Ray> hostile = bench::hostile_rays(*mesh, kRays, 7).rays;
    rays.insert(rays.end(), hostile.begin(), hostile.end());
    for (const Ray& r : rays) put(rays_out, r);
    for (const StructureInfo& info : structure_kinds()) {
      BuildSettings settings;
      settings.kind = info.kind;
      std::vector<BuildSettings> variants{settings};
      if (info.uses_contract) variants.push_back(settings), variants.back().contract = Contract::Fast;
      if (info.uses_builder)
        for (const BvhBuilderInfo& b : kBvhBuilders)
          if (b.builder != settings.builder) variants.push_back(settings), variants.back().builder = b.builder;
      for (const BuildSettings& v : variants) {
        dump(hits_out, *build_structure(mesh, v), rays);
        ++builds;
      }
    }
  }
  // The counters differ between the BVH's widths: equal files also say both ran the AVX2 paths or neither.
  std::printf("raylab_hit_dump: %zu builds over %zu meshes, %zu rays each; AVX2 paths: %s\n", builds,
              std::size(kMeshes), 2 * kRays, cpu_has_avx2() ? "yes" : "no");
  return std::fclose(rays_out) == 0 && std::fclose(hits_out) == 0 ? 0 : 1;
}
