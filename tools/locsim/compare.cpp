// `locsim compare A B`: two sweeps side by side, written by tools/report.py.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "commands.hpp"
#include "common.hpp"

namespace locsim::cli::compare_cmd {

/// What the command line gives; its options write into it, so it lives as long as the command.
struct State {
  std::string a, b, out;
  std::optional<std::string> labels;
};

[[noreturn]] void execute(const State& s) {
  std::vector<std::string> arguments = {"--compare", s.a, s.b, "--out", s.out};
  if (s.labels) {
    arguments.push_back("--labels");
    arguments.push_back(*s.labels);
  }
  exec_report(arguments);
}

}  // namespace locsim::cli::compare_cmd

namespace locsim::cli {

Command add_compare(CLI::App& app) {
  const auto state = std::make_shared<compare_cmd::State>();
  CLI::App* const compare = app.add_subcommand(
      "compare",
      "Write DIR/report.md comparing two sweeps: each configuration's error on both, the two "
      "rankings and whether they agree (docs/experiments.md)");
  compare->add_option("A", state->a, "First sweep folder (e.g. over recorded logs)")->required();
  compare->add_option("B", state->b, "Second sweep folder (e.g. over a simulated twin)")
      ->required();
  compare
      ->add_option("--out", state->out,
                   "Folder for report.md, compare.csv and report/compare.png (not a sweep folder)")
      ->required();
  compare->add_option("--labels", state->labels,
                      "The two sweeps' names in the report, as NAME_A,NAME_B (default: the "
                      "folders' base names)");
  return {compare, [state]() -> int { compare_cmd::execute(*state); }};
}

}  // namespace locsim::cli
