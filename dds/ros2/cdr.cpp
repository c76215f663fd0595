// Cyclone's XCDR1 serialisation of ROS 2 samples, and the ROS 2 message definitions (cdr.hpp).
#include "dds/ros2/cdr.hpp"

#include <dds/ddsi/ddsi_cdrstream.h>
#include <dds/ddsi/q_protocol.h>

namespace teamscan::dds::ros2 {

std::string cdr_bytes(const dds_topic_descriptor_t& desc, const void* sample) {
  dds_ostreamLE_t os;
  dds_ostreamLE_init(&os, 0, CDR_ENC_VERSION_1);
  (void)dds_stream_writeLE(&os, static_cast<const char*>(sample), desc.m_ops);
  const std::size_t n = os.x.m_index;
  const std::size_t pad = (4 - n % 4) % 4;
  std::string out;
  out.reserve(4 + n + pad);
  out.push_back('\0');
  out.push_back('\1');  // CDR_LE (ROS2_WIRE.md 2)
  out.push_back('\0');
  out.push_back(static_cast<char>(pad));
  out.append(reinterpret_cast<const char*>(os.x.m_buffer), n);
  out.append(pad, '\0');
  dds_ostreamLE_fini(&os);
  return out;
}

namespace {

// The .msg files of ros2/common_interfaces (and geometry2's tf2_msgs), comments and constants left out
// except PointField's datatype constants, which readers use.
#define TEAMSCAN_SEP "================================================================================\n"
constexpr char kTime[] = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";
constexpr char kHeader[] = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n";
constexpr char kPoint[] = "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n";
constexpr char kQuaternion[] = "MSG: geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w\n";
constexpr char kVector3[] = "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";
constexpr char kPose[] = "MSG: geometry_msgs/Pose\ngeometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n";

const std::string& point_cloud2() {
  static const std::string s = std::string(
      "std_msgs/Header header\nuint32 height\nuint32 width\nsensor_msgs/PointField[] fields\nbool is_bigendian\n"
      "uint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n" TEAMSCAN_SEP) + kHeader + TEAMSCAN_SEP +
      kTime + TEAMSCAN_SEP +
      "MSG: sensor_msgs/PointField\nuint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\n"
      "uint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\nstring name\nuint32 offset\nuint8 datatype\nuint32 count\n";
  return s;
}

const std::string& tf_message() {
  static const std::string s = std::string("geometry_msgs/TransformStamped[] transforms\n" TEAMSCAN_SEP
                                           "MSG: geometry_msgs/TransformStamped\nstd_msgs/Header header\n"
                                           "string child_frame_id\ngeometry_msgs/Transform transform\n" TEAMSCAN_SEP) +
                                kHeader + TEAMSCAN_SEP + kTime + TEAMSCAN_SEP +
                                "MSG: geometry_msgs/Transform\ngeometry_msgs/Vector3 translation\n"
                                "geometry_msgs/Quaternion rotation\n" TEAMSCAN_SEP +
                                kVector3 + TEAMSCAN_SEP + kQuaternion;
  return s;
}

const std::string& odometry() {
  static const std::string s =
      std::string("std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n"
                  "geometry_msgs/TwistWithCovariance twist\n" TEAMSCAN_SEP) +
      kHeader + TEAMSCAN_SEP + kTime + TEAMSCAN_SEP +
      "MSG: geometry_msgs/PoseWithCovariance\ngeometry_msgs/Pose pose\nfloat64[36] covariance\n" TEAMSCAN_SEP + kPose +
      TEAMSCAN_SEP + kPoint + TEAMSCAN_SEP + kQuaternion + TEAMSCAN_SEP +
      "MSG: geometry_msgs/TwistWithCovariance\ngeometry_msgs/Twist twist\nfloat64[36] covariance\n" TEAMSCAN_SEP +
      "MSG: geometry_msgs/Twist\ngeometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n" TEAMSCAN_SEP + kVector3;
  return s;
}

const std::string& pose_stamped() {
  static const std::string s = std::string("std_msgs/Header header\ngeometry_msgs/Pose pose\n" TEAMSCAN_SEP) + kHeader +
                               TEAMSCAN_SEP + kTime + TEAMSCAN_SEP + kPose + TEAMSCAN_SEP + kPoint + TEAMSCAN_SEP +
                               kQuaternion;
  return s;
}
#undef TEAMSCAN_SEP

}  // namespace

std::string_view ros2msg_definition(std::string_view type_name) {
  if (type_name == kPointCloud2Type) return point_cloud2();
  if (type_name == kTfMessageType) return tf_message();
  if (type_name == kOdometryType) return odometry();
  if (type_name == kPoseStampedType) return pose_stamped();
  return {};
}

}  // namespace teamscan::dds::ros2
