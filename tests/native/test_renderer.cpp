#include "ray_offset.h"
#include "raylab/camera.h"
#include "raylab/renderer.h"
#include "raylab/scene.h"
#include "raylab/triangle_intersection.h"
#include "support.h"

#include <gtest/gtest.h>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <random>
#include <thread>

using namespace raylab;

namespace {

// Slope of a camera-space direction: x / -z and y / -z.
glm::vec2 slope(const Ray& r) { return {r.direction.x / -r.direction.z, r.direction.y / -r.direction.z}; }

CameraSettings camera_of(int w, int h) {
  CameraSettings c;
  c.resolution_x = w;
  c.resolution_y = h;
  return c;
}

}  // namespace

TEST(Camera, CentreRayOfDefaultCameraLooksDownMinusZ) {
  const Camera cam(camera_of(1920, 1080));
  const Ray r = cam.ray(960.0f, 540.0f);
  EXPECT_EQ(r.origin, glm::vec3(0.0f));
  EXPECT_NEAR(r.direction.x, 0.0f, 1e-7f);
  EXPECT_NEAR(r.direction.y, 0.0f, 1e-7f);
  EXPECT_FLOAT_EQ(r.direction.z, -1.0f);
  EXPECT_FLOAT_EQ(r.tmin, 0.1f);
  EXPECT_FLOAT_EQ(r.tmax, 1000.0f);
}

TEST(Camera, CentreRayFollowsMatrixWorld) {
  CameraSettings s = camera_of(64, 48);
  // Blender's default camera orientation, moved: local -Z turned to world -Y... by a rotation about X.
  s.matrix_world = glm::translate(glm::mat4(1.0f), glm::vec3(1, 2, 3)) *
                   glm::rotate(glm::mat4(1.0f), glm::half_pi<float>(), glm::vec3(1, 0, 0));
  const Ray r = Camera(s).ray(32.0f, 24.0f);
  EXPECT_NEAR(glm::distance(r.origin, glm::vec3(1, 2, 3)), 0.0f, 1e-6f);
  EXPECT_NEAR(glm::distance(r.direction, glm::vec3(0, 1, 0)), 0.0f, 1e-6f);
  // The top row of the picture is towards the camera's +Y, which the rotation turned to +Z.
  EXPECT_GT(Camera(s).ray(32.0f, 0.0f).direction.z, 0.0f);
}

TEST(Camera, SensorFitAutoPutsSensorWidthAcrossTheLargerDimension) {
  // 36 mm over a 50 mm lens: the fitted dimension spans slopes -0.36..0.36.
  const Camera landscape(camera_of(1920, 1080));
  EXPECT_NEAR(slope(landscape.ray(1920.0f, 540.0f)).x, 0.36f, 1e-6f);
  EXPECT_NEAR(slope(landscape.ray(960.0f, 0.0f)).y, 0.36f * 1080.0f / 1920.0f, 1e-6f);
  const Camera portrait(camera_of(1080, 1920));
  EXPECT_NEAR(slope(portrait.ray(540.0f, 0.0f)).y, 0.36f, 1e-6f);
  EXPECT_NEAR(slope(portrait.ray(1080.0f, 960.0f)).x, 0.36f * 1080.0f / 1920.0f, 1e-6f);
}

TEST(Camera, SensorFitHorizontalAndVertical) {
  CameraSettings s = camera_of(1080, 1920);
  s.sensor_fit = SensorFit::Horizontal;
  EXPECT_NEAR(slope(Camera(s).ray(1080.0f, 960.0f)).x, 0.36f, 1e-6f);
  s = camera_of(1920, 1080);
  s.sensor_fit = SensorFit::Vertical;  // sensor_height (24 mm) across y
  EXPECT_NEAR(slope(Camera(s).ray(960.0f, 0.0f)).y, 0.24f, 1e-6f);
  EXPECT_NEAR(slope(Camera(s).ray(1920.0f, 540.0f)).x, 0.24f * 1920.0f / 1080.0f, 1e-5f);
}

TEST(Camera, ShiftIsAFractionOfTheLargerDimension) {
  for (auto [w, h] : {std::pair{1920, 1080}, std::pair{1080, 1920}}) {
    CameraSettings s = camera_of(w, h);
    s.shift_x = 0.5f;
    s.shift_y = 0.25f;
    const glm::vec2 centre = slope(Camera(s).ray(0.5f * w, 0.5f * h));
    EXPECT_NEAR(centre.x, 0.5f * 0.72f, 1e-6f) << w << "x" << h;
    EXPECT_NEAR(centre.y, 0.25f * 0.72f, 1e-6f) << w << "x" << h;
  }
}

