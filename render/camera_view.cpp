#include "render/camera_view.hpp"

#include <GL/gl.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>

namespace locsim::render {

namespace {

constexpr int kCylinderSides = 32;

/// Flat shading by face direction, so that faces meeting at an edge differ and cylinders look
/// round; at most 20 % darker, so a landmark keeps its hue and most of its brightness.
void shaded(const Rgb& c, double nx, double ny) {
  const double light = 0.5 * (1.0 + (0.6 * nx + 0.8 * ny));  // 0..1, light from the north-east
  const auto k = static_cast<float>(0.8 + 0.2 * light);
  glColor3f(c[0] * k, c[1] * k, c[2] * k);
}

/// A vertical prism over a convex (counter-clockwise) or any closed outline, sides and top.
void prism(const std::vector<Vec2>& outline, double height_m, const Rgb& c) {
  const double top = std::isfinite(height_m) ? height_m : kCeilingM;
  glBegin(GL_QUADS);
  for (std::size_t i = 0; i < outline.size(); ++i) {
    const Vec2& a = outline[i];
    const Vec2& b = outline[(i + 1) % outline.size()];
    const Vec2 edge = b - a;
    const double length = edge.norm();
    if (length <= 0.0) continue;
    shaded(c, edge.y() / length, -edge.x() / length);  // outward normal of a CCW outline
    glVertex3d(a.x(), a.y(), 0.0);
    glVertex3d(b.x(), b.y(), 0.0);
    glVertex3d(b.x(), b.y(), top);
    glVertex3d(a.x(), a.y(), top);
  }
  glEnd();
  glColor3f(c[0], c[1], c[2]);
  glBegin(GL_POLYGON);
  for (const Vec2& p : outline) glVertex3d(p.x(), p.y(), top);
  glEnd();
}

std::vector<Vec2> circle_outline(const Vec2& centre, double radius) {
  std::vector<Vec2> out;
  for (int i = 0; i < kCylinderSides; ++i) {
    const double a = 2.0 * std::numbers::pi * i / kCylinderSides;
    out.emplace_back(centre.x() + radius * std::cos(a), centre.y() + radius * std::sin(a));
  }
  return out;
}

std::vector<Vec2> box_outline(const Vec2& centre, const Vec2& size, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  std::vector<Vec2> out;
  for (const auto& [u, v] : {std::pair{0.5, 0.5}, {-0.5, 0.5}, {-0.5, -0.5}, {0.5, -0.5}}) {
    const double x = u * size.x(), y = v * size.y();
    out.emplace_back(centre.x() + c * x - s * y, centre.y() + s * x + c * y);
  }
  return out;
}

std::vector<Vec2> footprint_outline(const FootprintDef& f, const Pose2& pose) {
  switch (f.kind) {
    case FootprintDef::Kind::kCircle:
      return circle_outline(pose.position(), f.radius_m);
    case FootprintDef::Kind::kBox:
      return box_outline(pose.position(), f.size_m, pose.theta);
    case FootprintDef::Kind::kPolygon: {
      std::vector<Vec2> out;
      for (const Vec2& p : f.points_m) out.push_back(pose.transform(p));
      return out;
    }
  }
  return {};
}

Rgb to_float(const locsim::Rgb& c) {
  return {c[0] / 255.0f, c[1] / 255.0f, c[2] / 255.0f};
}

}  // namespace

CameraViewRenderer::CameraViewRenderer(const WorldDef& world, Palette palette)
    : world_(world), palette_(std::move(palette)) {
  static_list_ = glGenLists(1);
  glNewList(static_list_, GL_COMPILE);
  // The floor: far beyond the world, so that the horizon is the floor's edge only far away.
  glColor3f(palette_.floor[0] * 0.85f, palette_.floor[1] * 0.85f, palette_.floor[2] * 0.85f);
  glBegin(GL_QUADS);
  glVertex3d(-1000.0, -1000.0, 0.0);
  glVertex3d(1000.0, -1000.0, 0.0);
  glVertex3d(1000.0, 1000.0, 0.0);
  glVertex3d(-1000.0, 1000.0, 0.0);
  glEnd();
  const Rgb wall = {0.55f, 0.55f, 0.58f};  // lighter than from above: faces need shading room
  for (const WallDef& w : world_.walls) {
    const std::size_t n = w.points_m.size();
    for (std::size_t i = 0; i + 1 < n + (w.closed ? 1 : 0); ++i) {
      const Vec2& a = w.points_m[i];
      const Vec2& b = w.points_m[(i + 1) % n];
      const Vec2 d = b - a;
      const double length = d.norm();
      if (length <= 0.0) continue;
      // A box along the segment, its ends extended by half the thickness to close the corners.
      const Vec2 centre = 0.5 * (a + b);
      prism(box_outline(centre, {length + w.thickness_m, std::max(w.thickness_m, 0.02)},
                        std::atan2(d.y(), d.x())),
            w.height_m, wall);
    }
  }
  for (const BoxDef& b : world_.boxes)
    prism(box_outline(b.center_m, b.size_m, b.angle_rad), b.height_m, wall);
  for (const CircleDef& c : world_.circles)
    prism(circle_outline(c.center_m, c.radius_m), c.height_m, wall);
  for (const PolygonDef& p : world_.polygons) prism(p.points_m, p.height_m, wall);
  if (world_.map) {
    // Occupied cells, merged into runs along each row.
    const OccupancyMapDef& m = *world_.map;
    for (int row = 0; row < m.height_px; ++row) {
      for (int col = 0; col < m.width_px;) {
        if (m.occupied[static_cast<std::size_t>(row) * m.width_px + col] == 0) {
          ++col;
          continue;
        }
        const int start = col;
        while (col < m.width_px &&
               m.occupied[static_cast<std::size_t>(row) * m.width_px + col] != 0) {
          ++col;
        }
        // Row 0 is the image's top: y grows from the bottom row.
        const double x0 = start * m.resolution_m, x1 = col * m.resolution_m;
        const double y0 = (m.height_px - 1 - row) * m.resolution_m, y1 = y0 + m.resolution_m;
        std::vector<Vec2> cell;
        for (const auto& [x, y] : {std::pair{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}})
          cell.push_back(m.origin.transform({x, y}));
        prism(cell, kFullHeight, wall);
      }
    }
  }
  for (const BeaconDef& b : world_.beacons) {
    // A small box on the wall at its height.
    const double z = b.height_m;
    glColor3f(palette_.beacon[0], palette_.beacon[1], palette_.beacon[2]);
    glBegin(GL_QUADS);
    for (int face = 0; face < 4; ++face) {
      const double a0 = face * std::numbers::pi / 2, a1 = a0 + std::numbers::pi / 2;
      const double r = 0.06;
      glVertex3d(b.position_m.x() + r * std::cos(a0), b.position_m.y() + r * std::sin(a0),
                 z - 0.05);
      glVertex3d(b.position_m.x() + r * std::cos(a1), b.position_m.y() + r * std::sin(a1),
                 z - 0.05);
      glVertex3d(b.position_m.x() + r * std::cos(a1), b.position_m.y() + r * std::sin(a1),
                 z + 0.05);
      glVertex3d(b.position_m.x() + r * std::cos(a0), b.position_m.y() + r * std::sin(a0),
                 z + 0.05);
    }
    glEnd();
  }
  for (const LandmarkDef& l : world_.landmarks)
    prism(circle_outline(l.position_m, l.radius_m), l.height_m, to_float(l.color));
  glEndList();
}

void CameraViewRenderer::draw(const CameraShot& shot, const std::vector<ScenePrism>& moving,
                              const std::string& self) const {
  glViewport(0, 0, shot.width_px, shot.height_px);
  glDisable(GL_BLEND);
  glDisable(GL_STENCIL_TEST);
  glDisable(GL_LINE_SMOOTH);
  glDisable(GL_POINT_SMOOTH);
  glDisable(GL_POLYGON_SMOOTH);
  glDisable(GL_CULL_FACE);  // outlines of either winding
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glShadeModel(GL_FLAT);
  // The sky: a pale grey, unsaturated, so that it never passes for a landmark.
  glClearColor(0.86f, 0.88f, 0.90f, 1.0f);
  glClearDepth(1.0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);

  // Pinhole: the near plane's half extents are (w/2, h/2) pixels over the focal length.
  const double near_m = 0.05, far_m = 200.0;
  glMatrixMode(GL_PROJECTION);
  glLoadIdentity();
  const double half_w = near_m * 0.5 * shot.width_px / shot.focal_px;
  const double half_h = near_m * 0.5 * shot.height_px / shot.focal_px;
  glFrustum(-half_w, half_w, -half_h, half_h, near_m, far_m);

  // View: camera x right, y up, looking down -z; the optical axis at yaw theta, pitch tilt.
  const double cy = std::cos(shot.pose.theta), sy = std::sin(shot.pose.theta);
  const double ct = std::cos(shot.tilt_rad), st = std::sin(shot.tilt_rad);
  const Eigen::Vector3d forward(ct * cy, ct * sy, st);
  const Eigen::Vector3d right(sy, -cy, 0.0);
  const Eigen::Vector3d up = right.cross(forward);
  const Eigen::Vector3d eye(shot.pose.x, shot.pose.y, shot.height_m);
  // Column-major: rows of the rotation are right, up, -forward.
  const double view[16] = {
      right.x(), up.x(), -forward.x(), 0.0, right.y(),       up.y(),       -forward.y(),     0.0,
      right.z(), up.z(), -forward.z(), 0.0, -right.dot(eye), -up.dot(eye), forward.dot(eye), 1.0};
  glMatrixMode(GL_MODELVIEW);
  glLoadMatrixd(view);

  glCallList(static_list_);
  for (const ScenePrism& p : moving) {
    if (p.name == self) continue;
    const Rgb c = p.kind == "person" ? palette_.person
                  : p.kind == "cart" ? Rgb{0.6f, 0.45f, 0.3f}
                                     : Rgb{0.35f, 0.35f, 0.38f};
    prism(footprint_outline(p.footprint, p.pose), p.height_m, c);
  }
}

}  // namespace locsim::render
