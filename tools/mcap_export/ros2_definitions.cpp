// The .msg texts of ros2_definitions.hpp, composed from one text per type and its dependencies.
#include "tools/mcap_export/ros2_definitions.hpp"

#include <map>

namespace teamscan::mcap_export {
namespace {

const std::map<std::string, std::string>& types() {
  static const std::map<std::string, std::string> kTypes = {
      {"builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n"},
      {"std_msgs/Header", "builtin_interfaces/Time stamp\nstring frame_id\n"},
      {"geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z\n"},
      {"geometry_msgs/Point", "float64 x\nfloat64 y\nfloat64 z\n"},
      {"geometry_msgs/Quaternion", "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n"},
      {"geometry_msgs/Pose", "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n"},
      {"geometry_msgs/Transform", "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n"},
      {"geometry_msgs/TransformStamped",
       "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n"},
      {"geometry_msgs/PoseWithCovariance", "geometry_msgs/Pose pose\nfloat64[36] covariance\n"},
      {"geometry_msgs/Twist", "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n"},
      {"geometry_msgs/TwistWithCovariance", "geometry_msgs/Twist twist\nfloat64[36] covariance\n"},
      {"sensor_msgs/PointField",
       "uint8 INT8 = 1\nuint8 UINT8 = 2\nuint8 INT16 = 3\nuint8 UINT16 = 4\nuint8 INT32 = 5\nuint8 UINT32 = 6\n"
       "uint8 FLOAT32 = 7\nuint8 FLOAT64 = 8\nstring name\nuint32 offset\nuint8 datatype\nuint32 count\n"},
  };
  return kTypes;
}

std::string compose(const std::string& root, const std::vector<std::string>& dependencies) {
  std::string out = root;
  for (const std::string& d : dependencies) {
    out += std::string(80, '=') + "\nMSG: " + d + "\n" + types().at(d);
  }
  return out;
}

}  // namespace

std::string point_cloud2_definition() {
  return compose(
      "std_msgs/Header header\nuint32 height\nuint32 width\nsensor_msgs/PointField[] fields\nbool is_bigendian\n"
      "uint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n",
      {"std_msgs/Header", "builtin_interfaces/Time", "sensor_msgs/PointField"});
}

std::string tf_message_definition() {
  return compose("geometry_msgs/TransformStamped[] transforms\n",
                 {"geometry_msgs/TransformStamped", "std_msgs/Header", "builtin_interfaces/Time",
                  "geometry_msgs/Transform", "geometry_msgs/Vector3", "geometry_msgs/Quaternion"});
}

std::string odometry_definition() {
  return compose(
      "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n"
      "geometry_msgs/TwistWithCovariance twist\n",
      {"std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/PoseWithCovariance", "geometry_msgs/Pose",
       "geometry_msgs/Point", "geometry_msgs/Quaternion", "geometry_msgs/TwistWithCovariance", "geometry_msgs/Twist",
       "geometry_msgs/Vector3"});
}

std::string robot_status_definition(const std::vector<std::string>& columns) {
  std::string root =
      "# One row of the ground station's status.csv (docs/formats.md), one int64 per column\n"
      "std_msgs/Header header\n";
  for (const std::string& c : columns) root += "int64 " + c + "\n";
  return compose(root, {"std_msgs/Header", "builtin_interfaces/Time"});
}

}  // namespace teamscan::mcap_export
