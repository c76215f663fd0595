// Hardware-in-loop test of the store and forward (onboard/ring, docs/onboard.md "The ring"): the real
// teamscan-onboard against emulated devices on pseudo-terminals and a stand-in ground station on loopback
// DDS that stores what it receives and confirms it on teamscan/stored. The station goes silent (a radio
// shadow: it neither receives nor confirms), the daemon is SIGKILLed in the middle of the shadow and
// restarted, the station comes back: the restarted daemon continues the numbering and back-fills every
// scan of the shadow from its ring on teamscan/backfill, identical to what it had published live.
// Then the whole chain with the real teamscan-groundstation: two robots, the station SIGKILLed for 8 s
// and restarted on its session folder, one robot SIGKILLed and restarted in the middle of that shadow:
// the session ends with every scan of each robot stored exactly once (0 lost, 0 duplicates).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "common/clock.hpp"
#include "dds/qos.hpp"
#include "dds/topics.hpp"
#include "drivers/arcos/emulator.hpp"
#include "drivers/lms200/emulator.hpp"
#include "drivers/serial/pty_runner.hpp"
#include "groundstation/station/session_replay.hpp"
#include "teamscan.h"
#include "tests/hil/onboard/daemon_process.hpp"
#include "tests/support/dds_test_subscriber.hpp"

namespace teamscan {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

using test::daemon_path;
using test::file_text;
using test::station_path;
using test::TempDir;

// Every beam a range that changes with the sweep, so two scans differ.
class SweepRanges final : public lms200::RangeSource {
 public:
  void measure(const lms200::SweepTiming& sweep, std::span<lms200::BeamReading> beams) override {
    ++sweeps_;
    for (std::size_t i = 0; i < sweep.variant.beams() && i < beams.size(); ++i)
      beams[i] = {static_cast<std::uint32_t>(1000 + (i * 37 + sweeps_ * 11) % 5000), 0, lms200::BeamInvalid::none};
  }

 private:
  std::uint64_t sweeps_ = 0;
};

// Appends to the log: a restarted process writes after the first one.
pid_t spawn(const std::vector<std::string>& args, const fs::path& log_file) {
  return test::spawn(args, {}, log_file, true);
}

// A scan as the test compares it: stamp and points.
struct Seen {
  std::int64_t stamp_ns = 0;
  std::vector<std::int32_t> xyz;
  bool operator==(const Seen&) const = default;
};
Seen seen_of(const teamscan_msg_ScanPoints& s) {
  Seen v;
  v.stamp_ns = s.stamp_ns;
  for (std::uint16_t i = 0; i < s.count; ++i) {
    v.xyz.push_back(s.points[i].x_mm);
    v.xyz.push_back(s.points[i].y_mm);
    v.xyz.push_back(s.points[i].z_mm);
  }
  return v;
}

// The ground station as far as store and forward goes: reads teamscan/scan and teamscan/backfill, stores
// (here: keeps) each seq once, and publishes the highest contiguous seq on teamscan/stored.
class StationStandIn {
 public:
  explicit StationStandIn(dds_domainid_t domain)
      : live_{&teamscan_msg_ScanPoints_desc, dds::kTopicScan, scan_qos(), 256, domain},
        backfill_{&teamscan_msg_ScanPoints_desc, dds::kTopicBackfill, scan_qos(), 256, domain} {
    participant_ = dds_create_participant(domain, nullptr, nullptr);
    const dds_entity_t topic =
        dds_create_topic(participant_, &teamscan_msg_StoredState_desc, dds::kTopicStored, nullptr, nullptr);
    dds_qos_t* q = dds::make_team_writer_qos(std::chrono::seconds(2));
    writer_ = dds_create_writer(participant_, topic, q, nullptr);
    dds_delete_qos(q);
  }
  ~StationStandIn() { dds_delete(participant_); }
  bool ok() const { return live_.ok() && backfill_.ok() && writer_ > 0; }

  // Takes what arrived. In the shadow (`reachable` false) the live scans are taken and thrown away, as a
  // radio link that drops them would, but remembered as `published` for the comparison.
  void poll(bool reachable) {
    std::vector<teamscan_msg_ScanPoints> got;
    live_.take_available(got);
    for (const auto& s : got) {
      published[s.seq] = seen_of(s);
      if (reachable) store(s);
    }
    got.clear();
    backfill_.take_available(got);
    for (const auto& s : got) {
      backfilled[s.seq] = seen_of(s);
      if (reachable) store(s);
    }
    if (!reachable) return;
    teamscan_msg_StoredState st{};
    st.seq = ++seq_;
    st.stamp_ns = now_realtime().ns();
    st.count = 1;
    st.robots[0].robot_id = 5;
    st.robots[0].first_seq = first_;
    st.robots[0].contiguous_seq = contiguous;
    st.robots[0].stored = static_cast<std::uint32_t>(stored_.size());
    (void)dds_write(writer_, &st);
  }

