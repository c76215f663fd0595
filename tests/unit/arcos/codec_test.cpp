// ARCOS codec against every vector of PROTOCOLS.md §3.1 (A1-A23), encode and decode, plus the §1.12
// pitfalls and the tolerant decoders (short SIPs, truncated CONFIGpac).
#include <gtest/gtest.h>

#include "drivers/arcos/codec.hpp"
#include "tests/unit/arcos/test_support.hpp"

namespace teamscan::arcos {
namespace {

using test::bytes_of;
using test::frame;
using test::hex;

struct CommandVector {
  const char* id;
  PacketBuffer built;
  const char* wire;
  std::uint8_t command;
  CommandPacket::Arg arg;
  std::int32_t value;
};

TEST(ArcosChecksum, OddBodyUsesXorPath) {
  // §1.2: words 0x0F2B + 0x0214 = 0x113F, then the odd byte 0x3C XORed into the low half -> 0x1103 (A20).
  const std::uint8_t body[] = {0x0F, 0x2B, 0x02, 0x14, 0x3C};
  EXPECT_EQ(checksum(body), 0x1103);
  const std::uint8_t one[] = {0x07};
  EXPECT_EQ(checksum(one), 0x0007);
  EXPECT_EQ(checksum({}), 0x0000);
}

TEST(ArcosChecksum, SumKeepsSixteenBits) {
  const std::uint8_t body[] = {0xFF, 0xFF, 0x00, 0x02};  // 0xFFFF + 0x0002 = 0x10001 -> 0x0001
  EXPECT_EQ(checksum(body), 0x0001);
}

TEST(ArcosCommands, VectorsA1toA20EncodeExactly) {
  const std::uint8_t say[] = {0x14, 0x3C};
  const CommandVector v[] = {
      {"A1", make_command(Command::kSync0), "FA FB 03 00 00 00", 0, CommandPacket::Arg::kNone, 0},
      {"A2", make_command(Command::kSync1), "FA FB 03 01 00 01", 1, CommandPacket::Arg::kNone, 0},
      {"A3", make_command(Command::kSync2), "FA FB 03 02 00 02", 2, CommandPacket::Arg::kNone, 0},
      {"A5", make_command(Command::kOpen, 1), "FA FB 06 01 3B 01 00 02 3B", 1, CommandPacket::Arg::kInt, 1},
      {"A6", make_command(Command::kEnable, 1), "FA FB 06 04 3B 01 00 05 3B", 4, CommandPacket::Arg::kInt, 1},
      {"A7", make_command(Command::kVel, 200), "FA FB 06 0B 3B C8 00 D3 3B", 11, CommandPacket::Arg::kInt, 200},
      {"A8", make_command(Command::kVel, -200), "FA FB 06 0B 1B C8 00 D3 1B", 11, CommandPacket::Arg::kInt, -200},
      {"A9", make_command(Command::kRVel, 30), "FA FB 06 15 3B 1E 00 33 3B", 21, CommandPacket::Arg::kInt, 30},
      {"A10", make_command(Command::kRVel, -30), "FA FB 06 15 1B 1E 00 33 1B", 21, CommandPacket::Arg::kInt, -30},
      {"A11", make_command(Command::kRotate, 30), "FA FB 06 09 3B 1E 00 27 3B", 9, CommandPacket::Arg::kInt, 30},
      {"A12", make_command(Command::kHead, 90), "FA FB 06 0C 3B 5A 00 66 3B", 12, CommandPacket::Arg::kInt, 90},
      {"A13", make_command_type_only(Command::kSetO), "FA FB 04 07 3B 07 3B", 7, CommandPacket::Arg::kTypeOnly, 0},
      {"A14", make_command(Command::kSetA, -1000), "FA FB 06 05 1B E8 03 ED 1E", 5, CommandPacket::Arg::kInt, -1000},
      {"A15", make_vel2(200, 100), "FA FB 06 20 3B 05 0A 25 45", 32, CommandPacket::Arg::kInt, 0x0A05},
      {"A16", make_vel2(-200, 100), "FA FB 06 20 1B FB 09 1B 24", 32, CommandPacket::Arg::kInt, -0x09FB},
      {"A17", make_command(Command::kEncoder, 2), "FA FB 06 13 3B 02 00 15 3B", 19, CommandPacket::Arg::kInt, 2},
      {"A18", make_command(Command::kHostBaud, 4), "FA FB 06 32 3B 04 00 36 3B", 50, CommandPacket::Arg::kInt, 4},
      {"A19", make_command(Command::kClose, 1), "FA FB 06 02 3B 01 00 03 3B", 2, CommandPacket::Arg::kInt, 1},
      {"A20", make_command_string(Command::kSay, say), "FA FB 07 0F 2B 02 14 3C 11 03", 15, CommandPacket::Arg::kString, 0},
  };
  for (const auto& c : v) {
    SCOPED_TRACE(c.id);
    const auto wire = hex(c.wire);
    EXPECT_EQ(bytes_of(c.built), wire);
    // Decode direction: the wire bytes verify and give back the command and its argument.
    auto view = verify_packet(wire);
    ASSERT_TRUE(view.ok());
    auto cmd = decode_command(view.value());
    ASSERT_TRUE(cmd.ok());
    EXPECT_EQ(cmd->command, c.command);
    EXPECT_EQ(cmd->arg, c.arg);
    EXPECT_EQ(cmd->value, c.value);
  }
}

TEST(ArcosCommands, Vel2PackingAndSplit) {
  // A15: left +200 = 10 units (0x0A) in the high byte, right +100 = 5 units in the low byte.
  EXPECT_EQ(vel2_argument(200, 100), 0x0A05);
  // A16: left -200 = -10 = 0xF6 high byte -> the word 0xF605 is negative: sent as -(0x09FB).
  EXPECT_EQ(vel2_argument(-200, 100), -0x09FB);
  double l = 0, r = 0;
  vel2_split(-0x09FB, 20, l, r);
  EXPECT_DOUBLE_EQ(l, -200.0);
  EXPECT_DOUBLE_EQ(r, 100.0);
  // Clamped to a signed byte of units.
  EXPECT_EQ(vel2_argument(10000, -10000), static_cast<std::int16_t>(0x7F80));
}

TEST(ArcosCommands, IntArgumentIsClampedToSixteenBitMagnitude) {
  EXPECT_EQ(bytes_of(make_command(Command::kVel, 70000)), frame(std::vector<std::uint8_t>{0x0B, 0x3B, 0xFF, 0xFF}));
  EXPECT_EQ(bytes_of(make_command(Command::kVel, -70000)), frame(std::vector<std::uint8_t>{0x0B, 0x1B, 0xFF, 0xFF}));
}

TEST(ArcosCommands, DecodeRejectsBadArguments) {
  const auto unknown = frame(std::vector<std::uint8_t>{0x0B, 0x4C, 0x01, 0x00});
  ASSERT_TRUE(verify_packet(unknown).ok());
  EXPECT_FALSE(decode_command(verify_packet(unknown).value()).ok());
  const auto short_int = frame(std::vector<std::uint8_t>{0x0B, 0x3B, 0x01});
  EXPECT_FALSE(decode_command(verify_packet(short_int).value()).ok());
  const auto short_str = frame(std::vector<std::uint8_t>{0x0F, 0x2B, 0x05, 0x01});
  EXPECT_FALSE(decode_command(verify_packet(short_str).value()).ok());
}

TEST(ArcosSync2, VectorA4EncodeAndDecode) {
  const auto wire = hex("FA FB 1A 02 4D 79 50 33 41 54 00 50 69 6F 6E 65 65 72 00 70 33 61 74 2D 73 68 00 01 34");
  Sync2Reply r;
  r.name.assign("MyP3AT");
  r.robot_class.assign("Pioneer");
  r.subclass.assign("p3at-sh");
  EXPECT_EQ(bytes_of(encode_sync2_reply(r)), wire);
  auto view = verify_packet(wire);
  ASSERT_TRUE(view.ok());
  auto d = decode_sync2_reply(view.value());
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->name.view(), "MyP3AT");
  EXPECT_EQ(d->robot_class.view(), "Pioneer");
  EXPECT_EQ(d->subclass.view(), "p3at-sh");
}

TEST(ArcosSync2, MissingFinalNulAndStringsAreTolerated) {
  const std::vector<std::uint8_t> body = {0x02, 'R', '1', 0, 'P', 'i'};
  const auto wire = frame(body);
  auto d = decode_sync2_reply(verify_packet(wire).value());
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->name.view(), "R1");
  EXPECT_EQ(d->robot_class.view(), "Pi");
  EXPECT_EQ(d->subclass.view(), "");
}

