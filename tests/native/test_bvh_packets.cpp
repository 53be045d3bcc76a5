// The BVH's packet walk (bvh_packets.h): every batch answer is the single walk's, bit for bit (t, u, v,
// triangle, occluded), in both contracts, both widths, closest and any hit, on camera rays, shadow
// rays, random rays, rays at vertices and edges, rays with varied tmin and tmax, and batches of any
// length; and coherent batches really take the packet walk.
#include "support.h"

#include "../../native/src/bvh_packets.h"

#include <cstring>

using namespace raylab;
using namespace raylab::test;

namespace {

struct Config {
  Contract contract;
  TriangleTest test;
  int width;
};

std::string name_of(const Config& c) {
  return std::string(c.contract == Contract::Fast ? "fast" : "exact") + " " + triangle_test_name(c.test) + " width " +
         std::to_string(c.width);
}

// Both contracts at both widths this CPU runs, and the exact contract's Möller–Trumbore (the other
// kind of packet: its rays keep their own order).
std::vector<Config> configs() {
  std::vector<Config> out;
  for (const Contract contract : {Contract::Exact, Contract::Fast}) {
    out.push_back({contract, TriangleTest::Watertight, 4});
    if (contract == Contract::Exact ? cpu_has_avx2() : cpu_has_avx2_fma())
      out.push_back({contract, TriangleTest::Watertight, 8});
  }
  out.push_back({Contract::Exact, TriangleTest::MollerTrumbore, 4});
  if (cpu_has_avx2()) out.push_back({Contract::Exact, TriangleTest::MollerTrumbore, 8});
  return out;
}

Bvh bvh_of(const MeshPtr& mesh, const Config& c) {
  BuildSettings s;
  s.kind = StructureKind::Bvh;
  s.contract = c.contract;
  s.triangle_test = c.test;
  return Bvh(mesh, s, c.width);
}

// Rays from one eye through each vertex, each edge's midpoint and each edge's end, in the mesh's order
// (consecutive vertices lie close together: coherent groups of rays through shared edges and
// vertices, where the tie-break decides).
std::vector<Ray> vertex_rays(const TriangleMesh& mesh, size_t count) {
  const Bounds b = mesh.bounds();
  const glm::vec3 eye = b.center() + 2.0f * glm::vec3(0.3f, 0.4f, 1.0f) * b.extent();
  std::vector<Ray> rays;
  for (uint32_t t = 0; rays.size() < count && t < mesh.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k) {
      const glm::vec3 a = mesh.vertex(t, k), c = mesh.vertex(t, (k + 1) % 3);
      rays.push_back(ray_of(eye, a - eye));
      rays.push_back(ray_of(eye, 0.5f * (a + c) - eye));
    }
  rays.resize(std::min(rays.size(), count));
  return rays;
}

// Every ray's tmin and tmax varied: some hits lie before tmin or beyond tmax, some exactly at tmax.
std::vector<Ray> with_varied_interval(const Structure& s, std::vector<Ray> rays) {
  for (size_t i = 0; i < rays.size(); ++i) {
    Hit h;
    const bool hit = s.closest(rays[i], h);
    switch (i % 5) {
      case 0:
        if (hit) rays[i].tmax = h.t;  // the hit exactly at tmax
        break;
      case 1:
        if (hit) rays[i].tmin = h.t;  // that hit excluded: the next one
        break;
      case 2:
        if (hit) rays[i].tmax = std::nextafter(h.t, 0.0f);
        break;
      case 3:
        rays[i].tmin = 0.3f * float(i % 7);
        rays[i].tmax = rays[i].tmin + 1.0f + float(i % 3);
        break;
      default: break;
    }
  }
  return rays;
}

bool same_hit(const Hit& a, const Hit& b) { return std::memcmp(&a, &b, sizeof(Hit)) == 0; }

// Every batch query of `s` over `rays` against the single walk, ray by ray; returns the batch's counts.
// (The closest hit's counts where closest_batch traces packets, else any hit's.)
Bvh::PacketCounts expect_batch_is_single(const Bvh& s, const std::vector<Ray>& rays, const std::string& what) {
  std::vector<Hit> single(rays.size()), batch(rays.size(), Hit{1.0f, 2.0f, 3.0f, 4, 5}), api(rays.size());
  std::vector<uint8_t> single_any(rays.size()), batch_any(rays.size(), 7), api_any(rays.size(), 7);
  for (size_t i = 0; i < rays.size(); ++i) {
    Hit h;
    const bool hit = s.closest(rays[i], h);
    single[i] = h;
    EXPECT_EQ(hit, single[i].valid());
    single_any[i] = s.any(rays[i]);
  }
  Bvh::PacketCounts counts, any_counts;
  s.closest_batch(rays, batch, &counts);
  s.any_batch(rays, batch_any, &any_counts);
  EXPECT_EQ(counts.packet_rays + counts.single_rays, rays.size());
  EXPECT_EQ(any_counts.packet_rays + any_counts.single_rays, rays.size());
  EXPECT_EQ(any_counts.evicted, 0u);  // any hit never needs a ray's own order
  if (!s.closest_packets()) EXPECT_EQ(counts.packets, 0u) << what;
  size_t wrong = 0, wrong_any = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    if (!same_hit(single[i], batch[i]) && wrong++ < 5)
      ADD_FAILURE() << what << ": ray " << i << ": single t " << single[i].t << " triangle " << single[i].triangle
                    << ", batch t " << batch[i].t << " triangle " << batch[i].triangle;
    if (single_any[i] != batch_any[i] && wrong_any++ < 5)
      ADD_FAILURE() << what << ": ray " << i << ": single any " << int(single_any[i]) << ", batch any "
                    << int(batch_any[i]);
  }
  EXPECT_EQ(wrong, 0u) << what;
  EXPECT_EQ(wrong_any, 0u) << what;
  // The batch queries of the API (uncounted: the packets), on one thread and on all.
  for (const int threads : {1, 0}) {
    intersect_closest(s, rays, api, nullptr, threads);
    intersect_any(s, rays, api_any, nullptr, threads);
    size_t differ = 0;
    for (size_t i = 0; i < rays.size(); ++i) differ += !same_hit(single[i], api[i]) || single_any[i] != api_any[i];
    EXPECT_EQ(differ, 0u) << what << ": intersect_closest and intersect_any on " << threads << " threads";
  }
  return s.closest_packets() ? counts : any_counts;
}

