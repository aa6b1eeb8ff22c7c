#include "sim/run/run_outputs.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>

#include "sim/run/simulation.hpp"

namespace locsim {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

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
    (void)t_end_s;  // diagnostics were sampled with every estimate
    json entry = instance->metrics(kidnaps_s);
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