SipPacket a21_sip() {
  SipPacket s;
  s.type = 0x32;
  s.x_raw = 1000;
  s.y_raw = 0x7FF0;
  s.th_raw = 1024;
  s.battery_dv = 128;
  s.stall_bumpers = 0x0101 | (0x03 << 9);
  s.control = 1024;
  s.flags = 0x001F;
  s.compass = 45;
  s.sonar_count = 2;
  s.sonar[0] = {0, 1500};
  s.sonar[1] = {7, 300};
  s.tail_fields = 9;  // GRIP_STATE .. FAULTFLAGS
  s.analog = 0x80;
  s.dig_in = 0xFF;
  s.battery_x10 = 128;
  s.charge_state = 0;
  s.rot_vel = -15;
  return s;
}

const char* kA21 =
    "FA FB 28 32 E8 03 F0 7F 00 04 00 00 00 00 80 01 07 00 04 1F 00 2D 02 00 DC 05 07 2C 01 00 00 80 FF "
    "00 80 00 00 F1 FF 00 00 AC C7";

TEST(ArcosSip, VectorA21Encode) { EXPECT_EQ(bytes_of(encode_sip(a21_sip())), hex(kA21)); }

TEST(ArcosSip, VectorA21Decode) {
  const auto wire = hex(kA21);
  auto s = decode_sip(verify_packet(wire).value());
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s->type, 0x32);
  EXPECT_EQ(s->x_raw, 1000);
  EXPECT_EQ(s->y_raw, 0x7FF0);
  EXPECT_EQ(s->th_raw, 1024);
  EXPECT_EQ(s->left_vel, 0);
  EXPECT_EQ(s->right_vel, 0);
  EXPECT_EQ(s->battery_dv, 128);  // 12.8 V
  EXPECT_TRUE(s->left_stall());
  EXPECT_TRUE(s->right_stall());
  EXPECT_EQ(s->front_bumpers(), 0x03);
  EXPECT_EQ(s->rear_bumpers(), 0x00);
  EXPECT_EQ(s->control, 1024);
  EXPECT_TRUE(s->motors_enabled());
  EXPECT_EQ((s->flags >> 1) & 0x0F, 0x0F);  // sonar arrays
  EXPECT_FALSE(s->estop());
  EXPECT_EQ(s->compass * 2, 90);
  ASSERT_EQ(s->sonar_count, 2);
  EXPECT_EQ(s->sonar[0].number, 0);
  EXPECT_EQ(s->sonar[0].range, 1500);
  EXPECT_EQ(s->sonar[1].number, 7);
  EXPECT_EQ(s->sonar[1].range, 300);
  EXPECT_EQ(s->tail_fields, 9);
  EXPECT_TRUE(s->has(SipField::kFaultFlags));
  EXPECT_FALSE(s->has(SipField::kLatVel));
  EXPECT_EQ(s->analog, 0x80);
  EXPECT_EQ(s->dig_in, 0xFF);
  EXPECT_EQ(s->battery_x10, 128);
  EXPECT_EQ(s->rot_vel, -15);
  EXPECT_EQ(s->trailing_bytes, 0);
}

