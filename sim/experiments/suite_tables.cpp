#include "sim/experiments/suite_tables.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <set>
#include <sstream>

#include "sim/common/files.hpp"
#include "sim/common/format.hpp"
#include "sim/experiments/statistics.hpp"
#include "sim/metrics/error_metrics.hpp"
#include "sim/metrics/landmark_metrics.hpp"

namespace locsim {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace {

/// `text` on one line: each line break, with the next line's indentation, becomes a space.
std::string on_one_line(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '\n' && text[i] != '\r') {
      out += text[i];
      continue;
    }
    while (i + 1 < text.size() && std::isspace(static_cast<unsigned char>(text[i + 1]))) ++i;
    if (!out.empty() && out.back() != ' ') out += ' ';
  }
  return out;
}

}  // namespace

std::string csv_field(const std::string& text) {
  const std::string line = on_one_line(text);
  if (line.find_first_of(",\"") == std::string::npos) return line;
  std::string out = "\"";
  for (const char c : line) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string csv_number(const json& value, int decimals) {
  return value.is_number() ? fixed(value.get<double>(), decimals) : std::string();
}

std::optional<double> RunRecovery::tracking_rms_m() const {
  if (tracking_samples == 0) return std::nullopt;
  return std::sqrt(tracking_sum_sq / static_cast<double>(tracking_samples));
}

std::optional<double> RunRecovery::tracking_inside_95() const {
  if (tracking_consistency_samples == 0) return std::nullopt;
  return tracking_inside / static_cast<double>(tracking_consistency_samples);
}

RunRecovery recovery_of(const json& metrics) {
  RunRecovery out;
  const json convergence = metrics.value("convergence", json::object());
  const double position_m = convergence.value("position_m", 0.0),
               heading_deg = convergence.value("heading_deg", 0.0);
  const json segments = metrics.value("segments", json::array());
  for (std::size_t k = 0; k < segments.size(); ++k) {
    const json& segment = segments[k];
    if (const json tracking = segment.value("tracking", json()); tracking.is_object()) {
      const auto n = tracking.value("samples", std::size_t{0});
      const json rms = tracking.value("position_rms_m", json());
      if (n > 0 && rms.is_number()) {
        out.tracking_samples += n;
        out.tracking_sum_sq += rms.get<double>() * rms.get<double>() * static_cast<double>(n);
      }
      const auto m = tracking.value("consistency_samples", std::size_t{0});
      const json inside = tracking.value("inside_95_ellipse", json());
      if (m > 0 && inside.is_number()) {
        out.tracking_consistency_samples += m;
        out.tracking_inside += inside.get<double>() * static_cast<double>(m);
      }
    }
    if (const json jumps = segment.value("jumps", json()); jumps.is_object())
      out.jumps += jumps.value("count", std::size_t{0});
    if (k == 0) continue;
    const json carried = segment.value("carried_m", json()),
               turned = segment.value("turned_deg", json());
    // Without the carry's measure (metrics of an older locsim): counted.
    const bool moved = !carried.is_number() || !turned.is_number() ||
                       carried.get<double>() > position_m || turned.get<double>() > heading_deg;
    if (!moved) continue;
    ++out.kidnaps;
    // Without the scorer's judgement (metrics of an older locsim): recoverable.
    if (!segment.value("recoverable", true)) continue;
    ++out.recoverable;
    out.recovered += segment["recovery_s"].is_null() ? 0 : 1;
  }
  if (const json map = metrics.value("landmark_map", json()); map.is_object()) {
    out.map = RunRecovery::Map{
        map.value("observed", std::size_t{0}), map.value("aligned_within", std::size_t{0}),
        map.value("mapped", std::size_t{0}), map.value("spurious", std::size_t{0})};
  }
  return out;
}

std::pair<double, double> wilson_95(std::size_t k, std::size_t n) {
  if (n == 0) return {0.0, 1.0};
  const double z = 1.959963984540054, nn = static_cast<double>(n);
  const double p = static_cast<double>(k) / nn;
  const double centre = (p + z * z / (2 * nn)) / (1 + z * z / nn);
  const double half = z / (1 + z * z / nn) * std::sqrt(p * (1 - p) / nn + z * z / (4 * nn * nn));
  return {std::max(0.0, centre - half), std::min(1.0, centre + half)};
}

void write_family_tables(const fs::path& out_dir, const std::vector<json>& results,
                         const std::vector<std::string>& configs, std::ostream& md) {
  std::vector<std::string> families;
  for (const json& r : results) {
    const std::string family = r.value("family", "");
    if (!family.empty() && std::find(families.begin(), families.end(), family) == families.end())
      families.push_back(family);
  }
  if (families.empty()) return;
  if (families.size() > 1) families.push_back("");  // "": every family
  std::ostringstream csv;
  csv << "config,family,worlds,runs,ok,kidnaps,kidnaps_recoverable,kidnaps_recovered,"
         "kidnaps_recovered_share,kidnaps_recovered_ci95_low,"
         "kidnaps_recovered_ci95_high,position_rms_m_mean,"
         "position_rms_m_ci95,tracking_runs,tracking_position_rms_m_mean,"
         "tracking_position_rms_m_ci95,tracking_position_rms_m_median,inside_95_ellipse_mean,"
         "runs_with_jumps,jumps,tracking_inside_95_ellipse_mean\n";
  md << "\n### Per world family\n\n"
        "Each configuration on each family of the experiment's worlds, over worlds and seeds. "
        "Kidnaps: those that moved the robot beyond the convergence criterion (a shorter carry "
        "tests no recovery) and that the localizer's sensors made recoverable (after the "
        "landing they showed two distinct landmarks, three beacons in line of sight, or a laser "
        "scan; odometry alone never); recovered when the error came back within the criterion; "
        "the share with Wilson's 95 % interval, and after '/ N' all kidnaps. Tracking: the "
        "position RMS from each segment's "
        "convergence on (later losses included), over the runs that converged; mean ± 95 % "
        "confidence interval; median after ';'. Jumps: the runs whose error moved by more than "
     << short_number(kJumpM) << " m within " << short_number(kJumpWindowS)
     << " s of being within the criterion's position bound (and how many such jumps "
        "in all). Truth in the 95 % ellipse: over each run, and while converged (from each "
        "segment's convergence on).\n\n"
        "| config | family | worlds | runs | ok | kidnaps recovered | position RMS [m] | "
        "tracking RMS [m] | jumps while tracking | truth in the 95 % ellipse | while converged "
        "|\n"
        "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const std::string& config : configs) {
    for (const std::string& family : families) {
      std::set<std::string> worlds;
      std::size_t runs = 0, ok = 0, kidnaps = 0, recoverable = 0, recovered = 0;
      std::size_t runs_with_jumps = 0, jumps = 0;
      std::vector<double> position, tracking, inside, inside_converged;
      for (const json& r : results) {
        if (r["config"] != config || r.value("family", "").empty()) continue;
        if (!family.empty() && r.value("family", "") != family) continue;
        ++runs;
        worlds.insert(r.value("world", ""));
        if (r["status"] != "ok") continue;
        ++ok;
        const json& m = r["metrics"];
        position.push_back(m["position_error_m"]["rms"]);
        const RunRecovery recovery = recovery_of(m);
        kidnaps += recovery.kidnaps;
        recoverable += recovery.recoverable;
        recovered += recovery.recovered;
        if (const auto rms = recovery.tracking_rms_m()) tracking.push_back(*rms);
        if (const auto share = recovery.tracking_inside_95()) inside_converged.push_back(*share);
        runs_with_jumps += recovery.jumps > 0 ? 1 : 0;
        jumps += recovery.jumps;
        if (const json c = m.value("consistency", json()); c.is_object())
          inside.push_back(c["inside_95_ellipse"]);
      }
      if (runs == 0) continue;
      const Aggregate p = aggregate(position), t = aggregate(tracking), in = aggregate(inside),
                      ic = aggregate(inside_converged);
      const auto [low, high] = wilson_95(recovered, recoverable);
      const std::string share =
          recoverable > 0
              ? fixed(static_cast<double>(recovered) / static_cast<double>(recoverable), 4)
              : std::string();
      const std::string name = family.empty() ? "all" : family;
      csv << csv_field(config) << ',' << csv_field(name) << ',' << worlds.size() << ',' << runs
          << ',' << ok << ',' << kidnaps << ',' << recoverable << ',' << recovered << ',' << share
          << ',' << (recoverable > 0 ? fixed(low, 4) + ',' + fixed(high, 4) : std::string(","))
          << ',' << fixed(p.mean, 6) << ',' << fixed(p.ci95, 6) << ',' << t.n << ','
          << (t.n > 0 ? fixed(t.mean, 6) + ',' + fixed(t.ci95, 6) + ',' + fixed(t.median, 6)
                      : std::string(",,"))
          << ',' << (in.n > 0 ? fixed(in.mean, 4) : std::string()) << ',' << runs_with_jumps << ','
          << jumps << ',' << (ic.n > 0 ? fixed(ic.mean, 4) : std::string()) << '\n';
      md << "| " << config << " | " << (family.empty() ? "**all**" : family) << " | "
         << worlds.size() << " | " << runs << " | " << ok << " | "
         << (recoverable > 0 ? std::to_string(recovered) + "/" + std::to_string(recoverable) +
                                   " (" + fixed(low, 2) + "–" + fixed(high, 2) + ")"
                             : std::string("—"))
         << (kidnaps > 0 ? " / " + std::to_string(kidnaps) : std::string()) << " | "
         << fixed(p.mean, 3) << " ± " << fixed(p.ci95, 3) << "; " << fixed(p.median, 3) << " | "
         << (t.n > 0 ? fixed(t.mean, 3) + " ± " + fixed(t.ci95, 3) + "; " + fixed(t.median, 3) +
                           (t.n < ok ? " (" + std::to_string(t.n) + " runs)" : std::string())
                     : std::string("—"))
         << " | " << runs_with_jumps << " (" << jumps << ")"
         << " | " << (in.n > 0 ? fixed(in.mean, 2) + " ± " + fixed(in.ci95, 2) : std::string("—"))
         << " | " << (ic.n > 0 ? fixed(ic.mean, 2) + " ± " + fixed(ic.ci95, 2) : std::string("—"))
         << " |\n";
    }
  }
  write_file(out_dir / "summary_by_family.csv", csv.str());
}

