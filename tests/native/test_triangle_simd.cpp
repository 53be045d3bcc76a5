// intersect_watertight4 and intersect_watertight8 against intersect_watertight, lane by lane and bit for bit.
#include "raylab/triangle_packets.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <random>
#include <sstream>
#include <string>

using namespace raylab;

namespace {

std::string hex(float f) {
  char b[40];
  std::snprintf(b, sizeof b, "%a", double(f));
  return b;
}
std::string hex(const glm::vec3& p) { return "{" + hex(p.x) + ", " + hex(p.y) + ", " + hex(p.z) + "}"; }

// intersect_watertight's float filter replayed (the same operations), to count what the comparison
// exercises: lanes the filter passes to double precision, and among them those where the signs of the
// float edge functions alone would give another answer than double precision.
struct FilterReplay {
  bool to_double;
  bool float_inside;  // no two float edge functions of opposite sign
};
FilterReplay replay_filter(const WatertightRay& r, const glm::vec3& p0, const glm::vec3& p1, const glm::vec3& p2) {
  const glm::vec3 a = p0 - r.origin, b = p1 - r.origin, c = p2 - r.origin;
  const float ax = a[r.kx] - r.sx * a[r.kz], ay = a[r.ky] - r.sy * a[r.kz];
  const float bx = b[r.kx] - r.sx * b[r.kz], by = b[r.ky] - r.sy * b[r.kz];
  const float cx = c[r.kx] - r.sx * c[r.kz], cy = c[r.ky] - r.sy * c[r.kz];
  const float u = cx * by - cy * bx, v = ax * cy - ay * cx, w = bx * ay - by * ax;
  const float s = std::max(std::abs(ax), std::max(std::abs(bx), std::abs(cx))) +
                  std::max(std::abs(ay), std::max(std::abs(by), std::abs(cy)));
  const float z = std::max(std::abs(a[r.kz]), std::max(std::abs(b[r.kz]), std::abs(c[r.kz])));
  const float bound = watertight_filter_bound(s, z);
  const bool negative = u < -bound || v < -bound || w<-bound, positive = u> bound || v > bound || w > bound;
  return {!(negative && positive), !((u < 0 || v < 0 || w < 0) && (u > 0 || v > 0 || w > 0))};
}

// Rays and packets of four triangles built to sit on the test's edges: rays through vertices and
// edges (of the lane's triangle and of its neighbours sharing that vertex or edge, facing either
// way), near-degenerate, needle, collinear and point triangles, tiny and huge triangles (coordinates
// from denormals up to 2^59), mixed scales, origins on the triangle's plane and on the triangle,
// axis-aligned rays (an exact shear), directions of any magnitude with zero, -0, tiny (around the
// 2^-40 cut) and denormal components.
class Cases {
 public:
  explicit Cases(uint64_t seed) : rng_(seed) {}

  struct Case {
    Ray ray;
    glm::vec3 p[4][3];
  };

