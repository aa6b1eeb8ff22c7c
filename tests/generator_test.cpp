// Generated worlds (sim/world/generator.hpp, `locsim generate`): the same seed gives the same
// file, every drawn world loads and runs, the robot's path and the kidnaps' landings are free,
// and a landing asked for "in view" or "blind" is so, checked here from the loaded world.
#include "sim/world/generator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "run_support.hpp"
#include "sim/common/yaml_node.hpp"
#include "sim/world/world_loader.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

namespace fs = std::filesystem;

WorldDef load(const GeneratedWorld& world) {
  return parse_world(YamlNode::load_string(world.yaml, "generated"), ".");
}

/// Distance from `p` to the nearest wall segment, box or circle of `world`.
double clearance(const WorldDef& world, const Vec2& p) {
  double d = std::numeric_limits<double>::infinity();
  for (const WallDef& wall : world.walls) {
    const std::size_t n = wall.points_m.size();
    for (std::size_t i = 0; i + 1 < n + (wall.closed ? 1 : 0); ++i) {
      const Vec2 a = wall.points_m[i], b = wall.points_m[(i + 1) % n];
      const double t = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      d = std::min(d, (p - (a + t * (b - a))).norm());
    }
  }
  for (const BoxDef& box : world.boxes) {
    const Vec2 q = (p - box.center_m).cwiseAbs() - box.size_m / 2;
    d = std::min(d, q.cwiseMax(0.0).norm() + std::min(0.0, q.maxCoeff()));
  }
  for (const CircleDef& c : world.circles) d = std::min(d, (p - c.center_m).norm() - c.radius_m);
  return d;
}

/// Whether the segment a-b crosses one of the world's walls.
bool crosses_wall(const WorldDef& world, const Vec2& a, const Vec2& b) {
  const auto cross = [](const Vec2& u, const Vec2& v) { return u.x() * v.y() - u.y() * v.x(); };
  for (const WallDef& wall : world.walls) {
    const std::size_t n = wall.points_m.size();
    for (std::size_t i = 0; i + 1 < n + (wall.closed ? 1 : 0); ++i) {
      const Vec2 c = wall.points_m[i], d = wall.points_m[(i + 1) % n];
      const double denominator = cross(b - a, d - c);
      if (std::abs(denominator) < 1e-12) continue;
      const double t = cross(c - a, d - c) / denominator, u = cross(c - a, b - a) / denominator;
      if (t >= 0.0 && t <= 1.0 && u >= 0.0 && u <= 1.0) return true;
    }
  }
  return false;
}

/// Landmarks within `range` and `half_angle` of the pose's heading and not behind a wall (line
/// of sight past obstacles not checked: an upper bound for "blind", and "in view" is checked
/// with its own margin below).
int landmarks_near_heading(const WorldDef& world, const Pose2& pose, double range,
                           double half_angle) {
  int n = 0;
  for (const LandmarkDef& l : world.landmarks) {
    const Vec2 d = l.position_m - pose.position();
    const double bearing = wrap_angle(std::atan2(d.y(), d.x()) - pose.theta);
    if (d.norm() <= range && std::abs(bearing) <= half_angle &&
        !crosses_wall(world, pose.position(), l.position_m))
      ++n;
  }
  return n;
}

TEST(Generator, TheSameSeedGivesTheSameFileAndAnotherSeedAnotherWorld) {
  for (const std::string family : {"room", "corridor", "office"}) {
    GeneratorDef def;
    def.family = family;
    def.seed = 7;
    const std::string first = generate_world(def).yaml;
    EXPECT_EQ(generate_world(def).yaml, first) << family;
    def.seed = 8;
    EXPECT_NE(generate_world(def).yaml, first) << family;
    // A knob changes what it names: no people, no movers.
    def.seed = 7;
    def.people = 0;
    EXPECT_TRUE(load(generate_world(def)).movers.empty()) << family;
  }
}

