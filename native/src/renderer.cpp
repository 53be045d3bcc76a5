#include "raylab/renderer.h"

#include "ray_offset.h"
#include "threads.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <glm/gtc/constants.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace raylab {

namespace {

// A limit as the messages print it: 1e+20, 1000.
std::string number(float x) {
  std::ostringstream out;
  out << x;
  return out.str();
}

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

bool finite(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c)
    if (!finite(glm::vec3(m[c])) || !std::isfinite(m[c][3])) return false;
  return true;
}

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument(what);
}

// Radiance and irradiance are kept within +-kRadianceLimit wherever they could grow without bound (a
// light nearer than floats resolve, the sum over lights): with the accepted material ranges every
// product below stays finite, so no inf, and no NaN from inf * 0 or inf - inf, reaches a pixel.
glm::vec3 bounded(const glm::dvec3& x) {
  const double limit = kRadianceLimit;
  return glm::vec3(glm::clamp(x, glm::dvec3(-limit), glm::dvec3(limit)));
}

// splitmix64: a per-pixel stream, so that a pixel's samples do not depend on the thread or tile
// order and every structure renders the same image bit for bit. The seed is the mixed pixel index:
// seeding with the index itself would make neighbours' streams the same stream shifted by one.
struct PixelRandom {
  uint64_t state;
  explicit PixelRandom(uint64_t pixel) : state(mix(pixel)) {}
  static uint64_t mix(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  float next() { return float(mix(state += 0x9E3779B97F4A7C15ull) >> 40) * 0x1p-24f; }  // [0, 1)
};

// Blender's spot cone (Cycles' spot_attenuation): zero outside the half angle, a smoothstep over the
// blend band inside it, and the cosine to the axis as Blender keeps it.
float spot_attenuation(float cos_to_axis, float spot_size, float spot_blend) {
  const float cos_half = std::cos(0.5f * spot_size);
  if (cos_to_axis <= cos_half) return 0.0f;
  const float smooth = (1.0f - cos_half) * spot_blend;
  const float t = cos_to_axis - cos_half;
  if (smooth > 0.0f && t < smooth) {
    const float x = t / smooth;
    return cos_to_axis * x * x * (3.0f - 2.0f * x);
  }
  return cos_to_axis;
}

// A light with its world placement worked out once.
struct PlacedLight {
  const Light* light;
  glm::vec3 position;
  glm::vec3 axis;  // the direction it shines (local -Z), unit
};

struct PlacedInstance {
  const TriangleMesh* mesh;
  const std::vector<glm::vec3>* shading_normals;  // 3 per triangle, object space; null: flat
  const Material* material;
  glm::mat4 transform;      // object to world
  glm::mat3 normal_matrix;  // inverse transpose of its linear part
};

// The cosine of the light direction `l` to the shading normal `n`, or 0 when the light is behind it,
// or behind the geometric normal `ng` unless `past_face` (a smooth hit whose shadow ray, from the
// shadow-terminator point, decides): a smooth normal leaning past its face must not let light through
// the face from behind.
float light_cosine(const glm::vec3& n, const glm::vec3& ng, const glm::vec3& l, bool past_face) {
  const float cos_n = glm::dot(n, l);
  return cos_n > 0.0f && (past_face || glm::dot(ng, l) > 0.0f) ? cos_n : 0.0f;
}

// The interpolated smooth normal at a hit, in world space, on the side of `nf` (the geometric normal
// facing the ray); `nf` itself for a flat mesh or a degenerate interpolation. `side` is -1 when the
// corner normals had to be turned to reach that side, else +1.
struct ShadingNormal {
  glm::vec3 n;
  float side = 1.0f;
};

ShadingNormal shading_normal(const PlacedInstance& inst, const Hit& hit, const glm::vec3& nf) {
  if (!inst.shading_normals) return {nf};
  const glm::vec3* corner = inst.shading_normals->data() + 3 * size_t(hit.triangle);
  glm::vec3 n = inst.normal_matrix * ((1.0f - hit.u - hit.v) * corner[0] + hit.u * corner[1] + hit.v * corner[2]);
  const float length = glm::length(n);
  if (!(length > 0.0f) || !std::isfinite(length)) return {nf};
  n /= length;
  return glm::dot(n, nf) < 0.0f ? ShadingNormal{-n, -1.0f} : ShadingNormal{n, 1.0f};
}

// Hanika 2021, "Hacking the shadow terminator": the hit point lifted onto the curved surface that
// the corner normals imply. Each corner's tangent plane takes the point; where it lies below that
// plane it is raised onto it, and the raised points are blended with the barycentrics. Only a
// convex corner raises: a point above a tangent plane stays. Of the lift only the height over the
// face, on the side the normals point to, is kept: normals leaning far from the face would otherwise
// slide the point along it, off the triangle, or (leaning past 90 degrees) sink it behind the face.
// Object space: an affine map keeps points on planes, so the world point is the transformed one.
// `side` (+1 or -1) turns the normals to the side of the face the ray came from.
glm::vec3 terminator_point(const glm::vec3 corner[3], const glm::vec3* normals, const float weight[3],
                           const glm::vec3& p, float side) {
  const glm::vec3 face = glm::cross(corner[1] - corner[0], corner[2] - corner[0]);
  const float face_length = glm::length(face);
  if (!(face_length > 0.0f)) return p;
  glm::vec3 lift(0.0f), normal_sum(0.0f);
  for (int i = 0; i < 3; ++i) {
    const float length = glm::length(normals[i]);
    if (!(length > 0.0f) || !std::isfinite(length)) continue;
    const glm::vec3 n = normals[i] / length * side;
    lift -= weight[i] * std::min(0.0f, glm::dot(p - corner[i], n)) * n;
    normal_sum += weight[i] * n;
  }
  glm::vec3 up = face / face_length;
  if (glm::dot(up, normal_sum) < 0.0f) up = -up;
  return p + std::max(0.0f, glm::dot(lift, up)) * up;
}

// One sample of a light at a hit, before its shadow ray is traced: a point, spot or sun light gives
// one, an area light one per sample that faces the hit. `e` is the irradiance it brings if nothing is
// in the way; `shadow` decides that, when `traced` (shadows on for the render and the light).
struct LightSample {
  glm::vec3 l;  // unit, towards the light
  glm::vec3 e;
  Ray shadow{};
  bool traced = false;
  float visible = 1.0f;  // what the shadow ray found: 1 or 0
};

// What shading a hit works out before its lights: its material, normals, points and weights.
struct ShadePoint {
  const Material* m;
  glm::vec3 d;         // the incoming ray's direction
  glm::vec3 nf;        // the geometric normal facing the incoming ray
  glm::vec3 ns;        // the shading normal
  glm::vec3 p;         // the hit point, world space
  glm::vec3 shadow_p;  // where shadow rays start (the terminator point of a smooth hit)
  glm::vec3 v;
  bool entering;    // against the winding's normal: from outside
  bool terminator;  // light in front of ns but behind nf counts
  float kr;
  glm::vec3 tint, diffuse;
};

// The pixels traced together: a block of up to kBlock x kBlock pixels of a tile, each of their samples'
// camera rays one batch and their hits' shadow rays one batch per light. A cancel waits for at most one
// such block per thread. The batch lists the block's pixels in sub-blocks of kPacketW x kPacketH, row by
// row, so that each BVH packet (8 consecutive rays) covers 4 x 2 pixels: faster than a tile row of 64
// pixels (docs/bench/history.md).
constexpr int kBlock = 8;
constexpr int kPacketW = 4, kPacketH = 2;

class Tracer {
 public:
  Tracer(const SceneSnapshot& scene, std::vector<PlacedInstance> instances, std::vector<PlacedLight> lights,
         const RenderSettings& settings)
      : scene_(scene), instances_(std::move(instances)), lights_(std::move(lights)), settings_(settings) {}