  Case next() {
    Case c;
    // The scene's scale, the triangle's place relative to it, and the origin's distance.
    int e;
    switch (integer(0, 8)) {
      case 0: e = integer(-149, -100); break;  // denormal and tiny coordinates
      case 1: e = integer(-60, -10); break;
      case 2: e = integer(10, 40); break;
      case 3: e = integer(41, 58); break;  // up to kMaxCoordinate
      default: e = integer(-3, 3); break;
    }
    scale_ = std::ldexp(1.0f, e);
    const int far = std::min(integer(0, 3) == 0 ? integer(0, 30) : 0, 58 - e);
    centre_ = rng_() % 2 ? glm::vec3(0.0f) : std::ldexp(1.0f, far) * scale_ * random3();
    c.p[0][0] = triangle_point();
    c.p[0][1] = triangle_point();
    c.p[0][2] = triangle_point();
    shape(c.p[0]);
    const glm::vec3* base = c.p[0];

    // The target on the base triangle.
    glm::vec3 target;
    switch (integer(0, 6)) {
      case 0: target = base[integer(0, 2)]; break;
      case 1:
      case 2: {
        const int i = integer(0, 2), j = (i + 1) % 3;
        target = base[i] + fraction() * (base[j] - base[i]);
        break;
      }
      case 3: {
        const int i = integer(0, 2), j = (i + 1) % 3;
        target = 0.5f * (base[i] + base[j]);
        break;
      }
      case 4: {
        const float a = fraction(), b = (1.0f - a) * fraction();
        target = base[0] + a * (base[1] - base[0]) + b * (base[2] - base[0]);
        break;
      }
      case 5: {
        const int i = integer(0, 2), j = (i + 1) % 3;
        const float a = fraction();
        target = base[i] + a * (base[j] - base[i]) + offset(10, 30);
        break;
      }
      default: target = centre_ + scale_ * random3(); break;
    }
    target = clamp(target);

    // The origin and direction.
    Ray& ray = c.ray;
    switch (integer(0, 9)) {
      case 0:
      case 1: {  // on the triangle's plane (to rounding), aimed along it
        const float a = 3.0f * unit(), b = 3.0f * unit();
        ray.origin = clamp(base[0] + a * (base[1] - base[0]) + b * (base[2] - base[0]));
        ray.direction = rng_() % 2 ? target - ray.origin : base[1] - base[0];
        break;
      }
      case 2:  // on the triangle: t = 0 is never a hit with tmin = 0
        ray.origin = target;
        ray.direction = random3();
        break;
      case 3: {  // axis-aligned: the shear is exact
        const int axis = integer(0, 2);
        glm::vec3 d(0.0f);
        d[axis] = rng_() % 2 ? 1.0f : -1.0f;
        ray.origin = clamp(target - std::ldexp(scale_, integer(-10, 4)) * d);
        ray.direction = d;
        break;
      }
      default:
        ray.origin = clamp(target + offset(-8, 24));
        ray.direction = target - ray.origin;
        break;
    }
    if (ray.direction == glm::vec3(0.0f)) ray.direction = random3();
    perturb(ray.direction);
    if (integer(0, 3) == 0) {
      // The target at a t from 2^-134 to 2^-126, where the float z and t are denormal and the SIMD
      // test's relative margin on them underflows (the origin moved closer if the direction would
      // overflow); mostly with the base triangle flat across the ray's main axis, so that t is the
      // corners' common z.
      const int m = integer(126, 133);
      glm::vec3 to = target - ray.origin;
      const float largest = std::max(std::abs(to.x), std::max(std::abs(to.y), std::abs(to.z)));
      if (largest > 0.0f && std::ilogb(largest) + m > 126) {
        ray.origin = target - std::ldexp(1.0f, 126 - m - std::ilogb(largest)) * to;
        to = target - ray.origin;
      }
      const float now = std::max(std::abs(to.x), std::max(std::abs(to.y), std::abs(to.z)));
      if (now > 0.0f && std::ilogb(now) + m <= 126) {
        const float f = 1.0f + fraction();
        for (int i = 0; i < 3; ++i) ray.direction[i] = std::ldexp(f * to[i], m);
        const int axis = std::abs(to.x) == now ? 0 : std::abs(to.y) == now ? 1 : 2;
        if (integer(0, 3) != 0) c.p[0][0][axis] = c.p[0][1][axis] = c.p[0][2][axis] = target[axis];
      }
    }

    // The other lanes: neighbours, copies, strangers.
    for (int lane = 1; lane < 4; ++lane) {
      glm::vec3* q = c.p[lane];
      const int i = integer(0, 2), j = (i + 1) % 3, k = (i + 2) % 3;
      const glm::vec3 across = clamp(base[i] + base[j] - base[k] + offset(0, 30));
      switch (integer(0, 8)) {
        case 0: q[0] = base[j], q[1] = base[i], q[2] = across; break;  // shares edge i-j, same facing
        case 1: q[0] = base[i], q[1] = base[j], q[2] = across; break;  // shares edge i-j, opposite facing
        case 2: q[0] = base[i], q[1] = triangle_point(), q[2] = triangle_point(); break;  // shares a vertex
        case 3: q[0] = base[j], q[1] = base[k], q[2] = base[i]; break;                    // the base, rotated
        case 4: q[0] = base[i], q[1] = base[k], q[2] = base[j]; break;                    // the base, reversed
        case 5: {                                                                         // tiny, around the target
          const float s = std::ldexp(scale_, -integer(10, 40));
          for (int m = 0; m < 3; ++m) q[m] = clamp(target + s * random3());
          break;
        }
        case 6: {  // huge, around the target
          const float s = std::ldexp(1.0f, integer(20, 59));
          for (int m = 0; m < 3; ++m) q[m] = clamp(target + s * random3());
          break;
        }
        default:
          for (int m = 0; m < 3; ++m) q[m] = triangle_point();
          shape(q);
          break;
      }
    }
    return c;
  }

