// LmsClient against LmsEmulator in one process over a simulated serial line (PROTOCOLS.md §2.11):
// bring-up incl. the 500000 switch, variant, mm units via setup mode, streaming, scanner reset,
// silence, device loss and shutdown back to 9600. Time is simulated: nothing here waits on a clock.
#include "drivers/lms200/client.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>
#include <vector>

#include "drivers/lms200/emulator.hpp"

namespace teamscan::lms200 {
namespace {

// Ranges that identify the sweep: beam i of the scan ending at t reads 500 + i + (t in ms mod 2000) mm.
class TestRanges final : public RangeSource {
 public:
  void measure(const SweepTiming& sweep, std::span<BeamReading> beams) override {
    sweeps.push_back(sweep);
    for (std::size_t i = 0; i < beams.size(); ++i)
      beams[i] = BeamReading{expected_mm(sweep.sweep_end, i), 0, BeamInvalid::none};
  }
  static std::uint32_t expected_mm(Time sweep_end, std::size_t i) {
    return static_cast<std::uint32_t>(500 + i + static_cast<std::size_t>((sweep_end.ns() / 1'000'000) % 2000));
  }
  std::vector<SweepTiming> sweeps;
};

// A serial line in simulated time: bytes pass only if both UARTs run at the same rate (otherwise
// the receiver sees garbage), and the line can be cut (unplugged cable / powered-down converter).
class Bench {
 public:
  explicit Bench(LmsEmulatorOptions eo = {}, const LmsClientOptions& co = {})
      : emulator{paced(eo), &ranges}, client{co} {
    emulator.power_up(now);
  }

  void step() {
    now += kStep;
    emulator.on_tick(now);
    client.on_tick(now);
    std::array<std::uint8_t, 4096> buf{};
    std::size_t n = client.take_tx(buf);
    if (n > 0 && corrupt_next_command) {
      buf[n - 1] = static_cast<std::uint8_t>(buf[n - 1] ^ 0x01);  // break the CRC
      corrupt_next_command = false;
    }
    if (n > 0 && connected) deliver(std::span{buf}.first(n), client.baud(), emulator.baud(), [&](auto b) {
      emulator.on_rx(b, now);
    });
    const std::uint32_t emulator_baud = emulator.baud();  // the rate these bytes left at (it may switch after)
    n = emulator.take_tx(buf);
    if (noise_rate > 0.0)
      for (std::size_t i = 0; i < n; ++i)
        if (noise(rng) < noise_rate) buf[i] = static_cast<std::uint8_t>(buf[i] ^ (1u << (rng() % 8)));
    if (n > 0 && connected) deliver(std::span{buf}.first(n), emulator_baud, client.baud(), [&](auto b) {
      client.on_rx(b, now);
    });
    ScanTelegram s;
    ScanArrival a;
    while (client.take_scan(s, a)) on_scan(s, a);
  }

  // Runs until `done` or `limit` of simulated time; returns whether `done` became true.
  bool run_until(const std::function<bool()>& done, Duration limit) {
    const Time end = now + limit;
    while (now < end) {
      if (done()) return true;
      step();
    }
    return done();
  }
  void run_for(Duration d) { run_until([] { return false; }, d); }

