// The physics users rely on: rolling without slip where friction allows, slip where it does not,
// walls that stop the body but not the wheels, kidnapping unseen by the wheels, collisions.
#include <box2d/box2d.h>
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <locsim/models.hpp>
#include <numbers>
#include <random>
#include <vector>

#include "sim/common/math.hpp"
#include "test_support.hpp"

namespace locsim {
namespace {

using testing::drive_for;
using testing::make_sim;

constexpr const char* kOpenFloor = R"(
floor: {friction: 1.0}
robots:
  - name: r
    wheel_base_m: 0.35
    wheel_radius_m: 0.05
    start: {x: 0, y: 0, theta: 0}
)";

/// Distance the wheels' rims have rolled: mean of both wheels. [m]
double rim_travel(const DiffDriveRobot& robot) {
  return 0.5 * (robot.left().angle_rad * robot.left().radius_m +
                robot.right().angle_rad * robot.right().radius_m);
}

// Angles are wrapped everywhere (headings, bearings, noise); the quick return of an angle already
// in range must give what std::remainder gives, bit for bit, or the pinned hashes would move.
TEST(Angles, WrapIsRemaindersAnswerBitForBit) {
  const auto by_remainder = [](double a) {
    double w = std::remainder(a, 2.0 * std::numbers::pi);
    if (w <= -std::numbers::pi) w += 2.0 * std::numbers::pi;
    return w;
  };
  constexpr double pi = std::numbers::pi, inf = std::numeric_limits<double>::infinity();
  std::vector<double> angles = {0.0,
                                -0.0,
                                pi,
                                -pi,
                                3 * pi,
                                -3 * pi,
                                2 * pi,
                                -2 * pi,
                                1e300,
                                -1e-300,
                                inf,
                                -inf,
                                std::numeric_limits<double>::quiet_NaN()};
  for (const double edge : {pi, -pi, 3 * pi, -3 * pi}) {
    angles.push_back(std::nextafter(edge, inf));
    angles.push_back(std::nextafter(edge, -inf));
  }
  std::mt19937_64 engine(3);
  for (int i = 0; i < 100000; ++i)
    angles.push_back(std::uniform_real_distribution<double>(-20.0, 20.0)(engine));
  for (const double a : angles) {
    const auto expected = std::bit_cast<std::uint64_t>(by_remainder(a));
    if (std::isnan(a)) {
      EXPECT_TRUE(std::isnan(wrap_angle(a)) && std::isnan(sdk::wrap(a)));
      continue;
    }
    ASSERT_EQ(std::bit_cast<std::uint64_t>(wrap_angle(a)), expected) << a;
    ASSERT_EQ(std::bit_cast<std::uint64_t>(sdk::wrap(a)), expected) << a;
  }
}

// Box2D's profiling timer is replaced by free definitions (sim/world/physics_world.cpp): libbox2d's
// own calls must reach them, or each step still pays its ten gettimeofday calls. A world busy
// enough that its real step takes well over a microsecond reports zero times.
TEST(Box2dTimer, LibboxCallsReachTheFreeTimer) {
  b2World world(b2Vec2(0.0f, 0.0f));
  b2CircleShape circle;
  circle.m_radius = 0.3f;
  for (int i = 0; i < 400; ++i) {
    b2BodyDef def;
    def.type = b2_dynamicBody;
    def.position.Set(0.05f * static_cast<float>(i % 20), 0.05f * static_cast<float>(i / 20));
    world.CreateBody(&def)->CreateFixture(&circle, 1.0f);  // overlapping: many contacts
  }
  for (int i = 0; i < 5; ++i) world.Step(1.0f / 200.0f, 8, 3);
  const b2Profile& profile = world.GetProfile();
  EXPECT_EQ(profile.step, 0.0f);
  EXPECT_EQ(profile.collide, 0.0f);
  EXPECT_EQ(profile.solve, 0.0f);
  EXPECT_EQ(profile.solveInit, 0.0f);
}

TEST(DiffDrive, StraightDriveMatchesKinematicsOnHighFriction) {
  Simulation sim = make_sim(kOpenFloor);
  drive_for(sim, 5.0, 0.3, 0.0);
  drive_for(sim, 1.0, 0.0, 0.0);  // and stop
  const Pose2 pose = sim.robot(0).pose();
  const double rolled = rim_travel(sim.robot(0));
  EXPECT_NEAR(rolled, 0.3 * 5.0, 0.05);        // the ramp takes a little
  EXPECT_NEAR(pose.x, rolled, 1e-3 * rolled);  // no slip: ground = wheel distance within 0.1 %
  EXPECT_NEAR(pose.y, 0.0, 1e-4);
  EXPECT_NEAR(pose.theta, 0.0, 1e-4);
  EXPECT_LT(sim.robot(0).velocity_mps().norm(), 1e-3);
}

TEST(DiffDrive, TurnInPlaceMatchesKinematicsOnHighFriction) {
  Simulation sim = make_sim(kOpenFloor);
  drive_for(sim, 4.0, 0.0, 0.5);
  drive_for(sim, 1.0, 0.0, 0.0);
  const DiffDriveRobot& robot = sim.robot(0);
  // Heading change from the wheels: (right rim - left rim) / wheel base.
  const double from_wheels = (robot.right().angle_rad * robot.right().radius_m -
                              robot.left().angle_rad * robot.left().radius_m) /
                             robot.def().wheel_base_m;
  EXPECT_NEAR(from_wheels, 2.0, 0.05);
  EXPECT_NEAR(robot.pose().theta, from_wheels, 2e-3 * from_wheels);
  EXPECT_LT(robot.pose().position().norm(), 1e-3);  // turned on the spot
}

TEST(DiffDrive, ACommandResponseDelaysLagsAndScalesTheMotion) {
  // A ramp fast enough not to hide the response; dead time 0.2 s, lag 0.3 s, 90 % of the speed.
  Simulation sim = make_sim(R"(
floor: {friction: 1.0}
robots:
  - name: r
    max_wheel_accel_radps2: 1000
    command_response: {dead_time_s: 0.2, time_constant_v_s: 0.3, gain_v: 0.9, gain_omega: 0.8}
    start: {x: 0, y: 0, theta: 0}
)");
  drive_for(sim, 0.18, 0.4, 0.0);
  EXPECT_LT(sim.robot(0).velocity_mps().norm(), 1e-6);  // nothing before the dead time
  drive_for(sim, 0.32, 0.4, 0.0);                       // one time constant after it
  EXPECT_NEAR(sim.robot(0).velocity_mps().norm(), 0.9 * 0.4 * (1.0 - std::exp(-1.0)), 0.02);
  drive_for(sim, 3.0, 0.4, 0.0);  // settled: the gain
  EXPECT_NEAR(sim.robot(0).velocity_mps().norm(), 0.9 * 0.4, 0.005);
  // The turn rate has no lag of its own: after the dead time it follows at once, scaled.
  drive_for(sim, 0.5, 0.0, 0.5);
  drive_for(sim, 1.0, 0.0, 0.5);
  EXPECT_NEAR(sim.robot(0).yaw_rate_radps(), 0.8 * 0.5, 0.01);
  EXPECT_DOUBLE_EQ(sim.robot(0).given_omega_radps(), 0.5);
}

// side_slip (docs/worlds.md): the body travels at the crab angle to its heading, slides outward
// by c v omega in a turn, and wanders sideways by k^2 per metre; the wheels count none of it.
TEST(DiffDrive, ASideSlipSlidesTheBodyOffItsHeadingAsAsked) {
  const auto world = [](const std::string& slip) {
    return "floor: {friction: 1.0}\nrobots:\n  - name: r\n    max_wheel_accel_radps2: 1000\n"
           "    side_slip: " +
           slip + "\n    start: {x: 0, y: 0, theta: 0}\n";
  };
  const auto lateral_mps = [](const DiffDriveRobot& robot) {
    const double heading = robot.pose().theta;
    return -std::sin(heading) * robot.velocity_mps().x() +
           std::cos(heading) * robot.velocity_mps().y();
  };
  {
    Simulation sim = make_sim(world("{crab_angle_deg: 5}"));
    drive_for(sim, 1.0, 0.8, 0.0);
    const Pose2 from = sim.robot(0).pose();
    const double rolled_from = rim_travel(sim.robot(0));
    drive_for(sim, 10.0, 0.8, 0.0);
    const Pose2 to = sim.robot(0).pose();
    EXPECT_NEAR(to.theta, 0.0, 1e-4);  // no torque: the heading holds
    EXPECT_NEAR(std::atan2(to.y - from.y, to.x - from.x), deg_to_rad(5.0), deg_to_rad(0.05));
    // The wheels roll what the heading's share of the travel is.
    EXPECT_NEAR(rim_travel(sim.robot(0)) - rolled_from, to.x - from.x, 1e-3 * (to.x - from.x));
  }
  {
    // Outward, at the body's own forward speed and turn rate. Read after the step, the body has
    // turned by omega dt since its contacts set its velocity: another dt of compliance, as any
    // turning robot shows.
    Simulation sim = make_sim(world("{cornering_compliance_s: 0.2}"));
    const auto forward_mps = [](const DiffDriveRobot& robot) {
      const double heading = robot.pose().theta;
      return std::cos(heading) * robot.velocity_mps().x() +
             std::sin(heading) * robot.velocity_mps().y();
    };
    drive_for(sim, 5.0, 0.6, 0.5);
    EXPECT_NEAR(forward_mps(sim.robot(0)), 0.6, 1e-3);
    EXPECT_NEAR(lateral_mps(sim.robot(0)),
                -(0.2 + sim.dt_s()) * forward_mps(sim.robot(0)) * sim.robot(0).yaw_rate_radps(),
                2e-4);
    EXPECT_LT(lateral_mps(sim.robot(0)), -0.055);
    drive_for(sim, 2.0, 0.6, -0.5);
    EXPECT_NEAR(lateral_mps(sim.robot(0)),
                -(0.2 + sim.dt_s()) * forward_mps(sim.robot(0)) * sim.robot(0).yaw_rate_radps(),
                2e-4);
    EXPECT_GT(lateral_mps(sim.robot(0)), 0.055);
    drive_for(sim, 2.0, 0.0, 0.0);
    EXPECT_LT(sim.robot(0).velocity_mps().norm(), 1e-3);  // nothing at rest
  }
  {
    // The wander: the sideways drift over 1 s windows (ten time constants) has variance
    // k^2 M g(10), g(x) = (x - 1 + e^-x) / x, M = 1 m; 1000 windows.
    const double k = 0.05, tau_s = 0.1;
    Simulation sim = make_sim(world("{wander_k: 0.05, wander_correlation_s: 0.1}"), 7);
    drive_for(sim, 2.0, 1.0, 0.0);
    double sum_sq = 0.0, travelled = 0.0;
    for (int window = 0; window < 1000; ++window) {
      const Pose2 a = sim.robot(0).pose();
      drive_for(sim, 1.0, 1.0, 0.0);
      const Pose2 b = sim.robot(0).pose();
      const double mid = a.theta + 0.5 * wrap_angle(b.theta - a.theta);
      const double across = -std::sin(mid) * (b.x - a.x) + std::cos(mid) * (b.y - a.y);
      sum_sq += across * across;
      travelled += std::hypot(b.x - a.x, b.y - a.y);
    }
    const double x = 1.0 / tau_s, g = (x - 1.0 + std::exp(-x)) / x;
    EXPECT_NEAR(travelled / 1000.0, 1.0, 0.01);
    EXPECT_NEAR(sum_sq / travelled, k * k * g, 0.15 * k * k * g);
  }
}

TEST(DiffDrive, UnequalWheelRadiiCurveAStraightCommand) {
  Simulation sim = make_sim(R"(
floor: {friction: 1.0}
robots:
  - wheel_base_m: 0.35
    wheel_radius_m: 0.05
    wheel_radius_left_m: 0.051
    start: {x: 0, y: 0}
)");
  drive_for(sim, 10.0, 0.3, 0.0);
  const DiffDriveRobot& robot = sim.robot(0);
  // Both wheels turn alike; the larger left one rolls further, so the robot veers right.
  const double expected = (robot.right().angle_rad * 0.05 - robot.left().angle_rad * 0.051) / 0.35;
  EXPECT_LT(robot.pose().theta, -0.1);
  EXPECT_NEAR(robot.pose().theta, expected, 0.01 * std::abs(expected));
}

TEST(DiffDrive, IceWithHardAccelerationSlips) {
  Simulation sim = make_sim(R"(
floor: {friction: 0.05}
robots:
  - start: {x: 0, y: 0}
)");
  drive_for(sim, 2.0, 1.0, 0.0);
  const double ground = sim.robot(0).pose().x;
  const double wheels = rim_travel(sim.robot(0));
  EXPECT_GT(ground, 0.1);  // it does move
  EXPECT_LT(ground, 0.6 * wheels) << "ground " << ground << " m, wheels " << wheels << " m";
  EXPECT_GT(sim.stats(0).slip_time_s, 1.0);
}

TEST(DiffDrive, SameCommandOnCarpetDoesNotSlip) {
  Simulation sim = make_sim(R"(
floor: {friction: 1.0}
robots:
  - start: {x: 0, y: 0}
)");
  drive_for(sim, 2.0, 1.0, 0.0);
  EXPECT_NEAR(sim.robot(0).pose().x, rim_travel(sim.robot(0)), 1e-3);
  EXPECT_EQ(sim.stats(0).slip_time_s, 0.0);
}

TEST(DiffDrive, FrictionRegionAndFrictionEventApply) {
  // The robot starts on an icy region; an event turns the ice into carpet at t = 2 s.
  Simulation sim = make_sim(R"(
floor:
  friction: 1.0
  regions:
    - {name: ice, friction: 0.02, box: {min: [-5, -5], max: [5, 5]}}
robots:
  - start: {x: 0, y: 0}
scenario:
  events:
    - {at_s: 2.0, friction: {region: ice, friction: 1.0}}
)");
  drive_for(sim, 2.0, 1.0, 0.0);
  EXPECT_LT(sim.robot(0).pose().x, 0.5 * rim_travel(sim.robot(0)));
  const double x0 = sim.robot(0).pose().x, rolled0 = rim_travel(sim.robot(0));
  drive_for(sim, 1.0, 0.3, 0.0);  // settles to rolling on the new floor
  const double x1 = sim.robot(0).pose().x, rolled1 = rim_travel(sim.robot(0));
  drive_for(sim, 1.0, 0.3, 0.0);
  EXPECT_NEAR(sim.robot(0).pose().x - x1, rim_travel(sim.robot(0)) - rolled1, 1e-3);
  EXPECT_GT(x1, x0);
  EXPECT_GT(rolled1, rolled0);
}

TEST(DiffDrive, WallStopsTheBodyWhileTheWheelsKeepTurning) {
  Simulation sim = make_sim(R"(
floor: {friction: 0.8}
walls:
  - points: [[2, -5], [2, 5]]
robots:
  - footprint: {radius_m: 0.2}
    start: {x: 0, y: 0}
)");
  drive_for(sim, 8.0, 0.5, 0.0);  // reaches the wall after ~3.6 s
  const Pose2 against = sim.robot(0).pose();
  EXPECT_NEAR(against.x, 1.8, 0.02);  // touching the wall, not through it
  const double angle_before = sim.robot(0).left().angle_rad;
  drive_for(sim, 2.0, 0.5, 0.0);
  EXPECT_NEAR(sim.robot(0).pose().x, against.x, 1e-3);  // the body stays
  EXPECT_NEAR(sim.robot(0).left().angle_rad - angle_before, 2.0 * 0.5 / 0.05, 0.5);  // wheels spin
  EXPECT_TRUE(sim.robot(0).left().slipping);
  EXPECT_EQ(sim.stats(0).collisions, 1);
}

TEST(DiffDrive, WeakMotorStallsAgainstAWall) {
  // mu N r = 0.8 * (10 * 9.81 * 0.8 / 2) * 0.05 = 1.57 N m; a 0.5 N m motor cannot slip the wheel.
  Simulation sim = make_sim(R"(
floor: {friction: 0.8}
walls:
  - points: [[1, -5], [1, 5]]
robots:
  - max_wheel_torque_nm: 0.5
    start: {x: 0, y: 0}
)");
  drive_for(sim, 5.0, 0.5, 0.0);
  const double angle_before = sim.robot(0).left().angle_rad;
  drive_for(sim, 2.0, 0.5, 0.0);
  EXPECT_LT(sim.robot(0).left().angle_rad - angle_before, 0.5);  // vs 20 rad if free
}

TEST(Kidnap, MovesThePoseAndTheWheelsNeverNotice) {
  Simulation sim = make_sim(R"(
floor: {friction: 1.0}
robots:
  - start: {x: 0, y: 0}
scenario:
  events:
    - at_s: 2.0
      kidnap: {to: {x: 5, y: 3, theta_deg: 90}, carry_s: 1.0}
)");
  drive_for(sim, 2.0, 0.3, 0.0);
  const Pose2 before = sim.robot(0).pose();
  const double left = sim.robot(0).left().angle_rad, right = sim.robot(0).right().angle_rad;
  drive_for(sim, 0.5, 0.3, 0.0);  // carried: commands change nothing
  EXPECT_TRUE(sim.robot(0).carried());
  EXPECT_EQ(sim.robot(0).left().angle_rad, left);
  EXPECT_EQ(sim.robot(0).right().angle_rad, right);
  drive_for(sim, 0.5, 0.0, 0.0);  // put down at t = 3 s
  EXPECT_FALSE(sim.robot(0).carried());
  EXPECT_EQ(sim.robot(0).left().angle_rad, left);
  const Pose2 after = sim.robot(0).pose();
  EXPECT_NEAR(after.x, 5.0, 1e-3);
  EXPECT_NEAR(after.y, 3.0, 1e-3);
  EXPECT_NEAR(after.theta, std::numbers::pi / 2, 1e-3);
  EXPECT_GT((after.position() - before.position()).norm(), 5.0);
  const auto events = sim.take_events();
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].kind, "kidnap");
  EXPECT_EQ(events[1].kind, "put_down");
  EXPECT_DOUBLE_EQ(events[1].t_s, 3.0);
  EXPECT_EQ(sim.stats(0).kidnaps, 1);
}