  // tmin and tmax of a first test: mostly the defaults, else anything around the scene's distances.
  std::pair<float, float> window() {
    switch (integer(0, 5)) {
      case 0: return {-kInfinity, kInfinity};
      case 1: {
        const float a = signed_power(1.0f, -30, 30), b = signed_power(1.0f, -30, 30);
        return {std::min(a, b), std::max(a, b)};
      }
      default: return {0.0f, kInfinity};
    }
  }

 private:
  int integer(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }
  float unit() { return std::uniform_real_distribution<float>(-1.0f, 1.0f)(rng_); }
  float fraction() { return std::uniform_real_distribution<float>(0.0f, 1.0f)(rng_); }
  glm::vec3 random3() { return {unit(), unit(), unit()}; }
  // A random offset of size scale_ * 2^-k, k in [lo, hi]. (The draws are sequenced by statements: the
  // cases are the same whatever order a compiler evaluates operands in.)
  glm::vec3 offset(int lo, int hi) {
    const float size = std::ldexp(scale_, -integer(lo, hi));
    return size * random3();
  }
  // +-x * 2^-k * [1, 2), k in [lo, hi].
  float signed_power(float x, int lo, int hi) {
    const float magnitude = std::ldexp(x, -integer(lo, hi));
    const float mantissa = 1.0f + fraction();
    return unit() < 0.0f ? -magnitude * mantissa : magnitude * mantissa;
  }
  static glm::vec3 clamp(const glm::vec3& p) {
    return glm::clamp(p, glm::vec3(-kMaxCoordinate), glm::vec3(kMaxCoordinate));
  }
  glm::vec3 triangle_point() { return clamp(centre_ + scale_ * random3()); }

  // Makes a triangle near-degenerate, a needle, collinear, a point, or flat across an axis.
  void shape(glm::vec3* p) {
    switch (integer(0, 9)) {
      case 0: {
        const float a = fraction();
        p[2] = clamp(p[0] + a * (p[1] - p[0]) + offset(8, 40));
        break;
      }
      case 1: p[2] = clamp(p[1] + offset(8, 40)); break;
      case 2: p[2] = clamp(p[0] + 0.5f * (p[1] - p[0])); break;
      case 3: p[1] = p[2] = p[0]; break;
      case 4: p[1] = p[0]; break;
      case 5:
      case 6: {
        const int axis = integer(0, 2);
        p[1][axis] = p[2][axis] = p[0][axis];
        break;
      }
      default: break;
    }
  }