TEST(Camera, ResolutionPercentageScalesThePicture) {
  CameraSettings s = camera_of(1920, 1080);
  s.resolution_percentage = 50;
  const Camera cam(s);
  EXPECT_EQ(cam.width(), 960);
  EXPECT_EQ(cam.height(), 540);
  EXPECT_NEAR(slope(cam.ray(960.0f, 270.0f)).x, 0.36f, 1e-6f);
}

TEST(Camera, OrthographicRaysAreParallelAndSpanOrthoScale) {
  CameraSettings s = camera_of(200, 100);
  s.type = CameraType::Orthographic;
  s.ortho_scale = 7.0f;
  const Camera cam(s);
  const Ray a = cam.ray(0.0f, 0.0f), b = cam.ray(200.0f, 100.0f), c = cam.ray(100.0f, 50.0f);
  EXPECT_EQ(a.direction, glm::vec3(0, 0, -1));
  EXPECT_EQ(b.direction, a.direction);
  EXPECT_EQ(c.direction, a.direction);
  EXPECT_NEAR(b.origin.x - a.origin.x, 7.0f, 1e-5f);
  EXPECT_NEAR(a.origin.y - b.origin.y, 3.5f, 1e-5f);
  EXPECT_NEAR(glm::length(c.origin), 0.0f, 1e-6f);
}

TEST(Camera, InvalidSettingsThrow) {
  CameraSettings s = camera_of(0, 10);
  EXPECT_THROW(Camera{s}, std::invalid_argument);
  s = camera_of(10, 10);
  s.lens = 0.0f;
  EXPECT_THROW(Camera{s}, std::invalid_argument);
}

// A point on a random triangle at `scale`, offset along its normal, must lie strictly on the normal's
// side of the triangle's plane (decided in double), and a ray leaving from it must not hit the triangle.
TEST(RayOffset, OffsetPointIsOnTheNormalsSideAtEveryScale) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f), bary(0.0f, 1.0f);
  for (double scale = 1e-3; scale <= 1e6; scale *= 10.0) {
    int below = 0, rehit = 0;
    for (int trial = 0; trial < 2000; ++trial) {
      const glm::vec3 centre = float(scale) * glm::vec3(unit(rng), unit(rng), unit(rng)) * 4.0f;
      const glm::vec3 p0 = centre + float(scale) * glm::vec3(unit(rng), unit(rng), unit(rng));
      const glm::vec3 p1 = centre + float(scale) * glm::vec3(unit(rng), unit(rng), unit(rng));
      const glm::vec3 p2 = centre + float(scale) * glm::vec3(unit(rng), unit(rng), unit(rng));
      const glm::dvec3 nd = glm::cross(glm::dvec3(p1) - glm::dvec3(p0), glm::dvec3(p2) - glm::dvec3(p0));
      if (glm::length(nd) < 1e-3 * scale * scale) continue;  // nearly degenerate
      const glm::vec3 n = glm::vec3(glm::normalize(nd));
      float u = bary(rng), v = bary(rng);
      if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
      const glm::vec3 p = p0 + u * (p1 - p0) + v * (p2 - p0);  // rounded: a few ulps off the plane
      const glm::vec3 o = offset_ray(p, n);
      if (glm::dot(glm::dvec3(o) - glm::dvec3(p0), glm::normalize(nd)) <= 0.0) ++below;
      Ray r;
      r.origin = o;
      r.direction = glm::normalize(n + 0.9f * glm::vec3(unit(rng), unit(rng), unit(rng)));
      if (glm::dot(r.direction, n) <= 0.05f) continue;
      TriangleHit hit;
      if (intersect_watertight(WatertightRay(r), p0, p1, p2, 0.0f, kInfinity, hit)) ++rehit;
    }
    EXPECT_EQ(below, 0) << "scale " << scale;
    EXPECT_EQ(rehit, 0) << "scale " << scale;
  }
}

TEST(RayOffset, FixedEpsilonVanishesAtLargeCoordinates) {
  // Why the robust offset exists: 1e-4 is far below one ulp of 1e6 (0.0625).
  const glm::vec3 p(1e6f, 1e6f, 1e6f), n(0, 0, 1);
  EXPECT_EQ(offset_ray_fixed(p, n, 1e-4f), p);
  EXPECT_GT(offset_ray(p, n).z, p.z);
}

TEST(Fresnel, SchlickAtNormalAndGrazingIncidence) {
  EXPECT_NEAR(schlick_fresnel(1.0f, 1.0f, 1.5f), 0.04f, 1e-6f);
  EXPECT_NEAR(schlick_fresnel(0.0f, 1.0f, 1.5f), 1.0f, 1e-6f);
  EXPECT_LT(schlick_fresnel(0.7f, 1.0f, 1.5f), schlick_fresnel(0.3f, 1.0f, 1.5f));
}