TEST(Generator, EveryDrawnWorldHasAFreePathAndLandingsAsAsked) {
  for (const std::string family : {"room", "corridor", "office"}) {
    for (std::uint64_t seed = 1; seed <= 25; ++seed) {
      SCOPED_TRACE(family + " seed " + std::to_string(seed));
      GeneratorDef def;
      def.family = family;
      def.seed = seed;
      def.kidnaps = 3;
      const GeneratedWorld generated = generate_world(def);
      const WorldDef world = load(generated);
      ASSERT_EQ(world.robots.size(), 1u);
      ASSERT_TRUE(world.scenario.has_value());
      const double radius = world.robots[0].footprint.radius_m;
      EXPECT_GE(clearance(world, world.robots[0].start.position()), radius);
      ASSERT_EQ(world.scenario->drives.size(), 1u);
      const std::vector<Vec2>& path = world.scenario->drives[0].path_m;
      for (std::size_t i = 0; i < path.size(); ++i) {
        const Vec2 a = path[i], b = path[(i + 1) % path.size()];
        for (int k = 0; k <= 100; ++k)
          ASSERT_GE(clearance(world, a + (b - a) * (k / 100.0)), radius + 0.3)
              << "leg " << i << " at " << k << " %";
      }
      EXPECT_GE(world.landmarks.size(), family == "room" ? 4u : 3u);
      const auto drivable = [&](const Vec2& from) {  // a waypoint in a straight line, no wall
        return std::any_of(path.begin(), path.end(), [&](const Vec2& waypoint) {
          if (crosses_wall(world, from, waypoint)) return false;
          for (int k = 0; k <= 100; ++k)
            if (clearance(world, from + (waypoint - from) * (k / 100.0)) < radius) return false;
          return true;
        });
      };
      int kidnap = 0;
      for (const EventDef& e : world.scenario->events) {
        if (e.kind != EventDef::Kind::kKidnap) continue;
        ASSERT_TRUE(e.to.has_value());
        EXPECT_GE(clearance(world, e.to->position()), radius + 0.3);
        // In an office the robot heads for the nearest waypoint it can drive to: there is one.
        if (family == "office") {
          EXPECT_TRUE(drivable(e.to->position())) << "kidnap " << kidnap;
        }
        EXPECT_LE(e.at_s, world.scenario->duration_s - 10.0);
        // A landing that could not be had as asked says so in a note (and lands anywhere).
        const bool noted = std::any_of(
            generated.notes.begin(), generated.notes.end(),
            [](const std::string& n) { return n.find("no landing") != std::string::npos; });
        if (kidnap % 2 == 0 && !noted) {  // in view: straight ahead, within 7 m and 27.5 deg
          EXPECT_GE(landmarks_near_heading(world, *e.to, 7.0, deg_to_rad(27.5)), 1)
              << "kidnap " << kidnap;
        }
        if (kidnap % 2 == 1 && !noted) {  // blind: none within 8.5 m and 100 deg
          EXPECT_EQ(landmarks_near_heading(world, *e.to, 8.5, deg_to_rad(100.0)), 0)
              << "kidnap " << kidnap;
        }
        ++kidnap;
      }
      const auto noted = [&](const std::string& what) {
        return std::any_of(generated.notes.begin(), generated.notes.end(),
                           [&](const std::string& n) { return n.find(what) != std::string::npos; });
      };
      if (!noted("kidnaps fit")) {
        EXPECT_EQ(kidnap, 3);
      }
    }
  }
}