  // Directions of any magnitude, with zero, -0, tiny and denormal components.
  void perturb(glm::vec3& d) {
    if (integer(0, 1) == 0) {  // the largest component anywhere from 2^-100 to 2^127: t down to denormals
      const float largest = std::max(std::abs(d.x), std::max(std::abs(d.y), std::abs(d.z)));
      const int k = integer(-100, 127) - std::ilogb(largest);
      const glm::vec3 scaled(std::ldexp(d.x, k), std::ldexp(d.y, k), std::ldexp(d.z, k));
      if (std::isfinite(scaled.x) && std::isfinite(scaled.y) && std::isfinite(scaled.z) && scaled != glm::vec3(0.0f))
        d = scaled;
    }
    if (integer(0, 2) != 0) return;
    const int i = integer(0, 2);
    const float largest = std::max(std::abs(d.x), std::max(std::abs(d.y), std::abs(d.z)));
    switch (integer(0, 4)) {
      case 0: d[i] = 0.0f; break;
      case 1: d[i] = -0.0f; break;
      case 2: d[i] = signed_power(largest, 36, 44); break;
      case 3: d[i] = signed_power(1.0f, 127, 149); break;
      default: d[i] = std::nextafter(d[i], kInfinity); break;
    }
  }

  std::mt19937_64 rng_;
  float scale_ = 1.0f;
  glm::vec3 centre_{0.0f};
};

// The 8-lane test from code built for x86-64-v2: its own AVX2 function, called only after
// cpu_has_avx2().
RAYLAB_AVX2 __attribute__((noinline)) int watertight8(const WatertightRay& w, const TrianglePacket& a,
                                                      const TrianglePacket& b, float tmin, float tmax, float* t,
                                                      float* u, float* v) {
  const Watertight8Ray w8(w);
  return intersect_watertight8(w8, a, b, 0xff, tmin, tmax, t, u, v);
}

// The 8-lane any-hit test, the same way.
RAYLAB_AVX2 __attribute__((noinline)) int watertight8_any(const WatertightRay& w, const TrianglePacket& a,
                                                          const TrianglePacket& b, float tmin, float tmax) {
  const Watertight8Ray w8(w);
  float t[8], u[8], v[8];
  return intersect_watertight8<true>(w8, a, b, 0xff, tmin, tmax, t, u, v);
}

}  // namespace

