// The BVH's builders, once: the bindings parse and print their names and export the table to Python
// (_raylab.BUILDERS), where the add-on's Builder menu, the benchmark's builders experiment and the
// tests read it. Every builder makes a binary tree over the same primitive boxes (bvh_build.h), which
// the BVH collapses and walks the same way: they differ only in where they split, so in cost.
#pragma once

#include "raylab/named_table.h"

#include <string>

namespace raylab {

enum class BvhBuilder { Sah, Median, SpatialMedian, Lbvh };

struct BvhBuilderInfo {
  BvhBuilder builder;
  const char* name;
  const char* label;
  const char* description;
};

inline constexpr BvhBuilderInfo kBvhBuilders[] = {
    {BvhBuilder::Sah, "sah", "Binned SAH",
     "The surface area heuristic over 16 bins per axis (every split for nodes of 16 or fewer): each node "
     "splits where the expected cost of a ray is least, or stays a leaf when that is cheaper"},
    {BvhBuilder::Median, "median", "Object median",
     "Half of the triangles on each side, by centroid along the longest axis of the centroids' box"},
    {BvhBuilder::SpatialMedian, "spatial_median", "Spatial median",
     "The plane through the middle of the centroids' box along its longest axis, whatever the triangles "
     "on either side"},
    {BvhBuilder::Lbvh, "lbvh", "LBVH (Morton)",
     "Triangles sorted along a Morton curve (10 bits per axis) and split where the highest bit of their codes "
     "changes: the GPU builders' linear BVH"},
};

inline const char* bvh_builder_name(BvhBuilder b) { return name_in(kBvhBuilders, &BvhBuilderInfo::builder, b); }

// Throws std::invalid_argument listing the known names.
inline BvhBuilder bvh_builder_from_name(const std::string& name) {
  return value_in(kBvhBuilders, &BvhBuilderInfo::builder, name, "builder");
}

}  // namespace raylab
