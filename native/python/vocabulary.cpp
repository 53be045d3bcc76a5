// The core's vocabularies, exported once so that Python never lists them again: the structure kinds,
// the triangle tests, the counters and the build defaults. api.py, the add-on's menus and panels, the
// compare table, the benchmark and the tests read these.
#include "bindings.h"

#include "raylab/structure.h"
#include "raylab/traversal_record.h"
#include "raylab/triangle_intersection.h"

#include <pybind11/pybind11.h>

namespace py = pybind11;

namespace raylab::python {

void bind_vocabulary(py::module_& m) {
  py::list structures;
  for (const StructureInfo& s : structure_kinds()) {
    py::dict d;
    d["name"] = s.name;
    d["label"] = s.label;
    d["description"] = s.description;
    d["root_name"] = s.root_name;
    d["uses_max_depth"] = s.uses_max_depth;
    d["uses_leaf_size"] = s.uses_leaf_size;
    d["uses_top_level"] = s.uses_top_level;
    d["has_boxes"] = s.has_boxes;
    structures.append(d);
  }
  m.attr("STRUCTURES") = py::tuple(structures);

  py::list tests;
  for (const TriangleTestInfo& t : kTriangleTests) {
    py::dict d;
    d["name"] = t.name;
    d["label"] = t.label;
    d["description"] = t.description;
    tests.append(d);
  }
  m.attr("TRIANGLE_TESTS") = py::tuple(tests);

  py::list counters;
  for (const CounterInfo& c : kCounters) {
    py::dict d;
    d["name"] = c.name;
    d["label"] = c.label;
    d["description"] = c.description;
    d["object_work"] = c.object_work;
    counters.append(d);
  }
  m.attr("COUNTERS") = py::tuple(counters);

  const BuildSettings defaults;
  py::dict d;
  d["structure"] = structure_kind_name(defaults.kind);
  d["max_depth"] = defaults.max_depth;
  d["leaf_size"] = defaults.leaf_size;
  d["triangle_test"] = triangle_test_name(defaults.triangle_test);
  d["memory_budget"] = defaults.memory_budget;
  d["max_depth_limit"] = BuildSettings::kMaxDepthLimit;
  m.attr("BUILD_DEFAULTS") = d;
}

}  // namespace raylab::python