// Every lane of intersect_watertight4, and of intersect_watertight8 where the CPU has AVX2, gives
// exactly what intersect_watertight gives for that triangle: the same hit or miss and, on a hit, the
// same bits of t, u and v (both SIMD tests send the lanes their filter passes to the scalar test's own
// double-precision function, so the fallback is the scalar one). About a million lanes per test
// over the cases above, each packet tested with a first window (tmin, tmax) and then, for every
// lane the scalar test hits at t, with tmax = t, tmax just below t, tmin = t, tmin just below t and
// (just below t, t): the windows where the SIMD test's pre-check on the corners' z range and its
// behind test (a hit provably at or before tmin) decide.
// The any-hit forms (kAny) return the first lane the scalar test hits, or nothing.
TEST(TriangleIntersection, SimdLanesGiveTheScalarResultBitForBit) {
  Cases cases(0x5eed2013);
  long lanes = 0, hits = 0, denormal_hits = 0, to_double = 0, float_leaks = 0, mismatches = 0;
  long any_packets = 0, any_hits = 0, any_mismatches = 0;
  std::ostringstream report;
  for (int n = 0; n < 100000; ++n) {
    Cases::Case c = cases.next();
    TrianglePacket packet;
    for (int lane = 0; lane < 4; ++lane) {
      for (int corner = 0; corner < 3; ++corner)
        for (int axis = 0; axis < 3; ++axis) packet.p[corner][axis][lane] = c.p[lane][corner][axis];
      packet.triangle[lane] = uint32_t(lane);
    }
    // The 8-lane AVX2 test gets this packet in lanes 0-3 and the same triangles reversed in lanes
    // 4-7, so every triangle is also tested in another lane position.
    TrianglePacket reversed;
    for (int lane = 0; lane < 4; ++lane) {
      for (int corner = 0; corner < 3; ++corner)
        for (int axis = 0; axis < 3; ++axis) reversed.p[corner][axis][lane] = c.p[3 - lane][corner][axis];
      reversed.triangle[lane] = uint32_t(3 - lane);
    }
    const WatertightRay w(c.ray);
    const Watertight4Ray w4(w);
    const bool avx2 = cpu_has_avx2();
    auto compare = [&](float tmin, float tmax, bool count) {
      float t[4], u[4], v[4], t8[8], u8[8], v8[8];
      int mask = intersect_watertight4(w4, packet, tmin, tmax, t, u, v);
      const int simd_lanes = avx2 ? 12 : 4;  // lanes 4-11: the 8-lane test's lanes 0-7
      if (avx2) mask |= watertight8(w, packet, reversed, tmin, tmax, t8, u8, v8) << 4;
      // Any hit: the first lane the scalar test hits, in the 4-lane packet and in the 8 lanes.
      int first4 = 0, first8 = 0;
      for (int simd_lane = 7; simd_lane >= 0; --simd_lane) {
        const int lane = simd_lane < 4 ? simd_lane : 7 - simd_lane;
        TriangleHit h{};
        if (intersect_watertight(w, c.p[lane][0], c.p[lane][1], c.p[lane][2], tmin, tmax, h)) {
          first8 = 1 << simd_lane;
          if (simd_lane < 4) first4 = 1 << simd_lane;
        }
      }
      float ta[4], ua[4], va[4];
      const int any4 = intersect_watertight4<true>(w4, packet, tmin, tmax, ta, ua, va);
      ++any_packets;
      any_hits += first4 != 0;
      if (any4 != first4 || (avx2 && watertight8_any(w, packet, reversed, tmin, tmax) != first8)) {
        if (++any_mismatches <= 5)
          report << "case " << n << ": any-hit lanes " << any4 << " (8-lane "
                 << (avx2 ? watertight8_any(w, packet, reversed, tmin, tmax) : -1) << "), scalar first hits " << first4
                 << " (" << first8 << "), tmin " << hex(tmin) << " tmax " << hex(tmax) << "\n";
      }
      for (int simd_lane = 0; simd_lane < simd_lanes; ++simd_lane) {
        const int lane = simd_lane < 8 ? simd_lane % 4 : 3 - (simd_lane - 8);  // the triangle's own index
        const glm::vec3* p = c.p[lane];
        TriangleHit h{};
        const bool hit = intersect_watertight(w, p[0], p[1], p[2], tmin, tmax, h);
        ++lanes;
        if (simd_lane < 4) {  // the triangle's counts, once
          hits += hit;
          denormal_hits += hit && std::abs(h.t) < std::numeric_limits<float>::min();
        }
        if (count && simd_lane < 4) {
          const FilterReplay f = replay_filter(w, p[0], p[1], p[2]);
          to_double += f.to_double;
          float_leaks += f.to_double && !f.float_inside && hit;
        }
        const bool simd_hit = (mask >> simd_lane) & 1;
        const float st = simd_lane < 4 ? t[lane] : t8[simd_lane - 4];
        const float su = simd_lane < 4 ? u[lane] : u8[simd_lane - 4];
        const float sv = simd_lane < 4 ? v[lane] : v8[simd_lane - 4];
        const bool same = simd_hit == hit && (!hit || (std::bit_cast<uint32_t>(st) == std::bit_cast<uint32_t>(h.t) &&
                                                       std::bit_cast<uint32_t>(su) == std::bit_cast<uint32_t>(h.u) &&
                                                       std::bit_cast<uint32_t>(sv) == std::bit_cast<uint32_t>(h.v)));
        if (same) continue;
        if (++mismatches > 5) continue;
        report << "case " << n << (simd_lane < 4 ? " 4-lane test lane " : " 8-lane test lane ")
               << (simd_lane < 4 ? simd_lane : simd_lane - 4) << ": ray origin " << hex(c.ray.origin) << " direction "
               << hex(c.ray.direction) << ", triangle " << hex(p[0]) << " " << hex(p[1]) << " " << hex(p[2])
               << ", tmin " << hex(tmin) << " tmax " << hex(tmax) << ": scalar "
               << (hit ? "hit t " + hex(h.t) + " u " + hex(h.u) + " v " + hex(h.v) : std::string("miss")) << ", SIMD "
               << (simd_hit ? "hit t " + hex(st) + " u " + hex(su) + " v " + hex(sv) : std::string("miss")) << "\n";
      }
    };
    const auto [tmin, tmax] = cases.window();
    compare(tmin, tmax, true);
    for (int lane = 0; lane < 4; ++lane) {
      TriangleHit h{};
      const glm::vec3* p = c.p[lane];
      if (!intersect_watertight(w, p[0], p[1], p[2], tmin, tmax, h)) continue;
      const float below = std::nextafter(h.t, -kInfinity);
      compare(tmin, h.t, false);
      compare(tmin, below, false);
      compare(h.t, kInfinity, false);
      compare(below, kInfinity, false);
      compare(below, h.t, false);
    }
  }
  std::printf(
      "[ counts   ] %ld lanes compared, %ld hits (%ld at a denormal t); first windows: %ld lanes passed to "
      "double precision, %ld of them hits where the float edge functions have opposite signs\n",
      lanes, hits, denormal_hits, to_double, float_leaks);
  std::printf("[ counts   ] any hit: %ld packets, %ld of them hit\n", any_packets, any_hits);
  EXPECT_EQ(mismatches, 0) << mismatches << " lanes differ from the scalar test; the first:\n" << report.str();
  EXPECT_EQ(any_mismatches, 0) << any_mismatches << " any-hit packets differ from the scalar test:\n" << report.str();
  EXPECT_GT(any_hits, 100000);
  EXPECT_GT(lanes, 1000000);
  EXPECT_GT(hits, 100000);
  EXPECT_GT(to_double, 10000);
  EXPECT_GT(float_leaks, 100);
  EXPECT_GT(denormal_hits, 1000);
}

