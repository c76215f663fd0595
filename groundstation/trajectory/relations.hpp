// The relations metric of Kümmerle et al. 2009, "On measuring the accuracy of SLAM algorithms": a file
// of hand-verified relations `t1 t2 x y z roll pitch yaw` (metres, radians), each the motion
// pose(t1)⁻¹·pose(t2) between two scans named by their exact stamps; the error of a trajectory on a
// relation is relation⁻¹·(pose(t1)⁻¹·pose(t2)); reported as the mean ± standard deviation of its
// translation (m) and absolute rotation (°) and the means of their squares, over all relations.
// The parser is pure (text in, relations and counters out; a malformed line is counted, never fatal).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/pose.hpp"
#include "groundstation/trajectory/tum.hpp"

namespace teamscan::trajectory {

struct Relation {
  std::int64_t t1_us = 0, t2_us = 0;  // the two scans' stamps, exactly as written (µs)
  Pose2 t1_from_t2;                   // x, y, yaw (planar: z, roll and pitch are read and not used)
  // The unit of each stamp's last written decimal (µs): 1 for six decimals, 10 for five, … A stamp
  // written with fewer decimals than its log's names the scan whose stamp it is rounded from (MIT
  // CSAIL's relations give five decimals, its log six).
  std::int64_t t1_unit_us = 1, t2_unit_us = 1;
};

struct RelationsFile {
  std::vector<Relation> relations;
  std::uint64_t lines = 0, comments = 0, malformed = 0;
  std::string first_error;  // "line N: reason" of the first malformed line
};

[[nodiscard]] RelationsFile parse_relations(std::string_view text);

// The figures over the relations whose two stamps the trajectory has.
struct RelationErrors {
  std::size_t relations = 0;  // in the file
  std::size_t used = 0;       // both stamps found in the trajectory
  std::size_t rounded = 0;    // of those, with a stamp that named its scan rounded (Relation::t1_unit_us)
  double translation_mean_m = 0, translation_std_m = 0, translation_squared_mean_m2 = 0;
  double rotation_mean_deg = 0, rotation_std_deg = 0, rotation_squared_mean_deg2 = 0;
  double translation_max_m = 0, rotation_max_deg = 0;
};

// A trajectory may name a stamp twice (a log can): the first pose with that stamp is used. A stamp with
// fewer than six decimals that no pose has exactly names the pose nearest it within half its unit. Standard
// deviations are over the relations used (divided by n, as the published figures).
[[nodiscard]] RelationErrors relation_errors(const std::vector<Relation>& relations, const std::vector<StampedPose>& trajectory);

}  // namespace teamscan::trajectory
