// The simulation as a producer of the record stream: after each step (and once before the
// first), that step's readings, then its events, then, at the ground-truth rate, the true pose of
// each robot on the floor (none while a robot is carried).
#pragma once

#include <cstdint>

#include "sim/producers/simulation.hpp"
#include "sim/stream/record.hpp"

namespace locsim {

class SimulationSource {
 public:
  explicit SimulationSource(Simulation& sim);
  /// The records of the step just taken, to `out`.
  void emit(RecordConsumer& out);
  Simulation& simulation() { return sim_; }

 private:
  Simulation& sim_;
  std::int64_t stride_ = 1;  // physics steps per ground-truth sample
  std::int64_t last_step_ = -1;
  Record record_;
};

}  // namespace locsim
