// LmsClient over a real termios SerialPort against LmsEmulator on a pseudo-terminal (PtyRunner) in
// real time: full bring-up including the 500000 switch, streaming for seconds, the pty closed
// (unplug) -> device loss reported -> replug -> bring-up again, then shutdown back to 9600.
// Assertions are on states and contents, never on how fast the shared machine ran.
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <filesystem>
#include <functional>
#include <string>

#include "common/clock.hpp"
#include "drivers/lms200/client.hpp"
#include "drivers/lms200/emulator_pty.hpp"
#include "drivers/serial/serial_port.hpp"
#include "tools/teamscan/decode.hpp"

namespace teamscan::lms200 {
namespace {

// The host side as the robot daemon would run it: one loop, the port's rate follows the client.
class HostLoop {
 public:
  HostLoop(std::string path, const LmsClientOptions& options) : path_{std::move(path)}, client{options} {}

  void start() {
    open_port();
    client.start(now_monotonic());
  }

  void iterate() {
    const Time now = now_monotonic();
    if (!port_.is_open()) {
      if (now >= next_open_) {
        next_open_ = now + 100ms;
        if (open_port()) client.on_device_back(now);
      }
      if (!port_.is_open()) {
        ::usleep(2000);
        client.on_tick(now);
        return;
      }
    }
    if (port_.baud() != client.baud() && !port_.set_baud(client.baud()).ok()) return lose(now);
    std::array<std::uint8_t, 4096> buf{};
    const std::size_t n = client.take_tx(buf);
    if (n > 0 && !port_.write_all(std::span{buf}.first(n), 1s).ok()) return lose(now);
    auto got = port_.read(buf, 2ms);
    if (!got) return lose(now_monotonic());
    if (*got > 0) client.on_rx(std::span{buf}.first(*got), now_monotonic());
    client.on_tick(now_monotonic());
    ScanTelegram s;
    ScanArrival a;
    while (client.take_scan(s, a)) {
      ++scans;
      if (s.count != 361 || s.unit != Unit::mm) ++bad_scans;
      for (std::size_t i = 0; i < s.count; ++i)
        if (s.ranges_mm[i] != 3000u || s.invalid[i] != BeamInvalid::none) ++bad_beams;
    }
  }

  bool run_until(const std::function<bool()>& done, Duration limit) {
    const Time end = now_monotonic() + limit;
    while (now_monotonic() < end) {
      if (done()) return true;
      iterate();
    }
    return done();
  }

  std::string path_;
  LmsClient client;
  int scans = 0;
  int bad_scans = 0;
  int bad_beams = 0;
  int losses_seen = 0;

 private:
  bool open_port() {
    auto p = serial::SerialPort::open(path_.c_str(), client.baud());
    if (!p) return false;
    port_ = std::move(p.value());
    return true;
  }
  void lose(Time now) {
    ++losses_seen;
    port_.close();
    client.on_device_lost(now);
    next_open_ = now + 100ms;
  }

