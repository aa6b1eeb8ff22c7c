#include "sim/consumers/config_json.hpp"

#include "sim/world/variation.hpp"

namespace locsim {

using json = nlohmann::ordered_json;

namespace {
json point(const Vec2& p) {
  return json::array({p.x(), p.y()});
}
json points(const std::vector<Vec2>& ps) {
  json out = json::array();
  for (const Vec2& p : ps) out.push_back(point(p));
  return out;
}
/// Heights: "full" for floor-to-ceiling (JSON has no infinity).
json height(double h) {
  return h == kFullHeight ? json("full") : json(h);
}
json pose(const Pose2& p) {
  return json{{"x", p.x}, {"y", p.y}, {"theta", p.theta}};
}
json footprint(const FootprintDef& f) {
  switch (f.kind) {
    case FootprintDef::Kind::kCircle:
      return json{{"radius_m", f.radius_m}};
    case FootprintDef::Kind::kBox:
      return json{{"box_m", point(f.size_m)}};
    case FootprintDef::Kind::kPolygon:
      return json{{"polygon", points(f.points_m)}};
  }
  return json{};
}
json common(const SensorCommon& c) {
  json out{{"enabled", c.enabled}, {"rate_hz", c.rate_hz}, {"mount", pose(c.mount)}};
  if (c.believed_mount) out["believed_mount"] = pose(*c.believed_mount);
  if (c.outage_fraction > 0.0) {  // listed when set: the files of runs without stay as they were
    out["outage_fraction"] = c.outage_fraction;
    out["outage_mean_s"] = c.outage_mean_s;
    if (c.outage_long_share > 0.0) {
      out["outage_long_share"] = c.outage_long_share;
      out["outage_long_mean_s"] = c.outage_long_mean_s;
    }
  }
  return out;
}
json sensors(const SensorsDef& s) {
  json out = json::object();
  if (s.encoders) {
    const EncodersDef& d = *s.encoders;
    out["encoders"] = common(d.common);
    out["encoders"].update(
        {{"ticks_per_rev", d.ticks_per_rev}, {"k_left", d.k_left}, {"k_right", d.k_right}});
    if (d.k_correlation != 0.0) out["encoders"]["k_correlation"] = d.k_correlation;
    if (d.odometry_wheel_base_m)
      out["encoders"]["odometry_wheel_base_m"] = *d.odometry_wheel_base_m;
    json reports = json::array();
    for (const OdometryField field : kOdometryFields) {
      if ((d.reports & field) != 0) reports.push_back(odometry_field_name(field));
    }
    out["encoders"]["reports"] = reports;
    // Only when not the default, so that a world that does not use it writes what it wrote.
    if (d.measures == EncodersDef::Measures::kCommand) out["encoders"]["measures"] = "command";
    if (d.heading == EncodersDef::Heading::kGyro) {
      out["encoders"].update({{"heading", "gyro"},
                              {"gyro_bias_radps", d.gyro_bias_radps},
                              {"gyro_bias_sigma", d.gyro_bias_sigma},
                              {"gyro_noise_density", d.gyro_noise_density},
                              {"gyro_scale_error", d.gyro_scale_error}});
    }
  }
  if (s.imu) {
    const ImuDef& d = *s.imu;
    out["imu"] = common(d.common);
    out["imu"].update({{"gyro_noise_density", d.gyro_noise_density},
                       {"gyro_bias_sigma", d.gyro_bias_sigma},
                       {"gyro_bias_random_walk", d.gyro_bias_random_walk},
                       {"gyro_range", d.gyro_range},
                       {"accel_noise_density", d.accel_noise_density},
                       {"accel_bias_sigma", d.accel_bias_sigma},
                       {"accel_bias_random_walk", d.accel_bias_random_walk},
                       {"accel_range", d.accel_range}});
  }
  if (s.ptz_camera) {
    const PtzCameraDef& d = *s.ptz_camera;
    out["ptz_camera"] = common(d.common);
    out["ptz_camera"].update(
        {{"height_m", d.height_m},
         {"width_px", d.width_px},
         {"height_px", d.height_px},
         {"hfov", d.hfov_rad},
         {"zoom_max", d.zoom_max},
         {"pan_min", d.pan_min_rad},
         {"pan_max", d.pan_max_rad},
         {"max_pan_rate", d.max_pan_rate_radps},
         {"tilt", d.tilt_rad},
         {"zoom", d.zoom},
         {"min_range_m", d.min_range_m},
         {"max_range_m", d.max_range_m},
         {"pixel_noise_px", d.pixel_noise_px},
         {"min_blob_px", d.min_blob_px},
         {"miss_probability", d.miss_probability},
         {"false_detections_per_frame", d.false_detections_per_frame},
         {"report_ids", d.report_ids},
         {"mode", d.mode == PtzCameraDef::Mode::kRendered ? "rendered" : "analytic"}});
  }
  if (s.omni_camera) {
    const OmniCameraDef& d = *s.omni_camera;
    out["omni_camera"] = common(d.common);
    out["omni_camera"].update({{"max_range_m", d.max_range_m},
                               {"sigma_major_m", d.sigma_major_m},
                               {"sigma_minor_m", d.sigma_minor_m},
                               {"sigma_major_per_m", d.sigma_major_per_m},
                               {"report_ids", d.report_ids}});
  }
  if (s.ultrasonic) {
    const UltrasonicDef& d = *s.ultrasonic;
    json receivers = json::array();
    for (const auto& r : d.receivers)
      receivers.push_back({{"position", point(r.position_m)}, {"height_m", r.height_m}});
    out["ultrasonic"] = common(d.common);
    out["ultrasonic"].update({{"receivers", receivers},
                              {"sigma_m", d.sigma_m},
                              {"max_range_m", d.max_range_m},
                              {"dropout_probability", d.dropout_probability},
                              {"nlos_probability", d.nlos_probability},
                              {"nlos_bias_min_m", d.nlos_bias_min_m},
                              {"nlos_bias_mean_m", d.nlos_bias_mean_m}});
  }
  if (s.laser) {
    const LaserDef& d = *s.laser;
    out["laser"] = common(d.common);
    out["laser"].update({{"fov", d.fov_rad},
                         {"beams", d.beams},
                         {"min_range_m", d.min_range_m},
                         {"max_range_m", d.max_range_m},
                         {"sigma_m", d.sigma_m},
                         {"p_short", d.p_short},
                         {"lambda_short", d.lambda_short},
                         {"p_max", d.p_max},
                         {"p_random", d.p_random}});
  }
  if (s.range_bearing) {
    const RangeBearingDef& d = *s.range_bearing;
    out["range_bearing"] = common(d.common);
    out["range_bearing"].update({{"fov", d.fov_rad},
                                 {"min_range_m", d.min_range_m},
                                 {"max_range_m", d.max_range_m},
                                 {"sigma_range_m", d.sigma_range_m},
                                 {"sigma_range_per_m", d.sigma_range_per_m},
                                 {"range_bias_m", d.range_bias_m},
                                 {"range_bias_per_m", d.range_bias_per_m},
                                 {"sigma_bearing", d.sigma_bearing_rad},
                                 {"bearing_bias", d.bearing_bias_rad},
                                 {"miss_probability", d.miss_probability},
                                 {"false_detections", d.false_detections},
                                 {"noise_correlation_s", d.noise_correlation_s},
                                 {"report_ids", d.report_ids},
                                 {"sees_robots", d.sees_robots}});
    // Only when not the default, so that a world that does not use it writes what it wrote.
    if (d.range_model == RangeBearingDef::RangeModel::kDepth)
      out["range_bearing"]["range_model"] = "depth";
    if (d.noise_correlation_slow_share > 0.0) {
      out["range_bearing"]["noise_correlation_slow_s"] = d.noise_correlation_slow_s;
      out["range_bearing"]["noise_correlation_slow_share"] = d.noise_correlation_slow_share;
    }
    if (const auto& b = d.bearing_correlation) {
      out["range_bearing"]["bearing_noise_correlation_s"] = b->fast_s;
      out["range_bearing"]["bearing_noise_correlation_slow_s"] = b->slow_s;
      out["range_bearing"]["bearing_noise_correlation_slow_share"] = b->slow_share;
    }
  }
  return out;
}

const char* mode_name(DriveDef::Mode mode) {
  switch (mode) {
    case DriveDef::Mode::kIdle:
      return "idle";
    case DriveDef::Mode::kWaypoints:
      return "waypoints";
    case DriveDef::Mode::kVelocity:
      return "velocity";
    case DriveDef::Mode::kWander:
      return "wander";
    case DriveDef::Mode::kTrajectory:
      return "trajectory";
  }
  return "?";
}
}  // namespace

json to_json(const WorldDef& w) {
  json out;
  out["name"] = w.name;
  out["source"] = w.source.string();
  out["physics"] = {{"step_hz", w.physics.step_hz},
                    {"velocity_iterations", w.physics.velocity_iterations},
                    {"position_iterations", w.physics.position_iterations},
                    {"gravity_mps2", w.physics.gravity_mps2}};
  json regions = json::array();
  for (const FloorRegionDef& r : w.floor.regions) {
    regions.push_back(
        {{"name", r.name}, {"friction", r.friction}, {"polygon", points(r.polygon_m)}});
  }
  out["floor"] = {{"friction", w.floor.friction}, {"regions", regions}};
  json walls = json::array();
  for (const WallDef& wall : w.walls) {
    walls.push_back({{"points", points(wall.points_m)},
                     {"closed", wall.closed},
                     {"thickness_m", wall.thickness_m},
                     {"height_m", height(wall.height_m)}});
  }
  out["walls"] = walls;
  json boxes = json::array();
  for (const BoxDef& b : w.boxes) {
    boxes.push_back({{"center", point(b.center_m)},
                     {"size", point(b.size_m)},
                     {"angle", b.angle_rad},
                     {"height_m", height(b.height_m)}});
  }
  out["boxes"] = boxes;
  json circles = json::array();
  for (const CircleDef& c : w.circles) {
    circles.push_back({{"center", point(c.center_m)},
                       {"radius_m", c.radius_m},
                       {"height_m", height(c.height_m)}});
  }
  out["circles"] = circles;
  json polygons = json::array();
  for (const PolygonDef& p : w.polygons)
    polygons.push_back({{"points", points(p.points_m)}, {"height_m", height(p.height_m)}});
  out["polygons"] = polygons;
  if (w.map) {
    out["map"] = {{"yaml", w.map->yaml_file.string()},
                  {"image", w.map->image_file.string()},
                  {"resolution", w.map->resolution_m},
                  {"origin", json::array({w.map->origin.x, w.map->origin.y, w.map->origin.theta})},
                  {"occupied_thresh", w.map->occupied_thresh},
                  {"free_thresh", w.map->free_thresh},
                  {"negate", w.map->negate},
                  {"size_px", json::array({w.map->width_px, w.map->height_px})}};
  }
  json landmarks = json::array();
  for (const LandmarkDef& l : w.landmarks) {
    json color = l.color_name.empty() ? json::array({l.color[0], l.color[1], l.color[2]})
                                      : json(l.color_name);
    landmarks.push_back({{"id", l.id},
                         {"position", point(l.position_m)},
                         {"color", color},
                         {"radius_m", l.radius_m},
                         {"height_m", l.height_m}});
  }
  out["landmarks"] = landmarks;
  json beacons = json::array();
  for (const BeaconDef& b : w.beacons) {
    beacons.push_back({{"id", b.id}, {"position", point(b.position_m)}, {"height_m", b.height_m}});
  }
  out["beacons"] = beacons;
  json movers = json::array();
  for (const MoverDef& m : w.movers) {
    movers.push_back({{"name", m.name},
                      {"kind", m.kind},
                      {"footprint", footprint(m.footprint)},
                      {"path", points(m.path_m)},
                      {"speed_mps", m.speed_mps},
                      {"loop", m.loop},
                      {"moving", m.moving},
                      {"height_m", m.height_m}});
  }
  out["movers"] = movers;
  json robots = json::array();
  for (const RobotDef& r : w.robots) {
    robots.push_back({{"name", r.name},
                      {"footprint", footprint(r.footprint)},
                      {"mass_kg", r.mass_kg},
                      {"wheel_base_m", r.wheel_base_m},
                      {"wheel_radius_m", r.wheel_radius_m},
                      {"wheel_radius_left_m", r.wheel_radius_left_m},
                      {"wheel_radius_right_m", r.wheel_radius_right_m},
                      {"wheel_inertia_kgm2", r.wheel_inertia_kgm2},
                      {"max_wheel_speed_radps", r.max_wheel_speed_radps},
                      {"max_wheel_accel_radps2", r.max_wheel_accel_radps2},
                      {"max_wheel_torque_nm", r.max_wheel_torque_nm},
                      {"drive_load_fraction", r.drive_load_fraction},
                      {"height_m", r.height_m},
                      {"start", pose(r.start)},
                      {"sensors", sensors(r.sensors)}});
    if (const CommandResponseDef& c = r.command_response; !c.identity()) {
      robots.back()["command_response"] = {{"dead_time_s", c.dead_time_s},
                                           {"time_constant_v_s", c.time_constant_v_s},
                                           {"time_constant_omega_s", c.time_constant_omega_s},
                                           {"gain_v", c.gain_v},
                                           {"gain_omega", c.gain_omega}};
      if (c.wanders()) {
        robots.back()["command_response"]["gain_wander_v"] = c.gain_wander_v;
        robots.back()["command_response"]["gain_wander_omega"] = c.gain_wander_omega;
        robots.back()["command_response"]["gain_wander_correlation_s"] =
            c.gain_wander_correlation_s;
      }
    }
    if (const SideSlipDef& d = r.side_slip; d.any()) {
      robots.back()["side_slip"] = {{"crab_angle_deg", rad_to_deg(d.crab_angle_rad)},
                                    {"cornering_compliance_s", d.cornering_compliance_s},
                                    {"wander_k", d.wander_k},
                                    {"wander_correlation_s", d.wander_correlation_s}};
    }
  }
  out["robots"] = robots;
  // Only when on: a world with `variation: none` writes what it wrote before variation existed.
  if (w.variation.enabled) {
    const VariationDef& v = w.variation;
    out["variation"] = {{"wheel_radius_rel", v.wheel_radius_rel},
                        {"wheel_base_rel", v.wheel_base_rel},
                        {"motor_rel", v.motor_rel},
                        {"friction_rel", v.friction_rel},
                        {"mover_speed_rel", v.mover_speed_rel},
                        {"start_xy_m", v.start_xy_m},
                        {"start_theta", v.start_theta_rad},
                        {"waypoint_m", v.waypoint_m},
                        {"mover_phase", v.mover_phase},
                        {"drawn", w.drawn.applied ? to_json(w.drawn) : json(nullptr)}};
  }
  return out;
}

json to_json(const ScenarioDef& s) {
  json out;
  out["name"] = s.name;
  out["source"] = s.source.string();
  out["duration_s"] = s.duration_s;
  out["groundtruth_hz"] = s.groundtruth_hz;
  json drives = json::array();
  for (const DriveDef& d : s.drives) {
    json drive = {{"robot", d.robot}, {"mode", mode_name(d.mode)}};
    if (d.start_after_s > 0.0) drive["start_after_s"] = d.start_after_s;
    switch (d.mode) {
      case DriveDef::Mode::kIdle:
        break;
      case DriveDef::Mode::kWaypoints:
        drive["path"] = points(d.path_m);
        drive["loop"] = d.loop;
        drive["speed_mps"] = d.speed_mps;
        drive["max_turn_rate_radps"] = d.max_turn_rate_radps;
        drive["tolerance_m"] = d.tolerance_m;
        drive["heading_gain"] = d.heading_gain;
        break;
      case DriveDef::Mode::kVelocity: {
        json commands = json::array();
        for (const VelocityCommand& c : d.commands) {
          commands.push_back({{"t_s", c.t_s}, {"v_mps", c.v_mps}, {"w_radps", c.w_radps}});
        }
        drive["commands"] = commands;
        break;
      }
      case DriveDef::Mode::kWander:
        drive["speed_mps"] = d.speed_mps;
        drive["max_turn_rate_radps"] = d.max_turn_rate_radps;
        drive["clearance_m"] = d.clearance_m;
        break;
      case DriveDef::Mode::kTrajectory:
        // A recorded path has thousands of poses: the world file holds them, run.json their
        // count and span (every run of a sweep would otherwise carry megabytes of them).
        drive["poses"] = {{"count", d.trajectory.size()},
                          {"from_s", d.trajectory.front().t_s},
                          {"to_s", d.trajectory.back().t_s}};
        if (!d.poses_file.empty()) drive["poses_file"] = d.poses_file.string();
        break;
    }
    drives.push_back(drive);
  }
  out["drive"] = drives;
  json events = json::array();
  for (const EventDef& e : s.events) {
    json event = {{"at_s", e.at_s}};
    switch (e.kind) {
      case EventDef::Kind::kKidnap: {
        json kidnap = {{"robot", e.robot}, {"carry_s", e.carry_s}};
        if (e.to) {
          kidnap["to"] = pose(*e.to);
        } else {
          kidnap["to"] = "random";
          if (e.random_min_m) {
            kidnap["within"] = {{"min", point(*e.random_min_m)}, {"max", point(*e.random_max_m)}};
          }
        }
        event["kidnap"] = kidnap;
        break;
      }
      case EventDef::Kind::kPush:
        event["push"] = {{"robot", e.robot},
                         {"impulse_ns", point(e.impulse_ns)},
                         {"angular_impulse_nms", e.angular_impulse_nms}};
        break;
      case EventDef::Kind::kFriction:
        event["friction"] = {{"region", e.region}, {"friction", e.friction}};
        break;
      case EventDef::Kind::kObstacle:
        event["obstacle"] = {{"name", e.obstacle}, {"action", e.start_moving ? "start" : "stop"}};
        break;
      case EventDef::Kind::kSensorFault: {
        const char* modes[] = {"dropout", "stuck", "bias"};
        event["sensor_fault"] = {{"robot", e.robot},
                                 {"sensor", e.sensor},
                                 {"mode", modes[static_cast<int>(e.fault.mode)]},
                                 {"duration_s", e.fault.duration_s},
                                 {"bias", e.fault.bias}};
        break;
      }
      case EventDef::Kind::kEnd:
        event["end"] = json::object();
        break;
    }
    events.push_back(event);
  }
  out["events"] = events;
  json policies = json::array();
  for (const PanPolicyDef& p : s.pan_policies) {
    const char* modes[] = {"fixed", "sweep", "nearest_landmark"};
    policies.push_back({{"robot", p.robot},
                        {"policy", modes[static_cast<int>(p.mode)]},
                        {"pan", p.pan_rad},
                        {"sweep_min", p.sweep_min_rad},
                        {"sweep_max", p.sweep_max_rad},
                        {"sweep_rate", p.sweep_rate_radps}});
  }
  out["ptz"] = policies;
  // Only when not the default, so that the runs made before this key existed stay byte-identical.
  if (!s.localization.landmarks_known) out["localization"] = {{"landmarks_known", false}};
  return out;
}

}  // namespace locsim
