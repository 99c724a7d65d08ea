// What the vectorized loops share: Lanes, a GCC vector of kBatch doubles (an expression on Lanes is
// one instruction per 2, 4 or 8 doubles: SSE2, AVX2, AVX-512; scalars broadcast, 2.0 * x), and
// HYPERQN_VECTOR_CLONES, which compiles a hot function twice, for x86-64-v3 (AVX2 and FMA) and
// for plain x86-64, the loader picking the one the processor runs: the binary stays portable.
// GCC cannot clone virtual functions, so virtual ones call a cloned helper.
#pragma once

namespace hyperqn {

inline constexpr int kBatch = 8;
typedef double Lanes __attribute__((vector_size(kBatch * sizeof(double))));

#define HYPERQN_VECTOR_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))

}  // namespace hyperqn
