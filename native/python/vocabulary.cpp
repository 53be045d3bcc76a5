// The core's vocabularies, exported once so that Python never lists them again: the structure kinds,
// the triangle tests, the counters, the cost passes and which rays they count, the ray statuses and
// the build defaults. api.py, the add-on's menus and panels, the compare table, the benchmark and the
// tests read these.
#include "bindings.h"
#include "core_arrays.h"

#include "raylab/cost_passes.h"
#include "raylab/scene.h"
#include "raylab/structure.h"
#include "raylab/traversal_record.h"
#include "raylab/triangle_intersection.h"
#include "raylab/triangle_packets.h"

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <iterator>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace py = pybind11;

namespace raylab::python {

namespace {

template <class Row, class Member>
std::pair<const char*, Member Row::*> field(const char* name, Member Row::*member) {
  return {name, member};
}

// A table of rows as a tuple of dicts with the given fields.
template <class Row, class... Members>
py::tuple table(std::span<const Row> rows, std::pair<const char*, Members Row::*>... fields) {
  py::list out;
  for (const Row& row : rows) {
    py::dict d;
    ((d[fields.first] = row.*fields.second), ...);
    out.append(d);
  }
  return py::tuple(out);
}

}  // namespace

void bind_vocabulary(py::module_& m) {
  using S = StructureInfo;
  m.attr("STRUCTURES") = table(structure_kinds(), field("name", &S::name), field("label", &S::label),
                               field("description", &S::description), field("root_name", &S::root_name),
                               field("uses_max_depth", &S::uses_max_depth), field("uses_leaf_size", &S::uses_leaf_size),
                               field("uses_contract", &S::uses_contract), field("uses_builder", &S::uses_builder),
                               field("uses_top_level", &S::uses_top_level), field("has_boxes", &S::has_boxes));
  // Whether refit keeps the topology (else it rebuilds): StructureInfo::refit is a function, not a field.
  for (size_t i = 0; i < structure_kinds().size(); ++i)
    m.attr("STRUCTURES")[py::int_(i)]["refits"] = structure_kinds()[i].refit != nullptr;
  using T = TriangleTestInfo;
  m.attr("TRIANGLE_TESTS") = table(std::span<const T>(kTriangleTests), field("name", &T::name),
                                   field("label", &T::label), field("description", &T::description));
  using K = ContractInfo;
  m.attr("CONTRACTS") = table(std::span<const K>(kContracts), field("name", &K::name), field("label", &K::label),
                              field("description", &K::description));
  using B = BvhBuilderInfo;
  m.attr("BUILDERS") = table(std::span<const B>(kBvhBuilders), field("name", &B::name), field("label", &B::label),
                             field("description", &B::description));
  using M = SplitMethodInfo;
  m.attr("SPLIT_METHODS") =
      table(std::span<const M>(kSplitMethods), field("name", &M::name), field("description", &M::description));
  using C = CounterInfo;
  m.attr("COUNTERS") = table(std::span<const C>(kCounters), field("name", &C::name), field("label", &C::label),
                             field("description", &C::description), field("object_work", &C::object_work));

  using P = CostPassInfo;
  m.attr("COST_PASSES") = table(std::span<const P>(kCostPasses), field("name", &P::name), field("counter", &P::counter),
                                field("label", &P::label), field("description", &P::description));
  using R = CostRaysInfo;
  m.attr("COST_RAYS") = table(std::span<const R>(kCostRays), field("name", &R::name), field("label", &R::label),
                              field("description", &R::description));

  m.attr("RAY_STATUSES") =
      py::tuple(py::cast(std::vector<std::string>(std::begin(kRayStatusNames), std::end(kRayStatusNames))));

  const BuildSettings defaults;
  py::dict d;
  d["structure"] = structure_kind_name(defaults.kind);
  d["max_depth"] = max_depth_object(defaults.max_depth);
  d["leaf_size"] = defaults.leaf_size;
  d["triangle_test"] = triangle_test_name(defaults.triangle_test);
  d["contract"] = contract_name(defaults.contract);
  d["builder"] = bvh_builder_name(defaults.builder);
  d["memory_budget"] = defaults.memory_budget;
  d["max_depth_limit"] = BuildSettings::kMaxDepthLimit;
  m.attr("BUILD_DEFAULTS") = d;

  // The constants of Structure.sah_cost and of the top level's refit-or-rebuild decision.
  py::dict sah;
  sah["node_visit"] = kSahTraversalCost;
  sah["leaf_block"] = kPacketLanes;
  m.attr("SAH_CONSTANTS") = sah;
  m.attr("TOP_LEVEL_REFIT_LIMIT") = Scene::kTopLevelRefitLimit;
}

}  // namespace raylab::python
