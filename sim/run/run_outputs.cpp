#include "sim/run/run_outputs.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>

#include "sim/metrics/landmark_metrics.hpp"
#include "sim/run/simulation.hpp"

namespace locsim {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace {

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
  std::ofstream out(file, std::ios::binary);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + file.string());
}

json landmark_map_json(const LandmarkMapSummary& s) {
  const auto optional = [](const std::optional<double>& v) { return v ? json(*v) : json(nullptr); };
  return {{"mapped", s.mapped},
          {"matched", s.matched},
          {"error_m",
           {{"rms", optional(s.error_rms_m)},
            {"mean", optional(s.error_mean_m)},
            {"max", optional(s.error_max_m)}}},
          {"spurious", s.spurious},
          {"missed", s.missed},
          {"observed", s.observed},
          {"gate_m", kLandmarkMatchGateM}};
}

}  // namespace

void append_tum(std::string& line, double t_s, double x, double y, double theta) {
  append_fixed(line, t_s, 4);
  line += ' ';
  append_fixed(line, x, 6);
  line += ' ';
  append_fixed(line, y, 6);
  line += " 0 0 0 ";
  append_fixed(line, std::sin(0.5 * theta), 9);
  line += ' ';
  append_fixed(line, std::cos(0.5 * theta), 9);
  line += '\n';
}

void write_json_atomically(const fs::path& file, const json& content) {
  const fs::path temporary = file.string() + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary);
    out << content.dump(2) << '\n';
    if (!out) throw std::runtime_error("cannot write " + temporary.string());
  }
  fs::rename(temporary, file);
}

json write_localizer_metrics(const fs::path& dir, const std::string& robot, LocalizerHost& host,
                             const std::vector<double>& kidnaps_s, double t_end_s) {
  json summaries = json::array();
  json metrics;
  metrics["robot"] = robot;
  json entries = json::array(), timing = json::object();
  for (const auto& instance : host.instances()) {
    // The final landmark map first: a failure there shows in the entry's status.
    const std::vector<locsim_mapped_landmark> map = instance->landmark_map(t_end_s);
    json entry = instance->metrics(kidnaps_s);
    if (!map.empty()) {
      write_landmark_map_csv(dir / (instance->label() + "_map.csv"), map);
      std::vector<LandmarkPoint> mapped;
      for (const locsim_mapped_landmark& l : map) mapped.push_back({l.id, l.x, l.y});
      entry["landmark_map"] = landmark_map_json(
          summarize_landmark_map(mapped, host.true_landmarks(), host.observed_landmarks()));
    }
    entries.push_back(entry);
    const CostSummary cost = summarize_costs(instance->update_seconds());
    timing[instance->label()] = {
        {"updates", cost.calls},
        {"cost_per_update_us",
         {{"mean", cost.mean_us}, {"p99", cost.p99_us}, {"max", cost.max_us}}}};
    summaries.push_back({{"robot", robot},
                         {"label", instance->label()},
                         {"status", entry["status"]},
                         {"position_rms_m", entry["position_error_m"]["rms"]}});
    if (entry.contains("failure")) {
      std::fprintf(stderr,
                   "locsim: warning: localizer '%s' of robot '%s' failed at t = %.3f s in %s: %s\n",
                   instance->label().c_str(), robot.c_str(), entry["failure"]["t_s"].get<double>(),
                   entry["failure"]["call"].get<std::string>().c_str(),
                   entry["failure"]["message"].get<std::string>().c_str());
    }
  }
  metrics["localizers"] = entries;
  metrics["timing"] = timing;
  write_json_atomically(dir / "metrics.json", metrics);
  return summaries;
}

}  // namespace locsim
