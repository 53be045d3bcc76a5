// `grid`: a uniform grid of cells over the mesh's bounding box. A triangle is referenced by every cell
// it truly overlaps (separating-axis test, triangle_box_overlap.h), stored compactly: per cell an
// offset into one triangle-index array. Traversal is a 3D-DDA (Amanatides & Woo 1987) that walks the
// padded cells front to back and stops once the closest hit lies before the next cell's entry.
// The resolution follows pbrt-v1: about 3 * cbrt(N) cells along the longest axis, the other axes in
// proportion, each at least 1; max_depth and leaf_size do not apply. Built in src/grid.cpp.
// No multiple of cbrt(N) from 1 to 4 was clearly fastest, while memory grows as its cube: pbrt's 3 is
// kept, 1.5 to 2 are cheaper (docs/bench/history.md).
#pragma once

#include "box_intersection.h"
#include "raylab/structure.h"
#include "triangle_loop.h"

#include <algorithm>
#include <cmath>
#include <span>

namespace raylab {

class Grid final : public StructureBase<Grid> {
 public:
  // Limits that keep cell indices, and story ids (1 + cell index), in 32 bits.
  static constexpr int kMaxResolution = 1 << 20;
  static constexpr size_t kMaxCells = size_t(1) << 31;

  // Throws BuildError when not even a one-cell grid fits settings.memory_budget; below that the
  // resolution is lowered until the grid fits.
  Grid(MeshPtr mesh, const BuildSettings& settings);

  template <class Recorder>
  bool traverse_closest(const Ray& ray, Hit& hit, Recorder& record) const {
    return closest_over_leaves(*mesh_, settings_.triangle_test, ray, hit, record, [&](auto limit, auto visit) {
      walk(ray, record, limit, [&](uint32_t cell) { return visit(cell_triangles(cell)); });
    });
  }

  template <class Recorder>
  bool traverse_any(const Ray& ray, Recorder& record) const {
    return any_over_leaves(*mesh_, settings_.triangle_test, ray, record, [&](auto limit, auto visit) {
      walk(ray, record, limit, [&](uint32_t cell) { return visit(cell_triangles(cell)); });
    });
  }

  // The grid's bounds (depth 0, all triangles), then every non-empty cell in cell order (depth 1, a
  // leaf, its own triangles). Box ids in stories are 0 for the bounds and 1 + cell_index(cell).
  std::vector<BoxInfo> boxes() const override;
  // The offsets, the triangle-index array and the occupancy bits.
  size_t memory_bytes() const override;

  const Bounds& bounds() const { return bounds_; }
  glm::ivec3 resolution() const { return resolution_; }
  size_t cell_count() const { return size_t(resolution_.x) * size_t(resolution_.y) * size_t(resolution_.z); }
  uint32_t cell_index(const glm::ivec3& c) const {
    return uint32_t(c.x + size_t(resolution_.x) * (c.y + size_t(resolution_.y) * c.z));
  }
  // Cell i's boundary on `axis` (0 <= i <= resolution): build and traversal derive every cell from this
  // one function, so neighbouring cells share their planes bit for bit and tile the bounds exactly.
  // It is non-decreasing in i, plane(0) is bounds.lo and plane(resolution) is bounds.hi.
  float plane(int axis, int i) const {
    return i >= resolution_[axis] ? bounds_.hi[axis]
                                  : std::min(bounds_.hi[axis], bounds_.lo[axis] + float(i) * cell_size_[axis]);
  }
  Bounds cell_bounds(const glm::ivec3& c) const {
    return Bounds({plane(0, c.x), plane(1, c.y), plane(2, c.z)},
                  {plane(0, c.x + 1), plane(1, c.y + 1), plane(2, c.z + 1)});
  }
  bool occupied(uint32_t cell) const { return (occupied_[cell >> 6] >> (cell & 63u)) & 1u; }
  // The triangles of a cell, in ascending index order.
  std::span<const uint32_t> cell_triangles(uint32_t cell) const {
    return {triangles_.data() + offsets_[cell], offsets_[cell + 1] - offsets_[cell]};
  }