TEST(Generator, ADrawnWorldRunsWithEverySensorAndTheRobotDrivesItsLoop) {
  for (const std::string family : {"room", "corridor", "office"}) {
    GeneratorDef def;
    def.family = family;
    def.seed = 3;
    def.kidnaps = 0;
    const fs::path dir = testing::temp_dir("generated-" + family);
    const fs::path file = dir / "world.yaml";
    std::ofstream(file) << generate_world(def).yaml;
    RunOptions options;
    options.world_file = file;
    options.duration_s = 20.0;
    options.seed = 1;
    options.out_dir = dir / "out";
    options.localizers = {"odometry"};
    const auto metrics = testing::run_metrics(options);
    ASSERT_EQ(metrics["localizers"][0]["status"], "ok") << family;
    // 20 s at 0.4 m/s: the robot is not stuck against anything.
    std::ifstream truth(dir / "out" / "groundtruth.tum");
    std::string line;
    double t, x, y, x0 = NAN, y0 = NAN, travelled = 0.0;
    while (std::getline(truth, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream(line) >> t >> x >> y;
      if (!std::isnan(x0)) travelled += std::hypot(x - x0, y - y0);
      x0 = x, y0 = y;
    }
    EXPECT_GT(travelled, 5.0) << family;
  }
}

TEST(Generator, BadKnobsAreRefusedAndTheCliWritesNothingThen) {
  GeneratorDef def;
  def.family = "cave";
  EXPECT_THROW(generate_world(def), InputError);
  def.family = "room";
  def.width_m = 3.0;  // no room for a drive loop
  EXPECT_THROW(generate_world(def), InputError);
  def.width_m = 0.0;
  def.duration_s = 1.0;
  EXPECT_THROW(generate_world(def), InputError);

  const fs::path dir = testing::temp_dir("generate-cli");
  const auto ok = testing::locsim("generate room --seeds 3-4 --out " + dir.string());
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_TRUE(fs::exists(dir / "room_seed3.yaml"));
  EXPECT_TRUE(fs::exists(dir / "room_seed4.yaml"));
  // The same seed again: refused, naming the file; seed 5 is not written either.
  const auto again = testing::locsim("generate room --seeds 4-5 --out " + dir.string());
  EXPECT_EQ(again.exit_code, 2) << again.output;
  EXPECT_NE(again.output.find("room_seed4.yaml exists"), std::string::npos) << again.output;
  EXPECT_FALSE(fs::exists(dir / "room_seed5.yaml"));
  const auto bad = testing::locsim("generate room --seeds 5-2 --out " + dir.string());
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("--seeds"), std::string::npos) << bad.output;
  // What is written loads and validates as any world file.
  const auto valid = testing::locsim("validate " + (dir / "room_seed3.yaml").string());
  EXPECT_EQ(valid.exit_code, 0) << valid.output;
}

TEST(Generator, TheShippedSuiteIsWhatTheGeneratorDrawsToday) {
  // Every world of worlds/suite (rooms, corridors and offices with the default knobs; the SLAM
  // rooms; the held-back families) was written by the `locsim generate` command its header
  // gives: a change to the generator that moves one must regenerate it (and the suite's
  // reports), not leave a suite that no command reproduces. Each command is run as written.
  const fs::path suite = fs::path(LOCSIM_SOURCE_DIR) / "worlds/suite";
  const fs::path out = testing::temp_dir("suite-again");
  std::map<std::string, int> per_folder;
  int written = 0;
  for (const auto& entry : fs::recursive_directory_iterator(suite)) {
    if (entry.path().extension() != ".yaml" ||
        entry.path().parent_path().filename() == "experiments")
      continue;
    const std::string text = testing::read_file(entry.path());
    const std::string mark = "# Generated by `";
    ASSERT_EQ(text.rfind(mark, 0), 0u) << entry.path() << ": no generator command in its header";
    const std::size_t end = text.find('`', mark.size());
    ASSERT_NE(end, std::string::npos) << entry.path();
    const std::string command = text.substr(mark.size(), end - mark.size());
    ASSERT_EQ(command.rfind("locsim generate ", 0), 0u) << entry.path() << ": " << command;
    const fs::path folder = out / std::to_string(++written);
    const auto again = testing::locsim(command.substr(std::string("locsim ").size()) +
                                       " --quiet --out " + folder.string());
    ASSERT_EQ(again.exit_code, 0) << command << ": " << again.output;
    EXPECT_EQ(testing::read_file(folder / entry.path().filename()), text)
        << entry.path() << ": regenerate it with `" << command << " --out "
        << entry.path().parent_path().string() << " --overwrite`";
    ++per_folder[fs::relative(entry.path().parent_path(), suite).generic_string()];
  }
  EXPECT_EQ(per_folder, (std::map<std::string, int>{{".", 24},
                                                    {"held_back", 32},
                                                    {"slam", 8},
                                                    {"slam/held_back", 16},
                                                    {"slam/no_people", 8}}));
}

