// vector_math's AVX-512 kernels: compiled with -mavx512f (SLEEF's "nofma" versions), run only
// where the processor has AVX-512F.
#include <immintrin.h>
#include <sleef.h>

#include "vector_math_kernels.hpp"

namespace locsim::sdk::vector_math::detail {

void run_avx512(Op op, const double* in, double* out0, double* out1, std::size_t blocks) {
  for (std::size_t k = 0; k < blocks; ++k, in += 8, out0 += 8) {
    const __m512d x = _mm512_loadu_pd(in);
    switch (op) {
      case Op::kSinCos: {
        const Sleef___m512d_2 r = Sleef_cinz_sincosd8_u10avx512fnofma(x);
        _mm512_storeu_pd(out0, r.x);
        _mm512_storeu_pd(out1 + 8 * k, r.y);
        break;
      }
      case Op::kExp:
        _mm512_storeu_pd(out0, Sleef_cinz_expd8_u10avx512fnofma(x));
        break;
      case Op::kLog1p:
        _mm512_storeu_pd(out0, Sleef_cinz_log1pd8_u10avx512fnofma(x));
        break;
    }
  }
}

}  // namespace locsim::sdk::vector_math::detail
