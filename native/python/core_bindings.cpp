// Meshes, structures and their queries. The native module returns plain dicts of numpy arrays;
// addon/raylab/api.py gives them the attribute names of the agreed Python API.
#include "bindings.h"
#include "core_arrays.h"

#include "raylab/box_lines.h"
#include "raylab/mesh_io.h"
#include "raylab/refit.h"
#include "raylab/structure.h"
#include "raylab/tree.h"

#include <algorithm>
#include <limits>
#include <optional>

namespace raylab::python {

namespace {

constexpr double kNoLimit = std::numeric_limits<double>::infinity();

using StructurePtr = std::shared_ptr<Structure>;

StructurePtr build(MeshPtr mesh, const BuildSettings& settings) {
  py::gil_scoped_release release;
  return build_structure(std::move(mesh), settings);
}

// A mesh file that cannot be read is an OSError naming the path, as for Python's own open(); a path
// that names no file (NUL, directory) or a file with invalid content is a ValueError.
TriangleMesh read_mesh_file(const std::string& path) {
  try {
    py::gil_scoped_release release;
    return load_mesh(path);
  } catch (const std::invalid_argument&) {
    throw;  // a bad path or a file that reads but holds an invalid mesh: ValueError
  } catch (const std::runtime_error& e) {
    std::string message = e.what();
    message.erase(message.find_last_not_of(" \n") + 1);  // the loader ends its messages with a newline
    PyErr_SetString(PyExc_OSError, message.c_str());
    throw py::error_already_set();
  }
}

py::tuple mesh_to_arrays(const TriangleMesh& mesh) {
  py::array_t<float> v({py::ssize_t(mesh.vertices.size()), py::ssize_t(3)});
  py::array_t<uint32_t> t({py::ssize_t(mesh.triangles.size()), py::ssize_t(3)});
  // glm vectors are three packed scalars; an empty mesh has no data() to take a member of (UBSan).
  std::copy_n(reinterpret_cast<const float*>(mesh.vertices.data()), 3 * mesh.vertices.size(), v.mutable_data());
  std::copy_n(reinterpret_cast<const uint32_t*>(mesh.triangles.data()), 3 * mesh.triangles.size(), t.mutable_data());
  return py::make_tuple(v, t);
}

// (P,4) real RGBA rows (or one (4,) row) -> the palette of box_lines; ValueError naming `palette`.
std::vector<glm::vec4> palette_parameter(py::handle value) {
  const auto a = real_array<float>(value, "palette");
  const bool shaped =
      a && ((a->ndim() == 2 && a->shape(1) == 4 && a->shape(0) >= 1) || (a->ndim() == 1 && a->shape(0) == 4));
  if (!shaped) throw py::value_error("palette must be RGBA rows, (P,4) with P >= 1 or (4,), got " + describe(value));
  std::vector<glm::vec4> palette(size_t(a->size() / 4));
  std::copy_n(a->data(), a->size(), reinterpret_cast<float*>(palette.data()));
  return palette;
}

// The overlay's arrays (box_lines.h): positions (8B,3) f32, colors (8B,4) f32, indices (12B,2) u32.
py::dict box_lines_dict(const std::vector<BoxInfo>& b, py::handle depth_min, py::handle depth_max,
                        py::handle leaves_only, py::handle palette, py::handle fade, py::handle alpha_scale) {
  BoxLineOptions o;
  o.depth_min = int32_parameter(depth_min, "depth_min");
  if (!depth_max.is_none()) o.depth_max = int32_parameter(depth_max, "depth_max");
  o.leaves_only = bool_parameter(leaves_only, "leaves_only");
  if (!palette.is_none()) o.palette = palette_parameter(palette);
  o.fade = bool_parameter(fade, "fade");
  o.alpha_scale = float(number_parameter(alpha_scale, "alpha_scale"));
  if (o.palette.empty()) throw py::value_error("palette must have at least one colour");
  std::vector<uint32_t> selected;
  {
    py::gil_scoped_release release;
    selected = selected_boxes(b, o);
  }
  const auto n = py::ssize_t(selected.size());
  py::array_t<float> positions({8 * n, py::ssize_t(3)}), colors({8 * n, py::ssize_t(4)});
  py::array_t<uint32_t> indices({12 * n, py::ssize_t(2)});
  // Written in place (numpy's C-contiguous rows are glm's packed vectors), without the GIL.
  const std::span<glm::vec3> p(reinterpret_cast<glm::vec3*>(positions.mutable_data()), size_t(8 * n));
  const std::span<glm::vec4> c(reinterpret_cast<glm::vec4*>(colors.mutable_data()), size_t(8 * n));
  const std::span<glm::uvec2> e(reinterpret_cast<glm::uvec2*>(indices.mutable_data()), size_t(12 * n));
  {
    py::gil_scoped_release release;
    write_box_lines(b, selected, o, p, c, e);
  }
  py::dict d;
  d["positions"] = positions;
  d["colors"] = colors;
  d["indices"] = indices;
  d["box_count"] = selected.size();
  return d;
}

py::dict boxes(const Structure& s, py::handle lines, py::handle depth_min, py::handle depth_max, py::handle leaves_only,
               py::handle palette, py::handle fade, py::handle alpha_scale) {
  std::vector<BoxInfo> b;
  {
    py::gil_scoped_release release;
    b = s.boxes();
  }
  if (bool_parameter(lines, "lines"))
    return box_lines_dict(b, depth_min, depth_max, leaves_only, palette, fade, alpha_scale);
  py::dict d;
  put_bounds(d, b);
  d["depth"] = column<int32_t>(b, [](const BoxInfo& x) { return x.depth; });
  d["leaf"] = column<bool>(b, [](const BoxInfo& x) { return x.leaf; });
  d["triangle_count"] = column<uint32_t>(b, [](const BoxInfo& x) { return x.triangle_count; });
  return d;
}

template <class T, class V>
py::array_t<T> array_of(const std::vector<V>& v) {
  py::array_t<T> a(py::ssize_t(v.size()));
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

// Structure.tree(): StructureTree (raylab/tree.h) as arrays; ValueError for kinds without a tree.
py::dict tree(const Structure& s) {
  std::optional<StructureTree> t;
  {
    py::gil_scoped_release release;
    t = structure_tree(s);
  }
  if (!t)
    throw std::invalid_argument("structure '" + std::string(structure_kind_name(s.kind())) +
                                "' has no tree (the BVH and the octree have one; the grid's occupied cells are "
                                "boxes())");
  py::dict d;
  const py::ssize_t n = py::ssize_t(t->parent.size());
  d["width"] = t->width;
  d["parent"] = array_of<int32_t>(t->parent);
  py::array_t<int32_t> children({py::ssize_t(t->children.size() / std::max(t->width, 1)), py::ssize_t(t->width)});
  std::copy(t->children.begin(), t->children.end(), children.mutable_data());
  d["children"] = children;
  d["depth"] = array_of<int32_t>(t->depth);
  std::vector<glm::vec3> lo, hi;
  for (const Bounds& b : t->bounds) {
    lo.push_back(b.lo);
    hi.push_back(b.hi);
  }
  d["lo"] = rows(lo);
  d["hi"] = rows(hi);
  d["leaf"] = array_of<bool>(t->leaf);
  d["triangle_count"] = array_of<uint32_t>(t->triangle_count);
  d["sah_cost"] = t->sah_cost.empty() ? py::object(py::none()) : py::object(array_of<double>(t->sah_cost));
  d["node_count"] = n;
  return d;
}

// Structure.split_costs(node): SplitCosts (bvh_build.h) as arrays of (3, candidates) and the choice.
py::dict split_costs(const Structure& s, py::handle node_value) {
  const uint32_t node = uint32_t(integer_parameter(node_value, "node", 0, std::numeric_limits<uint32_t>::max()));
  SplitCosts c;
  {
    py::gil_scoped_release release;
    c = structure_split_costs(s, node);
  }
  const py::ssize_t k = py::ssize_t(c.cost[0].size());
  py::array_t<float> position({py::ssize_t(3), k}), cost({py::ssize_t(3), k});
  py::array_t<uint32_t> left({py::ssize_t(3), k});
  for (int a = 0; a < 3; ++a) {
    std::copy(c.position[a].begin(), c.position[a].end(), position.mutable_data() + a * k);
    std::copy(c.cost[a].begin(), c.cost[a].end(), cost.mutable_data() + a * k);
    std::copy(c.left_count[a].begin(), c.left_count[a].end(), left.mutable_data() + a * k);
  }
  py::dict d;
  d["node"] = node;
  d["count"] = c.count;
  d["lo"] = py::array_t<float>(3, &c.bounds.lo[0]);
  d["hi"] = py::array_t<float>(3, &c.bounds.hi[0]);
  d["leaf_cost"] = c.leaf_cost;
  d["candidates"] = c.sorted ? "sorted" : "binned";
  d["positions"] = position;
  d["costs"] = cost;
  d["left_counts"] = left;
  d["method"] = split_method_name(c.method);
  d["axis"] = c.axis;
  d["position"] = c.position_chosen;
  d["candidate"] = c.candidate;
  d["cost"] = c.cost_chosen;
  d["left_triangles"] = array_of<uint32_t>(c.left_prims);
  return d;
}

py::dict story(const Structure& s, py::handle origin, py::handle direction, py::handle tmin, py::handle tmax) {
  const Ray ray = ray_from_arrays(origin, direction, tmin, tmax);
  RayStory st;
  {
    py::gil_scoped_release release;
    st = s.story(ray);
  }
  return story_to_dict(st);
}

// Closest hits plus each ray's status as an index into RAY_STATUSES.
py::dict statuses(const Structure& s, py::handle origins, py::handle directions, py::handle tmin, py::handle tmax,
                  py::handle threads) {
  return status_arrays(origins, directions, tmin, tmax, threads, true,
                       [&](const auto& rays, auto& hits, auto& status, int n_threads) {
                         intersect_with_status(s, rays, hits, status, n_threads);
                       });
}

}  // namespace

void bind_core(py::module_& m) {
  py::register_exception<BuildError>(m, "BuildError", PyExc_RuntimeError);

  m.def(
      "load_mesh", [](py::handle path) { return mesh_to_arrays(read_mesh_file(path_parameter(path, "path"))); },
      py::arg("path"), "Reads an OBJ file: ((V,3) float32 vertices, (T,3) uint32 triangles).");

  py::class_<Structure, StructurePtr>(m, "Structure", "An acceleration structure over one mesh (keeps it alive).")
      .def_property_readonly("structure", [](const Structure& s) { return structure_kind_name(s.kind()); })
      .def_property_readonly("build_seconds", &Structure::build_seconds)
      .def_property_readonly("memory_bytes", &Structure::memory_bytes)
      .def_property_readonly("triangle_count", [](const Structure& s) { return s.mesh().triangle_count(); })
      .def_property_readonly("vertex_count", [](const Structure& s) { return s.mesh().vertices.size(); })
      .def_property_readonly("max_depth", [](const Structure& s) { return max_depth_object(s.settings().max_depth); })
      .def_property_readonly("leaf_size", [](const Structure& s) { return s.settings().leaf_size; })
      .def_property_readonly("triangle_test",
                             [](const Structure& s) { return triangle_test_name(s.settings().triangle_test); })
      .def_property_readonly("contract", [](const Structure& s) { return contract_name(s.settings().contract); })
      .def_property_readonly("builder", [](const Structure& s) { return bvh_builder_name(s.settings().builder); })
      .def_property_readonly(
          "mesh", [](const Structure& s) { return mesh_to_arrays(s.mesh()); },
          "A copy of the mesh: (vertices, triangles).")
      .def("intersect", &intersect_rays<Structure>, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
           py::arg("tmax") = kNoLimit, py::arg("count") = false, py::arg("per_ray") = false,
           py::arg("threads") = py::none())
      .def("occluded", &occluded_rays<Structure>, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
           py::arg("tmax") = kNoLimit, py::arg("count") = false, py::arg("per_ray") = false,
           py::arg("threads") = py::none())
      .def(
          "refit",
          [](const Structure& s, py::handle vertices) -> StructurePtr {
            std::vector<glm::vec3> points = vertices_from_array(vertices);
            py::gil_scoped_release release;
            return refit_structure(s, std::move(points));
          },
          py::arg("vertices"))
      .def_property_readonly("refitted", &Structure::refitted)
      .def("sah_cost",
           [](const Structure& s) -> py::object {
             const std::optional<double> cost = structure_sah_cost(s);
             return cost ? py::object(py::float_(*cost)) : py::object(py::none());
           })
      .def("tree", &tree)
      .def("split_costs", &split_costs, py::arg("node"))
      .def("boxes", &boxes, py::arg("lines") = false, py::arg("depth_min") = 0, py::arg("depth_max") = py::none(),
           py::arg("leaves_only") = false, py::arg("palette") = py::none(), py::arg("fade") = false,
           py::arg("alpha_scale") = 1.0)
      .def("statuses", &statuses, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
           py::arg("tmax") = kNoLimit, py::arg("threads") = py::none())
      .def("story", &story, py::arg("origin"), py::arg("direction"), py::arg("tmin") = 0.0, py::arg("tmax") = kNoLimit);

  with_settings_keywords(
      [&](auto... keywords) {
        m.def(
            "build",
            [](py::handle vertices, py::handle triangles, py::handle structure, py::handle max_depth,
               py::handle leaf_size, py::handle triangle_test, py::handle contract, py::handle builder,
               py::handle memory_budget) {
              const BuildSettings settings = settings_from_arguments(structure, max_depth, leaf_size, triangle_test,
                                                                     contract, builder, memory_budget);
              return build(mesh_from_arrays(vertices, triangles), settings);
            },
            keywords...);
      },
      py::arg("vertices"), py::arg("triangles"));

  with_settings_keywords(
      [&](auto... keywords) {
        m.def(
            "build_file",
            [](py::handle path, py::handle structure, py::handle max_depth, py::handle leaf_size,
               py::handle triangle_test, py::handle contract, py::handle builder, py::handle memory_budget) {
              const std::string file = path_parameter(path, "path");
              const BuildSettings settings = settings_from_arguments(structure, max_depth, leaf_size, triangle_test,
                                                                     contract, builder, memory_budget);
              return build(std::make_shared<const TriangleMesh>(read_mesh_file(file)), settings);
            },
            keywords...);
      },
      py::arg("path"));

  bind_scene(m);
}

}  // namespace raylab::python