// The packet walk itself on consecutive groups of `group` rays, whatever their coherence.
void expect_packets_are_single(const Bvh& s, const std::vector<Ray>& rays, int group, const std::string& what) {
  for (size_t i = 0; i < rays.size(); i += size_t(group)) {
    const size_t n = std::min(size_t(group), rays.size() - i);
    const std::span<const Ray> packet(&rays[i], n);
    Hit hits[Bvh::kPacketSize];
    uint8_t occluded[Bvh::kPacketSize];
    Bvh::PacketCounts counts;
    s.closest_packet(packet, std::span<Hit>(hits, n), &counts);
    s.any_packet(packet, std::span<uint8_t>(occluded, n));
    ASSERT_EQ(counts.packets, 1u);
    ASSERT_EQ(counts.packet_rays, n);
    for (size_t r = 0; r < n; ++r) {
      Hit h;
      s.closest(rays[i + r], h);
      ASSERT_TRUE(same_hit(h, hits[r])) << what << ": ray " << i + r << ": single t " << h.t << " triangle "
                                        << h.triangle << ", packet t " << hits[r].t << " triangle " << hits[r].triangle;
      ASSERT_EQ(uint8_t(s.any(rays[i + r])), occluded[r]) << what << ": ray " << i + r;
    }
  }
}

}  // namespace

