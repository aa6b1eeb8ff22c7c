#include "render/top_down.hpp"

#include <GL/gl.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <opencv2/imgproc.hpp>

namespace locsim::render {

namespace {

constexpr int kPanelWidthPx = 300;         // legend and errors, right of the map
constexpr int kCameraInsetHeightPx = 150;  // the camera view in the panel, at most
constexpr double kMarginM = 0.3;

void color(const Rgb& c, float alpha = 1.0f) {
  glColor4f(c[0], c[1], c[2], alpha);
}

void vertex(const Vec2& p) {
  glVertex2d(p.x(), p.y());
}

/// A filled disc or its outline.
void circle(const Vec2& center, double radius, bool filled, int segments = 40) {
  glBegin(filled ? GL_TRIANGLE_FAN : GL_LINE_LOOP);
  if (filled) vertex(center);
  for (int i = 0; i <= (filled ? segments : segments - 1); ++i) {
    const double a = 2.0 * std::numbers::pi * i / segments;
    glVertex2d(center.x() + radius * std::cos(a), center.y() + radius * std::sin(a));
  }
  glEnd();
}

/// The 95 % ellipse of a 2D position covariance (nothing when it is not positive semi-definite).
void ellipse_95(const Vec2& center, const Eigen::Matrix2d& covariance) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(covariance);
  if (eig.info() != Eigen::Success || eig.eigenvalues().minCoeff() < 0.0) return;
  const double chi2_95 = 5.991;  // 2 degrees of freedom
  const Eigen::Vector2d axes = (eig.eigenvalues() * chi2_95).cwiseSqrt();
  glBegin(GL_LINE_LOOP);
  for (int i = 0; i < 48; ++i) {
    const double t = 2.0 * std::numbers::pi * i / 48.0;
    const Eigen::Vector2d q =
        eig.eigenvectors() * Eigen::Vector2d(axes(0) * std::cos(t), axes(1) * std::sin(t));
    glVertex2d(center.x() + q.x(), center.y() + q.y());
  }
  glEnd();
}

/// A polygon that may be concave: the stencil counts how often each pixel is covered by the
/// fan's triangles (odd: inside), then one quad fills where the count is odd.
void fill_simple_polygon(const std::vector<Vec2>& points) {
  if (points.size() < 3) return;
  glEnable(GL_STENCIL_TEST);
  glClear(GL_STENCIL_BUFFER_BIT);
  glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
  glStencilFunc(GL_ALWAYS, 0, 1);
  glStencilOp(GL_KEEP, GL_KEEP, GL_INVERT);
  glBegin(GL_TRIANGLE_FAN);
  for (const Vec2& p : points) vertex(p);
  glEnd();
  glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  glStencilFunc(GL_EQUAL, 1, 1);
  glStencilOp(GL_KEEP, GL_KEEP, GL_KEEP);
  double x0 = points[0].x(), x1 = x0, y0 = points[0].y(), y1 = y0;
  for (const Vec2& p : points) {
    x0 = std::min(x0, p.x()), x1 = std::max(x1, p.x()), y0 = std::min(y0, p.y()),
    y1 = std::max(y1, p.y());
  }
  glRectd(x0, y0, x1, y1);
  glDisable(GL_STENCIL_TEST);
}

/// A footprint at a pose, filled or outlined.
void footprint(const FootprintDef& f, const Pose2& pose, bool filled) {
  if (f.kind == FootprintDef::Kind::kCircle) {
    circle(pose.position(), f.radius_m, filled);
    return;
  }
  std::vector<Vec2> corners;
  if (f.kind == FootprintDef::Kind::kBox) {
    const double hx = 0.5 * f.size_m.x(), hy = 0.5 * f.size_m.y();
    corners = {{hx, hy}, {-hx, hy}, {-hx, -hy}, {hx, -hy}};
  } else {
    corners = f.points_m;
  }
  glBegin(filled ? GL_POLYGON : GL_LINE_LOOP);  // convex by the world's rules
  for (const Vec2& c : corners) vertex(pose.transform(c));
  glEnd();
}

/// Friction tint: blue for slippery floors, brown for grippy ones, by the coefficient.
Rgb friction_tint(double friction) {
  const float t = static_cast<float>(std::clamp((friction - 0.1) / 1.1, 0.0, 1.0));
  return {0.55f + 0.3f * t, 0.75f - 0.1f * t, 0.95f - 0.45f * t};
}

cv::Scalar bgr(const Rgb& c) {
  return {c[2] * 255.0, c[1] * 255.0, c[0] * 255.0};
}

View fit_view(const WorldDef& world, int width_px, int height_px) {
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  const auto add = [&](const Vec2& p, double r = 0.0) {
    x0 = std::min(x0, p.x() - r), y0 = std::min(y0, p.y() - r);
    x1 = std::max(x1, p.x() + r), y1 = std::max(y1, p.y() + r);
  };
  for (const WallDef& w : world.walls)
    for (const Vec2& p : w.points_m) add(p, 0.5 * w.thickness_m);
  for (const BoxDef& b : world.boxes) add(b.center_m, 0.5 * b.size_m.norm());
  for (const CircleDef& c : world.circles) add(c.center_m, c.radius_m);
  for (const PolygonDef& p : world.polygons)
    for (const Vec2& v : p.points_m) add(v);
  for (const LandmarkDef& l : world.landmarks) add(l.position_m, l.radius_m);
  for (const BeaconDef& b : world.beacons) add(b.position_m);
  for (const MoverDef& m : world.movers)
    for (const Vec2& p : m.path_m) add(p, 0.5);
  for (const RobotDef& r : world.robots) add(r.start.position(), bounding_radius(r.footprint));
  for (const FloorRegionDef& region : world.floor.regions)
    for (const Vec2& p : region.polygon_m) add(p);
  if (world.map) {
    const auto& m = *world.map;
    add({m.origin.x, m.origin.y});
    add({m.origin.x + m.width_px * m.resolution_m, m.origin.y + m.height_px * m.resolution_m});
  }
  if (x0 > x1) x0 = y0 = -1.0, x1 = y1 = 1.0;  // an empty world
  x0 -= kMarginM, y0 -= kMarginM, x1 += kMarginM, y1 += kMarginM;
  View v;
  v.map_width_px = std::max(1, width_px - (width_px >= 2 * kPanelWidthPx ? kPanelWidthPx : 0));
  v.height_px = height_px;
  v.scale_px_per_m = std::min(v.map_width_px / (x1 - x0), height_px / (y1 - y0));
  // Centre the world in the map area: widen the shorter side.
  const double cx = 0.5 * (x0 + x1), cy = 0.5 * (y0 + y1);
  const double half_w = 0.5 * v.map_width_px / v.scale_px_per_m;
  const double half_h = 0.5 * height_px / v.scale_px_per_m;
  v.x_min = cx - half_w, v.x_max = cx + half_w, v.y_min = cy - half_h, v.y_max = cy + half_h;
  return v;
}

std::string format(const char* pattern, double a, double b = 0.0) {
  char text[96];
  std::snprintf(text, sizeof text, pattern, a, b);
  return text;
}

}  // namespace

