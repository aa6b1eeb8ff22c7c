// Declared ranges and the limits behind them (issue 22): the messages, the reading of numbers and
// angles, and the places where a value inside its range used to hang or allocate without bound.
#include <gtest/gtest.h>

#include <chrono>
#include <new>

#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/common/format.hpp"
#include "sim/common/range.hpp"
#include "sim/common/yaml_node.hpp"
#include "sim/sensors/models.hpp"
#include "sim/sensors/scene_rays.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

using testing::make_sim;

TEST(Range, MessagesAreShortAndCarryTheUnit) {
  const Range mass{0.01, 1e5, "kg"};
  EXPECT_EQ(out_of_range(1e38, mass), "1e+38 kg is outside [0.01, 100000] kg");
  EXPECT_EQ(out_of_range(1.7976931348623157e308, mass),
            "1.7976931348623157e+308 kg is outside [0.01, 100000] kg");
  EXPECT_EQ(out_of_range(0.01, mass), "");
  EXPECT_EQ(out_of_range(100000.0, mass), "");
  EXPECT_NE(out_of_range(std::nan(""), mass), "");  // NaN is inside no range
  const Range pan{deg_to_rad(-360.0), deg_to_rad(360.0), "rad"};
  EXPECT_EQ(out_of_range(400.0, pan, true), "400 deg is outside [-360, 360] deg");
  EXPECT_EQ(out_of_range(7.0, pan), "7 rad is outside [-6.28319, 6.28319] rad");
  const Range rate{deg_to_rad(0.01), deg_to_rad(10000.0), "rad/s"};
  EXPECT_EQ(describe(rate, true), "[0.01, 10000] deg/s");
  EXPECT_EQ(describe(Range{0.0, 4611686018427387904.0, ""}), "[0, 4611686018427387904]");
}