  void on_scan(const ScanTelegram& s, const ScanArrival& a) {
    ++scans;
    last_scan = s;
    last_arrival = a;
    // The scan is the sweep the emulator measured: find it by its ranges and check every beam.
    const Time sweep_end = a.sweep_end_estimate();
    // Back-dating by the transmission time recovers the sweep end to within one simulation step.
    const SweepTiming* match = nullptr;
    for (const auto& sw : ranges.sweeps)
      if (sw.sweep_end <= sweep_end + 2 * kStep && sweep_end <= sw.sweep_end + 3 * kStep + late_send_allowance)
        match = &sw;
    if (match != nullptr) {
      const Duration err = sweep_end - match->sweep_end;
      max_backdate_error = std::max(max_backdate_error, err < Duration{0} ? -err : err);
    }
    if (match == nullptr) {
      if (std::getenv("LMS_DEBUG") != nullptr) {
        std::fprintf(stderr, "unmatched: last_byte %lld est %lld bytes %d baud %u; sweeps:", (long long)a.last_byte.ns() / 1000,
                     (long long)sweep_end.ns() / 1000, a.telegram_bytes, a.baud);
        for (const auto& sw : ranges.sweeps) if ((sweep_end - sw.sweep_end) < 1s && (sw.sweep_end - sweep_end) < 1s) std::fprintf(stderr, " %lld", (long long)sw.sweep_end.ns() / 1000);
        std::fprintf(stderr, "\n");
      }
      ++unmatched;
      return;
    }
    for (std::size_t i = 0; i < s.count; ++i)
      if (s.ranges_mm[i] != TestRanges::expected_mm(match->sweep_end, i)) ++range_mismatches;
  }

  // This harness moves bytes instantly, so the emulator paces its own output.
  static LmsEmulatorOptions paced(LmsEmulatorOptions o) {
    o.pace_output = true;
    return o;
  }

  static void deliver(std::span<const std::uint8_t> bytes, std::uint32_t from, std::uint32_t to,
                      const std::function<void(std::span<const std::uint8_t>)>& rx) {
    if (from == to) {
      rx(bytes);
      return;
    }
    std::vector<std::uint8_t> garbled(bytes.begin(), bytes.end());
    for (auto& b : garbled) b = static_cast<std::uint8_t>(~b);  // wrong rate: framing garbage
    rx(garbled);
  }

  static constexpr Duration kStep = 1ms;
  Time now = Time::from_seconds(1000.0);
  TestRanges ranges;
  LmsEmulator emulator;
  LmsClient client;
  bool connected = true;
  bool corrupt_next_command = false;
  double noise_rate = 0.0;  // per byte from the scanner: one bit flipped
  std::mt19937 rng{42};
  std::uniform_real_distribution<double> noise{0.0, 1.0};
  // On a link slower than the mirror a scan waits for the line after its sweep ended (emulator rule).
  Duration late_send_allowance = 0ms;
  int scans = 0;
  int unmatched = 0;
  int range_mismatches = 0;
  Duration max_backdate_error{0};
  ScanTelegram last_scan{};
  ScanArrival last_arrival{};
};

LmsClientOptions fast_client(std::uint32_t baud = 500000, LaserVariant v = {180, 50}) {
  LmsClientOptions o;
  o.target_baud = baud;
  o.variant = v;
  o.units = Unit::mm;
  return o;
}

TEST(LmsClient, FullBringUpTo500kHalfDegreeMillimetres) {
  Bench b{{}, fast_client()};
  EXPECT_EQ(b.emulator.units(), 0);  // the scanner starts in cm
  b.client.start(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 10s)) << b.client.state_name();
  EXPECT_EQ(b.emulator.baud(), 500000u);
  EXPECT_EQ(b.client.baud(), 500000u);
  EXPECT_EQ(b.emulator.variant(), (LaserVariant{180, 50}));
  EXPECT_EQ(b.emulator.units(), 1);
  EXPECT_EQ(b.emulator.config().size(), kConfigBytes);
  EXPECT_TRUE(b.emulator.streaming());
  EXPECT_EQ(b.client.statistics().baud_switches, 1u);
  EXPECT_EQ(b.client.statistics().bringups, 1u);

