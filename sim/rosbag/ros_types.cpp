#include "sim/rosbag/ros_types.hpp"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <utility>

#include "sim/rosbag/message_definition.hpp"

namespace locsim::rosbag {
namespace {

// Fields only: the comments of ROS's files are theirs and carry nothing a decoder needs.
constexpr std::array<std::pair<std::string_view, std::string_view>, 29> kDefinitions = {{
    {"builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n"},
    {"builtin_interfaces/Duration", "int32 sec\nuint32 nanosec\n"},
    {"std_msgs/Header", "builtin_interfaces/Time stamp\nstring frame_id\n"},
    {"std_msgs/String", "string data\n"},
    {"rosgraph_msgs/Clock", "builtin_interfaces/Time clock\n"},
    {"geometry_msgs/Point", "float64 x\nfloat64 y\nfloat64 z\n"},
    {"geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z\n"},
    {"geometry_msgs/Quaternion", "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n"},
    {"geometry_msgs/Pose", "Point position\nQuaternion orientation\n"},
    {"geometry_msgs/PoseStamped", "std_msgs/Header header\nPose pose\n"},
    {"geometry_msgs/PoseWithCovariance", "Pose pose\nfloat64[36] covariance\n"},
    {"geometry_msgs/PoseWithCovarianceStamped",
     "std_msgs/Header header\nPoseWithCovariance pose\n"},
    {"geometry_msgs/PoseArray", "std_msgs/Header header\nPose[] poses\n"},
    {"geometry_msgs/Twist", "Vector3 linear\nVector3 angular\n"},
    {"geometry_msgs/TwistWithCovariance", "Twist twist\nfloat64[36] covariance\n"},
    {"geometry_msgs/Transform", "Vector3 translation\nQuaternion rotation\n"},
    {"geometry_msgs/TransformStamped",
     "std_msgs/Header header\nstring child_frame_id\nTransform transform\n"},
    {"tf2_msgs/TFMessage", "geometry_msgs/TransformStamped[] transforms\n"},
    {"nav_msgs/Odometry",
     "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n"
     "geometry_msgs/TwistWithCovariance twist\n"},
    {"nav_msgs/MapMetaData",
     "builtin_interfaces/Time map_load_time\nfloat32 resolution\nuint32 width\nuint32 height\n"
     "geometry_msgs/Pose origin\n"},
    {"nav_msgs/OccupancyGrid", "std_msgs/Header header\nMapMetaData info\nint8[] data\n"},
    {"sensor_msgs/LaserScan",
     "std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\nfloat32 angle_increment\n"
     "float32 time_increment\nfloat32 scan_time\nfloat32 range_min\nfloat32 range_max\n"
     "float32[] ranges\nfloat32[] intensities\n"},
    {"sensor_msgs/JointState",
     "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n"
     "float64[] effort\n"},
    // locsim's own, for what no ROS message carries (a bag carries their definitions).
    {"locsim_msgs/Detection",
     "string color\nint32 id\nfloat64 range\nfloat64 bearing\nint32 truth_id\nuint8 target\n"},
    {"locsim_msgs/Detections",
     "std_msgs/Header header\nfloat64 pan\nfloat64 tilt\nfloat64 zoom\nDetection[] detections\n"},
    {"locsim_msgs/BeaconRange",
     "int32 receiver\nint32 beacon\nfloat64 range\nuint8 truth_status\n"},
    {"locsim_msgs/BeaconRanges", "std_msgs/Header header\nBeaconRange[] ranges\n"},
    {"locsim_msgs/Event",
     "std_msgs/Header header\nstring kind\nstring robot\nint64 step\nstring details\n"},
    {"sensor_msgs/Imu",
     "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n"
     "float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n"
     "float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n"
     "float64[9] linear_acceleration_covariance\n"},
}};

}  // namespace

std::string_view known_definition(std::string_view type_name) {
  const std::string name = short_type_name(type_name);
  for (const auto& [known, text] : kDefinitions) {
    if (known == name) return text;
  }
  return {};
}

std::string schema_text(std::string_view type_name) {
  if (known_definition(type_name).empty()) {
    throw std::invalid_argument("schema_text: " + std::string(type_name) + " is not a known type");
  }
  // The resolved definition lists the type, then the types it uses depth first, once each.
  const MessageDefinition definition = MessageDefinition::known(type_name);
  std::string text(known_definition(type_name));
  for (std::size_t i = 1; i < definition.types().size(); ++i) {
    text += std::string(80, '=') + "\nMSG: " + definition.types()[i].name + "\n";
    text += known_definition(definition.types()[i].name);
  }
  return text;
}

std::vector<std::string> known_types() {
  std::vector<std::string> types;
  const auto add = [&](std::string_view name) {
    const std::size_t slash = name.find('/');
    types.push_back(std::string(name.substr(0, slash)) + "/msg" + std::string(name.substr(slash)));
  };
  for (const auto& definition : kDefinitions) add(definition.first);
  return types;
}

}  // namespace locsim::rosbag