  glm::vec3 trace(const Ray& ray, int depth, RenderStats& stats, PixelRandom& random) const {
    Hit hit;
    if (!scene_.closest(ray, hit, &stats.traversal)) return settings_.background;
    return shade(ray, hit, depth, stats, random);
  }

  // A hit's colour, its shadow rays traced one at a time as they come.
  glm::vec3 shade(const Ray& ray, const Hit& hit, int depth, RenderStats& stats, PixelRandom& random) const;

  // shade() in steps, so that the renderer can trace the shadow rays of many hits together: the
  // shading point; each light's samples (drawing the area lights' random positions, in light order);
  // the lights' sum once their samples' `visible` are known; and the rest (reflection, refraction).
  ShadePoint surface(const Ray& ray, const Hit& hit) const;
  void light_samples(const PlacedLight& pl, const ShadePoint& sp, PixelRandom& random,
                     std::vector<LightSample>& out) const;
  // The lights' light with the samples of light i at samples[first[i], first[i + 1]).
  glm::vec3 lit(const ShadePoint& sp, const LightSample* samples, const size_t* first, glm::vec3& specular) const;
  glm::vec3 finish(const ShadePoint& sp, const glm::vec3& local, const glm::vec3& specular, int depth,
                   RenderStats& stats, PixelRandom& random) const;

  const std::vector<PlacedLight>& lights() const { return lights_; }