TEST(Fresnel, TotalInternalReflectionBeyondTheCriticalAngle) {
  // From glass (1.5) into air the critical angle is asin(1/1.5) = 41.8 degrees.
  const glm::vec3 n(0, 0, 1);
  const float beyond = glm::radians(45.0f), within = glm::radians(30.0f);
  glm::vec3 out;
  EXPECT_FALSE(refract_direction(glm::vec3(std::sin(beyond), 0, -std::cos(beyond)), n, 1.5f, out));
  EXPECT_EQ(schlick_fresnel(std::cos(beyond), 1.5f, 1.0f), 1.0f);
  ASSERT_TRUE(refract_direction(glm::vec3(std::sin(within), 0, -std::cos(within)), n, 1.5f, out));
  EXPECT_NEAR(1.5f * std::sin(within), std::sqrt(out.x * out.x + out.y * out.y), 1e-5f);  // Snell
  EXPECT_LT(out.z, 0.0f);
  EXPECT_LT(schlick_fresnel(std::cos(within), 1.5f, 1.0f), 1.0f);
}

namespace {

MeshPtr quad(float half, float z) {
  auto m = std::make_shared<TriangleMesh>();
  m->vertices = {{-half, -half, z}, {half, -half, z}, {half, half, z}, {-half, half, z}};
  m->triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

// A 2x2 floor at z = 0 seen from straight above, lit by a point light at height 3.
struct FloorScene {
  Scene scene;
  CameraSettings camera;
  std::vector<Light> lights{1};
  std::vector<Material> materials{1};
  RenderSettings settings;

  FloorScene() {
    scene.add_instance(scene.add_mesh(quad(1.0f, 0.0f)), glm::mat4(1.0f));
    camera = camera_of(32, 32);
    camera.type = CameraType::Orthographic;
    camera.ortho_scale = 4.0f;  // the floor fills the middle half of the picture
    camera.matrix_world = glm::translate(glm::mat4(1.0f), glm::vec3(0, 0, 5));
    lights[0].matrix_world = glm::translate(glm::mat4(1.0f), glm::vec3(0, 0, 3));
    materials[0].specular = 0.0f;
    materials[0].ambient = 0.0f;
    settings.background = glm::vec3(0.25f, 0.5f, 0.75f);
  }
  void add_occluder() {  // a small square at height 1.5 over the floor's centre
    scene.add_instance(scene.add_mesh(quad(0.25f, 1.5f)), glm::mat4(1.0f));
  }
  RenderResult run() {
    scene.commit();
    return render(scene, camera, lights, materials, settings);
  }
};

glm::vec3 pixel(const RenderResult& r, int x, int y) {
  const float* p = &r.image[(size_t(y) * r.width + x) * 4];
  return {p[0], p[1], p[2]};
}

}  // namespace

TEST(Renderer, OneFloorIsLitAsThePointLightFalloffSays) {
  FloorScene f;
  const RenderResult r = f.run();
  ASSERT_EQ(r.width, 32);
  ASSERT_FALSE(r.cancelled);
  // Pixel (16, 16) is centred on floor point (0.0625, -0.0625, 0): irradiance E = P cos / (4 pi r^2).
  const glm::vec3 p(0.0625f, -0.0625f, 0.0f), light(0, 0, 3);
  const float r2 = glm::dot(light - p, light - p);
  const float e = 1000.0f * (3.0f / std::sqrt(r2)) / (4.0f * glm::pi<float>() * r2);
  EXPECT_NEAR(pixel(r, 16, 16).x, 0.8f * e / glm::pi<float>(), 1e-4f);
  EXPECT_EQ(r.image[(16 * 32 + 16) * 4 + 3], 1.0f);
  EXPECT_EQ(r.instance[16 * 32 + 16], 0);
  EXPECT_NEAR(r.distance[16 * 32 + 16], 5.0f, 1e-5f);
  // Outside the floor: the background, no instance.
  EXPECT_EQ(pixel(r, 1, 1), f.settings.background);
  EXPECT_EQ(r.instance[1 * 32 + 1], -1);
  EXPECT_EQ(r.stats.rays_primary, 32u * 32u);
  EXPECT_EQ(r.stats.rays_shadow, 16u * 16u);  // one per floor pixel
  EXPECT_EQ(r.stats.structure, "bvh");
}

TEST(Renderer, OccluderCastsAShadowOnlyWithShadowsOn) {
  FloorScene f;
  f.add_occluder();
  f.materials[0].ambient = 0.1f;
  // Pixels are 0.125 wide, pixel x centred at -2 + (x + 0.5) / 8. The camera looks straight down, so
  // the occluder (|x| <= 0.25) covers pixels 14..17; its shadow, cast from the light at twice its
  // height, covers |x| <= 0.5 on the floor. Pixel 12 (x = -0.44) is in the shadow beside the occluder.
  const RenderResult shadowed = f.run();
  const glm::vec3 ambient_only = 0.1f * 0.8f * f.settings.ambient;
  EXPECT_NEAR(pixel(shadowed, 12, 16).x, ambient_only.x, 1e-6f);
  EXPECT_GT(pixel(shadowed, 10, 16).x, 2.0f * ambient_only.x);  // x = -0.69: lit floor
  f.settings.shadows = false;
  const RenderResult unshadowed = f.run();
  EXPECT_GT(pixel(unshadowed, 12, 16).x, 2.0f * ambient_only.x);
  EXPECT_EQ(unshadowed.stats.rays_shadow, 0u);
}

TEST(Renderer, MirrorFloorReflectsTheBackground) {
  FloorScene f;
  f.materials[0].reflectivity = 1.0f;
  const RenderResult r = f.run();
  // A perfect mirror seen head-on shows what is above it: the background (nothing else is there).
  EXPECT_NEAR(glm::distance(pixel(r, 16, 16), f.settings.background), 0.0f, 1e-6f);
  EXPECT_EQ(r.stats.rays_reflection, 16u * 16u);
  f.settings.max_recursion = 0;  // no bounce allowed: the mirror is black
  EXPECT_EQ(pixel(f.run(), 16, 16), glm::vec3(0.0f));
}

TEST(Renderer, GlassSlabTransmitsMostLightAtNormalIncidence) {
  FloorScene f;
  f.materials[0].transmission = 1.0f;
  f.materials[0].ior = 1.5f;
  const RenderResult r = f.run();
  // Head-on through one interface: 4% reflected (background from above), 96% refracted (background below).
  EXPECT_NEAR(glm::distance(pixel(r, 16, 16), f.settings.background), 0.0f, 1e-5f);
  EXPECT_EQ(r.stats.rays_refraction, 16u * 16u);
  EXPECT_EQ(r.stats.rays_reflection, 16u * 16u);
}

TEST(Renderer, SunGivesStrengthTimesCosine) {
  FloorScene f;
  f.lights[0].type = LightType::Sun;
  f.lights[0].energy = 3.0f;
  f.lights[0].matrix_world = glm::mat4(1.0f);  // shines down its -Z: straight onto the floor
  EXPECT_NEAR(pixel(f.run(), 16, 16).x, 0.8f / glm::pi<float>() * 3.0f, 1e-5f);
  f.lights[0].matrix_world = glm::rotate(glm::mat4(1.0f), glm::radians(60.0f), glm::vec3(1, 0, 0));
  EXPECT_NEAR(pixel(f.run(), 16, 16).x, 0.8f / glm::pi<float>() * 1.5f, 1e-5f);
}

// Shadow on / shadow off, per pixel: 0 in the umbra, 1 in full light, in between only in a penumbra.
std::vector<float> shadow_ratios(FloorScene& f) {
  f.add_occluder();
  f.settings.shadows = true;
  const RenderResult on = f.run();
  f.settings.shadows = false;
  const RenderResult off = f.run();
  std::vector<float> ratios;
  for (int x = 0; x < 32; ++x)
    if (off.instance[16 * 32 + x] == 0) ratios.push_back(pixel(on, x, 16).x / pixel(off, x, 16).x);
  return ratios;
}

TEST(Renderer, AreaLightCastsSoftShadowsAndAPointLightHardOnes) {
  const auto penumbra = [](const std::vector<float>& ratios) {
    return std::count_if(ratios.begin(), ratios.end(), [](float r) { return r > 0.02f && r < 0.98f; });
  };
  FloorScene point;
  const std::vector<float> hard = shadow_ratios(point);
  EXPECT_EQ(penumbra(hard), 0);
  EXPECT_GT(std::count(hard.begin(), hard.end(), 0.0f), 0);
  FloorScene area;
  area.lights[0].type = LightType::Area;
  area.lights[0].size = 0.6f;
  area.lights[0].samples = 4;
  const std::vector<float> soft = shadow_ratios(area);
  // The umbra lies under the occluder, hidden from this camera; the penumbra around it is seen.
  EXPECT_GE(penumbra(soft), 4);
}

TEST(Renderer, SpotLightLightsOnlyInsideItsCone) {
  FloorScene f;
  f.lights[0].type = LightType::Spot;
  f.lights[0].spot_size = glm::radians(20.0f);  // radius on the floor: 3 tan(10 deg) = 0.53
  f.lights[0].spot_blend = 0.0f;
  const RenderResult r = f.run();
  EXPECT_GT(pixel(r, 16, 16).x, 0.0f);
  EXPECT_EQ(pixel(r, 9, 16).x, 0.0f);  // x = -0.81
}

TEST(Renderer, SuperSamplingCountsNxNPrimaryRaysAndCancelStopsWork) {
  FloorScene f;
  f.settings.super_sampling = 3;
  EXPECT_EQ(f.run().stats.rays_primary, 9u * 32u * 32u);
  RenderProgress progress;
  progress.cancel();
  f.scene.commit();
  const RenderResult r = render(f.scene, f.camera, f.lights, f.materials, f.settings, &progress);
  EXPECT_TRUE(r.cancelled);
  EXPECT_EQ(r.stats.rays_primary, 0u);
}

TEST(Renderer, EachPixelsWorkAddsUpToTheTotalsAndPrimaryCountsTheCameraRaysAlone) {
  FloorScene f;
  f.add_occluder();
  f.materials[0].reflectivity = 0.5f;  // reflection rays too
  f.settings.super_sampling = 2;
  const RenderResult all = f.run();
  ASSERT_EQ(all.pixel_work.size(), 32u * 32u);
  TraversalStats sum;
  for (const TraversalStats& w : all.pixel_work) sum += w;
  for (const CounterInfo& c : kCounters) EXPECT_EQ(sum.*c.field, all.stats.traversal.*c.field) << c.name;
  EXPECT_GT(all.stats.rays_reflection, 0u);
  EXPECT_EQ(all.pixel_work[1 * 32 + 1].rays, 4u);  // the background: its four camera rays alone
  // A floor pixel: four camera rays, four shadow rays and four reflection rays (which miss).
  EXPECT_EQ(all.pixel_work[16 * 32 + 8].rays, 12u);

  f.settings.cost_rays = CostRays::Primary;
  const RenderResult primary = f.run();
  EXPECT_EQ(primary.image, all.image);
  EXPECT_EQ(primary.stats.traversal.rays, all.stats.traversal.rays);  // the totals still count every ray
  for (size_t i = 0; i < primary.pixel_work.size(); ++i) {
    EXPECT_EQ(primary.pixel_work[i].rays, 4u);
    // Each pixel's camera rays, traced again on their own, did exactly this work.
    const int x = int(i % 32), y = int(i / 32);
    const Camera camera(f.camera);
    TraversalStats own;
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k) {
        Hit hit;
        f.scene.closest(camera.ray(float(x) + (float(k) + 0.5f) / 2.0f, float(y) + (float(j) + 0.5f) / 2.0f), hit,
                        &own);
      }
    for (const CounterInfo& c : kCounters)
      ASSERT_EQ(primary.pixel_work[i].*c.field, own.*c.field) << c.name << " " << i;
  }
}

