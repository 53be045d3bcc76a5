// Single-ray stories and per-ray statuses as dicts of numpy arrays: a structure's story (object
// space) and a scene's (its top level in world space, then each queried instance's own story).
#include "core_arrays.h"

#include "raylab/scene_snapshot.h"

namespace raylab::python {

namespace {

py::dict boxes_to_dict(const std::vector<StoryBox>& boxes) {
  py::dict d;
  put_bounds(d, boxes);
  d["depth"] = column<int32_t>(boxes, [](const StoryBox& b) { return b.depth; });
  d["hit"] = column<bool>(boxes, [](const StoryBox& b) { return b.hit; });
  d["t_entry"] = column<float>(boxes, [](const StoryBox& b) { return b.hit ? b.t_entry : kInfinity; });
  d["node"] = column<int32_t>(boxes, [](const StoryBox& b) { return b.node; });
  return d;
}

// t, triangle, u, v and the point on `ray` (the space the hit was found in); None on a miss.
py::object hit_to_dict(const Hit& h, const Ray& ray) {
  if (!h.valid()) return py::none();
  py::dict hit;
  hit["t"] = h.t;
  hit["triangle"] = int32_t(h.triangle);
  hit["u"] = h.u;
  hit["v"] = h.v;
  const glm::vec3 point = ray.at(h.t);
  hit["point"] = py::array_t<float>(3, &point.x);
  return hit;
}

}  // namespace

py::dict story_to_dict(const RayStory& st) {
  py::dict d;
  d["status"] = ray_status_name(st.status);
  d["boxes"] = boxes_to_dict(st.boxes);
  d["nodes"] = column<int32_t>(st.nodes, [](const StoryNode& n) { return n.node; });
  d["node_depths"] = column<int32_t>(st.nodes, [](const StoryNode& n) { return n.depth; });
  d["triangles"] = column<int32_t>(st.triangles, [](const StoryTriangle& t) { return t.triangle; });
  d["triangle_hits"] = column<bool>(st.triangles, [](const StoryTriangle& t) { return t.hit; });
  d["hit"] = hit_to_dict(st.hit, st.ray);
  d["stats"] = stats_to_dict(st.stats);
  return d;
}

py::dict scene_story_to_dict(const SceneStory& st, const SceneSnapshot& scene) {
  py::dict d;
  d["status"] = ray_status_name(st.status);
  d["top_boxes"] = boxes_to_dict(st.top_boxes);
  d["top_nodes"] = column<int32_t>(st.top_nodes, [](const StoryNode& n) { return n.node; });
  py::list parts;
  for (const SceneStory::Part& part : st.instances) {
    const Instance& inst = scene.instance(part.instance);
    py::dict p;
    p["instance"] = part.instance;
    p["mesh"] = inst.mesh;
    p["matrix"] = matrix_to_array(inst.transform);
    p["story"] = story_to_dict(part.story);
    parts.append(p);
  }
  d["instances"] = parts;
  py::object hit = hit_to_dict(st.hit, st.ray);
  if (!hit.is_none()) hit["instance"] = int32_t(st.hit.instance);
  d["hit"] = hit;
  d["stats"] = stats_to_dict(st.stats);
  return d;
}

py::dict statuses_to_dict(const std::vector<Hit>& hits, const std::vector<RayStatus>& statuses, bool single_instance) {
  py::dict d = hits_to_dict(hits, single_instance);
  d["status"] = column<int8_t>(statuses, [](RayStatus r) { return int8_t(r); });
  return d;
}

}  // namespace raylab::python
