#include "core_arrays.h"

#include "raylab/huge_array.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace raylab::python {

namespace {

using FloatRows = Contiguous<float>;

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

py::array as_array(py::handle obj, const char* what) {
  if (obj.is_none()) throw std::invalid_argument(std::string(what) + " must be an array, got None");
  py::array a = py::array::ensure(obj);  // a null handle when numpy cannot make an array of it
  if (!a) throw std::invalid_argument(std::string(what) + " cannot be read as a numpy array");
  return a;
}

char dtype_kind(const py::array& a) { return a.dtype().kind(); }

// Accepts float, signed and unsigned integer dtypes (converted to float32); rejects bool, complex,
// object and strings. `single_row_ok` also accepts a (3,) array.
FloatRows float_rows(py::handle obj, const char* what, bool single_row_ok) {
  py::array a = as_array(obj, what);
  const bool rows = a.ndim() == 2 && a.shape(1) == 3;
  const bool single = single_row_ok && a.ndim() == 1 && a.shape(0) == 3;
  if (!rows && !single)
    throw std::invalid_argument(std::string(what) + " must have shape (N, 3)" + (single_row_ok ? " or (3,)" : "") +
                                ", got " + shape_text(a));
  require_real_dtype(a, what);
  return converted<float>(a, what);
}

template <class Index>
void read_triangles(const py::array& a, std::vector<glm::uvec3>& out) {
  auto idx = converted<Index>(a, "triangles");
  const Index* p = idx.data();
  const size_t n = size_t(idx.shape(0));
  out.resize(n);
  for (size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      const Index k = p[3 * i + c];
      if constexpr (std::is_signed_v<Index>)
        if (k < 0)
          throw std::invalid_argument("triangle " + std::to_string(i) + " has a negative vertex index " +
                                      std::to_string(k));
      // Larger than any uint32 index: out of range whatever the vertex count; say so before narrowing.
      if (uint64_t(k) >= uint64_t(kInvalidIndex))
        throw std::invalid_argument("triangle " + std::to_string(i) + " refers to vertex " + std::to_string(k) +
                                    ", beyond any mesh");
      out[i][c] = uint32_t(k);
    }
}

void check_ray_row(const float* p, size_t ray, const char* what) {
  if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
    throw std::invalid_argument(std::string(what) + " of ray " + std::to_string(ray) +
                                " has a NaN or infinite coordinate");
}

void check_interval(double tmin, double tmax) {
  if (std::isnan(tmin) || std::isnan(tmax)) throw std::invalid_argument("tmin and tmax must not be NaN");
  if (tmin > tmax)
    throw std::invalid_argument("tmin (" + std::to_string(tmin) + ") is greater than tmax (" + std::to_string(tmax) +
                                ")");
}

}  // namespace

std::vector<glm::vec3> vertices_from_array(py::handle vertices) {
  FloatRows v = float_rows(vertices, "vertices", false);
  const float* p = v.data();
  std::vector<glm::vec3> out(size_t(v.shape(0)));
  for (size_t i = 0; i < out.size(); ++i) out[i] = {p[3 * i], p[3 * i + 1], p[3 * i + 2]};
  return out;
}

MeshPtr mesh_from_arrays(py::handle vertices, py::handle triangles) {
  std::vector<glm::vec3> points = vertices_from_array(vertices);
  py::array t = as_array(triangles, "triangles");
  if (!(t.ndim() == 2 && t.shape(1) == 3))
    throw std::invalid_argument("triangles must have shape (T, 3), got " + shape_text(t));
  const char k = dtype_kind(t);
  if (k != 'i' && k != 'u')
    throw std::invalid_argument("triangles must have an integer dtype (uint32 preferred), got " +
                                std::string(py::str(t.dtype())));

  auto mesh = std::make_shared<TriangleMesh>();
  mesh->vertices = std::move(points);
  if (k == 'u') read_triangles<uint64_t>(t, mesh->triangles);
  else read_triangles<int64_t>(t, mesh->triangles);
  mesh->validate();
  return mesh;
}

