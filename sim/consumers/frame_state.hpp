// What a picture of a run needs at one instant: the truth (robots, people), each localizer's
// belief (estimate, covariance, particles, a SLAM filter's landmark map) and the sensors' latest
// readings as world-frame geometry. Plain values, built by the runner at each video frame's
// simulated time; the renderer (render/, loaded only when a video is asked for) draws them. Nothing
// here links OpenGL or OpenCV.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sim/common/math.hpp"
#include "sim/robot/robot_def.hpp"
#include "sim/sensors/camera_image.hpp"
#include "sim/world/world_def.hpp"

namespace locsim {

struct FrameRobot {
  std::string name;
  Pose2 pose;             // true pose in the world
  bool carried = false;   // in the air (kidnapped): drawn as a ghost
  int kidnaps = 0;        // kidnaps so far: the true path breaks where this changes
  double height_m = 0.4;  // body height, for cameras' views [m]
  FootprintDef footprint;
  std::optional<Pose2> odometry;  // the base's dead-reckoned pose (odom frame = world at t = 0)
  // Sensor visuals from the latest readings, world frame.
  Vec2 laser_origin_m{0.0, 0.0};
  std::vector<Vec2> laser_hits_m;  // where beams hit (max-range readings, no hit, left out)
  struct UltrasonicLine {
    Vec2 receiver_m, beacon_m;
    bool line_of_sight = true;  // false: occluded (a reflection, or nothing came back)
  };
  std::vector<UltrasonicLine> ultrasonic;
  struct Camera {
    Pose2 optical_axis;  // position of the camera, heading of its axis (robot heading + pan)
    double hfov_rad = 0.0;
    double max_range_m = 0.0;
    std::vector<Vec2> detections_m;  // where each detection puts its landmark
    CameraShot shot;                 // for drawing the camera's own view
  };
  std::optional<Camera> camera;
  // The range-bearing sensor's latest detections, from the robot's position: where each puts
  // its target (world frame), and whether that is another robot.
  struct Sighting {
    Vec2 at_m{0.0, 0.0};
    bool robot = false;
  };
  std::vector<Sighting> sightings;
  bool range_bearing = false;  // has the sensor (the legend shows it even with nothing seen)
};

struct FrameMover {
  Pose2 pose;
  FootprintDef footprint;
  std::string kind;       // "person" or "cart"
  double height_m = 1.7;  // [m]
  std::string name;
};

struct FrameLocalizer {
  std::string label;
  std::size_t robot = 0;  // index into FrameState::robots
  bool failed = false;
  std::optional<Pose2> estimate;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  std::vector<Pose2> particles;
  std::vector<double> weights;  // empty: equal weights
  struct MappedLandmark {
    Vec2 position_m{0.0, 0.0};
    Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();  // [m^2]
  };
  std::vector<MappedLandmark> landmark_map;  // SLAM filters: the landmarks as mapped now
  double position_error_m = std::numeric_limits<double>::quiet_NaN();
  double heading_error_rad = std::numeric_limits<double>::quiet_NaN();
};

/// A kidnapping: where the robot was picked up and where it landed.
struct KidnapMark {
  std::size_t robot = 0;
  double t_s = 0.0;
  Pose2 from, to;
  bool landed = false;  // false while still carried
};

struct FrameState {
  double t_s = 0.0;
  std::vector<FrameRobot> robots;
  std::vector<FrameMover> movers;
  std::vector<FrameLocalizer> localizers;
  std::vector<KidnapMark> kidnaps;  // all so far
};

/// Video options as the command line gives them.
struct VideoOptions {
  std::optional<std::filesystem::path> video_file;  // .mp4 (H.264, else MPEG-4) or .avi
  std::optional<std::filesystem::path> frames_dir;  // also every frame as frame_NNNNNN.png
  int width_px = 1280;
  int height_px = 720;
  double fps = 30.0;               // video frames per second [1/s]
  double speed = 1.0;              // simulated seconds per video second [-]
  bool particles = true;           // draw the particle clouds
  std::string backend = "osmesa";  // GL context: osmesa (software, no display needed)
  bool camera_view = true;         // the first robot's PTZ camera view in the panel, if it has one
};

/// Receives the frames of a run, in order, each at its simulated time k * speed / fps.
class FrameSink {
 public:
  virtual ~FrameSink() = default;
  /// Before the first frame: the world as loaded.
  virtual void start(const WorldDef& world) = 0;
  virtual void frame(const FrameState& frame) = 0;
  /// After the last frame: flush and close the files. Frames written so far stay valid if this
  /// is never reached (a failed run keeps its PNGs; the MP4 needs it).
  virtual void finish() = 0;
  /// Frames written so far.
  virtual long frames() const = 0;
};

}  // namespace locsim
