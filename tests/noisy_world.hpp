// A simulated world with every noise `locsim calibrate` measures configured (docs/sensors.md),
// for the calibration and twin tests.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

namespace locsim::testing {

/// The world's YAML; its range-bearing sensor's noise correlated over `noise_correlation_s`.
inline std::string noisy_world(double noise_correlation_s) {
  return R"(name: calibration_test
walls:
  - points: [[0, 0], [10, 0], [10, 8], [0, 8]]
    closed: true
landmarks:  # beside the path (0.6 to 0.8 m off it) and in the corners: ranges from 0.5 to 7 m
  - {id: 1, position: [5.0, 1.4], color: red}
  - {id: 2, position: [8.7, 4.0], color: green}
  - {id: 3, position: [1.3, 4.0], color: blue}
  - {id: 4, position: [5.0, 3.2], color: red}
  - {id: 5, position: [3.5, 5.7], color: yellow}
  - {id: 6, position: [6.5, 5.7], color: magenta}
  - {id: 7, position: [0.5, 7.5], color: cyan}
  - {id: 8, position: [9.5, 0.5], color: green}
robots:
  - name: robot
    footprint: {radius_m: 0.2}
    wheel_base_m: 0.33
    wheel_radius_m: 0.05
    start: {x: 2, y: 2, theta_deg: 0}
    sensors:
      encoders: {rate_hz: 50, k_left: 0.01, k_right: 0.02}
      range_bearing:
        rate_hz: 10
        fov_deg: 120
        min_range_m: 0.3
        max_range_m: 7
        sigma_range_m: 0.05
        sigma_range_per_m: 0.02
        range_bias_m: 0.1
        range_bias_per_m: -0.05
        sigma_bearing_deg: 1.5
        bearing_bias_deg: 2
        miss_probability: 0.2
        false_detections: 0.3
        noise_correlation_s: )" +
         std::to_string(noise_correlation_s) + R"(
scenario:
  duration_s: 300
  drive:
    mode: waypoints
    path: [[8, 2], [8, 6], [5, 4], [2, 6], [2, 2]]
    loop: true
    speed_mps: 0.5
)";
}

/// The office map (worlds/maps, copied into `dir`) and one robot wandering in it for `duration_s`
/// at 0.4 m/s with `sensors` (the YAML of its sensors' map, e.g. "{laser: {beams: 181}}") and the
/// scenario's extra `scenario` lines; no movers, so what the laser sees is the map. Returns the
/// world file.
inline std::filesystem::path office_world(const std::filesystem::path& dir,
                                          const std::string& sensors, double duration_s,
                                          const std::string& scenario = "") {
  const std::filesystem::path maps = std::filesystem::path(LOCSIM_SOURCE_DIR) / "worlds" / "maps";
  for (const char* file : {"office.yaml", "office.pgm"}) {
    std::filesystem::copy_file(maps / file, dir / file,
                               std::filesystem::copy_options::overwrite_existing);
  }
  std::ofstream(dir / "world.yaml")
      << "name: office_laser\nmap: office.yaml\nrobots:\n  - name: robot\n"
         "    start: {x: 2.0, y: 2.0, theta_deg: 30}\n    sensors: "
      << sensors << "\nscenario:\n  name: wander\n  duration_s: " << duration_s
      << "\n  drive: {mode: wander, speed_mps: 0.4}\n"
      << scenario;
  return dir / "world.yaml";
}

/// A 20 x 15 m plaza with four beacons at its corners and a robot without an IMU that ranges
/// them one at a time with 0.2 m of noise (a UWB tag polling its anchors) while it drives a loop
/// for `duration_s`; its encoders are `encoders` (a flow map's YAML) and `localization` is the
/// scenario's localization line (empty: the scenario's default).
inline std::string range_only_world(const std::string& encoders, double duration_s,
                                    const std::string& localization = "") {
  return R"(name: range_only
beacons:
  - {id: 1, position: [0, 0], height_m: 0}
  - {id: 2, position: [20, 0], height_m: 0}
  - {id: 3, position: [20, 15], height_m: 0}
  - {id: 4, position: [0, 15], height_m: 0}
robots:
  - name: robot
    footprint: {radius_m: 0.3}
    wheel_base_m: 0.5
    wheel_radius_m: 0.1
    start: {x: 5, y: 4, theta_deg: 0}
    sensors:
      encoders: )" +
         encoders + R"(
      ultrasonic: {rate_hz: 4, receivers: [{position: [0, 0], height_m: 0}], sigma_m: 0.2,
                   beacons_per_reading: 1, dropout_probability: 0}
scenario:
  duration_s: )" +
         std::to_string(duration_s) + "\n" +
         (localization.empty() ? "" : "  " + localization + "\n") +
         R"(  drive: {mode: waypoints, path: [[15, 4], [15, 11], [5, 11], [5, 4]], loop: true, speed_mps: 0.8}
)";
}

}  // namespace locsim::testing
