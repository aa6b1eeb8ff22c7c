// The per-version kernels of vector_math.cpp: each processes `blocks` whole vectors (2, 4 or 8
// doubles). Each lives in a source compiled for its instruction set (SLEEF's header declares a
// version's functions only where the compiler targets it, and only there is passing its vector
// types by value the right calling convention), reached only after the dispatcher checked the
// processor.
#pragma once

#include <cstddef>

namespace locsim::sdk::vector_math::detail {

enum class Op { kSinCos, kExp, kLog1p };

/// in: blocks x width values; out0 the sines or the results, out1 the cosines (kSinCos).
void run_sse2(Op op, const double* in, double* out0, double* out1, std::size_t blocks);
void run_avx(Op op, const double* in, double* out0, double* out1, std::size_t blocks);
void run_avx512(Op op, const double* in, double* out0, double* out1, std::size_t blocks);

}  // namespace locsim::sdk::vector_math::detail