TEST(ArcosSip, VectorA22MinimalMovingSip) {
  const auto wire = hex("FA FB 22 33 00 00 00 00 00 00 FA 00 FA 00 7D 00 00 00 00 00 00 00 00 00 00 00 00 00 7D 00 00 00 00 00 00 35 EE");
  SipPacket s;
  s.type = 0x33;
  s.left_vel = 250;
  s.right_vel = 250;
  s.battery_dv = 125;
  s.battery_x10 = 125;
  s.charge_state = 0;
  s.tail_fields = 9;
  EXPECT_EQ(bytes_of(encode_sip(s)), wire);
  auto d = decode_sip(verify_packet(wire).value());
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->type, 0x33);
  EXPECT_EQ(d->left_vel, 250);
  EXPECT_EQ(d->right_vel, 250);
  EXPECT_EQ(d->battery_dv, 125);
  EXPECT_EQ(d->sonar_count, 0);
  EXPECT_EQ(d->tail_fields, 9);
}

TEST(ArcosSip, ShortSipsReportWhichTailFieldsArePresent) {
  const auto full = hex(kA21);
  const std::vector<std::uint8_t> body(full.begin() + 3, full.end() - 2);
  // Older P2OS/AROS firmware ends after DIGOUT: fixed 19 + 2×3 sonar + 5 tail bytes after the type.
  const std::size_t fixed = 1 + 19 + 6;
  struct Case { std::size_t keep; std::uint8_t fields; };
  for (const Case c : {Case{fixed, 0}, Case{fixed + 1, 1}, Case{fixed + 5, 5}, Case{fixed + 6, 5},
                       Case{fixed + 7, 6}, Case{fixed + 8, 7}, Case{fixed + 10, 8}}) {
    SCOPED_TRACE(c.keep);
    const auto wire = frame(std::span<const std::uint8_t>{body.data(), c.keep});
    auto s = decode_sip(verify_packet(wire).value());
    ASSERT_TRUE(s.ok());
    EXPECT_EQ(s->tail_fields, c.fields);
    EXPECT_EQ(s->sonar_count, 2);
    EXPECT_EQ(s->x_raw, 1000);
  }
  // A half field (BATTERYX10 cut after one byte) is not a field: reported as trailing.
  auto s = decode_sip(verify_packet(frame(std::span<const std::uint8_t>{body.data(), fixed + 6})).value());
  EXPECT_EQ(s->trailing_bytes, 1);
  EXPECT_FALSE(s->has(SipField::kBatteryX10));
  EXPECT_EQ(s->charge_state, 255);  // unknown when absent (ARIA)
}