  serial::SerialPort port_;
  Time next_open_{};
};

int count(const std::string& text, const std::string& part) {
  int n = 0;
  for (std::size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++n;
  return n;
}

// The session the runner recorded decodes cleanly with `teamscan decode --device lms200`: both
// directions, the baud headers respected, every scan the client got present.
void check_recorded_session(const std::string& path, int client_scans) {
  auto cap = load_capture(path);
  ASSERT_TRUE(cap.ok()) << cap.error().what << " line " << cap.error().detail;
  tool::DecodeInput in;
  std::uint32_t baud = 9600;
  for (const auto& r : cap->records) {
    if (r.kind == CaptureRecord::Kind::baud) {
      baud = r.baud;
      continue;
    }
    in.chunks.push_back(tool::DecodeChunk{r.time_us, r.direction, baud, r.bytes});
  }
  char* buf = nullptr;
  std::size_t size = 0;
  std::FILE* f = open_memstream(&buf, &size);
  EXPECT_EQ(tool::decode_lms200(in, f), 0);
  std::fclose(f);
  const std::string out{buf, size};
  std::free(buf);
  // Recording stopped mid-stream: at most the telegram then on the line is cut off, nothing else.
  EXPECT_EQ(count(out, "\"error\""), count(out, "\"reason\":\"truncated\",\"dir\":\"rx\""));
  EXPECT_LE(count(out, "\"error\""), 1);
  EXPECT_NE(out.find("\"naks\":0,\"bad_crc\":0,\"bad_length\":0,"), std::string::npos);
  EXPECT_NE(out.find("\"resyncs\":0,"), std::string::npos);
  EXPECT_GE(count(out, "\"name\":\"measured_values\""), client_scans);
  EXPECT_EQ(count(out, "\"new_baud\":500000"), 1);             // the switch, sent at 9600
  EXPECT_GE(count(out, "\"baud\":500000"), client_scans);      // the stream, received at 500k
  EXPECT_EQ(count(out, "\"name\":\"write_config\",\"dir\":\"tx\""), 1);
  EXPECT_GE(count(out, "\"units\":\"mm\""), 2);              // the 0x77 and its 0xF7 echo
}

TEST(LmsHil, BringUpStreamUnplugReplugShutdown) {
  const auto dir = std::filesystem::temp_directory_path() / ("teamscan-lms200-hil-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  serial::PtyRunnerOptions ro;
  ro.link_path = (dir / "ttyLMS").string();
  LmsEmulatorOptions eo;  // starts at 9600 in cm, 180°/1°
  auto emu = LmsPtyEmulator::create(eo, nullptr, ro);
  ASSERT_TRUE(emu.ok()) << emu.error().what;
  ASSERT_TRUE((*emu)->start().ok());

  LmsClientOptions co;
  co.target_baud = 500000;
  co.variant = {180, 50};
  co.silence_timeout = 1s;  // a loaded shared machine may stall the runner for a while
  HostLoop host{ro.link_path, co};
  const std::string cap_path = (dir / "session.cap").string();
  ASSERT_TRUE((*emu)->runner().record(cap_path, DeviceKind::lms200).ok());
  host.start();

  ASSERT_TRUE(host.run_until([&] { return host.client.streaming(); }, 30s)) << host.client.state_name() << " "
                                                                              << host.client.last_error();
  EXPECT_EQ((*emu)->with_emulator([](LmsEmulator& e) { return e.baud(); }), 500000u);
  EXPECT_EQ((*emu)->with_emulator([](LmsEmulator& e) { return e.units(); }), 1);
  EXPECT_EQ((*emu)->with_emulator([](LmsEmulator& e) { return e.variant(); }), (LaserVariant{180, 50}));

  // Stream for a few seconds of wall time.
  const Time stream_end = now_monotonic() + 3s;
  (void)host.run_until([&] { return now_monotonic() >= stream_end; }, 4s);
  EXPECT_GT(host.scans, 10);
  EXPECT_EQ(host.bad_scans, 0);
  EXPECT_EQ(host.bad_beams, 0);
  std::printf("streamed %d scans of 361 values in 3 s at 500000 baud\n", host.scans);
  ASSERT_TRUE((*emu)->runner().stop_recording().ok());
  check_recorded_session(cap_path, host.scans);

  // Unplug: the host's reads fail, the client reports the loss.
  (*emu)->unplug();
  ASSERT_TRUE(host.run_until([&] { return host.client.state() == LmsClientState::device_lost; }, 10s))
      << host.client.state_name();
  EXPECT_EQ(host.client.statistics().device_losses, 1u);
  (void)host.run_until([] { return false; }, 300ms);
  EXPECT_EQ(host.client.state(), LmsClientState::device_lost);

  // Replug: the port reopens, the client probes and brings the scanner up again.
  ASSERT_TRUE((*emu)->replug().ok());
  const int scans_before = host.scans;
  ASSERT_TRUE(host.run_until([&] { return host.client.statistics().bringups >= 2 && host.scans > scans_before; }, 30s))
      << host.client.state_name() << " " << host.client.last_error();
  EXPECT_EQ(host.bad_beams, 0);

  host.client.shutdown(now_monotonic());
  ASSERT_TRUE(host.run_until([&] { return host.client.state() == LmsClientState::stopped; }, 10s))
      << host.client.state_name();
  (void)host.run_until([] { return false; }, 100ms);
  EXPECT_EQ((*emu)->with_emulator([](LmsEmulator& e) { return e.baud(); }), 9600u);
  EXPECT_FALSE((*emu)->with_emulator([](LmsEmulator& e) { return e.streaming(); }));
  (*emu)->stop();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace teamscan::lms200