 private:
  glm::vec3 offset(const glm::vec3& p, const glm::vec3& n) const {
    return settings_.robust_offset ? offset_ray(p, n) : offset_ray_fixed(p, n, settings_.fixed_epsilon);
  }
  // A sample seen through the shadow ray from `origin` to the point `target` (on a light).
  void sample_to(const glm::vec3& origin, const glm::vec3& target, bool light_shadows, LightSample& s) const {
    const glm::vec3 to_target = target - origin;
    const float distance = glm::length(to_target);
    if (!(distance > 0.0f)) return;  // visible
    sample_along(origin, to_target / distance, distance, light_shadows, s);
  }
  // A sample seen through the shadow ray from `origin` to `origin + distance * direction`.
  void sample_along(const glm::vec3& origin, const glm::vec3& direction, float distance, bool light_shadows,
                    LightSample& s) const {
    if (!settings_.shadows || !light_shadows) return;  // visible
    s.traced = true;
    s.shadow.origin = origin;
    s.shadow.direction = direction;
    s.shadow.tmax = distance;
  }
  // Phong: Lambert's diffuse plus a normalised Phong lobe, lit by irradiance `e` (with the cosine)
  // arriving from unit direction `l`.
  glm::vec3 phong(const Material& m, const glm::vec3& diffuse, const glm::vec3& n, const glm::vec3& v,
                  const glm::vec3& l, const glm::vec3& e, glm::vec3& specular_out) const {
    const glm::vec3 r = glm::reflect(-l, n);
    const float cos_r = std::max(0.0f, glm::dot(r, v));
    const float lobe = m.specular * (m.shininess + 2.0f) * glm::one_over_two_pi<float>() * std::pow(cos_r, m.shininess);
    specular_out += lobe * e;
    return diffuse * glm::one_over_pi<float>() * e;
  }
  // One light's share, from its samples.
  glm::vec3 light_sum(const PlacedLight& pl, const ShadePoint& sp, const LightSample* samples, size_t count,
                      glm::vec3& specular) const;