TEST(ArcosSip, TruncatedFixedPartOrSonarIsAnError) {
  const auto full = hex(kA21);
  const std::vector<std::uint8_t> body(full.begin() + 3, full.end() - 2);
  EXPECT_FALSE(decode_sip(verify_packet(frame(std::span<const std::uint8_t>{body.data(), 19})).value()).ok());
  // Sonar count 2 but only one reading present.
  EXPECT_FALSE(decode_sip(verify_packet(frame(std::span<const std::uint8_t>{body.data(), 1 + 19 + 3})).value()).ok());
  // Not a SIP type.
  EXPECT_FALSE(decode_sip(verify_packet(hex("FA FB 03 00 00 00")).value()).ok());
}

TEST(ArcosSip, FullTailRoundTrips) {
  SipPacket s = a21_sip();
  s.tail_fields = kSipTailFieldCount;
  s.lat_vel = -321;
  s.temperature_c = -12;
  s.state_of_charge = 87;
  s.micro_time_us = 0xDEADBEEF;
  s.flags3 = 0x01020304;
  const auto wire = encode_sip(s);
  ASSERT_GT(wire.size, 0U);
  auto d = decode_sip(verify_packet(wire.span()).value());
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->tail_fields, kSipTailFieldCount);
  EXPECT_EQ(d->lat_vel, -321);
  EXPECT_EQ(d->temperature_c, -12);
  EXPECT_EQ(d->state_of_charge, 87);
  EXPECT_EQ(d->micro_time_us, 0xDEADBEEFU);
  EXPECT_EQ(d->flags3, 0x01020304U);
  EXPECT_EQ(d->rot_vel, -15);
}

TEST(ArcosSip, MaximalSonarCountFitsOnePacket) {
  SipPacket s;
  s.sonar_count = static_cast<std::uint8_t>(kMaxSonarReadings);
  for (std::size_t i = 0; i < kMaxSonarReadings; ++i) s.sonar[i] = {static_cast<std::uint8_t>(i), static_cast<std::uint16_t>(100 + i)};
  const auto wire = encode_sip(s);
  ASSERT_GT(wire.size, 0U);
  EXPECT_LE(wire.size, kMaxArcosPacket);
  auto d = decode_sip(verify_packet(wire.span()).value());
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->sonar_count, kMaxSonarReadings);
  EXPECT_EQ(d->sonar[kMaxSonarReadings - 1].range, 100 + kMaxSonarReadings - 1);
}

TEST(ArcosEncoder, VectorA23) {
  const auto wire = hex("FA FB 0B 90 40 E2 01 00 0F 04 F6 FF 77 B9");
  EXPECT_EQ(bytes_of(encode_encoder({123456, -654321})), wire);
  auto e = decode_encoder(verify_packet(wire).value());
  ASSERT_TRUE(e.ok());
  EXPECT_EQ(e->left, 123456);
  EXPECT_EQ(e->right, -654321);
  EXPECT_FALSE(decode_encoder(verify_packet(frame(std::vector<std::uint8_t>{0x90, 1, 2, 3})).value()).ok());
}