TEST(BvhPackets, CameraRaysTakeThePacketWalkAndGetTheSingleHits) {
  for (const char* name : {"bunny.obj", "goathead.obj"}) {
    const MeshPtr mesh = shipped(name);
    for (const Config& c : configs()) {
      const Bvh s = bvh_of(mesh, c);
      for (const glm::vec3 side : {glm::vec3(0, 0, 1), glm::vec3(-1, 0, 0)}) {
        const std::vector<Ray> rays = camera_rays(*mesh, 96, 72, side);
        const std::string what = std::string(name) + " camera, " + name_of(c);
        const Bvh::PacketCounts counts = expect_batch_is_single(s, rays, what);
        // Neighbouring pixels: nearly every ray in a full packet.
        EXPECT_GE(counts.packet_rays, rays.size() * 99 / 100) << what;
        EXPECT_LE(counts.packets, rays.size() / 7) << what;
        EXPECT_EQ(counts.evicted, 0u);
        // Forced into packets, the rays that leave one for their own order are the exception.
        Bvh::PacketCounts forced;
        for (size_t i = 0; i < rays.size(); i += Bvh::kPacketSize) {
          Hit hits[Bvh::kPacketSize];
          const size_t n = std::min(size_t(Bvh::kPacketSize), rays.size() - i);
          s.closest_packet(std::span<const Ray>(&rays[i], n), std::span<Hit>(hits, n), &forced);
        }
        if (s.closest_packets()) EXPECT_EQ(forced.evicted, 0u) << what;
        else EXPECT_LE(forced.evicted, forced.packet_rays / 5) << what;
      }
    }
  }
}

TEST(BvhPackets, ShadowRaysToAPointLight) {
  for (const char* name : {"bunny.obj", "goathead.obj"}) {
    const MeshPtr mesh = shipped(name);
    for (const Config& c : configs()) {
      const Bvh s = bvh_of(mesh, c);
      const std::vector<Ray> rays = shadow_rays(*mesh, s, camera_rays(*mesh, 160, 120, glm::vec3(0, 0, 1)));
      ASSERT_GT(rays.size(), 1000u);
      const std::string what = std::string(name) + " shadow, " + name_of(c);
      const Bvh::PacketCounts counts = expect_batch_is_single(s, rays, what);
      EXPECT_GE(counts.packet_rays, rays.size() / 2) << what;
    }
  }
}

TEST(BvhPackets, RaysThroughVerticesAndEdges) {
  const MeshPtr mesh = shipped("bunny.obj");
  const std::vector<Ray> rays = vertex_rays(*mesh, 6000);
  for (const Config& c : configs()) {
    const Bvh s = bvh_of(mesh, c);
    expect_batch_is_single(s, rays, "vertices and edges, " + name_of(c));
    expect_packets_are_single(s, rays, Bvh::kPacketSize, "vertices and edges as packets, " + name_of(c));
  }
}

TEST(BvhPackets, RaysWithVariedIntervals) {
  const MeshPtr mesh = shipped("bunny.obj");
  for (const Config& c : configs()) {
    const Bvh s = bvh_of(mesh, c);
    const std::vector<Ray> camera = with_varied_interval(s, camera_rays(*mesh, 64, 48, glm::vec3(0, 0, 1)));
    expect_batch_is_single(s, camera, "camera, varied intervals, " + name_of(c));
    // Packets of rays whose intervals differ: each ray's own tmin and tmax in every test.
    expect_packets_are_single(s, camera, Bvh::kPacketSize, "camera packets, varied intervals, " + name_of(c));
    const std::vector<Ray> edges = with_varied_interval(s, vertex_rays(*mesh, 3000));
    expect_packets_are_single(s, edges, Bvh::kPacketSize, "vertex packets, varied intervals, " + name_of(c));
  }
}

TEST(BvhPackets, IncoherentRaysWalkAloneAndForcedPacketsStillAgree) {
  const MeshPtr mesh = shipped("bunny.obj");
  std::vector<Ray> rays = random_rays(*mesh, 4000, 11);
  for (size_t i = 0; i < rays.size(); i += 3) rays[i].tmax = 0.5f + float(i % 7);
  for (const Config& c : configs()) {
    const Bvh s = bvh_of(mesh, c);
    const Bvh::PacketCounts counts = expect_batch_is_single(s, rays, "random, " + name_of(c));
    EXPECT_LE(counts.packet_rays, rays.size() / 50) << name_of(c);  // random rays form no groups
    // Forced into packets of every size: random directions, half through a vertex.
    for (const int group : {2, 5, Bvh::kPacketSize})
      expect_packets_are_single(s, rays, group, "random as packets of " + std::to_string(group) + ", " + name_of(c));
  }
}