  b.run_for(2s);
  // 0.5° = two mirror revolutions per scan: 37.5 scans/s, and 500 kBd carries them all (§2.10).
  EXPECT_GE(b.scans, 74);
  EXPECT_LE(b.scans, 76);
  EXPECT_EQ(b.unmatched, 0);
  EXPECT_EQ(b.range_mismatches, 0);
  EXPECT_EQ(b.last_scan.count, 361);
  EXPECT_EQ(b.last_scan.unit, Unit::mm);
  EXPECT_EQ(b.last_arrival.telegram_bytes, 732);
  EXPECT_EQ(b.emulator.statistics().scans_skipped, 0u);
  EXPECT_EQ(b.client.parser_statistics().bad_crc, 0u);
  // Back-dating the last byte by the 14.64 ms transmission time finds the sweep end to within the
  // 1 ms at which this simulated line hands bytes over (a reader cannot see when, inside one read,
  // a telegram's last byte came if the line then went idle) plus one byte time.
  EXPECT_LE(b.max_backdate_error, Bench::kStep + 20us);
}

TEST(LmsClient, EveryVariantStreamsItsBeamCount) {
  for (const LaserVariant v : {LaserVariant{180, 100}, LaserVariant{180, 50}, LaserVariant{100, 25},
                               LaserVariant{100, 50}, LaserVariant{100, 100}}) {
    Bench b{{}, fast_client(500000, v)};
    b.client.start(b.now);
    ASSERT_TRUE(b.run_until([&] { return b.scans >= 3; }, 10s)) << v.fov_deg << "/" << v.resolution_cdeg;
    EXPECT_EQ(b.last_scan.count, v.beams());
    EXPECT_EQ(b.range_mismatches, 0);
  }
}

TEST(LmsClient, SlowLinkSendsTheNewestScanWhenTheLineIsFree) {
  Bench b{{}, fast_client(38400, {180, 50})};
  b.late_send_allowance = 2 * kLmsRevolution;  // one 0.5° scan period
  b.client.start(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 10s));
  const int before = b.scans;
  b.run_for(4s);
  // 732 bytes at 38400 take 190.6 ms; a scan completes every 26.7 ms: each telegram waits for the
  // next completed sweep after the line frees, so 1/(190.6 + <=26.7 ms) ≈ 4.6–5.2 scans/s.
  const int per_4s = b.scans - before;
  EXPECT_GE(per_4s, 18);
  EXPECT_LE(per_4s, 21);
  EXPECT_GT(b.emulator.statistics().scans_skipped, 0u);
  EXPECT_EQ(b.range_mismatches, 0);
  EXPECT_EQ(b.unmatched, 0);
}

TEST(LmsClient, ProbesTheRateOfAScannerLeftStreamingAt38400) {
  LmsEmulatorOptions eo;
  eo.power_up_baud = 38400;  // as if a crashed driver left it there (§6)
  Bench b{eo, fast_client()};
  // Put the scanner into continuous mode behind the client's back.
  std::array<std::uint8_t, 16> cmd{};
  const auto n = build_start_continuous(cmd);
  b.emulator.on_rx(std::span{cmd}.first(n), b.now);
  b.run_for(200ms);
  ASSERT_TRUE(b.emulator.streaming());
  b.client.start(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming() && b.scans > 0; }, 20s)) << b.client.state_name();
  EXPECT_EQ(b.emulator.baud(), 500000u);
  EXPECT_GE(b.client.statistics().probe_rounds, 1u);
}

TEST(LmsClient, WaitsForThePowerOnTelegram) {
  LmsEmulatorOptions eo;
  eo.send_power_on = true;
  eo.power_on_delay = 5s;
  LmsClientOptions co = fast_client();
  co.wait_for_power_on = true;
  Bench b{eo, co};
  b.client.start(b.now);
  b.run_for(4s);
  EXPECT_EQ(b.client.state(), LmsClientState::waiting_power_on);
  EXPECT_EQ(b.client.statistics().probe_rounds, 0u);
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 5s)) << b.client.state_name();
  EXPECT_EQ(b.client.statistics().probe_rounds, 0u);  // the 0x90 started the bring-up
}

