// The locsim subcommands, one file each (tools/locsim/NAME.cpp). main.cpp adds them to the app in
// the order `locsim --help` lists them and runs the one the command line chose.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace locsim::cli {

/// A subcommand added to the app. `run` is called after the whole command line is parsed, not as
/// CLI11's callback: its errors then reach main's handlers (messages and exit codes), and
/// `--help` never starts it.
struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;  // returns the exit code
};

Command add_run(CLI::App& app);
Command add_validate(CLI::App& app);
Command add_plugins(CLI::App& app);
Command add_new_plugin(CLI::App& app);
Command add_sweep(CLI::App& app);
Command add_replay(CLI::App& app);
Command add_import(CLI::App& app);
Command add_export(CLI::App& app);
Command add_score(CLI::App& app);
Command add_calibrate(CLI::App& app);
Command add_twin(CLI::App& app);
Command add_generate(CLI::App& app);
Command add_report(CLI::App& app);
Command add_compare(CLI::App& app);
Command add_merge(CLI::App& app);

}  // namespace locsim::cli
