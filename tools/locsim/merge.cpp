// `locsim merge OUT PARTS...`: join the folders of sharded sweeps.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "sim/common/errors.hpp"
#include "sim/experiments/sweep.hpp"

namespace locsim::cli::merge_cmd {

/// What the command line gives; its options write into it, so it lives as long as the command.
struct State {
  std::string out;
  std::vector<std::string> parts;
};

int execute(const State& s) {
  const std::vector<std::filesystem::path> parts(s.parts.begin(), s.parts.end());
  merge_sweeps(s.out, parts);
  std::printf("merged %zu folders into %s\n", parts.size(), s.out.c_str());
  return kExitOk;
}

}  // namespace locsim::cli::merge_cmd

namespace locsim::cli {

Command add_merge(CLI::App& app) {
  const auto state = std::make_shared<merge_cmd::State>();
  CLI::App* const merge = app.add_subcommand("merge", "Join the folders of sharded sweeps");
  merge->add_option("out", state->out, "New folder for the joined sweep")->required();
  merge->add_option("parts", state->parts, "Shard folders")->required();
  merge->footer(
      "Exit codes:\n"
      "  0    joined (a warning when runs are missing: a shard not given or not finished)\n"
      "  1    a failure not caused by the input (an I/O error)\n"
      "  2    nothing written: a folder not a sweep's, a corrupt sweep.json or results.jsonl\n"
      "       (file:line), shards of other inputs, a folder given twice or a run in two shards,\n"
      "       a shard a live sweep still writes, or OUT not empty");
  return {merge, [state] { return merge_cmd::execute(*state); }};
}

}  // namespace locsim::cli
