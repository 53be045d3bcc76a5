#include "embree_tracer.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <pmmintrin.h>
#include <xmmintrin.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>

namespace raylab::bench {

namespace {

// Embree asks for flush-to-zero and denormals-are-zero in every tracing thread. TBB's worker
// threads also run raylab's traversals, so the previous mode is restored after each chunk:
// raylab is measured in default IEEE mode.
class DenormalsOff {
 public:
  DenormalsOff() : saved_(_mm_getcsr()) {
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  }
  ~DenormalsOff() { _mm_setcsr(saved_); }

 private:
  unsigned saved_;
};

constexpr size_t kGrain = 256;

// raylab's ray as Embree's, every field set.
RTCRay embree_ray(const Ray& ray) {
  RTCRay r;
  r.org_x = ray.origin.x, r.org_y = ray.origin.y, r.org_z = ray.origin.z;
  r.dir_x = ray.direction.x, r.dir_y = ray.direction.y, r.dir_z = ray.direction.z;
  r.tnear = ray.tmin, r.tfar = ray.tmax;
  r.time = 0.0f, r.mask = 0xffffffffu, r.id = 0, r.flags = 0;
  return r;
}

// One ray query, in Embree 3's form (an intersect context) or Embree 4's (no context needed; the
// default arguments are the same query).
#if RAYLAB_EMBREE_MAJOR >= 4
void intersect1(RTCScene scene, RTCRayHit& rh) { rtcIntersect1(scene, &rh); }
void occluded1(RTCScene scene, RTCRay& ray) { rtcOccluded1(scene, &ray); }
#else
void intersect1(RTCScene scene, RTCRayHit& rh) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  rtcIntersect1(scene, &context, &rh);
}
void occluded1(RTCScene scene, RTCRay& ray) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  rtcOccluded1(scene, &context, &ray);
}
#endif

// A run of up to 8 rays as Embree's packet: the active lanes' valid word is -1, the others' 0 (their
// fields zeroed, never read). The packet structs must be 32-byte aligned: RTC_ALIGN(32) on the types,
// and the callers keep them on the stack.
constexpr size_t kPacket = 8;

void fill_packet(std::span<const Ray> rays, int (&valid)[kPacket], RTCRay8& p) {
  for (size_t k = 0; k < kPacket; ++k) {
    const bool active = k < rays.size();
    const Ray ray = active ? rays[k] : Ray{};
    valid[k] = active ? -1 : 0;
    p.org_x[k] = ray.origin.x, p.org_y[k] = ray.origin.y, p.org_z[k] = ray.origin.z;
    p.dir_x[k] = ray.direction.x, p.dir_y[k] = ray.direction.y, p.dir_z[k] = ray.direction.z;
    p.tnear[k] = active ? ray.tmin : 0.0f, p.tfar[k] = active ? ray.tmax : -kInfinity;
    p.time[k] = 0.0f, p.mask[k] = 0xffffffffu, p.id[k] = unsigned(k), p.flags[k] = 0;
  }
}

#if RAYLAB_EMBREE_MAJOR >= 4
void intersect8(const int* valid, RTCScene scene, RTCRayHit8& rh) {
  RTCIntersectArguments args;
  rtcInitIntersectArguments(&args);
  args.flags = RTC_RAY_QUERY_FLAG_COHERENT;
  rtcIntersect8(valid, scene, &rh, &args);
}
void occluded8(const int* valid, RTCScene scene, RTCRay8& ray) {
  RTCOccludedArguments args;
  rtcInitOccludedArguments(&args);
  args.flags = RTC_RAY_QUERY_FLAG_COHERENT;
  rtcOccluded8(valid, scene, &ray, &args);
}
#else
void intersect8(const int* valid, RTCScene scene, RTCRayHit8& rh) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  rtcIntersect8(valid, scene, &context, &rh);
}
void occluded8(const int* valid, RTCScene scene, RTCRay8& ray) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  rtcOccluded8(valid, scene, &context, &ray);
}
#endif

// Whole packets per TBB task: kGrain rays.
tbb::blocked_range<size_t> packet_range(size_t rays) {
  return tbb::blocked_range<size_t>(0, (rays + kPacket - 1) / kPacket, kGrain / kPacket);
}

}  // namespace

EmbreeTracer::EmbreeTracer(const TriangleMesh& mesh) : mesh_(mesh) {
  device_ = rtcNewDevice(nullptr);
  if (!device_) throw std::runtime_error("rtcNewDevice failed: " + std::to_string(int(rtcGetDeviceError(nullptr))));
  rtcSetDeviceMemoryMonitorFunction(device_, &EmbreeTracer::monitor, this);
  padded_vertices_.assign(mesh.vertices.size() * 3 + 4, 0.0f);
  for (size_t i = 0; i < mesh.vertices.size(); ++i)
    for (int c = 0; c < 3; ++c) padded_vertices_[3 * i + c] = mesh.vertices[i][c];
}