  std::map<std::uint32_t, Seen> published, backfilled;
  std::uint32_t contiguous = 0;
  std::uint64_t duplicates = 0;

 private:
  static dds_qos_t* scan_qos() {
    static dds_qos_t* q = dds::make_scan_reader_qos();
    return q;
  }
  void store(const teamscan_msg_ScanPoints& s) {
    if (!stored_.emplace(s.seq, seen_of(s)).second) {
      ++duplicates;
      return;
    }
    if (first_ == 0) {
      first_ = s.seq;
      contiguous = s.seq;
    }
    while (stored_.count(contiguous + 1) != 0) ++contiguous;
  }
  test::DdsTestSubscriber<teamscan_msg_ScanPoints> live_, backfill_;
  dds_entity_t participant_ = 0, writer_ = 0;
  std::map<std::uint32_t, Seen> stored_;
  std::uint32_t first_ = 0, seq_ = 0;
};

TEST(RingHil, SigkillInAShadowLosesNothingItHadWritten) {
  TempDir dir{"teamscan-ring"};
  const fs::path arcos_link = dir.path / "ttyArcos", lms_link = dir.path / "ttyLms";
  const auto domain = static_cast<dds_domainid_t>(100 + (::getpid() + 37) % 100);

  arcos::PioneerEmulator pioneer;
  SweepRanges ranges;
  lms200::LmsEmulatorOptions lms_options;
  lms_options.variant = LaserVariant{180, 50};
  lms200::LmsEmulator scanner{lms_options, &ranges};
  scanner.power_up(now_monotonic());
  auto arcos_runner = serial::PtyRunner::create(pioneer, serial::PtyRunnerOptions{.link_path = arcos_link.string()});
  ASSERT_TRUE(arcos_runner.ok()) << arcos_runner.error().what;
  auto lms_runner = serial::PtyRunner::create(scanner, serial::PtyRunnerOptions{.link_path = lms_link.string()});
  ASSERT_TRUE(lms_runner.ok()) << lms_runner.error().what;
  ASSERT_TRUE((*arcos_runner)->start().ok());
  ASSERT_TRUE((*lms_runner)->start().ok());

  // The live writer keeps 20 scans for a returning station; the ring back-fills the older ones.
  std::ofstream(dir.path / "onboard.toml") << "[robot]\nid = 5\n"
                                           << "[arcos]\ndevice = \"" << arcos_link.string() << "\"\n"
                                           << "[lms]\ndevice = \"" << lms_link.string() << "\"\n"
                                           << "[mount]\nx_m = 0.16\ny_m = 0\nz_m = 0.45\npitch_deg = 15\n"
                                           << "[status]\nperiod_s = 0.2\n"
                                           << "[dds]\ndomain = " << domain << "\nscan_history_depth = 20\n"
                                           << "[ring]\npath = \"" << (dir.path / "ring.bin").string() << "\"\n"
                                           << "capacity_s = 120\nflush_records = 75\nflush_period_s = 0.5\n"
                                           << "backfill_rate_hz = 300\n";
  StationStandIn station{domain};
  ASSERT_TRUE(station.ok());
  const fs::path log = dir.path / "daemon.log";
  const std::vector<std::string> argv{daemon_path(), "--config", (dir.path / "onboard.toml").string()};
  pid_t pid = spawn(argv, log);
  ASSERT_GT(pid, 0);
  struct KillOnExit {
    pid_t* pid;
    ~KillOnExit() {
      int st = 0;
      if (*pid > 0 && ::waitpid(*pid, &st, WNOHANG) == 0) {
        ::kill(*pid, SIGKILL);
        ::waitpid(*pid, &st, 0);
      }
    }
  } kill_on_exit{&pid};

  auto run_for = [&](std::chrono::milliseconds d, bool reachable, const std::function<bool()>& until = {}) {
    const auto end = Clock::now() + d;
    while (Clock::now() < end) {
      station.poll(reachable);
      if (until && until()) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  };
  // In contact: the station stores and confirms the live scans.
  ASSERT_TRUE(run_for(std::chrono::seconds(30), true, [&] { return station.contiguous >= 150; })) << file_text(log);
  const std::uint32_t confirmed_before = station.contiguous;
  // The shadow: 4 s without contact (the robot's reachable_timeout is 3 s), then SIGKILL in the middle of it.
  run_for(std::chrono::seconds(4), false);
  ::kill(pid, SIGKILL);
  int st = 0;
  ::waitpid(pid, &st, 0);
  pid = 0;
  run_for(std::chrono::milliseconds(300), false);  // what was in flight
  ASSERT_FALSE(station.published.empty());
  const std::uint32_t last_before_kill = station.published.rbegin()->first;
  ASSERT_GT(last_before_kill, confirmed_before + 100) << "the shadow should hold more than 100 scans";

  // Restarted, still in the shadow for 2 s, then the station is back.
  pid = spawn(argv, log);
  ASSERT_GT(pid, 0);
  run_for(std::chrono::seconds(2), false);
  const bool whole =
      run_for(std::chrono::seconds(40), true, [&] { return station.contiguous > last_before_kill + 50; });
  ASSERT_TRUE(whole) << "contiguous " << station.contiguous << " of " << last_before_kill << "\n" << file_text(log);

  // Nothing published before the kill is missing: every scan of the shadow came back through the ring,
  // identical to its live copy.
  std::size_t compared = 0;
  for (std::uint32_t seq = confirmed_before + 1; seq <= last_before_kill; ++seq) {
    const auto live = station.published.find(seq);
    const auto back = station.backfilled.find(seq);
    ASSERT_NE(back, station.backfilled.end()) << "scan " << seq << " was not back-filled";
    if (live != station.published.end()) {
      EXPECT_EQ(back->second, live->second) << "scan " << seq;
      ++compared;
    }
  }
  EXPECT_GT(compared, 100u);
  // The restarted daemon continued the numbering: no seq after the kill repeats one from before it.
  const std::string text = file_text(log);
  EXPECT_NE(text.find("recovered"), std::string::npos) << text;
  EXPECT_NE(text.find("back-filling"), std::string::npos) << text;
  std::uint32_t first_after = 0;
  for (const auto& [seq, seen] : station.published)
    if (seq > last_before_kill) {
      first_after = seq;
      break;
    }
  EXPECT_GT(first_after, last_before_kill);
  // A back-filled scan the station already had (a race with a confirmation on its way) is only counted.
  std::printf("shadow %u..%u back-filled; %zu back-filled in all, %llu duplicates at the station\n",
              confirmed_before + 1, last_before_kill, station.backfilled.size(),
              static_cast<unsigned long long>(station.duplicates));
  ::kill(pid, SIGTERM);
  ::waitpid(pid, &st, 0);
  pid = 0;
  EXPECT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 0) << text;
}

}  // namespace
}  // namespace teamscan