TopDownRenderer::TopDownRenderer(const WorldDef& world, int width_px, int height_px,
                                 bool draw_particles)
    : world_(world),
      width_px_(width_px),
      height_px_(height_px),
      draw_particles_(draw_particles),
      view_(fit_view(world, width_px, height_px)) {
  if (world_.map) {
    // The occupancy map as a texture: occupied cells dark, free ones transparent.
    const auto& m = *world_.map;
    std::vector<std::uint8_t> rgba(static_cast<std::size_t>(m.width_px) * m.height_px * 4, 0);
    for (int row = 0; row < m.height_px; ++row) {
      for (int col = 0; col < m.width_px; ++col) {
        // Texture rows from the bottom (GL), the map's from the top.
        const std::size_t src = static_cast<std::size_t>(row) * m.width_px + col;
        const std::size_t dst =
            (static_cast<std::size_t>(m.height_px - 1 - row) * m.width_px + col) * 4;
        if (m.occupied[src] != 0) {
          rgba[dst] = 64, rgba[dst + 1] = 64, rgba[dst + 2] = 69, rgba[dst + 3] = 255;
        }
      }
    }
    glGenTextures(1, &map_texture_);
    glBindTexture(GL_TEXTURE_2D, map_texture_);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA, m.width_px, m.height_px, 0, GL_RGBA, GL_UNSIGNED_BYTE,
                 rgba.data());
  }
}

void TopDownRenderer::remember(const FrameState& frame) {
  truth_.resize(frame.robots.size());
  odometry_.resize(frame.robots.size());
  truth_kidnaps_.resize(frame.robots.size(), 0);
  for (std::size_t i = 0; i < frame.robots.size(); ++i) {
    const FrameRobot& r = frame.robots[i];
    if (r.carried) continue;  // no floor trail while in the air
    // A new segment after each kidnap, carried or instant.
    if (truth_[i].segments.empty() || r.kidnaps != truth_kidnaps_[i]) {
      truth_[i].segments.emplace_back();
    }
    truth_kidnaps_[i] = r.kidnaps;
    truth_[i].segments.back().emplace_back(r.pose.x, r.pose.y);
    if (r.odometry) {
      if (odometry_[i].segments.empty()) odometry_[i].segments.emplace_back();
      odometry_[i].segments.back().emplace_back(r.odometry->x, r.odometry->y);
    }
  }
  estimates_.resize(frame.localizers.size());
  labels_.resize(frame.localizers.size());
  for (std::size_t k = 0; k < frame.localizers.size(); ++k) {
    const FrameLocalizer& l = frame.localizers[k];
    labels_[k] = l.label;
    if (!l.estimate) continue;
    if (estimates_[k].segments.empty()) estimates_[k].segments.emplace_back();
    estimates_[k].segments.back().emplace_back(l.estimate->x, l.estimate->y);
  }
}

