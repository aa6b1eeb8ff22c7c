// Particle updates per second for the landmark model: motion sampling, weighting by 6 landmark
// detections, normalisation, N_eff and low-variance resampling. Target (issue 6): >= 10 million
// particle updates per second per core; 10 000 particles well under a millisecond.
#include <benchmark/benchmark.h>

#include "locsim/particles.hpp"

namespace {

using namespace locsim::sdk;

void BM_ParticleUpdateLandmarks(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  Random random(1);
  ParticleSet particles, scratch;
  particles.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    particles.x[i] = random.uniform(0, 6), particles.y[i] = random.uniform(0, 4);
    particles.theta[i] = random.uniform(-3.14, 3.14);
  }
  const double landmarks[6][2] = {{0, 0}, {3, 0}, {6, 0}, {6, 4}, {3, 4}, {0, 4}};
  const OdometryDelta delta{0.01, 0.03, -0.01};
  const OdometryNoise noise;
  std::vector<std::size_t> chosen;
  for (auto _ : state) {
    sample_motion(particles, delta, noise, random);
    for (std::size_t i = 0; i < n; ++i) {
      double log_w = 0.0;
      for (const auto& l : landmarks) {
        log_w += landmark_log_match(particles.x[i], particles.y[i], particles.theta[i], 2.5, 0.3,
                                    l[0], l[1], 0.3, 0.1);
      }
      particles.weight[i] = std::exp(log_w) + 1e-300;
    }
    normalize(particles.weight);
    benchmark::DoNotOptimize(effective_sample_size(particles.weight));
    low_variance_resample(particles.weight, random, chosen);
    apply_resample(particles, chosen, scratch);
  }
  state.counters["particle_updates_per_s"] =
      benchmark::Counter(static_cast<double>(n) * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ParticleUpdateLandmarks)->Arg(400)->Arg(10000)->Unit(benchmark::kMicrosecond);

}  // namespace