 private:
  // The cells a ray overlaps along one axis, as a window that slides along the ray: k counts cells in
  // the ray's direction (k = cell for a positive component, resolution - 1 - cell for a negative one).
  // Cell k joins the window at enter(k) and leaves it after leave(k); a zero component keeps a fixed
  // window. Both are computed with intersect_box's own expressions for the cell's slab, padded alike,
  // so the window holds at every t exactly the cells whose slab intersect_box would find there.
  struct AxisWindow {
    int axis, count, step;  // step: +1, -1, or 0 for a zero component
    int first, last;        // the window [first, last] in k; empty while first > last
    float t_enter;          // when k = last + 1 joins (infinity when none is left)
    float t_leave;          // when k = first leaves (infinity when none is left)
    int cell(int k) const { return step < 0 ? count - 1 - k : k; }
  };

  float slab_enter(const BoxRay& r, const AxisWindow& w, int k) const {
    const int a = w.axis, c = w.cell(k);
    // intersect_box's near distance: from the lower plane going up, from the upper one going down.
    return w.step > 0 ? ((plane(a, c) - r.origin[a]) - r.pad) * r.inv_dir[a]
                      : ((plane(a, c + 1) - r.origin[a]) + r.pad) * r.inv_dir[a];
  }
  float slab_leave(const BoxRay& r, const AxisWindow& w, int k) const {
    const int a = w.axis, c = w.cell(k);
    return (w.step > 0 ? ((plane(a, c + 1) - r.origin[a]) + r.pad) * r.inv_dir[a]
                       : ((plane(a, c) - r.origin[a]) - r.pad) * r.inv_dir[a]) *
           kBoxFarScale;
  }

  // The window of one axis at t, the padded grid's entry: the cells that joined at or before t and
  // do not leave before it. Both distances are non-decreasing in k, so a binary search finds them.
  AxisWindow start_window(const BoxRay& r, int axis, float t) const {
    AxisWindow w{axis, resolution_[axis], 0, 0, 0, kInfinity, kInfinity};
    const float inv = r.inv_dir[axis];
    if (inv == kInfinity) {  // a zero component: intersect_box's test of such a slab, without t
      const float o = r.origin[axis];
      w.first = count_while(w.count, [&](int c) { return !((plane(axis, c + 1) - o) + r.pad >= 0.0f); });
      w.last = count_while(w.count, [&](int c) { return (plane(axis, c) - o) - r.pad <= 0.0f; }) - 1;
      return w;
    }
    w.step = inv > 0.0f ? 1 : -1;
    w.first = count_while(w.count, [&](int k) { return slab_leave(r, w, k) < t; });
    w.last = count_while(w.count, [&](int k) { return slab_enter(r, w, k) <= t; }) - 1;
    w.t_enter = w.last + 1 < w.count ? slab_enter(r, w, w.last + 1) : kInfinity;
    w.t_leave = w.first < w.count ? slab_leave(r, w, w.first) : kInfinity;
    return w;
  }

  // The length of the prefix of 0..count-1 on which the monotone predicate holds.
  template <class Predicate>
  static int count_while(int count, Predicate holds) {
    int lo = 0, hi = count;
    while (lo < hi) {
      const int mid = lo + (hi - lo) / 2;
      if (holds(mid)) lo = mid + 1;
      else hi = mid;
    }
    return lo;
  }

  // Visits the non-empty cells of windows[0] x windows[1] x windows[2], with the window of axis
  // `fixed` narrowed to its newest cell (all three in full when fixed is -1): each gets its padded box
  // test, and a cell entered at or before limit() is visited. Returns true when visit_cell says stop.
  template <class Recorder, class Limit, class VisitCell>
  bool visit_cells(const AxisWindow (&windows)[3], int fixed, const BoxRay& box_ray, Recorder& record, Limit& limit,
                   VisitCell& visit_cell) const {
    int from[3], to[3];
    for (int a = 0; a < 3; ++a) {
      // A cell whose padded slab is empty (a zero-width cell at negative t: kBoxFarScale shrinks a
      // negative far distance) leaves before it joins; then nothing joined.
      from[a] = a == fixed ? std::max(windows[a].last, windows[a].first) : windows[a].first;
      to[a] = windows[a].last;
    }
    for (int kz = from[2]; kz <= to[2]; ++kz)
      for (int ky = from[1]; ky <= to[1]; ++ky)
        for (int kx = from[0]; kx <= to[0]; ++kx) {
          const glm::ivec3 c(windows[0].cell(kx), windows[1].cell(ky), windows[2].cell(kz));
          const uint32_t cell = cell_index(c);
          if (!occupied(cell)) continue;  // empty: nothing to test, no box test
          const Bounds box = cell_bounds(c);
          float t = box_ray.tmin;
          const bool hit = intersect_box(box, box_ray, limit(), t);
          record.box(cell + 1, box, 1, hit, t);
          if (!hit) continue;
          record.node(cell + 1, 1);
          if (visit_cell(cell)) return true;
        }
    return false;
  }

