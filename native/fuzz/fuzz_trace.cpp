// libFuzzer over build and trace: the bytes become a few triangles (float coordinates taken bit for bit,
// so denormals, huge values and exact repeats all occur), build settings and rays. Every structure must
// return brute force's closest hit and any-hit answer, and never a hit at a t outside (tmin, tmax] or not
// finite; a refused build is fine.
#include "raylab/structure.h"

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <vector>

namespace {

class Bytes {
 public:
  Bytes(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  bool empty() const { return at_ >= size_; }
  uint8_t byte() { return at_ < size_ ? data_[at_++] : 0; }
  float number() {
    // Half the time a small integer grid (exact shared edges and vertices), else raw float bits.
    if (byte() & 1) return float(int(byte()) - 128) / 16.0f;
    uint32_t bits = 0;
    for (int i = 0; i < 4; ++i) bits = bits << 8 | byte();
    float f;
    std::memcpy(&f, &bits, 4);
    return f;
  }

 private:
  const uint8_t* data_;
  size_t size_, at_ = 0;
};

bool same(const raylab::Hit& a, bool hit_a, const raylab::Hit& b, bool hit_b) {
  if (hit_a != hit_b) return false;
  if (!hit_a) return true;
  return a.t == b.t || (a.triangle == b.triangle && std::fabs(a.t - b.t) <= 1e-5f * std::fabs(b.t));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Bytes in(data, size);
  auto mesh = std::make_shared<raylab::TriangleMesh>();
  const int triangles = 1 + in.byte() % 12;
  for (int i = 0; i < 3 * triangles; ++i) mesh->vertices.push_back({in.number(), in.number(), in.number()});
  for (int i = 0; i < triangles; ++i) mesh->triangles.push_back({3 * i, 3 * i + 1, 3 * i + 2});
  raylab::BuildSettings settings;
  settings.max_depth = in.byte() % 8;
  settings.leaf_size = 1 + in.byte() % 8;
  settings.triangle_test = (in.byte() & 1) ? raylab::TriangleTest::MollerTrumbore : raylab::TriangleTest::Watertight;
  std::vector<std::unique_ptr<raylab::Structure>> structures;
  try {
    for (const raylab::StructureInfo& kind : raylab::structure_kinds()) {
      settings.kind = kind.kind;
      structures.push_back(raylab::build_structure(mesh, settings));
    }
  } catch (const std::exception&) {
    return 0;  // refused (non-finite or too large coordinates, budget): the contract
  }
  while (!in.empty()) {
    raylab::Ray ray;
    ray.origin = {in.number(), in.number(), in.number()};
    ray.direction = {in.number(), in.number(), in.number()};
    ray.tmin = std::fabs(in.number());
    ray.tmax = (in.byte() & 3) ? INFINITY : std::fabs(in.number());
    if (!(ray.tmin <= ray.tmax) || !std::isfinite(ray.tmin)) continue;
    bool finite = true;
    for (int c = 0; c < 3; ++c) finite = finite && std::isfinite(ray.origin[c]) && std::isfinite(ray.direction[c]);
    if (!finite || (ray.direction.x == 0 && ray.direction.y == 0 && ray.direction.z == 0)) continue;
    raylab::Hit reference;
    const bool hit = structures[0]->closest(ray, reference);
    if (hit && !(std::isfinite(reference.t) && reference.t > ray.tmin && reference.t <= ray.tmax)) std::abort();
    const bool any = structures[0]->any(ray);
    for (size_t s = 1; s < structures.size(); ++s) {
      raylab::Hit h;
      const bool got = structures[s]->closest(ray, h);
      if (!same(h, got, reference, hit)) std::abort();
      if (structures[s]->any(ray) != any) std::abort();
    }
  }
  return 0;
}