TEST(BvhPackets, MixedBatchesOfAnyLength) {
  const MeshPtr mesh = shipped("goathead.obj");
  const std::vector<Ray> camera = camera_rays(*mesh, 40, 30, glm::vec3(0, 0, 1));
  const std::vector<Ray> random = random_rays(*mesh, 600, 5);
  // Coherent runs broken by random rays at irregular places.
  std::vector<Ray> mixed;
  for (size_t i = 0, j = 0; i < camera.size(); ++i) {
    mixed.push_back(camera[i]);
    if (i % 13 == 5 || i % 29 == 0) mixed.push_back(random[j++ % random.size()]);
  }
  for (const Config& c : configs()) {
    const Bvh s = bvh_of(mesh, c);
    const Bvh::PacketCounts counts = expect_batch_is_single(s, mixed, "mixed, " + name_of(c));
    EXPECT_GT(counts.packets, 0u);
    EXPECT_GT(counts.single_rays, 0u);
    for (const size_t length : {size_t(1), size_t(2), size_t(3), size_t(7), size_t(9), size_t(257)}) {
      const std::vector<Ray> part(mixed.begin() + 100, mixed.begin() + 100 + std::ptrdiff_t(length));
      const Bvh::PacketCounts part_counts = expect_batch_is_single(s, part, "length " + std::to_string(length));
      if (length == 1) EXPECT_EQ(part_counts.packets, 0u);
    }
  }
}

TEST(BvhPackets, EdgeCases) {
  // An empty mesh, a single triangle, and rays that no packet takes (a NaN, a zero direction).
  for (const Config& c : configs()) {
    const MeshPtr empty = mesh_of({}, {});
    const Bvh none = bvh_of(empty, c);
    const std::vector<Ray> rays =
        camera_rays(*mesh_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}}), 8, 6, glm::vec3(0, 0, 1));
    expect_batch_is_single(none, rays, "empty mesh, " + name_of(c));
    const MeshPtr one = mesh_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}});
    const Bvh s = bvh_of(one, c);
    std::vector<Ray> odd = rays;
    odd[3].direction = glm::vec3(std::nanf(""), 0.0f, -1.0f);
    odd[4].direction = glm::vec3(0.0f);
    odd[5].origin.x = std::nanf("");
    odd[9].tmin = odd[9].tmax = 2.5f;
    expect_batch_is_single(s, odd, "one triangle, " + name_of(c));
    expect_packets_are_single(s, odd, Bvh::kPacketSize, "one triangle as packets, " + name_of(c));
  }
}

TEST(BvhPackets, CountedQueriesWalkOneRayAtATime) {
  // Counted, a batch's counters are the sum of the single walks' (the packets never count).
  const MeshPtr mesh = shipped("bunny.obj");
  BuildSettings settings;
  const auto s = build_structure(mesh, settings);
  const std::vector<Ray> rays = camera_rays(*mesh, 48, 36, glm::vec3(0, 0, 1));
  TraversalStats sum, batch;
  for (const Ray& ray : rays) {
    Hit h;
    s->closest(ray, h, sum);
  }
  std::vector<Hit> hits(rays.size());
  intersect_closest(*s, rays, hits, &batch, 1);
  EXPECT_EQ(batch.rays, sum.rays);
  EXPECT_EQ(batch.nodes_visited, sum.nodes_visited);
  EXPECT_EQ(batch.box_tests, sum.box_tests);
  EXPECT_EQ(batch.triangle_tests, sum.triangle_tests);
}

