// Writes the seed corpus of fuzz_cdr_samples (cdr_input.hpp format): a sane sample of every teamscan type
// and the bad values the edge refuses (robot ids 0 / 33 / 999999, count 65535 / 402, stamps 0 / INT64_MIN /
// INT64_MAX, coordinates ±2^31 mm, yaw 2^31 µrad, NaN covariances, absurd odometry corrections),
// serialised by Cyclone's dds_stream_write from the generated descriptors, little- and big-endian.
// usage: make_cdr_seeds DIR
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>

#include <dds/ddsi/ddsi_cdrstream.h>
#include <dds/ddsi/q_protocol.h>

#include "tests/fuzz/dds/cdr_input.hpp"

namespace {

using namespace teamscan;

void write_seed(const std::string& dir, const std::string& name, int type, const void* sample, bool big_endian) {
  const dds_topic_descriptor_t& desc = fuzz::cdr_descriptor(type);
  std::string bytes(1, static_cast<char>(type));
  bytes += std::string("\0", 1) + (big_endian ? std::string("\0", 1) : std::string("\1", 1)) + std::string(2, '\0');
  if (big_endian) {
    dds_ostreamBE_t os;
    dds_ostreamBE_init(&os, 0, CDR_ENC_VERSION_1);
    (void)dds_stream_writeBE(&os, static_cast<const char*>(sample), desc.m_ops);
    bytes.append(reinterpret_cast<const char*>(os.x.m_buffer), os.x.m_index);
    dds_ostreamBE_fini(&os);
  } else {
    dds_ostreamLE_t os;
    dds_ostreamLE_init(&os, 0, CDR_ENC_VERSION_1);
    (void)dds_stream_writeLE(&os, static_cast<const char*>(sample), desc.m_ops);
    bytes.append(reinterpret_cast<const char*>(os.x.m_buffer), os.x.m_index);
    dds_ostreamLE_fini(&os);
  }
  std::ofstream(dir + "/" + name + (big_endian ? "_be.cdr" : ".cdr"), std::ios::binary) << bytes;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_cdr_seeds DIR\n");
    return 2;
  }
  const std::string dir = argv[1];
  constexpr std::int64_t kNow = 1'800'000'000'000'000'000;
  for (bool be : {false, true}) {
    teamscan_msg_RobotPose p{1, 1, kNow, 1200, -3400, 1000000, 300, 0, 200};
    write_seed(dir, "pose", 0, &p, be);
    if (be) continue;
    p.robot_id = 999999;
    write_seed(dir, "pose_robot_999999", 0, &p, false);
    p.robot_id = 1;
    p.stamp_ns = INT64_MIN;
    write_seed(dir, "pose_stamp_min", 0, &p, false);
    p.stamp_ns = kNow;
    p.x_mm = INT32_MIN;
    p.yaw_urad = INT32_MAX;
    write_seed(dir, "pose_far_yaw", 0, &p, false);
  }
  static teamscan_msg_ScanPoints s{};
  s.robot_id = 2;
  s.seq = 7;
  s.stamp_ns = kNow;
  s.origin_z_mm = 462;
  s.count = 401;
  for (std::uint16_t b = 0; b < 401; ++b) s.points[b] = teamscan_msg_ScanPoint{1000 + b, 2000, 300, b, 0};
  write_seed(dir, "scan", 1, &s, false);
  write_seed(dir, "scan", 1, &s, true);
  // A scan the robot corrected (its applied map_from_odom), and one with an absurd correction.
  s.corr_x_mm = 250;
  s.corr_y_mm = -400;
  s.corr_yaw_urad = 80'000;
  s.corr_seq = 3;
  write_seed(dir, "scan_corrected", 1, &s, false);
  s.corr_yaw_urad = INT32_MIN;
  s.corr_x_mm = INT32_MAX;
  write_seed(dir, "scan_bad_correction", 1, &s, false);
  s.corr_x_mm = s.corr_y_mm = s.corr_yaw_urad = 0;
  s.corr_seq = 0;
  s.count = 65535;
  write_seed(dir, "scan_count_65535", 1, &s, false);
  s.count = 402;
  s.robot_id = 33;
  s.points[9].x_mm = INT32_MAX;
  write_seed(dir, "scan_count_402_robot_33", 1, &s, false);
  teamscan_msg_RobotStatus st{};
  st.robot_id = 3;
  st.seq = 0xFFFFFFFFu;
  st.stamp_ns = 0;
  st.clock_sync = 2;
  write_seed(dir, "status_clock_unset", 2, &st, false);
  static teamscan_msg_TeamState t{};
  t.seq = 1;
  t.stamp_ns = kNow;
  t.count = 2;
  for (std::uint32_t i = 0; i < 2; ++i) {
    t.members[i] = teamscan_msg_TeamMember{i + 1, 3000, 1500 * static_cast<std::int32_t>(i), 200, 0, 400.0f, 0.0f, 400.0f,
                                           508, 497, 500, 0, 0, kNow,
                                           // member 1 with an odometry correction, member 2 without
                                           i == 0 ? 250 : 0, i == 0 ? -400 : 0, i == 0 ? 80'000 : 0,
                                           i == 0 ? 30u : 0u, i == 0 ? 2'000u : 0u, i == 0 ? 5u : 0u};
  }
  write_seed(dir, "team", 3, &t, false);
  write_seed(dir, "team", 3, &t, true);
  t.members[0].corr_yaw_urad = INT32_MAX;
  write_seed(dir, "team_bad_correction", 3, &t, false);
  t.members[0].corr_yaw_urad = 80'000;
  t.members[1].cov_xx_mm2 = std::numeric_limits<float>::quiet_NaN();
  write_seed(dir, "team_nan_cov", 3, &t, false);
  t.count = 200;
  write_seed(dir, "team_count_200", 3, &t, false);
  teamscan_msg_MapVoxel voxels[3] = {{0, 0, 0, 1, 0}, {100, 0, 0, 2, 1}, {0, 100, 50, 65535, 0}};
  teamscan_msg_MapUpdate m{};
  m.seq = 1;
  m.stamp_ns = kNow;
  m.resolution_mm = 100;
  m.total_voxels = 3;
  m.voxels._buffer = voxels;
  m.voxels._length = m.voxels._maximum = 3;
  write_seed(dir, "map", 4, &m, false);
  // What the station stored (store and forward): robot 3 confirmed, an unknown robot, a seq from the future.
  static teamscan_msg_StoredState st_msg{};
  st_msg.seq = 1;
  st_msg.stamp_ns = kNow;
  st_msg.count = 3;
  st_msg.robots[0] = teamscan_msg_RobotStored{3, 50, 1, 50, 40};
  st_msg.robots[1] = teamscan_msg_RobotStored{40, 10, 1, 10, 10};
  st_msg.robots[2] = teamscan_msg_RobotStored{3, 500, 1, 500, 500};
  write_seed(dir, "stored", 5, &st_msg, false);
  write_seed(dir, "stored", 5, &st_msg, true);
  return 0;
}