  // The walk both queries share. `limit()` is the far end of the search (the closest hit so far, or
  // ray.tmax); `visit_cell(cell)` tests a cell's triangles and returns true to stop.
  //
  // Exactness: a triangle the triangle test hits at t lies in a cell whose padded box the ray enters
  // at or before t (box_intersection.h), so it suffices to box-test every non-empty cell whose padded
  // box the ray can enter before limit(). The per-axis windows hold exactly the cells whose padded
  // slab contains t, computed with intersect_box's expressions, and their events are taken in order of
  // t (joins before leaves at equal t, the slabs being closed): a cell is proposed when the last of
  // its three slabs is entered, which is its entry distance. So the walk proposes cells front to back
  // by padded entry and stops at the first entry beyond limit(), never skipping a cell rounding lets
  // the ray touch: there is no separate DDA arithmetic to disagree with the box test.
  template <class Recorder, class Limit, class VisitCell>
  void walk(const Ray& ray, Recorder& record, Limit limit, VisitCell visit_cell) const {
    const BoxRay box_ray(ray, bounds_);
    float t_root;
    if (!enter_root(bounds_, !offsets_.empty(), box_ray, limit(), record, t_root)) return;
    // Every cell lies inside the bounds, so no cell is entered within [tmin, limit] before t_root.
    AxisWindow windows[3] = {start_window(box_ray, 0, t_root), start_window(box_ray, 1, t_root),
                             start_window(box_ray, 2, t_root)};
    if (visit_cells(windows, -1, box_ray, record, limit, visit_cell)) return;
    for (;;) {
      int join = 0, leave = 0;
      for (int a = 1; a < 3; ++a) {
        if (windows[a].t_enter < windows[join].t_enter) join = a;
        if (windows[a].t_leave < windows[leave].t_leave) leave = a;
      }
      AxisWindow& j = windows[join];
      AxisWindow& l = windows[leave];
      if (l.t_leave < j.t_enter) {
        ++l.first;
        l.t_leave = l.first < l.count ? slab_leave(box_ray, l, l.first) : kInfinity;
        if (l.first > l.last && l.t_enter == kInfinity) return;  // this axis has left the grid for good
        continue;
      }
      // No cell is left to enter, or the next one's padded entry lies beyond the search. (A cell
      // entered at an infinite distance, by overflow, cannot hold a hit: none has an infinite t.)
      if (j.t_enter == kInfinity || j.t_enter > limit()) return;
      ++j.last;
      j.t_enter = j.last + 1 < j.count ? slab_enter(box_ray, j, j.last + 1) : kInfinity;
      if (visit_cells(windows, join, box_ray, record, limit, visit_cell)) return;
    }
  }

  // The grid's memory for `cells` cells and `references` triangle references.
  static size_t bytes_needed(size_t cells, size_t references);
  // Fills the grid at `resolution`; false, holding nothing, when it would exceed the memory budget.
  bool build(const glm::ivec3& resolution);
  // The first and last cell along `axis` whose closed slab reaches [lo, hi].
  glm::ivec2 cell_span(int axis, float lo, float hi) const;
  template <class F>
  void for_each_overlapped_cell(uint32_t triangle, F f) const;

  Bounds bounds_;
  glm::ivec3 resolution_{0};
  glm::vec3 cell_size_{0.0f};
  std::vector<uint32_t> offsets_;    // per cell (x fastest, then y, then z) and one more: CSR offsets
  std::vector<uint32_t> triangles_;  // the cells' runs, one after another
  // Bit per cell: non-empty. The walk reads it for every cell it passes and the offsets only for the
  // non-empty ones: 1/32 of the offsets' size, it stays in cache where the offsets miss (the offsets
  // check took most of the walk's time on large meshes: docs/bench/history.md).
  std::vector<uint64_t> occupied_;
};

std::unique_ptr<Structure> build_grid(MeshPtr mesh, const BuildSettings& settings);

}  // namespace raylab
