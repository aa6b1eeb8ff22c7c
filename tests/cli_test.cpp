// The locsim command as a user meets it: exit codes, messages, and run folders.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <opencv2/videoio.hpp>

#include "locsim/localizer.h"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;
using testing::locsim;
using testing::Outcome;

using testing::kDemo;

TEST(Cli, HelpDocumentsTheExitCodes) {
  const Outcome help = locsim("--help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.output.find("2    bad input"), std::string::npos) << help.output;
  const Outcome run_help = locsim("run --help");
  EXPECT_EQ(run_help.exit_code, 0);
  EXPECT_NE(run_help.output.find("--seed"), std::string::npos);
  EXPECT_NE(run_help.output.find("130  interrupted"), std::string::npos);
  EXPECT_NE(run_help.output.find("4    --video/--frames"), std::string::npos);
  EXPECT_NE(run_help.output.find("--video-speed"), std::string::npos);
}

TEST(Cli, BadCommandLineExitsWithTwo) {
  EXPECT_EQ(locsim("").exit_code, 2);
  EXPECT_EQ(locsim("run").exit_code, 2);
  EXPECT_EQ(locsim("run " + kDemo + " --seed banana").exit_code, 2);
  EXPECT_EQ(locsim("run " + kDemo + " --duration -3").exit_code, 2);
  EXPECT_EQ(locsim("fly").exit_code, 2);
}

TEST(Cli, ACommandLineErrorIsOneLineWithThePrefix) {
  for (const std::string& arguments :
       {"run " + kDemo + " --duration 0", "run " + kDemo + " --seed banana", std::string("fly")}) {
    const Outcome o = locsim(arguments);
    EXPECT_EQ(o.exit_code, 2) << arguments;
    EXPECT_EQ(o.output.rfind("locsim: error: ", 0), 0u) << o.output;
    EXPECT_EQ(std::count(o.output.begin(), o.output.end(), '\n'), 1) << o.output;
  }
}

TEST(Cli, AnOutputPathThatCannotBeMadeExitsWithTwoNamingTheOption) {
  const fs::path dir = testing::temp_dir("cli_outputs");
  const std::string log = (dir / "rec.locsimlog").string();
  ASSERT_EQ(locsim("run " + kDemo + " --duration 1 -q --no-readings --out " + (dir / "R").string() +
                   " --log " + log)
                .exit_code,
            0);
  for (const std::string& out : {std::string("/proc/locsim_test_out"), std::string("''")}) {
    for (const auto& [command, option] :
         {std::pair{"calibrate " + log + " -q --out " + out, "--out"},
          std::pair{"generate room --seeds 1 -q --out " + out, "--out"},
          std::pair{"new-plugin my_filter " + out, "new-plugin"},
          std::pair{"twin " + log + " -q --out " + out, out == "''" ? "--out" : "cannot write"},
          std::pair{
              "run " + kDemo + " --duration 1 -q --out " + (dir / "S").string() + " --log " + out,
              out == "''" ? "--log" : "cannot write the log"}}) {
      const Outcome o = locsim(command);
      EXPECT_EQ(o.exit_code, 2) << command << "\n" << o.output;
      EXPECT_EQ(o.output.rfind(std::string("locsim: error: ") + option, 0), 0u) << command << "\n"
                                                                                << o.output;
      EXPECT_EQ(o.output.find("filesystem error"), std::string::npos) << o.output;
    }
  }
  EXPECT_FALSE(fs::exists(dir / "S"));
  // A plugin name longer than a file name may be: refused, nothing made.
  const Outcome long_name =
      locsim("new-plugin " + std::string(300, 'a') + " " + (dir / "np").string());
  EXPECT_EQ(long_name.exit_code, 2) << long_name.output;
  EXPECT_FALSE(fs::exists(dir / "np"));
  // twin onto the log it reads, or onto a folder.
  fs::create_directories(dir / "folder.yaml");
  for (const std::string& out : {log, (dir / "folder.yaml").string()}) {
    const Outcome o = locsim("twin " + log + " -q --overwrite --out " + out);
    EXPECT_EQ(o.exit_code, 2) << out << "\n" << o.output;
  }
  EXPECT_EQ(
      locsim("replay " + log + " -q --localizer odometry --out " + (dir / "P").string()).exit_code,
      0)
      << "the log was damaged";
}

TEST(Cli, MissingWorldFileExitsWithTwoAndWritesNothing) {
  const fs::path out = testing::temp_dir("cli") / "out";
  const Outcome o = locsim("run /nonexistent/world.yaml --out " + out.string());
  EXPECT_EQ(o.exit_code, 2);
  EXPECT_NE(o.output.find("/nonexistent/world.yaml: no such file"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(out));
}

TEST(Cli, MalformedWorldNamesFileLineColumnAndKeyAndWritesNothing) {
  const fs::path dir = testing::temp_dir("cli");
  std::ofstream(dir / "bad.yaml") << "robots:\n  - start: {x: 0, y: 0}\n    wheel_radius_m: -1\n";
  const Outcome o =
      locsim("run " + (dir / "bad.yaml").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(o.exit_code, 2);
  EXPECT_NE(
      o.output.find("bad.yaml:3:21: 'robots[0].wheel_radius_m': -1 m is outside [0.001, 10] m"),
      std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

// Issue 22: values a run cannot use are refused before its folder is made, with the place that
// gives them.
TEST(Cli, OutOfRangeValuesExitWithTwoBeforeAnyFolderIsMade) {
  const fs::path dir = testing::temp_dir("cli");
  // --duration has the scenario's declared range (before: 1e17 s ran 0 steps and said completed).
  Outcome o = locsim("run " + kDemo + " --duration 1e17 --out " + (dir / "long").string());
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("--duration: must be in [0.001, 1e+07], got 1e17"), std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(dir / "long"));
  // A random kidnap with no room for the robot (before: an error half-way, a half-written folder).
  std::ofstream(dir / "full.yaml")
      << "boxes:\n  - {center: [5, 4], size: [2, 2]}\nrobots:\n  - start: {x: 2, y: 2}\n"
         "scenario:\n  duration_s: 5\n  events:\n    - {at_s: 1, kidnap: {to: random, within: "
         "{min: [4.5, 3.5], max: [5.5, 4.5]}}}\n";
  o = locsim("run " + (dir / "full.yaml").string() + " --out " + (dir / "kidnap").string());
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("full.yaml:8:7: 'scenario.events[0].kidnap.within': robot 'robot0' "
                          "fits nowhere"),
            std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(dir / "kidnap"));
  // A scenario file whose ground-truth rate does not divide the physics rate: at its line.
  std::ofstream(dir / "gt.yaml") << "name: gt\nduration_s: 1\ngroundtruth_hz: 30\n";
  o = locsim("run " + kDemo + " --scenario " + (dir / "gt.yaml").string() + " --out " +
             (dir / "gt").string());
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("gt.yaml:3:17: 'groundtruth_hz': rate 30 Hz must divide the physics "
                          "rate (200 Hz)"),
            std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(dir / "gt"));
}

TEST(Cli, ADirectoryGivenAsTheWorldSaysSo) {
  const fs::path dir = testing::temp_dir("cli");
  const Outcome o = locsim("validate " + dir.string());
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find(dir.string() + ": is a directory, not a file"), std::string::npos)
      << o.output;
}

TEST(Cli, RunWritesTheRunFolder) {
  const fs::path out = testing::temp_dir("cli") / "out";
  const Outcome o = locsim("run " + kDemo + " --duration 2 --seed 5 --out " + out.string());
  EXPECT_EQ(o.exit_code, 0) << o.output;
  EXPECT_NE(o.output.find("completed"), std::string::npos);
  for (const char* file : {"run.json", "groundtruth.tum", "events.csv"}) {
    EXPECT_TRUE(fs::exists(out / file)) << file;
  }
  EXPECT_FALSE(fs::exists(out / "run.json.tmp"));
  // The demo robot carries every sensor: one stream each, with its header and rows.
  for (const char* sensor :
       {"encoders", "imu", "ptz_camera", "omni_camera", "ultrasonic", "laser"}) {
    const std::string stream =
        testing::read_file(out / "readings" / (std::string(sensor) + ".csv"));
    EXPECT_TRUE(stream.starts_with("t_s,")) << sensor;
    EXPECT_GT(std::count(stream.begin(), stream.end(), '\n'), 10) << sensor;
  }
  EXPECT_TRUE(fs::exists(out / "readings/sensors.json"));
  EXPECT_NE(testing::read_file(out / "run.json").find("\"seed\": 5"), std::string::npos);
}

TEST(Cli, RefusesToOverwriteANonEmptyFolder) {
  const fs::path out = testing::temp_dir("cli");
  std::ofstream(out / "precious.txt") << "keep me";
  const Outcome o = locsim("run " + kDemo + " --duration 1 --out " + out.string());
  EXPECT_EQ(o.exit_code, 2);
  EXPECT_NE(o.output.find("--overwrite"), std::string::npos);
  EXPECT_EQ(testing::read_file(out / "precious.txt"), "keep me");
  EXPECT_FALSE(fs::exists(out / "run.json"));
  // --overwrite empties a run folder only: this one is not, and stays as it is.
  const Outcome overwrite =
      locsim("run " + kDemo + " --duration 1 --overwrite -q --out " + out.string());
  EXPECT_EQ(overwrite.exit_code, 2) << overwrite.output;
  EXPECT_EQ(testing::read_file(out / "precious.txt"), "keep me");
  EXPECT_FALSE(fs::exists(out / "run.json"));
}

TEST(Cli, MultiRobotWorldsWriteOneFolderPerRobot) {
  const fs::path dir = testing::temp_dir("cli");
  std::ofstream(dir / "two.yaml") << "robots:\n  - {name: a, start: {x: 0, y: 0}}\n"
                                     "  - {name: b, start: {x: 2, y: 0}}\n";
  const Outcome o = locsim("run " + (dir / "two.yaml").string() + " --duration 1 --out " +
                           (dir / "out").string());
  EXPECT_EQ(o.exit_code, 0) << o.output;
  EXPECT_TRUE(fs::exists(dir / "out/a/groundtruth.tum"));
  EXPECT_TRUE(fs::exists(dir / "out/b/groundtruth.tum"));
  EXPECT_TRUE(fs::exists(dir / "out/events.csv"));
  EXPECT_FALSE(fs::exists(dir / "out/groundtruth.tum"));
}

TEST(Cli, CtrlCKeepsWhatWasWrittenAndSaysInterrupted) {
  const fs::path out = testing::temp_dir("cli") / "out";
  // SIGINT after 0.5 s of a run that would take minutes.
  const std::string command = "timeout --preserve-status -s INT 0.5 " + std::string(LOCSIM_BINARY) +
                              " run " + kDemo + " --duration 1000000 --no-readings -q --out " +
                              out.string();
  const int status = std::system(command.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 130);
  const auto run = nlohmann::json::parse(testing::read_file(out / "run.json"));
  EXPECT_EQ(run["status"], "interrupted");
  const double simulated = run["simulated_s"].get<double>();
  EXPECT_GT(simulated, 10.0);
  // Every row up to the interruption is there: the last one is at the last multiple of 20 ms.
  const std::string groundtruth = testing::read_file(out / "groundtruth.tum");
  const std::size_t last_line = groundtruth.rfind('\n', groundtruth.size() - 2) + 1;
  EXPECT_NEAR(std::stod(groundtruth.substr(last_line)), simulated, 0.0201);
}

TEST(Cli, RealtimePacesToTheWallClock) {
  const fs::path out = testing::temp_dir("cli") / "out";
  EXPECT_EQ(
      locsim("run " + kDemo + " --realtime --duration 0.5 -q --out " + out.string()).exit_code, 0);
  const auto run = nlohmann::json::parse(testing::read_file(out / "run.json"));
  EXPECT_GE(run["timing"]["wall_s"].get<double>(), 0.49);
  EXPECT_LT(run["timing"]["wall_s"].get<double>(), 2.0);
  EXPECT_EQ(run["timing"]["realtime_paced"], true);
}

TEST(Cli, ValidateChecksWithoutRunning) {
  const Outcome ok = locsim("validate " + kDemo);
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("ok"), std::string::npos);
  const fs::path dir = testing::temp_dir("cli");
  std::ofstream(dir / "stuck.yaml") << "boxes:\n  - {center: [0, 0], size: [1, 1]}\n"
                                       "robots:\n  - start: {x: 0, y: 0}\n";
  const Outcome stuck = locsim("validate " + (dir / "stuck.yaml").string());
  EXPECT_EQ(stuck.exit_code, 2);
  EXPECT_NE(
      stuck.output.find("stuck.yaml:4:5: 'robots[0].start': robot 'robot0' starts in collision"),
      std::string::npos)
      << stuck.output;
}

