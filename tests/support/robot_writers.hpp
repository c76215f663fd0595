// Writers of teamscan/pose, teamscan/scan and teamscan/status for any robot id, created on first use in
// that robot's partition with the robots' QoS (dds/qos.hpp), so one test or benchmark process can speak
// as several robots and the station's sender check (partition = robot) sees each as itself.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <map>

#include <dds/dds.h>

#include "dds/qos.hpp"
#include "dds/topics.hpp"
#include "teamscan.h"

namespace teamscan::test {

class RobotWriters {
 public:
  enum Kind { kPose = 0, kScan = 1, kStatus = 2 };
  // keep_all: every written sample reaches a matched reader (exact counts in tests); else the robots' history.
  RobotWriters(dds_entity_t participant, bool keep_all) : participant_{participant}, keep_all_{keep_all} {
    topics_[kPose] = dds_create_topic(participant, &teamscan_msg_RobotPose_desc, dds::kTopicPose, nullptr, nullptr);
    topics_[kScan] = dds_create_topic(participant, &teamscan_msg_ScanPoints_desc, dds::kTopicScan, nullptr, nullptr);
    topics_[kStatus] = dds_create_topic(participant, &teamscan_msg_RobotStatus_desc, dds::kTopicStatus, nullptr, nullptr);
  }
  [[nodiscard]] bool ok() const { return topics_[kPose] > 0 && topics_[kScan] > 0 && topics_[kStatus] > 0; }
  // The writer of `kind` for `robot_id` (any value: ids the station refuses get a partition too).
  dds_entity_t writer(Kind kind, std::uint32_t robot_id) {
    auto [it, fresh] = writers_.try_emplace(robot_id);
    if (fresh) {
      using namespace std::chrono_literals;
      dds_qos_t* q = dds::make_scan_writer_qos(robot_id, 300, 2s, 1s);
      if (keep_all_) dds_qset_history(q, DDS_HISTORY_KEEP_ALL, 0);
      it->second[kPose] = dds_create_writer(participant_, topics_[kPose], q, nullptr);
      it->second[kScan] = dds_create_writer(participant_, topics_[kScan], q, nullptr);
      dds_delete_qos(q);
      q = dds::make_state_writer_qos(robot_id, 2s, 1s);
      if (keep_all_) dds_qset_history(q, DDS_HISTORY_KEEP_ALL, 0);
      it->second[kStatus] = dds_create_writer(participant_, topics_[kStatus], q, nullptr);
      dds_delete_qos(q);
    }
    return it->second[kind];
  }
  // Waits until every writer's samples are acknowledged by its matched readers (at most `timeout` each);
  // false if any was not.
  bool wait_for_acks(dds_duration_t timeout) {
    bool all = true;
    for (auto& [id, w] : writers_)
      for (dds_entity_t e : w) all = dds_wait_for_acks(e, timeout) == 0 && all;
    return all;
  }
  // Readers matched by robot_id's writer of `kind` (0 if it has none yet).
  [[nodiscard]] std::uint32_t matched(Kind kind, std::uint32_t robot_id) {
    dds_publication_matched_status_t st{};
    return dds_get_publication_matched_status(writer(kind, robot_id), &st) == 0 ? st.current_count : 0;
  }

 private:
  dds_entity_t participant_;
  bool keep_all_;
  std::array<dds_entity_t, 3> topics_{};
  std::map<std::uint32_t, std::array<dds_entity_t, 3>> writers_;
};

}  // namespace teamscan::test
