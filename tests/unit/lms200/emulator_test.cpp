// LmsEmulator alone, driven with raw telegrams (PROTOCOLS.md §2.4): ACK + reply, NAK on a bad CRC,
// 0x92 on unknown commands, baud switch after the acknowledgement, setup mode and config, reset,
// power-on telegram, paced output.
#include "drivers/lms200/emulator.hpp"

#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "tests/unit/lms200/test_util.hpp"

namespace teamscan::lms200 {
namespace {

using test::hex;

struct Rig {
  explicit Rig(LmsEmulatorOptions o = unpaced()) : emu{o} { emu.power_up(now); }
  static LmsEmulatorOptions unpaced() {
    LmsEmulatorOptions o;
    o.pace_output = false;
    return o;
  }
  std::vector<std::uint8_t> send(const std::vector<std::uint8_t>& bytes, Duration wait = 1ms) {
    emu.on_rx(bytes, now);
    now += wait;
    emu.on_tick(now);
    return drain();
  }
  std::vector<std::uint8_t> drain() {
    std::array<std::uint8_t, 8192> b{};
    std::vector<std::uint8_t> out;
    for (std::size_t n; (n = emu.take_tx(b)) > 0;) out.insert(out.end(), b.begin(), b.begin() + static_cast<std::ptrdiff_t>(n));
    return out;
  }
  Time now = Time::from_seconds(10.0);
  LmsEmulator emu;
};

std::vector<std::uint8_t> cat(std::initializer_list<std::vector<std::uint8_t>> parts) {
  std::vector<std::uint8_t> out;
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

TEST(LmsEmulator, AnswersStartContinuousWithAckAndL17) {
  Rig r;
  EXPECT_EQ(r.send(hex("02 00 02 00 20 24 34 08")), hex("06 02 80 03 00 A0 00 10 16 0A"));
  EXPECT_TRUE(r.emu.streaming());
}

TEST(LmsEmulator, NakOnBadCrc) {
  Rig r;
  EXPECT_EQ(r.send(hex("02 00 02 00 20 24 34 09")), hex("15"));
  EXPECT_FALSE(r.emu.streaming());
  EXPECT_EQ(r.emu.statistics().naks_sent, 1u);
}

TEST(LmsEmulator, IncorrectCommandIsAckedThenL20) {
  Rig r;
  std::array<std::uint8_t, 16> b{};
  const std::uint8_t body[] = {0x55};
  const auto n = build_telegram(b, kAddressToLms, body);
  EXPECT_EQ(r.send(test::bytes_of(b, n)), cat({hex("06"), hex("02 80 02 00 92 10 7F 33")}));
  EXPECT_EQ(r.emu.statistics().incorrect_commands, 1u);
}

TEST(LmsEmulator, BaudSwitchAfterTheReplyLeft) {
  Rig r;
  r.emu.on_rx(hex("02 00 02 00 20 48 58 08"), r.now);  // L8
  EXPECT_EQ(r.emu.baud(), 9600u);  // ACK and A0 still to go at 9600
  EXPECT_EQ(r.drain(), hex("06 02 80 03 00 A0 00 10 16 0A"));
  EXPECT_EQ(r.emu.baud(), 500000u);
}

TEST(LmsEmulator, VariantAcceptedAndRefused) {
  Rig r;
  EXPECT_EQ(r.send(hex("02 00 05 00 3B B4 00 32 00 3B 1F")),  // L11
            hex("06 02 80 07 00 BB 01 B4 00 32 00 10 03 9D"));  // §5 public reply
  EXPECT_EQ(r.emu.variant(), (LaserVariant{180, 50}));
  std::array<std::uint8_t, 32> b{};
  const auto n = build_variant(b, {180, 25});
  const auto reply = r.send(test::bytes_of(b, n));
  ASSERT_EQ(reply.size(), 14u);
  EXPECT_EQ(reply[6], 0x00);  // refused, old variant kept
  EXPECT_EQ(r.emu.variant(), (LaserVariant{180, 50}));
}

TEST(LmsEmulator, SetupModeConfigReadModifyWrite) {
  Rig r;
  // 0x77 outside setup mode is rejected.
  std::array<std::uint8_t, 64> b{};
  std::array<std::uint8_t, 32> cfg{};
  cfg[6] = 1;
  auto n = build_write_config(b, cfg);
  auto reply = r.send(test::bytes_of(b, n));
  ASSERT_GT(reply.size(), 6u);
  EXPECT_EQ(reply[5], 0xF7);
  EXPECT_EQ(reply[6], 0x00);
  EXPECT_EQ(r.emu.units(), 0);
  // Wrong password -> A0 01 (L18 after the ACK); right one -> A0 00.
  n = build_setup_mode(b, "SICK_LMX");
  EXPECT_EQ(r.send(test::bytes_of(b, n)), hex("06 02 80 03 00 A0 01 10 14 0B"));
  EXPECT_EQ(r.send(hex("02 00 0A 00 20 00 53 49 43 4B 5F 4C 4D 53 BE C5")), hex("06 02 80 03 00 A0 00 10 16 0A"));
  EXPECT_TRUE(r.emu.in_setup_mode());
  // 0x74 gives the 32-byte block; a 34-byte write is refused, the L16 write accepted.
  reply = r.send(hex("02 00 01 00 74 50 12"));
  ASSERT_EQ(reply.size(), 1u + 6 + 1 + 32 + 1);
  EXPECT_EQ(reply[5], 0xF4);
  std::array<std::uint8_t, 34> long_cfg{};
  n = build_write_config(b, long_cfg);
  reply = r.send(test::bytes_of(b, n));
  EXPECT_EQ(reply[6], 0x00);
  reply = r.send(hex("02 00 21 00 77 00 00 00 00 00 00 01 00 00 02 02 "
                     "00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 FC 7E"));  // L16
  EXPECT_EQ(reply[6], 0x01);
  EXPECT_EQ(r.emu.units(), 1);
}

TEST(LmsEmulator, ResetSends91ThenPowerOnAt9600) {
  LmsEmulatorOptions o = Rig::unpaced();
  o.reset_delay = 2s;
  Rig r{o};
  (void)r.send(hex("02 00 02 00 20 40 50 08"));  // -> 38400
  ASSERT_EQ(r.emu.baud(), 38400u);
  const auto reply = r.send(hex("02 00 01 00 10 34 12"));  // L13
  ASSERT_EQ(reply.size(), 1u + 8);
  EXPECT_EQ(reply[0], kAck);
  EXPECT_EQ(reply[5], 0x91);
  EXPECT_FALSE(r.emu.powered());
  // Deaf while rebooting.
  EXPECT_TRUE(r.send(hex("02 00 01 00 31 15 12"), 1s).empty());
  r.now += 1s;
  r.emu.on_tick(r.now);
  const auto power_on = r.drain();
  ASSERT_EQ(power_on.size(), 29u);  // §2.1
  EXPECT_EQ(power_on[4], 0x90);
  EXPECT_EQ(r.emu.baud(), 9600u);
  EXPECT_EQ(r.emu.units(), 0);
}

TEST(LmsEmulator, StatusAndTypeReplies) {
  Rig r;
  auto reply = r.send(hex("02 00 01 00 31 15 12"));
  ASSERT_EQ(reply.size(), 1u + 160);  // "status reply 161 B incl. ACK" (§5 Olin)
  const auto info = parse_status_data(TelegramView{std::span{reply}.subspan(1)}.data());
  ASSERT_TRUE(info.has_value());
  EXPECT_EQ(info->baud, 9600u);
  EXPECT_EQ(info->operating_mode, 0x25);
  std::array<std::uint8_t, 16> b{};
  reply = r.send(test::bytes_of(b, build_lms_type_request(b)));
  ASSERT_GT(reply.size(), 20u);
  EXPECT_EQ(reply[5], 0xBA);
  EXPECT_EQ(std::string(reply.begin() + 6, reply.begin() + 18), "LMS200;30106");
}

TEST(LmsEmulator, PolledScanOnRequest) {
  Rig r;
  const auto reply = r.send(hex("02 00 02 00 30 01 31 18"));  // L9
  ASSERT_EQ(reply.size(), 1u + 372);  // 181 values (§2.10 table)
  EXPECT_EQ(reply[5], 0xB0);
}

TEST(LmsEmulator, PowerOnTelegramAfterTheDelay) {
  LmsEmulatorOptions o = Rig::unpaced();
  o.send_power_on = true;
  o.power_on_delay = 30s;
  Rig r{o};
  EXPECT_TRUE(r.send(hex("02 00 01 00 31 15 12"), 29s).empty());
  r.now += 1s;
  r.emu.on_tick(r.now);
  const auto out = r.drain();
  ASSERT_EQ(out.size(), 29u);
  EXPECT_EQ(out[4], 0x90);
}

TEST(LmsEmulator, PacedOutputTakesTheLineTime) {
  LmsEmulatorOptions o;
  o.pace_output = true;
  Rig r{o};
  r.emu.on_rx(hex("02 00 01 00 31 15 12"), r.now);
  std::array<std::uint8_t, 512> b{};
  std::size_t got = r.emu.take_tx(b);
  EXPECT_EQ(got, 0u);  // nothing has finished its 10 bits yet
  // 161 bytes at 9600 take 167.7 ms: after 100 ms about 96 bytes, after 170 ms all.
  r.now += 100ms;
  r.emu.on_tick(r.now);
  got = r.emu.take_tx(b);
  EXPECT_EQ(got, 96u);
  r.now += 70ms;
  r.emu.on_tick(r.now);
  got += r.emu.take_tx(b);
  EXPECT_EQ(got, 161u);
}

}  // namespace
}  // namespace teamscan::lms200