  const SceneSnapshot& scene_;
  std::vector<PlacedInstance> instances_;
  std::vector<PlacedLight> lights_;
  const RenderSettings& settings_;
};

// Light falloff. Point, spot and area energies are Blender watts, radiated as a point of intensity
// energy / (4 pi) W/sr, so the irradiance at distance r is energy / (4 pi r^2) * cos(theta). With a
// Lambertian BRDF of albedo / pi this is Cycles' own scale: Blender's default scene (a 1000 W point
// light about 6 m from a 0.8 grey cube) gives radiance 0.3-0.4 on the lit faces, a well exposed
// picture with no extra factor. The sun's strength is irradiance: strength * cos(theta). An area
// light splits its energy over its samples, each radiating only forwards with an extra cosine.
// `ns` shades (the Phong terms); the geometric `nf` places the shadow rays and hides lights behind.
void Tracer::light_samples(const PlacedLight& pl, const ShadePoint& sp, PixelRandom& random,
                           std::vector<LightSample>& out) const {
  const Light& light = *pl.light;
  const glm::vec3 &p = sp.p, &n = sp.ns, &ng = sp.nf;
  // In double: colour times energy, over a squared distance of a denormal, stays finite there.
  const glm::dvec3 radiant = glm::dvec3(light.color) * double(light.energy);
  const glm::vec3 origin = offset(sp.shadow_p, ng);
  // Light behind the face reaches a smooth hit only through a shadow ray, which the face itself
  // stops where the shading normals lean past a flat surface: without one it stays out. (At the
  // boundary of an open smooth mesh the lifted ray can pass the edge: light from just behind the
  // last faces then reaches them, as it would reach the curved surface they stand for.)
  const bool past_face = sp.terminator && settings_.shadows && light.shadows;
  constexpr float kFourPi = 4.0f * glm::pi<float>();

  if (light.type == LightType::Sun) {
    const glm::vec3 l = -pl.axis;
    const float cos_n = light_cosine(n, ng, l, past_face);
    if (cos_n <= 0.0f) return;
    LightSample& s = out.emplace_back(LightSample{l, bounded(radiant * double(cos_n))});
    sample_along(origin, l, kInfinity, light.shadows, s);
    return;
  }
  if (light.type == LightType::Area) {
    const int k = light.samples;
    const glm::dvec3 per_sample = radiant / (double(k * k) * kFourPi);
    for (int i = 0; i < k; ++i)
      for (int j = 0; j < k; ++j) {
        const float sx = ((float(i) + random.next()) / float(k) - 0.5f) * light.size;
        const float sy = ((float(j) + random.next()) / float(k) - 0.5f) * light.size;
        const glm::vec3 q = glm::vec3(light.matrix_world * glm::vec4(sx, sy, 0.0f, 1.0f));
        const glm::vec3 to_light = q - p;
        const float r2 = glm::dot(to_light, to_light);
        if (!(r2 > 0.0f) || !std::isfinite(r2)) continue;  // on the light, or beyond float's range
        const float r = std::sqrt(r2);
        const glm::vec3 l = to_light / r;
        const float cos_n = light_cosine(n, ng, l, past_face), cos_light = glm::dot(pl.axis, -l);
        if (cos_n <= 0.0f || cos_light <= 0.0f) continue;
        LightSample& s = out.emplace_back(LightSample{l, bounded(per_sample * (double(cos_n) * cos_light / r2))});
        sample_to(origin, q, light.shadows, s);
      }
    return;
  }
  // Point and spot.
  const glm::vec3 to_light = pl.position - p;
  const float r2 = glm::dot(to_light, to_light);
  if (!(r2 > 0.0f) || !std::isfinite(r2)) return;  // on the light, or beyond float's range
  const float r = std::sqrt(r2);
  const glm::vec3 l = to_light / r;
  const float cos_n = light_cosine(n, ng, l, past_face);
  if (cos_n <= 0.0f) return;
  double factor = cos_n / (kFourPi * double(r2));
  if (light.type == LightType::Spot)
    factor *= spot_attenuation(glm::dot(pl.axis, -l), light.spot_size, light.spot_blend);
  if (factor <= 0.0f) return;
  // The shadow ray runs from its own start (the offset, maybe lifted point) to the light itself.
  LightSample& s = out.emplace_back(LightSample{l, bounded(radiant * factor)});
  sample_to(origin, pl.position, light.shadows, s);
}

glm::vec3 Tracer::light_sum(const PlacedLight& pl, const ShadePoint& sp, const LightSample* samples, size_t count,
                            glm::vec3& specular) const {
  const Material& m = *sp.m;
  if (pl.light->type != LightType::Area) {
    if (count == 0) return glm::vec3(0.0f);
    return phong(m, sp.diffuse, sp.ns, sp.v, samples[0].l, samples[0].e * samples[0].visible, specular);
  }
  glm::vec3 sum(0.0f);
  for (size_t i = 0; i < count; ++i)
    sum += phong(m, sp.diffuse, sp.ns, sp.v, samples[i].l, samples[i].e * samples[i].visible, specular);
  return sum;
}

ShadePoint Tracer::surface(const Ray& ray, const Hit& hit) const {
  const PlacedInstance& inst = instances_[hit.instance];
  const Material& m = *inst.material;
  const glm::uvec3 tri = inst.mesh->triangles[hit.triangle];
  const glm::vec3 a = inst.mesh->vertices[tri.x], b = inst.mesh->vertices[tri.y], c = inst.mesh->vertices[tri.z];
  ShadePoint sp;
  sp.m = &m;
  const glm::vec3 d = sp.d = ray.direction;
  glm::vec3 n = inst.normal_matrix * glm::cross(b - a, c - a);
  const float length = glm::length(n);
  n = length > 0.0f && std::isfinite(length) ? n / length : -d;
  sp.entering = glm::dot(n, d) < 0.0f;
  const glm::vec3 nf = sp.nf = sp.entering ? n : -n;
  // Smooth shading bends the Phong terms only; offsets, reflection and refraction stay geometric.
  const ShadingNormal smooth = shading_normal(inst, hit, nf);
  sp.ns = smooth.n;
  // The hit point from the barycentrics, not from origin + t * direction: its rounding error is then
  // relative to the point itself, as the integer-ulp offset assumes. From the ray, the error would be
  // relative to the ray's length and origin, and a far camera would sink points below a floor
  // through the origin by more than the offset lifts them.
  const float weight[3] = {1.0f - hit.u - hit.v, hit.u, hit.v};
  const glm::vec3 p_object = weight[0] * a + weight[1] * b + weight[2] * c;
  sp.p = glm::vec3(inst.transform * glm::vec4(p_object, 1.0f));
  sp.v = -d;
  // Smooth hits get the shadow-terminator point, with the corner normals turned as the shading
  // normal was, to the side of the face the ray came from.
  sp.terminator = settings_.shadow_terminator && inst.shading_normals != nullptr && sp.ns != nf;
  sp.shadow_p = sp.p;
  if (sp.terminator) {
    const glm::vec3 corner[3] = {a, b, c};
    const glm::vec3* normals = inst.shading_normals->data() + 3 * size_t(hit.triangle);
    sp.shadow_p =
        glm::vec3(inst.transform * glm::vec4(terminator_point(corner, normals, weight, p_object, smooth.side), 1.0f));
  }
  sp.kr = m.reflectivity + m.metallic * (1.0f - m.reflectivity);
  sp.tint = glm::mix(glm::vec3(1.0f), m.diffuse, m.metallic);
  sp.diffuse = m.diffuse * (1.0f - m.metallic);
  return sp;
}

glm::vec3 Tracer::lit(const ShadePoint& sp, const LightSample* samples, const size_t* first,
                      glm::vec3& specular) const {
  glm::vec3 local = bounded(double(sp.m->ambient) * glm::dvec3(settings_.ambient) * glm::dvec3(sp.diffuse));
  for (size_t i = 0; i < lights_.size(); ++i) {
    local = bounded(local + light_sum(lights_[i], sp, samples + first[i], first[i + 1] - first[i], specular));
    specular = bounded(specular);
  }
  return local;
}

glm::vec3 Tracer::shade(const Ray& ray, const Hit& hit, int depth, RenderStats& stats, PixelRandom& random) const {
  const ShadePoint sp = surface(ray, hit);
  // Reused by every shade() on this thread: its samples are done with before the recursion below.
  thread_local std::vector<LightSample> samples;
  thread_local std::vector<size_t> first;
  samples.clear();
  first.assign(1, 0);
  for (const PlacedLight& pl : lights_) {
    light_samples(pl, sp, random, samples);
    first.push_back(samples.size());
  }
  for (LightSample& s : samples)
    if (s.traced) {
      ++stats.rays_shadow;
      s.visible = scene_.any(s.shadow, &stats.traversal) ? 0.0f : 1.0f;
    }
  glm::vec3 specular(0.0f);
  const glm::vec3 local = lit(sp, samples.data(), first.data(), specular);
  return finish(sp, local, specular, depth, stats, random);
}

glm::vec3 Tracer::finish(const ShadePoint& sp, const glm::vec3& local, const glm::vec3& specular, int depth,
                         RenderStats& stats, PixelRandom& random) const {
  const Material& m = *sp.m;
  const glm::vec3 &d = sp.d, &nf = sp.nf, &v = sp.v, &p = sp.p;
  const float kr = sp.kr;
  const float t = m.transmission;
  glm::vec3 color = specular + (1.0f - t) * (1.0f - kr) * local;
  if (depth >= settings_.max_recursion) return bounded(color);

  // Fresnel splits the transmitted share into reflection and refraction; under total internal
  // reflection all of it reflects.
  float fresnel = 0.0f;
  glm::vec3 refracted;
  bool refracts = false;
  if (t > 0.0f) {
    const float n1 = sp.entering ? 1.0f : m.ior, n2 = sp.entering ? m.ior : 1.0f;
    fresnel = schlick_fresnel(glm::dot(v, nf), n1, n2);
    refracts = refract_direction(d, nf, n1 / n2, refracted);
    if (!refracts) fresnel = 1.0f;
  }
  const glm::vec3 reflect_weight = (1.0f - t) * kr * sp.tint + glm::vec3(t * fresnel);
  if (reflect_weight != glm::vec3(0.0f)) {
    ++stats.rays_reflection;
    Ray r;
    r.origin = offset(p, nf);
    r.direction = glm::reflect(d, nf);
    color += reflect_weight * trace(r, depth + 1, stats, random);
  }
  if (refracts && t * (1.0f - fresnel) > 0.0f) {
    ++stats.rays_refraction;
    Ray r;
    r.origin = offset(p, -nf);
    r.direction = refracted;
    color += t * (1.0f - fresnel) * trace(r, depth + 1, stats, random);
  }
  return bounded(color);
}

}  // namespace

