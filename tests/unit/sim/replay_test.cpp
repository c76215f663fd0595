// The data set agrees with the captures: replaying each robot's recorded serial sessions (through the
// capture text format) into fresh driver clients reproduces its points exactly.
#include <gtest/gtest.h>

#include <cstdlib>

#include "sim/replay.hpp"
#include "sim/simulator.hpp"

namespace teamscan::sim {
namespace {

Scenario load(const char* name) {
  const char* src = std::getenv("TEAMSCAN_SOURCE_DIR");
  const ScenarioLoad l = load_scenario_file(std::string{src ? src : "."} + "/sim/scenarios/" + name + ".toml");
  if (!l.scenario) {
    ADD_FAILURE() << l.error;
    return {};
  }
  return *l.scenario;
}

void expect_replay_reproduces(const char* name, double duration_s) {
  const Scenario sc = load(name);
  SimOptions o;
  o.duration_s = duration_s;
  const SimOutput out = simulate(sc, o);
  ASSERT_EQ(out.captures.size(), sc.robots.size());
  for (std::size_t ri = 0; ri < sc.robots.size(); ++ri) {
    const RobotCaptures& rc = out.captures[ri];
    EXPECT_TRUE(rc.arcos_connected && rc.lms_streaming) << name << " robot " << int(rc.id);
    // Through the file format, as a user's replay would read them.
    const Result<Capture> arcos = parse_capture(format_capture(rc.arcos));
    const Result<Capture> lms = parse_capture(format_capture(rc.lms200));
    ASSERT_TRUE(arcos.ok() && lms.ok());
    EXPECT_EQ(lms->device, DeviceKind::lms200);

    std::vector<LabelledPoint> expected;
    for (const LabelledPoint& p : out.dataset.points)
      if (p.robot == rc.id) expected.push_back(p);
    ASSERT_FALSE(expected.empty());

    std::size_t k = 0, mismatches = 0;
    std::uint32_t scan_index = 0;
    const ReplayStats stats = replay_robot(*arcos, *lms, sc.robots[ri], out.dataset.robots[ri].registration,
                                           Time::from_ns(rc.start_ns), [&](const ReceivedScan& rs) {
      const ScanPoints& pts = *rs.points;
      if (pts.stamp.ns() < sc.start_time_ns) return;  // bring-up scans are not in the data set
      for (std::uint16_t i = 0; i < pts.count; ++i) {
        const ScanPoint& sp = pts.points[i];
        if (sp.flags & kPointUnplaced) continue;
        if (k >= expected.size()) {
          ++mismatches;
          continue;
        }
        const LabelledPoint& e = expected[k++];
        const bool same = e.scan == scan_index && e.beam == sp.beam && e.x == static_cast<float>(sp.x_mm * 1e-3) &&
                          e.y == static_cast<float>(sp.y_mm * 1e-3) && e.z == static_cast<float>(sp.z_mm * 1e-3);
        if (!same && mismatches++ < 5)
          ADD_FAILURE() << name << " robot " << int(rc.id) << " point " << k - 1 << ": scan " << e.scan << "/" << scan_index
                        << " beam " << e.beam << "/" << sp.beam << " x " << e.x << "/" << sp.x_mm;
      }
      ++scan_index;
    });
    EXPECT_EQ(k, expected.size()) << name << " robot " << int(rc.id);
    EXPECT_EQ(mismatches, 0u);
    EXPECT_GT(stats.sips, 0u);
    std::printf("[%s] robot %d: replayed %llu rx chunks, %llu scans, %zu points identical\n", name, rc.id,
                static_cast<unsigned long long>(stats.rx_chunks), static_cast<unsigned long long>(stats.scans), k);
  }
}

TEST(Replay, CapturesReproduceThePointsOfLap2) { expect_replay_reproduces("lap2", 8.0); }
TEST(Replay, CapturesReproduceThePointsOfTeam3) { expect_replay_reproduces("team3", 6.0); }

TEST(Replay, CapturesBeginWithTheBringUp) {
  SimOptions o;
  o.duration_s = 1.0;
  const SimOutput out = simulate(load("lap2"), o);
  ASSERT_FALSE(out.captures.empty());
  // The host's first LMS telegram is a status request 0x31 at 9600 baud (PROTOCOLS.md §2.11 step 1):
  // 02 00 01 00 31 and the SICK CRC 15 12 (§3.2).
  const std::vector<std::uint8_t> tx = out.captures[0].lms200.bytes(CaptureDirection::tx);
  ASSERT_GE(tx.size(), 7u);
  EXPECT_EQ(std::vector<std::uint8_t>(tx.begin(), tx.begin() + 7), (std::vector<std::uint8_t>{0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12}));
  // The ARCOS session starts with SYNC0 FA FB 03 00 00 00 (§1.4).
  const std::vector<std::uint8_t> arcos_tx = out.captures[0].arcos.bytes(CaptureDirection::tx);
  ASSERT_GE(arcos_tx.size(), 6u);
  EXPECT_EQ(std::vector<std::uint8_t>(arcos_tx.begin(), arcos_tx.begin() + 6), (std::vector<std::uint8_t>{0xFA, 0xFB, 0x03, 0x00, 0x00, 0x00}));
  // Baud changes are recorded: the LMS link ends up at the scenario's 500 kBd.
  bool saw_500k = false;
  for (const CaptureRecord& r : out.captures[0].lms200.records) saw_500k |= r.kind == CaptureRecord::Kind::baud && r.baud == 500000;
  EXPECT_TRUE(saw_500k);
}

}  // namespace
}  // namespace teamscan::sim