TEST(Renderer, MaterialIndexOutOfRangeThrows) {
  FloorScene f;
  f.materials.clear();
  EXPECT_THROW(f.run(), std::invalid_argument);
  FloorScene g;
  g.settings.super_sampling = 5;
  EXPECT_THROW(g.run(), std::invalid_argument);
}

TEST(ShadingNormals, AreValidatedKeptBesideTheMeshAndDroppedWithIt) {
  Scene scene;
  const uint32_t mesh = scene.add_mesh(quad(1.0f, 0.0f));
  EXPECT_EQ(scene.shading_normals(mesh), nullptr);
  EXPECT_THROW(scene.set_shading_normals(mesh, std::vector<glm::vec3>(5, glm::vec3(0, 0, 1))), std::invalid_argument);
  std::vector<glm::vec3> bad(6, glm::vec3(0, 0, 1));
  bad[4].y = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(scene.set_shading_normals(mesh, bad), std::invalid_argument);
  EXPECT_THROW(scene.set_shading_normals(mesh + 1, std::vector<glm::vec3>(6)), std::invalid_argument);
  scene.set_shading_normals(mesh, std::vector<glm::vec3>(6, glm::vec3(0, 0, 1)));
  ASSERT_NE(scene.shading_normals(mesh), nullptr);
  EXPECT_EQ(scene.shading_normals(mesh)->size(), 6u);
  scene.replace_mesh(mesh, quad(2.0f, 0.0f));
  EXPECT_EQ(scene.shading_normals(mesh), nullptr);  // they described the old triangles
}

