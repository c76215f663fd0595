// teamscan_secure_peer: a second DDS process for the DDS Security tests, on the raw Cyclone API so that
// it can do what the daemons never do (publish as another robot, in another partition, the team state).
// Every mode takes --domain D, --seconds S and optionally --pki DIR (a credential bundle; without it the
// participant has no credentials).
//   listen    readers on all five teamscan topics (robot partitions and the default one); prints
//             "participant <rc>", then at the end "discovered <teamscan endpoints in DCPSPublication>
//             matched <publications matched> samples <samples received>"
//   publish   --robot N (robot_id in the samples) --partition P [--team] [--rate HZ]: writes scans
//             and poses (the robots' writer QoS) claiming robot N in partition P (and, with --team, team states);
//             prints "participant <rc>", "scan_writer <rc>", "team_writer <rc>", then at the end
//             "written <n> matched <max publications' matched readers>"
#include <time.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

#include <dds/dds.h>

#include "dds/security/credentials.hpp"
#include "dds/qos.hpp"
#include "teamscan.h"

namespace {

const char* arg(int argc, char** argv, const char* name, const char* dflt) {
  for (int i = 2; i + 1 < argc; ++i)
    if (std::strcmp(argv[i], name) == 0) return argv[i + 1];
  return dflt;
}
bool flag(int argc, char** argv, const char* name) {
  for (int i = 2; i < argc; ++i)
    if (std::strcmp(argv[i], name) == 0) return true;
  return false;
}
std::int64_t realtime_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

dds_entity_t make_participant(int argc, char** argv) {
  const auto domain = static_cast<dds_domainid_t>(std::atoi(arg(argc, argv, "--domain", "0")));
  dds_qos_t* q = dds_create_qos();
  const char* pki = arg(argc, argv, "--pki", nullptr);
  if (pki != nullptr) teamscan::dds::security::add_security_properties(q, pki);
  const dds_entity_t pp = dds_create_participant(domain, q, nullptr);
  dds_delete_qos(q);
  std::printf("participant %d\n", pp < 0 ? pp : 0);
  std::fflush(stdout);
  return pp;
}

dds_qos_t* reliable_qos(const char* partition) {
  dds_qos_t* q = dds_create_qos();
  dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_history(q, DDS_HISTORY_KEEP_ALL, 0);
  if (partition != nullptr && partition[0] != '\0') dds_qset_partition1(q, partition);
  return q;
}

int run_listen(int argc, char** argv, double seconds) {
  const dds_entity_t pp = make_participant(argc, argv);
  if (pp < 0) return 1;
  const dds_topic_descriptor_t* descs[5] = {&teamscan_msg_RobotPose_desc, &teamscan_msg_ScanPoints_desc,
                                            &teamscan_msg_RobotStatus_desc, &teamscan_msg_TeamState_desc,
                                            &teamscan_msg_MapUpdate_desc};
  const char* names[5] = {"teamscan/pose", "teamscan/scan", "teamscan/status", "teamscan/team", "teamscan/map"};
  dds_entity_t readers[10];
  int nreaders = 0;
  for (const char* partition : {"robot*", ""}) {
    dds_qos_t* q = reliable_qos(partition);
    const dds_entity_t sub = dds_create_subscriber(pp, q, nullptr);
    dds_delete_qos(q);
    for (int t = 0; t < 5; ++t) {
      const dds_entity_t tp = dds_create_topic(pp, descs[t], names[t], nullptr, nullptr);
      const dds_entity_t rd = tp < 0 ? tp : dds_create_reader(sub, tp, nullptr, nullptr);
      if (rd > 0) readers[nreaders++] = rd;
    }
  }
  std::uint64_t samples = 0;
  std::uint32_t matched = 0;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    for (int r = 0; r < nreaders; ++r) {
      void* buf[16] = {nullptr};
      dds_sample_info_t info[16];
      const int n = dds_take(readers[r], buf, info, 16, 16);
      for (int i = 0; i < n; ++i) samples += info[i].valid_data ? 1 : 0;
      if (n > 0) (void)dds_return_loan(readers[r], buf, n);
      dds_subscription_matched_status_t st{};
      if (dds_get_subscription_matched_status(readers[r], &st) == 0 && st.total_count > 0) matched += st.total_count_change;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  // Remote teamscan endpoints this participant learnt of through discovery.
  std::uint32_t discovered = 0;
  const dds_entity_t builtin = dds_create_reader(pp, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr);
  void* buf[64] = {nullptr};
  dds_sample_info_t info[64];
  const int n = builtin < 0 ? 0 : dds_read(builtin, buf, info, 64, 64);
  for (int i = 0; i < n; ++i) {
    const auto* ep = static_cast<const dds_builtintopic_endpoint_t*>(buf[i]);
    if (info[i].valid_data && std::strncmp(ep->topic_name, "teamscan/", 9) == 0) ++discovered;
  }
  if (n > 0) (void)dds_return_loan(builtin, buf, n);
  std::printf("discovered %u matched %u samples %llu\n", discovered, matched, static_cast<unsigned long long>(samples));
  dds_delete(pp);
  return 0;
}

int run_publish(int argc, char** argv, double seconds) {
  const dds_entity_t pp = make_participant(argc, argv);
  if (pp < 0) return 1;
  const auto robot = static_cast<std::uint32_t>(std::atoi(arg(argc, argv, "--robot", "1")));
  const char* partition = arg(argc, argv, "--partition", "robot1");
  const double rate = std::atof(arg(argc, argv, "--rate", "20"));
  const dds_entity_t tp_scan = dds_create_topic(pp, &teamscan_msg_ScanPoints_desc, "teamscan/scan", nullptr, nullptr);
  const dds_entity_t tp_pose = dds_create_topic(pp, &teamscan_msg_RobotPose_desc, "teamscan/pose", nullptr, nullptr);
  // The robots' own writer QoS (what the station expects), in the partition asked for.
  dds_qos_t* q = teamscan::dds::make_scan_writer_qos(robot, 300, std::chrono::seconds(2), std::chrono::milliseconds(10));
  dds_qset_partition1(q, partition);
  const dds_entity_t scan_wr = dds_create_writer(pp, tp_scan, q, nullptr);
  dds_delete_qos(q);
  q = teamscan::dds::make_state_writer_qos(robot, std::chrono::seconds(2), std::chrono::milliseconds(10));
  dds_qset_partition1(q, partition);
  const dds_entity_t pose_wr = dds_create_writer(pp, tp_pose, q, nullptr);
  dds_delete_qos(q);
  std::printf("scan_writer %d\n", scan_wr < 0 ? scan_wr : 0);
  dds_entity_t team_wr = 0;
  if (flag(argc, argv, "--team")) {
    const dds_entity_t tp_team = dds_create_topic(pp, &teamscan_msg_TeamState_desc, "teamscan/team", nullptr, nullptr);
    q = teamscan::dds::make_team_writer_qos(std::chrono::seconds(2));
    team_wr = tp_team < 0 ? tp_team : dds_create_writer(pp, tp_team, q, nullptr);
    dds_delete_qos(q);
    std::printf("team_writer %d\n", team_wr < 0 ? team_wr : 0);
  }
  std::fflush(stdout);
  static teamscan_msg_ScanPoints scan{};
  teamscan_msg_RobotPose pose{};
  teamscan_msg_TeamState team{};
  std::uint32_t written = 0, matched = 0;
  const auto period = std::chrono::duration<double>(1.0 / rate);
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (std::uint32_t seq = 1; std::chrono::steady_clock::now() < end; ++seq) {
    scan.robot_id = pose.robot_id = robot;
    scan.seq = pose.seq = seq;
    scan.stamp_ns = pose.stamp_ns = realtime_ns();
    scan.count = 10;
    pose.x_mm = 1000;
    if (scan_wr > 0 && dds_write(scan_wr, &scan) == 0) ++written;
    if (pose_wr > 0 && dds_write(pose_wr, &pose) == 0) ++written;
    if (team_wr > 0) {
      team.seq = seq;
      (void)dds_write(team_wr, &team);
    }
    for (dds_entity_t w : {scan_wr, pose_wr, team_wr}) {
      dds_publication_matched_status_t st{};
      if (w > 0 && dds_get_publication_matched_status(w, &st) == 0 && st.current_count > matched) matched = st.current_count;
    }
    std::this_thread::sleep_for(period);
  }
  std::printf("written %u matched %u\n", written, matched);
  dds_delete(pp);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: teamscan_secure_peer listen|publish --domain D --seconds S [--pki DIR] ...\n");
    return 2;
  }
  const double seconds = std::atof(arg(argc, argv, "--seconds", "3"));
  if (std::strcmp(argv[1], "listen") == 0) return run_listen(argc, argv, seconds);
  if (std::strcmp(argv[1], "publish") == 0) return run_publish(argc, argv, seconds);
  std::fprintf(stderr, "teamscan_secure_peer: unknown mode %s\n", argv[1]);
  return 2;
}
