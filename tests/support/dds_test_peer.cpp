// teamscan_dds_test_peer: a separate DDS process for multi-process tests (loopback config only).
//   Every mode takes --domain D (DDS domain id; default: Cyclone's default).
//   robot --robot ID [--rate HZ] [--scans N] [--first-seq S] [--points P] [--depth D]
//         publishes pose + scan (+ status every 10th) at HZ through DdsBridge; N = 0: until SIGTERM.
//         Prints "matched" once a scan reader is matched and "done <last seq>" at the end.
//   sink [--count N] [--timeout S]
//         takes teamscan/scan until N samples or S seconds; prints
//         "received <n> in_order <0|1> first <seq> last <seq> distinct <k>".
//   drain [--timeout S] [--report S]
//         reads every teamscan/scan sample and discards it (memory stays bounded: a soak's sink) until
//         SIGTERM or S seconds (0: no limit); every --report seconds and at the end prints
//         "drained <n> robots <k> gaps <missing seqs> last <seq>".
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <set>
#include <string>
#include <vector>

#include "onboard/bridge/bridge.hpp"
#include "dds/qos.hpp"
#include "teamscan.h"
#include "tests/support/dds_test_subscriber.hpp"

namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

long arg_long(int argc, char** argv, const char* name, long dflt) {
  for (int i = 2; i + 1 < argc; ++i) {
    if (std::strcmp(argv[i], name) == 0) return std::strtol(argv[i + 1], nullptr, 10);
  }
  return dflt;
}

std::int64_t realtime_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

int run_robot(int argc, char** argv) {
  using namespace teamscan::onboard;
  using teamscan::ScanPoint;
  using teamscan::ScanPoints;
  using teamscan::Time;
  DdsBridgeOptions opt;
  opt.robot_id = static_cast<std::uint32_t>(arg_long(argc, argv, "--robot", 1));
  opt.domain_id = static_cast<std::uint32_t>(arg_long(argc, argv, "--domain", DDS_DOMAIN_DEFAULT));
  opt.scan_history_depth = static_cast<std::uint32_t>(arg_long(argc, argv, "--depth", 300));
  const long rate_hz = arg_long(argc, argv, "--rate", 50);
  const long scans = arg_long(argc, argv, "--scans", 0);
  const auto first_seq = static_cast<std::uint32_t>(arg_long(argc, argv, "--first-seq", 1));
  const auto points = static_cast<std::uint16_t>(arg_long(argc, argv, "--points", 401));
  auto bridge = DdsBridge::create(opt);
  if (!bridge) {
    std::fprintf(stderr, "robot: %s (%ld)\n", bridge.error().what, bridge.error().detail);
    return 1;
  }
  static ScanPoints scan;
  OnboardPose pose;
  OnboardStatus status;
  pose.robot_id = scan.robot_id = status.robot_id = opt.robot_id;
  bool announced = false;
  std::uint32_t seq = first_seq;
  const long period_ns = 1'000'000'000L / (rate_hz > 0 ? rate_hz : 1);
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  for (long i = 0; (scans == 0 || i < scans) && g_stop == 0; ++i, ++seq) {
    if (!announced && bridge->scan_subscribers() > 0) {
      std::printf("matched\n");
      std::fflush(stdout);
      announced = true;
    }
    const std::int64_t now = realtime_ns();
    pose.seq = seq;
    pose.stamp_ns = now;
    pose.x_mm = static_cast<std::int32_t>(1000 * opt.robot_id + (seq % 1000));
    pose.y_mm = static_cast<std::int32_t>(seq % 500);
    scan.seq = seq;
    scan.stamp = Time::from_ns(now);
    scan.count = points;
    for (std::uint16_t b = 0; b < points; ++b) {
      scan.points[b] = ScanPoint{static_cast<std::int32_t>(seq), b, static_cast<std::int32_t>(opt.robot_id), b, 0};
    }
    (void)bridge->publish_pose(pose);
    (void)bridge->publish_scan(scan);
    if (seq % 10 == 0) {
      status.seq = seq / 10;
      status.stamp_ns = now;
      status.scans_published = bridge->counters().scans_written;
      (void)bridge->publish_status(status);
    }
    next.tv_nsec += period_ns;
    while (next.tv_nsec >= 1'000'000'000L) { next.tv_nsec -= 1'000'000'000L; ++next.tv_sec; }
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
  }
  (void)bridge->wait_for_scan_acks(std::chrono::seconds(2));
  std::printf("done %u\n", seq - 1);
  std::fflush(stdout);
  return 0;
}