namespace teamscan {
namespace {

// One robot: an emulated Pioneer and LMS-200 on ptys and its teamscan-onboard config with a ring.
struct RobotRig {
  arcos::PioneerEmulator pioneer;
  SweepRanges ranges;
  lms200::LmsEmulator scanner{[] {
                                lms200::LmsEmulatorOptions o;
                                o.variant = LaserVariant{180, 50};
                                return o;
                              }(),
                              &ranges};
  std::unique_ptr<serial::PtyRunner> arcos, lms;
  fs::path config, log;
  pid_t pid = 0;

  bool start(const fs::path& dir, std::uint32_t id, dds_domainid_t domain) {
    scanner.power_up(now_monotonic());
    const fs::path arcos_link = dir / ("ttyArcos" + std::to_string(id)),
                   lms_link = dir / ("ttyLms" + std::to_string(id));
    auto a = serial::PtyRunner::create(pioneer, serial::PtyRunnerOptions{.link_path = arcos_link.string()});
    auto l = serial::PtyRunner::create(scanner, serial::PtyRunnerOptions{.link_path = lms_link.string()});
    if (!a.ok() || !l.ok()) return false;
    arcos = std::move(a.value());
    lms = std::move(l.value());
    if (!arcos->start().ok() || !lms->start().ok()) return false;
    config = dir / ("robot" + std::to_string(id) + ".toml");
    log = dir / ("robot" + std::to_string(id) + ".log");
    std::ofstream(config) << "[robot]\nid = " << id << "\n"
                          << "[arcos]\ndevice = \"" << arcos_link.string() << "\"\n"
                          << "[lms]\ndevice = \"" << lms_link.string() << "\"\n"
                          << "[mount]\nx_m = 0.16\ny_m = 0\nz_m = 0.45\npitch_deg = 15\n"
                          << "[status]\nperiod_s = 0.2\n"
                          << "[dds]\ndomain = " << domain << "\nscan_history_depth = 50\n"
                          << "[ring]\npath = \"" << (dir / ("ring" + std::to_string(id) + ".bin")).string() << "\"\n"
                          << "capacity_s = 120\nbackfill_rate_hz = 300\n";
    run();
    return pid > 0;
  }
  void run() { pid = spawn({daemon_path(), "--config", config.string()}, log); }
  void signal(int sig) {
    if (pid <= 0) return;
    int st = 0;
    ::kill(pid, sig);
    ::waitpid(pid, &st, 0);
    pid = 0;
  }
  ~RobotRig() { signal(SIGKILL); }
};

TEST(RingHil, StationDownAndARobotKilledInTheShadowLoseNoScan) {
  TempDir dir{"teamscan-ring"};
  const auto domain = static_cast<dds_domainid_t>(100 + (::getpid() + 71) % 100);
  const fs::path session = dir.path / "session";
  const fs::path station_log = dir.path / "station.log";
  std::ofstream(dir.path / "station.toml") << "[ros2]\nenabled = false\n[view]\nlisten = \"\"\n";
  const std::vector<std::string> station_argv{
      station_path(),        "--config",       (dir.path / "station.toml").string(),
      "--session-dir",       session.string(), "--domain",
      std::to_string(domain)};
  pid_t station = spawn(station_argv, station_log);
  ASSERT_GT(station, 0);
  struct Stop {
    pid_t* pid;
    ~Stop() {
      int st = 0;
      if (*pid > 0) {
        ::kill(*pid, SIGKILL);
        ::waitpid(*pid, &st, 0);
      }
    }
  } stop_station{&station};
  RobotRig r1, r2;
  ASSERT_TRUE(r1.start(dir.path, 1, domain));
  ASSERT_TRUE(r2.start(dir.path, 2, domain));

  // The operator's view: teamscan/status of both robots.
  dds_qos_t* sq = dds::make_state_reader_qos();
  test::DdsTestSubscriber<teamscan_msg_RobotStatus> status{&teamscan_msg_RobotStatus_desc, dds::kTopicStatus, sq, 64,
                                                           domain};
  dds_delete_qos(sq);
  ASSERT_TRUE(status.ok());
  std::map<std::uint32_t, teamscan_msg_RobotStatus> last;
  std::uint32_t max_shadow_ms[3] = {0, 0, 0}, max_unconfirmed[3] = {0, 0, 0};
  auto watch = [&](std::chrono::milliseconds d, const std::function<bool()>& until = {}) {
    const auto end = Clock::now() + d;
    while (Clock::now() < end) {
      std::vector<teamscan_msg_RobotStatus> got;
      status.take_available(got);
      for (const auto& st : got) {
        if (st.robot_id < 1 || st.robot_id > 2) continue;
        last[st.robot_id] = st;
        max_shadow_ms[st.robot_id] = std::max(max_shadow_ms[st.robot_id], st.shadow_ms);
        max_unconfirmed[st.robot_id] = std::max(max_unconfirmed[st.robot_id], st.ring_unconfirmed);
      }
      if (until && until()) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  };
  auto confirmed = [&](std::uint32_t id, std::uint32_t seq) {
    return last.count(id) != 0 && last[id].ring_confirmed_seq >= seq && last[id].shadow_ms == 0;
  };
  // In contact: both robots scanning, the station confirming.
  ASSERT_TRUE(watch(std::chrono::seconds(40), [&] { return confirmed(1, 100) && confirmed(2, 100); }))
      << file_text(station_log) << file_text(r1.log);
  // The station dies for 8 s; robot 1's daemon is SIGKILLed 4 s into the shadow and restarted.
  int st = 0;
  ::kill(station, SIGKILL);
  ::waitpid(station, &st, 0);
  station = 0;
  watch(std::chrono::seconds(4));
  r1.signal(SIGKILL);
  r1.run();
  watch(std::chrono::seconds(4));
  EXPECT_GT(max_shadow_ms[2], 3000u);  // the robots said they were in a shadow
  EXPECT_GT(max_unconfirmed[2], 200u);
  station = spawn(station_argv, station_log);
  ASSERT_GT(station, 0);
  // Back in contact: each robot whole again (every scan back to its live window confirmed, no back-fill left).
  // (The robots' newest scans before the station's return must be confirmed: the confirmations moved.)
  const std::uint32_t newest1 = last[1].ring_confirmed_seq + last[1].ring_unconfirmed;
  const std::uint32_t newest2 = last[2].ring_confirmed_seq + last[2].ring_unconfirmed;
  const auto start = Clock::now();
  const bool whole = watch(std::chrono::seconds(60), [&] {
    return confirmed(1, newest1) && confirmed(2, newest2) && last[1].backfill_remaining == 0 &&
           last[2].backfill_remaining == 0 && last[1].ring_unconfirmed < 100 && last[2].ring_unconfirmed < 100;
  });
  std::printf("both robots whole %.1f s after the station's restart\n",
              std::chrono::duration<double>(Clock::now() - start).count());
  ASSERT_TRUE(whole) << "robot 1 unconfirmed " << last[1].ring_unconfirmed << ", robot 2 " << last[2].ring_unconfirmed
                     << "\n"
                     << file_text(station_log);
  // Orderly stop: the robots flush their last scans, the station stores them.
  r1.signal(SIGTERM);
  r2.signal(SIGTERM);
  watch(std::chrono::seconds(2));
  ::kill(station, SIGTERM);
  ::waitpid(station, &st, 0);
  station = 0;

  // The session: per robot every seq from its first to its last, each once.
  std::map<std::uint32_t, std::vector<std::uint32_t>> seqs, pose_seqs;
  station::SessionReadStats stats;
  const Status read = station::replay_session_files(
      session.string(), [&](const station::PoseObservation& p) { pose_seqs[p.robot_id].push_back(p.seq); },
      [&](const ScanPoints& s, const station::Receipt& receipt) {
        if (receipt.rejected == 0) seqs[s.robot_id].push_back(s.seq);
      },
      stats);
  ASSERT_TRUE(read.ok()) << read.error().what;
  // ... and every pose: the 8 s outage held more poses than the live pose writer's history (64, 6.4 s at
  // 10 Hz), the older ones came from the ring on teamscan/backfill_pose.
  for (std::uint32_t id : {1u, 2u}) {
    std::vector<std::uint32_t>& v = pose_seqs[id];
    ASSERT_FALSE(v.empty());
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    const std::uint32_t first = v.front(), last_seq = v.back();
    v.erase(std::unique(v.begin(), v.end()), v.end());
    EXPECT_EQ(n, v.size()) << "robot " << id << ": " << n - v.size() << " poses stored twice";
    std::string holes;
    for (std::size_t i = 1; i < v.size() && holes.size() < 200; ++i)
      if (v[i] != v[i - 1] + 1) holes += " " + std::to_string(v[i - 1] + 1) + ".." + std::to_string(v[i] - 1);
    EXPECT_EQ(v.size(), static_cast<std::size_t>(last_seq - first + 1))
        << "robot " << id << ": pose seq " << first << ".." << last_seq << ", " << (last_seq - first + 1 - v.size())
        << " missing:" << holes;
    std::printf("robot %u: stored %zu poses, seq %u..%u\n", id, n, first, last_seq);
  }
  for (std::uint32_t id : {1u, 2u}) {
    std::vector<std::uint32_t>& v = seqs[id];
    ASSERT_FALSE(v.empty());
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    const std::uint32_t first = v.front(), last_seq = v.back();
    v.erase(std::unique(v.begin(), v.end()), v.end());
    EXPECT_EQ(n, v.size()) << "robot " << id << ": " << n - v.size() << " scans stored twice";
    EXPECT_EQ(v.size(), static_cast<std::size_t>(last_seq - first + 1))
        << "robot " << id << ": seq " << first << ".." << last_seq << ", " << (last_seq - first + 1 - v.size())
        << " missing";
    std::printf("robot %u: stored %zu scans, seq %u..%u, %u missing; shadow up to %.1f s, %u unconfirmed at most\n", id,
                n, first, last_seq, static_cast<unsigned>(last_seq - first + 1 - v.size()), max_shadow_ms[id] / 1000.0,
                max_unconfirmed[id]);
  }
  // The restarted station knew what its session held (events.log): the robots back-filled only its outage.
  const std::string events = file_text(session / "events.log");
  EXPECT_NE(events.find("stored scans from the session folder"), std::string::npos) << events;
}

}  // namespace
}  // namespace teamscan
