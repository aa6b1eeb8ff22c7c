#include "sim/plugin_host/instance_runner.hpp"

#include <algorithm>

namespace locsim {

InstanceRunner::InstanceRunner(const std::vector<const LocalizerDef*>& defs, CallState* calls) {
  for (const LocalizerDef* def : defs) {
    ParamSet params(def->library->table(), def->spec);  // checked by the host already
    instances_.push_back(std::make_unique<LocalizerInstance>(
        def->library, def->info.label, std::move(params), *def->world, def->seed, calls,
        static_cast<int>(def->index)));
    indices_.push_back(def->index);
    reported_.push_back(false);
    const int robot = static_cast<int>(def->info.robot);
    if (robot_slot_.size() <= def->info.robot) robot_slot_.resize(def->info.robot + 1, -1);
    if (robot_slot_[def->info.robot] < 0) {
      robot_slot_[def->info.robot] = static_cast<int>(robots_.size());
      robots_.push_back(Robot{robot, ReadingTranslator(*def->robot), {}});
    }
    robots_[static_cast<std::size_t>(robot_slot_[def->info.robot])].slots.push_back(
        instances_.size() - 1);
  }
}

void InstanceRunner::report_failure(std::size_t slot, EstimateConsumer& out) {
  const LocalizerInstance& instance = *instances_[slot];
  if (!instance.failed() || reported_[slot]) return;
  reported_[slot] = true;
  const LocalizerInstance::Failure& f = *instance.failure();
  LocalizerFailure failure;
  failure.localizer = indices_[slot];
  failure.t_s = f.t_s;
  failure.call = f.call;
  failure.message = f.message;
  out.failure(failure);
}

void InstanceRunner::consume(const Record& record, EstimateConsumer& out) {
  if (record.type != Record::Type::kReading && record.type != Record::Type::kGroundTruth) return;
  const int robot_index =
      record.type == Record::Type::kReading ? record.reading.robot : record.robot;
  if (robot_index < 0 || static_cast<std::size_t>(robot_index) >= robot_slot_.size() ||
      robot_slot_[static_cast<std::size_t>(robot_index)] < 0) {
    return;
  }
  Robot& robot =
      robots_[static_cast<std::size_t>(robot_slot_[static_cast<std::size_t>(robot_index)])];
  if (record.type == Record::Type::kReading) {
    const locsim_reading& reading = robot.translator.translate(record.reading);
    for (const std::size_t slot : robot.slots) {
      instances_[slot]->deliver(reading);
      report_failure(slot, out);
    }
    return;
  }
  for (const std::size_t slot : robot.slots) {
    LocalizerInstance& instance = *instances_[slot];
    if (instance.failed()) continue;
    EstimateSample sample;
    sample.diagnostics = instance.diagnostics(record.t_s);  // sampled for their means
    const std::optional<locsim_estimate> estimate = instance.estimate(record.t_s);
    if (!estimate) {
      report_failure(slot, out);
      continue;
    }
    sample.localizer = indices_[slot];
    sample.t_s = record.t_s;
    sample.truth = record.pose;
    sample.pose = {estimate->pose.x, estimate->pose.y, estimate->pose.theta};
    std::copy(std::begin(estimate->covariance), std::end(estimate->covariance),
              sample.covariance.begin());
    sample.perception_updates = instance.perception_updates();
    out.estimate(sample);
  }
}

std::vector<LocalizerSnapshot> InstanceRunner::snapshot(double t_s, EstimateConsumer& out) {
  std::vector<LocalizerSnapshot> snapshots(instances_.size());
  for (std::size_t slot = 0; slot < instances_.size(); ++slot) {
    LocalizerInstance& instance = *instances_[slot];
    LocalizerSnapshot& s = snapshots[slot];
    s.estimate = instance.estimate(t_s);
    s.particles = instance.particles(t_s, &s.weights);
    s.landmark_map = instance.landmark_map(t_s);
    s.failed = instance.failed();
    report_failure(slot, out);
  }
  return snapshots;
}

std::vector<LocalizerFinal> InstanceRunner::finish(double t_end_s, EstimateConsumer& out) {
  std::vector<LocalizerFinal> finals(instances_.size());
  for (std::size_t slot = 0; slot < instances_.size(); ++slot) {
    LocalizerInstance& instance = *instances_[slot];
    LocalizerFinal& f = finals[slot];
    f.landmark_map = instance.landmark_map(t_end_s);  // a failure here shows in the status
    report_failure(slot, out);
    f.known = true;
    f.updates = instance.updates();
    f.perception_updates = instance.perception_updates();
    f.cost = instance.cost();
  }
  return finals;
}

}  // namespace locsim
