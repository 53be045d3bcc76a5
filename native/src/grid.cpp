#include "grid.h"

#include "triangle_box_overlap.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <bit>
#include <cmath>
#include <numeric>

namespace raylab {

namespace {

// pbrt-v1's rule (GridAccel): 3 * cbrt(N) cells along the longest axis and as many per unit length
// along the others, rounded, at least 1 per axis. A flat axis gets 1 cell.
glm::ivec3 pbrt_resolution(const glm::vec3& extent, size_t triangle_count) {
  const float longest = std::max({extent.x, extent.y, extent.z});
  if (!(longest > 0.0f)) return glm::ivec3(1);
  const double per_unit = 3.0 * std::cbrt(double(triangle_count)) / double(longest);
  glm::ivec3 r;
  for (int a = 0; a < 3; ++a)
    r[a] = int(std::clamp(std::round(double(extent[a]) * per_unit), 1.0, double(Grid::kMaxResolution)));
  return r;
}

size_t cells_of(const glm::ivec3& r) { return size_t(r.x) * size_t(r.y) * size_t(r.z); }

// Every axis scaled by `factor` (rounded down, at least 1): a coarser grid.
glm::ivec3 coarser(const glm::ivec3& r, double factor) {
  glm::ivec3 out;
  for (int a = 0; a < 3; ++a) out[a] = std::max(1, int(std::floor(r[a] * factor)));
  return out;
}

std::string bytes_text(size_t bytes) { return std::to_string(bytes) + " bytes"; }

}  // namespace

// The grid's memory: one offset per cell and one more, one index per triangle reference, a bit per cell.
size_t Grid::bytes_needed(size_t cells, size_t references) {
  return (cells + 1 + references) * sizeof(uint32_t) + (cells + 63) / 64 * sizeof(uint64_t);
}

Grid::Grid(MeshPtr mesh, const BuildSettings& settings) : StructureBase(std::move(mesh), settings) {
  // settings.max_depth and settings.leaf_size are the octree's and the BVH's: a grid's only
  // parameter, its resolution, follows from the triangle count.
  const size_t n = mesh_->triangle_count();
  if (n == 0) return;
  const size_t budget = settings_.memory_budget;
  // Every triangle is referenced at least once, however coarse the grid.
  if (bytes_needed(1, n) > budget)
    throw BuildError("grid build would need at least " + bytes_text(bytes_needed(1, n)) +
                     " for the references of its " + std::to_string(n) + " triangles, more than the memory budget of " +
                     bytes_text(budget));
  bounds_ = mesh_->bounds();
  glm::ivec3 r = pbrt_resolution(bounds_.extent(), n);
  // The offsets alone must leave room for one reference per triangle.
  while (cells_of(r) > 1 && (bytes_needed(cells_of(r), n) > budget || cells_of(r) >= kMaxCells)) r = coarser(r, 0.9);
  // A grid whose references overflow the budget is retried coarser: fewer, larger cells hold fewer
  // references, down to one reference per triangle in a single cell, which fits (checked above).
  while (!build(r) && cells_of(r) > 1) r = coarser(r, 0.8);
  if (offsets_.empty())
    throw BuildError("grid build would need more than the memory budget of " + bytes_text(budget) +
                     " even as one cell");
}

// The cells along `axis` whose closed slab reaches [lo, hi]: the first whose upper plane is >= lo, the
// last whose lower plane is <= hi. A guess from the cell size, then exact against plane().
glm::ivec2 Grid::cell_span(int axis, float lo, float hi) const {
  const int n = resolution_[axis];
  auto guess = [&](float x) {
    const float f = (x - bounds_.lo[axis]) / cell_size_[axis];  // NaN or inf for a flat axis: n is 1
    return f >= float(n) ? n - 1 : f > 0.0f ? int(f) : 0;
  };
  int first = guess(lo);
  while (first > 0 && plane(axis, first) >= lo) --first;
  while (first < n - 1 && plane(axis, first + 1) < lo) ++first;
  int last = guess(hi);
  while (last < n - 1 && plane(axis, last + 1) <= hi) ++last;
  while (last > 0 && plane(axis, last) > hi) --last;
  return {first, last};
}

// Calls f(cell) for every cell triangle `t` overlaps, by the separating-axis test on the cells its
// bounds reach, in blocks of 2 x 2 x 2 cells that share most of the test's work (the box face normals
// are decided by the span itself). A triangle whose bounds reach a single cell lies in it: the cells
// tile the bounds.
template <class F>
void Grid::for_each_overlapped_cell(uint32_t t, F f) const {
  const glm::vec3 a = mesh_->vertex(t, 0), b = mesh_->vertex(t, 1), c = mesh_->vertex(t, 2);
  const glm::vec3 lo = glm::min(a, glm::min(b, c)), hi = glm::max(a, glm::max(b, c));
  glm::ivec2 span[3];
  for (int axis = 0; axis < 3; ++axis) span[axis] = cell_span(axis, lo[axis], hi[axis]);
  if (span[0].x == span[0].y && span[1].x == span[1].y && span[2].x == span[2].y) {
    f(cell_index({span[0].x, span[1].x, span[2].x}));
    return;
  }
  for (int z = span[2].x; z <= span[2].y; z += 2)
    for (int y = span[1].x; y <= span[1].y; y += 2)
      for (int x = span[0].x; x <= span[0].y; x += 2) {
        const glm::ivec3 base(x, y, z);
        glm::dvec3 planes[3];
        uint32_t cells = 0xff;
        for (int axis = 0; axis < 3; ++axis) {
          const int i = base[axis];
          const bool two = i + 1 <= span[axis].y;  // the block's upper half along `axis` is in the span
          planes[0][axis] = plane(axis, i);
          planes[1][axis] = plane(axis, i + 1);
          planes[2][axis] = plane(axis, two ? i + 2 : i + 1);
          if (!two) cells &= ~(axis == 0 ? 0xaau : axis == 1 ? 0xccu : 0xf0u);
        }
        for (uint32_t m = detail::triangle_grid_overlaps(planes, a, b, c, cells); m != 0; m &= m - 1) {
          const int i = std::countr_zero(m);
          f(cell_index(base + glm::ivec3(i & 1, (i >> 1) & 1, (i >> 2) & 1)));
        }
      }
}

// Counting sort in parallel: count each cell's references, place the cells' runs by a running sum,
// fill them (each cell's offset serves as its cursor, then moves back), and sort each run, so the
// grid is the same on every run. Returns false, holding nothing, when the grid would need more than
// the memory budget.
bool Grid::build(const glm::ivec3& resolution) {
  const uint32_t n = uint32_t(mesh_->triangle_count());
  resolution_ = resolution;
  cell_size_ = bounds_.extent() / glm::vec3(resolution);
  const size_t cells = cells_of(resolution);
  offsets_.assign(cells + 1, 0u);
  std::atomic<uint64_t> references{0};
  auto for_triangles = [&](auto body) {
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 256), [&](const tbb::blocked_range<uint32_t>& range) {
      for (uint32_t t = range.begin(); t != range.end(); ++t) body(t);
    });
  };
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 256), [&](const tbb::blocked_range<uint32_t>& range) {
    uint64_t count = 0;
    for (uint32_t t = range.begin(); t != range.end(); ++t)
      for_each_overlapped_cell(t, [&](uint32_t cell) {
        std::atomic_ref<uint32_t>(offsets_[cell]).fetch_add(1, std::memory_order_relaxed);
        ++count;
      });
    references.fetch_add(count, std::memory_order_relaxed);
  });
  const uint64_t total = references.load();
  if (total > 0xffffffffu || bytes_needed(cells, total) > settings_.memory_budget) {
    std::vector<uint32_t>().swap(offsets_);  // give the memory back: the next try is within the budget
    return false;
  }
  std::exclusive_scan(offsets_.begin(), offsets_.end(), offsets_.begin(), 0u);
  triangles_.assign(total, 0u);
  for_triangles([&](uint32_t t) {
    for_each_overlapped_cell(t, [&](uint32_t cell) {
      triangles_[std::atomic_ref<uint32_t>(offsets_[cell]).fetch_add(1, std::memory_order_relaxed)] = t;
    });
  });
  // Each offset now holds its cell's end, the next cell's start.
  std::copy_backward(offsets_.begin(), offsets_.end() - 1, offsets_.end());
  offsets_[0] = 0;
  occupied_.assign((cells + 63) / 64, 0u);
  // Blocks of whole 64-cell words, so that no two tasks write the same word.
  tbb::parallel_for(tbb::blocked_range<size_t>(0, occupied_.size(), 64), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t cell = range.begin() * 64; cell != std::min(cells, range.end() * 64); ++cell) {
      std::sort(triangles_.begin() + offsets_[cell], triangles_.begin() + offsets_[cell + 1]);
      if (offsets_[cell] != offsets_[cell + 1]) occupied_[cell >> 6] |= uint64_t(1) << (cell & 63);
    }
  });
  return true;
}

std::vector<BoxInfo> Grid::boxes() const {
  if (offsets_.empty()) return {};
  std::vector<BoxInfo> out = {{bounds_, 0, false, uint32_t(mesh_->triangle_count())}};
  for (int z = 0; z < resolution_.z; ++z)
    for (int y = 0; y < resolution_.y; ++y)
      for (int x = 0; x < resolution_.x; ++x) {
        const uint32_t cell = cell_index({x, y, z});
        const uint32_t count = offsets_[cell + 1] - offsets_[cell];
        if (count != 0) out.push_back({cell_bounds({x, y, z}), 1, true, count});
      }
  return out;
}

size_t Grid::memory_bytes() const {
  return (offsets_.capacity() + triangles_.capacity()) * sizeof(uint32_t) + occupied_.capacity() * sizeof(uint64_t);
}

std::unique_ptr<Structure> build_grid(MeshPtr mesh, const BuildSettings& settings) {
  return std::make_unique<Grid>(std::move(mesh), settings);
}

}  // namespace raylab