TEST(LmsClient, RecoversFromAResetCommandSeenAs0x91Then0x90) {
  LmsEmulatorOptions eo;
  eo.reset_delay = 2s;
  Bench b{eo, fast_client()};
  b.client.start(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 10s));
  // Another program (or a watchdog) resets the scanner: it answers 0x91 at 500k, then 0x90 at 9600.
  std::array<std::uint8_t, 16> cmd{};
  const auto n = build_reset(cmd);
  b.emulator.on_rx(std::span{cmd}.first(n), b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.state() == LmsClientState::waiting_reset; }, 1s))
      << b.client.state_name();
  EXPECT_EQ(b.client.baud(), 9600u);
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 10s)) << b.client.state_name();
  EXPECT_EQ(b.client.statistics().bringups, 2u);
  EXPECT_GE(b.client.statistics().scanner_resets, 1u);
  EXPECT_EQ(b.emulator.baud(), 500000u);
  EXPECT_EQ(b.emulator.units(), 1);  // the reset restored cm; the bring-up set mm again
  const int before = b.scans;
  b.run_for(500ms);
  EXPECT_GT(b.scans, before);
}

TEST(LmsClient, RecoversFromASpontaneousRestartThroughSilence) {
  LmsEmulatorOptions eo;
  eo.reset_delay = 3s;
  Bench b{eo, fast_client()};
  b.client.start(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 10s));
  b.emulator.spontaneous_reset(b.now);  // power glitch: no 0x91, silence, then 0x90 at 9600
  ASSERT_TRUE(b.run_until([&] { return b.client.statistics().silences > 0; }, 1s));
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 20s)) << b.client.state_name();
  EXPECT_EQ(b.client.statistics().bringups, 2u);
  EXPECT_EQ(b.emulator.baud(), 500000u);
}

TEST(LmsClient, SilenceThenLineBackReprobesAndStreamsAgain) {
  Bench b{{}, fast_client()};
  b.client.start(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 10s));
  b.connected = false;
  b.run_for(2s);
  EXPECT_GE(b.client.statistics().silences, 1u);
  EXPECT_FALSE(b.client.streaming());
  b.connected = true;
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 20s)) << b.client.state_name();
  const int before = b.scans;
  b.run_for(500ms);
  EXPECT_GT(b.scans, before);
  EXPECT_EQ(b.range_mismatches, 0);
}

TEST(LmsClient, DeviceLostAndBack) {
  Bench b{{}, fast_client()};
  b.client.start(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 10s));
  b.connected = false;
  b.client.on_device_lost(b.now);
  EXPECT_EQ(b.client.state(), LmsClientState::device_lost);
  b.run_for(3s);
  EXPECT_EQ(b.client.state(), LmsClientState::device_lost);  // no probing into a missing device
  b.connected = true;
  b.client.on_device_back(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 10s)) << b.client.state_name();
  EXPECT_EQ(b.client.statistics().device_losses, 1u);
  EXPECT_EQ(b.client.statistics().bringups, 2u);
}

TEST(LmsClient, ShutdownStopsTheStreamAndReturnsTo9600) {
  Bench b{{}, fast_client()};
  b.client.start(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 10s));
  b.run_for(300ms);
  b.client.shutdown(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.state() == LmsClientState::stopped; }, 5s)) << b.client.state_name();
  b.run_for(100ms);
  EXPECT_FALSE(b.emulator.streaming());
  EXPECT_EQ(b.emulator.baud(), 9600u);
  EXPECT_EQ(b.client.baud(), 9600u);
  // A new client finds it at the default rate on the first probe.
  LmsClient again{fast_client()};
  b.client.shutdown(b.now);
  EXPECT_EQ(b.client.state(), LmsClientState::stopped);
}

TEST(LmsClient, WritesBackThe34ByteBlockOfNewerFirmware) {
  LmsEmulatorOptions eo;
  eo.config_bytes = 34;
  Bench b{eo, fast_client()};
  b.client.start(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 10s)) << b.client.last_error();
  EXPECT_EQ(b.client.device_config().size(), 34u);
  EXPECT_EQ(b.emulator.units(), 1);
}