namespace {

// "a, b or c": the names of a vocabulary table, for a parameter error.
template <class Table>
std::string names_of(const Table& table) {
  std::string out;
  size_t k = 0;
  for (const auto& row : table) {
    out += (k == 0 ? "" : k + 1 == std::size(table) ? " or " : ", ") + std::string(row.name);
    ++k;
  }
  return out;
}

// "auto" or a whole number: BuildSettings::max_depth (its range is validate()'s).
int max_depth_parameter(py::handle value) {
  const std::string accepted = "'" + std::string(BuildSettings::kAutoDepthName) + "' or an integer";
  if (py::isinstance<py::str>(value)) {
    if (value.cast<std::string>() == BuildSettings::kAutoDepthName) return BuildSettings::kAutoDepth;
    throw std::invalid_argument("max_depth must be " + accepted + ", got " + describe(value));
  }
  const int depth = int32_parameter(value, "max_depth");
  // -1 is kAutoDepth inside; from Python only the name means auto.
  if (depth == BuildSettings::kAutoDepth) BuildSettings::refuse_negative_depth(depth);
  return depth;
}

}  // namespace

BuildSettings settings_from_arguments(py::handle structure, py::handle max_depth, py::handle leaf_size,
                                      py::handle triangle_test_name, py::handle contract, py::handle builder,
                                      py::handle memory_budget) {
  BuildSettings s;
  static const std::string structures = names_of(structure_kinds()), tests = names_of(kTriangleTests),
                           contracts = names_of(kContracts), builders = names_of(kBvhBuilders);
  s.kind = structure_kind_from_name(str_parameter(structure, "structure", structures.c_str()));
  s.max_depth = max_depth_parameter(max_depth);
  s.leaf_size = int32_parameter(leaf_size, "leaf_size");
  s.triangle_test = triangle_test_from_name(str_parameter(triangle_test_name, "triangle_test", tests.c_str()));
  s.contract = contract_from_name(str_parameter(contract, "contract", contracts.c_str()));
  s.builder = bvh_builder_from_name(str_parameter(builder, "builder", builders.c_str()));
  if (!memory_budget.is_none()) s.memory_budget = memory_budget_parameter(memory_budget, "memory_budget", true);
  return s;  // validated where it enters the core: build_structure, the Scene
}

RayArrays ray_arrays(py::handle origins, py::handle directions, py::handle tmin_value, py::handle tmax_value) {
  const double tmin = number_parameter(tmin_value, "tmin"), tmax = number_parameter(tmax_value, "tmax");
  check_interval(tmin, tmax);
  RayArrays a{float_rows(origins, "origins", true), float_rows(directions, "directions", true), {}};
  const FloatRows &o = a.origins, &d = a.directions;
  const size_t no = o.ndim() == 2 ? size_t(o.shape(0)) : 1;
  const size_t nd = d.ndim() == 2 ? size_t(d.shape(0)) : 1;
  if (o.ndim() == 2 && d.ndim() == 2 && no != nd)
    throw std::invalid_argument("origins and directions differ in length: " + std::to_string(no) + " and " +
                                std::to_string(nd));
  // A (3,) row is shared by every ray: stride 0.
  a.rows.origins = o.data();
  a.rows.origin_stride = o.ndim() == 2 ? 3 : 0;
  a.rows.directions = d.data();
  a.rows.direction_stride = d.ndim() == 2 ? 3 : 0;
  a.rows.tmin = float(tmin);
  a.rows.tmax = float(tmax);
  a.rows.count = o.ndim() == 2 ? no : nd;
  return a;
}

void refuse_ray(const RayRows& rows, size_t i) {
  check_ray_row(rows.origin(i), i, "origin");
  check_ray_row(rows.direction(i), i, "direction");
  throw std::invalid_argument("direction of ray " + std::to_string(i) + " has zero length");
}

std::vector<Ray> rays_from_arrays(py::handle origins, py::handle directions, py::handle tmin_value,
                                  py::handle tmax_value) {
  const RayArrays a = ray_arrays(origins, directions, tmin_value, tmax_value);
  std::vector<Ray> rays(a.rows.count);
  for (size_t i = 0; i < rays.size(); ++i) {
    if (!a.rows.usable(i)) refuse_ray(a.rows, i);
    rays[i] = a.rows.ray(i);
  }
  return rays;
}

