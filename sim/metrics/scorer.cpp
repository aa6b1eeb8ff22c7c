#include "sim/metrics/scorer.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>

#include "sim/common/files.hpp"
#include "sim/common/format.hpp"
#include "sim/common/math.hpp"
#include "sim/sensors/models.hpp"

namespace locsim {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace {

// What a kind of reading must show after a kidnap's landing for a filter using it to be able to
// find the robot again. Landmarks: two distinct ones (range and bearing to one known landmark
// leave the robot anywhere on a circle round it, facing it). Beacons: three distinct ones in line
// of sight (two ranges cross twice). Laser: scans that tell the true place apart from every
// other (LaserPlaceJudge: not in a symmetric room or a featureless stretch of corridor), or, when
// the scorer has no map to judge by, one scan. Odometry and IMU alone never find a kidnapped
// robot.
constexpr std::size_t kLandmarksToRecover = 2;
constexpr std::size_t kBeaconsToRecover = 3;
constexpr long kLaserScansToRecover = 1;
// The laser's judgement weighs a scan a second for the first ten seconds after the landing: enough
// for the robot to drive past what tells alike places apart, and a bounded cost (a coarse search
// over the map on the first, then the candidates refined over all).
constexpr std::size_t kLaserProbes = 10;
constexpr double kLaserProbeEveryS = 1.0;
constexpr std::size_t kLaserProbeBeams = 60;  // end points kept per probe, evenly spread

json error_json(const ErrorSummary& e) {
  // No samples, no errors: null, not a perfect 0 (a log without truth, a localizer that failed
  // before its first estimate).
  const auto value = [&](double v) { return e.samples > 0 ? json(v) : json(nullptr); };
  return {{"samples", e.samples},
          {"position_error_m",
           {{"rms", value(e.position_rms_m)},
            {"mean", value(e.position_mean_m)},
            {"max", value(e.position_max_m)},
            {"rms_x", value(e.x_rms_m)},
            {"rms_y", value(e.y_rms_m)}}},
          {"heading_error_deg",
           {{"rms", value(rad_to_deg(e.heading_rms_rad))},
            {"mean", value(rad_to_deg(e.heading_mean_rad))},
            {"max", value(rad_to_deg(e.heading_max_rad))}}},
          {"time_lost_s", value(e.time_lost_s)},
          {"consistency", e.consistency_samples == 0
                              ? json(nullptr)
                              : json{{"samples", e.consistency_samples},
                                     {"nees_mean", e.nees_mean},
                                     {"nees_median", e.nees_median},
                                     {"position_nees_mean", e.position_nees_mean},
                                     {"inside_95_ellipse", e.inside_95_fraction}}}};
}

json landmark_map_json(const LandmarkMapSummary& s) {
  const auto optional = [](const std::optional<double>& v) { return v ? json(*v) : json(nullptr); };
  return {{"mapped", s.mapped},
          {"matched", s.matched},
          {"error_m",
           {{"rms", optional(s.error_rms_m)},
            {"mean", optional(s.error_mean_m)},
            {"max", optional(s.error_max_m)}}},
          {"error_aligned_m",
           {{"rms", optional(s.aligned_rms_m)},
            {"mean", optional(s.aligned_mean_m)},
            {"max", optional(s.aligned_max_m)}}},
          {"aligned_within", s.aligned_within},
          {"aligned_gate_m", kLandmarkAlignedGateM},
          {"spurious", s.spurious},
          {"missed", s.missed},
          {"observed", s.observed},
          {"gate_m", kLandmarkMatchGateM}};
}

/// LABEL_map.csv: a SLAM filter's final landmark map, one row per landmark in the plugin's order.
void write_landmark_map_csv(const fs::path& file,
                            const std::vector<locsim_mapped_landmark>& landmarks) {
  std::string text = "id,x_m,y_m,cov_xx,cov_xy,cov_yy\n";
  for (const locsim_mapped_landmark& l : landmarks) {
    text += std::to_string(l.id) + ',';
    append_fixed(text, l.x, 6);
    text += ',';
    append_fixed(text, l.y, 6);
    for (const double c : {l.covariance[0], l.covariance[1], l.covariance[3]}) {
      text += ',';
      append_fixed(text, c, 9);
    }
    text += '\n';
  }
  write_file(file, text);
}

}  // namespace

Scorer::Scorer(const WorldDef& world, std::vector<LocalizerInfo> localizers,
               const ConvergenceCriterion& criterion, const OccupancyGrid* grid)
    : criterion_(criterion),
      kidnaps_(world.robots.size()),
      put_downs_(world.robots.size()),
      observed_(world.robots.size()),
      sensed_(world.robots.size()) {
  for (const LandmarkDef& l : world.landmarks) {
    true_landmarks_.push_back({l.id, l.position_m.x(), l.position_m.y()});
  }
  bool any_laser = false;
  for (const RobotDef& r : world.robots) {
    robot_names_.push_back(r.name);
    lasers_.push_back(r.sensors.laser);
    any_laser = any_laser || r.sensors.laser.has_value();
  }
  bool reads_laser = false;
  for (LocalizerInfo& info : localizers) {
    reads_laser = reads_laser || info.readings == 0 ||
                  (info.readings & LOCSIM_READING_BIT(LOCSIM_READING_LASER)) != 0;
    Track& track = tracks_.emplace_back();
    track.info = std::move(info);
    track.all = ErrorAccumulator(criterion);
    track.segment = ErrorAccumulator(criterion);
  }
  // The judge costs distance transforms of the map and a search per kidnap: only when a filter's
  // verdict may need it (and built when one does, laser_verdict).
  if (grid != nullptr && grid->width > 0 && grid->height > 0 && any_laser && reads_laser)
    judged_map_ = *grid;
}

void Scorer::consume(const Record& record) {
  if (record.type == Record::Type::kGroundTruth && judged_map_ && truth_known(record.pose)) {
    // A probe scan's true pose: the ground truth of the step it was taken in (readings come
    // before the step's ground truth in the stream).
    const auto r = static_cast<std::size_t>(record.robot);
    if (r < sensed_.size() && !kidnaps_[r].empty() && sensed_[r].size() > kidnaps_[r].size()) {
      Sensed& sensed = sensed_[r][kidnaps_[r].size()];
      if (sensed.pending_probe) {
        sensed.laser_probes.push_back({record.pose, std::move(*sensed.pending_probe)});
        sensed.pending_probe.reset();
      }
    }
    return;
  }
  if (record.type == Record::Type::kEvent) {
    const bool kidnap = record.event.kind == "kidnap";
    if (!kidnap && record.event.kind != "put_down") return;
    for (std::size_t r = 0; r < robot_names_.size(); ++r) {
      if (robot_names_[r] == record.event.robot)
        (kidnap ? kidnaps_ : put_downs_)[r].push_back(record.event.t_s);
    }
    return;
  }
  if (record.type != Record::Type::kReading) return;
  const auto r = static_cast<std::size_t>(record.reading.robot);
  if (r >= robot_names_.size()) return;
  // After the latest kidnap's put-down (not while carried): what the sensors show now decides
  // whether that kidnap can be recovered from.
  Sensed* sensed = nullptr;
  if (!kidnaps_[r].empty() && put_downs_[r].size() >= kidnaps_[r].size()) {
    sensed_[r].resize(kidnaps_[r].size() + 1);
    sensed = &sensed_[r][kidnaps_[r].size()];
  }
  // What the cameras have shown the robot: a SLAM filter's map is judged against these.
  const auto note = [&](const std::vector<Detection>& detections, bool map_camera) {
    for (const Detection& d : detections) {
      if (d.truth_id < 0 || d.target != DetectionTarget::kLandmark) continue;
      if (map_camera) observed_[r].insert(d.truth_id);
      if (sensed != nullptr) sensed->landmarks.insert(d.truth_id);
    }
  };
  if (const auto* ptz = std::get_if<PtzReading>(&record.reading.data)) {
    note(ptz->detections, true);
  } else if (const auto* omni = std::get_if<OmniReading>(&record.reading.data)) {
    note(omni->detections, true);
  } else if (const auto* rb = std::get_if<RangeBearingReading>(&record.reading.data)) {
    note(rb->detections, false);
  } else if (sensed == nullptr) {
    return;
  } else if (const auto* ultrasonic = std::get_if<UltrasonicReading>(&record.reading.data)) {
    for (const BeaconRange& range : ultrasonic->ranges) {
      if (std::isfinite(range.range_m) && range.truth_status == RangeStatus::kLineOfSight)
        sensed->beacons.insert(range.beacon_id);
    }
  } else if (const auto* scan = std::get_if<LaserScan>(&record.reading.data)) {
    ++sensed->laser_scans;
    if (judged_map_ && lasers_[r] && sensed->laser_probes.size() < kLaserProbes &&
        !sensed->pending_probe && record.reading.t_s >= sensed->next_probe_s) {
      // The hits' end points in the robot frame, at most kLaserProbeBeams of them.
      const LaserDef& laser = *lasers_[r];
      const int beams = static_cast<int>(scan->ranges_m.size());
      const int stride = std::max(1, beams / static_cast<int>(kLaserProbeBeams));
      std::vector<Vec2> end_points;
      for (int i = 0; i < beams; i += stride) {
        const double range = scan->ranges_m[static_cast<std::size_t>(i)];
        if (!(range >= laser.min_range_m && range < laser.max_range_m)) continue;
        const double angle = laser_beam_angle(i, beams, laser.fov_rad);
        end_points.push_back(
            laser.common.mount.transform(Vec2(range * std::cos(angle), range * std::sin(angle))));
      }
      sensed->pending_probe = std::move(end_points);
      sensed->next_probe_s = record.reading.t_s + kLaserProbeEveryS;
    }
  }
}

const LaserPlaceVerdict* Scorer::laser_verdict(const Track& track) const {
  if (!judged_map_ || track.kidnaps_passed == 0) return nullptr;
  const Sensed& sensed = sensed_since_kidnap(track);
  if (sensed.laser_probes.empty()) return nullptr;
  const auto key = std::pair{track.info.robot, track.kidnaps_passed};
  auto it = laser_verdicts_.find(key);
  if (it == laser_verdicts_.end()) {
    if (!laser_judge_) laser_judge_.emplace(*judged_map_);
    it = laser_verdicts_.emplace(key, laser_judge_->judge(sensed.laser_probes)).first;
  }
  return &it->second;
}

const Scorer::Sensed& Scorer::sensed_since_kidnap(const Track& track) const {
  static const Sensed kNothing;  // no reading since the put-down (or a kidnap at the very end)
  const std::vector<Sensed>& by_kidnap = sensed_[track.info.robot];
  return track.kidnaps_passed < by_kidnap.size() ? by_kidnap[track.kidnaps_passed] : kNothing;
}

std::optional<bool> Scorer::recoverable(const Track& track) const {
  if (track.kidnaps_passed == 0) return std::nullopt;
  const Sensed& sensed = sensed_since_kidnap(track);
  const std::uint32_t uses = track.info.readings != 0 ? track.info.readings : ~0u;
  const auto used = [&](int kind) { return (uses & LOCSIM_READING_BIT(kind)) != 0; };
  const auto laser_tells = [&] {
    if (sensed.laser_scans < kLaserScansToRecover) return false;
    if (!judged_map_) return true;  // no map to judge by: any scan
    const LaserPlaceVerdict* verdict = laser_verdict(track);
    return verdict != nullptr && verdict->told_apart;
  };
  return (used(LOCSIM_READING_LANDMARKS) && sensed.landmarks.size() >= kLandmarksToRecover) ||
         (used(LOCSIM_READING_BEACON_RANGES) && sensed.beacons.size() >= kBeaconsToRecover) ||
         (used(LOCSIM_READING_LASER) && laser_tells());
}

json Scorer::segment_json(const Track& track) const {
  const ErrorAccumulator& segment = track.segment;
  const ErrorSummary summary = segment.summary();
  json out = {{"from_s", segment.first_t_s()}, {"to_s", segment.last_t_s()}};
  out.update(error_json(summary));
  out["recovery_s"] =
      summary.converged_at_s ? json(*summary.converged_at_s - segment.first_t_s()) : json(nullptr);
  out["recovery_steps"] =
      summary.converged_at_steps ? json(*summary.converged_at_steps) : json(nullptr);
  out["tracking"] = {
      {"samples", summary.tracking_samples},
      {"position_rms_m",
       summary.tracking_samples > 0 ? json(summary.tracking_position_rms_m) : json(nullptr)},
      {"consistency_samples", summary.tracking_consistency_samples},
      {"inside_95_ellipse", summary.tracking_consistency_samples > 0
                                ? json(summary.tracking_inside_95_fraction)
                                : json(nullptr)}};
  out["jumps"] = {{"count", summary.jumps},
                  {"first_s", summary.first_jump_s ? json(*summary.first_jump_s) : json(nullptr)}};
  if (track.kidnaps_passed > 0) {
    out["carried_m"] = track.carried_m ? json(*track.carried_m) : json(nullptr);
    out["turned_deg"] = track.turned_rad ? json(rad_to_deg(*track.turned_rad)) : json(nullptr);
    const Sensed& sensed = sensed_since_kidnap(track);
    out["sensed"] = {{"landmarks", sensed.landmarks.size()},
                     {"beacons", sensed.beacons.size()},
                     {"laser_scans", sensed.laser_scans}};
    if (const LaserPlaceVerdict* v = laser_verdict(track)) {
      const auto optional = [](const std::optional<double>& x) {
        return x ? json(*x) : json(nullptr);
      };
      out["sensed"]["laser_place"] = {
          {"told_apart", v->told_apart},
          {"log_ratio", std::isfinite(v->log_ratio) ? json(v->log_ratio) : json(nullptr)},
          {"other_m", optional(v->other_m)},
          {"other_deg", optional(v->other_deg)}};
    }
    out["recoverable"] = *recoverable(track);
  }
  return out;
}

void Scorer::estimate(const EstimateSample& s) {
  Track& track = tracks_[s.localizer];
  const auto add_diagnostics = [&] {
    if (!s.diagnostics.empty()) track.last_diagnostics = s.diagnostics;
    for (const auto& [name, value] : s.diagnostics) {
      auto& [sum, samples] = track.diagnostic_sums[name];
      sum += value;
      ++samples;
    }
  };
  if (!truth_known(s.truth)) {
    ++track.unscored;  // a log without truth: the estimate is kept (its .tum), not scored
    add_diagnostics();
    return;
  }
  // Segments between kidnaps: a sample at a kidnap's time opens the segment after it. The
  // kidnap's event came earlier in the stream than any estimate of that time.
  const std::vector<double>& kidnaps = kidnaps_[track.info.robot];
  while (track.kidnaps_passed < kidnaps.size() && s.t_s >= kidnaps[track.kidnaps_passed]) {
    if (!track.segment.empty()) track.closed_segments.push_back(segment_json(track));
    track.segment = ErrorAccumulator(criterion_);
    ++track.kidnaps_passed;
    track.before_kidnap = track.last_truth;
    track.carried_m.reset();
    track.turned_rad.reset();
  }
  // The kidnap's put-down event, too, came before any estimate of its time.
  const std::vector<double>& put_downs = put_downs_[track.info.robot];
  if (track.kidnaps_passed > 0 && !track.carried_m && track.before_kidnap &&
      put_downs.size() >= track.kidnaps_passed && s.t_s >= put_downs[track.kidnaps_passed - 1]) {
    track.carried_m =
        std::hypot(s.truth.x - track.before_kidnap->x, s.truth.y - track.before_kidnap->y);
    track.turned_rad = std::abs(wrap_angle(s.truth.theta - track.before_kidnap->theta));
  }
  track.last_truth = s.truth;
  const ErrorSample error{s.t_s,
                          s.pose.x - s.truth.x,
                          s.pose.y - s.truth.y,
                          wrap_angle(s.pose.theta - s.truth.theta),
                          s.perception_updates,
                          s.covariance};
  track.all.add(error);
  track.segment.add(error);
  add_diagnostics();
}

void Scorer::failure(const LocalizerFailure& failure) {
  Track& track = tracks_[failure.localizer];
  if (!track.failure) track.failure = failure;
}

json Scorer::metrics_json(const Track& track, const LocalizerFinal& end) const {
  json out;
  out["label"] = track.info.label;
  out["plugin"] = track.info.plugin;
  // The kinds of reading the plugin says it uses (null: it does not say, so all of them).
  json readings = json::array();
  for (const auto& [kind, name] : {std::pair{LOCSIM_READING_ODOMETRY, "odometry"},
                                   {LOCSIM_READING_IMU, "imu"},
                                   {LOCSIM_READING_LANDMARKS, "landmarks"},
                                   {LOCSIM_READING_BEACON_RANGES, "beacon_ranges"},
                                   {LOCSIM_READING_LASER, "laser"}}) {
    if ((track.info.readings & LOCSIM_READING_BIT(kind)) != 0) readings.push_back(name);
  }
  out["readings"] = track.info.readings != 0 ? readings : json(nullptr);
  out["params"] = json::parse(track.info.params_json);
  out["status"] = !track.failure ? "ok" : track.failure->interrupted ? "interrupted" : "failed";
  if (track.failure) {
    const LocalizerFailure& f = *track.failure;
    out["failure"] = {{"t_s", f.t_s}, {"call", f.call}, {"message", f.message}};
    if (f.signal) out["failure"]["signal"] = *f.signal;
    if (f.timeout_s) out["failure"]["timeout_s"] = *f.timeout_s;
  }
  const ErrorSummary e = track.all.summary();
  out.update(error_json(e));
  // Estimates at instants the log has no truth for (an imported bag without it): kept in the
  // localizer's .tum, scored against nothing.
  if (track.unscored > 0) out["unscored_samples"] = track.unscored;
  const ConvergenceCriterion& c = criterion_;
  out["convergence"] = {
      {"position_m", c.position_m},
      {"heading_deg", rad_to_deg(c.heading_rad)},
      {"hold_samples", c.hold_samples},
      {"time_s", e.converged_at_s ? json(*e.converged_at_s) : json(nullptr)},
      {"steps", e.converged_at_steps ? json(*e.converged_at_steps) : json(nullptr)}};
  json segments = track.closed_segments;
  if (!track.segment.empty()) segments.push_back(segment_json(track));
  // Jumps are counted within segments: a kidnap's carry moves the truth, not the estimate.
  std::size_t jumps = 0;
  json first_jump_s = nullptr;
  for (const json& segment : segments) {
    jumps += segment["jumps"]["count"].get<std::size_t>();
    if (first_jump_s.is_null()) first_jump_s = segment["jumps"]["first_s"];
  }
  out["jumps"] = {
      {"count", jumps}, {"first_s", first_jump_s}, {"m", kJumpM}, {"window_s", kJumpWindowS}};
  out["segments"] = segments;
  json diagnostics = json::object(), means = json::object();
  for (const auto& [name, value] : track.last_diagnostics) diagnostics[name] = value;
  for (const auto& [name, sum] : track.diagnostic_sums) {
    means[name] = sum.first / static_cast<double>(std::max<long>(sum.second, 1));
  }
  out["diagnostics"] = diagnostics;
  out["diagnostics_mean"] = means;  // over the ground-truth samples
  out["updates"] = end.known ? json(end.updates) : json(nullptr);
  return out;
}

json Scorer::write(const std::vector<fs::path>& robot_dirs,
                   const std::vector<LocalizerFinal>& ends) const {
  json summaries = json::array();
  for (std::size_t r = 0; r < robot_dirs.size(); ++r) {
    json entries = json::array(), timing = json::object();
    bool any = false;
    for (std::size_t k = 0; k < tracks_.size(); ++k) {
      const Track& track = tracks_[k];
      if (track.info.robot != r) continue;
      any = true;
      const LocalizerFinal& end = ends[k];
      json entry = metrics_json(track, end);
      if (!end.landmark_map.empty()) {
        write_landmark_map_csv(robot_dirs[r] / (track.info.label + "_map.csv"), end.landmark_map);
        std::vector<LandmarkPoint> mapped;
        for (const locsim_mapped_landmark& l : end.landmark_map) mapped.push_back({l.id, l.x, l.y});
        entry["landmark_map"] =
            landmark_map_json(summarize_landmark_map(mapped, true_landmarks_, observed_[r]));
      }
      timing[track.info.label] = end.known
                                     ? json{{"updates", end.cost.calls},
                                            {"cost_per_update_us",
                                             {{"mean", end.cost.mean_us},
                                              {"p99", end.cost.p99_us},
                                              {"max", end.cost.max_us}}}}
                                     : json{{"updates", nullptr}, {"cost_per_update_us", nullptr}};
      summaries.push_back({{"robot", track.info.robot_name},
                           {"label", track.info.label},
                           {"status", entry["status"]},
                           {"position_rms_m", entry["position_error_m"]["rms"]}});
      if (track.failure) {
        std::fprintf(
            stderr,
            "locsim: warning: localizer '%s' of robot '%s' failed at t = %.3f s in %s: %s\n",
            track.info.label.c_str(), track.info.robot_name.c_str(), track.failure->t_s,
            track.failure->call.c_str(), track.failure->message.c_str());
      }
      entries.push_back(std::move(entry));
    }
    if (!any) continue;
    json metrics;
    metrics["robot"] = robot_names_[r];
    metrics["localizers"] = entries;
    metrics["timing"] = timing;
    write_json_atomically(robot_dirs[r] / "metrics.json", metrics);
  }
  return summaries;
}

std::vector<std::string> Scorer::failed() const {
  std::vector<std::string> out;
  for (const Track& track : tracks_) {
    if (!track.failure || track.failure->interrupted) continue;
    out.push_back(robot_names_.size() > 1 ? track.info.robot_name + "/" + track.info.label
                                          : track.info.label);
  }
  return out;
}

}  // namespace locsim
