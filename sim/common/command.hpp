// Running another program to its end and keeping what it printed: the cluster's commands
// (sbatch, squeue), which locsim drives but does not link.
#pragma once

#include <string>
#include <vector>

namespace locsim {

struct CommandOutput {
  int exit_code = -1;  // its exit status; 128 + N when signal N ended it
  std::string out;     // what it wrote to stdout
  std::string err;     // and to stderr
};

/// Runs `argv` (argv[0] looked up in PATH) with this process's environment and no stdin, and
/// waits for it. Throws std::runtime_error when it cannot be started, naming it and the reason
/// ("not found on PATH").
CommandOutput run_command(const std::vector<std::string>& argv);

}  // namespace locsim