void TopDownRenderer::draw_static() {
  const Palette& p = palette_;
  const double px = 1.0 / view_.scale_px_per_m;  // one pixel [m]
  // Floor, friction regions, occupancy map.
  color(p.floor);
  glRectd(view_.x_min, view_.y_min, view_.x_max, view_.y_max);
  for (const FloorRegionDef& region : world_.floor.regions) {
    color(friction_tint(region.friction), 0.55f);
    fill_simple_polygon(region.polygon_m);
  }
  if (world_.map && map_texture_ != 0) {
    const auto& m = *world_.map;
    glEnable(GL_TEXTURE_2D);
    glBindTexture(GL_TEXTURE_2D, map_texture_);
    glColor4f(1, 1, 1, 1);
    const double x0 = m.origin.x, y0 = m.origin.y;
    const double x1 = x0 + m.width_px * m.resolution_m, y1 = y0 + m.height_px * m.resolution_m;
    glBegin(GL_QUADS);
    glTexCoord2d(0, 0), glVertex2d(x0, y0);
    glTexCoord2d(1, 0), glVertex2d(x1, y0);
    glTexCoord2d(1, 1), glVertex2d(x1, y1);
    glTexCoord2d(0, 1), glVertex2d(x0, y1);
    glEnd();
    glDisable(GL_TEXTURE_2D);
  }

  // Static geometry.
  color(p.wall);
  for (const WallDef& w : world_.walls) {
    const std::size_t n = w.points_m.size();
    const double half = 0.5 * std::max(w.thickness_m, 2.0 * px);
    for (std::size_t i = 0; i + 1 < n + (w.closed ? 1 : 0); ++i) {
      const Vec2 a = w.points_m[i], b = w.points_m[(i + 1) % n];
      const Vec2 d = b - a;
      if (d.norm() <= 0.0) continue;
      const Vec2 along = d.normalized() * half, side(-along.y(), along.x());
      glBegin(GL_QUADS);  // the segment with square ends that close the corners
      vertex(a - along + side), vertex(b + along + side), vertex(b + along - side),
          vertex(a - along - side);
      glEnd();
    }
  }
  for (const BoxDef& b : world_.boxes) {
    FootprintDef f;
    f.kind = FootprintDef::Kind::kBox;
    f.size_m = b.size_m;
    footprint(f, {b.center_m.x(), b.center_m.y(), b.angle_rad}, true);
  }
  for (const CircleDef& c : world_.circles) circle(c.center_m, c.radius_m, true);
  for (const PolygonDef& poly : world_.polygons) {
    glBegin(GL_POLYGON);
    for (const Vec2& v : poly.points_m) vertex(v);
    glEnd();
  }
}

void TopDownRenderer::paint_trails() {
  // Estimates in their colours, then the odometry dashed grey, then the truth solid black, so
  // that the truth's newest piece lies on top.
  for (std::size_t k = 0; k < estimates_.size(); ++k)
    paint(estimates_[k], palette_.filter(k), 1, false);
  for (Trail& t : odometry_) paint(t, palette_.odometry, 1, true);
  for (Trail& t : truth_) paint(t, palette_.truth, 2, false);
}

void TopDownRenderer::paint(Trail& trail, const Rgb& colour, int thickness_px, bool dashed) {
  // A trail grows by a piece of about a pixel a frame and never changes behind: its pieces are
  // painted once onto the kept image, with OpenCV's anti-aliased lines. Drawing the whole paths
  // again every frame with GL cost 14 % of a demo run's CPU by its end (5 paths, 9000 pieces).
  constexpr int kShift = 4;                                               // sixteenths of a pixel
  constexpr double kDashPx = 8.0;                                         // dash and gap
  cv::Mat map = trails_(cv::Rect(0, 0, view_.map_width_px, height_px_));  // clips to the map
  const auto fixed = [&](const cv::Point2d& world) {
    // OpenCV's pixel centres are at whole coordinates, the view's half a pixel in.
    const cv::Point2d at = view_.to_pixel(world.x, world.y) - cv::Point2d(0.5, 0.5);
    return cv::Point(static_cast<int>(std::lround(at.x * (1 << kShift))),
                     static_cast<int>(std::lround(at.y * (1 << kShift))));
  };
  const cv::Scalar line_colour = bgr(colour);
  const auto piece = [&](const cv::Point2d& a, const cv::Point2d& b) {
    if (!dashed) {
      cv::line(map, fixed(a), fixed(b), line_colour, thickness_px, cv::LINE_AA, kShift);
      return;
    }
    // Dashes along the path's length, continued from piece to piece.
    const double length_px = cv::norm(b - a) * view_.scale_px_per_m;
    double s = 0.0;
    while (s < length_px) {
      const double at = trail.painted_px + s;
      const double phase = std::fmod(at, 2.0 * kDashPx);
      const double run =
          std::min((phase < kDashPx ? kDashPx : 2.0 * kDashPx) - phase, length_px - s);
      if (phase < kDashPx) {
        cv::line(map, fixed(a + (b - a) * (s / length_px)),
                 fixed(a + (b - a) * ((s + run) / length_px)), line_colour, thickness_px,
                 cv::LINE_AA, kShift);
      }
      s += run;
    }
    trail.painted_px += length_px;
  };
  while (trail.painted_segment < trail.segments.size()) {
    const std::vector<cv::Point2d>& segment = trail.segments[trail.painted_segment];
    for (; trail.painted_point + 1 < segment.size(); ++trail.painted_point)
      piece(segment[trail.painted_point], segment[trail.painted_point + 1]);
    if (trail.painted_segment + 1 == trail.segments.size()) break;
    ++trail.painted_segment;
    trail.painted_point = 0;
  }
}

