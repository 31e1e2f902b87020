#pragma once
// LOOM_CPU_CLONES: a function compiled once per x86-64 level (AVX-512, AVX2, baseline), the clone
// picked at load time from the processor's features (target_clones). Clang 14 resolves an
// "arch=x86-64-v4" clone on processors without AVX-512 too (an illegal instruction in the
// sanitizer and fuzzing builds, which clang compiles), so clang names the clones by feature;
// GCC keeps the levels, whose tuning the benchmarks were measured with.

#if defined(__clang__)
#define LOOM_CPU_CLONES [[gnu::target_clones("avx512f", "avx2", "default")]]
#else
#define LOOM_CPU_CLONES [[gnu::target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")]]
#endif
