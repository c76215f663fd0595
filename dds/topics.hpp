// The teamscan topics (DESIGN.md "DDS topics"): each generated IDL type paired with its one topic name,
// so a reader or writer names the type and gets the right topic (no name typed twice).
#pragma once

#include <dds/dds.h>

#include "teamscan.h"

namespace teamscan::dds {

inline constexpr const char* kTopicPose = "teamscan/pose";
inline constexpr const char* kTopicScan = "teamscan/scan";
inline constexpr const char* kTopicStatus = "teamscan/status";
inline constexpr const char* kTopicTeam = "teamscan/team";
inline constexpr const char* kTopicMap = "teamscan/map";
inline constexpr const char* kTopicStored = "teamscan/stored";      // StoredState: station -> robots
inline constexpr const char* kTopicBackfill = "teamscan/backfill";  // ScanPoints from the ring: robot -> station
inline constexpr const char* kTopicBackfillPose = "teamscan/backfill_pose";  // RobotPose from the ring: robot -> station

// TopicOf<Sample>::name and ::descriptor() for every generated type that has a topic. ScanPoints and
// RobotPose have a second topic each, kTopicBackfill and kTopicBackfillPose, named where their readers and
// writers are made.
template <class Sample>
struct TopicOf;

template <>
struct TopicOf<teamscan_msg_RobotPose> {
  static constexpr const char* name = kTopicPose;
  static const dds_topic_descriptor_t* descriptor() { return &teamscan_msg_RobotPose_desc; }
};
template <>
struct TopicOf<teamscan_msg_ScanPoints> {
  static constexpr const char* name = kTopicScan;
  static const dds_topic_descriptor_t* descriptor() { return &teamscan_msg_ScanPoints_desc; }
};
template <>
struct TopicOf<teamscan_msg_RobotStatus> {
  static constexpr const char* name = kTopicStatus;
  static const dds_topic_descriptor_t* descriptor() { return &teamscan_msg_RobotStatus_desc; }
};
template <>
struct TopicOf<teamscan_msg_TeamState> {
  static constexpr const char* name = kTopicTeam;
  static const dds_topic_descriptor_t* descriptor() { return &teamscan_msg_TeamState_desc; }
};
template <>
struct TopicOf<teamscan_msg_StoredState> {
  static constexpr const char* name = kTopicStored;
  static const dds_topic_descriptor_t* descriptor() { return &teamscan_msg_StoredState_desc; }
};
template <>
struct TopicOf<teamscan_msg_MapUpdate> {
  static constexpr const char* name = kTopicMap;
  static const dds_topic_descriptor_t* descriptor() { return &teamscan_msg_MapUpdate_desc; }
};

}  // namespace teamscan::dds
