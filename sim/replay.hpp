// Replays a robot's recorded serial sessions (captures/robotN-arcos.cap, -lms200.cap) through fresh
// ArcosClient and LmsClient instances configured as the simulator configured them, and the same
// RobotReceiver: the scans come out as the same 3-D points as in the data set, byte for byte.
#pragma once

#include <cstdint>

#include "common/capture.hpp"
#include "drivers/arcos/client.hpp"
#include "drivers/lms200/client.hpp"
#include "sim/receiver.hpp"
#include "sim/scenario.hpp"

namespace teamscan::sim {

// The client configuration the simulator uses for a robot (and a replay must use again).
[[nodiscard]] arcos::ArcosClientOptions arcos_client_options(const RobotSpec& spec);
[[nodiscard]] lms200::LmsClientOptions lms_client_options(const RobotSpec& spec);

struct ReplayStats {
  std::uint64_t rx_chunks = 0;
  std::uint64_t scans = 0;
  std::uint64_t sips = 0;
};

// Feeds the host-received (rx) bytes of both captures in time order (capture time 0 = `start`), ticks
// the clients at their deadlines in between as the VirtualLink did, and hands every projected scan
// to `on_scan`. `map_from_odom` is the robot's registration (dataset.toml).
ReplayStats replay_robot(const Capture& arcos, const Capture& lms, const RobotSpec& spec, const Pose2& map_from_odom,
                         Time start, const RobotReceiver::ScanHandler& on_scan);

}  // namespace teamscan::sim