EmbreeTracer::~EmbreeTracer() {
  if (scene_) rtcReleaseScene(scene_);
  rtcReleaseDevice(device_);
}

bool EmbreeTracer::monitor(void* self, ssize_t bytes, bool) {
  static_cast<EmbreeTracer*>(self)->allocated_ += bytes;
  return true;
}

double EmbreeTracer::build(RTCBuildQuality quality) {
  if (scene_) rtcReleaseScene(scene_);
  const int64_t before = allocated_;
  scene_ = rtcNewScene(device_);
  rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_NONE);
  rtcSetSceneBuildQuality(scene_, quality);
  RTCGeometry geometry = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
  rtcSetGeometryBuildQuality(geometry, quality);
  rtcSetSharedGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, padded_vertices_.data(), 0,
                             3 * sizeof(float), mesh_.vertices.size());
  rtcSetSharedGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, mesh_.triangles.data(), 0,
                             3 * sizeof(uint32_t), mesh_.triangles.size());
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(scene_, geometry);
  rtcReleaseGeometry(geometry);
  const auto start = std::chrono::steady_clock::now();
  rtcCommitScene(scene_);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (rtcGetDeviceError(device_) != RTC_ERROR_NONE) throw std::runtime_error("Embree scene build failed");
  scene_bytes_ = size_t(std::max<int64_t>(0, allocated_ - before));
  return seconds;
}

void EmbreeTracer::closest(std::span<const Ray> rays, std::span<Hit> hits) const {
  tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), kGrain), [&](const tbb::blocked_range<size_t>& r) {
    DenormalsOff mode;
    for (size_t i = r.begin(); i != r.end(); ++i) {
      RTCRayHit rh;
      rh.ray = embree_ray(rays[i]);
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
      intersect1(scene_, rh);
      Hit h;
      if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
        h.t = rh.ray.tfar;
        h.u = rh.hit.u;
        h.v = rh.hit.v;
        h.triangle = rh.hit.primID;
        h.instance = 0;
      }
      hits[i] = h;
    }
  });
}

void EmbreeTracer::any(std::span<const Ray> rays, std::span<uint8_t> occluded) const {
  tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), kGrain), [&](const tbb::blocked_range<size_t>& r) {
    DenormalsOff mode;
    for (size_t i = r.begin(); i != r.end(); ++i) {
      RTCRay rr = embree_ray(rays[i]);
      occluded1(scene_, rr);
      occluded[i] = rr.tfar == -kInfinity;  // Embree marks an occluded ray by tfar = -inf
    }
  });
}

void EmbreeTracer::closest_packets(std::span<const Ray> rays, std::span<Hit> hits) const {
  tbb::parallel_for(packet_range(rays.size()), [&](const tbb::blocked_range<size_t>& r) {
    DenormalsOff mode;
    for (size_t p = r.begin(); p != r.end(); ++p) {
      const size_t first = p * kPacket, count = std::min(kPacket, rays.size() - first);
      alignas(32) int valid[kPacket];
      alignas(32) RTCRayHit8 rh;
      fill_packet(rays.subspan(first, count), valid, rh.ray);
      for (size_t k = 0; k < kPacket; ++k) {
        rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
      }
      intersect8(valid, scene_, rh);
      for (size_t k = 0; k < count; ++k) {
        Hit h;
        if (rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID) {
          h.t = rh.ray.tfar[k];
          h.u = rh.hit.u[k];
          h.v = rh.hit.v[k];
          h.triangle = rh.hit.primID[k];
          h.instance = 0;
        }
        hits[first + k] = h;
      }
    }
  });
}

void EmbreeTracer::any_packets(std::span<const Ray> rays, std::span<uint8_t> occluded) const {
  tbb::parallel_for(packet_range(rays.size()), [&](const tbb::blocked_range<size_t>& r) {
    DenormalsOff mode;
    for (size_t p = r.begin(); p != r.end(); ++p) {
      const size_t first = p * kPacket, count = std::min(kPacket, rays.size() - first);
      alignas(32) int valid[kPacket];
      alignas(32) RTCRay8 ray;
      fill_packet(rays.subspan(first, count), valid, ray);
      occluded8(valid, scene_, ray);
      for (size_t k = 0; k < count; ++k) occluded[first + k] = ray.tfar[k] == -kInfinity;
    }
  });
}

}  // namespace raylab::bench