float schlick_fresnel(float cos_incident, float n1, float n2) {
  float r0 = (n1 - n2) / (n1 + n2);
  r0 *= r0;
  float cos_theta = std::clamp(cos_incident, 0.0f, 1.0f);
  if (n1 > n2) {
    // Leaving the denser medium, Schlick's formula needs the transmitted angle.
    const float eta = n1 / n2;
    const float sin2_t = eta * eta * (1.0f - cos_theta * cos_theta);
    if (sin2_t >= 1.0f) return 1.0f;
    cos_theta = std::sqrt(1.0f - sin2_t);
  }
  const float x = 1.0f - cos_theta;
  return r0 + (1.0f - r0) * x * x * x * x * x;
}

bool refract_direction(const glm::vec3& incident, const glm::vec3& n, float eta, glm::vec3& out) {
  const float cos_i = -glm::dot(incident, n);
  const float k = 1.0f - eta * eta * (1.0f - cos_i * cos_i);
  if (k < 0.0f) return false;
  out = glm::normalize(eta * incident + (eta * cos_i - std::sqrt(k)) * n);
  return true;
}

void RenderSettings::validate() const {
  require(super_sampling >= 1 && super_sampling <= 4,
          "super_sampling must be 1 to 4, got " + std::to_string(super_sampling));
  require(max_recursion >= 0 && max_recursion <= 64,
          "max_recursion must be 0 to 64, got " + std::to_string(max_recursion));
  require(finite(background) && glm::all(glm::lessThanEqual(glm::abs(background), glm::vec3(kRadianceLimit))),
          "background must be finite, each component within +-" + number(kRadianceLimit));
  require(finite(ambient), "ambient must be finite");
  require(std::isfinite(fixed_epsilon) && fixed_epsilon >= 0.0f, "fixed_epsilon must be finite and >= 0");
  require(threads >= 0, "threads must be >= 0 (0: all cores), got " + std::to_string(threads));
  require(tile_size >= 1 && tile_size <= 4096, "tile_size must be 1 to 4096");
  require(memory_budget > 0, "memory_budget must be positive");
}

size_t render_buffer_bytes(int width, int height) {
  constexpr size_t per_pixel = 4 * sizeof(float) + sizeof(int32_t) + sizeof(float) + sizeof(TraversalStats);
  return size_t(width) * size_t(height) * per_pixel;
}