TEST(LmsClient, SkipsSetupModeWhenTheConfigIsAlreadyRight) {
  LmsEmulatorOptions eo;
  eo.units = 1;
  eo.write_config_delay = 3s;
  Bench b{eo, fast_client()};
  b.client.start(b.now);
  // With a 3 s write the bring-up would take > 3 s if it wrote; it must not need to.
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 2s)) << b.client.state_name();
}

TEST(LmsClient, WaitsForASlowConfigWrite) {
  LmsEmulatorOptions eo;
  eo.write_config_delay = 3s;
  Bench b{eo, fast_client()};
  b.client.start(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.state() == LmsClientState::writing_config; }, 5s));
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 10s)) << b.client.state_name();
  EXPECT_EQ(b.client.statistics().timeouts, 0u);
}

TEST(LmsClient, RefusedVariantIsReportedAndRetried) {
  Bench b{{}, fast_client(500000, {180, 25})};  // not a variant of the LMS (§2.5)
  b.client.start(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.statistics().refused > 0; }, 10s));
  EXPECT_STREQ(b.client.last_error(), "variant refused");
  EXPECT_EQ(b.client.state(), LmsClientState::backoff);
  EXPECT_FALSE(b.client.streaming());
}

TEST(LmsClient, WrongPasswordIsRefused) {
  LmsClientOptions co = fast_client();
  co.password = "WRONG_PW";
  Bench b{{}, co};
  b.client.start(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.statistics().refused > 0; }, 10s));
  EXPECT_STREQ(b.client.last_error(), "setup mode refused (password)");
}

TEST(LmsClient, RealtimeIndexAndStatusByteArePassedThrough) {
  LmsClientOptions co = fast_client(500000, {180, 100});
  co.realtime_index = true;
  Bench b{{}, co};
  b.client.start(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.scans >= 2; }, 10s));
  ASSERT_TRUE(b.last_scan.realtime_index.has_value());
  EXPECT_EQ(b.last_arrival.telegram_bytes, 373);  // 372 + the index byte
  EXPECT_EQ(b.last_scan.status.raw, kHealthyStatus);
}

TEST(LmsClient, ScansWithAnErrorStatusAreDropped) {
  LmsEmulatorOptions eo;
  eo.status_byte = 0x13;  // class 3 = error (§2.9)
  Bench b{eo, fast_client()};
  b.client.start(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 10s));
  b.run_for(1s);
  EXPECT_EQ(b.scans, 0);
  EXPECT_GT(b.client.statistics().scans_bad_status, 30u);
}

TEST(LmsClient, NakedCommandIsSentAgain) {
  Bench b{{}, fast_client()};
  b.corrupt_next_command = true;  // the first probe arrives with a bad CRC -> NAK
  b.client.start(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 10s)) << b.client.state_name();
  EXPECT_EQ(b.emulator.statistics().naks_sent, 1u);
  EXPECT_GE(b.client.statistics().naks, 1u);
}

TEST(LmsClient, NoisyLineDeliversOnlyIntactScans) {
  Bench b{{}, fast_client()};
  b.client.start(b.now);
  ASSERT_TRUE(b.run_until([&] { return b.client.streaming(); }, 10s));
  b.noise_rate = 1e-4;  // ~7 % of 732-byte telegrams hit
  b.run_for(10s);
  EXPECT_GT(b.client.parser_statistics().bad_crc, 0u);
  EXPECT_EQ(b.range_mismatches, 0);  // a corrupted scan is never delivered
  EXPECT_EQ(b.unmatched, 0);
  EXPECT_GT(b.scans, 300);           // the rest keep coming (375 sent)
  EXPECT_TRUE(b.client.streaming());
}

TEST(LmsClient, StateNamesAreDistinct) {
  EXPECT_STREQ(to_string(LmsClientState::streaming), "streaming");
  EXPECT_STREQ(to_string(LmsClientState::waiting_power_on), "waiting_power_on");
  EXPECT_STREQ(to_string(LmsClientState::device_lost), "device_lost");
}

}  // namespace
}  // namespace teamscan::lms200