TEST(Cli, PluginsShowsEachPluginsAbiVersion) {
  // The tests' plugin folder first: it holds one built for ABI version 1, and the plugins that
  // fail to load (each listed as failed, so the listing exits with 3).
  const Outcome o =
      testing::run_command("LOCSIM_PLUGIN_PATH=" + std::string(LOCSIM_TEST_PLUGIN_DIR) + " " +
                           LOCSIM_BINARY + " plugins");
  EXPECT_EQ(o.exit_code, 3) << o.output;
  const std::string current = "(ABI version " + std::to_string(LOCSIM_LOCALIZER_ABI_VERSION) + ")";
  EXPECT_NE(o.output.find("\ntest_abi1  bad  (ABI version 1)\n"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("\ntest_noop  a test plugin  " + current + "\n"), std::string::npos)
      << o.output;
  // The build's own plugins, after the tests' folder.
  const std::size_t odometry = o.output.find("\nodometry  ");
  ASSERT_NE(odometry, std::string::npos) << o.output;
  const std::string line =
      o.output.substr(odometry + 1, o.output.find('\n', odometry + 1) - odometry - 1);
  EXPECT_TRUE(line.ends_with("  " + current)) << line;
  EXPECT_NE(
      o.output.find("(failed) " + std::string(LOCSIM_TEST_PLUGIN_DIR) + "/locsim_test_bad_abi.so"),
      std::string::npos)
      << o.output;
}

TEST(Cli, RunRendersAVideoWithNoDisplayAndReportsBadVideoOptions) {
  unsetenv("DISPLAY");  // offscreen: no X server needed
  unsetenv("WAYLAND_DISPLAY");
  const fs::path dir = testing::temp_dir("cli-video");
  const Outcome o = locsim("run " + kDemo + " --duration 1 --out " + (dir / "out").string() +
                           " --localizer ekf_landmarks --video " + (dir / "run.mp4").string() +
                           " --video-size 320x240 --video-fps 10");
  EXPECT_EQ(o.exit_code, 0) << o.output;
  EXPECT_NE(o.output.find("video: 11 frames of 320x240"), std::string::npos) << o.output;
  EXPECT_GT(fs::file_size(dir / "run.mp4"), 1000u);

  const Outcome size = locsim("run " + kDemo + " --duration 1 --out " + (dir / "a").string() +
                              " --video " + (dir / "a.mp4").string() + " --video-size big");
  EXPECT_EQ(size.exit_code, 2) << size.output;
  EXPECT_NE(size.output.find("--video-size: 'big'"), std::string::npos) << size.output;

  // A video the encoder cannot write: exit 4, the message names the file, and the video is
  // opened before the run folder is made: none is.
  const Outcome format = locsim("run " + kDemo + " --duration 1 --out " + (dir / "b").string() +
                                " --video " + (dir / "b.txt").string());
  EXPECT_EQ(format.exit_code, 4) << format.output;
  EXPECT_NE(format.output.find("b.txt"), std::string::npos) << format.output;
  EXPECT_FALSE(fs::exists(dir / "b"));
}

TEST(Cli, ReplayRendersAVideoOfALogWithRunsVideoOptions) {
  unsetenv("DISPLAY");  // offscreen: no X server needed
  unsetenv("WAYLAND_DISPLAY");
  const fs::path dir = testing::temp_dir("cli-replay-video");
  const Outcome help = locsim("replay --help");
  EXPECT_NE(help.output.find("--video-speed"), std::string::npos) << help.output;
  EXPECT_NE(help.output.find("--no-camera-view"), std::string::npos) << help.output;
  const std::string log = (dir / "demo.locsimlog").string();
  const Outcome run =
      locsim("run " + kDemo + " --duration 1 -q --out " + (dir / "run").string() + " --log " + log);
  ASSERT_EQ(run.exit_code, 0) << run.output;

  const Outcome o = locsim("replay " + log + " --out " + (dir / "out").string() +
                           " --localizer ekf_landmarks --video " + (dir / "replay.mp4").string() +
                           " --video-size 320x240 --video-fps 10 --video-speed 0.5");
  ASSERT_EQ(o.exit_code, 0) << o.output;
  // 1 s of log at half speed, 10 frames a second: a frame every 0.05 s, 21 frames.
  EXPECT_NE(o.output.find("video: 21 frames of 320x240"), std::string::npos) << o.output;
  cv::VideoCapture video((dir / "replay.mp4").string(), cv::CAP_FFMPEG);
  ASSERT_TRUE(video.isOpened());
  int decoded = 0;
  for (cv::Mat image; video.read(image);) ++decoded;
  EXPECT_EQ(decoded, 21);

  // Refused as a run's: a bad size is bad input, a video the encoder cannot write is exit 4
  // before the replay's folder is made.
  const Outcome size = locsim("replay " + log + " --out " + (dir / "a").string() + " --video " +
                              (dir / "a.mp4").string() + " --video-size 65x64");
  EXPECT_EQ(size.exit_code, 2) << size.output;
  const Outcome format = locsim("replay " + log + " --out " + (dir / "b").string() + " --video " +
                                (dir / "b.txt").string());
  EXPECT_EQ(format.exit_code, 4) << format.output;
  EXPECT_NE(format.output.find("b.txt"), std::string::npos) << format.output;
  EXPECT_FALSE(fs::exists(dir / "b"));
}

TEST(Cli, RunAndValidateLoadTheRendererForARenderedCamera) {
  // mode: rendered needs the renderer: `locsim run` and `locsim validate` load it without being
  // asked, and the detections come from the images (the field's landmarks, with their ids).
  unsetenv("DISPLAY");
  const fs::path dir = testing::temp_dir("cli-rendered");
  const std::string world =
      (fs::path(LOCSIM_SOURCE_DIR) / "worlds/asrl/field_rendered.yaml").string();
  const Outcome check = locsim("validate " + world);
  EXPECT_EQ(check.exit_code, 0) << check.output;
  const Outcome o = locsim("run " + world + " --duration 2 --out " + (dir / "out").string());
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const std::string ptz = testing::read_file(dir / "out/readings/ptz_camera.csv");
  EXPECT_NE(ptz.find(",green,"), std::string::npos) << ptz;
  EXPECT_NE(testing::read_file(dir / "out/run.json").find("\"mode\": \"rendered\""),
            std::string::npos);
  // A renderer that cannot be found: exit 4, the message says where it looked.
  setenv("LOCSIM_RENDER_MODULE", (dir / "missing.so").c_str(), 1);
  const Outcome missing =
      locsim("run " + world + " --duration 1 --out " + (dir / "missing").string());
  unsetenv("LOCSIM_RENDER_MODULE");
  EXPECT_EQ(missing.exit_code, 4) << missing.output;
  EXPECT_NE(missing.output.find("missing.so"), std::string::npos) << missing.output;
}

// Issue 49: a file given where an output folder is meant is bad input (exit 2, before anything
// runs or is written), not an I/O failure at the end (exit 1).
TEST(Cli, AFileGivenAsAnOutputFolderExitsWithTwoAndIsLeftAsItIs) {
  const fs::path dir = testing::temp_dir("cli");
  const Outcome recorded =
      locsim("run " + kDemo + " --duration 3 -q --no-readings --out " + (dir / "run").string() +
             " --log " + (dir / "run.locsimlog").string());
  ASSERT_EQ(recorded.exit_code, 0) << recorded.output;
  const fs::path file = dir / "file.txt";
  std::ofstream(file) << "keep\n";
  const std::string log = (dir / "run.locsimlog").string();
  struct Case {
    std::string command, message;
  };
  const std::string not_a_folder = "--out: '" + file.string() + "' exists and is not a folder";
  const std::string inside = "--out: '" + (file / "sub").string() + "' cannot be made: '" +
                             file.string() + "' is not a folder";
  for (const Case& c : std::vector<Case>{
           {"calibrate " + log + " -q --out " + file.string(), not_a_folder},
           {"calibrate " + log + " -q --out " + (file / "sub").string(), inside},
           {"generate room --seeds 1-2 -q --out " + file.string(), not_a_folder},
           {"generate room --seeds 1 -q --out " + (file / "sub").string(), inside},
           {"run " + kDemo + " --duration 1 -q --out " + (dir / "new").string() + " --log " +
                (file / "x.locsimlog").string(),
            "--log: '" + file.string() + "' exists and is not a folder"},
       }) {
    SCOPED_TRACE(c.command);
    const Outcome o = locsim(c.command);
    EXPECT_EQ(o.exit_code, 2) << o.output;
    testing::expect_contains(o.output, c.message);
    EXPECT_EQ(testing::read_file(file), "keep\n");
  }
  EXPECT_FALSE(fs::exists(dir / "new"));
}

TEST(Cli, ALogInsideARunFolderNotYetMadeIsWritten) {
  // Before: exit 1, "cannot write the log": its folder was not made.
  const fs::path dir = testing::temp_dir("cli");
  const fs::path out = dir / "new";
  const Outcome o = locsim("run " + kDemo + " --duration 2 -q --localizer odometry --out " +
                           out.string() + " --log " + (out / "logs/run.locsimlog").string());
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_TRUE(fs::exists(out / "run.json"));
  const Outcome replayed = locsim("replay " + (out / "logs/run.locsimlog").string() +
                                  " -q --localizer odometry --out " + (dir / "replay").string());
  EXPECT_EQ(replayed.exit_code, 0) << replayed.output;
  EXPECT_EQ(testing::read_file(dir / "replay/odometry.tum"),
            testing::read_file(out / "odometry.tum"));
}

}  // namespace
}  // namespace locsim
