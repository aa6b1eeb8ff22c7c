// The locsim command line. Exit codes: 0 ok, 1 failure, 2 bad input, 130 interrupted.
// Each subcommand is its own file (commands.hpp); this one parses, dispatches and turns errors into
// messages and exit codes, the same for every subcommand.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "sim/common/errors.hpp"
#include "sim/run/runner.hpp"

int main(int argc, char** argv) {
  CLI::App app{"locsim: a simulator for mobile-robot localization research"};
  app.footer(locsim::cli::kExitCodes);
  app.set_version_flag("--version", locsim::locsim_version());
  app.require_subcommand(1);

  // In the order `locsim --help` lists them (a braced list is evaluated left to right).
  const std::vector<locsim::cli::Command> commands = {
      locsim::cli::add_run(app),     locsim::cli::add_validate(app),
      locsim::cli::add_plugins(app), locsim::cli::add_new_plugin(app),
      locsim::cli::add_sweep(app),   locsim::cli::add_replay(app),
      locsim::cli::add_import(app),  locsim::cli::add_export(app),
      locsim::cli::add_score(app),   locsim::cli::add_calibrate(app),
      locsim::cli::add_twin(app),    locsim::cli::add_generate(app),
      locsim::cli::add_report(app),  locsim::cli::add_compare(app),
      locsim::cli::add_merge(app)};

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // One line with the prefix every other error has, so a script's grep finds it.
    std::fprintf(stderr, "locsim: error: %s (see --help)\n", locsim::printable(e.what()).c_str());
    return locsim::kExitBadInput;
  }

  try {
    for (const locsim::cli::Command& command : commands) {
      if (*command.app) return command.run();
    }
    // require_subcommand(1) makes the parse fail without one.
    throw std::logic_error("no subcommand was parsed");
  } catch (const locsim::PluginError& e) {
    std::fprintf(stderr, "locsim: plugin error: %s\n", e.what());
    return locsim::kExitPlugin;
  } catch (const locsim::RenderError& e) {
    std::fprintf(stderr, "locsim: render error: %s\n", locsim::printable(e.what()).c_str());
    return locsim::kExitRender;
  } catch (const locsim::InputError& e) {
    std::fprintf(stderr, "locsim: error: %s\n", e.what());
    return locsim::kExitBadInput;
  } catch (const std::bad_alloc&) {
    // The inputs' bounds are meant to make this unreachable; if not, say what was being built.
    const std::string stage = locsim::Activity::failed();
    std::fprintf(stderr, "locsim: failure: out of memory%s\n",
                 stage.empty() ? "" : (" while " + stage).c_str());
    return locsim::kExitFailure;
  } catch (const std::exception& e) {
    // Not one of ours (their messages are made printable already): it may quote anything.
    std::fprintf(stderr, "locsim: failure: %s\n", locsim::printable(e.what()).c_str());
    return locsim::kExitFailure;
  }
}