void TopDownRenderer::draw(const FrameState& frame) {
  remember(frame);
  const Palette& p = palette_;
  glViewport(0, 0, width_px_, height_px_);
  glClearStencil(0);
  glDisable(GL_DEPTH_TEST);
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  glEnable(GL_LINE_SMOOTH);
  glHint(GL_LINE_SMOOTH_HINT, GL_NICEST);
  // The map area is the left part of the image; GL's y is up like the world's.
  glViewport(0, 0, view_.map_width_px, height_px_);
  glMatrixMode(GL_PROJECTION);
  glLoadIdentity();
  glOrtho(view_.x_min, view_.x_max, view_.y_min, view_.y_max, -1.0, 1.0);
  glMatrixMode(GL_MODELVIEW);
  glLoadIdentity();
  const double px = 1.0 / view_.scale_px_per_m;  // one pixel [m]

  // The static world (floor, friction regions, map, walls, obstacles) is drawn once and kept as an
  // image; each frame draws only what moves, onto a transparent layer that compose() lays over
  // it. Drawing the static world, or even copying it as a texture, costs llvmpipe a third of a
  // frame; the compositing costs a fraction of that, on the CPU, in the same pass as the
  // read-back conversion.
  if (background_.empty()) {
    glClearColor(p.background[0], p.background[1], p.background[2], 1.0f);
    glClear(GL_COLOR_BUFFER_BIT | GL_STENCIL_BUFFER_BIT);
    draw_static();
    glFinish();
    cv::Mat rgba(height_px_, width_px_, CV_8UC4);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, width_px_, height_px_, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data);
    cv::flip(rgba, rgba, 0);  // GL reads rows from the bottom
    cv::cvtColor(rgba, background_, cv::COLOR_RGBA2BGR);
    trails_ = background_.clone();
  }
  paint_trails();
  glClearColor(0.0f, 0.0f, 0.0f, 0.0f);
  glClear(GL_COLOR_BUFFER_BIT);
  // Premultiplied alpha: colour = src * a + dst * (1 - a), alpha = a + dst alpha * (1 - a).
  glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);

  // Sensor visuals under everything that moves.
  for (const FrameRobot& r : frame.robots) {
    if (r.carried) continue;
    if (r.camera) {
      const auto& c = *r.camera;
      const double reach = std::min(c.max_range_m, 0.2 * (view_.x_max - view_.x_min));
      color(p.camera, 0.18f);
      glBegin(GL_TRIANGLE_FAN);
      glVertex2d(c.optical_axis.x, c.optical_axis.y);
      for (int i = 0; i <= 24; ++i) {
        const double a = c.optical_axis.theta - 0.5 * c.hfov_rad + c.hfov_rad * i / 24.0;
        glVertex2d(c.optical_axis.x + reach * std::cos(a), c.optical_axis.y + reach * std::sin(a));
      }
      glEnd();
      color(p.camera, 0.9f);
      glLineWidth(1.5f);
      glBegin(GL_LINES);
      for (const Vec2& d : c.detections_m) glVertex2d(r.pose.x, r.pose.y), vertex(d);
      glEnd();
    }
    if (!r.sightings.empty()) {
      // Range-bearing detections as the cameras': a line to where each puts its target, robots
      // in a colour of their own.
      glLineWidth(1.5f);
      glBegin(GL_LINES);
      for (const FrameRobot::Sighting& s : r.sightings) {
        color(s.robot ? p.robot_sighting : p.sighting, 0.9f);
        glVertex2d(r.pose.x, r.pose.y), vertex(s.at_m);
      }
      glEnd();
    }
    if (!r.laser_hits_m.empty()) {
      // Where the beams hit, and every sixth ray, faint, so the scan reads as a laser's (all the
      // rays, or a filled scan, cost llvmpipe a quarter of a frame).
      color(p.laser, 0.22f);
      glLineWidth(1.0f);
      glBegin(GL_LINES);
      for (std::size_t i = 0; i < r.laser_hits_m.size(); i += 6)
        vertex(r.laser_origin_m), vertex(r.laser_hits_m[i]);
      glEnd();
      color(p.laser, 0.9f);
      glPointSize(3.0f);
      glBegin(GL_POINTS);
      for (const Vec2& h : r.laser_hits_m) vertex(h);
      glEnd();
    }
    glLineWidth(1.5f);
    glBegin(GL_LINES);
    for (const auto& u : r.ultrasonic) {
      color(u.line_of_sight ? p.line_of_sight : p.occluded, u.line_of_sight ? 0.5f : 0.9f);
      vertex(u.receiver_m), vertex(u.beacon_m);
    }
    glEnd();
  }

  // Landmarks and beacons.
  for (const LandmarkDef& l : world_.landmarks) {
    const double r = std::max(l.radius_m, 5.0 * px);
    glColor4f(l.color[0] / 255.0f, l.color[1] / 255.0f, l.color[2] / 255.0f, 1.0f);
    circle(l.position_m, r, true);
    glLineWidth(1.5f);
    color({0, 0, 0});
    circle(l.position_m, r, false);
  }
  for (const BeaconDef& b : world_.beacons) {
    const double h = 6.0 * px;
    color(p.beacon);
    glRectd(b.position_m.x() - h, b.position_m.y() - h, b.position_m.x() + h, b.position_m.y() + h);
  }
  // People and carts.
  for (const FrameMover& m : frame.movers) {
    color(p.person, 0.9f);
    footprint(m.footprint, m.pose, true);
    color({0.4f, 0.25f, 0.1f});
    glLineWidth(1.5f);
    footprint(m.footprint, m.pose, false);
  }

  // Kidnaps: a cross where the robot was picked up, a dashed line to where it landed.
  for (const KidnapMark& k : frame.kidnaps) {
    const double s = 8.0 * px;
    color(p.kidnap);
    glLineWidth(3.0f);
    glBegin(GL_LINES);
    glVertex2d(k.from.x - s, k.from.y - s), glVertex2d(k.from.x + s, k.from.y + s);
    glVertex2d(k.from.x - s, k.from.y + s), glVertex2d(k.from.x + s, k.from.y - s);
    glEnd();
    if (k.landed) {
      glLineWidth(2.0f);
      glEnable(GL_LINE_STIPPLE);
      glLineStipple(3, 0x00FF);
      glBegin(GL_LINES);
      glVertex2d(k.from.x, k.from.y), glVertex2d(k.to.x, k.to.y);
      glEnd();
      glDisable(GL_LINE_STIPPLE);
      circle(k.to.position(), s, false);
    }
  }

  // Particles are splatted on the CPU in compose(): llvmpipe spends 0.3 us on each point.

  // The robots' true footprints (a ghost while carried), heading ticks.
  for (const FrameRobot& r : frame.robots) {
    const float a = r.carried ? 0.35f : 1.0f;
    glColor4f(1.0f, 1.0f, 1.0f, 0.6f * a);
    footprint(r.footprint, r.pose, true);
    color(p.truth, a);
    glLineWidth(2.0f);
    footprint(r.footprint, r.pose, false);
    glBegin(GL_LINES);
    glVertex2d(r.pose.x, r.pose.y);
    vertex(r.pose.transform({bounding_radius(r.footprint), 0.0}));
    glEnd();
  }

  // Estimates: an arrow and the 95 % position ellipse.
  for (std::size_t k = 0; k < frame.localizers.size(); ++k) {
    const FrameLocalizer& l = frame.localizers[k];
    if (!l.estimate) continue;
    const Rgb c = p.filter(k);
    const Pose2& e = *l.estimate;
    const double len = 18.0 * px, wid = 7.0 * px;
    color(c);
    glBegin(GL_TRIANGLES);
    vertex(e.transform({len, 0.0})), vertex(e.transform({-0.4 * len, wid})),
        vertex(e.transform({-0.4 * len, -wid}));
    glEnd();
    color({0, 0, 0}, 0.8f);
    glLineWidth(1.0f);
    glBegin(GL_LINE_LOOP);
    vertex(e.transform({len, 0.0})), vertex(e.transform({-0.4 * len, wid})),
        vertex(e.transform({-0.4 * len, -wid}));
    glEnd();
    color(c, 0.95f);
    glLineWidth(2.0f);
    ellipse_95(e.position(), l.covariance.topLeftCorner<2, 2>());
  }
  // SLAM filters' landmark maps: a cross in the filter's colour at each mapped landmark, with its
  // 95 % ellipse.
  for (std::size_t k = 0; k < frame.localizers.size(); ++k) {
    const Rgb c = p.filter(k);
    const double s = 5.0 * px;
    for (const FrameLocalizer::MappedLandmark& m : frame.localizers[k].landmark_map) {
      const Vec2& q = m.position_m;
      color(c);
      glLineWidth(2.0f);
      glBegin(GL_LINES);
      glVertex2d(q.x() - s, q.y() - s), glVertex2d(q.x() + s, q.y() + s);
      glVertex2d(q.x() - s, q.y() + s), glVertex2d(q.x() + s, q.y() - s);
      glEnd();
      color(c, 0.8f);
      glLineWidth(1.0f);
      ellipse_95(q, m.covariance);
    }
  }
  glLineWidth(1.0f);
}