int run_sink(int argc, char** argv) {
  const long count = arg_long(argc, argv, "--count", 1);
  const long timeout_s = arg_long(argc, argv, "--timeout", 10);
  dds_qos_t* q = teamscan::dds::make_scan_reader_qos();
  teamscan::test::DdsTestSubscriber<teamscan_msg_ScanPoints> sub(&teamscan_msg_ScanPoints_desc,
                                                                 teamscan::dds::kTopicScan, q, 256,
      static_cast<dds_domainid_t>(arg_long(argc, argv, "--domain", DDS_DOMAIN_DEFAULT)));
  dds_delete_qos(q);
  if (!sub.ok()) {
    std::fprintf(stderr, "sink: cannot create reader\n");
    return 1;
  }
  std::printf("ready\n");
  std::fflush(stdout);
  std::vector<teamscan_msg_ScanPoints> got;
  got.reserve(static_cast<std::size_t>(count));
  (void)sub.take_until(got, static_cast<std::size_t>(count), std::chrono::seconds(timeout_s));
  bool in_order = true;
  std::set<std::uint32_t> distinct;
  for (std::size_t i = 0; i < got.size(); ++i) {
    distinct.insert(got[i].seq);
    if (i > 0 && got[i].seq != got[i - 1].seq + 1) in_order = false;
  }
  std::printf("received %zu in_order %d first %u last %u distinct %zu\n", got.size(), in_order ? 1 : 0,
              got.empty() ? 0u : got.front().seq, got.empty() ? 0u : got.back().seq, distinct.size());
  std::fflush(stdout);
  return 0;
}

int run_drain(int argc, char** argv) {
  const long timeout_s = arg_long(argc, argv, "--timeout", 0);
  const long report_s = arg_long(argc, argv, "--report", 60);
  dds_qos_t* q = teamscan::dds::make_scan_reader_qos();
  teamscan::test::DdsTestSubscriber<teamscan_msg_ScanPoints> sub(&teamscan_msg_ScanPoints_desc,
                                                                 teamscan::dds::kTopicScan, q, 64,
      static_cast<dds_domainid_t>(arg_long(argc, argv, "--domain", DDS_DOMAIN_DEFAULT)));
  dds_delete_qos(q);
  if (!sub.ok()) {
    std::fprintf(stderr, "drain: cannot create reader\n");
    return 1;
  }
  std::printf("ready\n");
  std::fflush(stdout);
  std::vector<teamscan_msg_ScanPoints> got;
  got.reserve(256);
  // Per robot id (1..32): last sequence seen, to count the ones that never arrived.
  std::uint32_t last_seq[33] = {};
  std::uint64_t drained = 0, gaps = 0, robots = 0;
  std::uint32_t last = 0;
  const auto start = std::chrono::steady_clock::now();
  auto next_report = start + std::chrono::seconds(report_s > 0 ? report_s : 60);
  auto report = [&] {
    std::printf("drained %llu robots %llu gaps %llu last %u\n", static_cast<unsigned long long>(drained),
                static_cast<unsigned long long>(robots), static_cast<unsigned long long>(gaps), last);
    std::fflush(stdout);
  };
  while (g_stop == 0) {
    got.clear();
    (void)sub.take_until(got, 64, std::chrono::milliseconds(200));
    for (const auto& s : got) {
      ++drained;
      last = s.seq;
      if (s.robot_id == 0 || s.robot_id > 32) continue;
      std::uint32_t& prev = last_seq[s.robot_id];
      if (prev == 0) ++robots;
      else if (s.seq > prev + 1) gaps += s.seq - prev - 1;
      prev = s.seq;
    }
    const auto now = std::chrono::steady_clock::now();
    if (now >= next_report) {
      report();
      next_report += std::chrono::seconds(report_s > 0 ? report_s : 60);
    }
    if (timeout_s > 0 && now - start >= std::chrono::seconds(timeout_s)) break;
  }
  report();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::signal(SIGTERM, on_signal);
  std::signal(SIGINT, on_signal);
  if (argc >= 2 && std::strcmp(argv[1], "robot") == 0) return run_robot(argc, argv);
  if (argc >= 2 && std::strcmp(argv[1], "sink") == 0) return run_sink(argc, argv);
  if (argc >= 2 && std::strcmp(argv[1], "drain") == 0) return run_drain(argc, argv);
  std::fprintf(stderr, "usage: teamscan_dds_test_peer robot|sink|drain [options]\n");
  return 2;
}