void require_render_memory(int width, int height, const RenderSettings& settings, size_t caller_bytes_per_pixel) {
  const size_t needed = render_buffer_bytes(width, height) + size_t(width) * size_t(height) * caller_bytes_per_pixel;
  require(needed <= settings.memory_budget,
          "width x height " + std::to_string(width) + " x " + std::to_string(height) + " at super_sampling " +
              std::to_string(settings.super_sampling) + " (whose samples take no memory) needs about " +
              std::to_string(needed) + " bytes, over the render's memory_budget of " +
              std::to_string(settings.memory_budget) + " bytes: lower the resolution or raise memory_budget");
}

void Material::validate() const {
  require(finite(diffuse) && glm::all(glm::lessThanEqual(glm::abs(diffuse), glm::vec3(kMaxDiffuse))),
          "diffuse must be finite, each component within +-" + number(kMaxDiffuse));
  require(specular >= 0.0f && specular <= kMaxSpecular, "specular must be 0 to " + number(kMaxSpecular));
  require(shininess >= 0.0f && shininess <= kMaxShininess, "shininess must be 0 to " + number(kMaxShininess));
  require(metallic >= 0.0f && metallic <= 1.0f, "metallic must be 0 to 1");
  require(reflectivity >= 0.0f && reflectivity <= 1.0f, "reflectivity must be 0 to 1");
  require(transmission >= 0.0f && transmission <= 1.0f, "transmission must be 0 to 1");
  require(ior >= kIorRange[0] && ior <= kIorRange[1],
          "ior must be " + number(kIorRange[0]) + " to " + number(kIorRange[1]));
  require(std::isfinite(ambient), "ambient must be finite");
}

void Light::validate() const {
  require(finite(color), "color must be finite");
  require(std::isfinite(energy), "energy must be finite");
  require(finite(matrix_world), "matrix_world has a NaN or infinite entry");
  require(glm::determinant(glm::mat3(matrix_world)) != 0.0f, "matrix_world is singular");
  require(std::isfinite(radius) && radius >= 0.0f, "radius must be finite and >= 0");
  require(spot_size > 0.0f && spot_size <= glm::pi<float>(), "spot_size must be in (0, pi]");
  require(spot_blend >= 0.0f && spot_blend <= 1.0f, "spot_blend must be 0 to 1");
  require(std::isfinite(size) && size > 0.0f, "size must be finite and > 0");
  require(samples >= 1 && samples <= 64, "samples must be 1 to 64");
}

RenderStats& RenderStats::operator+=(const RenderStats& o) {
  rays_primary += o.rays_primary;
  rays_shadow += o.rays_shadow;
  rays_reflection += o.rays_reflection;
  rays_refraction += o.rays_refraction;
  traversal += o.traversal;
  return *this;
}

RenderResult render(const Scene& scene, const CameraSettings& camera, std::span<const Light> lights,
                    std::span<const Material> materials, const RenderSettings& settings, RenderProgress* progress) {
  const SceneSnapshotPtr snapshot = scene.snapshot();  // every ray of the render sees this one state
  return render(*snapshot, camera, lights, materials, settings, progress);
}

