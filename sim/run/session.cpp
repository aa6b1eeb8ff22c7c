#include "sim/run/session.hpp"

#include <sys/resource.h>

#include "sim/common/errors.hpp"
#include "sim/world/occupancy.hpp"
#include "sim/world/physics_world.hpp"

namespace locsim {

Session::Session(const SessionOptions& options, const WorldDef& world, const ScenarioDef& scenario,
                 std::uint64_t seed, const std::atomic<bool>* interrupt)
    : world_(world), options_(options) {
  std::shared_ptr<const ParamFile> params_file;
  if (options.params_file)
    params_file = std::make_shared<const ParamFile>(load_param_file(*options.params_file));
  std::vector<LocalizerSpec> specs;
  for (const std::string& text : options.localizers) {
    specs.push_back(parse_localizer_spec(text));
    specs.back().params_file = params_file;
  }
  OccupancyGrid grid;
  if (!specs.empty()) {
    // The static world only, rasterized as the localizers see it (no robot moves in it).
    const PhysicsWorld physics(world);
    grid = rasterize_static_world(physics, scenario.localization.grid_resolution_m);
  }
  HostOptions host;
  host.isolate = options.isolate;
  host.plugin_timeout_s = options.plugin_timeout_s;
  host.plugin_memory_bytes = options.plugin_memory_bytes;
  host.interrupt = interrupt;
  host_ = std::make_unique<LocalizerHost>(specs, world, scenario.localization, grid, seed, host);
  scorer_ = std::make_unique<Scorer>(world, host_->localizers(), options.convergence, &grid);
}

std::vector<std::filesystem::path> session_input_files(const SessionOptions& options) {
  std::vector<std::filesystem::path> files;
  if (options.params_file) files.push_back(*options.params_file);
  for (const std::string& text : options.localizers) {
    const LocalizerSpec spec = parse_localizer_spec(text);
    // A plugin and a loader's source given as files (one found by name is installed elsewhere).
    for (const std::string& file : {spec.plugin, spec.source}) {
      std::error_code error;
      if (!file.empty() && std::filesystem::is_regular_file(file, error)) files.push_back(file);
    }
  }
  return files;
}

void Session::open(const std::filesystem::path& out_dir,
                   const std::vector<std::filesystem::path>& keep) {
  folder_ = RunFolder::create(out_dir, world_, options_.overwrite, keep);
  recorder_ =
      std::make_unique<RunRecorder>(folder_, world_, host_->localizers(), options_.readings);
  host_->add_output(*scorer_);
  host_->add_output(*recorder_);
  fanout_.add(*host_);  // first: workers get each record as early as possible
  fanout_.add(*scorer_);
  fanout_.add(*recorder_);
}

void RunEnd::caught(const std::string& context) {
  try {
    throw;
  } catch (const Interrupted&) {
    if (!failure) status = "interrupted";
  } catch (const std::exception& e) {
    if (failure) return;
    status = "failed";
    error = context + e.what();
    failure = std::current_exception();
  }
}

nlohmann::ordered_json Session::finish(double t_end_s, RunEnd& end) {
  std::vector<LocalizerFinal> finals(host_->localizers().size());
  try {
    // Only Ctrl-C stops the localizers where they are; otherwise (a failed run too) they take in
    // every record sent so far, so that the outputs end at the same instant.
    if (end.status != "interrupted" || !options_.isolate) {
      finals = host_->finish(t_end_s);
    } else {
      host_->abort();
    }
  } catch (...) {
    end.caught();
    host_->abort();
  }
  // Each output on its own: a file that cannot be written costs the others nothing.
  nlohmann::ordered_json localizers = nlohmann::ordered_json::array();
  try {
    if (!host_->localizers().empty()) localizers = scorer_->write(folder_.robot_dirs, finals);
  } catch (...) {
    end.caught();
  }
  try {
    recorder_->close();
  } catch (...) {
    end.caught();
  }
  return localizers;
}

nlohmann::ordered_json peak_memory_json() {
  rusage self{}, children{};
  ::getrusage(RUSAGE_SELF, &self);
  ::getrusage(RUSAGE_CHILDREN, &children);
  // ru_maxrss is in KiB on Linux.
  return {{"locsim", static_cast<double>(self.ru_maxrss) / 1024.0},
          {"largest_localizer", static_cast<double>(children.ru_maxrss) / 1024.0}};
}

}  // namespace locsim