void TopDownRenderer::compose(const FrameState& frame, const std::uint8_t* rgba,
                              cv::Mat& bgr) const {
  trails_.copyTo(bgr);
  // The particle clouds on the static world and the trails, under the drawn layer: a dot of 2 x 2
  // pixels (3 x 3 when zoomed in), the filter's colour, opacity by weight.
  if (draw_particles_) {
    const int dot = view_.scale_px_per_m > 120.0 ? 3 : 2;
    for (std::size_t k = 0; k < frame.localizers.size(); ++k) {
      const FrameLocalizer& l = frame.localizers[k];
      const Rgb c = palette_.filter(k);
      const float color_bgr[3] = {c[2] * 255.0f, c[1] * 255.0f, c[0] * 255.0f};
      double top = 0.0;
      for (const double w : l.weights) top = std::max(top, w);
      const bool weighted = l.weights.size() == l.particles.size() && top > 0.0;
      for (std::size_t i = 0; i < l.particles.size(); ++i) {
        const cv::Point2d at = view_.to_pixel(l.particles[i].x, l.particles[i].y);
        const int x0 = static_cast<int>(std::floor(at.x)) - dot / 2;
        const int y0 = static_cast<int>(std::floor(at.y)) - dot / 2;
        if (x0 < 0 || y0 < 0 || x0 + dot > view_.map_width_px || y0 + dot > height_px_) continue;
        const float alpha = weighted ? static_cast<float>(0.2 + 0.7 * l.weights[i] / top) : 0.5f;
        for (int y = y0; y < y0 + dot; ++y) {
          std::uint8_t* row = bgr.ptr<std::uint8_t>(y) + 3 * x0;
          for (int j = 0; j < 3 * dot; ++j) {
            // Rounded by + 0.5: the blend of two bytes is never negative.
            row[j] = static_cast<std::uint8_t>(
                row[j] + alpha * (color_bgr[j % 3] - static_cast<float>(row[j])) + 0.5f);
          }
        }
      }
    }
  }
  // Most of the drawn layer is empty (moving things cover little of the world, the side panel
  // none of it): empty pixels are skipped sixteen at a time.
  constexpr int kRun = 16;  // pixels, 64 bytes of the layer: one cache line
  const auto empty_run = [](const std::uint8_t* layer) {
    std::uint64_t any = 0;
    for (int k = 0; k < kRun / 2; ++k) {
      std::uint64_t two_pixels = 0;
      std::memcpy(&two_pixels, layer + 8 * k, sizeof two_pixels);
      any |= two_pixels;
    }
    return any == 0;
  };
  for (int y = 0; y < height_px_; ++y) {
    const std::uint8_t* layer = rgba + static_cast<std::size_t>(y) * width_px_ * 4;
    std::uint8_t* out = bgr.ptr<std::uint8_t>(y);
    for (int x = 0; x < width_px_; ++x) {
      if (x % kRun == 0 && x + kRun <= width_px_ && empty_run(layer + 4 * x)) {
        x += kRun - 1;
        continue;
      }
      const std::uint8_t* in = layer + 4 * x;
      if (in[3] == 0 && in[0] == 0 && in[1] == 0 && in[2] == 0) continue;
      // out = layer (premultiplied) + under * (1 - alpha), rounded; RGBA to BGR.
      const unsigned keep = 255u - in[3];
      for (int c = 0; c < 3; ++c) {
        const unsigned v = in[2 - c] + (out[3 * x + c] * keep + 127u) / 255u;
        out[3 * x + c] = static_cast<std::uint8_t>(v > 255u ? 255u : v);
      }
    }
  }
}