TEST(Kidnap, RandomPoseIsFreeAndInsideTheGivenArea) {
  const std::string world = R"(
walls:
  - points: [[0, 0], [6, 0], [6, 4], [0, 4]]
    closed: true
boxes:
  - {center: [3, 2], size: [2, 2]}
robots:
  - start: {x: 1, y: 1}
scenario:
  events:
    - {at_s: 0.5, kidnap: {to: random}}
)";
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    Simulation sim = make_sim(world, seed);
    drive_for(sim, 0.6, 0.0, 0.0);
    const Pose2 pose = sim.robot(0).pose();
    EXPECT_GT(pose.x, 0.2);
    EXPECT_LT(pose.x, 5.8);
    EXPECT_GT(pose.y, 0.2);
    EXPECT_LT(pose.y, 3.8);
    const bool in_box = std::abs(pose.x - 3) < 1.2 && std::abs(pose.y - 2) < 1.2;
    EXPECT_FALSE(in_box) << "seed " << seed << " put the robot into the box";
  }
}

TEST(Collisions, PersonWalkingIntoTheRobotCollidesAndPushesIt) {
  Simulation sim = make_sim(R"(
floor: {friction: 0.8}
movers:
  - name: alice
    path: [[-3, 0], [3, 0]]
    speed_mps: 1.0
    loop: false
robots:
  - name: r
    start: {x: 0, y: 0.1}
)");
  drive_for(sim, 4.0, 0.0, 0.0);
  const auto events = sim.take_events();
  const auto collision = std::find_if(events.begin(), events.end(), [](const SimEvent& e) {
    return e.kind == "collision" && e.details.find("with=alice") != std::string::npos;
  });
  ASSERT_NE(collision, events.end());
  EXPECT_NEAR(collision->t_s, 2.55, 0.05);                // 3 m - (0.25 + 0.2 m radii) at 1 m/s
  EXPECT_GT(sim.robot(0).pose().position().norm(), 0.1);  // shoved aside
}

