#include "sim/run/export_bag.hpp"

#include <system_error>

#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/producers/log_source.hpp"
#include "sim/world/occupancy.hpp"
#include "sim/world/physics_world.hpp"

namespace fs = std::filesystem;

namespace locsim {
namespace {

/// Whether `dir` holds nothing but a bag's files (what --overwrite may replace).
bool is_bag_folder(const fs::path& dir) {
  std::error_code error;
  bool metadata = false;
  for (fs::directory_iterator it(dir, error), end; !error && it != end; it.increment(error)) {
    const fs::path& entry = it->path();
    if (!it->is_regular_file(error)) return false;
    if (entry.filename() == "metadata.yaml") {
      metadata = true;
    } else if (entry.extension() != ".mcap" && entry.extension() != ".db3") {
      return false;
    }
  }
  return !error && metadata;
}

/// Whether `file` lies inside `dir` (after links are followed).
bool is_within(const fs::path& file, const fs::path& dir) {
  std::error_code error;
  const fs::path f = fs::weakly_canonical(file, error);
  const fs::path d = fs::weakly_canonical(dir, error);
  const auto [d_end, f_end] = std::mismatch(d.begin(), d.end(), f.begin(), f.end());
  return d_end == d.end();
}

}  // namespace

void check_bag_folder(const fs::path& out, bool overwrite, const std::vector<fs::path>& inputs) {
  if (out.empty() || !out.has_filename()) {
    throw InputError("--rosbag2: " + quote_input(out.string()) + " does not name a bag folder");
  }
  std::error_code error;
  const bool exists = fs::exists(fs::symlink_status(out, error));
  if (exists && !overwrite) {
    throw InputError("--rosbag2: " + out.string() + " exists (pass --overwrite to replace a bag)");
  }
  if (exists && (!fs::is_directory(out) || !is_bag_folder(out))) {
    throw InputError("--rosbag2: " + out.string() +
                     " is not a bag folder (metadata.yaml and .mcap files only): not replaced");
  }
  for (const fs::path& input : inputs) {
    if (is_within(input, out)) {
      throw InputError("--rosbag2: " + out.string() + " holds " + input.string() +
                       ", which locsim reads: not replaced");
    }
  }
  check_output_folder(out.parent_path(), "--rosbag2");
}

ExportSummary export_rosbag2(const fs::path& log, const fs::path& out,
                             RosbagRecorderOptions options, bool overwrite) {
  check_bag_folder(out, overwrite, {log});
  std::error_code error;
  const bool exists = fs::exists(fs::symlink_status(out, error));
  const fs::path partial = out.string() + ".partial";
  if (fs::exists(fs::symlink_status(partial, error))) {
    if (!fs::is_directory(partial) || !is_bag_folder(partial)) {
      throw InputError("--rosbag2: " + partial.string() +
                       " is in the way (not a bag folder an export left: not removed)");
    }
    fs::remove_all(partial);
  }

  LogSource source(log);
  const WorldDef& world = source.world();
  // The map the localizers see: the static world, rasterized as a session does.
  const PhysicsWorld physics(world);
  const OccupancyGrid grid =
      rasterize_static_world(physics, source.scenario().localization.grid_resolution_m);
  if (options.bag_name.empty()) options.bag_name = out.filename().string();
  // The log's header rides along: `import rosbag2` rebuilds the same world from it.
  if (options.log_header.empty()) options.log_header = source.header().dump();
  ExportSummary summary;
  try {
    RosbagRecorder recorder(partial, world, grid, options);
    Record record;
    while (source.next(record)) {
      recorder.consume(record);
      ++summary.records;
    }
    recorder.finish();
    summary.messages = recorder.messages();
  } catch (...) {
    fs::remove_all(partial, error);
    throw;
  }
  if (exists) fs::remove_all(out);
  fs::rename(partial, out);
  for (const auto& entry : fs::directory_iterator(out)) summary.bag_bytes += entry.file_size();
  return summary;
}

}  // namespace locsim
