// The bytes of teamscan/team and teamscan/scan on the wire (XCDR1, @final, as idl/CMakeLists.txt builds
// the types): Cyclone's serialiser run on the generated descriptors equals a sample hand-encoded here
// from the XCDR1 rules (each primitive aligned to its size, 8-byte ones included; little-endian), field
// by field in the order of idl/teamscan.idl, independent of the code under test. Pins the layout of the
// odometry correction fields (TeamMember.corr_*, ScanPoints.corr_*): a reordering, a type change or a
// field lost in idl/ changes these bytes.
#include <gtest/gtest.h>

#include <dds/ddsi/ddsi_cdrstream.h>
#include <dds/ddsi/q_protocol.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "teamscan.h"

namespace teamscan {
namespace {

// Cyclone's serialisation of one sample, without the 4-byte encapsulation header.
std::vector<std::uint8_t> serialise(const dds_topic_descriptor_t& desc, const void* sample) {
  dds_ostreamLE_t os;
  dds_ostreamLE_init(&os, 0, CDR_ENC_VERSION_1);
  (void)dds_stream_writeLE(&os, static_cast<const char*>(sample), desc.m_ops);
  std::vector<std::uint8_t> bytes(os.x.m_buffer, os.x.m_buffer + os.x.m_index);
  dds_ostreamLE_fini(&os);
  return bytes;
}

// XCDR1 little-endian by hand: align to the primitive's size (from the stream's start), then its bytes.
class Cdr {
 public:
  Cdr& u8(std::uint8_t v) { return put(v, 1); }
  Cdr& u16(std::uint16_t v) { return put(v, 2); }
  Cdr& u32(std::uint32_t v) { return put(v, 4); }
  Cdr& i32(std::int32_t v) { return put(static_cast<std::uint32_t>(v), 4); }
  Cdr& i64(std::int64_t v) { return put(static_cast<std::uint64_t>(v), 8); }
  Cdr& f32(float v) {
    std::uint32_t u = 0;
    std::memcpy(&u, &v, 4);
    return put(u, 4);
  }
  [[nodiscard]] const std::vector<std::uint8_t>& bytes() const { return b_; }

