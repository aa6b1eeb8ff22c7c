// A boundary-value pass over every number of every shipped world, scenario, map and experiment
// file (worlds/), and of tests/data/every_key/ (which gives every key there is): each numeric
// scalar the loaders read is replaced, one at a time, by values at and beyond the edges of what a
// double and its declared range hold; then the input is loaded and, when it loads, the world is
// built (with the localizers' occupancy grid) and simulated for a moment with its sensors on. Each
// case must end in one of two ways: an InputError whose message names file:line:column and a key,
// or a run whose robots and movers keep finite poses. Crashes (Box2D's asserts abort), hangs, other
// exceptions (std::bad_alloc) and NaN poses fail the test, each case named. Every case runs in a
// forked child, under a time limit and an address-space limit, so that one crash is one failed
// case.
//
// In CI (the default) each distinct key path (indices aside) is tried once, at its first place in
// the files, with a core set of values, for about a minute on two cores. LOCSIM_BOUNDARY_FULL=1
// tries every place with every value (the acceptance pass); LOCSIM_BOUNDARY_JOBS=N runs N cases
// at a time (default 1; full mode 2).
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "render/rendered_camera.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/common/format.hpp"
#include "sim/common/yaml_node.hpp"
#include "sim/experiments/experiment.hpp"
#include "sim/producers/simulation.hpp"
#include "sim/run/runner.hpp"
#include "sim/world/occupancy.hpp"
#include "sim/world/physics_world.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;

enum class Kind { kWorld, kScenario, kMap, kExperiment };

const char* kind_name(Kind kind) {
  switch (kind) {
    case Kind::kWorld:
      return "world";
    case Kind::kScenario:
      return "scenario";
    case Kind::kMap:
      return "map";
    case Kind::kExperiment:
      return "experiment";
  }
  return "?";
}

/// One shipped file, and how a case of it is run.
struct InputFile {
  fs::path path;  // in the mirror
  Kind kind = Kind::kWorld;
  std::string text;
  // kScenario: the world and duration of the first experiment that uses it. kMap: the first world
  // that uses it, and where its `map:` value is in that world's text.
  fs::path partner;
  std::optional<double> partner_duration_s;
  std::size_t partner_offset = 0, partner_length = 0;
};

/// A number the loaders read with a range, where it is in the file.
struct Scalar {
  std::size_t file = 0;
  std::string key_path;
  std::size_t offset = 0, length = 0;  // of its text
  Range range;
  bool degrees = false, integer = false;
};

/// What the observer saw for one file during the baseline load: key path -> use.
struct SeenUse {
  Range range;
  bool degrees = false, integer = false;
};
std::map<std::string, std::map<std::string, SeenUse>>* g_seen = nullptr;

void record_use(const RangeUse& use) {
  if (g_seen != nullptr && use.present) {
    (*g_seen)[use.file][use.key_path] = SeenUse{use.range, use.degrees, use.integer};
  }
}

/// Every scalar of a YAML document with its key path (as YamlNode names it) and its text's place.
void walk(const YAML::Node& node, const std::string& path,
          const std::function<void(const std::string&, const YAML::Node&)>& visit) {
  if (node.IsMap()) {
    for (const auto& entry : node) {
      const std::string key = entry.first.Scalar();
      walk(entry.second, path.empty() ? key : path + "." + key, visit);
    }
  } else if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i) {
      walk(node[i], path + "[" + std::to_string(i) + "]", visit);
    }
  } else if (node.IsScalar()) {
    visit(path, node);
  }
}

/// "robots[3].start.x" -> "robots[].start.x".
std::string without_indices(const std::string& path) {
  return std::regex_replace(path, std::regex(R"(\[\d+\])"), "[]");
}