// The smallest cases the comparison above found: a triangle flat across the ray's axis, hit at a
// denormal t (the same as a unit direction and a triangle about 1e-40 away). The SIMD test's pre-check
// on the corners' z range computed z = sz * ez in float, one denormal ulp off the t that the scalar
// test rounds from double, and its relative margin (2^-20 z) underflowed to zero: at tmax = t, or tmin
// just below t, it rejected the lane that the scalar test hits (a closest-hit search passes tmax = the
// best t so far, to see ties).
TEST(TriangleIntersection, SimdLaneKeepsAHitAtADenormalTOnTheWindowsEdge) {
  struct Repro {
    float direction_z, plane_z, t;
    bool at_tmax;  // else tmin just below t
  };
  // t = plane_z / direction_z; the float z of the pre-check was 0x1.1177p-133 (above t) and
  // 0x1.6c9cp-135 (= tmin).
  for (const Repro& c : {Repro{1e38f, 0x1.41743ep-7f /* 0.00981f */, 0x1.1176p-133f, true},
                         Repro{2e38f, 0x1.ac9afep-8f /* 0.00654f */, 0x1.6cap-135f, false}}) {
    Ray ray;
    ray.origin = {0, 0, 0};
    ray.direction = {0, 0, c.direction_z};
    const glm::vec3 p0(-1, -1, c.plane_z), p1(1, -1, c.plane_z), p2(0, 1, c.plane_z);
    const float tmin = c.at_tmax ? 0.0f : std::nextafter(c.t, 0.0f), tmax = c.at_tmax ? c.t : kInfinity;
    const WatertightRay w(ray);
    TriangleHit h{};
    ASSERT_TRUE(intersect_watertight(w, p0, p1, p2, tmin, tmax, h));
    EXPECT_EQ(h.t, c.t);
    TrianglePacket packet;
    for (int lane = 0; lane < 4; ++lane) {
      for (int axis = 0; axis < 3; ++axis) {
        packet.p[0][axis][lane] = p0[axis];
        packet.p[1][axis][lane] = p1[axis];
        packet.p[2][axis][lane] = p2[axis];
      }
      packet.triangle[lane] = uint32_t(lane);
    }
    float t[4], u[4], v[4];
    const Watertight4Ray w4(w);
    ASSERT_EQ(intersect_watertight4(w4, packet, tmin, tmax, t, u, v), 0xf)
        << "tmin " << hex(tmin) << " tmax " << hex(tmax);
    for (int lane = 0; lane < 4; ++lane) {
      EXPECT_EQ(std::bit_cast<uint32_t>(t[lane]), std::bit_cast<uint32_t>(h.t));
      EXPECT_EQ(std::bit_cast<uint32_t>(u[lane]), std::bit_cast<uint32_t>(h.u));
      EXPECT_EQ(std::bit_cast<uint32_t>(v[lane]), std::bit_cast<uint32_t>(h.v));
    }
  }
}

