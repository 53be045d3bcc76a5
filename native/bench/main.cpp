// raylab_bench: raylab's structures side by side with Embree 3 on one mesh, the same rays, one run.
// Writes <out>/<name>.json (timings, counts, hit agreement) and the .npy files the Python driver
// and Blender's BVHTree run use (mesh, a subset of the rays, Embree's hits on them).
// Usage: raylab_bench --mesh FILE.obj|icosphere:LEVELS|subdivided:LEVELS:FILE.obj --name NAME --out DIR [options]; see
// --help.
#include "arbitration.h"
#include "embree_tracer.h"
#include "hit_comparison.h"
#include "hostile_rays.h"
#include "npy.h"

#include "raylab/mesh_io.h"
#include "raylab/structure.h"

#include <tbb/global_control.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <bit>
#include <charconv>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <random>
#include <thread>
#include <unordered_map>

#include <sched.h>
#include <time.h>

namespace raylab::bench {
namespace {

// Every structure the core has, in its table's order.
std::vector<std::string> every_structure() {
  std::vector<std::string> names;
  for (const raylab::StructureInfo& kind : raylab::structure_kinds()) names.push_back(kind.name);
  return names;
}

// Every contract, exact first.
std::vector<std::string> every_contract() {
  std::vector<std::string> names;
  for (const raylab::ContractInfo& info : raylab::kContracts) names.push_back(info.name);
  return names;
}

struct Options {
  std::string mesh, name, out_dir = ".";
  int camera_width = 512, camera_height = 384;
  size_t random_rays = 100000;
  size_t export_rays = 20000;  // rays per set written for Blender's BVHTree
  size_t hostile_rays = 20000;
  int reps = 5, build_reps = 3;
  double rep_seconds = 0.15;  // each timed repetition traces about this long (at most all rays)
  std::vector<int> threads{1, 2};
  std::vector<std::string> structures = every_structure();
  std::vector<std::string> contracts = every_contract();
  std::vector<std::string> builders{raylab::bvh_builder_name(raylab::BuildSettings{}.builder)};  // the default
  std::vector<std::string> embree_qualities{"medium", "high"};
  int max_depth = raylab::BuildSettings{}.max_depth, leaf_size = raylab::BuildSettings{}.leaf_size;
};

// --cpu-time: the tracing timed by the process's CPU time instead of the wall clock. On a machine
// shared with other work, a one-thread run's CPU time leaves out the time other processes held the
// core (their effect on the caches remains); with more threads it adds the threads' times.
bool g_cpu_time = false;

// Embree's build qualities by the names --embree takes.
const std::map<std::string, RTCBuildQuality> kEmbreeQualities{
    {"low", RTC_BUILD_QUALITY_LOW}, {"medium", RTC_BUILD_QUALITY_MEDIUM}, {"high", RTC_BUILD_QUALITY_HIGH}};

// "WxH" with both positive, or nothing.
std::optional<std::pair<int, int>> parse_size(const std::string& text) {
  const size_t x = text.find('x');
  if (x == std::string::npos) return std::nullopt;
  int w = 0, h = 0;
  const char* end = text.data() + text.size();
  const auto [w_end, w_error] = std::from_chars(text.data(), text.data() + x, w);
  const auto [h_end, h_error] = std::from_chars(text.data() + x + 1, end, h);
  if (w_error != std::errc() || h_error != std::errc() || w_end != text.data() + x || h_end != end || w < 1 || h < 1)
    return std::nullopt;
  return std::pair{w, h};
}

// A command-line check by the core's own parser: `parse` throws with the core's message for a name it
// does not know.
template <class Parse>
CLI::Validator core_name(Parse parse, const char* label) {
  return CLI::Validator(
      [parse](std::string& name) {
        try {
          parse(name);
          return std::string();
        } catch (const std::exception& e) {
          return std::string(e.what());
        }
      },
      label);
}

void add_options(CLI::App& app, Options& o) {
  app.option_defaults()->always_capture_default();
  const CLI::Range positive(1, std::numeric_limits<int>::max());
  app.add_option("--mesh", o.mesh,
                 "an OBJ file, icosphere:LEVELS (20 * 4^LEVELS triangles) or subdivided:LEVELS:FILE (an OBJ file's "
                 "triangles split in 4^LEVELS)")
      ->required();
  app.add_option("--name", o.name, "the name of the output files")->required();
  app.add_option("--out", o.out_dir, "the output folder");
  app.add_option_function<std::string>(
         "--camera",
         [&o](const std::string& size) {
           const auto wh = parse_size(size);
           if (!wh) throw CLI::ValidationError("--camera", "expects WxH with positive W and H, got " + size);
           std::tie(o.camera_width, o.camera_height) = *wh;
         },
         "the camera's picture size, WxH")
      ->default_str(std::to_string(o.camera_width) + "x" + std::to_string(o.camera_height));
  app.add_option("--random-rays", o.random_rays, "random rays in the mesh's box");
  app.add_option("--hostile-rays", o.hostile_rays,
                 "rays at vertices and edges, grazing, from a hair above a surface, tmax a hair past or short");
  app.add_option("--export-rays", o.export_rays, "rays per set written for Blender's BVHTree");
  app.add_option("--reps", o.reps, "timed repetitions of each query")->check(positive);
  app.add_option("--build-reps", o.build_reps, "timed builds of each structure")->check(positive);
  app.add_option("--rep-seconds", o.rep_seconds, "about how long one repetition traces");
  app.add_option("--threads", o.threads, "thread counts, comma-separated")->delimiter(',')->check(positive);
  // The core knows the structures' and contracts' names: a name it rejects is rejected here, before any work.
  app.add_option("--structures", o.structures, "raylab's structures, comma-separated")
      ->delimiter(',')
      ->check(core_name([](const std::string& name) { structure_kind_from_name(name); }, "STRUCTURE"));
  app.add_option("--contracts", o.contracts,
                 "the contracts of the structures that take one (exact, fast), comma-separated; a fast one is "
                 "named <structure>_fast")
      ->delimiter(',')
      ->check(core_name([](const std::string& name) { contract_from_name(name); }, "CONTRACT"));
  app.add_option("--builders", o.builders,
                 "the BVH's builders (sah, median, spatial_median, lbvh), comma-separated; another than the "
                 "default is named <structure>_<builder>")
      ->delimiter(',')
      ->check(core_name([](const std::string& name) { bvh_builder_from_name(name); }, "BUILDER"));
  app.add_option("--embree", o.embree_qualities, "Embree's build qualities, comma-separated")
      ->delimiter(',')
      ->check(CLI::IsMember(kEmbreeQualities));
  app.add_option("--max-depth", o.max_depth,
                 "octree: the deepest level, or " + std::to_string(raylab::BuildSettings::kAutoDepth) + " for auto");
  app.add_option("--leaf-size", o.leaf_size, "octree and bvh: triangles per leaf");
  app.add_flag("--cpu-time", g_cpu_time,
               "time the tracing by the process's CPU time, not the wall clock (one-thread runs on a shared machine)");
}

// Every triangle split into four at its edges' midpoints, `levels` times (4^levels times the
// triangles); `place` puts each new midpoint vertex (the icosphere projects it onto the sphere).
template <class Place>
void subdivide(TriangleMesh& m, int levels, Place place) {
  for (int level = 0; level < levels; ++level) {
    std::unordered_map<uint64_t, uint32_t> midpoints;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      const uint64_t key = (uint64_t(std::min(a, b)) << 32) | std::max(a, b);
      auto [it, inserted] = midpoints.try_emplace(key, uint32_t(m.vertices.size()));
      if (inserted) m.vertices.push_back(place(0.5f * (m.vertices[a] + m.vertices[b])));
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
}

// An icosahedron subdivided `levels` times (20 * 4^levels triangles) on the unit sphere: a closed
// mesh of any size, generated rather than shipped.
TriangleMesh icosphere(int levels) {
  TriangleMesh m;
  const float p = (1.0f + std::sqrt(5.0f)) / 2.0f;
  m.vertices = {{-1, p, 0},  {1, p, 0},  {-1, -p, 0}, {1, -p, 0}, {0, -1, p},  {0, 1, p},
                {0, -1, -p}, {0, 1, -p}, {p, 0, -1},  {p, 0, 1},  {-p, 0, -1}, {-p, 0, 1}};
  m.triangles = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                 {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                 {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (glm::vec3& v : m.vertices) v = glm::normalize(v);
  subdivide(m, levels, [](const glm::vec3& v) { return glm::normalize(v); });
  return m;
}

// icosphere:LEVELS; subdivided:LEVELS:FILE, an OBJ file's triangles split 4^LEVELS ways in their
// planes (the same surface with more, smaller triangles: the dragon at 1.6M triangles is
// subdivided:2:dragon.obj); or an OBJ file.
TriangleMesh load(const std::string& spec) {
  const std::string sphere = "icosphere:", subdivided = "subdivided:";
  if (spec.rfind(sphere, 0) == 0) return icosphere(std::stoi(spec.substr(sphere.size())));
  if (spec.rfind(subdivided, 0) == 0) {
    const size_t colon = spec.find(':', subdivided.size());
    if (colon == std::string::npos) throw std::invalid_argument("expected subdivided:LEVELS:FILE, got " + spec);
    TriangleMesh m = load_mesh(spec.substr(colon + 1));
    subdivide(m, std::stoi(spec.substr(subdivided.size(), colon - subdivided.size())),
              [](const glm::vec3& v) { return v; });
    return m;
  }
  return load_mesh(spec);
}

// How far the camera of the "camera_sky" set stands, in the framing camera's distance: the mesh a
// third smaller across the picture, sky around it, about 1 / 1.5^2 of the framing camera's hits (issue
// 41's two framings; on the benchmark meshes 5-8 % of the rays hit against 11-18 %).
constexpr float kSkyDistance = 1.5f;

// A pinhole camera 40 degrees high looking at the mesh's bounding sphere from the front, a little
// from the right and above; at distance 1 the sphere fills the picture's height, so that the mesh
// fills most of it; farther (kSkyDistance) the mesh is smaller, with sky around it.
std::vector<Ray> camera_rays(const Bounds& b, int width, int height, float distance = 1.0f) {
  const glm::vec3 center = b.center();
  const float radius = 0.5f * glm::length(b.extent());
  const float half_fov = 20.0f * std::numbers::pi_v<float> / 180.0f;
  const glm::vec3 back = glm::normalize(glm::vec3(0.35f, 0.3f, 1.0f));
  const glm::vec3 eye = center + back * (distance * radius / std::sin(half_fov));
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

// From every camera ray's hit (Embree's, the oracle's) towards a point light above and to the left of the
// camera, in pixel order: the renderer's shadow rays, coherent as a tile's are. tmin keeps a ray off the
// surface it starts on (1e-4 of the mesh's size); tmax = 1 ends it at the light.
std::vector<Ray> shadow_rays(const EmbreeTracer& oracle, const Bounds& b, const std::vector<Ray>& camera) {
  std::vector<Hit> hits(camera.size());
  oracle.closest(camera, hits);
  const float size = glm::length(b.extent());
  const glm::vec3 light = b.center() + size * glm::vec3(-0.6f, 1.2f, 1.0f);
  std::vector<Ray> rays;
  for (size_t i = 0; i < camera.size(); ++i) {
    if (!hits[i].valid()) continue;
    Ray r;
    r.origin = camera[i].at(hits[i].t);
    r.direction = light - r.origin;
    r.tmin = 1e-4f * size / glm::length(r.direction);
    r.tmax = 1.0f;
    rays.push_back(r);
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

// The calling thread pinned to the first core it may run on while this lives (a one-thread run: with
// TBB limited to one thread, the calling thread does all the work), its affinity restored after; the
// Python driver's API runs are pinned the same way, so both sides run on one core.
class PinnedToOneCore {
 public:
  explicit PinnedToOneCore(bool pin) {
    if (!pin || sched_getaffinity(0, sizeof(saved_), &saved_) != 0) return;
    for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu)
      if (CPU_ISSET(cpu, &saved_)) {
        cpu_set_t one;
        CPU_ZERO(&one);
        CPU_SET(cpu, &one);
        pinned_ = sched_setaffinity(0, sizeof(one), &one) == 0;
        break;
      }
  }
  ~PinnedToOneCore() {
    if (pinned_) sched_setaffinity(0, sizeof(saved_), &saved_);
  }
  PinnedToOneCore(const PinnedToOneCore&) = delete;
  PinnedToOneCore& operator=(const PinnedToOneCore&) = delete;

 private:
  cpu_set_t saved_{};
  bool pinned_ = false;
};

double process_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

double seconds_of(const std::function<void()>& work) {
  if (g_cpu_time) {
    const double start = process_cpu_seconds();
    work();
    return process_cpu_seconds() - start;
  }
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

// Key order is kept as written: the Python driver and the report list sets and kinds in that order.
using Json = nlohmann::ordered_json;

Json stats_json(const TraversalStats& s) {
  const double n = std::max<double>(1.0, double(s.rays));
  return {{"rays", s.rays},
          {"rays_ignored", s.rays_ignored},
          {"box_tests_per_ray", double(s.box_tests) / n},
          {"triangle_tests_per_ray", double(s.triangle_tests) / n},
          {"nodes_visited_per_ray", double(s.nodes_visited) / n}};
}

constexpr double kCheckSeconds = 1.0;

// One tracer of the run (a raylab structure or an Embree build) and what it reports.
struct Contender {
  std::string name;
  Tracer tracer;
  // What only one kind of tracer reports (raylab's counts and agreement) on `rays` of a set.
  std::function<Json(const RaySet&, const std::vector<Ray>&)> extra;
  Json runs = Json::array(), per_set = Json::object();
};

// Times both queries of every contender on every ray set at every thread count. The repetitions
// are interleaved (repetition r of every contender, then r + 1), so that a machine shared with other
// processes slows them alike and the medians' ratios stay fair.
void trace_runs(std::vector<Contender>& contenders, const std::vector<RaySet>& sets, const Options& o) {
  for (const RaySet& set : sets) {
    std::vector<std::vector<Ray>> subsets;
    for (const Contender& c : contenders)
      subsets.push_back(strided(set.rays, rays_per_repetition(c.tracer, set.rays, o.rep_seconds)));
    for (int threads : o.threads) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
      const PinnedToOneCore pin(threads == 1);
      for (const char* query : {"closest", "any"}) {
        const bool closest = query[0] == 'c';
        std::vector<std::function<void()>> work;
        std::vector<std::vector<Hit>> hits(contenders.size());
        std::vector<std::vector<uint8_t>> occluded(contenders.size());
        for (size_t i = 0; i < contenders.size(); ++i) {
          hits[i].resize(subsets[i].size());
          occluded[i].resize(subsets[i].size());
          work.push_back([&, i] {
            closest ? contenders[i].tracer.closest(subsets[i], hits[i])
                    : contenders[i].tracer.any(subsets[i], occluded[i]);
          });
          work[i]();  // warm-up: caches and lazily started worker threads
        }
        std::vector<std::vector<double>> seconds(contenders.size());
        for (int r = 0; r < o.reps; ++r)
          for (size_t i = 0; i < contenders.size(); ++i) seconds[i].push_back(seconds_of(work[i]));
        for (size_t i = 0; i < contenders.size(); ++i) {
          const double med = median(seconds[i]);
          const size_t n = subsets[i].size();
          contenders[i].runs.push_back({{"rays", set.name},
                                        {"query", query},
                                        {"threads", threads},
                                        {"ray_count", n},
                                        {"seconds_median", med},
                                        {"seconds", seconds[i]},
                                        {"rays_per_second", double(n) / med}});
        }
      }
    }
    // Counts and agreement on every ray of the set when the tracer gets through them in about
    // kCheckSeconds; brute force on a million triangles checks the rays it can.
    for (size_t i = 0; i < contenders.size(); ++i) {
      const size_t n = subsets[i].size();
      const size_t checked =
          n == set.rays.size()
              ? n
              : std::min(set.rays.size(), std::max(n, size_t(double(n) / o.rep_seconds * kCheckSeconds)));
      contenders[i].per_set[set.name] = contenders[i].extra(set, strided(set.rays, checked));
    }
  }
}

constexpr uint64_t kWrongExamples = 3;  // wrong answers kept per verdict, tracer and ray set

Json verdicts_json(const std::array<uint64_t, kVerdicts>& counts) {
  Json j = Json::object();
  uint64_t rays = 0, wrong = 0;
  for (int v = 0; v < kVerdicts; ++v) {
    j[verdict_name(Verdict(v))] = counts[v];
    rays += counts[v];
    if (Verdict(v) != Verdict::Right) wrong += counts[v];
  }
  j["rays"] = rays;
  j["wrong"] = wrong;
  j["wrong_per_million"] = rays ? 1e6 * double(wrong) / double(rays) : 0.0;
  return j;
}

// The price of exactness: the closest hits of every judged contender on every ray of every set, each
// judged by the float64 referee against the triangles any of them reported (and, for the hostile rays,
// the triangle the ray was aimed at). Returns per contender {set: verdict counts}, hostile ones by kind.
std::vector<Json> judge_runs(const Referee& referee, std::vector<Contender>& contenders,
                             const std::vector<size_t>& judged, const std::vector<RaySet>& sets,
                             const HostileRays& hostile) {
  std::vector<Json> out(contenders.size(), Json::object());
  for (const RaySet& set : sets) {
    const bool aimed = set.name == "hostile";
    std::vector<std::vector<Hit>> hits(contenders.size());
    for (size_t i : judged) {
      hits[i].resize(set.rays.size());
      contenders[i].tracer.closest(set.rays, hits[i]);
    }
    for (size_t i : judged) {
      std::array<uint64_t, kVerdicts> counts{};
      std::vector<std::array<uint64_t, kVerdicts>> by_kind(kHostileKinds);
      std::vector<uint32_t> candidates;
      Json examples = Json::array();
      for (size_t r = 0; r < set.rays.size(); ++r) {
        candidates.clear();
        for (size_t j : judged) candidates.push_back(hits[j][r].triangle);
        if (aimed) candidates.push_back(hostile.target[r]);
        const Referee::Judgement judgement = referee.judge(set.rays[r], hits[i][r], candidates);
        const int v = int(judgement.verdict);
        ++counts[v];
        if (aimed) ++by_kind[int(hostile.kind[r])][v];
        if (judgement.verdict != Verdict::Right && counts[v] <= kWrongExamples) {
          const Ray& ray = set.rays[r];
          const Hit& h = hits[i][r];
          examples.push_back(
              {{"verdict", verdict_name(judgement.verdict)},
               {"kind", aimed ? hostile_kind_name(hostile.kind[r]) : set.name.c_str()},
               {"origin", {ray.origin.x, ray.origin.y, ray.origin.z}},
               {"direction", {ray.direction.x, ray.direction.y, ray.direction.z}},
               {"tmin", ray.tmin},
               {"tmax", ray.tmax},
               {"triangle", h.valid() ? Json(h.triangle) : Json(nullptr)},
               {"t", h.valid() ? Json(h.t) : Json(nullptr)},
               {"passed_by", judgement.witness == kInvalidIndex ? Json(nullptr) : Json(judgement.witness)}});
        }
      }
      Json j = verdicts_json(counts);
      j["examples"] = std::move(examples);
      if (aimed) {
        Json kinds = Json::object();
        for (int k = 0; k < kHostileKinds; ++k) kinds[hostile_kind_name(HostileKind(k))] = verdicts_json(by_kind[k]);
        j["by_kind"] = std::move(kinds);
      }
      out[i][set.name] = std::move(j);
    }
  }
  return out;
}

// The tracer Embree's packet API is reported as.
const std::string kEmbreePackets = "embree_packets";

// Embree's packet API against its single rays on the same scene and rays: the closest hits the same
// (triangle, and t, u, v bit for bit) and the same rays occluded, or how many differ, with the first
// few rays that do. Embree's packet kernels may round differently from its single-ray ones (other
// instructions, the same test), hence the class of the same triangle at another t, u, v (rounding).
Json packets_agreement_json(const EmbreeTracer& embree, const std::vector<Ray>& rays) {
  std::vector<Hit> single(rays.size()), packed(rays.size());
  std::vector<uint8_t> single_any(rays.size()), packed_any(rays.size());
  embree.closest(rays, single);
  embree.closest_packets(rays, packed);
  embree.any(rays, single_any);
  embree.any_packets(rays, packed_any);
  auto bits = [](float x) { return std::bit_cast<uint32_t>(x); };
  uint64_t same = 0, rounding = 0, other_triangle = 0, hit_or_miss = 0, any_differs = 0;
  Json examples = Json::array();
  for (size_t i = 0; i < rays.size(); ++i) {
    const Hit &a = single[i], &b = packed[i];
    const char* kind = nullptr;
    if (a.valid() != b.valid()) ++hit_or_miss, kind = "hit_or_miss";
    else if (!a.valid() ||
             (a.triangle == b.triangle && bits(a.t) == bits(b.t) && bits(a.u) == bits(b.u) && bits(a.v) == bits(b.v)))
      ++same;
    else if (a.triangle == b.triangle) ++rounding, kind = "rounding";
    else ++other_triangle, kind = "other_triangle";
    if (single_any[i] != packed_any[i]) {
      ++any_differs;
      if (!kind) kind = "occluded";
    }
    if (kind && examples.size() < kWrongExamples) {
      const Ray& r = rays[i];
      auto hit = [](const Hit& h) { return h.valid() ? Json{{"triangle", h.triangle}, {"t", h.t}} : Json(nullptr); };
      examples.push_back({{"kind", kind},
                          {"origin", {r.origin.x, r.origin.y, r.origin.z}},
                          {"direction", {r.direction.x, r.direction.y, r.direction.z}},
                          {"single", hit(a)},
                          {"packet", hit(b)},
                          {"occluded_single", bool(single_any[i])},
                          {"occluded_packet", bool(packed_any[i])}});
    }
  }
  return {{"rays", rays.size()},
          {"closest",
           {{"same", same}, {"rounding", rounding}, {"other_triangle", other_triangle}, {"hit_or_miss", hit_or_miss}}},
          {"any", {{"same", rays.size() - any_differs}, {"differs", any_differs}}},
          {"examples", std::move(examples)}};
}

// Build times of every builder at every thread count, repetitions interleaved as in trace_runs.
// `build(i)` builds contender i and returns its seconds; it throws for a structure that cannot be
// built (the caller leaves it out).
std::vector<Json> build_times_json(const Options& o, size_t count, const std::function<double(size_t)>& build) {
  std::vector<Json> out(count, Json::object());
  for (int threads : o.threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
    const PinnedToOneCore pin(threads == 1);
    std::vector<std::vector<double>> seconds(count);
    for (int r = 0; r < o.build_reps; ++r)
      for (size_t i = 0; i < count; ++i) seconds[i].push_back(build(i));
    for (size_t i = 0; i < count; ++i)
      out[i][std::to_string(threads)] = {{"seconds_median", median(seconds[i])}, {"seconds", seconds[i]}};
  }
  return out;
}

// The ray sets the driver traces through the Python API as well (tools/bench/experiments.py, run_api).
constexpr const char* kApiSets[] = {"camera", "camera_sky", "random"};

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
      rows.insert(rows.end(), {h.valid() ? double(h.t) : INFINITY, h.valid() ? double(h.triangle) : -1.0, double(h.u),
                               double(h.v)});
    write_npy(base + ".embree_" + set.name + ".npy", "<f8", {hits.size(), 4}, rows.data(),
              rows.size() * sizeof(double));
  }
  // Every ray of the sets the Python API's queries take as they are (tmin 0, tmax infinity for all: the
  // API takes one interval per call), for the driver's timing of the user's path on the very rays timed here.
  for (const RaySet& set : sets)
    if (std::ranges::find(kApiSets, set.name) != std::end(kApiSets))
      write_npy(base + ".trace_" + set.name + ".npy", "<f4", {set.rays.size(), 8}, set.rays.data(),
                set.rays.size() * sizeof(Ray));
}

int run(const Options& o) {
  std::filesystem::create_directories(o.out_dir);
  const auto mesh = std::make_shared<TriangleMesh>(load(o.mesh));
  mesh->validate();
  const Bounds bounds = mesh->bounds();
  std::cerr << o.name << ": " << mesh->triangle_count() << " triangles\n";

  // The oracle: Embree at medium quality, the default of rtcNewScene.
  EmbreeTracer oracle(*mesh);
  oracle.build(RTC_BUILD_QUALITY_MEDIUM);

  const std::vector<Ray> camera = camera_rays(bounds, o.camera_width, o.camera_height);
  const HostileRays hostile = hostile_rays(*mesh, o.hostile_rays, 20241203);
  std::vector<RaySet> sets{{"camera", camera},
                           {"camera_sky", camera_rays(bounds, o.camera_width, o.camera_height, kSkyDistance)},
                           {"shadow", shadow_rays(oracle, bounds, camera)},
                           {"random", random_rays(bounds, o.random_rays)}};
  if (!hostile.rays.empty()) sets.push_back({"hostile", hostile.rays});

  // Every structure and Embree build first (one that cannot be built is reported with its error),
  // then the build times and the tracing, each interleaved across them.
  Json tracers = Json::array();
  struct Built {
    std::string name, kind;
    bool judged = false;     // its answers judged by the float64 referee
    BuildSettings settings;  // raylab
    std::unique_ptr<Structure> structure;
    RTCBuildQuality quality{};  // Embree
    std::shared_ptr<EmbreeTracer> embree;
    bool packets = false;  // Embree's packet API on the scene of the entry before it (medium quality)
  };
  std::vector<Built> built;
  for (const std::string& structure : o.structures)
    for (const std::string& contract_text : o.contracts)
      for (const std::string& builder_text : o.builders) {
        // Each contract of a structure that takes one (bvh, bvh_fast), and each builder of one that takes
        // one (bvh_median); the defaults of the others.
        const StructureInfo& info = structure_info(structure);
        const Contract contract = contract_from_name(contract_text);
        const BvhBuilder builder = bvh_builder_from_name(builder_text);
        if (contract != Contract::Exact && !info.uses_contract) continue;
        if (builder != BuildSettings{}.builder && !info.uses_builder) continue;
        const std::string name = (contract == Contract::Exact ? structure : structure + "_" + contract_text) +
                                 (builder == BuildSettings{}.builder ? "" : "_" + builder_text);
        std::cerr << "  " << name << "\n";
        Built b{name, "raylab", info.uses_contract};
        b.settings.kind = info.kind;
        b.settings.max_depth = o.max_depth;
        b.settings.leaf_size = o.leaf_size;
        b.settings.contract = contract;
        b.settings.builder = builder;
        try {
          b.structure = build_structure(mesh, b.settings);
        } catch (const std::exception& e) {  // a structure not written yet, over the memory budget, no AVX2
          tracers.push_back({{"name", name}, {"kind", "raylab"}, {"contract", contract_text}, {"error", e.what()}});
          continue;
        }
        built.push_back(std::move(b));
      }
  for (const std::string& quality : o.embree_qualities) {
    std::cerr << "  embree " << quality << "\n";
    Built b{"embree_" + quality, "embree", true};
    b.quality = kEmbreeQualities.at(quality);
    b.embree = std::make_shared<EmbreeTracer>(*mesh);
    b.embree->build(b.quality);
    built.push_back(std::move(b));
    // Embree's packet API on the medium scene: a second tracer of the same build.
    if (quality == "medium") {
      Built p{kEmbreePackets, "embree", false};
      p.quality = built.back().quality;
      p.embree = built.back().embree;
      p.packets = true;
      built.push_back(std::move(p));
    }
  }
  std::vector<Json> build_times = build_times_json(o, built.size(), [&](size_t i) {
    Built& b = built[i];
    if (b.packets) return 0.0;  // its scene is the entry before it: built and timed there
    if (b.embree) return b.embree->build(b.quality);
    b.structure = build_structure(mesh, b.settings);
    return b.structure->build_seconds();
  });
  for (size_t i = 0; i < built.size(); ++i)
    if (built[i].packets) build_times[i] = build_times[i - 1];

  const Referee referee(*mesh);
  std::vector<Contender> contenders;
  for (Built& b : built) {
    if (b.packets) {
      EmbreeTracer& embree = *b.embree;
      contenders.push_back({b.name,
                            {[&embree](auto r, auto h) { embree.closest_packets(r, h); },
                             [&embree](auto r, auto oc) { embree.any_packets(r, oc); }},
                            [&embree](const RaySet&, const std::vector<Ray>& rays) {
                              return Json{{"agreement_with_single_rays", packets_agreement_json(embree, rays)}};
                            }});
      continue;
    }
    if (b.embree) {
      EmbreeTracer& embree = *b.embree;
      contenders.push_back(
          {b.name,
           {[&embree](auto r, auto h) { embree.closest(r, h); }, [&embree](auto r, auto oc) { embree.any(r, oc); }},
           [](const RaySet&, const std::vector<Ray>&) { return Json::object(); }});
      continue;
    }
    const Structure& s = *b.structure;
    auto counts_and_agreement = [&s, &mesh, &oracle, &referee, &hostile](const RaySet& set,
                                                                         const std::vector<Ray>& rays) {
      std::vector<Hit> ours(rays.size()), theirs(rays.size());
      std::vector<uint8_t> our_any(rays.size()), their_any(rays.size());
      TraversalStats closest_stats, any_stats;
      intersect_closest(s, rays, ours, &closest_stats);
      intersect_any(s, rays, our_any, &any_stats);
      oracle.closest(rays, theirs);
      oracle.any(rays, their_any);
      // The hostile set is checked whole (its rays are few), so its targets line up with the rays.
      const bool aimed = set.name == "hostile" && rays.size() == hostile.rays.size();
      const Arbiter arbiter{&referee, aimed ? std::span<const uint32_t>(hostile.target) : std::span<const uint32_t>()};
      return Json{
          {"counts", {{"closest", stats_json(closest_stats)}, {"any", stats_json(any_stats)}}},
          {"agreement_with_embree",
           {{"closest", comparison_json(*mesh, compare_closest(*mesh, rays, ours, theirs, arbiter))},
            {"any", comparison_json(*mesh, compare_any(*mesh, rays, our_any, their_any, ours, theirs, arbiter))}}}};
    };
    contenders.push_back({b.name,
                          {[&s](auto r, auto h) { intersect_closest(s, r, h, nullptr); },
                           [&s](auto r, auto oc) { intersect_any(s, r, oc, nullptr); }},
                          counts_and_agreement});
  }
  trace_runs(contenders, sets, o);
  std::vector<size_t> judged;
  for (size_t i = 0; i < built.size(); ++i)
    if (built[i].judged) judged.push_back(i);
  std::vector<Json> exactness = judge_runs(referee, contenders, judged, sets, hostile);
  for (size_t i = 0; i < built.size(); ++i) {
    const Built& b = built[i];
    tracers.push_back(
        {{"name", b.name},
         {"kind", b.kind},
         {"contract", b.embree ? Json(nullptr) : Json(contract_name(b.settings.contract))},
         {"api", b.embree ? Json(b.packets ? "rtcIntersect8" : "rtcIntersect1") : Json(nullptr)},
         {"builder", b.embree ? Json(nullptr) : Json(bvh_builder_name(b.settings.builder))},
         {"error", nullptr},
         {"build", build_times[i]},
         {"memory_bytes", b.embree ? b.embree->memory_bytes() : b.structure->memory_bytes()},
         {"tracing", {{"runs", std::move(contenders[i].runs)}, {"per_ray_set", std::move(contenders[i].per_set)}}},
         {"exactness", std::move(exactness[i])}});
  }

  export_for_python(o, *mesh, sets, oracle);

  Json set_info = Json::object();
  for (const RaySet& set : sets) set_info[set.name] = {{"count", set.rays.size()}};
  if (!hostile.rays.empty()) {
    Json kinds = Json::array();
    for (int k = 0; k < kHostileKinds; ++k) kinds.push_back(hostile_kind_name(HostileKind(k)));
    set_info["hostile"]["kinds"] = std::move(kinds);
  }
  const Json result{
      {"mesh", o.name},
      {"source", o.mesh},
      {"triangles", mesh->triangle_count()},
      {"vertices", mesh->vertices.size()},
      {"camera", {{"width", o.camera_width}, {"height", o.camera_height}}},
      {"ray_sets", std::move(set_info)},
      {"repetitions", o.reps},
      {"build_repetitions", o.build_reps},
      {"hardware_threads", std::thread::hardware_concurrency()},
      {"embree_version", RTC_VERSION_STRING},
      {"clock", g_cpu_time ? "cpu" : "wall"},
      {"octree",
       {{"max_depth", o.max_depth == raylab::BuildSettings::kAutoDepth ? Json(raylab::BuildSettings::kAutoDepthName)
                                                                       : Json(o.max_depth)},
        {"leaf_size", o.leaf_size}}},
      {"tracers", std::move(tracers)},
  };
  // A path or message that is not UTF-8 gets U+FFFD rather than losing the whole run to an exception.
  std::ofstream(o.out_dir + "/" + o.name + ".json")
      << result.dump(-1, ' ', false, Json::error_handler_t::replace) << "\n";
  return 0;
}

}  // namespace
}  // namespace raylab::bench

int main(int argc, char** argv) {
  raylab::bench::Options options;
  CLI::App app{"raylab_bench: raylab's structures side by side with Embree on one mesh, the same rays"};
  raylab::bench::add_options(app, options);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help ends here too, with status 0; a bad command line exits 2, the usual usage error.
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    return raylab::bench::run(options);
  } catch (const std::exception& e) {
    std::cerr << "raylab_bench: " << e.what() << "\n";
    return 1;
  }
}