/// The values each number is set to: IEEE extremes around zero and at the ends of a double, a
/// number past 32-bit integers, and the declared range's ends and the first values beyond them.
std::vector<std::string> boundary_values(const Scalar& s, bool full) {
  const double to_unit = s.degrees ? 180.0 / std::numbers::pi : 1.0;
  const double lo = s.range.min * to_unit, hi = s.range.max * to_unit;
  std::vector<double> values = {lo, hi};
  if (s.integer) {
    values.push_back(lo - 1.0);
    values.push_back(hi + 1.0);
  } else {
    values.push_back(std::nextafter(lo, -std::numeric_limits<double>::infinity()));
    values.push_back(std::nextafter(hi, std::numeric_limits<double>::infinity()));
  }
  const std::vector<double> core = {0.0, 1e-300, 1e300, -1e300};
  const std::vector<double> more = {-1.0, -1e-300, 2147483648.0, 1e10};
  values.insert(values.end(), core.begin(), core.end());
  if (full) values.insert(values.end(), more.begin(), more.end());
  std::vector<std::string> out;
  for (const double v : values) {
    std::string text = s.integer && std::abs(v) < 9e15 && v == std::floor(v)
                           ? std::to_string(static_cast<long long>(v))
                           : short_number(v);
    if (std::find(out.begin(), out.end(), text) == out.end()) out.push_back(text);
  }
  return out;
}

/// The outcome of a case, from its child process.
struct Outcome {
  enum class Status { kRan, kInputError, kBadMessage, kException, kNonFinite, kCrash, kHang };
  Status status = Status::kRan;
  std::string detail;
};

// ---- the child's side

[[noreturn]] void child_exit(int fd, const std::string& line, int code) {
  std::size_t written = 0;
  while (written < line.size()) {
    const ssize_t n = ::write(fd, line.data() + written, line.size() - written);
    if (n <= 0) break;
    written += static_cast<std::size_t>(n);
  }
  ::_exit(code);
}

bool finite_pose(const Pose2& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.theta);
}

/// Loads, builds and runs one case; reports on `fd` as "R", "I message", "E message", "N message".
[[noreturn]] void run_child(int fd, const fs::path& world, const std::optional<fs::path>& scenario,
                            const std::optional<fs::path>& experiment,
                            std::optional<double> duration_s, double window_s) {
  try {
    RunInputs inputs;
    if (experiment) {
      const ExperimentDef e = load_experiment(*experiment);
      inputs = load_run_inputs(e.worlds.front().file, e.scenario, e.duration_s);
    } else {
      inputs = load_run_inputs(world, scenario, duration_s);
    }
    {
      // What a run with localizers builds first: the occupancy grid they are given.
      const PhysicsWorld statics(inputs.world);
      (void)rasterize_static_world(statics, inputs.scenario.localization.grid_resolution_m);
    }
    inputs.scenario.duration_s = std::min(inputs.scenario.duration_s, window_s);
    const LandmarkImagerFactory imager = [](const WorldDef& w, const PtzCameraDef& camera) {
      return std::make_shared<render::RenderedCamera>(w, camera, "osmesa");
    };
    Simulation sim(inputs.world, inputs.scenario, 1, imager);
    const auto check = [&] {
      for (std::size_t i = 0; i < sim.robot_count(); ++i) {
        if (!finite_pose(sim.robot(i).pose())) {
          child_exit(
              fd, "N robot " + sim.robot(i).name() + " at t = " + fixed(sim.time_s(), 3) + " s", 0);
        }
      }
      for (const Mover& mover : sim.world().movers()) {
        const b2Vec2 p = mover.body->GetPosition();
        if (!std::isfinite(p.x) || !std::isfinite(p.y)) {
          child_exit(fd, "N mover " + mover.def.name + " at t = " + fixed(sim.time_s(), 3) + " s",
                     0);
        }
      }
    };
    check();
    while (!sim.done()) {
      sim.step();
      (void)sim.take_readings();
      (void)sim.take_events();
      check();
    }
    child_exit(fd, "R", 0);
  } catch (const InputError& e) {
    child_exit(fd, std::string("I ") + e.what(), 0);
  } catch (const std::bad_alloc&) {
    child_exit(fd, "E std::bad_alloc while " + Activity::failed(), 0);
  } catch (const std::exception& e) {
    child_exit(fd, std::string("E ") + e.what(), 0);
  }
}