TopDownRenderer::Panel TopDownRenderer::overlay(const FrameState& frame, cv::Mat& image,
                                                bool camera_view) const {
  const Palette& p = palette_;
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  const auto text = [&](const std::string& s, cv::Point at, double size, const cv::Scalar& c,
                        int thickness = 1) {
    cv::putText(image, s, at, font, size, c, thickness, cv::LINE_AA);
  };
  const cv::Scalar black(0, 0, 0), grey(90, 90, 90);
  const bool panel = view_.map_width_px < image.cols;
  // Simulated time: in the panel, else over the map's top left corner.
  if (!panel) text(format("t = %.1f s", frame.t_s), {12, 32}, 0.8, black, 2);
  // Scale bar: 1 m (or 10 cm, 10 m, whatever fits in about 120 px).
  double bar_m = 1.0;
  while (bar_m * view_.scale_px_per_m > 200.0) bar_m /= 10.0;
  while (bar_m * view_.scale_px_per_m < 40.0) bar_m *= 10.0;
  const int bar_px = static_cast<int>(std::lround(bar_m * view_.scale_px_per_m));
  const cv::Point bar0(12, view_.height_px - 16);
  cv::line(image, bar0, bar0 + cv::Point(bar_px, 0), black, 2);
  cv::line(image, bar0 - cv::Point(0, 5), bar0 + cv::Point(0, 5), black, 2);
  cv::line(image, bar0 + cv::Point(bar_px, -5), bar0 + cv::Point(bar_px, 5), black, 2);
  text(bar_m >= 1.0 ? format("%.0f m", bar_m) : format("%.0f cm", bar_m * 100.0),
       bar0 + cv::Point(bar_px + 8, 5), 0.5, black);
  // Kidnap labels.
  for (const KidnapMark& k : frame.kidnaps) {
    const cv::Point2d at = view_.to_pixel(k.from.x, k.from.y);
    text(format("kidnap %.0f s", k.t_s),
         cv::Point(static_cast<int>(at.x) + 10, static_cast<int>(at.y) - 10), 0.45, bgr(p.kidnap),
         1);
  }

  // The side panel: legend and each filter's error now.
  Panel out;
  if (!panel) return out;
  const int x = view_.map_width_px + 16;
  int y = 34;
  text(world_.name, {x, y}, 0.6, grey, 1);
  y += 34;
  text(format("t = %.1f s", frame.t_s), {x, y}, 0.8, black, 2);
  y += 38;
  const auto swatch_line = [&](const Rgb& c, bool dashed) {
    if (!dashed) {
      cv::line(image, {x, y - 5}, {x + 26, y - 5}, bgr(c), 3, cv::LINE_AA);
    } else {
      for (int s = 0; s < 26; s += 9)
        cv::line(image, {x + s, y - 5}, {x + s + 5, y - 5}, bgr(c), 3);
    }
  };
  swatch_line(p.truth, false);
  text("truth", {x + 36, y}, 0.55, black);
  y += 26;
  if (!odometry_.empty() && !odometry_[0].segments.empty()) {
    swatch_line(p.odometry, true);
    text("wheel odometry", {x + 36, y}, 0.55, black);
    y += 26;
  }
  y += 8;
  for (std::size_t k = 0; k < frame.localizers.size(); ++k) {
    const FrameLocalizer& l = frame.localizers[k];
    cv::rectangle(image, {x, y - 14}, {x + 26, y + 2}, bgr(p.filter(k)), cv::FILLED);
    text(l.label, {x + 36, y}, 0.6, black, 1);
    y += 22;
    std::string status;
    if (l.failed) {
      status = "failed";
    } else if (!l.estimate) {
      status = "no estimate";
    } else if (std::isnan(l.position_error_m)) {
      status = "(robot carried)";
    } else {
      status = format("error %.3f m  %.1f deg", l.position_error_m,
                      l.heading_error_rad * 180.0 / std::numbers::pi);
    }
    text(status, {x + 36, y}, 0.5, l.failed ? bgr(p.kidnap) : grey);
    y += 30;
  }
  // What the robot sees comes before the key to the map's symbols: at most kCameraInsetHeightPx
  // high, so that with the main job's three filters most of the key still fits under it.
  if (camera_view && !frame.robots.empty() && frame.robots[0].camera) {
    const CameraShot& shot = frame.robots[0].camera->shot;
    const int shot_w = static_cast<int>(shot.width_px), shot_h = static_cast<int>(shot.height_px);
    const int width = std::min(
        {image.cols - x - 16, 3 * shot_w / 2, kCameraInsetHeightPx * shot_w / std::max(shot_h, 1)});
    const int height = width * shot_h / std::max(shot_w, 1);
    const int top = y + 14;  // its caption's line above it
    if (width >= 64 && top + height + 8 <= image.rows) {
      out.camera = cv::Rect(x, top, width, height);
      y = top + height + 30;
    }
  }
  y += 6;
  const auto marker = [&](const std::string& label, auto draw) {
    if (y + 6 > image.rows) return;  // no room left in the panel
    draw(cv::Point(x + 13, y - 5));
    text(label, {x + 36, y}, 0.5, grey);
    y += 24;
  };
  if (!world_.landmarks.empty()) {
    marker("landmark", [&](cv::Point c) {
      const auto& l = world_.landmarks.front();
      cv::circle(image, c, 7, cv::Scalar(l.color[2], l.color[1], l.color[0]), cv::FILLED,
                 cv::LINE_AA);
      cv::circle(image, c, 7, black, 1, cv::LINE_AA);
    });
  }
  if (!world_.beacons.empty()) {
    marker("ultrasonic beacon", [&](cv::Point c) {
      cv::rectangle(image, c - cv::Point(6, 6), c + cv::Point(6, 6), bgr(p.beacon), cv::FILLED);
    });
  }
  if (!frame.movers.empty()) {
    marker("person",
           [&](cv::Point c) { cv::circle(image, c, 7, bgr(p.person), cv::FILLED, cv::LINE_AA); });
  }
  if (!frame.kidnaps.empty()) {
    marker("kidnap: picked up, landed", [&](cv::Point c) {
      cv::line(image, c - cv::Point(6, 6), c + cv::Point(6, 6), bgr(p.kidnap), 2);
      cv::line(image, c + cv::Point(-6, 6), c + cv::Point(6, -6), bgr(p.kidnap), 2);
    });
  }
  bool camera = false, laser = false, ultrasonic = false, sightings = false;
  for (const FrameRobot& r : frame.robots) {
    camera = camera || r.camera.has_value();
    sightings = sightings || r.range_bearing;
    laser = laser || !r.laser_hits_m.empty();
    ultrasonic = ultrasonic || !r.ultrasonic.empty();
  }
  if (laser) {
    marker("laser rays and hits", [&](cv::Point c) {
      cv::line(image, c + cv::Point(-12, 4), c + cv::Point(8, -4), bgr({0.95f, 0.75f, 0.75f}), 1);
      for (int i = -8; i <= 8; i += 5)
        cv::circle(image, c + cv::Point(i, 0), 2, bgr(p.laser), cv::FILLED);
    });
  }
  if (ultrasonic) {
    marker("ultrasound: clear, occluded", [&](cv::Point c) {
      cv::line(image, c + cv::Point(-12, -3), c + cv::Point(12, -3), bgr(p.line_of_sight), 2);
      cv::line(image, c + cv::Point(-12, 3), c + cv::Point(12, 3), bgr(p.occluded), 2);
    });
  }
  if (camera) {
    marker("camera view, detections", [&](cv::Point c) {
      cv::rectangle(image, c - cv::Point(10, 6), c + cv::Point(10, 6), bgr(p.camera), cv::FILLED);
    });
  }
  if (sightings) {
    marker("ranged: landmark, robot", [&](cv::Point c) {
      cv::line(image, c + cv::Point(-12, -3), c + cv::Point(12, -3), bgr(p.sighting), 2);
      cv::line(image, c + cv::Point(-12, 3), c + cv::Point(12, 3), bgr(p.robot_sighting), 2);
    });
  }
  bool mapped = false;
  for (const FrameLocalizer& l : frame.localizers) mapped = mapped || !l.landmark_map.empty();
  if (mapped) {
    marker("SLAM map, 95 % ellipse", [&](cv::Point c) {
      cv::line(image, c - cv::Point(5, 5), c + cv::Point(5, 5), grey, 2, cv::LINE_AA);
      cv::line(image, c + cv::Point(-5, 5), c + cv::Point(5, -5), grey, 2, cv::LINE_AA);
      cv::ellipse(image, c, {10, 7}, 0, 0, 360, grey, 1, cv::LINE_AA);
    });
  }
  if (draw_particles_) {
    bool any = false;
    for (const FrameLocalizer& l : frame.localizers) any = any || !l.particles.empty();
    if (any)
      marker("particles (opacity: weight)", [&](cv::Point c) {
        for (int i = -8; i <= 8; i += 4)
          cv::circle(image, c + cv::Point(i, (i * 7) % 5), 1, grey, cv::FILLED);
      });
    bool ellipse = false;
    for (const FrameLocalizer& l : frame.localizers) ellipse = ellipse || l.estimate.has_value();
    if (ellipse)
      marker("estimate, 95 % ellipse", [&](cv::Point c) {
        cv::ellipse(image, c, {11, 6}, 0, 0, 360, grey, 1, cv::LINE_AA);
      });
  }
  return out;
}

