// Seeded random streams. Every component draws from its own stream, derived from the run seed
// and the component's name, so adding a component never changes another one's numbers.
#pragma once

#include <cstdint>
#include <random>
#include <string_view>

namespace locsim {

/// One deterministic stream. The engine is std::mt19937_64, whose output the standard fixes;
/// the conversions to uniform and normal variates are our own so that results do not depend on
/// the standard library's (unspecified) distribution algorithms.
class RandomStream {
 public:
  explicit RandomStream(std::uint64_t seed) : engine_(seed) {}

  /// Uniform in [0, 1), 53 random bits.
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  /// Uniform in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Standard normal by the Marsaglia polar method.
  double normal();
  /// Normal with the given mean and standard deviation.
  double normal(double mean, double stddev) { return mean + stddev * normal(); }
  std::uint64_t next_u64() { return engine_(); }

 private:
  std::mt19937_64 engine_;
  double spare_normal_ = 0.0;
  bool has_spare_normal_ = false;
};

/// Derives the seed of the stream called `name` from the run seed (FNV-1a of the name mixed with
/// the seed through splitmix64).
std::uint64_t derive_seed(std::uint64_t run_seed, std::string_view name);

inline RandomStream make_stream(std::uint64_t run_seed, std::string_view name) {
  return RandomStream(derive_seed(run_seed, name));
}

}  // namespace locsim