 private:
  Cdr& put(std::uint64_t v, std::size_t size) {
    while (b_.size() % size != 0) b_.push_back(0);
    for (std::size_t i = 0; i < size; ++i) b_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
    return *this;
  }
  std::vector<std::uint8_t> b_;
};

std::string first_difference(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b) {
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
    if (a[i] != b[i]) return "first difference at byte " + std::to_string(i);
  }
  return "sizes " + std::to_string(a.size()) + " and " + std::to_string(b.size());
}

TEST(TeamscanCdr, TeamMemberCarriesTheOdometryCorrectionAfterValidNs) {
  static teamscan_msg_TeamState t;
  std::memset(&t, 0, sizeof t);
  t.seq = 0x01020304u;
  t.stamp_ns = 0x1122334455667788;
  t.count = 2;
  t.members[0] = teamscan_msg_TeamMember{3, -1500, 2500, 120, -80, 400.0f, -12.5f, 900.0f, 508, 497, 800, 0, 0,
                                         1'800'000'000'123'456'789, -152, 37, -1'570'796, 41, 8'727, 0xA1B2C3D4u};
  t.members[1] = teamscan_msg_TeamMember{5, 0, 0, 0, 0, 0.0f, 0.0f, 0.0f, 0, 0, 0, 1, 0, -1, 0, 0, 0, 0, 0, 0};

  Cdr c;
  c.u32(0x01020304u).i64(0x1122334455667788).u8(2);
  for (std::uint32_t i = 0; i < teamscan_msg_MAX_ROBOTS; ++i) {
    const teamscan_msg_TeamMember& m = t.members[i];  // zeros beyond count: the array is fixed-size
    c.u32(m.robot_id).i32(m.x_mm).i32(m.y_mm).i32(m.vx_mmps).i32(m.vy_mmps);
    c.f32(m.cov_xx_mm2).f32(m.cov_xy_mm2).f32(m.cov_yy_mm2);
    c.u16(m.length_mm).u16(m.width_mm).u16(m.height_mm).u8(m.lost).u8(m.reserved).i64(m.valid_ns);
    c.i32(m.corr_x_mm).i32(m.corr_y_mm).i32(m.corr_yaw_urad).u32(m.corr_sigma_mm).u32(m.corr_sigma_yaw_urad).u32(m.corr_seq);
  }
  const std::vector<std::uint8_t> wire = serialise(teamscan_msg_TeamState_desc, &t);
  EXPECT_EQ(wire, c.bytes()) << first_difference(wire, c.bytes());
  // 20 bytes of header, the first member 76 (4 bytes of padding before its valid_ns), 31 more of 72.
  EXPECT_EQ(wire.size(), 20u + 76u + 31u * 72u);
  // The first member's correction, at fixed offsets: corr_x_mm at 72, corr_seq at 92.
  const std::vector<std::uint8_t> corr(wire.begin() + 72, wire.begin() + 96);
  const std::vector<std::uint8_t> expected = {0x68, 0xFF, 0xFF, 0xFF,   // −152
                                              0x25, 0x00, 0x00, 0x00,   // 37
                                              0x14, 0x08, 0xE8, 0xFF,   // −1 570 796
                                              0x29, 0x00, 0x00, 0x00,   // 41
                                              0x17, 0x22, 0x00, 0x00,   // 8 727
                                              0xD4, 0xC3, 0xB2, 0xA1};  // 0xA1B2C3D4
  EXPECT_EQ(corr, expected);
}

TEST(TeamscanCdr, ScanPointsCarriesTheAppliedCorrectionBeforeCount) {
  static teamscan_msg_ScanPoints s;
  std::memset(&s, 0, sizeof s);
  s.robot_id = 2;
  s.seq = 70000;
  s.stamp_ns = 1'800'000'000'000'000'001;
  s.origin_x_mm = -40;
  s.origin_y_mm = 50;
  s.origin_z_mm = 462;
  s.corr_x_mm = 1'000'000;
  s.corr_y_mm = -1;
  s.corr_yaw_urad = 3'141'593;
  s.corr_seq = 9;
  s.count = 2;
  s.points[0] = teamscan_msg_ScanPoint{1, 2, 3, 0, 0};
  s.points[1] = teamscan_msg_ScanPoint{-4, -5, -6, 400, 0x41};

  Cdr c;
  c.u32(s.robot_id).u32(s.seq).i64(s.stamp_ns).i32(s.origin_x_mm).i32(s.origin_y_mm).i32(s.origin_z_mm);
  c.i32(s.corr_x_mm).i32(s.corr_y_mm).i32(s.corr_yaw_urad).u32(s.corr_seq).u16(s.count);
  for (std::uint32_t i = 0; i < teamscan_msg_MAX_BEAMS; ++i) {
    const teamscan_msg_ScanPoint& p = s.points[i];
    c.i32(p.x_mm).i32(p.y_mm).i32(p.z_mm).u16(p.beam).u16(p.flags);
  }
  const std::vector<std::uint8_t> wire = serialise(teamscan_msg_ScanPoints_desc, &s);
  EXPECT_EQ(wire, c.bytes()) << first_difference(wire, c.bytes());
  EXPECT_EQ(wire.size(), 48u + 401u * 16u);
  const std::vector<std::uint8_t> corr(wire.begin() + 28, wire.begin() + 46);
  const std::vector<std::uint8_t> expected = {0x40, 0x42, 0x0F, 0x00,  // 1 000 000
                                              0xFF, 0xFF, 0xFF, 0xFF,  // −1
                                              0xD9, 0xEF, 0x2F, 0x00,  // 3 141 593
                                              0x09, 0x00, 0x00, 0x00,  // corr_seq 9
                                              0x02, 0x00};             // count 2
  EXPECT_EQ(corr, expected);
}

}  // namespace
}  // namespace teamscan