void TopDownRenderer::inset_camera(const FrameState& frame, const cv::Mat& camera_bgr,
                                   const cv::Rect& place, cv::Mat& image) const {
  if (frame.robots.empty() || !frame.robots[0].camera || camera_bgr.empty()) return;
  const FrameRobot::Camera& camera = *frame.robots[0].camera;
  const int x = place.x, top = place.y, width = place.width, height = place.height;
  cv::Mat scaled;
  cv::resize(camera_bgr, scaled, {width, height}, 0, 0, cv::INTER_NEAREST);
  scaled.copyTo(image(cv::Rect(x, top, width, height)));
  cv::rectangle(image, {x - 1, top - 1}, {x + width, top + height}, cv::Scalar(60, 60, 60), 1);
  const double pan_deg =
      rad_to_deg(wrap_angle(camera.optical_axis.theta - frame.robots[0].pose.theta));
  cv::putText(image,
              format("camera %.0fx%.0f", camera.shot.width_px, camera.shot.height_px) +
                  format(", pan %+.0f deg", pan_deg),
              {x, top - 8}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(90, 90, 90), 1, cv::LINE_AA);
  // Each detection's bearing as a tick above the picture, in the camera's colour.
  const double scale = static_cast<double>(width) / camera.shot.width_px;
  for (const Vec2& d : camera.detections_m) {
    const Vec2 offset = d - camera.optical_axis.position();
    const double bearing =
        wrap_angle(std::atan2(offset.y(), offset.x()) - camera.optical_axis.theta);
    if (std::abs(bearing) >= 0.5 * std::numbers::pi) continue;
    const double u = 0.5 * camera.shot.width_px - camera.shot.focal_px * std::tan(bearing);
    if (u < 0.0 || u > camera.shot.width_px) continue;
    const int px = x + static_cast<int>(std::lround(u * scale));
    cv::line(image, {px, top + 1}, {px, top + 12}, bgr(palette_.camera), 3);
  }
}

}  // namespace locsim::render