// The behind test (a lane whose hit lies provably at or before tmin is rejected in float) at the
// edge of float: a hit one float step past tmin at t near 2^63, where the float numerator
// u z0 + v z1 + w z2 and tmin times the determinant both overflowed to infinity and compared equal,
// so the lane was rejected (found by the comparison above); and, at ordinary scales, the hit kept
// with tmin one step below t and rejected with tmin = t, as the scalar test decides.
TEST(TriangleIntersection, SimdBehindTestKeepsAHitJustPastTmin) {
  struct Repro {
    glm::vec3 origin, direction, p0, p1, p2;
  };
  const Repro cases[] = {
      {{-0x1.c179b4p+44f, -0x1.e4b26cp+42f, -0x1.16f54p+44f},
       {0.0f, -0x1p-31f, -0x1.9a223p-69f},
       {-0x1.c17e02p+44f, -0x1.e52f0ap+42f, -0x1.16f7dap+44f},
       {-0x1.c167a2p+44f, -0x1.e496dep+42f, -0x1.16c9cap+44f},
       {-0x1.c15832p+44f, -0x1.e4ea36p+42f, -0x1.16e5e8p+44f}},
      {{0.25f, 0.25f, 1.0f}, {0.1f, -0.2f, -1.0f}, {-1, -1, 0}, {1, -1, 0}, {0, 1, 0}},
  };
  for (const Repro& c : cases) {
    Ray ray;
    ray.origin = c.origin;
    ray.direction = c.direction;
    const WatertightRay w(ray);
    TriangleHit h{};
    ASSERT_TRUE(intersect_watertight(w, c.p0, c.p1, c.p2, 0.0f, kInfinity, h));
    TrianglePacket packet;
    for (int lane = 0; lane < 4; ++lane) {
      for (int axis = 0; axis < 3; ++axis) {
        packet.p[0][axis][lane] = c.p0[axis];
        packet.p[1][axis][lane] = c.p1[axis];
        packet.p[2][axis][lane] = c.p2[axis];
      }
      packet.triangle[lane] = uint32_t(lane);
    }
    const Watertight4Ray w4(w);
    float t[4], u[4], v[4];
    const float below = std::nextafter(h.t, 0.0f);
    EXPECT_EQ(intersect_watertight4(w4, packet, below, kInfinity, t, u, v), 0xf) << "tmin " << hex(below);
    EXPECT_EQ(std::bit_cast<uint32_t>(t[0]), std::bit_cast<uint32_t>(h.t));
    EXPECT_EQ(intersect_watertight4<true>(w4, packet, below, kInfinity, t, u, v), 0x1);
    EXPECT_EQ(intersect_watertight4(w4, packet, h.t, kInfinity, t, u, v), 0) << "tmin " << hex(h.t);
    EXPECT_EQ(intersect_watertight4<true>(w4, packet, h.t, kInfinity, t, u, v), 0);
    if (cpu_has_avx2()) {
      float t8[8], u8[8], v8[8];
      EXPECT_EQ(watertight8(w, packet, packet, below, kInfinity, t8, u8, v8), 0xff);
      EXPECT_EQ(watertight8_any(w, packet, packet, below, kInfinity), 0x1);
      EXPECT_EQ(watertight8(w, packet, packet, h.t, kInfinity, t8, u8, v8), 0);
      EXPECT_EQ(watertight8_any(w, packet, packet, h.t, kInfinity), 0);
    }
  }
}