TEST(ArcosConfig, RealP3dxShFragmentDecodesAsFarAsItGoes) {
  // The first bytes of a real P3DX-SH CONFIGpac (reedhedges/AriaCoda#15, PROTOCOLS.md §5); the packet
  // is incomplete, so only its data are decoded (decode_config must not need the whole packet, §6).
  std::vector<std::uint8_t> data;
  for (std::string_view s : {"Pioneer", "p3dx-sh", "GJC_3156"}) {
    data.insert(data.end(), s.begin(), s.end());
    data.push_back(0);
  }
  for (auto b : hex("00 68 01 E8 03 2C 01 D0 07 F4 01")) data.push_back(b);
  for (char ch : std::string_view{"FAPESP_3156"}) data.push_back(static_cast<std::uint8_t>(ch));
  data.push_back(0);
  for (auto b : hex("64 00 00 00 00")) data.push_back(b);
  PacketView v{0x20, data, {}};
  auto c = decode_config(v);
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->robot_class.view(), "Pioneer");
  EXPECT_EQ(c->subclass.view(), "p3dx-sh");
  EXPECT_EQ(c->serial_number.view(), "GJC_3156");
  EXPECT_EQ(c->rot_vel_top, 360);
  EXPECT_EQ(c->trans_vel_top, 1000);
  EXPECT_EQ(c->rot_acc_top, 300);
  EXPECT_EQ(c->trans_acc_top, 2000);
  EXPECT_EQ(c->pwm_max, 500);
  EXPECT_EQ(c->name.view(), "FAPESP_3156");
  EXPECT_EQ(c->sip_cycle_ms, 100);
  EXPECT_EQ(c->host_baud, 0);
  EXPECT_EQ(c->aux1_baud, 0);
  EXPECT_EQ(c->has_gripper, 0);
  EXPECT_EQ(c->fields_present, 14);  // .. HasGripper; FrontSonar is cut
  EXPECT_FALSE(c->complete());
}

TEST(ArcosConfig, RoundTripAllAndRequiredFields) {
  ConfigPacket c;
  c.robot_class.assign("Pioneer");
  c.subclass.assign("p3at-sh");
  c.name.assign("bot7");
  c.firmware_version.assign("1.9");
  c.sip_cycle_ms = 100;
  c.watchdog_ms = 2000;
  c.drift_factor = -17;
  c.gyro_rate_limit = 999;
  c.config_flags = 0xA5A5A5A5;
  c.gyro_fw_version = -3;
  auto all = decode_config(verify_packet(encode_config(c).span()).value());
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(all->fields_present, kConfigAllFields);
  EXPECT_EQ(all->watchdog_ms, 2000);
  EXPECT_EQ(all->drift_factor, -17);
  EXPECT_EQ(all->firmware_version.view(), "1.9");
  EXPECT_EQ(all->config_flags, 0xA5A5A5A5U);
  EXPECT_EQ(all->gyro_fw_version, -3);
  auto req = decode_config(verify_packet(encode_config(c, kConfigRequiredFields).span()).value());
  ASSERT_TRUE(req.ok());
  EXPECT_EQ(req->fields_present, kConfigRequiredFields);
  EXPECT_TRUE(req->complete());
  EXPECT_EQ(req->gyro_rate_limit, 999);
  EXPECT_EQ(req->config_flags, 0U);
}

TEST(ArcosPitfalls, CorruptedVelPacketIsRejected) {
  // §1.12 item 1: accepted by ROS p2os' Check(), rejected by ARIA and Player.
  EXPECT_FALSE(verify_packet(hex("FA FB 06 0B 3B 88 00 D3 3B")).ok());
}

TEST(ArcosPitfalls, CountBelowThreeIsRejected) {
  // §1.12 item 3: count 0/1/2 would wrap ARIA's body length.
  EXPECT_FALSE(verify_packet(hex("FA FB 00")).ok());
  EXPECT_FALSE(verify_packet(hex("FA FB 01 00")).ok());
  EXPECT_FALSE(verify_packet(hex("FA FB 02 00 00")).ok());
  EXPECT_FALSE(verify_packet(hex("FA FB 02 00 00 00")).ok());
}

TEST(ArcosPitfalls, ChecksumIsBigEndianOnTheWire) {
  // A7 with the checksum bytes swapped must fail.
  EXPECT_FALSE(verify_packet(hex("FA FB 06 0B 3B C8 00 3B D3")).ok());
}

}  // namespace
}  // namespace teamscan::arcos
