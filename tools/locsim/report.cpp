// `locsim report DIR`: DIR/report.md with plots, written by tools/report.py.
#include <memory>
#include <string>

#include "commands.hpp"
#include "common.hpp"

namespace locsim::cli {

Command add_report(CLI::App& app) {
  const auto dir = std::make_shared<std::string>();
  CLI::App* const report =
      app.add_subcommand("report", "Write DIR/report.md with plots for a sweep or run folder");
  report->add_option("dir", *dir, "Sweep, run or calibration folder")->required();
  report->footer(
      "Exit codes:\n"
      "  0    DIR/report.md and DIR/report/*.png written\n"
      "  1    they cannot be written (a read-only folder, a full disk): the message names the\n"
      "       file and the reason; a report.md of before is left whole\n"
      "  2    DIR is not a sweep, run or calibration folder, or a file in it cannot be read");
  return {report, [dir]() -> int { exec_report({*dir}); }};
}

}  // namespace locsim::cli