TEST(YamlNode, EveryNumberIsReadWithItsRange) {
  const YamlNode root = YamlNode::load_string(
      "a: 3\nb: 2.5\nc: 1e999\nd: 7\nangle_deg: 720\nh: 1e300\nlist: [[1, 2], [3, 40]]\n",
      "t.yaml");
  const Range small{0.0, 10.0, "m"};
  EXPECT_EQ(root["a"].as_int(small), 3);
  EXPECT_EQ(root["b"].as_double(small), 2.5);
  const auto message = [](const auto& read) {
    try {
      read();
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(message([&] { root["c"].as_double(small); }),
            "t.yaml:3:4: 'c': expected a number, got '1e999'");
  EXPECT_EQ(message([&] { root["b"].as_int(small); }),
            "t.yaml:2:4: 'b': expected an integer, got '2.5'");
  const YamlNode seed = YamlNode::load_string("18446744073709551616", "s.yaml");
  EXPECT_EQ(message([&] {
              seed.as_int(Range{0.0, 100.0, ""});
            }),
            "s.yaml:1:1: 18446744073709551616 is outside [0, 100]");
  EXPECT_EQ(message([&] {
              root.get_double("d", 0.0, Range{0.0, 5.0, "s"});
            }),
            "t.yaml:4:4: 'd': 7 s is outside [0, 5] s");
  EXPECT_EQ(message([&] { root["list"].as_points(1, small); }),
            "t.yaml:7:20: 'list[1][1]': 40 m is outside [0, 10] m");
  // Headings: any angle within kHeadingRange, wrapped; absurd magnitudes are refused.
  EXPECT_DOUBLE_EQ(root.get_heading("angle", 1.0), 0.0);
  EXPECT_EQ(message([&] { root.get_heading("h", 0.0); }),
            "t.yaml:6:4: 'h': 1e+300 rad is outside [-1000000, 1000000] rad");
  // A heading already in (-pi, pi] is kept bit for bit (the shipped worlds' results depend on it).
  const YamlNode pose = YamlNode::load_string("{x: 0, y: 0, theta: 3.141592653589793}", "p.yaml");
  EXPECT_EQ(pose.as_pose(kWorldCoordinateRange).theta, 3.141592653589793);
}

TEST(YamlNode, AssigningANodeRebindsItAndLeavesTheDocumentAlone) {
  // yaml-cpp's own assignment writes into the node assigned to: through YamlNode it would have
  // edited the file's tree (a scenario map turned into a scalar).
  const YamlNode root = YamlNode::load_string("a: {b: 1}\nc: 2\n", "t.yaml");
  YamlNode at = root["a"];
  at = root["c"];
  EXPECT_EQ(at.as_int(Range{0.0, 9.0, ""}), 2);
  EXPECT_TRUE(root["a"].is_map());
  EXPECT_EQ(root["a"]["b"].as_int(Range{0.0, 9.0, ""}), 1);
}

TEST(Files, InputFilesAreCheckedBeforeTheyAreRead) {
  const auto dir = testing::temp_dir("files");
  const auto message = [](const std::filesystem::path& file, std::uintmax_t max) {
    try {
      read_input_file(file, max);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(message(dir, 100), dir.string() + ": is a directory, not a file");
  EXPECT_EQ(message(dir / "none.yaml", 100), (dir / "none.yaml").string() + ": no such file");
  std::ofstream(dir / "big.yaml") << std::string(200, 'x');
  EXPECT_NE(message(dir / "big.yaml", 100).find("the file has 200 bytes; at most 100 are read"),
            std::string::npos);
  EXPECT_EQ(read_input_file(dir / "big.yaml", 200), std::string(200, 'x'));
}

TEST(Activity, AnErrorWithoutAPlaceIsToldWhatWasBeingBuilt) {
  try {
    const Activity outer("reading w.yaml");
    const Activity inner("building the sensors' ray grid");
    throw std::bad_alloc();
  } catch (const std::bad_alloc&) {
    EXPECT_EQ(Activity::failed(), "reading w.yaml: building the sensors' ray grid");
  }
  { const Activity done("something that ended well"); }
  EXPECT_EQ(Activity::failed(), "");
}

TEST(Limits, ALoopingPathWithinTheToleranceDoesNotHangTheDriver) {
  // Every waypoint within the tolerance of the robot, looping: before, update() never returned.
  Simulation sim = make_sim(R"(
robots:
  - start: {x: 1, y: 1}
scenario:
  drive: {mode: waypoints, path: [[1, 1], [1.02, 1]], loop: true, tolerance_m: 0.5}
)");
  for (int i = 0; i < 100; ++i) sim.step();
  EXPECT_NEAR(sim.robot(0).pose().x, 1.0, 1e-3);
}

TEST(Limits, AFastSweepOverANarrowPanRangeTakesAFewPasses) {
  // A sweep of 10000 deg/s between limits 1.5e-9 rad apart: before, each frame reflected about
  // 1e10 times (a hang); whole periods are dropped now.
  Simulation sim = make_sim(R"(
robots:
  - start: {x: 1, y: 1}
    sensors: {ptz_camera: {max_pan_rate_deg: 10000}}
scenario:
  ptz: {policy: sweep, sweep_min: 0.1, sweep_max: 0.1000000015, sweep_rate_deg: 10000}
)");
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < 400; ++i) sim.step();  // 2 s, 20 frames
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
  double pan = 0.0;
  for (const Reading& r : sim.take_readings()) {
    if (const auto* ptz = std::get_if<PtzReading>(&r.data)) pan = ptz->pan_rad;
  }
  EXPECT_GE(pan, 0.1);
  EXPECT_LE(pan, 0.1000000015);
}

TEST(Limits, AliasesCannotMultiplyAWorldPastItsBudget) {
  // 20 bytes of YAML repeat a 1001-point wall: 2000 times is 2 million Box2D edges.
  std::string yaml = "robots:\n  - start: {x: 5, y: 5}\nwalls:\n  - &long\n    points: [";
  for (int i = 0; i <= 1000; ++i) yaml += (i ? ", [" : "[") + std::to_string(i) + ", 0]";
  yaml += "]\n";
  for (int i = 1; i < 2000; ++i) yaml += "  - *long\n";
  try {
    testing::world_from_yaml(yaml);
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'walls[1048]': the walls so far have 1049000 segments, "
                                         "more than fit in a world's memory budget of 1 GiB"),
              std::string::npos)
        << e.what();
  }
}

TEST(Limits, TheRayGridStaysSmallForAWorldOfKilometres) {
  // Two walls 19 km apart, and a diagonal across: at the finest cells this was 1e8 cells (800 MB)
  // and as many entries for the diagonal alone.
  const StaticRaycaster rays({{{-9500.0, -9500.0}, {-9500.0, 9500.0}},
                              {{9500.0, -9500.0}, {9500.0, 9500.0}},
                              {{-9500.0, -9500.0}, {9500.0, 9500.0}}},
                             {});
  EXPECT_LE(static_cast<double>(rays.cell_count()), StaticRaycaster::kMaxCells);
  EXPECT_NEAR(rays.cast({0.0, -1.0}, {-1.0, 0.0}, 20000.0), 1.0, 1e-6);  // the diagonal
  EXPECT_NEAR(rays.cast({0.0, 5.0}, {1.0, 0.0}, 20000.0), 5.0, 1e-6);
  EXPECT_NEAR(rays.cast({5.0, 0.0}, {1.0, 0.0}, 20000.0), 9495.0, 1e-6);  // the right wall
}

}  // namespace
}  // namespace locsim