RenderResult render(const SceneSnapshot& scene, const CameraSettings& camera_settings, std::span<const Light> lights,
                    std::span<const Material> materials, const RenderSettings& settings, RenderProgress* progress) {
  const auto start = std::chrono::steady_clock::now();
  settings.validate();
  const Camera camera(camera_settings);
  for (size_t i = 0; i < materials.size(); ++i) {
    try {
      materials[i].validate();
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("materials[" + std::to_string(i) + "]: " + e.what());
    }
  }
  std::vector<PlacedLight> placed_lights;
  for (size_t i = 0; i < lights.size(); ++i) {
    try {
      lights[i].validate();
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("lights[" + std::to_string(i) + "]: " + e.what());
    }
    const glm::mat4& m = lights[i].matrix_world;
    placed_lights.push_back({&lights[i], glm::vec3(m[3]), glm::normalize(glm::vec3(m * glm::vec4(0, 0, -1, 0)))});
  }
  std::vector<PlacedInstance> instances;
  for (uint32_t i = 0; i < scene.instance_count(); ++i) {
    const Instance& inst = scene.instance(i);
    require(inst.material < materials.size(), "instance " + std::to_string(i) + " uses material " +
                                                  std::to_string(inst.material) + " but " +
                                                  std::to_string(materials.size()) + " materials were given");
    instances.push_back({&scene.mesh(inst.mesh), scene.shading_normals(inst.mesh), &materials[inst.material],
                         inst.transform, glm::transpose(glm::inverse(glm::mat3(inst.transform)))});
  }
  const Tracer tracer(scene, std::move(instances), std::move(placed_lights), settings);

  const int w = camera.width(), h = camera.height();
  require_render_memory(w, h, settings);
  RenderResult result;
  result.width = w;
  result.height = h;
  result.image.assign(size_t(w) * h * 4, 0.0f);
  result.instance.assign(size_t(w) * h, -1);
  result.distance.assign(size_t(w) * h, kInfinity);
  result.pixel_work.assign(size_t(w) * h, TraversalStats{});

  const int ts = settings.tile_size;
  const int tiles_x = (w + ts - 1) / ts, tiles_y = (h + ts - 1) / ts;
  const int tiles = tiles_x * tiles_y;
  RenderProgress local_progress;
  RenderProgress& prog = progress ? *progress : local_progress;
  prog.pixels_done.store(0);
  prog.pixels_total.store(uint64_t(w) * h);
  std::atomic<bool> skipped{false};
  tbb::enumerable_thread_specific<RenderStats> per_thread;
  const int ss = settings.super_sampling;
  const bool centre_is_sample = ss % 2 == 1;

  // A tile is rendered a block of pixels at a time (kBlock), sample by sample: the block's camera rays
  // together, then the hits' shadow rays towards each light together (coherent batches:
  // SceneSnapshot::closest_batch and any_batch), then each hit's shading in pixel order, its reflection
  // and refraction rays one at a time. Each pixel draws its random stream in the order a pixel-by-pixel
  // render draws it, and every ray counts into its own pixel, so the image, the counters and the cost
  // buffers are those of settings.batches off (the same steps with every ray traced alone), and of a
  // render one pixel at a time (tile_size 1), bit for bit.
  struct BlockWork {
    std::vector<Ray> rays;
    std::vector<Hit> hits;
    std::vector<uint8_t> occluded;
    std::vector<TraversalStats> counts;
    std::vector<PixelRandom> random;
    std::vector<RenderStats> own;  // each pixel's work alone (its cost buffers)
    std::vector<TraversalStats> primary;
    std::vector<glm::vec3> sum;
    std::vector<Hit> camera_hits;
    std::vector<ShadePoint> points;
    std::vector<LightSample> samples;
    std::vector<size_t> first, base;  // pixel p's samples of light i: [first[base[p] + i], first[base[p] + i + 1])
    std::vector<uint32_t> owner, sample;
    std::vector<int> px, py;  // the batch's pixels
    size_t index(size_t p, int width) const { return size_t(py[p]) * size_t(width) + size_t(px[p]); }
  };
  tbb::enumerable_thread_specific<BlockWork> block_work;
  const size_t light_count = tracer.lights().size();
  const auto closest = [&](BlockWork& rw, bool counted) {
    const size_t n = rw.rays.size();
    rw.hits.assign(n, Hit{});
    if (counted) rw.counts.assign(n, TraversalStats{});
    if (settings.batches)
      return scene.closest_batch(rw.rays, rw.hits, counted ? rw.counts : std::span<TraversalStats>());
    for (size_t q = 0; q < n; ++q) scene.closest(rw.rays[q], rw.hits[q], counted ? &rw.counts[q] : nullptr);
  };
  const auto render_block = [&](BlockWork& rw) {
    const size_t n = rw.px.size();
    rw.random.clear();
    for (size_t p = 0; p < n; ++p) rw.random.emplace_back(rw.index(p, w));
    rw.own.assign(n, RenderStats{});
    rw.primary.assign(n, TraversalStats{});
    rw.sum.assign(n, glm::vec3(0.0f));
    rw.points.resize(n);
    rw.base.resize(n);
    for (int j = 0; j < ss; ++j)
      for (int i = 0; i < ss; ++i) {
        rw.rays.clear();
        for (size_t p = 0; p < n; ++p)
          rw.rays.push_back(camera.ray(float(rw.px[p]) + (float(i) + 0.5f) / float(ss),
                                       float(rw.py[p]) + (float(j) + 0.5f) / float(ss)));
        closest(rw, true);
        rw.camera_hits.swap(rw.hits);
        rw.samples.clear();
        rw.first.clear();
        for (size_t p = 0; p < n; ++p) {
          ++rw.own[p].rays_primary;
          rw.primary[p] += rw.counts[p];
          const Hit& hit = rw.camera_hits[p];
          if (!hit.valid()) continue;
          if (centre_is_sample && i == ss / 2 && j == ss / 2) {
            result.instance[rw.index(p, w)] = int32_t(hit.instance);
            result.distance[rw.index(p, w)] = hit.t;  // the direction has unit length
          }
          rw.points[p] = tracer.surface(rw.rays[p], hit);
          rw.base[p] = rw.first.size();
          rw.first.push_back(rw.samples.size());
          for (const PlacedLight& pl : tracer.lights()) {
            tracer.light_samples(pl, rw.points[p], rw.random[p], rw.samples);
            rw.first.push_back(rw.samples.size());
          }
        }
        for (size_t l = 0; l < light_count; ++l) {
          rw.rays.clear();
          rw.owner.clear();
          rw.sample.clear();
          for (size_t p = 0; p < n; ++p) {
            if (!rw.camera_hits[p].valid()) continue;
            for (size_t k = rw.first[rw.base[p] + l]; k < rw.first[rw.base[p] + l + 1]; ++k)
              if (rw.samples[k].traced) {
                rw.rays.push_back(rw.samples[k].shadow);
                rw.owner.push_back(uint32_t(p));
                rw.sample.push_back(uint32_t(k));
              }
          }
          const size_t m = rw.rays.size();
          if (m == 0) continue;
          rw.occluded.assign(m, 0);
          rw.counts.assign(m, TraversalStats{});
          if (settings.batches) {
            scene.any_batch(rw.rays, rw.occluded, rw.counts);
          } else {
            for (size_t q = 0; q < m; ++q) rw.occluded[q] = scene.any(rw.rays[q], &rw.counts[q]);
          }
          for (size_t q = 0; q < m; ++q) {
            rw.samples[rw.sample[q]].visible = rw.occluded[q] ? 0.0f : 1.0f;
            RenderStats& own = rw.own[rw.owner[q]];
            ++own.rays_shadow;
            own.traversal += rw.counts[q];
          }
        }
        for (size_t p = 0; p < n; ++p) {
          if (!rw.camera_hits[p].valid()) {
            rw.sum[p] += settings.background;
            continue;
          }
          glm::vec3 specular(0.0f);
          const glm::vec3 local = tracer.lit(rw.points[p], rw.samples.data(), &rw.first[rw.base[p]], specular);
          rw.sum[p] += tracer.finish(rw.points[p], local, specular, 0, rw.own[p], rw.random[p]);
        }
      }
    if (!centre_is_sample) {
      // The centre is no sample of an even grid: probe it apart, uncounted, as it is no render work.
      rw.rays.clear();
      for (size_t p = 0; p < n; ++p) rw.rays.push_back(camera.ray(float(rw.px[p]) + 0.5f, float(rw.py[p]) + 0.5f));
      closest(rw, false);
      for (size_t p = 0; p < n; ++p)
        if (rw.hits[p].valid()) {
          result.instance[rw.index(p, w)] = int32_t(rw.hits[p].instance);
          result.distance[rw.index(p, w)] = rw.hits[p].t;  // the direction has unit length
        }
    }
    for (size_t p = 0; p < n; ++p) {
      RenderStats& own = rw.own[p];
      own.traversal += rw.primary[p];
      result.pixel_work[rw.index(p, w)] = settings.cost_rays == CostRays::Primary ? rw.primary[p] : own.traversal;
      const glm::vec3 color = rw.sum[p] / float(ss * ss);
      float* out = &result.image[rw.index(p, w) * 4];
      out[0] = color.x;
      out[1] = color.y;
      out[2] = color.z;
      out[3] = 1.0f;
    }
  };

  const auto render_tile = [&](int tile) {
    RenderStats& stats = per_thread.local();
    BlockWork& rw = block_work.local();
    const int x0 = (tile % tiles_x) * ts, y0 = (tile / tiles_x) * ts;
    const int x1 = std::min(x0 + ts, w), y1 = std::min(y0 + ts, h);
    for (int by = y0; by < y1; by += kBlock)
      for (int bx = x0; bx < x1; bx += kBlock) {
        // Read before every block of pixels (a relaxed load costs nothing next to their rays), so that a
        // cancel stops a tile half-way; the pixels left keep their initial values.
        if (prog.cancel_requested.load(std::memory_order_relaxed)) {
          skipped.store(true, std::memory_order_relaxed);
          return;
        }
        const int ex = std::min(bx + kBlock, x1), ey = std::min(by + kBlock, y1);
        rw.px.clear();
        rw.py.clear();
        for (int sy = by; sy < ey; sy += kPacketH)
          for (int sx = bx; sx < ex; sx += kPacketW)
            for (int y = sy; y < std::min(sy + kPacketH, ey); ++y)
              for (int x = sx; x < std::min(sx + kPacketW, ex); ++x) {
                rw.px.push_back(x);
                rw.py.push_back(y);
              }
        render_block(rw);
        for (size_t p = 0; p < rw.px.size(); ++p) stats += rw.own[p];
        prog.pixels_done.fetch_add(uint64_t(rw.px.size()), std::memory_order_relaxed);
      }
  };
  const auto run = [&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, tiles, 1), [&](const tbb::blocked_range<int>& range) {
      for (int tile = range.begin(); tile != range.end(); ++tile) render_tile(tile);
    });
  };
  run_on_threads(settings.threads, run);

  RenderStats& stats = result.stats;
  for (const RenderStats& s : per_thread) stats += s;
  result.cancelled = skipped.load();
  stats.width = w;
  stats.height = h;
  stats.build_seconds = scene.build_seconds();
  stats.memory_bytes = scene.memory_bytes();
  stats.structure = scene.mesh_count() > 0 ? structure_kind_name(scene.structure(0).kind()) : "";
  stats.render_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace raylab
