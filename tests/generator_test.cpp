// Generated worlds (sim/world/generator.hpp, `locsim generate`): the same seed gives the same
// file, every drawn world loads and runs, the robot's path and the kidnaps' landings are free,
// and a landing asked for "in view" or "blind" is so, checked here from the loaded world.
#include "sim/world/generator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
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
  // worlds/suite/FAMILY_seedN.yaml were written by `locsim generate FAMILY --seeds 1-8` with
  // the default knobs: a change to the generator that moves them must regenerate them (and the
  // suite's report), not leave a suite that no command reproduces.
  // The SLAM rooms (worlds/suite/slam) are the suite's rooms without kidnaps, and without people
  // in no_people/: each file's header gives its command.
  const fs::path suite = fs::path(LOCSIM_SOURCE_DIR) / "worlds/suite";
  const auto per_family = [](const fs::path& folder, const GeneratorDef& knobs) {
    std::map<std::string, int> count;
    for (const auto& entry : fs::directory_iterator(folder)) {
      const std::string name = entry.path().filename().string();
      const std::size_t at = name.find("_seed");
      if (entry.path().extension() != ".yaml" || at == std::string::npos) continue;
      GeneratorDef def = knobs;
      def.family = name.substr(0, at);
      def.seed = std::stoull(name.substr(at + 5));
      EXPECT_EQ(generate_world(def).yaml, testing::read_file(entry.path()))
          << entry.path() << ": regenerate with `" << generate_command(def) << "` (--seeds 1-8 "
          << "--out " << folder.filename() << "; remove the old files first)";
      ++count[def.family];
    }
    return count;
  };
  EXPECT_EQ(per_family(suite, {}),
            (std::map<std::string, int>{{"corridor", 8}, {"office", 8}, {"room", 8}}));
  GeneratorDef no_kidnaps;
  no_kidnaps.kidnaps = 0;
  EXPECT_EQ(per_family(suite / "slam", no_kidnaps), (std::map<std::string, int>{{"room", 8}}));
  GeneratorDef calm = no_kidnaps;
  calm.people = 0;
  EXPECT_EQ(per_family(suite / "slam/no_people", calm), (std::map<std::string, int>{{"room", 8}}));
}

TEST(Generator, AFilesHeaderSaysTheCommandThatDrawsIt) {
  GeneratorDef def;
  def.family = "corridor";
  def.seed = 5;
  EXPECT_EQ(generate_command(def), "locsim generate corridor --seed 5");
  def.people = 0;
  def.kidnaps = 3;
  def.quick_kidnaps = true;
  def.landing = KidnapLanding::kBlind;
  def.beacons = false;
  const std::string command = generate_command(def);
  EXPECT_EQ(command,
            "locsim generate corridor --seed 5 --people 0 --no-beacons --kidnaps 3 --quick-kidnaps "
            "--landing blind");
  EXPECT_NE(generate_world(def).yaml.find("# Generated by `" + command + "`"), std::string::npos);
  for (const std::string_view name : {"alternate", "in_view", "blind", "any"})
    EXPECT_EQ(landing_name(*landing_from_name(name)), name);
  EXPECT_FALSE(landing_from_name("sideways"));
}

}  // namespace
}  // namespace locsim