TEST(Generator, CountsDrawnPerSeedAndARobotWithoutAnImu) {
  // --people 5-20: each seed draws its crowd within the range, and the range shows in the
  // header's command; a fixed count draws nothing (the same world as before ranges existed).
  GeneratorDef def;
  def.family = "room";
  def.people = CountKnob(5, 20);
  std::set<std::size_t> crowds;
  for (std::uint64_t seed = 1; seed <= 12; ++seed) {
    def.seed = seed;
    const GeneratedWorld generated = generate_world(def);
    const std::size_t people = load(generated).movers.size();
    const bool noted = !generated.notes.empty();
    EXPECT_TRUE((people >= 5 && people <= 20) || noted) << "seed " << seed << ": " << people;
    crowds.insert(people);
  }
  EXPECT_GE(crowds.size(), 4u) << "a range drawn per seed gives different crowds";
  EXPECT_EQ(generate_command(def), "locsim generate room --seeds 12 --people 5-20");
  def.people = CountKnob(7, 7);
  GeneratorDef fixed = def;
  fixed.people = 7;
  EXPECT_EQ(generate_world(def).yaml, generate_world(fixed).yaml);
  // Without an IMU: no imu sensor, everything else as with it.
  GeneratorDef with_imu;
  with_imu.seed = 4;
  GeneratorDef without = with_imu;
  without.imu = false;
  const WorldDef a = load(generate_world(with_imu)), b = load(generate_world(without));
  EXPECT_TRUE(a.robots[0].sensors.imu.has_value());
  EXPECT_FALSE(b.robots[0].sensors.imu.has_value());
  EXPECT_TRUE(b.robots[0].sensors.laser.has_value());
  EXPECT_EQ(a.landmarks.size(), b.landmarks.size());
  EXPECT_EQ(a.movers.size(), b.movers.size());
  EXPECT_EQ(generate_command(without), "locsim generate room --seeds 4 --no-imu");
  // Bad ranges: refused, naming the option.
  for (const std::string text : {"20-5", "5-", "-5", "5-200", "x", "3-4-5", ""}) {
    try {
      CountKnob::parse(text, "--people");
      ADD_FAILURE() << "'" << text << "' was taken";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("--people"), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(CountKnob::parse("5-20", "--people"), CountKnob(5, 20));
  EXPECT_EQ(CountKnob::parse("0", "--people"), CountKnob(0));
  const fs::path dir = testing::temp_dir("generate-ranges");
  const auto bad = testing::locsim("generate room --people 9-3 --out " + dir.string());
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("--people"), std::string::npos) << bad.output;
  EXPECT_FALSE(fs::exists(dir / "room_seed1.yaml"));
}

TEST(Generator, AFilesHeaderSaysTheCommandThatDrawsIt) {
  GeneratorDef def;
  def.family = "corridor";
  def.seed = 5;
  EXPECT_EQ(generate_command(def), "locsim generate corridor --seeds 5");
  def.people = 0;
  def.kidnaps = 3;
  def.quick_kidnaps = true;
  def.landing = KidnapLanding::kBlind;
  def.beacons = false;
  const std::string command = generate_command(def);
  EXPECT_EQ(
      command,
      "locsim generate corridor --seeds 5 --people 0 --no-beacons --kidnaps 3 --quick-kidnaps "
      "--landing blind");
  EXPECT_NE(generate_world(def).yaml.find("# Generated by `" + command + "`"), std::string::npos);
  for (const std::string_view name : {"alternate", "in_view", "blind", "any"})
    EXPECT_EQ(landing_name(*landing_from_name(name)), name);
  EXPECT_FALSE(landing_from_name("sideways"));
}

}  // namespace
}  // namespace locsim
