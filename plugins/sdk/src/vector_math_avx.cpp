// vector_math's AVX kernels: compiled with -mavx (no FMA), run only where the processor has AVX.
#include <immintrin.h>
#include <sleef.h>

#include "vector_math_kernels.hpp"

namespace locsim::sdk::vector_math::detail {

void run_avx(Op op, const double* in, double* out0, double* out1, std::size_t blocks) {
  for (std::size_t k = 0; k < blocks; ++k, in += 4, out0 += 4) {
    const __m256d x = _mm256_loadu_pd(in);
    switch (op) {
      case Op::kSinCos: {
        const Sleef___m256d_2 r = Sleef_cinz_sincosd4_u10avx(x);
        _mm256_storeu_pd(out0, r.x);
        _mm256_storeu_pd(out1 + 4 * k, r.y);
        break;
      }
      case Op::kExp:
        _mm256_storeu_pd(out0, Sleef_cinz_expd4_u10avx(x));
        break;
      case Op::kLog1p:
        _mm256_storeu_pd(out0, Sleef_cinz_log1pd4_u10avx(x));
        break;
    }
  }
}

}  // namespace locsim::sdk::vector_math::detail