TEST(Collisions, RobotsCollideWithEachOther) {
  Simulation sim = make_sim(R"(
robots:
  - {name: a, start: {x: 0, y: 0, theta: 0}}
  - {name: b, start: {x: 2, y: 0, theta_deg: 180}}
)");
  for (int i = 0; i < 600; ++i) {
    sim.robot(0).command(0.4, 0.0);
    sim.robot(1).command(0.4, 0.0);
    sim.step();
  }
  EXPECT_EQ(sim.stats(0).collisions, 1);
  EXPECT_EQ(sim.stats(1).collisions, 1);
  EXPECT_LT(sim.robot(0).pose().x, sim.robot(1).pose().x - 0.39);  // never interpenetrate
}

TEST(Collisions, PushMovesTheRobot) {
  Simulation sim = make_sim(R"(
robots:
  - start: {x: 0, y: 0}
scenario:
  events:
    - {at_s: 0.1, push: {impulse_ns: [0, 20]}}
)");
  drive_for(sim, 1.0, 0.0, 0.0);
  EXPECT_GT(sim.robot(0).pose().y, 0.05);  // sideways: the wheels' lateral grip slows it
  EXPECT_EQ(sim.robot(0).left().angle_rad, 0.0);
}

TEST(Movers, WalkTheirPathAtTheirSpeedAndObeyStopAndStart) {
  Simulation sim = make_sim(R"(
movers:
  - {name: bob, path: [[0, 5], [4, 5], [4, 7]], speed_mps: 0.5, loop: false}
robots:
  - start: {x: 0, y: 0}
scenario:
  events:
    - {at_s: 2, obstacle: {name: bob, action: stop}}
    - {at_s: 4, obstacle: {name: bob, action: start}}
)");
  const auto bob = [&] { return from_b2(sim.world().movers()[0].body->GetPosition()); };
  drive_for(sim, 2.0, 0.0, 0.0);
  EXPECT_NEAR(bob().x(), 1.0, 1e-4);
  drive_for(sim, 2.0, 0.0, 0.0);  // stopped
  EXPECT_NEAR(bob().x(), 1.0, 1e-4);
  drive_for(sim, 7.0, 0.0, 0.0);  // 3 m to the corner, then 0.5 m up
  EXPECT_NEAR(bob().x(), 4.0, 1e-4);
  EXPECT_NEAR(bob().y(), 5.5, 1e-3);
  drive_for(sim, 10.0, 0.0, 0.0);  // stays at the end of an open path
  EXPECT_NEAR(bob().y(), 7.0, 1e-4);
}

