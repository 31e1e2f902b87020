#pragma once
// LOOM_CPU_CLONES: a function compiled once per x86-64 level (AVX-512, AVX2, baseline), the clone
// picked at load time from the processor's features (GCC's target_clones). Clang 14 has no
// target_clones for C++: it compiles such a function for the first level alone, which is an
// illegal instruction on a processor without AVX-512. So the builds clang compiles (the
// sanitizer and fuzzing lanes) get the baseline code only.

#if defined(__clang__)
#define LOOM_CPU_CLONES
#else
#define LOOM_CPU_CLONES [[gnu::target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")]]
#endif
