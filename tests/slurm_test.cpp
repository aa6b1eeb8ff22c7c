// `locsim sweep --slurm` on a real cluster: a one-node Slurm of Debian's daemons (munged,
// slurmctld, slurmd), started as root in a folder of the test's own, with no service manager.
// The merged results must equal a local sweep's, every file but the wall-clock timings.
//
// Without root, or without the daemons, the cluster tests are skipped, saying why; with
// LOCSIM_TEST_SLURM=required (tools/test sets it when run as root) they fail instead, so that CI
// cannot pass them unrun.
#include "sim/experiments/slurm.hpp"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "sim/common/command.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

/// `name` in PATH or /usr/sbin (root's daemons), "" when in neither.
fs::path find_program(const std::string& name) {
  std::string path = std::getenv("PATH") != nullptr ? std::getenv("PATH") : "";
  path += ":/usr/sbin:/sbin";
  std::istringstream dirs(path);
  for (std::string dir; std::getline(dirs, dir, ':');) {
    const fs::path candidate = fs::path(dir) / name;
    if (!dir.empty() && ::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return {};
}

/// A TCP port nothing listens on now.
int free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t size = sizeof address;
  int port = 0;
  if (fd >= 0 && ::bind(fd, reinterpret_cast<sockaddr*>(&address), size) == 0 &&
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &size) == 0) {
    port = ntohs(address.sin_port);
  }
  if (fd >= 0) ::close(fd);
  return port;
}