TEST(Drivers, WaypointsAreVisitedInOrder) {
  Simulation sim = make_sim(R"(
robots:
  - start: {x: 0, y: 0}
scenario:
  duration_s: 40
  drive: {mode: waypoints, path: [[2, 0], [2, 2], [0, 2]], loop: false, speed_mps: 0.5}
)");
  double closest[3] = {1e9, 1e9, 1e9};
  const Vec2 targets[3] = {{2, 0}, {2, 2}, {0, 2}};
  while (!sim.done()) {
    sim.step();
    for (int i = 0; i < 3; ++i) {
      closest[i] = std::min(closest[i], (sim.robot(0).pose().position() - targets[i]).norm());
    }
  }
  for (const double d : closest) EXPECT_LT(d, 0.06);
  EXPECT_LT((sim.robot(0).pose().position() - targets[2]).norm(), 0.06);  // stopped at the end
}

TEST(Drivers, AfterAKidnapNearestInSightHeadsForAWaypointItCanReach) {
  // Two rooms split by a wall at x = 4 with a doorway at y in [3, 4.2]. The robot loops
  // between (1, 1) and (2, 1) in the west room and is carried into the east room at 2 s.
  // Continuing to its old target, it drives into the wall; with nearest_in_sight it heads for
  // the nearest waypoint it can reach in a straight line: (3, 3.6), through the doorway (the
  // other two are behind the wall). Static contacts are counted from the put-down on.
  const auto run = [](const std::string& after_kidnap) {
    Simulation sim = make_sim(R"(
walls:
  - points: [[0, 0], [8, 0], [8, 5], [0, 5]]
    closed: true
  - points: [[4, 0], [4, 3]]
  - points: [[4, 4.2], [4, 5]]
robots:
  - start: {x: 1, y: 1}
scenario:
  duration_s: 20
  drive: {mode: waypoints, path: [[2, 1], [1, 1], [3, 3.6]], loop: true, speed_mps: 0.4,
          after_kidnap: )" + after_kidnap +
                              R"(}
  events:
    - at_s: 2
      kidnap: {to: {x: 6, y: 3.6, theta_deg: 0}, carry_s: 0.5}
)");
    int static_contacts = 0;
    double closest_m = 1e9;  // to (3, 3.6), after the put-down
    while (!sim.done()) {
      sim.step();
      for (const auto& e : sim.take_events()) {
        if (e.kind == "collision" && e.details.find("with=static") != std::string::npos &&
            sim.time_s() > 2.5)
          ++static_contacts;
      }
      if (sim.time_s() > 2.5)
        closest_m = std::min(closest_m, (sim.robot(0).pose().position() - Vec2(3, 3.6)).norm());
    }
    return std::pair{static_contacts, closest_m};
  };
  const auto [stuck_contacts, stuck_closest] = run("continue");
  EXPECT_GT(stuck_contacts, 0);   // into the wall, towards (2, 1) or (1, 1)
  EXPECT_GT(stuck_closest, 1.0);  // and never through the doorway (its centre stays east)
  const auto [contacts, closest] = run("nearest_in_sight");
  EXPECT_EQ(contacts, 0);
  EXPECT_LT(closest, 0.06);  // through the doorway to (3, 3.6), then on round the loop
}