namespace {

/// One configuration's figures on one part of the suite.
struct PartFigures {
  std::set<std::string> worlds;
  std::size_t runs = 0, ok = 0, recoverable = 0, recovered = 0, runs_with_jumps = 0, jumps = 0;
  std::vector<double> inside_converged, tracking;
  std::size_t maps = 0, observed = 0, aligned_within = 0, mapped = 0, spurious = 0;

  void add(const json& result) {
    ++runs;
    worlds.insert(result.value("world", ""));
    if (result["status"] != "ok") return;
    ++ok;
    const RunRecovery r = recovery_of(result["metrics"]);
    recoverable += r.recoverable;
    recovered += r.recovered;
    runs_with_jumps += r.jumps > 0 ? 1 : 0;
    jumps += r.jumps;
    if (const auto share = r.tracking_inside_95()) inside_converged.push_back(*share);
    if (const auto rms = r.tracking_rms_m()) tracking.push_back(*rms);
    if (r.map) {
      ++maps;
      observed += r.map->observed;
      aligned_within += r.map->aligned_within;
      mapped += r.map->mapped;
      spurious += r.map->spurious;
    }
  }
  static std::optional<double> share(std::size_t k, std::size_t n) {
    if (n == 0) return std::nullopt;
    return static_cast<double>(k) / static_cast<double>(n);
  }
  std::optional<double> recovered_share() const { return share(recovered, recoverable); }
  std::optional<double> jump_share() const { return share(runs_with_jumps, ok); }
  std::optional<double> inside_share() const {
    if (inside_converged.empty()) return std::nullopt;
    return aggregate(inside_converged).mean;
  }
  std::optional<double> landmark_share() const { return share(aligned_within, observed); }
  std::optional<double> spurious_share() const { return share(spurious, mapped); }
};

std::string optional_fixed(const std::optional<double>& v, int decimals) {
  return v ? fixed(*v, decimals) : std::string();
}

std::string share_percent(const std::optional<double>& v) {
  return v ? fixed(100.0 * *v, 0) + " %" : std::string("—");
}

}  // namespace

