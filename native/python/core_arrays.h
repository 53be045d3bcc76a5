// numpy <-> core conversions shared by the core bindings (structures and scenes). Every check on
// user data happens here, with the GIL held, so that native code only ever sees valid input and a
// mistake becomes a ValueError that names it instead of a crash.
#pragma once

#include "parameters.h"

#include "raylab/geometry.h"
#include "raylab/ray_rows.h"
#include "raylab/scene.h"
#include "raylab/scene_snapshot.h"

#include <glm/mat4x4.hpp>
#include "raylab/structure.h"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <optional>
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace raylab::python {

namespace py = pybind11;

// A C-contiguous array of T with numpy's conversion. numpy may fail to convert (a float64 value past
// float32's range under `-W error`, a copy past a memory limit): that raises a ValueError naming
// `what`, chained to numpy's error, never a null array.
template <class T>
using Contiguous = py::array_t<T, py::array::c_style | py::array::forcecast>;

template <class T>
Contiguous<T> converted(py::handle value, const std::string& what) {
  try {
    return Contiguous<T>(py::reinterpret_borrow<py::object>(value));
  } catch (py::error_already_set& e) {
    const std::string message = what + " cannot be converted to " + std::string(py::str(py::dtype::of<T>()));
    py::raise_from(e, PyExc_ValueError, message.c_str());
    throw py::error_already_set();
  }
}

// Whether `a` holds real numbers: float, signed or unsigned integers (not bool, complex, object, text).
inline bool real_dtype(const py::array& a) {
  const char k = a.dtype().kind();
  return k == 'f' || k == 'i' || k == 'u';
}

// `value` converted as converted() says when numpy reads it as an array of real numbers; nothing when
// it does not (the caller says which shape it wanted).
template <class T>
std::optional<Contiguous<T>> real_array(py::handle value, const std::string& what) {
  if (value.is_none()) return std::nullopt;
  py::array a = py::array::ensure(value);  // a null handle when numpy cannot make an array of it
  if (!a) return std::nullopt;
  if (!real_dtype(a)) return std::nullopt;
  return converted<T>(a, what);
}

// The kinds of dtype a numeric parameter takes: real numbers (float, signed and unsigned integers);
// bool, complex, object and strings raise a ValueError naming `what`.
void require_real_dtype(const py::array& a, const std::string& what);

// (V,3) real vertices and (T,3) integer triangles -> a validated mesh. Other real dtypes are
// converted to float32; negative or out-of-range indices and non-finite coordinates raise.
MeshPtr mesh_from_arrays(py::handle vertices, py::handle triangles);
// (V,3) real vertices as points (converted to float32; their values are checked by whoever uses them).
std::vector<glm::vec3> vertices_from_array(py::handle vertices);

// The keywords every build takes, as any Python objects -> settings (a wrong type or unknown name
// raises a ValueError naming the keyword; the values' ranges are BuildSettings::validate()'s, called
// where the settings enter the core).
// The build settings as keyword arguments with BuildSettings' own defaults, for every binding that
// takes them (build, build_file, Scene, Scene.set_settings): `def(f, leading args..., settings...)`.
// max_depth as Python sees it: "auto" or a whole number.
inline py::object max_depth_object(int max_depth) {
  if (max_depth == BuildSettings::kAutoDepth) return py::str(BuildSettings::kAutoDepthName);
  return py::int_(max_depth);
}

inline auto settings_keywords() {
  const BuildSettings d;
  return std::make_tuple(py::arg("structure") = structure_kind_name(d.kind),
                         py::arg("max_depth") = max_depth_object(d.max_depth), py::arg("leaf_size") = d.leaf_size,
                         py::arg("triangle_test") = triangle_test_name(d.triangle_test),
                         py::arg("contract") = contract_name(d.contract),
                         py::arg("builder") = bvh_builder_name(d.builder), py::arg("memory_budget") = py::none());
}

// Calls `define(keywords...)` with settings_keywords() appended to `leading` (py::arg objects).
template <class Define, class... Leading>
void with_settings_keywords(Define define, Leading... leading) {
  std::apply([&](auto... settings) { define(leading..., settings...); }, settings_keywords());
}

BuildSettings settings_from_arguments(py::handle structure, py::handle max_depth, py::handle leaf_size,
                                      py::handle triangle_test, py::handle contract, py::handle builder,
                                      py::handle memory_budget);

// (N,3) origins and directions; either may be a single (3,) row shared by all rays. tmin and tmax
// are any Python objects, read as real numbers. ray_arrays checks the arrays and the interval and reads
// the rays in place (float32 C-order arrays are not copied); refuse_ray raises the ValueError of an
// unusable row (a NaN or infinite coordinate, a zero direction); rays_from_arrays makes every ray.
struct RayArrays {
  Contiguous<float> origins, directions;
  RayRows rows;  // reads the two arrays above
};
RayArrays ray_arrays(py::handle origins, py::handle directions, py::handle tmin, py::handle tmax);
[[noreturn]] void refuse_ray(const RayRows& rows, size_t i);
std::vector<Ray> rays_from_arrays(py::handle origins, py::handle directions, py::handle tmin, py::handle tmax);
// One ray from (3,) origin and direction.
Ray ray_from_arrays(py::handle origin, py::handle direction, py::handle tmin, py::handle tmax);

// Closest hits as numpy arrays: t, triangle, u, v, instance, hit. `single_instance` reports
// instance 0 for every hit (a lone structure has no instance of its own).
py::dict hits_to_dict(const std::vector<Hit>& hits, bool single_instance);
// The six arrays of closest hits (t, triangle, u, v, instance, hit), each a contiguous view of one
// allocation whose columns `out` points at, to be written before Python sees them.
py::dict hit_columns(size_t n, bool single_instance, HitColumns& out);
py::dict occlusion_to_dict(const std::vector<uint8_t>& occluded);
py::dict stats_to_dict(const TraversalStats& stats);
// Each ray's counters: every kCounters name -> an (N,) uint32 array. A count beyond uint32 raises
// (ValueError) rather than wrap.
py::dict per_ray_to_dict(std::span<const TraversalStats> per_ray);

// glm's column-major matrix as numpy's row-major (4,4) float32.
py::array_t<float> matrix_to_array(const glm::mat4& m);

// (N,3) float32 rows of points, and a column of one field of each item.
inline py::array_t<float> rows(const std::vector<glm::vec3>& points) {
  py::array_t<float> a({py::ssize_t(points.size()), py::ssize_t(3)});
  float* p = a.mutable_data();
  for (size_t i = 0; i < points.size(); ++i)
    for (int c = 0; c < 3; ++c) p[3 * i + c] = points[i][c];
  return a;
}
// The boxes' corners as d["lo"] and d["hi"], (N,3) each: items have a `bounds`.
template <class Item>
void put_bounds(py::dict& d, const std::vector<Item>& items) {
  std::vector<glm::vec3> lo, hi;
  for (const Item& item : items) {
    lo.push_back(item.bounds.lo);
    hi.push_back(item.bounds.hi);
  }
  d["lo"] = rows(lo);
  d["hi"] = rows(hi);
}
template <class T, class Item, class Field>
py::array_t<T> column(const std::vector<Item>& items, Field field) {
  py::array_t<T> a(py::ssize_t(items.size()));
  T* p = a.mutable_data();
  for (size_t i = 0; i < items.size(); ++i) p[i] = T(field(items[i]));
  return a;
}
// stories.cpp: one ray's story (see RayStory / SceneStory) and batch statuses (indices into RAY_STATUSES).
py::dict story_to_dict(const RayStory& story);
py::dict scene_story_to_dict(const SceneStory& story, const SceneSnapshot& scene);
py::dict statuses_to_dict(const std::vector<Hit>& hits, const std::vector<RayStatus>& statuses, bool single_instance);

// A batch query: rays from the arrays, `trace(rays, results, stats, threads, per_ray)` with the GIL
// released while the cores trace, then the results as a dict of arrays plus "stats" (the totals, None
// unless `count` or `per_ray`) and "per_ray" (each ray's counters, None unless `per_ray`).
template <class Result, class Trace, class ToDict>
py::dict trace_arrays(py::handle origins, py::handle directions, py::handle tmin, py::handle tmax,
                      py::handle count_flag, py::handle per_ray_flag, py::handle threads_value, Trace trace,
                      ToDict to_dict) {
  const std::vector<Ray> rays = rays_from_arrays(origins, directions, tmin, tmax);
  const bool per_ray = bool_parameter(per_ray_flag, "per_ray");
  const bool count = bool_parameter(count_flag, "count") || per_ray;
  const int threads = threads_parameter(threads_value);
  std::vector<Result> results(rays.size());
  std::vector<TraversalStats> own(per_ray ? rays.size() : 0);
  TraversalStats stats;
  {
    py::gil_scoped_release release;
    trace(rays, results, count ? &stats : nullptr, threads, std::span<TraversalStats>(own));
  }
  py::dict d = to_dict(results);
  d["stats"] = count ? py::object(stats_to_dict(stats)) : py::none();
  d["per_ray"] = per_ray ? py::object(per_ray_to_dict(own)) : py::none();
  return d;
}

// What the uncounted batch queries trace: a structure, or the scene's current snapshot (held for the call).
inline const Structure& traced(const Structure& s, SceneSnapshotPtr&) { return s; }
inline const SceneSnapshot& traced(const Scene& s, SceneSnapshotPtr& held) {
  held = s.snapshot();
  return *held;
}

// Closest hits with each ray's status: `trace(rays, hits, statuses)` is a structure's or a scene's.
template <class Trace>
py::dict status_arrays(py::handle origins, py::handle directions, py::handle tmin, py::handle tmax, py::handle threads,
                       bool single_instance, Trace trace) {
  std::vector<RayStatus> statuses;
  return trace_arrays<Hit>(
      origins, directions, tmin, tmax, py::bool_(false), py::bool_(false), threads,
      [&](const std::vector<Ray>& rays, std::vector<Hit>& hits, TraversalStats*, int n_threads,
          std::span<TraversalStats>) {
        statuses.resize(rays.size());
        trace(rays, hits, statuses, n_threads);
      },
      [&](const std::vector<Hit>& hits) { return statuses_to_dict(hits, statuses, single_instance); });
}

// An uncounted batch query of the Python API: the rays read in place (ray_rows.h), `columns(n)` makes
// the arrays returned (a dict) and where the answers go, `trace(target, rows, where, threads)` writes
// them with the GIL released; an unusable ray raises its ValueError after.
template <class Target, class Columns, class Trace>
py::dict trace_in_place(const Target& target, py::handle origins, py::handle directions, py::handle tmin,
                        py::handle tmax, py::handle threads, Columns columns, Trace trace) {
  const RayArrays rays = ray_arrays(origins, directions, tmin, tmax);
  const int n_threads = threads_parameter(threads);
  auto [d, where] = columns(rays.rows.count);
  SceneSnapshotPtr held;
  const auto& what = traced(target, held);
  size_t refused;
  {
    py::gil_scoped_release release;
    refused = trace(what, rays.rows, where, n_threads);
  }
  if (refused != rays.rows.count) refuse_ray(rays.rows, refused);
  d["stats"] = py::none();
  d["per_ray"] = py::none();
  return d;
}

// The batch queries of the Python API, for a Structure or a Scene. Uncounted (the common call), the
// rays are read in place and the answers written once into the arrays returned (trace_in_place);
// counted, every ray is made first and walks alone with its counters (trace_arrays).
template <class Target>
py::dict intersect_rays(const Target& target, py::handle origins, py::handle directions, py::handle tmin,
                        py::handle tmax, py::handle count, py::handle per_ray, py::handle threads) {
  constexpr bool single_instance = std::is_same_v<Target, Structure>;
  if (bool_parameter(count, "count") || bool_parameter(per_ray, "per_ray"))
    return trace_arrays<Hit>(
        origins, directions, tmin, tmax, count, per_ray, threads,
        [&](const std::vector<Ray>& rays, std::vector<Hit>& hits, TraversalStats* stats, int n_threads,
            std::span<TraversalStats> own) { intersect_closest(target, rays, hits, stats, n_threads, own); },
        [](const std::vector<Hit>& hits) { return hits_to_dict(hits, single_instance); });
  return trace_in_place(
      target, origins, directions, tmin, tmax, threads,
      [](size_t n) {
        HitColumns out;
        py::dict d = hit_columns(n, single_instance, out);
        return std::pair(d, out);
      },
      [](const auto& what, const RayRows& rows, const HitColumns& out, int n_threads) {
        return closest_rows(what, rows, out, n_threads);
      });
}

template <class Target>
py::dict occluded_rays(const Target& target, py::handle origins, py::handle directions, py::handle tmin,
                       py::handle tmax, py::handle count, py::handle per_ray, py::handle threads) {
  if (bool_parameter(count, "count") || bool_parameter(per_ray, "per_ray"))
    return trace_arrays<uint8_t>(
        origins, directions, tmin, tmax, count, per_ray, threads,
        [&](const std::vector<Ray>& rays, std::vector<uint8_t>& occluded, TraversalStats* stats, int n_threads,
            std::span<TraversalStats> own) { intersect_any(target, rays, occluded, stats, n_threads, own); },
        occlusion_to_dict);
  return trace_in_place(
      target, origins, directions, tmin, tmax, threads,
      [](size_t n) {
        py::array_t<bool> hit{py::ssize_t(n)};
        py::dict d;
        d["hit"] = hit;
        return std::pair(d, hit.mutable_data());
      },
      [](const auto& what, const RayRows& rows, bool* occluded, int n_threads) {
        return any_rows(what, rows, occluded, n_threads);
      });
}

void bind_scene(py::module_& m);  // core_scene.cpp

}  // namespace raylab::python