TEST(ShadingNormals, BendTheLightingButNotTheGeometry) {
  FloorScene flat;
  const RenderResult f = flat.run();
  FloorScene tilted;
  const glm::vec3 n = glm::normalize(glm::vec3(1, 0, 1));
  tilted.scene.set_shading_normals(0, std::vector<glm::vec3>(6, n));
  const RenderResult t = tilted.run();
  // Pixel (16, 16) sees floor point (0.0625, -0.0625, 0): the cosine to the light is now the tilted one.
  const glm::vec3 l = glm::normalize(glm::vec3(0, 0, 3) - glm::vec3(0.0625f, -0.0625f, 0.0f));
  EXPECT_NEAR(pixel(t, 16, 16).x, pixel(f, 16, 16).x * glm::dot(n, l) / l.z, 1e-5f);
  EXPECT_EQ(t.instance, f.instance);
  EXPECT_EQ(t.distance, f.distance);
  EXPECT_EQ(t.stats.rays_shadow, f.stats.rays_shadow);
}

TEST(ShadingNormals, DoNotLetLightThroughTheFaceFromBehind) {
  FloorScene f;
  // The light is below the floor but in front of the leaning shading normal: the floor stays dark.
  f.scene.set_shading_normals(0, std::vector<glm::vec3>(6, glm::normalize(glm::vec3(1, 0, 0.1f))));
  f.lights[0].matrix_world = glm::translate(glm::mat4(1.0f), glm::vec3(10, 0, -0.5f));
  f.settings.shadows = false;
  EXPECT_EQ(pixel(f.run(), 16, 16), glm::vec3(0.0f));
  // With shadows a smooth hit lets light behind its face in, for the shadow ray to decide: from the
  // terminator point, a little above the floor, it runs into the floor itself.
  f.lights[0].matrix_world = glm::translate(glm::mat4(1.0f), glm::vec3(10, 0, -3.0f));
  f.settings.shadows = true;
  ASSERT_TRUE(f.settings.shadow_terminator);
  EXPECT_EQ(pixel(f.run(), 16, 16), glm::vec3(0.0f));
}

