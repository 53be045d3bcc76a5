// The SIMD intrinsics of the kernels, chosen when raylab is built. The kernels are written in x86's SSE
// and AVX2 intrinsics. On x86-64 these are the compiler's own (immintrin.h): the AVX2 kernels are compiled
// per function (RAYLAB_AVX2, RAYLAB_AVX2_FMA) and chosen at run time (RAYLAB_CPU_SUPPORTS), the rest of
// the build stays x86-64-v2. Elsewhere (arm64) SIMDe maps the same calls onto NEON with x86's results
// (IEEE arithmetic; x86's NaN rules for min, max and conversions: SIMDe's exact mode, no SIMDE_FAST_*), so
// the hits are the same bit for bit; every kernel is compiled for the build's target there and the 8-wide
// ones (two NEON halves) are always available. CMakeLists.txt turns off the fusing of a * b + c on those
// targets: x86-64-v2 has no FMA, so x86 never fuses outside the fast contract's kernels.
#pragma once

#if defined(__x86_64__) || defined(__i386__)

#include <immintrin.h>

#define RAYLAB_AVX2 __attribute__((target("avx2")))
#define RAYLAB_AVX2_FMA __attribute__((target("avx2,fma")))
#define RAYLAB_CPU_SUPPORTS(feature) __builtin_cpu_supports(feature)

#else

#define SIMDE_ENABLE_NATIVE_ALIASES
#include <simde/x86/avx2.h>
#include <simde/x86/fma.h>

#define RAYLAB_AVX2
#define RAYLAB_AVX2_FMA
#define RAYLAB_CPU_SUPPORTS(feature) true

// Where SIMDe 0.7 differs from x86 (read in its source; OctreeExactness failed on the comparisons), x86's
// definition:
// - _mm256_fmsub_ps is a product and then a difference, two roundings; x86's is one fused rounding, which
//   a fused a * b + (-c) is exactly (the negation is exact).
// - The negated comparisons are the opposite ordered ones (_mm_cmpngt_ps is _mm_cmple_ps), false in a
//   lane holding a NaN, where x86's are true: the ordered comparison's complement.
// - _mm_max_pd is NEON's fmax on arm64 (NaN if either is; +0 over -0); x86's is `a > b ? a : b`.
#undef _mm256_fmsub_ps
#define _mm256_fmsub_ps(a, b, c) simde_mm256_fmadd_ps(a, b, simde_mm256_xor_ps(c, simde_mm256_set1_ps(-0.0f)))
inline simde__m128 raylab_not_ps(simde__m128 m) {
  return simde_mm_xor_ps(m, simde_mm_castsi128_ps(simde_mm_set1_epi32(-1)));
}
#undef _mm_cmpngt_ps
#define _mm_cmpngt_ps(a, b) raylab_not_ps(simde_mm_cmpgt_ps(a, b))
#undef _mm_cmpnge_ps
#define _mm_cmpnge_ps(a, b) raylab_not_ps(simde_mm_cmpge_ps(a, b))
#undef _mm_cmpnlt_ps
#define _mm_cmpnlt_ps(a, b) raylab_not_ps(simde_mm_cmplt_ps(a, b))
#undef _mm_cmpnle_ps
#define _mm_cmpnle_ps(a, b) raylab_not_ps(simde_mm_cmple_ps(a, b))
inline simde__m256d raylab_max_pd(simde__m256d a, simde__m256d b) {
  return simde_mm256_blendv_pd(b, a, simde_mm256_cmp_pd(a, b, SIMDE_CMP_GT_OQ));
}
#undef _mm256_max_pd
#define _mm256_max_pd(a, b) raylab_max_pd(a, b)

#endif
