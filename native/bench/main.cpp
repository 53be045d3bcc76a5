// raylab_bench: raylab's structures side by side with Embree 3 on one mesh, the same rays, one run.
// Writes <out>/<name>.json (timings, counts, hit agreement) and the .npy files the Python driver
// and Blender's BVHTree run use (mesh, a subset of the rays, Embree's hits on them).
// Usage: raylab_bench --mesh FILE.obj|icosphere:LEVELS --name NAME --out DIR [options]; see usage().
#include "embree_tracer.h"
#include "hit_comparison.h"
#include "json.h"
#include "npy.h"

#include "raylab/mesh_io.h"
#include "raylab/structure.h"

#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <numbers>
#include <random>
#include <sstream>
#include <thread>
#include <unordered_map>

namespace raylab::bench {
namespace {

struct Options {
  std::string mesh, name, out_dir = ".";
  int camera_width = 512, camera_height = 384;
  size_t random_rays = 100000;
  size_t export_rays = 20000;  // rays per set written for Blender's BVHTree
  int reps = 5, build_reps = 3;
  double rep_seconds = 0.15;  // each timed repetition traces about this long (at most all rays)
  std::vector<int> threads{1, 2};
  std::vector<std::string> structures{"none", "aabb", "octree", "grid", "bvh"};
  std::vector<std::string> embree_qualities{"medium", "high"};
  int max_depth = 6, leaf_size = 8;
};

[[noreturn]] void usage(const std::string& problem) {
  std::cerr << "raylab_bench: " << problem << "\n"
            << "usage: raylab_bench --mesh FILE.obj|icosphere:LEVELS --name NAME --out DIR\n"
               "  [--camera WxH] [--random-rays N] [--export-rays N] [--reps N] [--build-reps N]\n"
               "  [--rep-seconds S] [--threads 1,2] [--structures none,aabb,octree,grid,bvh]\n"
               "  [--embree medium,high] [--max-depth D] [--leaf-size L]\n";
  std::exit(2);
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> parts;
  std::stringstream in(s);
  for (std::string p; std::getline(in, p, ',');)
    if (!p.empty()) parts.push_back(p);
  return parts;
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (i + 1 >= argc) usage("missing value after " + arg);
    const std::string value = argv[++i];
    try {
      if (arg == "--mesh") o.mesh = value;
      else if (arg == "--name") o.name = value;
      else if (arg == "--out") o.out_dir = value;
      else if (arg == "--camera") {
        const size_t x = value.find('x');
        if (x == std::string::npos) usage("--camera expects WxH");
        o.camera_width = std::stoi(value.substr(0, x));
        o.camera_height = std::stoi(value.substr(x + 1));
      } else if (arg == "--random-rays") o.random_rays = std::stoul(value);
      else if (arg == "--export-rays") o.export_rays = std::stoul(value);
      else if (arg == "--reps") o.reps = std::stoi(value);
      else if (arg == "--build-reps") o.build_reps = std::stoi(value);
      else if (arg == "--rep-seconds") o.rep_seconds = std::stod(value);
      else if (arg == "--threads") {
        o.threads.clear();
        for (const std::string& t : split(value)) o.threads.push_back(std::stoi(t));
      } else if (arg == "--structures") o.structures = split(value);
      else if (arg == "--embree") o.embree_qualities = split(value);
      else if (arg == "--max-depth") o.max_depth = std::stoi(value);
      else if (arg == "--leaf-size") o.leaf_size = std::stoi(value);
      else usage("unknown option " + arg);
    } catch (const std::logic_error&) {
      usage("bad value '" + value + "' for " + arg);
    }
  }
  if (o.mesh.empty() || o.name.empty()) usage("--mesh and --name are required");
  if (o.camera_width < 1 || o.camera_height < 1 || o.reps < 1 || o.build_reps < 1 || o.threads.empty())
    usage("sizes, repetitions and thread counts must be positive");
  for (int t : o.threads)
    if (t < 1) usage("thread counts must be positive");
  return o;
}

// An icosahedron subdivided `levels` times (20 * 4^levels triangles) on the unit sphere: a closed
// mesh of any size, generated rather than shipped.
TriangleMesh icosphere(int levels) {
  TriangleMesh m;
  const float p = (1.0f + std::sqrt(5.0f)) / 2.0f;
  m.vertices = {{-1, p, 0}, {1, p, 0}, {-1, -p, 0}, {1, -p, 0}, {0, -1, p}, {0, 1, p},
                {0, -1, -p}, {0, 1, -p}, {p, 0, -1}, {p, 0, 1}, {-p, 0, -1}, {-p, 0, 1}};
  m.triangles = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                 {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
                 {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
  for (glm::vec3& v : m.vertices) v = glm::normalize(v);
  for (int level = 0; level < levels; ++level) {
    std::unordered_map<uint64_t, uint32_t> midpoints;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      const uint64_t key = (uint64_t(std::min(a, b)) << 32) | std::max(a, b);
      auto [it, inserted] = midpoints.try_emplace(key, uint32_t(m.vertices.size()));
      if (inserted) m.vertices.push_back(glm::normalize(m.vertices[a] + m.vertices[b]));
      return it->second;
    };
    std::vector<glm::uvec3> finer;
    finer.reserve(m.triangles.size() * 4);
    for (const glm::uvec3& t : m.triangles) {
      const uint32_t ab = midpoint(t.x, t.y), bc = midpoint(t.y, t.z), ca = midpoint(t.z, t.x);
      finer.insert(finer.end(), {{t.x, ab, ca}, {t.y, bc, ab}, {t.z, ca, bc}, {ab, bc, ca}});
    }
    m.triangles = std::move(finer);
  }
  return m;
}

TriangleMesh load(const std::string& spec) {
  const std::string prefix = "icosphere:";
  if (spec.rfind(prefix, 0) == 0) return icosphere(std::stoi(spec.substr(prefix.size())));
  return load_mesh(spec);
}

// A pinhole camera 40 degrees high looking at the mesh's bounding sphere from the front, a little
// from the right and above, so that the mesh fills most of the picture.
std::vector<Ray> camera_rays(const Bounds& b, int width, int height) {
  const glm::vec3 center = b.center();
  const float radius = 0.5f * glm::length(b.extent());
  const float half_fov = 20.0f * std::numbers::pi_v<float> / 180.0f;
  const glm::vec3 back = glm::normalize(glm::vec3(0.35f, 0.3f, 1.0f));
  const glm::vec3 eye = center + back * (radius / std::sin(half_fov));
  const glm::vec3 forward = -back;
  const glm::vec3 right = glm::normalize(glm::cross(forward, glm::vec3(0, 1, 0)));
  const glm::vec3 up = glm::cross(right, forward);
  const float tan_y = std::tan(half_fov), tan_x = tan_y * float(width) / float(height);
  std::vector<Ray> rays;
  rays.reserve(size_t(width) * height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float sx = (2.0f * (x + 0.5f) / width - 1.0f) * tan_x;
      const float sy = (1.0f - 2.0f * (y + 0.5f) / height) * tan_y;
      Ray r;
      r.origin = eye;
      r.direction = glm::normalize(forward + sx * right + sy * up);
      rays.push_back(r);
    }
  return rays;
}

// Origins uniform in the mesh's bounding box, directions uniform on the sphere: incoherent rays,
// many starting inside the mesh.
std::vector<Ray> random_rays(const Bounds& b, size_t n) {
  std::mt19937 rng(20240611);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::vector<Ray> rays(n);
  for (Ray& r : rays) {
    r.origin = b.lo + glm::vec3(unit(rng), unit(rng), unit(rng)) * b.extent();
    const float z = 2.0f * unit(rng) - 1.0f, phi = 2.0f * std::numbers::pi_v<float> * unit(rng);
    const float s = std::sqrt(std::max(0.0f, 1.0f - z * z));
    r.direction = {s * std::cos(phi), s * std::sin(phi), z};
  }
  return rays;
}

// n rays spread over the whole set (every k-th), so a subset sees the same mix as the set.
std::vector<Ray> strided(const std::vector<Ray>& rays, size_t n) {
  n = std::min(n, rays.size());
  std::vector<Ray> out(n);
  for (size_t i = 0; i < n; ++i) out[i] = rays[i * rays.size() / n];
  return out;
}

double seconds_of(const std::function<void()>& work) {
  const auto start = std::chrono::steady_clock::now();
  work();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// One tracer behind the two batch queries, so raylab and Embree are timed by the same code.
struct Tracer {
  std::function<void(std::span<const Ray>, std::span<Hit>)> closest;
  std::function<void(std::span<const Ray>, std::span<uint8_t>)> any;
};

// The number of rays one repetition traces: grown from a small probe until it takes measurable
// time, then scaled to opts.rep_seconds. Brute force on a million triangles gets a few hundred
// rays, a BVH all of them.
size_t rays_per_repetition(const Tracer& tracer, const std::vector<Ray>& rays, double rep_seconds) {
  size_t n = std::min<size_t>(16, rays.size());
  for (;;) {
    const std::vector<Ray> probe = strided(rays, n);
    std::vector<Hit> hits(probe.size());
    const double s = seconds_of([&] { tracer.closest(probe, hits); });
    if (n == rays.size()) return n;
    if (s > 0.02) return std::clamp<size_t>(size_t(double(n) / s * rep_seconds), n, rays.size());
    n = std::min(rays.size(), n * 8);
  }
}

struct RaySet {
  std::string name;
  std::vector<Ray> rays;
};

std::string stats_json(const TraversalStats& s) {
  const double n = std::max<double>(1.0, double(s.rays));
  return json::object({{"rays", json::num(double(s.rays))},
                       {"rays_ignored", json::num(double(s.rays_ignored))},
                       {"box_tests_per_ray", json::num(double(s.box_tests) / n)},
                       {"triangle_tests_per_ray", json::num(double(s.triangle_tests) / n)},
                       {"nodes_visited_per_ray", json::num(double(s.nodes_visited) / n)}});
}

constexpr double kCheckSeconds = 1.0;

// Times both queries on every ray set at every thread count; `extra(set, rays)` adds what only
// one kind of tracer reports (raylab's counts and agreement).
std::string trace_runs(const Tracer& tracer, const std::vector<RaySet>& sets, const Options& o,
                       const std::function<std::string(const RaySet&, const std::vector<Ray>&)>& extra) {
  std::vector<std::string> runs;
  std::vector<json::Member> per_set;
  for (const RaySet& set : sets) {
    const size_t n = rays_per_repetition(tracer, set.rays, o.rep_seconds);
    const std::vector<Ray> subset = strided(set.rays, n);
    std::vector<Hit> hits(n);
    std::vector<uint8_t> occluded(n);
    for (int threads : o.threads) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
      for (const char* query : {"closest", "any"}) {
        const bool closest = query[0] == 'c';
        auto work = [&] { closest ? tracer.closest(subset, hits) : tracer.any(subset, occluded); };
        work();  // warm-up: caches and lazily started worker threads
        std::vector<double> seconds;
        for (int r = 0; r < o.reps; ++r) seconds.push_back(seconds_of(work));
        const double med = median(seconds);
        runs.push_back(json::object({{"rays", json::str(set.name)},
                                     {"query", json::str(query)},
                                     {"threads", json::num(threads)},
                                     {"ray_count", json::num(double(n))},
                                     {"seconds_median", json::num(med)},
                                     {"seconds", json::numbers(seconds)},
                                     {"rays_per_second", json::num(double(n) / med)}}));
      }
    }
    // Counts and agreement on every ray of the set when the tracer gets through them in about
    // kCheckSeconds; brute force on a million triangles checks the rays it can.
    const size_t checked = n == set.rays.size()
                               ? n
                               : std::min(set.rays.size(), std::max(n, size_t(double(n) / o.rep_seconds * kCheckSeconds)));
    per_set.push_back({set.name, extra(set, strided(set.rays, checked))});
  }
  return json::object({{"runs", json::array(runs)}, {"per_ray_set", json::object(per_set)}});
}

std::string build_times_json(const Options& o, const std::function<double()>& build) {
  std::vector<json::Member> m;
  for (int threads : o.threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
    std::vector<double> seconds;
    for (int r = 0; r < o.build_reps; ++r) seconds.push_back(build());
    m.push_back({std::to_string(threads), json::object({{"seconds_median", json::num(median(seconds))},
                                                         {"seconds", json::numbers(seconds)}})});
  }
  return json::object(m);
}

void export_for_python(const Options& o, const TriangleMesh& mesh, const std::vector<RaySet>& sets,
                       EmbreeTracer& embree) {
  const std::string base = o.out_dir + "/" + o.name;
  write_npy(base + ".vertices.npy", "<f4", {mesh.vertices.size(), 3}, mesh.vertices.data(),
            mesh.vertices.size() * sizeof(glm::vec3));
  write_npy(base + ".triangles.npy", "<u4", {mesh.triangles.size(), 3}, mesh.triangles.data(),
            mesh.triangles.size() * sizeof(glm::uvec3));
  for (const RaySet& set : sets) {
    const std::vector<Ray> subset = strided(set.rays, o.export_rays);
    static_assert(sizeof(Ray) == 8 * sizeof(float), "Ray is origin, tmin, direction, tmax");
    write_npy(base + ".rays_" + set.name + ".npy", "<f4", {subset.size(), 8}, subset.data(),
              subset.size() * sizeof(Ray));
    std::vector<Hit> hits(subset.size());
    embree.closest(subset, hits);
    std::vector<double> rows;  // t, triangle (-1 on miss), u, v
    for (const Hit& h : hits)
      rows.insert(rows.end(), {h.valid() ? double(h.t) : INFINITY, h.valid() ? double(h.triangle) : -1.0,
                               double(h.u), double(h.v)});
    write_npy(base + ".embree_" + set.name + ".npy", "<f8", {hits.size(), 4}, rows.data(),
              rows.size() * sizeof(double));
  }
}

RTCBuildQuality quality_from_name(const std::string& name) {
  if (name == "low") return RTC_BUILD_QUALITY_LOW;
  if (name == "medium") return RTC_BUILD_QUALITY_MEDIUM;
  if (name == "high") return RTC_BUILD_QUALITY_HIGH;
  usage("unknown Embree build quality " + name);
}

int run(const Options& o) {
  std::filesystem::create_directories(o.out_dir);
  const auto mesh = std::make_shared<TriangleMesh>(load(o.mesh));
  mesh->validate();
  const Bounds bounds = mesh->bounds();
  const std::vector<RaySet> sets{{"camera", camera_rays(bounds, o.camera_width, o.camera_height)},
                                 {"random", random_rays(bounds, o.random_rays)}};
  std::cerr << o.name << ": " << mesh->triangle_count() << " triangles\n";

  // The oracle: Embree at medium quality, the default of rtcNewScene.
  EmbreeTracer oracle(*mesh);
  oracle.build(RTC_BUILD_QUALITY_MEDIUM);
  const Tracer oracle_tracer{[&](auto r, auto h) { oracle.closest(r, h); }, [&](auto r, auto o) { oracle.any(r, o); }};

  std::vector<std::string> tracers;
  for (const std::string& name : o.structures) {
    std::cerr << "  " << name << "\n";
    BuildSettings settings;
    settings.kind = structure_kind_from_name(name);
    settings.max_depth = o.max_depth;
    settings.leaf_size = o.leaf_size;
    std::unique_ptr<Structure> structure;
    std::string build_times;
    try {
      build_times = build_times_json(o, [&] {
        structure = build_structure(mesh, settings);
        return structure->build_seconds();
      });
    } catch (const std::exception& e) {  // a structure not written yet, or over the memory budget
      tracers.push_back(json::object({{"name", json::str(name)}, {"kind", json::str("raylab")},
                                      {"error", json::str(e.what())}}));
      continue;
    }
    const Structure& s = *structure;
    const Tracer tracer{[&](auto r, auto h) { intersect_closest(s, r, h, nullptr); },
                        [&](auto r, auto oc) { intersect_any(s, r, oc, nullptr); }};
    auto counts_and_agreement = [&](const RaySet&, const std::vector<Ray>& rays) {
      std::vector<Hit> ours(rays.size()), theirs(rays.size());
      std::vector<uint8_t> our_any(rays.size()), their_any(rays.size());
      TraversalStats closest_stats, any_stats;
      intersect_closest(s, rays, ours, &closest_stats);
      intersect_any(s, rays, our_any, &any_stats);
      oracle.closest(rays, theirs);
      oracle.any(rays, their_any);
      return json::object(
          {{"counts", json::object({{"closest", stats_json(closest_stats)}, {"any", stats_json(any_stats)}})},
           {"agreement_with_embree",
            json::object({{"closest", comparison_json(*mesh, compare_closest(*mesh, rays, ours, theirs))},
                          {"any", comparison_json(*mesh, compare_any(*mesh, rays, our_any, their_any, ours, theirs))}})}});
    };
    const std::string traced = trace_runs(tracer, sets, o, counts_and_agreement);
    tracers.push_back(json::object({{"name", json::str(name)},
                                    {"kind", json::str("raylab")},
                                    {"error", "null"},
                                    {"build", build_times},
                                    {"memory_bytes", json::num(double(s.memory_bytes()))},
                                    {"tracing", traced}}));
  }

  for (const std::string& quality : o.embree_qualities) {
    std::cerr << "  embree " << quality << "\n";
    EmbreeTracer embree(*mesh);
    const RTCBuildQuality q = quality_from_name(quality);
    const std::string build_times = build_times_json(o, [&] { return embree.build(q); });
    const Tracer tracer{[&](auto r, auto h) { embree.closest(r, h); }, [&](auto r, auto oc) { embree.any(r, oc); }};
    const std::string traced = trace_runs(tracer, sets, o, [](const RaySet&, const std::vector<Ray>&) {
      return std::string("{}");
    });
    tracers.push_back(json::object({{"name", json::str("embree_" + quality)},
                                    {"kind", json::str("embree")},
                                    {"error", "null"},
                                    {"build", build_times},
                                    {"memory_bytes", json::num(double(embree.memory_bytes()))},
                                    {"tracing", traced}}));
  }

  export_for_python(o, *mesh, sets, oracle);

  std::vector<json::Member> set_info;
  for (const RaySet& set : sets) set_info.push_back({set.name, json::object({{"count", json::num(double(set.rays.size()))}})});
  const std::string result = json::object({
      {"mesh", json::str(o.name)},
      {"source", json::str(o.mesh)},
      {"triangles", json::num(double(mesh->triangle_count()))},
      {"vertices", json::num(double(mesh->vertices.size()))},
      {"camera", json::object({{"width", json::num(o.camera_width)}, {"height", json::num(o.camera_height)}})},
      {"ray_sets", json::object(set_info)},
      {"repetitions", json::num(o.reps)},
      {"build_repetitions", json::num(o.build_reps)},
      {"hardware_threads", json::num(std::thread::hardware_concurrency())},
      {"embree_version", json::str(RTC_VERSION_STRING)},
      {"octree", json::object({{"max_depth", json::num(o.max_depth)}, {"leaf_size", json::num(o.leaf_size)}})},
      {"tracers", json::array(tracers)},
  });
  std::ofstream(o.out_dir + "/" + o.name + ".json") << result << "\n";
  return 0;
}

}  // namespace
}  // namespace raylab::bench

int main(int argc, char** argv) {
  try {
    return raylab::bench::run(raylab::bench::parse(argc, argv));
  } catch (const std::exception& e) {
    std::cerr << "raylab_bench: " << e.what() << "\n";
    return 1;
  }
}