/// A one-node Slurm cluster on this machine, for the life of the object: munged with a key of its
/// own, slurmctld and slurmd as root, every file in a folder of its own (not /etc, /var, /run),
/// SLURM_CONF pointing Slurm's commands (and locsim's) at it.
class OneNodeSlurm {
 public:
  OneNodeSlurm() {
    if (::geteuid() != 0) {
      why_not_ = "not root: slurmctld and slurmd run as root here";
      return;
    }
    for (const char* program :
         {"munged", "slurmctld", "slurmd", "sbatch", "squeue", "sinfo", "scontrol"}) {
      programs_[program] = find_program(program);
      if (programs_[program].empty()) {
        why_not_ = std::string(program) + " not found: tools/setup installs slurm-wlm and munge";
        return;
      }
    }
    // Short: munged's socket path must fit a sockaddr_un (108 bytes).
    char pattern[] = "/tmp/locsim-slurm-XXXXXX";
    if (::mkdtemp(pattern) == nullptr) {
      ADD_FAILURE() << "mkdtemp: " << std::strerror(errno);
      return;
    }
    dir_ = pattern;
    fs::create_directories(dir_ / "state");
    fs::create_directories(dir_ / "spool");
    {
      std::ifstream random("/dev/urandom", std::ios::binary);
      std::string key(1024, '\0');
      random.read(key.data(), static_cast<std::streamsize>(key.size()));
      std::ofstream(dir_ / "munge.key", std::ios::binary) << key;
      fs::permissions(dir_ / "munge.key", fs::perms::owner_read);
    }
    // The node is this machine, named as slurmd names itself: the host name up to its first dot
    // (and told so with -N, whatever the machine's name resolves to).
    char name[256] = {};
    ::gethostname(name, sizeof name - 1);
    const std::string host = std::string(name).substr(0, std::string(name).find('.'));
    const unsigned cpus = std::max(1u, std::thread::hardware_concurrency());
    const fs::path socket = dir_ / "munge.sock";
    const int ctld_port = free_port();
    int slurmd_port = free_port();
    while (slurmd_port == ctld_port) slurmd_port = free_port();
    std::ofstream(dir_ / "slurm.conf")
        << "ClusterName=locsimtest\nSlurmctldHost=" << host << "(127.0.0.1)\n"
        << "SlurmUser=root\nSlurmdUser=root\n"
        << "SlurmctldPort=" << ctld_port << "\nSlurmdPort=" << slurmd_port << "\n"
        << "AuthType=auth/munge\nCredType=cred/munge\nAuthInfo=socket=" << socket.string() << "\n"
        << "StateSaveLocation=" << (dir_ / "state").string() << "\n"
        << "SlurmdSpoolDir=" << (dir_ / "spool").string() << "\n"
        << "SlurmctldPidFile=" << (dir_ / "slurmctld.pid").string() << "\n"
        << "SlurmdPidFile=" << (dir_ / "slurmd.pid").string() << "\n"
        << "SlurmctldLogFile=" << (dir_ / "slurmctld.log").string() << "\n"
        << "SlurmdLogFile=" << (dir_ / "slurmd.log").string() << "\n"
        << "ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n"
        << "SelectType=select/cons_tres\nSelectTypeParameters=CR_Core\nReturnToService=2\n"
        << "MpiDefault=none\nJobCompType=jobcomp/none\n"
        << "AccountingStorageType=accounting_storage/none\n"
        << "NodeName=" << host << " NodeAddr=127.0.0.1 CPUs=" << cpus << " State=UNKNOWN\n"
        << "PartitionName=main Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n";
    ::setenv("SLURM_CONF", (dir_ / "slurm.conf").c_str(), 1);

    const auto start = [&](const std::vector<std::string>& argv) {
      const CommandOutput started = run_command(argv);
      if (started.exit_code != 0) {
        ADD_FAILURE() << argv[0] << " did not start (exit " << started.exit_code
                      << "): " << started.err << started.out << logs();
        return false;
      }
      return true;
    };
    // Each forks its daemon and returns.
    if (!start({programs_["munged"], "--force", "--socket=" + socket.string(),
                "--key-file=" + (dir_ / "munge.key").string(),
                "--log-file=" + (dir_ / "munged.log").string(),
                "--pid-file=" + (dir_ / "munged.pid").string(),
                "--seed-file=" + (dir_ / "munged.seed").string()}) ||
        !start({programs_["slurmctld"], "-f", (dir_ / "slurm.conf").string()}) ||
        !start({programs_["slurmd"], "-f", (dir_ / "slurm.conf").string(), "-N", host})) {
      return;
    }
    // Up when the node has registered and takes jobs. Generous: a loaded machine is slow.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    std::string state;
    while (std::chrono::steady_clock::now() < deadline) {
      state = run_command({programs_["sinfo"], "--noheader", "--format=%t"}).out;
      if (state.rfind("idle", 0) == 0) {
        up_ = true;
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
    ADD_FAILURE() << "the node did not come up (sinfo: '" << state << "')" << logs();
  }

  ~OneNodeSlurm() {
    if (dir_.empty()) return;
    if (!programs_["scontrol"].empty()) run_command({programs_["scontrol"], "shutdown"});
    // Each daemon ended, by SIGKILL when it does not end on its own: none outlives the test.
    for (const char* daemon : {"slurmd", "slurmctld", "munged"}) {
      std::ifstream in(dir_ / (std::string(daemon) + ".pid"));
      pid_t pid = 0;
      if (!(in >> pid) || pid <= 0) continue;
      if (std::string(daemon) == "munged") ::kill(pid, SIGTERM);
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
      while (::kill(pid, 0) == 0 && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
      if (::kill(pid, 0) == 0) ::kill(pid, SIGKILL);
    }
    ::unsetenv("SLURM_CONF");
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }

  OneNodeSlurm(const OneNodeSlurm&) = delete;
  OneNodeSlurm& operator=(const OneNodeSlurm&) = delete;

  bool up() const { return up_; }
  /// Why no cluster could be started here ("" when it was tried).
  const std::string& why_not() const { return why_not_; }

  /// The daemons' logs, for a failure's message.
  std::string logs() const {
    std::string text;
    for (const char* log : {"munged.log", "slurmctld.log", "slurmd.log"}) {
      text += "\n--- " + std::string(log) + ":\n" + testing::read_file(dir_ / log);
    }
    return text;
  }

 private:
  std::map<std::string, fs::path> programs_;
  fs::path dir_;
  std::string why_not_;
  bool up_ = false;
};

/// Starts the cluster, or skips the test saying why (fails it when LOCSIM_TEST_SLURM=required).
#define START_SLURM(cluster)                                             \
  OneNodeSlurm cluster;                                                  \
  if (!cluster.why_not().empty()) {                                      \
    const char* required = std::getenv("LOCSIM_TEST_SLURM");             \
    if (required != nullptr && std::string(required) == "required")      \
      FAIL() << "LOCSIM_TEST_SLURM=required, but " << cluster.why_not(); \
    GTEST_SKIP() << cluster.why_not();                                   \
  }                                                                      \
  ASSERT_TRUE(cluster.up())

/// 3 seeds x 2 localizers on the demo world, 1.5 s each.
fs::path write_experiment(const fs::path& dir) {
  const fs::path file = dir / "experiment.yaml";
  std::ofstream(file) << "name: cluster\nworld: " << LOCSIM_SOURCE_DIR
                      << "/worlds/demo/demo.yaml\nduration_s: 1.5\nseeds: {from: 1, to: 3}\n"
                      << "timeout_s: 120\nlocalizers:\n  - plugin: odometry\n"
                      << "  - plugin: ekf_landmarks\n";
  return file;
}

json without(json j, std::initializer_list<const char*> keys) {
  for (const char* key : keys) j.erase(key);
  return j;
}

/// Sweep folder `b` holds what `a` does, byte for byte but the wall-clock timings: the tables,
/// every result, every run's and every seed's files. (run.json names the log it replayed and
/// log.txt the folders: paths, which differ between any two folders.)
void expect_same_sweep(const fs::path& a, const fs::path& b) {
  for (const char* table : {"results.csv", "summary.csv", "summary.md", "segments.csv"}) {
    EXPECT_EQ(testing::read_file(b / table), testing::read_file(a / table)) << table;
  }
  const auto results = [](const fs::path& dir) {
    std::map<std::size_t, std::string> by_index;
    std::istringstream lines(testing::read_file(dir / "results.jsonl"));
    for (std::string line; std::getline(lines, line);) {
      const json r = json::parse(line);
      by_index[r["index"].get<std::size_t>()] = without(r, {"timing"}).dump();
    }
    return by_index;
  };
  EXPECT_EQ(results(b), results(a));
  std::size_t compared = 0;
  for (const char* sub : {"runs", "logs"}) {
    for (const auto& entry : fs::recursive_directory_iterator(a / sub)) {
      if (!entry.is_regular_file() || entry.path().filename() == "log.txt") continue;
      const fs::path relative = entry.path().lexically_relative(a);
      ASSERT_TRUE(fs::exists(b / relative)) << relative;
      ++compared;
      if (entry.path().extension() == ".json") {
        EXPECT_EQ(without(json::parse(testing::read_file(b / relative)), {"timing", "log_file"}),
                  without(json::parse(testing::read_file(entry.path())), {"timing", "log_file"}))
            << relative;
      } else {
        EXPECT_EQ(testing::read_file(b / relative), testing::read_file(entry.path())) << relative;
      }
    }
  }
  EXPECT_GT(compared, 20u);
}

SlurmSweepOptions on_slurm(const fs::path& experiment, const fs::path& out, bool resume,
                           const fs::path& stand_in) {
  SlurmSweepOptions options;
  options.sweep.experiment_file = experiment;
  options.sweep.out_dir = out;
  options.sweep.resume = resume;
  options.sweep.locsim_binary = stand_in;
  options.tasks = 3;
  options.poll_interval = std::chrono::milliseconds(200);
  return options;
}

TEST(SlurmSweep, OnAOneNodeClusterTheMergedSweepEqualsALocalOneAndResumeRunsOnlyWhatIsLeft) {
  START_SLURM(cluster);
  const fs::path dir = testing::temp_dir("slurm");
  const fs::path experiment = write_experiment(dir);
  SweepOptions local;
  local.experiment_file = experiment;
  local.out_dir = dir / "local";
  local.jobs = 2;
  local.locsim_binary = LOCSIM_BINARY;
  ASSERT_EQ(run_sweep(local).not_ok, 0u);

  // As a cluster user types it.
  const testing::Outcome o =
      testing::locsim("sweep " + experiment.string() + " --out " + (dir / "cluster").string() +
                      " --slurm 3 --sbatch=--time=10");
  ASSERT_EQ(o.exit_code, 0) << o.output << cluster.logs();
  testing::expect_contains(o.output, "3 of 3 shards submitted (array 1-3)");
  testing::expect_contains(o.output, ": ended");
  testing::expect_contains(o.output, "6 runs, 6 with a result, 0 in error");
  expect_same_sweep(dir / "local", dir / "cluster");
  for (int k = 1; k <= 3; ++k) {
    EXPECT_TRUE(fs::exists(dir / "cluster/slurm" / ("shard-" + std::to_string(k)) / "sweep.json"));
  }

  // A task that fails (here: its locsim exits 1 once): its shard's runs have no result, the task's
  // log says why, the other shards are merged.
  const fs::path failing = dir / "failing";
  const fs::path stand_in = testing::write_stand_in(
      dir, "*'--shard 2/3'*) if [ ! -e " + (dir / "failed_once").string() + " ]; then touch " +
               (dir / "failed_once").string() +
               "; echo 'stand-in: the task of shard 2 fails' >&2; exit 1; fi;;\n");
  SlurmSweepSummary summary = run_sweep_on_slurm(on_slurm(experiment, failing, false, stand_in));
  EXPECT_EQ(summary.submitted, 3u);
  EXPECT_EQ(summary.with_result, 4u);
  ASSERT_EQ(summary.unfinished.size(), 1u);
  EXPECT_EQ(summary.unfinished[0].first, 2);
  testing::expect_contains(testing::read_file(summary.unfinished[0].second),
                           "stand-in: the task of shard 2 fails");
  // --resume submits that shard alone.
  const std::string first_job = summary.job_id;
  summary = run_sweep_on_slurm(on_slurm(experiment, failing, true, stand_in));
  EXPECT_EQ(summary.submitted, 1u);
  EXPECT_NE(summary.job_id, first_job);
  EXPECT_TRUE(summary.unfinished.empty());
  EXPECT_EQ(summary.with_result, 6u);
  const json job = json::parse(testing::read_file(failing / "slurm/job.json"));
  ASSERT_EQ(job["submissions"].size(), 2u);
  EXPECT_EQ(job["submissions"][1]["shards"], json::array({2}));
  expect_same_sweep(dir / "local", failing);

  // Interrupted while it waits, the job runs on; --resume waits for that job rather than
  // submitting its shards again. Shard 1's task holds until the resume has seen the job queued.
  const fs::path go = dir / "go";
  const fs::path waiting = dir / "waiting";
  const fs::path holding = testing::write_stand_in(
      dir, "*'--shard 1/3'*) while [ ! -e " + go.string() + " ]; do sleep 0.1; done;;\n");
  std::atomic<bool> interrupt{false};
  SlurmSweepOptions options = on_slurm(experiment, waiting, false, holding);
  options.progress = [&](const std::string& line) {
    if (line.find("submitted") != std::string::npos) interrupt = true;
  };
  summary = run_sweep_on_slurm(options, &interrupt);
  ASSERT_TRUE(summary.interrupted);
  const std::string held_job = summary.job_id;
  EXPECT_FALSE(fs::exists(waiting / "results.csv"));
  options = on_slurm(experiment, waiting, true, holding);
  std::vector<std::string> lines;
  options.progress = [&](const std::string& line) {
    lines.push_back(line);
    std::ofstream{go};
  };
  summary = run_sweep_on_slurm(options);
  EXPECT_FALSE(summary.interrupted);
  EXPECT_EQ(summary.job_id, held_job);
  EXPECT_EQ(summary.submitted, 0u);
  ASSERT_FALSE(lines.empty());
  testing::expect_contains(lines.front(), "slurm job " + held_job + ": ");
  expect_same_sweep(dir / "local", waiting);
}

TEST(SlurmSweep, ABadExperimentOrNoSlurmIsRefusedBeforeAnythingIsSubmittedOrWritten) {
  // No cluster needed: the checks come first. sbatch is kept off the PATH, so that a check
  // skipped would show as "sbatch not found" rather than pass.
  const fs::path dir = testing::temp_dir("slurm-refused");
  const fs::path experiment = write_experiment(dir);
  std::ofstream(dir / "unknown.yaml") << "name: u\nworld: " << LOCSIM_SOURCE_DIR
                                      << "/worlds/demo/demo.yaml\nduration_s: 1\nseeds: [1]\n"
                                      << "localizers:\n  - plugin: no_such_plugin\n";
  const std::string no_slurm = "PATH=/nonexistent " + std::string(LOCSIM_BINARY);
  testing::Outcome o = testing::run_command(no_slurm + " sweep " + (dir / "unknown.yaml").string() +
                                            " --out " + (dir / "a").string() + " --slurm 2");
  EXPECT_EQ(o.exit_code, 3) << o.output;
  testing::expect_contains(o.output, "no_such_plugin");
  EXPECT_FALSE(fs::exists(dir / "a"));
  o = testing::run_command(no_slurm + " sweep " + experiment.string() + " --out " +
                           (dir / "b").string() + " --slurm 7");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  testing::expect_contains(o.output, "--slurm 7: more tasks than the sweep's 6 runs");
  o = testing::run_command(no_slurm + " sweep " + experiment.string() + " --out " +
                           (dir / "b").string() + " --slurm 2 --shard 1/2");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  o = testing::run_command(no_slurm + " sweep " + experiment.string() + " --out " +
                           (dir / "b").string() + " --sbatch=--time=5");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  testing::expect_contains(o.output, "--sbatch requires --slurm");
  EXPECT_FALSE(fs::exists(dir / "b"));
  // A good experiment where Slurm's commands are missing: exit 1 saying so, nothing left behind.
  o = testing::run_command(no_slurm + " sweep " + experiment.string() + " --out " +
                           (dir / "b").string() + " --slurm 2");
  EXPECT_EQ(o.exit_code, 1) << o.output;
  testing::expect_contains(o.output, "cannot run sbatch: not found on PATH");
  EXPECT_FALSE(fs::exists(dir / "b"));
}

}  // namespace
}  // namespace locsim