void require_real_dtype(const py::array& a, const std::string& what) {
  if (!real_dtype(a))
    throw std::invalid_argument(what + " must have a real number dtype (float32 preferred), got " +
                                std::string(py::str(a.dtype())));
}

Ray ray_from_arrays(py::handle origin, py::handle direction, py::handle tmin_value, py::handle tmax_value) {
  const double tmin = number_parameter(tmin_value, "tmin"), tmax = number_parameter(tmax_value, "tmax");
  check_interval(tmin, tmax);
  FloatRows o = float_rows(origin, "origin", true);
  FloatRows d = float_rows(direction, "direction", true);
  if (o.ndim() != 1 || d.ndim() != 1)
    throw std::invalid_argument("origin and direction of one ray must have shape (3,)");
  const RayRows row{o.data(), 0, d.data(), 0, float(tmin), float(tmax), 1};
  if (!row.usable(0)) refuse_ray(row, 0);
  return row.ray(0);
}

py::dict hit_columns(size_t n, bool single_instance, HitColumns& out) {
  // t, u, v, triangle, instance (4 bytes a row each), then hit (1 byte), each column on a cache line.
  const auto rounded = [](size_t bytes) { return (bytes + 63) / 64 * 64; };
  const size_t column = rounded(4 * n);
  unsigned char* p = static_cast<unsigned char*>(allocate_huge(5 * column + rounded(n)));
  const py::capsule owner(p, [](void* q) { std::free(q); });
  out.t = reinterpret_cast<float*>(p);
  out.u = reinterpret_cast<float*>(p + column);
  out.v = reinterpret_cast<float*>(p + 2 * column);
  out.triangle = reinterpret_cast<int32_t*>(p + 3 * column);
  out.instance = reinterpret_cast<int32_t*>(p + 4 * column);
  out.hit = reinterpret_cast<bool*>(p + 5 * column);
  out.single_instance = single_instance;
  const py::ssize_t rows = py::ssize_t(n);
  py::dict d;
  d["t"] = py::array_t<float>(rows, out.t, owner);
  d["triangle"] = py::array_t<int32_t>(rows, out.triangle, owner);
  d["u"] = py::array_t<float>(rows, out.u, owner);
  d["v"] = py::array_t<float>(rows, out.v, owner);
  d["instance"] = py::array_t<int32_t>(rows, out.instance, owner);
  d["hit"] = py::array_t<bool>(rows, out.hit, owner);
  return d;
}

py::dict hits_to_dict(const std::vector<Hit>& hits, bool single_instance) {
  HitColumns out;
  py::dict d = hit_columns(hits.size(), single_instance, out);
  write_hits(out, 0, hits);
  return d;
}

py::dict occlusion_to_dict(const std::vector<uint8_t>& occluded) {
  py::array_t<bool> hit(py::ssize_t(occluded.size()));
  bool* p = hit.mutable_data();
  for (size_t i = 0; i < occluded.size(); ++i) p[i] = occluded[i] != 0;
  py::dict d;
  d["hit"] = hit;
  return d;
}

py::array_t<float> matrix_to_array(const glm::mat4& m) {
  py::array_t<float> a({py::ssize_t(4), py::ssize_t(4)});
  float* p = a.mutable_data();
  for (int row = 0; row < 4; ++row)
    for (int col = 0; col < 4; ++col) p[4 * row + col] = m[col][row];
  return a;
}

py::dict stats_to_dict(const TraversalStats& s) {
  py::dict d;
  for (const CounterInfo& c : kCounters) d[c.name] = s.*c.field;
  return d;
}

py::dict per_ray_to_dict(std::span<const TraversalStats> per_ray) {
  py::dict d;
  for (const CounterInfo& c : kCounters) {
    py::array_t<uint32_t> a(py::ssize_t(per_ray.size()));
    uint32_t* p = a.mutable_data();
    for (size_t i = 0; i < per_ray.size(); ++i) {
      const uint64_t n = per_ray[i].*c.field;
      if (n > std::numeric_limits<uint32_t>::max())
        throw py::value_error(std::string("per_ray: ray ") + std::to_string(i) + " counted " + std::to_string(n) + " " +
                              c.name + ", beyond uint32; use count=True for totals");
      p[i] = uint32_t(n);
    }
    d[c.name] = a;
  }
  return d;
}

}  // namespace raylab::python
