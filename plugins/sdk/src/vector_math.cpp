// vector_math's dispatcher, its portable and SSE2 kernels. Each call runs whole vectors of the
// chosen version, then the last few elements padded to one more vector: every element goes
// through the same function whatever the array's length.
#include "locsim/vector_math.hpp"

#include <sleef.h>

#include <algorithm>
#include <stdexcept>
#include <string>

#include "vector_math_kernels.hpp"

#ifdef LOCSIM_VECTOR_MATH_X86
#include <immintrin.h>
#endif

namespace locsim::sdk::vector_math {

namespace detail {
namespace {

void run_portable(Op op, const double* in, double* out0, double* out1, std::size_t count) {
  for (std::size_t i = 0; i < count; ++i) {
    switch (op) {
      case Op::kSinCos: {
        const auto r = Sleef_cinz_sincosd1_u10purec(in[i]);
        out0[i] = r.x, out1[i] = r.y;
        break;
      }
      case Op::kExp:
        out0[i] = Sleef_cinz_expd1_u10purec(in[i]);
        break;
      case Op::kLog1p:
        out0[i] = Sleef_cinz_log1pd1_u10purec(in[i]);
        break;
    }
  }
}

}  // namespace

#ifdef LOCSIM_VECTOR_MATH_X86
void run_sse2(Op op, const double* in, double* out0, double* out1, std::size_t blocks) {
  for (std::size_t k = 0; k < blocks; ++k, in += 2, out0 += 2) {
    const __m128d x = _mm_loadu_pd(in);
    switch (op) {
      case Op::kSinCos: {
        const Sleef___m128d_2 r = Sleef_cinz_sincosd2_u10sse2(x);
        _mm_storeu_pd(out0, r.x);
        _mm_storeu_pd(out1 + 2 * k, r.y);
        break;
      }
      case Op::kExp:
        _mm_storeu_pd(out0, Sleef_cinz_expd2_u10sse2(x));
        break;
      case Op::kLog1p:
        _mm_storeu_pd(out0, Sleef_cinz_log1pd2_u10sse2(x));
        break;
    }
  }
}
#endif

}  // namespace detail

namespace {

using detail::Op;

std::size_t width(Isa isa) {
  switch (isa) {
    case Isa::kPortable:
      return 1;
    case Isa::kSse2:
      return 2;
    case Isa::kAvx:
      return 4;
    case Isa::kAvx512:
      return 8;
  }
  return 1;
}

void run_blocks(Isa isa, Op op, const double* in, double* out0, double* out1, std::size_t blocks) {
  switch (isa) {
    case Isa::kPortable:
      detail::run_portable(op, in, out0, out1, blocks);
      return;
#ifdef LOCSIM_VECTOR_MATH_X86
    case Isa::kSse2:
      detail::run_sse2(op, in, out0, out1, blocks);
      return;
    case Isa::kAvx:
      detail::run_avx(op, in, out0, out1, blocks);
      return;
    case Isa::kAvx512:
      detail::run_avx512(op, in, out0, out1, blocks);
      return;
#else
    default:
      break;
#endif
  }
  throw std::logic_error("vector_math: no such version in this build");
}

void run(Isa isa, Op op, std::span<const double> in, std::span<double> out0,
         std::span<double> out1) {
  if (out0.size() != in.size() || (op == Op::kSinCos && out1.size() != in.size()))
    throw std::invalid_argument("vector_math: the outputs must be as long as the input");
  if (isa > widest_isa())
    throw std::invalid_argument(std::string("vector_math: this processor does not run ") +
                                isa_name(isa));
  const std::size_t w = width(isa), whole = in.size() / w, done = whole * w;
  run_blocks(isa, op, in.data(), out0.data(), out1.data(), whole);
  if (done == in.size()) return;
  double pad_in[8] = {}, pad0[8], pad1[8];
  std::copy(in.begin() + static_cast<std::ptrdiff_t>(done), in.end(), pad_in);
  run_blocks(isa, op, pad_in, pad0, pad1, 1);
  const std::size_t rest = in.size() - done;
  std::copy_n(pad0, rest, out0.begin() + static_cast<std::ptrdiff_t>(done));
  if (op == Op::kSinCos) std::copy_n(pad1, rest, out1.begin() + static_cast<std::ptrdiff_t>(done));
}

Isa detect() {
#ifdef LOCSIM_VECTOR_MATH_X86
  if (__builtin_cpu_supports("avx512f")) return Isa::kAvx512;
  if (__builtin_cpu_supports("avx")) return Isa::kAvx;
  return Isa::kSse2;  // every x86-64 has it
#else
  return Isa::kPortable;
#endif
}

}  // namespace

Isa widest_isa() {
  static const Isa isa = detect();
  return isa;
}

const char* isa_name(Isa isa) {
  switch (isa) {
    case Isa::kPortable:
      return "portable";
    case Isa::kSse2:
      return "sse2";
    case Isa::kAvx:
      return "avx";
    case Isa::kAvx512:
      return "avx512";
  }
  return "?";
}

void sincos(Isa isa, std::span<const double> angle_rad, std::span<double> sin_out,
            std::span<double> cos_out) {
  run(isa, Op::kSinCos, angle_rad, sin_out, cos_out);
}
void exp(Isa isa, std::span<const double> x, std::span<double> out) {
  run(isa, Op::kExp, x, out, {});
}
void log1p(Isa isa, std::span<const double> x, std::span<double> out) {
  run(isa, Op::kLog1p, x, out, {});
}

void sincos(std::span<const double> angle_rad, std::span<double> sin_out,
            std::span<double> cos_out) {
  sincos(widest_isa(), angle_rad, sin_out, cos_out);
}
void exp(std::span<const double> x, std::span<double> out) {
  exp(widest_isa(), x, out);
}
void log1p(std::span<const double> x, std::span<double> out) {
  log1p(widest_isa(), x, out);
}

}  // namespace locsim::sdk::vector_math
