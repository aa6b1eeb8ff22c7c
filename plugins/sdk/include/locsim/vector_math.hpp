// Elementary functions over arrays, for the per-particle loops of filters: sin and cos, exp and
// log1p of every element, several elements per instruction. Results are bit-identical on every
// processor: the functions are SLEEF's deterministic ones ("cinz": no fused multiply-add, the
// same bits from the portable C, SSE2, AVX and AVX-512 versions; Shibata and Petrogalli, "SLEEF:
// a portable vectorized library of C standard mathematical functions", IEEE TPDS 2020), and the
// widest this processor runs is chosen at run time. Within 1 ulp of the exact result, as libm's
// are, though not always libm's bits (about 3.5 % of sines differ from glibc's by 1 ulp).
//
// Measured on the 2-core development VM over 10 000 elements (BM_VectorMath): sin and cos 6x
// glibc's sincos with AVX-512, 3.2x with AVX; exp 3.1x and 2.2x; log1p 4.7x and 2.5x.
// Two slow corners, where the processor works on subnormal numbers: log1p of x below about 1e-36
// (5-13x slower: a power of x in its polynomial is subnormal; clamp, as landmark_pf's outlier
// mixture does at e^-40) and exp of -745..-708 (6x slower: the result is subnormal).
#pragma once

#include <cstddef>
#include <span>

namespace locsim::sdk::vector_math {

/// The versions, narrowest first. kPortable runs anywhere (one element at a time).
enum class Isa { kPortable, kSse2, kAvx, kAvx512 };

/// The widest version this processor runs and this build has.
Isa widest_isa();
/// "portable", "sse2", "avx" or "avx512".
const char* isa_name(Isa isa);

/// sin_out[i] = sin(angle_rad[i]), cos_out[i] = cos(angle_rad[i]). Spans of one size; an output
/// may be the input.
void sincos(std::span<const double> angle_rad, std::span<double> sin_out,
            std::span<double> cos_out);
/// out[i] = exp(x[i]).
void exp(std::span<const double> x, std::span<double> out);
/// out[i] = log(1 + x[i]).
void log1p(std::span<const double> x, std::span<double> out);

/// The same on a given version (tests compare them); std::invalid_argument if this processor
/// does not run it.
void sincos(Isa isa, std::span<const double> angle_rad, std::span<double> sin_out,
            std::span<double> cos_out);
void exp(Isa isa, std::span<const double> x, std::span<double> out);
void log1p(Isa isa, std::span<const double> x, std::span<double> out);

}  // namespace locsim::sdk::vector_math