TEST(Drivers, StartAfterHoldsTheRobotStillThenDrives) {
  Simulation sim = make_sim(R"(
robots:
  - start: {x: 0, y: 0}
scenario:
  duration_s: 4
  drive: {mode: waypoints, start_after_s: 2, path: [[3, 0]], loop: false, speed_mps: 0.5}
)");
  while (sim.time_s() < 1.99) sim.step();
  EXPECT_LT(sim.robot(0).pose().position().norm(), 1e-6);  // still standing
  while (!sim.done()) sim.step();
  EXPECT_GT(sim.robot(0).pose().position().x(), 0.5);  // then off at 0.5 m/s
}

/// One robot wandering a closed 4 m x 4 m room for `duration_s`, driven by `drive` (YAML keys).
Simulation wander_in_room(double duration_s, const std::string& drive) {
  return make_sim(R"(
walls:
  - points: [[0, 0], [4, 0], [4, 4], [0, 4]]
    closed: true
robots:
  - start: {x: 2, y: 2}
scenario:
  duration_s: )" + std::to_string(duration_s) +
                  "\n  drive: {mode: wander, " + drive + "}\n");
}

TEST(Drivers, WanderNeverLeavesAClosedRoom) {
  Simulation sim = wander_in_room(60.0, "speed_mps: 0.5");
  while (!sim.done()) sim.step();
  const Pose2 pose = sim.robot(0).pose();
  EXPECT_GT(sim.stats(0).ground_distance_m, 10.0);
  EXPECT_TRUE(pose.x > 0 && pose.x < 4 && pose.y > 0 && pose.y < 4);
  // Looking ahead at 20 Hz (2.5 cm of travel between looks) it turns before it touches a wall.
  EXPECT_EQ(sim.stats(0).collisions, 0);
}

// Looking ahead seldom enough, a wanderer at speed reaches the wall between two looks: the rate
// is what decides, not the physics step.
TEST(Drivers, WanderLooksAheadAtItsCheckRate) {
  const auto collisions = [](double check_hz) {
    Simulation sim =
        wander_in_room(30.0, "speed_mps: 1.0, clearance_check_hz: " + std::to_string(check_hz));
    while (!sim.done()) sim.step();
    return sim.stats(0).collisions;
  };
  EXPECT_EQ(collisions(200.0), 0);
  EXPECT_GT(collisions(1.0), 0);
}

}  // namespace
}  // namespace locsim
