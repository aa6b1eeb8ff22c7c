#include "sim/producers/simulation_source.hpp"

#include <cmath>

namespace locsim {

SimulationSource::SimulationSource(Simulation& sim)
    : sim_(sim),
      stride_(std::llround(sim.world_def().physics.step_hz / sim.scenario().groundtruth_hz)) {}

void SimulationSource::emit(RecordConsumer& out) {
  for (Reading& reading : sim_.take_readings()) {
    record_.type = Record::Type::kReading;
    record_.robot = reading.robot;
    record_.reading = std::move(reading);
    out.consume(record_);
  }
  for (SimEvent& event : sim_.take_events()) {
    record_.type = Record::Type::kEvent;
    record_.robot = -1;
    for (std::size_t i = 0; i < sim_.robot_count(); ++i) {
      if (sim_.robot(i).name() == event.robot) record_.robot = static_cast<int>(i);
    }
    record_.event = std::move(event);
    out.consume(record_);
  }
  if (sim_.step_index() % stride_ != 0 || sim_.step_index() == last_step_) return;
  last_step_ = sim_.step_index();
  for (std::size_t i = 0; i < sim_.robot_count(); ++i) {
    const DiffDriveRobot& robot = sim_.robot(i);
    if (robot.carried()) continue;  // in the air: no floor pose to report or compare with
    record_.type = Record::Type::kGroundTruth;
    record_.t_s = sim_.time_s();
    record_.robot = static_cast<int>(i);
    record_.pose = robot.pose();
    out.consume(record_);
  }
}

}  // namespace locsim
