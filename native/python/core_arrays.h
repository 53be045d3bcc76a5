// numpy <-> core conversions shared by the core bindings (structures and scenes). Every check on
// user data happens here, with the GIL held, so that native code only ever sees valid input and a
// mistake becomes a ValueError that names it instead of a crash.
#pragma once

#include "parameters.h"

#include "raylab/geometry.h"
#include "raylab/structure.h"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <type_traits>
#include <vector>

namespace raylab::python {

namespace py = pybind11;

// (V,3) real vertices and (T,3) integer triangles -> a validated mesh. Other real dtypes are
// converted to float32; negative or out-of-range indices and non-finite coordinates raise.
MeshPtr mesh_from_arrays(py::handle vertices, py::handle triangles);

// The keywords every build takes, as any Python objects -> validated settings (a wrong type,
// unknown name or bad value raises a ValueError naming the keyword).
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
                         py::arg("max_depth") = max_depth_object(d.max_depth),
                         py::arg("leaf_size") = d.leaf_size,
                         py::arg("triangle_test") = triangle_test_name(d.triangle_test),
                         py::arg("memory_budget") = py::none());
}

// Calls `define(keywords...)` with settings_keywords() appended to `leading` (py::arg objects).
template <class Define, class... Leading>
void with_settings_keywords(Define define, Leading... leading) {
  std::apply([&](auto... settings) { define(leading..., settings...); }, settings_keywords());
}

BuildSettings settings_from_arguments(py::handle structure, py::handle max_depth, py::handle leaf_size,
                                      py::handle triangle_test, py::handle memory_budget);

// (N,3) origins and directions; either may be a single (3,) row shared by all rays. tmin and tmax
// are any Python objects, read as real numbers.
std::vector<Ray> rays_from_arrays(py::handle origins, py::handle directions, py::handle tmin, py::handle tmax);
// One ray from (3,) origin and direction.
Ray ray_from_arrays(py::handle origin, py::handle direction, py::handle tmin, py::handle tmax);

// Closest hits as numpy arrays: t, triangle, u, v, instance, hit. `single_instance` reports
// instance 0 for every hit (a lone structure has no instance of its own).
py::dict hits_to_dict(const std::vector<Hit>& hits, bool single_instance);
py::dict occlusion_to_dict(const std::vector<uint8_t>& occluded);
py::dict stats_to_dict(const TraversalStats& stats);


// A batch query: rays from the arrays, `trace(rays, results, stats)` with the GIL released while both
// cores trace, then the results as a dict of arrays plus "stats" (None unless `count`).
template <class Result, class Trace, class ToDict>
py::dict trace_arrays(py::handle origins, py::handle directions, py::handle tmin, py::handle tmax,
                      py::handle count_flag, Trace trace, ToDict to_dict) {
  const std::vector<Ray> rays = rays_from_arrays(origins, directions, tmin, tmax);
  const bool count = bool_parameter(count_flag, "count");
  std::vector<Result> results(rays.size());
  TraversalStats stats;
  {
    py::gil_scoped_release release;
    trace(rays, results, count ? &stats : nullptr);
  }
  py::dict d = to_dict(results);
  d["stats"] = count ? py::object(stats_to_dict(stats)) : py::none();
  return d;
}

// The batch queries of the Python API, for a Structure or a Scene (both have intersect_closest and
// intersect_any).
template <class Target>
py::dict intersect_rays(const Target& target, py::handle origins, py::handle directions, py::handle tmin,
                        py::handle tmax, py::handle count) {
  return trace_arrays<Hit>(
      origins, directions, tmin, tmax, count,
      [&](const std::vector<Ray>& rays, std::vector<Hit>& hits, TraversalStats* stats) {
        intersect_closest(target, rays, hits, stats);
      },
      [](const std::vector<Hit>& hits) { return hits_to_dict(hits, std::is_same_v<Target, Structure>); });
}

template <class Target>
py::dict occluded_rays(const Target& target, py::handle origins, py::handle directions, py::handle tmin,
                       py::handle tmax, py::handle count) {
  return trace_arrays<uint8_t>(
      origins, directions, tmin, tmax, count,
      [&](const std::vector<Ray>& rays, std::vector<uint8_t>& occluded, TraversalStats* stats) {
        intersect_any(target, rays, occluded, stats);
      },
      occlusion_to_dict);
}

void bind_scene(py::module_& m);  // core_scene.cpp

}  // namespace raylab::python
