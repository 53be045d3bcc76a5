// raylab/simd.h gives every architecture x86's SSE and AVX2 results. These are the intrinsics where SIMDe
// (the arm64 path) gave other answers until simd.h replaced them: NaN in the negated comparisons and in
// _mm256_max_pd, signed zeros in it, and the one rounding of _mm256_fmsub_ps. On x86 the same expectations
// check the hardware's own answers.
#include "fast_contract.h"
#include "raylab/simd.h"

#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <limits>

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

TEST(Simd, NegatedComparisonsAreTrueWhereALaneIsNaN) {
  // Lanes: 1 against 2, NaN against 1, 2 against NaN, NaN against NaN.
  const __m128 a = _mm_setr_ps(1.0f, kNaN, 2.0f, kNaN), b = _mm_setr_ps(2.0f, 1.0f, kNaN, kNaN);
  EXPECT_EQ(_mm_movemask_ps(_mm_cmpngt_ps(a, b)), 0b1111);
  EXPECT_EQ(_mm_movemask_ps(_mm_cmpnge_ps(a, b)), 0b1111);
  EXPECT_EQ(_mm_movemask_ps(_mm_cmpnlt_ps(a, b)), 0b1110);
  EXPECT_EQ(_mm_movemask_ps(_mm_cmpnle_ps(a, b)), 0b1110);
}

RAYLAB_AVX2 void max_pd(const double* a, const double* b, double* out) {
  _mm256_storeu_pd(out, _mm256_max_pd(_mm256_loadu_pd(a), _mm256_loadu_pd(b)));
}

RAYLAB_AVX2_FMA float fmsub_lane0(float a, float b, float c) {
  return _mm_cvtss_f32(
      _mm256_castps256_ps128(_mm256_fmsub_ps(_mm256_set1_ps(a), _mm256_set1_ps(b), _mm256_set1_ps(c))));
}

TEST(Simd, MaxPdIsAGreaterThanBThenAElseB) {
  if (!raylab::cpu_has_avx2_fma()) GTEST_SKIP() << "this CPU has no AVX2";
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double a[4] = {nan, 1.0, -0.0, 0.0}, b[4] = {1.0, nan, 0.0, -0.0};
  double out[4];
  max_pd(a, b, out);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(std::bit_cast<uint64_t>(out[i]), std::bit_cast<uint64_t>(b[i])) << "lane " << i;
  }
}

TEST(Simd, FmsubRoundsOnce) {
  if (!raylab::cpu_has_avx2_fma()) GTEST_SKIP() << "this CPU has no AVX2 and FMA";
  // (1 + 2^-12)^2 = 1 + 2^-11 + 2^-24 rounds to 1 + 2^-11 as a float product; fused, 2^-24 is kept.
  const float a = 1.0f + 0x1p-12f;
  EXPECT_EQ(fmsub_lane0(a, a, 1.0f + 0x1p-11f), 0x1p-24f);
}

}  // namespace