// A render reads one snapshot from start to end: while another thread moves the occluder back and
// forth and commits, every render is pixel for pixel one of the two states' renders.
TEST(Renderer, RendersDuringCommitsShowOneStateWhole) {
  FloorScene f;
  f.add_occluder();  // instance 1: its shadow falls on the floor's centre
  const glm::mat4 away = glm::translate(glm::mat4(1.0f), glm::vec3(100, 0, 0));
  const RenderResult shadowed = f.run();
  f.scene.set_transform(1, away);
  const RenderResult lit = f.run();
  ASSERT_NE(shadowed.image, lit.image);
  const auto same = [](const RenderResult& a, const RenderResult& b) {
    return a.image == b.image && a.instance == b.instance && a.distance == b.distance;
  };

  std::atomic<bool> done{false};
  int mixed = 0;
  std::thread renderer([&] {
    for (int i = 0; i < 10; ++i) {
      const RenderResult r = render(f.scene, f.camera, f.lights, f.materials, f.settings);
      if (!same(r, shadowed) && !same(r, lit)) ++mixed;
    }
    done.store(true);
  });
  for (int k = 0; !done.load(); ++k) {
    f.scene.set_transform(1, k % 2 == 0 ? glm::mat4(1.0f) : away);
    f.scene.commit();
  }
  renderer.join();
  EXPECT_EQ(mixed, 0);
}

namespace {

// One 4096-pixel tile of brute-force work over thousands of triangles: seconds uncancelled, so that
// another thread surely sees it half-way.
struct SlowTile {
  Scene scene{[] {
    BuildSettings b;
    b.kind = StructureKind::None;
    return b;
  }()};
  CameraSettings camera = camera_of(64, 64);
  std::vector<Light> lights{1};
  std::vector<Material> materials{1};
  RenderSettings settings;

  SlowTile() {
    auto m = std::make_shared<TriangleMesh>();
    for (uint32_t i = 0; i < 20000; ++i) {  // a stack of small squares under the camera
      const float z = -1.0f - 0.001f * float(i);
      const uint32_t k = uint32_t(m->vertices.size());
      m->vertices.insert(m->vertices.end(), {{-1, -1, z}, {1, -1, z}, {1, 1, z}, {-1, 1, z}});
      m->triangles.push_back({k, k + 1, k + 2});
      m->triangles.push_back({k, k + 2, k + 3});
    }
    scene.add_instance(scene.add_mesh(m), glm::mat4(1.0f));
    scene.commit();
    camera.type = CameraType::Orthographic;
    camera.ortho_scale = 4.0f;
    camera.matrix_world = glm::translate(glm::mat4(1.0f), glm::vec3(0, 0, 5));
    settings.super_sampling = 4;
    settings.tile_size = 4096;  // the whole picture is one tile
  }
};

}  // namespace