void write_part_tables(const fs::path& out_dir, const std::vector<json>& results,
                       const std::vector<std::string>& configs, std::ostream& md) {
  const bool any_held_back = std::any_of(results.begin(), results.end(),
                                         [](const json& r) { return r.value("held_back", false); });
  if (!any_held_back) return;
  std::ostringstream csv, gaps;
  csv << "config,part,worlds,runs,ok,kidnaps_recoverable,kidnaps_recovered,"
         "kidnaps_recovered_share,runs_with_jumps,jumps,tracking_inside_95_ellipse_mean,"
         "tracking_position_rms_m_median,landmarks_observed,landmarks_aligned_within,"
         "landmarks_aligned_share,landmarks_mapped,landmarks_spurious,landmarks_spurious_share\n";
  md << "\n### Chosen on and held back\n\n"
        "The same figures on the worlds the defaults were chosen on and on the worlds held back "
        "from that choice (`held_back: true`), over worlds and seeds. Kidnaps recovered: of those "
        "the localizer's sensors made recoverable. Jumps: runs whose error moved by more than "
     << short_number(kJumpM) << " m within " << short_number(kJumpWindowS)
     << " s of being within the convergence criterion's position bound. Truth in the "
        "95 % ellipse while converged: the mean over runs of the share from each segment's "
        "convergence on. Landmarks (SLAM filters): the true landmarks the cameras showed that the "
        "final map holds within "
     << short_number(kLandmarkAlignedGateM)
     << " m after aligning it, and the share of the map matching no true landmark.\n\n"
        "| config | part | worlds | runs | ok | kidnaps recovered | runs with a jump | truth in "
        "the 95 % ellipse while converged | tracking RMS [m], median | landmarks mapped | "
        "spurious |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const std::string& config : configs) {
    PartFigures parts[2];  // chosen on, held back
    for (const json& r : results) {
      if (r["config"] != config || r.value("family", "").empty()) continue;
      parts[r.value("held_back", false) ? 1 : 0].add(r);
    }
    for (int k = 0; k < 2; ++k) {
      const PartFigures& f = parts[k];
      if (f.runs == 0) continue;
      const Aggregate t = aggregate(f.tracking);
      const char* part = k == 0 ? "chosen_on" : "held_back";
      csv << csv_field(config) << ',' << part << ',' << f.worlds.size() << ',' << f.runs << ','
          << f.ok << ',' << f.recoverable << ',' << f.recovered << ','
          << optional_fixed(f.recovered_share(), 4) << ',' << f.runs_with_jumps << ',' << f.jumps
          << ',' << optional_fixed(f.inside_share(), 4) << ','
          << (t.n > 0 ? fixed(t.median, 6) : std::string()) << ',';
      if (f.maps > 0) {
        csv << f.observed << ',' << f.aligned_within << ',' << optional_fixed(f.landmark_share(), 4)
            << ',' << f.mapped << ',' << f.spurious << ',' << optional_fixed(f.spurious_share(), 4);
      } else {
        csv << ",,,,,";
      }
      csv << '\n';
      md << "| " << config << " | " << (k == 0 ? "chosen on" : "**held back**") << " | "
         << f.worlds.size() << " | " << f.runs << " | " << f.ok << " | "
         << (f.recoverable > 0 ? share_percent(f.recovered_share()) + " (" + std::to_string(f.recovered) +
                                     "/" + std::to_string(f.recoverable) + ")"
                               : std::string("—"))
         << " | " << f.runs_with_jumps << "/" << f.ok << " | " << share_percent(f.inside_share()) << " | "
         << (t.n > 0 ? fixed(t.median, 3) : std::string("—")) << " | "
         << (f.maps > 0 ? share_percent(f.landmark_share()) + " (" + std::to_string(f.aligned_within) +
                              "/" + std::to_string(f.observed) + ")"
                        : std::string("—"))
         << " | " << (f.maps > 0 ? share_percent(f.spurious_share()) : std::string("—")) << " |\n";
    }
    // Gaps between the parts, in points of a share.
    const auto gap = [&](const char* what, const std::optional<double>& chosen,
                         const std::optional<double>& held) {
      if (!chosen || !held) return;
      const double points = 100.0 * (*held - *chosen);
      if (std::abs(points) <= kPartGapPoints) return;
      gaps << "- **" << config << "**: " << what << ' ' << fixed(100.0 * *held, 0)
           << " % held back against " << fixed(100.0 * *chosen, 0) << " % chosen on ("
           << fixed(std::abs(points), 0) << " points " << (points < 0 ? "lower" : "higher")
           << ").\n";
    };
    gap("kidnaps recovered", parts[0].recovered_share(), parts[1].recovered_share());
    gap("runs with a jump while tracking", parts[0].jump_share(), parts[1].jump_share());
    gap("truth in the 95 % ellipse while converged", parts[0].inside_share(),
        parts[1].inside_share());
    gap("landmarks mapped", parts[0].landmark_share(), parts[1].landmark_share());
    gap("spurious share of the map", parts[0].spurious_share(), parts[1].spurious_share());
  }
  const std::string called = gaps.str();
  md << "\n"
     << (called.empty() ? "No figure differs by more than " + fixed(kPartGapPoints, 0) +
                              " points between the parts.\n"
                        : "Gaps of more than " + fixed(kPartGapPoints, 0) +
                              " points between the parts:\n\n" + called);
  write_file(out_dir / "summary_by_part.csv", csv.str());
}

}  // namespace locsim