// ---- the parent's side

struct Case {
  std::size_t scalar = 0;
  std::string value;
};

class Runner {
 public:
  Runner(std::vector<InputFile> files, double window_s, double timeout_s)
      : files_(std::move(files)), window_s_(window_s), timeout_s_(timeout_s) {}

  /// Starts a child for `text` standing for `files_[file]` (or the file as it is, when `text` is
  /// null); returns its pid and the read end of its pipe.
  std::pair<pid_t, int> start(std::size_t file, const std::string* text, std::size_t id) {
    const InputFile& f = files_[file];
    // The case's own copy sits beside the original, so that relative paths resolve alike.
    fs::path mutated = f.path;
    if (text != nullptr) {
      mutated = f.path.parent_path() / (f.path.stem().string() + ".case" + std::to_string(id) +
                                        f.path.extension().string());
      write_file(mutated, *text);
    }
    fs::path world = f.path;
    std::optional<fs::path> scenario, experiment;
    std::optional<double> duration;
    switch (f.kind) {
      case Kind::kWorld:
        world = mutated;
        break;
      case Kind::kExperiment:
        experiment = mutated;
        break;
      case Kind::kScenario:
        world = f.partner;
        scenario = mutated;
        duration = f.partner_duration_s;
        break;
      case Kind::kMap: {
        // The world that uses the map, pointing at the case's copy of it.
        std::string world_text = testing::read_file(f.partner);
        world_text.replace(f.partner_offset, f.partner_length, mutated.filename().string());
        world = f.partner.parent_path() / (f.partner.stem().string() + ".case" +
                                           std::to_string(id) + f.partner.extension().string());
        write_file(world, world_text);
        break;
      }
    }
    int pipe_fds[2];
    if (::pipe(pipe_fds) != 0) throw std::runtime_error("pipe failed");
    std::fflush(nullptr);
    const pid_t pid = ::fork();
    if (pid == 0) {
      ::close(pipe_fds[0]);
      // Room for what a world may need (1 GiB) over what the process already maps: an allocation
      // beyond fails as std::bad_alloc, a failed case, instead of swapping the machine.
      rlimit limit{};
      limit.rlim_cur = limit.rlim_max = address_space_bytes() + (std::uint64_t{3} << 29);
      ::setrlimit(RLIMIT_AS, &limit);
      run_child(pipe_fds[1], world, scenario, experiment, duration, window_s_);
    }
    ::close(pipe_fds[1]);
    if (pid < 0) throw std::runtime_error("fork failed");
    return {pid, pipe_fds[0]};
  }

