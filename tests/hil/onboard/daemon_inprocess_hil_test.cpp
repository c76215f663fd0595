// Hardware-in-loop test of the daemon's event loop in-process, against an emulated Pioneer and LMS-200
// on pseudo-terminals, with a recording Publisher in place of the DDS bridge (it also plays the ground
// station: a teammate 3 m ahead, fresh, and in the second test this robot's odometry correction). Checks
// what reaches the publisher: pose, scan points in the map frame with direction-filter flags, status, the
// "kept" publish mode, and the correction applied. In the third, the writes block for 3 s (a radio link
// going down) behind the daemon's send queue: the loop keeps reading, and every scan the laser sent
// reaches the writer.
#include <gtest/gtest.h>

#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>

#include "common/clock.hpp"
#include "drivers/arcos/emulator.hpp"
#include "drivers/lms200/emulator.hpp"
#include "drivers/serial/pty_runner.hpp"
#include "onboard/daemon/daemon.hpp"
#include "onboard/daemon/send_queue.hpp"

namespace teamscan::onboard {
namespace {

namespace fs = std::filesystem;

struct TempDir {
  fs::path path;
  TempDir() {
    std::string tmpl = (fs::temp_directory_path() / "teamscan-onboard-XXXXXX").string();
    path = ::mkdtemp(tmpl.data());
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

class FlatRanges final : public lms200::RangeSource {
 public:
  void measure(const lms200::SweepTiming& sweep, std::span<lms200::BeamReading> beams) override {
    for (std::size_t i = 0; i < sweep.variant.beams() && i < beams.size(); ++i) beams[i] = {3000, 0, lms200::BeamInvalid::none};
  }
};

// Records what the daemon publishes; offers a fresh team state with one teammate at (x, y) mm and, if
// `own` is a correction, this robot (id 1) as a member with that odometry correction.
class RecordingPublisher final : public Publisher {
 public:
  RecordingPublisher(std::int32_t mate_x_mm, std::int32_t mate_y_mm, OdomCorrection own = {})
      : x_{mate_x_mm}, y_{mate_y_mm}, own_{own} {}
  Status publish_pose(const OnboardPose& p) override {
    std::lock_guard lock{m_};
    pose_ = p;
    ++poses_;
    return ok_status();
  }
  Status publish_scan(const ScanPoints& s) override {
    std::lock_guard lock{m_};
    scan_ = s;
    ++scans_;
    return ok_status();
  }
  Status publish_status(const OnboardStatus& s) override {
    std::lock_guard lock{m_};
    status_ = s;
    ++statuses_;
    return ok_status();
  }
  bool take_team(TeamSnapshot& out) override {
    // A new state on every other poll, as a ground station publishing at ~50 Hz would.
    fresh_ = !fresh_;
    if (!fresh_) return false;
    out.count = 1;
    out.members[0] = TeamMemberState{};
    out.members[0].robot_id = 2;
    out.members[0].x_mm = x_;
    out.members[0].y_mm = y_;
    out.members[0].valid_ns = now_realtime().ns();
    if (!own_.none()) {
      out.count = 2;
      out.members[1] = TeamMemberState{};
      out.members[1].robot_id = 1;
      out.members[1].valid_ns = out.members[0].valid_ns;
      out.members[1].correction = own_;
    }
    return true;
  }
  const char* name() const override { return "recording"; }

  template <class F>
  auto with(F&& f) {
    std::lock_guard lock{m_};
    return f();
  }
  OnboardPose pose_{};
  ScanPoints scan_{};
  OnboardStatus status_{};
  long poses_ = 0, scans_ = 0, statuses_ = 0;

 private:
  std::mutex m_;
  std::int32_t x_, y_;
  OdomCorrection own_;
  bool fresh_ = false;
};

bool wait_until(const std::function<bool()>& pred, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

// The in-process tests' robot: both emulated devices on their links, the 0.5° variant at 500 kBd, a
// level laser 0.16 m ahead, the 7° cone, a status every 0.1 s.
std::string base_config(const fs::path& arcos_link, const fs::path& lms_link) {
  return "[robot]\nid = 1\n[arcos]\ndevice = \"" + arcos_link.string() + "\"\n[lms]\ndevice = \"" + lms_link.string() +
         "\"\nbaud = 500000\nfov_deg = 180\nresolution_deg = 0.5\n[mount]\nx_m = 0.16\ny_m = 0\nz_m = 0.45\npitch_deg = 0\n"
         "[filter]\nhalf_angle_deg = 7\nextrapolate_team = false\n[status]\nperiod_s = 0.1\n";
}

TEST(OnboardDaemonInProcess, PublishesFilteredMapFramePoints) {
  TempDir dir;
  const fs::path arcos_link = dir.path / "ttyArcos", lms_link = dir.path / "ttyLms";
  arcos::PioneerEmulator pioneer;
  FlatRanges ranges;
  lms200::LmsEmulatorOptions lms_options;
  lms_options.variant = LaserVariant{180, 50};
  lms200::LmsEmulator scanner{lms_options, &ranges};
  scanner.power_up(now_monotonic());
  auto arcos_runner = serial::PtyRunner::create(pioneer, serial::PtyRunnerOptions{.link_path = arcos_link.string()});
  auto lms_runner = serial::PtyRunner::create(scanner, serial::PtyRunnerOptions{.link_path = lms_link.string()});
  ASSERT_TRUE(arcos_runner.ok() && lms_runner.ok());
  ASSERT_TRUE((*arcos_runner)->start().ok());
  ASSERT_TRUE((*lms_runner)->start().ok());

  std::string msg;
  auto config = parse_onboard_config(base_config(arcos_link, lms_link),
                                     msg);
  ASSERT_TRUE(config.ok()) << msg;

  for (const PublishMode mode : {PublishMode::all, PublishMode::kept}) {
    SCOPED_TRACE(mode == PublishMode::all ? "publish all" : "publish kept");
    config->publish = mode;
    // The teammate 3.16 m ahead of the robot's centre: where the laser's 0° beam (3 m from the laser
    // at x = 0.16 m) hits.
    RecordingPublisher rec{3160, 0};
    auto daemon = OnboardDaemon::create(config.value(), rec);
    ASSERT_TRUE(daemon.ok()) << daemon.error().what;
    int rc = -1;
    std::thread loop{[&] { rc = (*daemon)->run(); }};

    const bool streamed = wait_until([&] { return rec.with([&] { return rec.scans_ >= 20 && rec.poses_ >= 2; }); },
                                     std::chrono::seconds(30));
    const ScanPoints scan = rec.with([&] { return rec.scan_; });
    const OnboardPose pose = rec.with([&] { return rec.pose_; });
    const OnboardStatus status = rec.with([&] { return rec.status_; });
    ::pthread_kill(loop.native_handle(), SIGTERM);
    loop.join();
    ASSERT_TRUE(streamed);
    EXPECT_EQ(rc, 0);

    EXPECT_EQ(pose.robot_id, 1u);
    EXPECT_EQ(pose.x_mm, 0);
    EXPECT_EQ(pose.y_mm, 0);
    EXPECT_EQ(scan.robot_id, 1u);
    EXPECT_EQ(scan.origin_x_mm, 160);
    EXPECT_EQ(scan.origin_z_mm, 450);
    EXPECT_NE(status.arcos_state, 0);
    EXPECT_NE(status.lms_state, 0);
    EXPECT_TRUE(status.team_fresh);

    // Beam 180 (0°) hits (3160, 0, 450); beam 192 (6°): robot-frame (3143.6, 313.6) is 5.7° off the line
    // to the teammate, inside the 7° cone; beam 196 (8°): (3130.8, 417.5) is 7.6° off, outside; beam 0
    // (−90°): (160, −3000).
    auto find = [&](std::uint16_t beam) -> const ScanPoint* {
      for (std::uint16_t i = 0; i < scan.count; ++i)
        if (scan.points[i].beam == beam) return &scan.points[i];
      return nullptr;
    };
    if (mode == PublishMode::all) {
      ASSERT_EQ(scan.count, 361);
      ASSERT_NE(find(180), nullptr);
      EXPECT_EQ(find(180)->x_mm, 3160);
      EXPECT_EQ(find(180)->y_mm, 0);
      EXPECT_EQ(find(180)->z_mm, 450);
      EXPECT_EQ(find(180)->flags, kPointDirectionFiltered);
      EXPECT_EQ(find(192)->flags, kPointDirectionFiltered);
      EXPECT_EQ(find(196)->flags, 0);
      EXPECT_EQ(find(0)->x_mm, 160);
      EXPECT_EQ(find(0)->y_mm, -3000);
      EXPECT_EQ(find(0)->flags, 0);
    } else {
      EXPECT_LT(scan.count, 361);
      EXPECT_GT(scan.count, 300);
      EXPECT_EQ(find(180), nullptr);
      EXPECT_EQ(find(192), nullptr);
      ASSERT_NE(find(196), nullptr);
      for (std::uint16_t i = 0; i < scan.count; ++i) EXPECT_EQ(scan.points[i].flags, 0) << scan.points[i].beam;
    }
  }
  (*arcos_runner)->stop();
  (*lms_runner)->stop();
}

// The station's odometry correction for this robot arrives in teamscan/team: the daemon projects its
// scans with it (origin and points in the corrected map frame, the scan saying which correction), starts
// its direction filter's cone at its corrected position against the teammate's corrected position, and
// counts the correction in its status; teamscan/pose stays in the odometry-map frame.
TEST(OnboardDaemonInProcess, AppliesItsOwnCorrectionFromTheTeamState) {
  TempDir dir;
  const fs::path arcos_link = dir.path / "ttyArcos", lms_link = dir.path / "ttyLms";
  arcos::PioneerEmulator pioneer;
  FlatRanges ranges;
  lms200::LmsEmulatorOptions lms_options;
  lms_options.variant = LaserVariant{180, 50};
  lms200::LmsEmulator scanner{lms_options, &ranges};
  scanner.power_up(now_monotonic());
  auto arcos_runner = serial::PtyRunner::create(pioneer, serial::PtyRunnerOptions{.link_path = arcos_link.string()});
  auto lms_runner = serial::PtyRunner::create(scanner, serial::PtyRunnerOptions{.link_path = lms_link.string()});
  ASSERT_TRUE(arcos_runner.ok() && lms_runner.ok());
  ASSERT_TRUE((*arcos_runner)->start().ok());
  ASSERT_TRUE((*lms_runner)->start().ok());
  std::string msg;
  auto config = parse_onboard_config(base_config(arcos_link, lms_link),
                                     msg);
  ASSERT_TRUE(config.ok()) << msg;
  // map_from_odom = (0.5 m, −0.2 m, 0.1 rad): the robot, at its odometry origin, stands at (0.5, −0.2)
  // heading 0.1 rad in the team's map; the teammate 3.16 m straight ahead of it there, at (3644, 115).
  const OdomCorrection c{500, -200, 100'000, 3};
  RecordingPublisher rec{3644, 115, c};
  auto daemon = OnboardDaemon::create(config.value(), rec);
  ASSERT_TRUE(daemon.ok()) << daemon.error().what;
  int rc = -1;
  std::thread loop{[&] { rc = (*daemon)->run(); }};
  const bool streamed = wait_until(
      [&] { return rec.with([&] { return rec.scans_ >= 20 && rec.poses_ >= 2 && rec.status_.corrections_applied > 0; }); },
      std::chrono::seconds(30));
  const ScanPoints scan = rec.with([&] { return rec.scan_; });
  const OnboardPose pose = rec.with([&] { return rec.pose_; });
  const OnboardStatus status = rec.with([&] { return rec.status_; });
  ::pthread_kill(loop.native_handle(), SIGTERM);
  loop.join();
  ASSERT_TRUE(streamed);
  EXPECT_EQ(rc, 0);
  EXPECT_EQ(pose.x_mm, 0);  // teamscan/pose: the odometry-map frame
  EXPECT_EQ(pose.y_mm, 0);
  EXPECT_EQ(scan.applied.seq, 3u);
  EXPECT_EQ(scan.applied.x_mm, 500);
  EXPECT_EQ(scan.applied.yaw_urad, 100'000);
  // Origin (0.16, 0) corrected: (659.2, −184.0).
  EXPECT_EQ(scan.origin_x_mm, 659);
  EXPECT_EQ(scan.origin_y_mm, -184);
  ASSERT_EQ(scan.count, 361);
  const auto find = [&](std::uint16_t beam) -> const ScanPoint& { return scan.points[beam]; };
  // Beam 180 (0°) corrected: (3644.2, 115.5), on the line to the teammate; beam 192 (6°): 5.7° off it,
  // inside the 7° cone; beam 196 (8°) outside.
  EXPECT_EQ(find(180).x_mm, 3644);
  EXPECT_EQ(find(180).y_mm, 115);
  EXPECT_EQ(find(180).flags, kPointDirectionFiltered);
  EXPECT_EQ(find(192).flags, kPointDirectionFiltered);
  EXPECT_EQ(find(196).flags, 0);
  EXPECT_EQ(status.corrections_applied, 1u);  // the same correction in every team state: taken once
  EXPECT_EQ(status.corrections_rejected, 0u);
  (*arcos_runner)->stop();
  (*lms_runner)->stop();
}


// What a stalling writer was given; owned by the test, so it outlives the queue that owns the writer.
struct StallingLink {
  std::mutex m;
  std::condition_variable cv;
  bool stalled = false;
  long poses = 0, scans = 0, seq_gaps = 0;
  std::uint32_t last_seq = 0;
  OnboardStatus status{};
  void stall(bool on) {
    {
      std::lock_guard lock{m};
      stalled = on;
    }
    cv.notify_all();
  }
  template <class F>
  auto with(F&& f) {
    std::lock_guard lock{m};
    return f();
  }
};

// A writer whose pose writes block while the link is stalled (Cyclone's sendmsg when the link goes
// down), and whose reader-match count waits as long (Cyclone's dds_get_publication_matched_status takes
// the writer's lock, which the blocked dds_write holds); counts every scan and pose it is given.
class StallingPublisher final : public Publisher {
 public:
  explicit StallingPublisher(StallingLink& link) : link_{link} {}
  Status publish_pose(const OnboardPose&) override {
    std::unique_lock lock{link_.m};
    link_.cv.wait(lock, [&] { return !link_.stalled; });
    ++link_.poses;
    return ok_status();
  }
  Status publish_scan(const ScanPoints& s) override {
    std::lock_guard lock{link_.m};
    if (link_.scans > 0 && s.seq != link_.last_seq + 1) ++link_.seq_gaps;
    link_.last_seq = s.seq;
    ++link_.scans;
    return ok_status();
  }
  Status publish_status(const OnboardStatus& s) override {
    std::lock_guard lock{link_.m};
    link_.status = s;
    return ok_status();
  }
  bool take_team(TeamSnapshot&) override { return false; }
  std::uint32_t scan_reader_matches() const override {
    std::unique_lock lock{link_.m};
    link_.cv.wait(lock, [&] { return !link_.stalled; });
    return 1;
  }
  const char* name() const override { return "stalling"; }

 private:
  StallingLink& link_;
};

TEST(OnboardDaemonInProcess, AWriteThatBlocksDoesNotStopTheDevices) {
  TempDir dir;
  const fs::path arcos_link = dir.path / "ttyArcos", lms_link = dir.path / "ttyLms";
  arcos::PioneerEmulator pioneer;
  FlatRanges ranges;
  lms200::LmsEmulatorOptions lms_options;
  lms_options.variant = LaserVariant{180, 50};
  lms200::LmsEmulator scanner{lms_options, &ranges};
  scanner.power_up(now_monotonic());
  auto arcos_runner = serial::PtyRunner::create(pioneer, serial::PtyRunnerOptions{.link_path = arcos_link.string()});
  auto lms_runner = serial::PtyRunner::create(scanner, serial::PtyRunnerOptions{.link_path = lms_link.string()});
  ASSERT_TRUE(arcos_runner.ok() && lms_runner.ok());
  ASSERT_TRUE((*arcos_runner)->start().ok());
  ASSERT_TRUE((*lms_runner)->start().ok());
  std::string msg;
  auto config = parse_onboard_config(base_config(arcos_link, lms_link) +
                                         "[ring]\npath = \"" + (dir.path / "ring.bin").string() + "\"\ncapacity_s = 30\n",
                                     msg);
  ASSERT_TRUE(config.ok()) << msg;
  StallingLink link;
  auto queue = SendQueue::create(std::make_unique<StallingPublisher>(link));
  ASSERT_TRUE(queue.ok()) << queue.error().what;
  auto daemon = OnboardDaemon::create(config.value(), *queue.value());
  ASSERT_TRUE(daemon.ok()) << daemon.error().what;
  int rc = -1;
  std::thread loop{[&] { rc = (*daemon)->run(); }};
  const bool streamed = wait_until([&] { return link.with([&] { return link.scans >= 20 && link.poses >= 2; }); },
                                   std::chrono::seconds(30));
  // The link goes down for 3 s: about 110 scans of this 0.5° variant (37.5 Hz), far more than the serial
  // ports buffer.
  link.stall(true);
  std::this_thread::sleep_for(std::chrono::seconds(3));
  const long scans_during_stall = link.with([&] { return link.scans; });
  const PublisherHealth during = queue.value()->health();
  link.stall(false);
  const bool caught_up = wait_until([&] { return queue.value()->health().depth == 0; }, std::chrono::seconds(20));
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const OnboardStatus status = link.with([&] { return link.status; });
  ::pthread_kill(loop.native_handle(), SIGTERM);
  loop.join();
  daemon.value().reset();
  queue.value().reset();  // writes what is still queued
  ASSERT_TRUE(streamed);
  ASSERT_TRUE(caught_up);
  EXPECT_EQ(rc, 0);
  const lms200::LmsEmulatorStatistics sent = (*lms_runner)->with_device([&](serial::SerialEndpoint&) { return scanner.statistics(); });
  (*arcos_runner)->stop();
  (*lms_runner)->stop();

  // The stall held the writes (the queue filled with poses and scans) but not the loop: the laser never
  // had to drop a sweep, no telegram was lost or re-synchronised, both devices stayed open.
  EXPECT_GT(during.depth, 100u);
  EXPECT_EQ(sent.scans_skipped, 0u);
  EXPECT_EQ(status.lms_resyncs, 0u);
  EXPECT_EQ(status.lms_bad_telegrams, 0u);
  EXPECT_EQ(status.lms_reopens, 1u);
  EXPECT_EQ(status.arcos_reopens, 1u);
  EXPECT_EQ(status.dds_write_errors, 0u);
  // Every scan the laser sent reached the writer, in order (the last may have been cut by the stop).
  const long scans = link.with([&] { return link.scans; });
  EXPECT_GE(scans, static_cast<long>(sent.scans_sent) - 1);
  EXPECT_LE(scans, static_cast<long>(sent.scans_sent));
  EXPECT_EQ(link.seq_gaps, 0);
  // The scans of the stall and after it came through.
  EXPECT_GT(scans, scans_during_stall + 100);
}

}  // namespace
}  // namespace teamscan::onboard
