#include "sim/world/generator.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "sim/common/errors.hpp"
#include "sim/common/format.hpp"
#include "sim/common/math.hpp"
#include "sim/common/random.hpp"
#include "sim/common/yaml_node.hpp"
#include "sim/world/world_loader.hpp"

namespace locsim {
namespace {

// The generated robot: the demo's (a 0.2 m footprint, every sensor at its defaults, phantom
// detections included). Clearances below are from its footprint.
constexpr double kRobotRadiusM = 0.2;
constexpr double kDriveSpeedMps = 0.4;
// The PTZ camera's defaults (sim/sensors/sensor_defs.hpp): what "a landmark in view" means for a
// landing, with margins so that a landing in view is in view however the pan sweep starts.
constexpr double kViewHalfAngleRad = deg_to_rad(65.0 / 2.0 - 5.0);
constexpr double kViewMinRangeM = 0.6, kViewMaxRangeM = 7.0;
// A landing is "blind" when no landmark is within this range and half-angle: the pan sweep
// (+-90 deg) does not find one before the robot turns.
constexpr double kBlindHalfAngleRad = deg_to_rad(100.0);
constexpr const char* kColors[] = {"red",    "green",  "blue", "yellow", "magenta", "cyan",
                                   "orange", "purple", "pink", "brown",  "white",   "black"};

/// A pillar (circle) or a cabinet (axis-aligned box).
struct Obstacle {
  bool circle = true;
  Vec2 center{0.0, 0.0};
  double radius_m = 0.0;                  // circle
  Vec2 half_size{0.0, 0.0};               // box
  double distance(const Vec2& p) const {  // from its surface (negative inside)
    if (circle) return (p - center).norm() - radius_m;
    const Vec2 d = (p - center).cwiseAbs() - half_size;
    return d.cwiseMax(0.0).norm() + std::min(0.0, d.maxCoeff());
  }
};

double to_mm(double v) {
  return std::round(v * 1000.0) / 1000.0;
}

double segment_distance(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / std::max(ab.squaredNorm(), 1e-12), 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

/// A rectangular room or corridor [0, L] x [0, W] and what is placed in it.
class Layout {
 public:
  Layout(const GeneratorDef& def, double length, double width)
      : def_(def), length_(length), width_(width) {}

  RandomStream stream(std::string_view what) const {
    return make_stream(def_.seed, "generate/" + std::string(what));
  }
  double wall_distance(const Vec2& p) const {
    double d = std::min({p.x(), length_ - p.x(), p.y(), width_ - p.y()});
    for (const auto& [a, b] : inner_walls) d = std::min(d, segment_distance(p, a, b));
    return d;
  }
  /// Whether the segment a-b passes through an inner wall (an office's).
  bool crosses_inner_wall(const Vec2& a, const Vec2& b) const {
    const auto cross = [](const Vec2& u, const Vec2& v) { return u.x() * v.y() - u.y() * v.x(); };
    for (const auto& [c, d] : inner_walls) {
      const Vec2 r = b - a, s = d - c;
      const double denominator = cross(r, s);
      if (std::abs(denominator) < 1e-12) continue;  // parallel: the clearance checks see it
      const double t = cross(c - a, s) / denominator, u = cross(c - a, r) / denominator;
      if (t >= 0.0 && t <= 1.0 && u >= 0.0 && u <= 1.0) return true;
    }
    return false;
  }
  double obstacle_distance(const Vec2& p) const {
    double d = std::numeric_limits<double>::infinity();
    for (const Obstacle& o : obstacles) d = std::min(d, o.distance(p));
    return d;
  }
  double path_distance(const Vec2& p) const {
    double d = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < path.size(); ++i)
      d = std::min(d, segment_distance(p, path[i], path[(i + 1) % path.size()]));
    return d;
  }
  /// Free for the robot's centre with `margin` to spare from walls, obstacles and landmarks
  /// (cylinders of 0.1 m).
  bool free(const Vec2& p, double margin) const {
    bool clear = wall_distance(p) >= kRobotRadiusM + margin &&
                 obstacle_distance(p) >= kRobotRadiusM + margin;
    for (const Vec2& l : landmarks) clear = clear && (l - p).norm() >= 0.1 + kRobotRadiusM + margin;
    return clear;
  }
  /// The segment a-b clear of obstacles by `clearance` (sampled every 5 cm).
  bool segment_clear(const Vec2& a, const Vec2& b, double clearance) const {
    if (crosses_inner_wall(a, b)) return false;
    const int steps = std::max(1, static_cast<int>(std::ceil((b - a).norm() / 0.05)));
    for (int i = 0; i <= steps; ++i) {
      const Vec2 p = a + (b - a) * (static_cast<double>(i) / steps);
      if (obstacle_distance(p) < clearance) return false;
    }
    return true;
  }
  /// Whether the robot can drive from a to b in a straight line, its footprint clear of walls
  /// and obstacles: after a kidnap in an office it heads for the nearest waypoint it can reach
  /// so (drive.after_kidnap: nearest_in_sight), and a landing must have one.
  bool drivable(const Vec2& a, const Vec2& b) const {
    if (crosses_inner_wall(a, b)) return false;
    const int steps = std::max(1, static_cast<int>(std::ceil((b - a).norm() / 0.05)));
    for (int i = 0; i <= steps; ++i) {
      const Vec2 p = a + (b - a) * (static_cast<double>(i) / steps);
      if (wall_distance(p) < kRobotRadiusM + 0.05 || obstacle_distance(p) < kRobotRadiusM + 0.05)
        return false;
    }
    return true;
  }
  bool waypoint_drivable(const Vec2& from) const {
    return std::any_of(path.begin(), path.end(),
                       [&](const Vec2& waypoint) { return drivable(from, waypoint); });
  }
  /// Landmarks straight ahead of `pose` within `max_range` and `half_angle` of its heading, not
  /// behind an inner wall; with `sight`, only those whose line of sight is clear of obstacles
  /// too (a landing "in view" needs one; a "blind" one has none even behind a pillar, which the
  /// robot would soon see past, but may have one behind an office's wall).
  int landmarks_seen(const Pose2& pose, double half_angle, double max_range, bool sight) const {
    int seen = 0;
    for (const Vec2& l : landmarks) {
      const Vec2 d = l - pose.position();
      const double r = d.norm();
      const double bearing = wrap_angle(std::atan2(d.y(), d.x()) - pose.theta);
      if ((sight && r < kViewMinRangeM) || r > max_range || std::abs(bearing) > half_angle)
        continue;
      if (sight && !segment_clear(pose.position(), l, 0.0)) continue;
      if (crosses_inner_wall(pose.position(), l)) continue;
      ++seen;
    }
    return seen;
  }

  const GeneratorDef& def_;
  double length_, width_;
  std::vector<Vec2> path;                          // the drive loop's waypoints
  std::vector<std::pair<Vec2, Vec2>> inner_walls;  // an office's, besides the outer rectangle
  std::vector<Vec2> landmarks;
  std::vector<Obstacle> obstacles;
  struct Walker {
    Vec2 a, b;
    double speed_mps;
  };
  std::vector<Walker> people;
  struct Patch {
    Vec2 min, max;
    double friction;
  };
  std::vector<Patch> patches;
  std::vector<Vec2> beacons;
  struct Kidnap {
    double at_s;
    Pose2 to;
    std::string landing;  // "in view", "blind", "any"
  };
  std::vector<Kidnap> kidnaps;
  std::vector<std::string> notes;
};

/// One of `n` indices, each as likely.
std::size_t pick(RandomStream& random, std::size_t n) {
  return std::min(n - 1, static_cast<std::size_t>(random.uniform() * static_cast<double>(n)));
}

/// The count asked for, or one drawn in the family's range [lo, hi], or in the range asked for.
/// A count asked for draws nothing: the stream's later draws stay as they were.
int count_or(const CountKnob& asked, RandomStream& random, int lo, int hi) {
  if (asked.given()) {
    if (asked.min == asked.max) return asked.min;
    lo = asked.min;
    hi = asked.max;
  }
  return std::min(hi, lo + static_cast<int>(std::floor(random.uniform() * (hi - lo + 1))));
}

void place_obstacles(Layout& layout, int count, bool against_walls) {
  RandomStream random = layout.stream("obstacles");
  int placed = 0;
  for (int k = 0; k < count; ++k) {
    for (int attempt = 0; attempt < 500; ++attempt) {
      Obstacle o;
      o.circle = random.uniform() < 0.5;
      o.radius_m = random.uniform(0.15, 0.4);
      o.half_size = {random.uniform(0.15, 0.6), random.uniform(0.15, 0.6)};
      const double x = random.uniform(0.0, layout.length_);
      const double y = random.uniform(0.0, layout.width_);
      o.center = {x, y};
      if (against_walls) {  // a cabinet or a bin standing at a corridor wall
        o.circle = false;
        o.half_size.y() = std::min(o.half_size.y(), 0.25);
        o.center.y() =
            y < layout.width_ / 2 ? o.half_size.y() + 0.03 : layout.width_ - o.half_size.y() - 0.03;
      }
      const double extent = o.circle ? o.radius_m : o.half_size.norm();
      // Clear of the drive path (the robot passes), of the landmarks (the camera sees them),
      // of the walls unless standing against one, and of the other obstacles.
      bool ok = layout.path_distance(o.center) >= extent + kRobotRadiusM + 0.35;
      for (const Vec2& l : layout.landmarks) ok = ok && (l - o.center).norm() >= extent + 0.5;
      if (!against_walls) ok = ok && layout.wall_distance(o.center) >= extent + 0.3;
      ok = ok && layout.obstacle_distance(o.center) >= extent + 0.5;
      if (!ok) continue;
      layout.obstacles.push_back(o);
      ++placed;
      break;
    }
  }
  if (placed < count)
    layout.notes.push_back("placed " + std::to_string(placed) + " of " + std::to_string(count) +
                           " obstacles (no room clear of the path)");
}

void place_patches(Layout& layout, int count) {
  RandomStream random = layout.stream("slippery");
  for (int k = 0; k < count; ++k) {
    // On the drive path: a patch the robot never crosses would test nothing.
    const std::size_t leg = std::min(
        layout.path.size() - 1,
        static_cast<std::size_t>(random.uniform() * static_cast<double>(layout.path.size())));
    const Vec2 a = layout.path[leg], b = layout.path[(leg + 1) % layout.path.size()];
    const Vec2 c = a + (b - a) * random.uniform(0.2, 0.8);
    const Vec2 half{random.uniform(0.4, 0.8), random.uniform(0.4, 0.8)};  // braces: drawn in order
    const Vec2 lo = c - half, hi = c + half;
    layout.patches.push_back({lo.cwiseMax(Vec2(0.05, 0.05)),
                              hi.cwiseMin(Vec2(layout.length_ - 0.05, layout.width_ - 0.05)),
                              random.uniform(0.05, 0.15)});
  }
}

void place_kidnaps(Layout& layout) {
  const GeneratorDef& def = layout.def_;
  RandomStream random = layout.stream("kidnaps");
  double t = def.duration_s * random.uniform(0.2, 0.35);
  for (int k = 0; k < def.kidnaps; ++k) {
    if (k > 0)
      t += def.quick_kidnaps && k == 1 ? random.uniform(3.0, 6.0)
                                       : def.duration_s * random.uniform(0.15, 0.25);
    if (t > def.duration_s - 10.0) {
      layout.notes.push_back("only " + std::to_string(k) + " of " + std::to_string(def.kidnaps) +
                             " kidnaps fit in the run (each needs 10 s after it)");
      break;
    }
    std::string want = "any";
    if (def.landing == KidnapLanding::kInView ||
        (def.landing == KidnapLanding::kAlternate && k % 2 == 0))
      want = "in view";
    else if (def.landing == KidnapLanding::kBlind ||
             (def.landing == KidnapLanding::kAlternate && k % 2 == 1))
      want = "blind";
    std::optional<Pose2> landing;
    for (int attempt = 0; attempt < 2000 && !landing; ++attempt) {
      const Pose2 p{random.uniform(0.0, layout.length_), random.uniform(0.0, layout.width_),
                    random.uniform(-std::numbers::pi, std::numbers::pi)};
      // Clear of everything with room to turn. Not kept away from where the robot is then
      // (the generator does not simulate the drive): a landing may be a short carry.
      if (!layout.free(p.position(), 0.3)) continue;
      if (!layout.inner_walls.empty() && !layout.waypoint_drivable(p.position())) continue;
      if (want == "in view" &&
          layout.landmarks_seen(p, kViewHalfAngleRad, kViewMaxRangeM, true) == 0)
        continue;
      if (want == "blind" && layout.landmarks_seen(p, kBlindHalfAngleRad, 8.5, false) > 0) continue;
      landing = p;
    }
    if (!landing) {
      layout.notes.push_back("kidnap " + std::to_string(k + 1) + ": no landing " + want +
                             " found; it lands anywhere free");
      for (int attempt = 0; attempt < 2000 && !landing; ++attempt) {
        const Pose2 p{random.uniform(0.0, layout.length_), random.uniform(0.0, layout.width_),
                      random.uniform(-std::numbers::pi, std::numbers::pi)};
        if (layout.free(p.position(), 0.3) &&
            (layout.inner_walls.empty() || layout.waypoint_drivable(p.position())))
          landing = p;
      }
      want = "any";
      if (!landing) throw std::logic_error("generate: no free landing in the world");
    }
    layout.kidnaps.push_back({t, *landing, want});
    t += 2.0;  // the carry
  }
}

/// `count` landmarks drawn by `draw` (a candidate, or nullopt to draw again), 1 m apart.
template <class Draw>
void place_landmarks(Layout& layout, int count, Draw&& draw) {
  for (int k = 0; k < count; ++k) {
    for (int attempt = 0; attempt < 500; ++attempt) {
      const std::optional<Vec2> p = draw();
      if (!p) continue;
      bool ok = true;
      for (const Vec2& q : layout.landmarks) ok = ok && (q - *p).norm() >= 1.0;
      if (!ok) continue;
      layout.landmarks.push_back(*p);
      break;
    }
  }
  if (static_cast<int>(layout.landmarks.size()) < count)
    layout.notes.push_back("placed " + std::to_string(layout.landmarks.size()) + " of " +
                           std::to_string(count) + " landmarks (1 m apart)");
}

void draw_room(Layout& layout) {
  const GeneratorDef& def = layout.def_;
  RandomStream random = layout.stream("path");
  // A loop inset from each wall by 1-2 m, its corners jittered.
  const double l = layout.length_, w = layout.width_;
  const auto inset = [&](double size) {
    return std::min(random.uniform(1.0, 2.0), std::max(0.6, size / 2 - 1.0));
  };
  const double x0 = inset(l), x1 = l - inset(l), y0 = inset(w), y1 = w - inset(w);
  const auto jitter = [&] { return random.uniform(-0.3, 0.3); };
  layout.path = {{x0 + jitter(), y0 + jitter()},
                 {x1 + jitter(), y0 + jitter()},
                 {x1 + jitter(), y1 + jitter()},
                 {x0 + jitter(), y1 + jitter()}};
  if (random.uniform() < 0.5) std::reverse(layout.path.begin() + 1, layout.path.end());

  RandomStream lm = layout.stream("landmarks");
  const int count = count_or(def.landmarks, lm, 4, 8);
  place_landmarks(layout, count, [&]() -> std::optional<Vec2> {
    if (def.landmarks_anywhere) {
      const Vec2 p{lm.uniform(0.5, l - 0.5), lm.uniform(0.5, w - 0.5)};  // braces: in order
      if (layout.path_distance(p) < kRobotRadiusM + 0.5) return std::nullopt;
      return p;
    }
    // On the perimeter, 0.3 m in from the wall.
    const double s = lm.uniform(0.0, 2.0 * (l + w));
    const Vec2 p = s < l           ? Vec2(s, 0.3)
                   : s < l + w     ? Vec2(l - 0.3, s - l)
                   : s < 2 * l + w ? Vec2(2 * l + w - s, w - 0.3)
                                   : Vec2(0.3, 2 * (l + w) - s);
    return p.cwiseMax(Vec2(0.3, 0.3)).cwiseMin(Vec2(l - 0.3, w - 0.3));
  });
  RandomStream counts = layout.stream("counts");
  place_obstacles(layout, count_or(def.obstacles, counts, 2, 5), false);
  // People cross the room from wall to wall, through the drive loop.
  RandomStream walkers = layout.stream("people");
  const int people = count_or(def.people, counts, 1, 3);
  for (int k = 0; k < people; ++k) {
    for (int attempt = 0; attempt < 500; ++attempt) {
      const bool across_x = walkers.uniform() < 0.5;
      const Vec2 a = across_x ? Vec2(0.5, walkers.uniform(0.5, w - 0.5))
                              : Vec2(walkers.uniform(0.5, l - 0.5), 0.5);
      const Vec2 b = across_x ? Vec2(l - 0.5, walkers.uniform(0.5, w - 0.5))
                              : Vec2(walkers.uniform(0.5, l - 0.5), w - 0.5);
      const double speed = walkers.uniform(0.5, 1.1);
      if (!layout.segment_clear(a, b, 0.4)) continue;
      // Not through where the robot starts: a shove before the filters have seen anything.
      if (segment_distance(layout.path[0], a, b) < kRobotRadiusM + 1.0) continue;
      layout.people.push_back({a, b, speed});
      break;
    }
  }
  if (static_cast<int>(layout.people.size()) < people)
    layout.notes.push_back("placed " + std::to_string(layout.people.size()) + " of " +
                           std::to_string(people) + " people (no clear walk across the room)");
  place_patches(layout, count_or(def.slippery, counts, 0, 2));
  if (def.beacons)
    layout.beacons = {{0.1, 0.1}, {l - 0.1, 0.1}, {l - 0.1, w - 0.1}, {0.1, w - 0.1}};
}

/// `people` walking up and down a corridor between y0 and y0 + width, each along one side (a
/// person is 0.25 m in radius); a cabinet in that lane: the other one.
void place_corridor_walkers(Layout& layout, double y0, double width, int people) {
  RandomStream walkers = layout.stream("people");
  const double l = layout.length_;
  for (int k = 0; k < people; ++k) {
    const double lane = walkers.uniform() < 0.5 ? width * 0.35 : width * 0.65;
    const double speed = walkers.uniform(0.5, 1.1);
    for (const double y_lane : {lane, width - lane}) {
      const Vec2 a(0.6, y0 + y_lane), b(l - 0.6, y0 + y_lane);
      if (!layout.segment_clear(a, b, 0.27)) continue;
      layout.people.push_back({a, b, speed});
      break;
    }
  }
  if (static_cast<int>(layout.people.size()) < people)
    layout.notes.push_back("placed " + std::to_string(layout.people.size()) + " of " +
                           std::to_string(people) + " people (cabinets block both lanes)");
}

void draw_corridor(Layout& layout) {
  const GeneratorDef& def = layout.def_;
  const double l = layout.length_, w = layout.width_;
  RandomStream random = layout.stream("path");
  // Up and down the corridor's centre line, turning 1.5 m from each end.
  const double y = w / 2 + random.uniform(-0.1, 0.1);
  layout.path = {{1.5, y}, {l - 1.5, y}};
  RandomStream lm = layout.stream("landmarks");
  place_landmarks(layout, count_or(def.landmarks, lm, 3, 3), [&]() -> std::optional<Vec2> {
    // On a side wall, 0.2 m in.
    const double x = lm.uniform(0.3, l - 0.3);
    return Vec2(x, lm.uniform() < 0.5 ? 0.2 : w - 0.2);
  });
  RandomStream counts = layout.stream("counts");
  place_obstacles(layout, count_or(def.obstacles, counts, 2, 4), true);
  place_corridor_walkers(layout, 0.0, w, count_or(def.people, counts, 1, 3));
  place_patches(layout, count_or(def.slippery, counts, 0, 2));
  if (def.beacons) {
    for (double x = 0.1; x < l; x += 8.0)
      layout.beacons.push_back({x, layout.beacons.size() % 2 == 0 ? 0.1 : w - 0.1});
  }
}

/// An office: a corridor along x with a row of rooms on each side, each room entered by a
/// doorway from the corridor. The robot drives the corridor and into some of the rooms, round
/// a leg inside each and out again; landmarks hang on the rooms' walls and the corridor's.
void draw_office(Layout& layout) {
  const GeneratorDef& def = layout.def_;
  const double l = layout.length_, w = layout.width_;
  RandomStream random = layout.stream("plan");
  const double corridor = random.uniform(1.8, 2.4);
  const double y0 = to_mm(random.uniform(0.4, 0.6) * (w - corridor)), y1 = to_mm(y0 + corridor);
  const double yc = (y0 + y1) / 2;
  struct Room {
    double xa, xb, door;  // extent along x, doorway centre [m]
    bool south;
  };
  std::vector<Room> rooms;
  for (const bool south : {true, false}) {
    double xa = 0.0;
    while (xa < l - 0.1) {
      double xb = to_mm(xa + random.uniform(3.5, 6.0));
      if (xb > l - 3.5) xb = l;  // the last room takes what is left
      const double door = to_mm(random.uniform(xa + 1.0, xb - 1.0));
      rooms.push_back({xa, xb, door, south});
      if (xb < l) {  // the partition to the next room
        layout.inner_walls.push_back(south ? std::pair{Vec2(xb, 0.0), Vec2(xb, y0)}
                                           : std::pair{Vec2(xb, y1), Vec2(xb, w)});
      }
      xa = xb;
    }
  }
  // The corridor's walls, broken by the doorways (1.2 m: the robot passes 0.4 m from each jamb).
  constexpr double kDoorHalfM = 0.6;
  for (const bool south : {true, false}) {
    double from = 0.0;
    for (const Room& room : rooms) {
      if (room.south != south) continue;
      layout.inner_walls.push_back(
          {Vec2(from, south ? y0 : y1), Vec2(room.door - kDoorHalfM, south ? y0 : y1)});
      from = room.door + kDoorHalfM;
    }
    layout.inner_walls.push_back({Vec2(from, south ? y0 : y1), Vec2(l, south ? y0 : y1)});
  }
  // The drive: along the corridor, into each visited room through its doorway, to the room's
  // far end and back out; rooms visited in the order of their doorways.
  std::vector<const Room*> visited;
  for (const Room& room : rooms)
    if (random.uniform() < 0.5) visited.push_back(&room);
  if (visited.size() < 2) {  // at least two rooms, one on each side
    visited.clear();
    for (const bool south : {true, false}) {
      std::vector<const Room*> side;
      for (const Room& room : rooms)
        if (room.south == south) side.push_back(&room);
      visited.push_back(side[pick(random, side.size())]);
    }
  }
  std::sort(visited.begin(), visited.end(),
            [](const Room* a, const Room* b) { return a->door < b->door; });
  layout.path.push_back({1.2, yc});
  for (const Room* room : visited) {
    const double depth = room->south ? y0 : w - y1;
    const double y_in = room->south ? y0 - std::min(1.5, depth / 2) : y1 + std::min(1.5, depth / 2);
    const double x_far =
        room->door - room->xa > room->xb - room->door ? room->xa + 1.0 : room->xb - 1.0;
    layout.path.push_back({room->door, yc});
    layout.path.push_back({room->door, y_in});
    layout.path.push_back({x_far, y_in});
    layout.path.push_back({room->door, y_in});
    layout.path.push_back({room->door, yc});
  }
  layout.path.push_back({l - 1.2, yc});

  // Landmarks: on the rooms' walls away from the corridor (their far wall and partitions) and
  // on the corridor's walls clear of the doorways. About one per room and two in the corridor.
  RandomStream lm = layout.stream("landmarks");
  const int count = count_or(def.landmarks, lm, static_cast<int>(rooms.size()) / 2 + 2,
                             static_cast<int>(rooms.size()) + 2);
  place_landmarks(layout, count, [&]() -> std::optional<Vec2> {
    if (lm.uniform() < 0.25) {  // the corridor
      const double x = lm.uniform(0.3, l - 0.3);
      const bool south = lm.uniform() < 0.5;
      for (const Room& room : rooms)
        if (room.south == south && std::abs(x - room.door) < kDoorHalfM + 0.5) return std::nullopt;
      return Vec2(x, south ? y0 + 0.2 : y1 - 0.2);
    }
    const Room& room = rooms[pick(lm, rooms.size())];
    const double width = room.xb - room.xa, depth = room.south ? y0 : w - y1;
    // 0.3 m in from the far wall or a partition; not on the corridor's side (the doorway's).
    const double s = lm.uniform(0.0, width + 2.0 * depth);
    const double y_far = room.south ? 0.3 : w - 0.3;
    const double y_side = room.south ? lm.uniform(0.3, y0 - 0.5) : lm.uniform(y1 + 0.5, w - 0.3);
    const Vec2 q = s < width           ? Vec2(room.xa + std::clamp(s, 0.3, width - 0.3), y_far)
                   : s < width + depth ? Vec2(room.xa + 0.3, y_side)
                                       : Vec2(room.xb - 0.3, y_side);
    if (layout.path_distance(q) < kRobotRadiusM + 0.5) return std::nullopt;
    return q;
  });
  RandomStream counts = layout.stream("counts");
  place_obstacles(layout, count_or(def.obstacles, counts, 3, 8), false);
  place_corridor_walkers(layout, y0, corridor, count_or(def.people, counts, 1, 3));
  place_patches(layout, count_or(def.slippery, counts, 0, 2));
  if (def.beacons) {
    // On the corridor's ceiling every 6 m, and one in each room's far corner.
    for (double x = 0.1; x < l; x += 6.0)
      layout.beacons.push_back({x, layout.beacons.size() % 2 == 0 ? y0 + 0.1 : y1 - 0.1});
    for (const Room& room : rooms)
      layout.beacons.push_back({room.xa + 0.1, room.south ? 0.1 : w - 0.1});
  }
}

void emit_point(YAML::Emitter& out, const Vec2& p) {
  out << YAML::Flow << YAML::BeginSeq << to_mm(p.x()) << to_mm(p.y()) << YAML::EndSeq;
}

std::string emit(const Layout& layout, const std::string& header) {
  const GeneratorDef& def = layout.def_;
  const double l = layout.length_, w = layout.width_;
  YAML::Emitter out;
  out.SetDoublePrecision(10);
  out << YAML::Comment(header);
  out << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << def.family + "_seed" + std::to_string(def.seed);
  out << YAML::Key << "walls" << YAML::Value << YAML::BeginSeq << YAML::BeginMap;
  out << YAML::Key << "points" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (const Vec2& c : {Vec2(0, 0), Vec2(l, 0), Vec2(l, w), Vec2(0, w)}) emit_point(out, c);
  out << YAML::EndSeq << YAML::Key << "closed" << YAML::Value << true;
  out << YAML::EndMap;
  for (const auto& [a, b] : layout.inner_walls) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "points" << YAML::Value << YAML::BeginSeq;
    emit_point(out, a);
    emit_point(out, b);
    out << YAML::EndSeq << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (!layout.patches.empty()) {
    out << YAML::Key << "floor" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "friction" << YAML::Value << 0.8;
    out << YAML::Key << "regions" << YAML::Value << YAML::BeginSeq;
    for (std::size_t k = 0; k < layout.patches.size(); ++k) {
      const auto& patch = layout.patches[k];
      out << YAML::Flow << YAML::BeginMap;
      out << YAML::Key << "name" << YAML::Value << "slippery" + std::to_string(k + 1);
      out << YAML::Key << "friction" << YAML::Value << to_mm(patch.friction);
      out << YAML::Key << "box" << YAML::Value << YAML::BeginMap;
      out << YAML::Key << "min" << YAML::Value;
      emit_point(out, patch.min);
      out << YAML::Key << "max" << YAML::Value;
      emit_point(out, patch.max);
      out << YAML::EndMap << YAML::EndMap;
    }
    out << YAML::EndSeq << YAML::EndMap;
  }
  std::vector<const Obstacle*> circles, boxes;
  for (const Obstacle& o : layout.obstacles) (o.circle ? circles : boxes).push_back(&o);
  if (!boxes.empty()) {
    out << YAML::Key << "boxes" << YAML::Value << YAML::BeginSeq;
    for (const Obstacle* o : boxes) {
      out << YAML::Flow << YAML::BeginMap << YAML::Key << "center" << YAML::Value;
      emit_point(out, o->center);
      out << YAML::Key << "size" << YAML::Value;
      emit_point(out, 2.0 * o->half_size);
      out << YAML::Key << "height_m" << YAML::Value << 1.2 << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  if (!circles.empty()) {
    out << YAML::Key << "circles" << YAML::Value << YAML::BeginSeq;
    for (const Obstacle* o : circles) {
      out << YAML::Flow << YAML::BeginMap << YAML::Key << "center" << YAML::Value;
      emit_point(out, o->center);
      out << YAML::Key << "radius_m" << YAML::Value << to_mm(o->radius_m) << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  out << YAML::Key << "landmarks" << YAML::Value << YAML::BeginSeq;
  for (std::size_t k = 0; k < layout.landmarks.size(); ++k) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "id" << YAML::Value << k + 1;
    out << YAML::Key << "position" << YAML::Value;
    emit_point(out, layout.landmarks[k]);
    out << YAML::Key << "color" << YAML::Value << kColors[k % std::size(kColors)] << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (!layout.beacons.empty()) {
    out << YAML::Key << "beacons" << YAML::Value << YAML::BeginSeq;
    for (std::size_t k = 0; k < layout.beacons.size(); ++k) {
      out << YAML::Flow << YAML::BeginMap << YAML::Key << "id" << YAML::Value << k + 1;
      out << YAML::Key << "position" << YAML::Value;
      emit_point(out, layout.beacons[k]);
      out << YAML::Key << "height_m" << YAML::Value << 2.5 << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  if (!layout.people.empty()) {
    out << YAML::Key << "movers" << YAML::Value << YAML::BeginSeq;
    for (std::size_t k = 0; k < layout.people.size(); ++k) {
      const auto& p = layout.people[k];
      out << YAML::Flow << YAML::BeginMap;
      out << YAML::Key << "name" << YAML::Value << "person" + std::to_string(k + 1);
      out << YAML::Key << "kind" << YAML::Value << "person";
      out << YAML::Key << "path" << YAML::Value << YAML::BeginSeq;
      emit_point(out, p.a);
      emit_point(out, p.b);
      out << YAML::EndSeq << YAML::Key << "speed_mps" << YAML::Value << to_mm(p.speed_mps);
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  // The robot: the demo's, every sensor at its own defaults.
  const Vec2 start = layout.path[0], next = layout.path[1];
  const double heading = std::atan2(next.y() - start.y(), next.x() - start.x());
  out << YAML::Key << "robots" << YAML::Value << YAML::BeginSeq << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << "robot";
  out << YAML::Key << "footprint" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key
      << "radius_m" << YAML::Value << kRobotRadiusM << YAML::EndMap;
  out << YAML::Key << "mass_kg" << YAML::Value << 10;
  out << YAML::Key << "wheel_base_m" << YAML::Value << 0.33;
  out << YAML::Key << "wheel_radius_m" << YAML::Value << 0.05;
  out << YAML::Key << "start" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "x"
      << YAML::Value << to_mm(start.x()) << YAML::Key << "y" << YAML::Value << to_mm(start.y())
      << YAML::Key << "theta_deg" << YAML::Value << to_mm(rad_to_deg(heading)) << YAML::EndMap;
  out << YAML::Key << "sensors" << YAML::Value << YAML::BeginMap;
  const auto sensor = [&](const char* name, double rate_hz, bool mount, double mount_x) {
    out << YAML::Key << name << YAML::Value << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "rate_hz" << YAML::Value << rate_hz;
    if (mount)
      out << YAML::Key << "mount" << YAML::Value << YAML::BeginMap << YAML::Key << "x"
          << YAML::Value << mount_x << YAML::Key << "y" << YAML::Value << 0 << YAML::Key << "theta"
          << YAML::Value << 0 << YAML::EndMap;
    out << YAML::EndMap;
  };
  sensor("encoders", 50, false, 0);
  if (def.imu) sensor("imu", 100, false, 0);
  sensor("ptz_camera", 10, true, 0.1);
  sensor("omni_camera", 10, false, 0);
  if (!layout.beacons.empty()) sensor("ultrasonic", 20, false, 0);
  sensor("laser", 10, true, 0.12);
  out << YAML::EndMap << YAML::EndMap << YAML::EndSeq;

  out << YAML::Key << "scenario" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << (layout.kidnaps.empty() ? "tracking" : "kidnap");
  out << YAML::Key << "duration_s" << YAML::Value << def.duration_s;
  out << YAML::Key << "drive" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "mode" << YAML::Value << "waypoints";
  out << YAML::Key << "path" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (std::size_t k = 1; k <= layout.path.size(); ++k)
    emit_point(out, layout.path[k % layout.path.size()]);
  out << YAML::EndSeq;
  out << YAML::Key << "loop" << YAML::Value << true;
  out << YAML::Key << "speed_mps" << YAML::Value << kDriveSpeedMps;
  // Put down in one room, the waypoint it was heading for may be behind a wall.
  if (!layout.inner_walls.empty())
    out << YAML::Key << "after_kidnap" << YAML::Value << "nearest_in_sight";
  out << YAML::EndMap;
  out << YAML::Key << "ptz" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "policy"
      << YAML::Value << "sweep" << YAML::EndMap;
  if (!layout.kidnaps.empty()) {
    out << YAML::Key << "events" << YAML::Value << YAML::BeginSeq;
    for (const auto& k : layout.kidnaps) {
      out << YAML::BeginMap << YAML::Key << "at_s" << YAML::Value << to_mm(k.at_s);
      out << YAML::Key << "kidnap" << YAML::Value << YAML::Flow << YAML::BeginMap;
      out << YAML::Key << "to" << YAML::Value << YAML::BeginMap << YAML::Key << "x" << YAML::Value
          << to_mm(k.to.x) << YAML::Key << "y" << YAML::Value << to_mm(k.to.y) << YAML::Key
          << "theta_deg" << YAML::Value << to_mm(rad_to_deg(k.to.theta)) << YAML::EndMap;
      out << YAML::Key << "carry_s" << YAML::Value << 2.0 << YAML::EndMap << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  out << YAML::EndMap;
  out << YAML::EndMap;
  if (!out.good()) throw std::logic_error("generate: YAML emitter: " + out.GetLastError());
  return std::string(out.c_str()) + "\n";
}

}  // namespace

std::string CountKnob::text() const {
  if (!given()) return "drawn";
  return min == max ? std::to_string(min) : std::to_string(min) + "-" + std::to_string(max);
}

CountKnob CountKnob::parse(std::string_view text, std::string_view option) {
  const auto number = [](std::string_view part, int& out) {
    const auto [end, ec] = std::from_chars(part.data(), part.data() + part.size(), out);
    return !part.empty() && ec == std::errc() && end == part.data() + part.size();
  };
  const std::size_t dash = text.find('-');
  CountKnob knob;
  const bool read =
      dash == std::string_view::npos
          ? number(text, knob.min) && (knob.max = knob.min, true)
          : number(text.substr(0, dash), knob.min) && number(text.substr(dash + 1), knob.max);
  const auto& range = GeneratorDef::kCountRange;
  if (!read || knob.min < range.min || knob.max > range.max || knob.max < knob.min)
    throw InputError(std::string(option) + ": expected a count N or a range A-B drawn per seed (" +
                     short_number(range.min) + " <= A <= B <= " + short_number(range.max) +
                     "), got '" + std::string(text) + "'");
  return knob;
}

const std::vector<std::string>& generator_families() {
  static const std::vector<std::string> families = {"room", "corridor", "office"};
  return families;
}

std::string_view landing_name(KidnapLanding landing) {
  switch (landing) {
    case KidnapLanding::kInView:
      return "in_view";
    case KidnapLanding::kBlind:
      return "blind";
    case KidnapLanding::kAny:
      return "any";
    case KidnapLanding::kAlternate:
      break;
  }
  return "alternate";
}

std::optional<KidnapLanding> landing_from_name(std::string_view name) {
  for (const KidnapLanding l : {KidnapLanding::kAlternate, KidnapLanding::kInView,
                                KidnapLanding::kBlind, KidnapLanding::kAny})
    if (landing_name(l) == name) return l;
  return std::nullopt;
}

std::string generate_command(const GeneratorDef& def) {
  const GeneratorDef defaults;
  std::ostringstream out;
  out << "locsim generate " << def.family << " --seeds " << def.seed;
  if (def.length_m != defaults.length_m) out << " --length " << def.length_m;
  if (def.width_m != defaults.width_m) out << " --width " << def.width_m;
  if (def.landmarks != defaults.landmarks) out << " --landmarks " << def.landmarks.text();
  if (def.landmarks_anywhere) out << " --landmarks-anywhere";
  if (def.obstacles != defaults.obstacles) out << " --obstacles " << def.obstacles.text();
  if (def.people != defaults.people) out << " --people " << def.people.text();
  if (def.slippery != defaults.slippery) out << " --slippery " << def.slippery.text();
  if (!def.beacons) out << " --no-beacons";
  if (!def.imu) out << " --no-imu";
  if (def.kidnaps != defaults.kidnaps) out << " --kidnaps " << def.kidnaps;
  if (def.quick_kidnaps) out << " --quick-kidnaps";
  if (def.landing != defaults.landing) out << " --landing " << landing_name(def.landing);
  if (def.duration_s != defaults.duration_s) out << " --duration " << def.duration_s;
  return out.str();
}

GeneratedWorld generate_world(const GeneratorDef& def) {
  const auto& families = generator_families();
  if (std::find(families.begin(), families.end(), def.family) == families.end())
    throw InputError("generate: no family '" + def.family + "' (room, corridor or office)");
  const auto check = [](double value, const Range& range, const char* what) {
    if (!range.contains(value))
      throw InputError("generate: " + std::string(what) + ": " + out_of_range(value, range));
  };
  if (def.length_m != 0.0) check(def.length_m, GeneratorDef::kSizeRange, "--length");
  if (def.width_m != 0.0) check(def.width_m, GeneratorDef::kSizeRange, "--width");
  check(def.duration_s, GeneratorDef::kDurationRange, "--duration");
  for (const auto& [knob, what] : {std::pair{def.landmarks, "--landmarks"},
                                   {def.obstacles, "--obstacles"},
                                   {def.people, "--people"},
                                   {def.slippery, "--slippery"},
                                   {CountKnob(def.kidnaps), "--kidnaps"}}) {
    if (!knob.given()) continue;
    check(knob.min, GeneratorDef::kCountRange, what);
    check(knob.max, GeneratorDef::kCountRange, what);
    if (knob.max < knob.min)
      throw InputError("generate: " + std::string(what) + ": the range " + knob.text() +
                       " ends below its start");
  }
  const bool room = def.family == "room", office = def.family == "office";
  RandomStream size = make_stream(def.seed, "generate/size");
  const double length = def.length_m != 0.0 ? def.length_m
                        : room              ? size.uniform(8.0, 20.0)
                        : office            ? size.uniform(16.0, 30.0)
                                            : size.uniform(20.0, 40.0);
  const double width = def.width_m != 0.0 ? def.width_m
                       : room             ? size.uniform(6.0, 12.0)
                       : office           ? size.uniform(9.0, 14.0)
                                          : size.uniform(2.0, 3.0);
  if (room && std::min(length, width) < 4.0)
    throw InputError("generate: a room needs at least 4 m x 4 m for its drive loop");
  if (office && (length < 8.0 || width < 8.5))
    throw InputError(
        "generate: an office needs at least 8 m x 8.5 m (rooms 3 m deep either side of the "
        "corridor)");
  if (!room && !office && (length < 6.0 || width < 1.5))
    throw InputError("generate: a corridor needs at least 6 m x 1.5 m");
  Layout layout(def, to_mm(length), to_mm(width));
  if (room)
    draw_room(layout);
  else if (office)
    draw_office(layout);
  else
    draw_corridor(layout);
  place_kidnaps(layout);

  std::ostringstream header;
  header << "Generated by `" << generate_command(def) << "` (docs/worlds.md#generated-worlds): "
         << (room     ? "a room"
             : office ? "an office (rooms off a corridor)"
                      : "a corridor")
         << " of " << to_mm(length) << " m x " << to_mm(width) << " m, " << layout.landmarks.size()
         << " landmarks" << (def.landmarks_anywhere ? " standing free" : " along the walls") << ", "
         << layout.obstacles.size() << " obstacles, " << layout.people.size() << " people, "
         << layout.patches.size() << " slippery patches, " << layout.beacons.size() << " beacons, "
         << layout.kidnaps.size() << " kidnaps" << (def.imu ? "" : ", a robot without an IMU")
         << ".";
  for (std::size_t k = 0; k < layout.kidnaps.size(); ++k) {
    const auto& kidnap = layout.kidnaps[k];
    header << "\nKidnap " << k + 1 << " at " << to_mm(kidnap.at_s) << " s lands "
           << (kidnap.landing == "in view" ? "with a landmark in the camera's view"
               : kidnap.landing == "blind" ? "with no landmark within 100 deg of its heading"
                                           : "anywhere free")
           << ".";
  }
  for (const std::string& note : layout.notes) header << "\nNote: " << note << ".";
  GeneratedWorld world{emit(layout, header.str()), layout.notes};
  // The loader is the judge: a generated world it refuses is this generator's bug.
  try {
    parse_world(YamlNode::load_string(world.yaml, "generated world"), ".");
  } catch (const InputError& e) {
    throw std::logic_error(std::string("generate: the drawn world does not load: ") + e.what());
  }
  return world;
}

}  // namespace locsim