  /// Runs `cases` (null text: the file as shipped) `jobs` at a time; returns their outcomes.
  std::vector<Outcome> run(
      const std::vector<std::pair<std::size_t, std::optional<std::string>>>& cases, int jobs) {
    std::vector<Outcome> outcomes(cases.size());
    struct Running {
      std::size_t index;
      pid_t pid;
      int fd;
      std::string output;
      std::chrono::steady_clock::time_point start;
    };
    std::vector<Running> running;
    std::size_t next = 0;
    while (next < cases.size() || !running.empty()) {
      while (next < cases.size() && static_cast<int>(running.size()) < jobs) {
        const auto& [file, text] = cases[next];
        const auto [pid, fd] = start(file, text ? &*text : nullptr, next);
        running.push_back({next, pid, fd, {}, std::chrono::steady_clock::now()});
        ++next;
      }
      std::vector<pollfd> fds;
      for (const Running& r : running) fds.push_back({r.fd, POLLIN, 0});
      ::poll(fds.data(), fds.size(), 50);
      for (std::size_t k = 0; k < running.size();) {
        Running& r = running[k];
        char buffer[4096];
        ssize_t n = 0;
        if (fds[k].revents != 0) {
          n = ::read(r.fd, buffer, sizeof(buffer));
          if (n > 0) r.output.append(buffer, static_cast<std::size_t>(n));
        }
        int status = 0;
        const bool overdue =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - r.start).count() >
            timeout_s_;
        if (overdue) ::kill(r.pid, SIGKILL);
        if (n > 0 || ::waitpid(r.pid, &status, overdue ? 0 : WNOHANG) == 0) {
          ++k;
          continue;
        }
        // Exited (or killed): drain the pipe, then judge.
        while ((n = ::read(r.fd, buffer, sizeof(buffer))) > 0) {
          r.output.append(buffer, static_cast<std::size_t>(n));
        }
        ::close(r.fd);
        outcomes[r.index] = judge(r.output, status, overdue);
        remove_case_files(r.index);
        running.erase(running.begin() + static_cast<std::ptrdiff_t>(k));
        fds.erase(fds.begin() + static_cast<std::ptrdiff_t>(k));
      }
    }
    return outcomes;
  }

 private:
  static std::uint64_t address_space_bytes() {
    std::ifstream statm("/proc/self/statm");
    std::uint64_t pages = 0;
    statm >> pages;
    return pages * static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE));
  }

  Outcome judge(const std::string& output, int status, bool overdue) const {
    if (overdue) return {Outcome::Status::kHang, "killed after " + fixed(timeout_s_, 0) + " s"};
    if (WIFSIGNALED(status)) {
      return {Outcome::Status::kCrash, std::string("signal ") + strsignal(WTERMSIG(status))};
    }
    if (output.empty()) {
      return {Outcome::Status::kCrash,
              "exited " + std::to_string(WEXITSTATUS(status)) + " without a report"};
    }
    const std::string detail = output.size() > 2 ? output.substr(2) : "";
    switch (output[0]) {
      case 'R':
        return {Outcome::Status::kRan, ""};
      case 'N':
        return {Outcome::Status::kNonFinite, detail};
      case 'I': {
        // file:line:column: 'key': problem
        static const std::regex kLocated(R"(^[^:]+:\d+:\d+: '[^']+': .+)");
        return {std::regex_search(detail, kLocated) ? Outcome::Status::kInputError
                                                    : Outcome::Status::kBadMessage,
                detail};
      }
      default:
        return {Outcome::Status::kException, detail};
    }
  }

  void remove_case_files(std::size_t id) const {
    const std::string tag = ".case" + std::to_string(id) + ".";
    for (const InputFile& f : files_) {
      for (const fs::path& p : {f.path, f.partner}) {
        if (p.empty()) continue;
        std::error_code error;
        fs::remove(p.parent_path() / (p.stem().string() + tag + p.extension().string().substr(1)),
                   error);
      }
    }
  }

  std::vector<InputFile> files_;
  double window_s_, timeout_s_;
};