TEST(Renderer, ACancelStopsASingleTileHalfWayAndItsProgressCountsPixels) {
  SlowTile s;
  RenderProgress progress;
  float seen = 0.0f;
  std::thread watcher([&] {
    // Waits for the first few pixels of the one tile, then cancels.
    while (progress.pixels_done.load() < 8) std::this_thread::yield();
    seen = progress.fraction();
    progress.cancel();
  });
  const RenderResult r = render(s.scene, s.camera, s.lights, s.materials, s.settings, &progress);
  watcher.join();
  EXPECT_GT(seen, 0.0f);
  EXPECT_LT(seen, 1.0f);
  EXPECT_TRUE(r.cancelled);
  size_t done = 0;
  for (size_t p = 0; p < size_t(r.width) * r.height; ++p) {
    const bool rendered = r.image[4 * p + 3] == 1.0f;
    done += rendered;
    if (!rendered) {  // untouched: zero colour and alpha, no hit, no work
      EXPECT_EQ(r.image[4 * p], 0.0f);
      EXPECT_EQ(r.instance[p], -1);
      EXPECT_EQ(r.pixel_work[p].rays, 0u);
    }
  }
  EXPECT_GE(done, 8u);
  EXPECT_LT(done, size_t(r.width) * r.height / 2);  // stopped in the tile, not at its end
  EXPECT_EQ(r.stats.rays_primary, 16u * done);
}

TEST(Renderer, AResolutionBeyondTheMemoryBudgetIsRefusedBeforeAnythingIsAllocated) {
  FloorScene f;
  f.camera = camera_of(46341, 46341);
  f.scene.commit();
  try {
    render(f.scene, f.camera, f.lights, f.materials, f.settings);
    FAIL() << "rendered";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("46341 x 46341"), std::string::npos) << what;
    EXPECT_NE(what.find(std::to_string(render_buffer_bytes(46341, 46341))), std::string::npos) << what;
    EXPECT_NE(what.find(std::to_string(kDefaultMemoryBudget)), std::string::npos) << what;
  }
  f.camera = camera_of(32, 32);
  f.settings.memory_budget = render_buffer_bytes(32, 32) - 1;
  EXPECT_THROW(render(f.scene, f.camera, f.lights, f.materials, f.settings), std::invalid_argument);
  f.settings.memory_budget = render_buffer_bytes(32, 32);
  EXPECT_FALSE(render(f.scene, f.camera, f.lights, f.materials, f.settings).cancelled);
}

