// Fixed capacities of the whole system (DESIGN.md: at most 32 robots, at most 401 beams a scan).
// Every fixed-size buffer on the robot is sized from here.
#pragma once

#include <cstddef>

namespace teamscan {

inline constexpr std::size_t kMaxRobots = 32;          // robot ids 1..32
inline constexpr std::size_t kMaxBeams = 401;          // LMS 2xx 100°/0.25° variant
inline constexpr std::size_t kMaxArcosPacket = 3 + 255;    // FA FB count + up to 255 bytes
inline constexpr std::size_t kMaxLmsTelegram = 6 + 1024;   // STX addr len(2) + data + CRC (0xB1 is 160)
inline constexpr std::size_t kSerialRxChunk = 4096;        // bytes read from a port per call

}  // namespace teamscan