TEST(Boundary, EveryNumberOfEveryShippedFileLoadsCleanlyOrRunsFinite) {
  const auto started = std::chrono::steady_clock::now();
  const bool full = std::getenv("LOCSIM_BOUNDARY_FULL") != nullptr &&
                    std::string(std::getenv("LOCSIM_BOUNDARY_FULL")) == "1";
  int jobs = full ? 2 : 1;
  if (const char* env = std::getenv("LOCSIM_BOUNDARY_JOBS")) jobs = std::max(1, std::atoi(env));
  const double window_s = full ? 2.0 : 1.0;
  const double timeout_s = full ? 60.0 : 30.0;

  // A mirror of worlds/: the cases' files are written beside their originals there.
  const fs::path scratch =
      fs::temp_directory_path() / ("locsim_boundary_" + std::to_string(::getpid()));
  fs::remove_all(scratch);
  fs::create_directories(scratch);
  fs::copy(fs::path(LOCSIM_SOURCE_DIR) / "worlds", scratch / "worlds", fs::copy_options::recursive);
  fs::copy(fs::path(LOCSIM_SOURCE_DIR) / "tests/data/every_key", scratch / "every_key",
           fs::copy_options::recursive);
  struct Cleanup {
    fs::path dir;
    ~Cleanup() {
      std::error_code error;
      fs::remove_all(dir, error);
    }
  } cleanup{scratch};

  // The files, each with its kind.
  std::vector<InputFile> files;
  for (const auto& entry : fs::recursive_directory_iterator(scratch)) {
    if (entry.path().extension() != ".yaml") continue;
    InputFile f;
    f.path = entry.path();
    f.text = testing::read_file(f.path);
    const YAML::Node root = YAML::Load(f.text);
    f.kind = root["localizers"] ? Kind::kExperiment
             : root["image"]    ? Kind::kMap
             : root["robots"]   ? Kind::kWorld
                                : Kind::kScenario;
    files.push_back(std::move(f));
  }
  std::sort(files.begin(), files.end(),
            [](const InputFile& a, const InputFile& b) { return a.path < b.path; });
  // Partners: scenarios run on the world of the first experiment naming them, maps in the first
  // world naming them.
  for (InputFile& f : files) {
    if (f.kind == Kind::kScenario) {
      for (const InputFile& e : files) {
        if (e.kind != Kind::kExperiment) continue;
        const YAML::Node root = YAML::Load(e.text);
        if (!root["scenario"] || !root["scenario"].IsScalar()) continue;
        if (fs::weakly_canonical(e.path.parent_path() / root["scenario"].Scalar()) !=
            fs::weakly_canonical(f.path)) {
          continue;
        }
        f.partner = e.path.parent_path() / root["world"].Scalar();
        if (root["duration_s"]) f.partner_duration_s = root["duration_s"].as<double>();
        break;
      }
    } else if (f.kind == Kind::kMap) {
      for (const InputFile& w : files) {
        if (w.kind != Kind::kWorld) continue;
        const YAML::Node map = YAML::Load(w.text)["map"];
        if (!map || fs::weakly_canonical(w.path.parent_path() / map.Scalar()) !=
                        fs::weakly_canonical(f.path)) {
          continue;
        }
        f.partner = w.path;
        f.partner_offset = static_cast<std::size_t>(map.Mark().pos);
        f.partner_length = map.Scalar().size();
        break;
      }
    }
  }

  // The baseline: every file loads as shipped, and the observer tells each number's range.
  std::map<std::string, std::map<std::string, SeenUse>> seen;
  g_seen = &seen;
  const RangeObserver previous = YamlNode::observe_ranges(record_use);
  for (const InputFile& f : files) {
    SCOPED_TRACE(f.path.string());
    switch (f.kind) {
      case Kind::kWorld:
        EXPECT_NO_THROW(load_run_inputs(f.path, std::nullopt, std::nullopt));
        break;
      case Kind::kExperiment:
        EXPECT_NO_THROW(load_experiment(f.path));
        break;
      case Kind::kScenario:
        if (!f.partner.empty()) {
          EXPECT_NO_THROW(load_run_inputs(f.partner, f.path, f.partner_duration_s));
        }
        break;
      case Kind::kMap:
        if (!f.partner.empty()) {
          EXPECT_NO_THROW(load_run_inputs(f.partner, std::nullopt, std::nullopt));
        }
        break;
    }
  }
  YamlNode::observe_ranges(previous);
  g_seen = nullptr;

  // The numbers: every scalar the loaders read with a range, at its place in the text.
  std::vector<Scalar> scalars;
  std::size_t unread_numbers = 0;
  std::set<std::string> unread_paths;
  for (std::size_t i = 0; i < files.size(); ++i) {
    const InputFile& f = files[i];
    const auto& uses = seen[f.path.string()];
    walk(YAML::Load(f.text), "", [&](const std::string& path, const YAML::Node& node) {
      const auto use = uses.find(path);
      if (use == uses.end()) {
        // A number no loader reads as one: plugin parameters (their plugins check them), names.
        try {
          (void)node.as<double>();
          ++unread_numbers;
          unread_paths.insert(without_indices(path));
        } catch (const YAML::Exception&) {
        }
        return;
      }
      const auto pos = static_cast<std::size_t>(node.Mark().pos);
      ASSERT_EQ(f.text.compare(pos, node.Scalar().size(), node.Scalar()), 0)
          << f.path << ": " << path << " is not a plain scalar";
      scalars.push_back(Scalar{i, path, pos, node.Scalar().size(), use->second.range,
                               use->second.degrees, use->second.integer});
    });
  }
  ASSERT_GT(scalars.size(), 100u);

  // The cases: first every file as shipped (the harness itself must run them), then the values.
  std::vector<std::pair<std::size_t, std::optional<std::string>>> cases;
  std::vector<std::pair<std::size_t, std::string>> labels;  // scalar (or npos), value
  for (std::size_t i = 0; i < files.size(); ++i) {
    if ((files[i].kind == Kind::kScenario || files[i].kind == Kind::kMap) &&
        files[i].partner.empty()) {
      continue;
    }
    cases.emplace_back(i, std::nullopt);
    labels.emplace_back(std::string::npos, "as shipped");
  }
  std::set<std::string> tried_paths;
  std::size_t distinct_paths = 0;
  for (std::size_t k = 0; k < scalars.size(); ++k) {
    const Scalar& s = scalars[k];
    const InputFile& f = files[s.file];
    if ((f.kind == Kind::kScenario || f.kind == Kind::kMap) && f.partner.empty()) continue;
    const bool first =
        tried_paths.insert(std::string(kind_name(f.kind)) + ":" + without_indices(s.key_path))
            .second;
    distinct_paths += first ? 1 : 0;
    if (!full && !first) continue;
    for (const std::string& value : boundary_values(s, full)) {
      std::string text = f.text;
      text.replace(s.offset, s.length, value);
      cases.emplace_back(s.file, std::move(text));
      labels.emplace_back(k, value);
    }
  }

  Runner runner(files, window_s, timeout_s);
  const std::vector<Outcome> outcomes = runner.run(cases, jobs);

  std::map<Outcome::Status, std::size_t> counts;
  std::size_t failures = 0;
  for (std::size_t c = 0; c < cases.size(); ++c) {
    const Outcome& o = outcomes[c];
    ++counts[o.status];
    if (o.status == Outcome::Status::kRan || o.status == Outcome::Status::kInputError) continue;
    ++failures;
    const InputFile& f = files[cases[c].first];
    const auto& [scalar, value] = labels[c];
    static const char* kNames[] = {"ran",       "input error", "message without file:line:col",
                                   "exception", "NaN pose",    "crash",
                                   "hang"};
    ADD_FAILURE() << fs::relative(f.path, scratch).string() << ": "
                  << (scalar == std::string::npos ? std::string("(as shipped)")
                                                  : scalars[scalar].key_path + " = " + value)
                  << ": " << kNames[static_cast<int>(o.status)] << ": " << o.detail;
  }
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  std::printf(
      "boundary (%s): %zu files, %zu numbers (%zu distinct key paths; %zu numbers no loader reads "
      "as one), %zu cases in %.1f s with %d jobs: %zu ran finite, %zu input errors with "
      "file:line:col and key, %zu other messages, %zu exceptions, %zu NaN poses, %zu crashes, "
      "%zu hangs\n",
      full ? "full" : "ci", files.size(), scalars.size(), distinct_paths, unread_numbers,
      cases.size(), elapsed, jobs, counts[Outcome::Status::kRan],
      counts[Outcome::Status::kInputError], counts[Outcome::Status::kBadMessage],
      counts[Outcome::Status::kException], counts[Outcome::Status::kNonFinite],
      counts[Outcome::Status::kCrash], counts[Outcome::Status::kHang]);
  if (full) {
    std::printf("numbers no loader reads as one (plugin parameters, names):");
    for (const std::string& path : unread_paths) std::printf(" %s", path.c_str());
    std::printf("\n");
  }
  EXPECT_EQ(failures, 0u);
}

}  // namespace
}  // namespace locsim