// The renderer's counted packets: every ray of a packet counts, into its own counters, what its own
// counted walk counts, and gets its hit, in every contract, width and triangle test, for camera rays,
// shadow rays and incoherent rays forced into packets (those leave for their own order, and still count
// as alone).
TEST(BvhPackets, CountedPacketsCountEachRayAsItsOwnWalk) {
  const MeshPtr mesh = shipped("goathead.obj");
  for (const Config& c : configs()) {
    const Bvh s = bvh_of(mesh, c);
    const std::vector<Ray> camera = camera_rays(*mesh, 64, 48, glm::vec3(0, 0, 1));
    const std::vector<Ray> sets[] = {camera, shadow_rays(*mesh, s, camera), random_rays(*mesh, 2000, 7)};
    for (const std::vector<Ray>& rays : sets) {
      const std::string what = name_of(c) + ", " + std::to_string(rays.size()) + " rays";
      std::vector<TraversalStats> closest_counts(rays.size()), any_counts(rays.size());
      for (size_t i = 0; i < rays.size(); i += Bvh::kPacketSize) {
        const size_t n = std::min(size_t(Bvh::kPacketSize), rays.size() - i);
        Hit hits[Bvh::kPacketSize];
        uint8_t occluded[Bvh::kPacketSize];
        s.closest_packet(std::span<const Ray>(&rays[i], n), std::span<Hit>(hits, n), nullptr,
                         std::span<TraversalStats>(&closest_counts[i], n));
        s.any_packet(std::span<const Ray>(&rays[i], n), std::span<uint8_t>(occluded, n), nullptr,
                     std::span<TraversalStats>(&any_counts[i], n));
        for (size_t r = 0; r < n; ++r) {
          TraversalStats own, own_any;
          Hit h;  // a default Hit on a miss, as the packet gives
          s.closest(rays[i + r], h, own);
          ASSERT_EQ(std::memcmp(&hits[r], &h, sizeof(Hit)), 0) << what << " ray " << i + r;
          ASSERT_EQ(occluded[r], uint8_t(s.any(rays[i + r], own_any))) << what << " ray " << i + r;
          for (const CounterInfo& k : kCounters) {
            ASSERT_EQ(closest_counts[i + r].*k.field, own.*k.field) << what << " " << k.name << " ray " << i + r;
            ASSERT_EQ(any_counts[i + r].*k.field, own_any.*k.field) << what << " any " << k.name << " ray " << i + r;
          }
        }
      }
      // And through the batch, which groups the coherent rays.
      std::vector<Hit> hits(rays.size());
      std::vector<TraversalStats> batch(rays.size());
      s.closest_batch_counted(rays, hits, batch);
      EXPECT_EQ(std::memcmp(batch.data(), closest_counts.data(), batch.size() * sizeof(TraversalStats)), 0) << what;
    }
  }
}

// The eight lanes made at once (fill_lanes8) hold the bits each ray's own walk makes (fill_lane from
// its BoxRay): hostile rays whose components are tiny, zero, -0, denormal or huge, far from the root.
TEST(BvhPackets, LanesMadeTogetherHoldEachRaysOwnConstants) {
  if (!cpu_has_avx2()) GTEST_SKIP() << "no AVX2: the 8-lane setup is not run here";
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  const float odd[] = {0.0f, -0.0f, 1e-45f, -1e-39f, 1e-30f, 3e-13f, 1e30f, -2.5f};
  const Bounds root{{-1.0f, -2.0f, -0.5f}, {3.0f, 1.0f, 0.25f}};
  for (int round = 0; round < 2000; ++round) {
    Ray rays[8];
    const int n = 1 + round % 8;
    for (Ray& r : rays) {
      for (int a = 0; a < 3; ++a) {
        r.origin[a] = unit(rng) * std::pow(10.0f, float(round % 7) - 2.0f);
        r.direction[a] = (rng() % 3 == 0) ? odd[rng() % 8] : unit(rng);
      }
      if (r.direction == glm::vec3(0.0f)) r.direction.z = 1.0f;
      r.tmin = std::abs(unit(rng));
      r.tmax = r.tmin + 10.0f;
    }
    for (const bool fast : {false, true}) {
      PacketLanes together, alone;
      glm::vec3 directions[8];
      if (fast) fill_lanes8<true>(rays, n, root, together, directions);
      else fill_lanes8<false>(rays, n, root, together, directions);
      for (int r = 0; r < 8; ++r) {
        const Ray& ray = rays[r < n ? r : 0];
        const glm::vec3 d = effective_direction(ray.direction);
        if (fast) fill_lane<true>(alone, r, BoxRay(ray, d, root));
        else fill_lane<false>(alone, r, BoxRay(ray, d, root));
        ASSERT_EQ(std::memcmp(&directions[r], &d, sizeof d), 0) << "round " << round << " lane " << r;
      }
      ASSERT_EQ(std::memcmp(&together, &alone, sizeof together), 0) << "round " << round << (fast ? " fast" : " exact");
    }
  }
}
