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

// SIMDe 0.7 emulates _mm256_fmsub_ps as a product and then a difference, two roundings; x86's is one
// fused rounding, which a fused a * b + (-c) is exactly (the negation is exact).
#undef _mm256_fmsub_ps
#define _mm256_fmsub_ps(a, b, c) simde_mm256_fmadd_ps(a, b, simde_mm256_xor_ps(c, simde_mm256_set1_ps(-0.0f)))

#endif
