// teamscan_secure_feed: a light multi-robot DDS load for the cost of DDS Security (run_security_cost.sh).
// Robots --first .. --first+N-1, one participant each, with its own identity when --pki SITE is given
// (SITE/robot<i>/, `teamscan pki`; Cyclone 0.10.2 refused a second identity's writers in one process:
// run one process per secured robot), each writing 181-point scans at --rate Hz and poses at 10 Hz with the
// robots' own QoS and partition, stamped with CLOCK_REALTIME when written (the station's scan -> fused
// map latency then measures DDS + the station). Waits for every scan writer to match a reader first.
// Prints "matched <n> after <s> s", then "written <scans> scans cpu <s> s wall <s> s".
//   usage: teamscan_secure_feed --robots N [--first ID] --rate HZ --seconds S --domain D [--pki SITE]
#include <sys/resource.h>
#include <time.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include <dds/dds.h>

#include "dds/security/credentials.hpp"
#include "dds/qos.hpp"
#include "teamscan.h"

namespace {

const char* arg(int argc, char** argv, const char* name, const char* dflt) {
  for (int i = 1; i + 1 < argc; ++i)
    if (std::strcmp(argv[i], name) == 0) return argv[i + 1];
  return dflt;
}
std::int64_t realtime_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}
double cpu_s() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) + 1e-6 * static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

struct Robot {
  std::uint32_t id = 0;
  dds_entity_t participant = 0, scan = 0, pose = 0;
  double x_m = 0, y_m = 0;
};

}  // namespace

int main(int argc, char** argv) {
  using namespace teamscan;
  const int n = std::atoi(arg(argc, argv, "--robots", "32"));
  const int first = std::atoi(arg(argc, argv, "--first", "1"));
  const double rate = std::atof(arg(argc, argv, "--rate", "75"));
  const double seconds = std::atof(arg(argc, argv, "--seconds", "10"));
  const auto domain = static_cast<dds_domainid_t>(std::atoi(arg(argc, argv, "--domain", "0")));
  const char* site = arg(argc, argv, "--pki", nullptr);
  std::vector<Robot> robots(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    Robot& r = robots[static_cast<std::size_t>(i)];
    r.id = static_cast<std::uint32_t>(first + i);
    r.x_m = -4.5 + 1.5 * ((first + i - 1) % 7);
    r.y_m = -4.5 + 1.5 * ((first + i - 1) / 7);
    dds_qos_t* pq = dds_create_qos();
    if (site != nullptr) dds::security::add_security_properties(pq, std::string(site) + "/" + dds::security::robot_identity(r.id));
    r.participant = dds_create_participant(domain, pq, nullptr);
    dds_delete_qos(pq);
    if (r.participant < 0) {
      std::fprintf(stderr, "robot %u: cannot create participant: %s\n", r.id, dds_strretcode(r.participant));
      return 1;
    }
    const dds_entity_t ts = dds_create_topic(r.participant, &teamscan_msg_ScanPoints_desc, "teamscan/scan", nullptr, nullptr);
    const dds_entity_t tp = dds_create_topic(r.participant, &teamscan_msg_RobotPose_desc, "teamscan/pose", nullptr, nullptr);
    dds_qos_t* q = dds::make_scan_writer_qos(r.id, 300, std::chrono::seconds(2), std::chrono::milliseconds(10));
    r.scan = dds_create_writer(r.participant, ts, q, nullptr);
    dds_delete_qos(q);
    q = dds::make_state_writer_qos(r.id, std::chrono::seconds(2), std::chrono::milliseconds(10));
    r.pose = dds_create_writer(r.participant, tp, q, nullptr);
    dds_delete_qos(q);
    if (r.scan < 0 || r.pose < 0) {
      std::fprintf(stderr, "robot %u: cannot create writers\n", r.id);
      return 1;
    }
  }
  // Every robot matched by the station before the clock starts.
  const auto t0 = std::chrono::steady_clock::now();
  int matched = 0;
  while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(60)) {
    matched = 0;
    for (const Robot& r : robots) {
      dds_publication_matched_status_t st{};
      if (dds_get_publication_matched_status(r.scan, &st) == 0 && st.current_count > 0) ++matched;
    }
    if (matched == n) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  std::printf("matched %d after %.2f s\n", matched, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  std::fflush(stdout);

  static teamscan_msg_ScanPoints scan{};
  teamscan_msg_RobotPose pose{};
  const double cpu0 = cpu_s();
  const auto start = std::chrono::steady_clock::now();
  const auto period = std::chrono::duration<double>(1.0 / rate);
  std::uint64_t written = 0;
  const auto ticks = static_cast<std::uint32_t>(seconds * rate);
  for (std::uint32_t k = 0; k < ticks; ++k) {
    std::this_thread::sleep_until(start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(period * k));
    const double t = k / rate;
    for (Robot& r : robots) {
      const double x = r.x_m + 0.3 * std::cos(0.3 * t), y = r.y_m + 0.3 * std::sin(0.3 * t), yaw = 0.3 * t + M_PI / 2;
      if (k % static_cast<std::uint32_t>(std::max(1.0, rate / 10)) == 0) {
        pose.robot_id = r.id;
        ++pose.seq;
        pose.stamp_ns = realtime_ns();
        pose.x_mm = static_cast<std::int32_t>(x * 1000);
        pose.y_mm = static_cast<std::int32_t>(y * 1000);
        pose.yaw_urad = static_cast<std::int32_t>(std::remainder(yaw, 2 * M_PI) * 1e6);
        (void)dds_write(r.pose, &pose);
      }
      scan.robot_id = r.id;
      scan.seq = k + 1;
      scan.origin_x_mm = static_cast<std::int32_t>(x * 1000);
      scan.origin_y_mm = static_cast<std::int32_t>(y * 1000);
      scan.origin_z_mm = 460;
      scan.count = 181;
      for (std::uint16_t b = 0; b < 181; ++b) {
        const double a = yaw - M_PI / 2 + b * M_PI / 180;
        scan.points[b].x_mm = static_cast<std::int32_t>((x + 2.0 * std::cos(a)) * 1000);
        scan.points[b].y_mm = static_cast<std::int32_t>((y + 2.0 * std::sin(a)) * 1000);
        scan.points[b].z_mm = static_cast<std::int32_t>(b * 10);
        scan.points[b].beam = b;
        scan.points[b].flags = 0;
      }
      scan.stamp_ns = realtime_ns();
      if (dds_write(r.scan, &scan) == 0) ++written;
    }
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("written %llu scans cpu %.2f s wall %.2f s\n", static_cast<unsigned long long>(written), cpu_s() - cpu0, wall);
  std::this_thread::sleep_for(std::chrono::seconds(1));  // let the last samples be acknowledged
  for (const Robot& r : robots) dds_delete(r.participant);
  return 0;
}