namespace {

// The goat head, smooth, over a floor, with two more instances (flat, one glass, one metal), a point, a
// sun, a spot and an area light: camera, shadow, reflection and refraction rays, instances the top
// level culls and rays that leave packets.
RenderResult render_goat_scene(Contract contract, bool batches, int super_sampling, int tile_size = 32) {
  BuildSettings build;
  build.contract = contract;
  Scene scene(build);
  const MeshPtr head = test::shipped("goathead.obj");
  std::vector<glm::vec3> normals;
  for (const glm::uvec3& t : head->triangles) {
    const glm::vec3 n =
        glm::cross(head->vertices[t.y] - head->vertices[t.x], head->vertices[t.z] - head->vertices[t.x]);
    normals.insert(normals.end(), {n, n * 0.8f + glm::vec3(0.1f), n * 0.9f - glm::vec3(0.1f)});
  }
  const Bounds b = head->bounds();
  const glm::vec3 c = 0.5f * (b.lo + b.hi);
  const float r = 0.5f * glm::length(b.hi - b.lo);
  const uint32_t smooth = scene.add_mesh(head, normals), flat = scene.add_mesh(head);
  scene.add_instance(smooth, glm::mat4(1.0f), 0);
  scene.add_instance(flat, glm::translate(glm::mat4(1.0f), glm::vec3(1.2f * r, 0.5f * r, 0)), 1);
  scene.add_instance(flat, glm::translate(glm::mat4(1.0f), glm::vec3(-1.1f * r, 0.6f * r, 0)), 2);
  const float z = b.lo.z, s = 4.0f * r;
  scene.add_instance(scene.add_mesh(test::mesh_of(
                         {{c.x - s, c.y - s, z}, {c.x + s, c.y - s, z}, {c.x + s, c.y + s, z}, {c.x - s, c.y + s, z}},
                         {{0, 1, 2}, {0, 2, 3}})),
                     glm::mat4(1.0f), 3);
  scene.commit();
  CameraSettings camera = camera_of(48, 36);
  camera.matrix_world = glm::inverse(glm::lookAt(c + glm::vec3(0.8f, -2.4f, 1.0f) * r, c, glm::vec3(0, 0, 1)));
  std::vector<Light> lights(4);
  const auto at = [&](glm::vec3 p) { return glm::inverse(glm::lookAt(c + p * r, c, glm::vec3(0, 0, 1))); };
  lights[0].matrix_world = at({-2.0f, -2.0f, 3.0f});
  lights[0].energy = 1000.0f * r * r;
  lights[1].type = LightType::Sun;
  lights[1].energy = 2.0f;
  lights[1].matrix_world = at({1.0f, 1.0f, 1.0f});
  lights[2].type = LightType::Spot;
  lights[2].energy = 500.0f * r * r;
  lights[2].spot_size = 0.8f;
  lights[2].matrix_world = at({3.0f, -1.0f, 3.0f});
  lights[3].type = LightType::Area;
  lights[3].energy = 300.0f * r * r;
  lights[3].size = r;
  lights[3].samples = 2;
  lights[3].matrix_world = at({-1.0f, 2.0f, 3.0f});
  std::vector<Material> materials(4);
  materials[0].specular = 0.3f;
  materials[1].transmission = 0.8f;
  materials[1].ior = 1.5f;
  materials[2].metallic = 0.7f;
  materials[3].reflectivity = 0.3f;
  RenderSettings settings;
  settings.super_sampling = super_sampling;
  settings.batches = batches;
  settings.threads = 1;
  settings.tile_size = tile_size;
  return render(scene, camera, lights, materials, settings);
}

void expect_same_render(const RenderResult& a, const RenderResult& b, const std::string& what) {
  ASSERT_EQ(a.image.size(), b.image.size()) << what;
  EXPECT_EQ(std::memcmp(a.image.data(), b.image.data(), a.image.size() * sizeof(float)), 0) << what;
  EXPECT_EQ(a.instance, b.instance) << what;
  EXPECT_EQ(std::memcmp(a.distance.data(), b.distance.data(), a.distance.size() * sizeof(float)), 0) << what;
  EXPECT_EQ(std::memcmp(a.pixel_work.data(), b.pixel_work.data(), a.pixel_work.size() * sizeof(TraversalStats)), 0)
      << what;
  EXPECT_EQ(a.stats.rays_primary, b.stats.rays_primary) << what;
  EXPECT_EQ(a.stats.rays_shadow, b.stats.rays_shadow) << what;
  EXPECT_EQ(a.stats.rays_reflection, b.stats.rays_reflection) << what;
  EXPECT_EQ(a.stats.rays_refraction, b.stats.rays_refraction) << what;
  for (const CounterInfo& c : kCounters) EXPECT_EQ(a.stats.traversal.*c.field, b.stats.traversal.*c.field) << what;
}

void expect_batches_render_as_single_rays() {
  for (Contract contract : {Contract::Exact, Contract::Fast})
    for (int ss : {1, 2}) {
      const std::string what = std::string(contract_name(contract)) + " super_sampling " + std::to_string(ss);
      const RenderResult batched = render_goat_scene(contract, true, ss);
      EXPECT_GT(batched.stats.rays_shadow, 0u) << what;
      EXPECT_GT(batched.stats.rays_refraction, 0u) << what;
      expect_same_render(batched, render_goat_scene(contract, false, ss), what);
    }
}

}  // namespace

// The batches (camera rays of a tile row, shadow rays towards one light: the BVH's counted packets)
// change nothing a render gives, in both contracts: the image, the buffers, every counter.
TEST(RendererBatches, TheImageStatsAndCostAreThoseOfOneRayAtATime) { expect_batches_render_as_single_rays(); }

// The same with the 4-wide nodes (SSE), which RAYLAB_BVH_WIDTH=4 makes the default.
TEST(RendererBatches, TheImageStatsAndCostAreThoseOfOneRayAtATimeWithFourWideNodes) {
  const raylab::test::ScopedEnv width("RAYLAB_BVH_WIDTH", "4");
  expect_batches_render_as_single_rays();
}

// A render traces a block of a tile's pixels together (8 x 8, in sub-blocks of 4 x 2): the image, the
// buffers and every counter are those of a render one pixel at a time (tiles of one pixel, each its
// own block), whatever the blocks (tiles of 13 pixels cut them short on both sides; 48 x 36 pixels cut
// the last tiles), batched or not.
TEST(RendererBatches, BlocksOfPixelsRenderAsOnePixelAtATime) {
  for (Contract contract : {Contract::Exact, Contract::Fast})
    for (bool batches : {true, false}) {
      const RenderResult alone = render_goat_scene(contract, batches, 1, 1);
      for (int tile_size : {13, 32}) {
        const std::string what = std::string(contract_name(contract)) + (batches ? " batches" : " single rays") +
                                 " tile_size " + std::to_string(tile_size);
        expect_same_render(render_goat_scene(contract, batches, 1, tile_size), alone, what);
      }
    }
}
