#include "hostile_rays.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace raylab::bench {

const char* hostile_kind_name(HostileKind kind) {
  switch (kind) {
    case HostileKind::Vertex: return "vertex";
    case HostileKind::Edge: return "edge";
    case HostileKind::Grazing: return "grazing";
    case HostileKind::HairToward: return "hair_toward";
    case HostileKind::HairAway: return "hair_away";
    case HostileKind::TmaxPast: return "tmax_past";
    case HostileKind::TmaxShort: return "tmax_short";
  }
  return "?";
}

namespace {

double magnitude(const glm::dvec3& p) { return std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}); }

// Three draws as a vector, drawn z first. C++ leaves the order of a call's arguments open: x86-64 GCC
// evaluates glm::dvec3(draw(), draw(), draw()) last argument first, arm64 GCC first argument first. A
// fixed order, x86's, gives every architecture the rays the benchmarks and tests were measured with.
template <class Draw>
glm::dvec3 draw_dvec3(Draw&& draw) {
  const double z = draw(), y = draw(), x = draw();
  return {x, y, z};
}

// A unit vector perpendicular to n.
glm::dvec3 perpendicular(const glm::dvec3& n) {
  const glm::dvec3 a = std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  return glm::normalize(glm::cross(n, a));
}

}  // namespace

HostileRays hostile_rays(const TriangleMesh& mesh, size_t count, uint32_t seed) {
  std::vector<uint32_t> usable;  // triangles with an area: a degenerate one has no inside to aim at
  for (uint32_t t = 0; t < mesh.triangle_count(); ++t) {
    const glm::dvec3 a = mesh.vertex(t, 0), b = mesh.vertex(t, 1), c = mesh.vertex(t, 2);
    if (glm::length(glm::cross(b - a, c - a)) > 0.0) usable.push_back(t);
  }
  if (usable.empty()) throw std::invalid_argument("hostile rays: the mesh has no triangle with an area");
  const Bounds box = mesh.bounds();
  const glm::dvec3 lo = box.lo, extent = box.extent();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<size_t> pick(0, usable.size() - 1);
  auto in_box = [&] { return lo + draw_dvec3([&] { return unit(rng); }) * extent; };
  HostileRays out;
  out.rays.reserve(count);
  for (size_t i = 0; i < count; ++i) {
    const HostileKind kind = HostileKind(i % kHostileKinds);
    const uint32_t t = usable[pick(rng)];
    const glm::dvec3 p[3] = {mesh.vertex(t, 0), mesh.vertex(t, 1), mesh.vertex(t, 2)};
    const glm::dvec3 n = glm::normalize(glm::cross(p[1] - p[0], p[2] - p[0]));
    const double size = std::max({glm::length(p[1] - p[0]), glm::length(p[2] - p[1]), glm::length(p[0] - p[2])});
    // A point well inside: barycentrics at least 0.1 each.
    double b1 = 0.1 + 0.8 * unit(rng), b2 = 0.1 + 0.8 * unit(rng);
    if (b1 + b2 > 0.9) b1 = 1.0 - b1, b2 = 1.0 - b2;
    b1 = std::clamp(b1, 0.1, 0.8), b2 = std::clamp(b2, 0.1, 0.9 - b1);
    const glm::dvec3 inside = p[0] + b1 * (p[1] - p[0]) + b2 * (p[2] - p[0]);
    const int corner = int(unit(rng) * 3) % 3;
    glm::dvec3 origin, target = inside;
    double tmax = INFINITY;
    switch (kind) {
      case HostileKind::Vertex: origin = in_box(), target = p[corner]; break;
      case HostileKind::Edge: {
        const double s = unit(rng);
        origin = in_box(), target = glm::dvec3(glm::vec3(p[corner] + s * (p[(corner + 1) % 3] - p[corner])));
        break;
      }
      case HostileKind::Grazing: {
        const double cosine = std::pow(10.0, -5.0 + 3.0 * unit(rng));  // 1e-5 .. 1e-2
        const glm::dvec3 along = perpendicular(n);
        const double side = unit(rng) < 0.5 ? -1.0 : 1.0;
        origin = inside - 4.0 * size * (along - side * cosine * n);
        break;
      }
      case HostileKind::HairToward:
      case HostileKind::HairAway: {
        // A float step of the coordinates here is magnitude * 2^-23; the hair is 1 to 100 of them.
        const double hair = magnitude(inside) * std::ldexp(1.0, -23) * std::pow(10.0, 2.0 * unit(rng));
        const double side = unit(rng) < 0.5 ? -1.0 : 1.0;  // either face of the triangle
        origin = inside + side * std::max(hair, 1e-30) * n;
        if (kind == HostileKind::HairAway) {
          glm::dvec3 d;
          do d = draw_dvec3([&] { return unit(rng); }) * 2.0 - 1.0;
          while (glm::length(d) > 1.0 || glm::length(d) < 1e-3);
          d = glm::normalize(d);
          if (glm::dot(d, n) * side < 0.0) d = -d;  // away from the surface it starts above
          target = origin + d * size;
        }
        break;
      }
      case HostileKind::TmaxPast:
      case HostileKind::TmaxShort: origin = in_box(); break;
    }
    Ray r;
    r.origin = glm::vec3(origin);
    r.direction = glm::vec3(glm::normalize(target - glm::dvec3(r.origin)));
    if (kind == HostileKind::TmaxPast || kind == HostileKind::TmaxShort) {
      // The hit's t on the float ray, in double: along the direction as stored.
      const glm::dvec3 d = r.direction, o = r.origin;
      const double hit = glm::dot(n, p[0] - o) / glm::dot(n, d);
      tmax = hit * (kind == HostileKind::TmaxPast ? 1.0 + 1e-6 : 1.0 - 1e-6);
      if (!(tmax > 0.0)) tmax = INFINITY;  // the origin lay on the triangle's plane: an ordinary ray
    }
    r.tmax = float(tmax);
    out.rays.push_back(r);
    out.target.push_back(t);
    out.kind.push_back(kind);
  }
  return out;
}

}  // namespace raylab::bench
