// The fused model moved rigidly with the pose graph (model_move.hpp).
#include "groundstation/fusion/model_move.hpp"

#include <algorithm>
#include <cmath>

namespace teamscan::fusion {

namespace {

// Per robot: each scan's correction in the estimate, ascending by number (a number held twice: the
// newest scan's).
struct Numbered {
  std::uint32_t seq;
  std::int64_t stamp_ns;
  Pose2 correction;
  Vec2 odom_m;  // the robot's position by its odometry
};
using Corrections = std::array<std::vector<Numbered>, kMaxRobots + 1>;

Corrections corrections_of(const GraphEstimate* e) {
  Corrections out;
  if (e == nullptr) return out;
  for (const GraphScanPose& p : e->poses())
    if (p.robot >= 1 && p.robot <= kMaxRobots) out[p.robot].push_back({p.scan, p.stamp_ns, p.graph * p.odom.inverse(), {p.odom.x_m, p.odom.y_m}});
  for (std::vector<Numbered>& v : out) {
    // A robot's scans come in stamp order, their numbers rising with it: sorted already but after a restart.
    if (!std::is_sorted(v.begin(), v.end(), [](const Numbered& x, const Numbered& y) { return x.seq < y.seq; }))
      std::stable_sort(v.begin(), v.end(), [](const Numbered& x, const Numbered& y) { return x.seq < y.seq; });
    // Of equal numbers the newest stays (stable: among equal stamps, the later in the estimate).
    std::size_t kept = 0;
    for (std::size_t i = 0; i < v.size(); ++i) {
      if (kept > 0 && v[kept - 1].seq == v[i].seq) {
        if (v[i].stamp_ns >= v[kept - 1].stamp_ns) v[kept - 1] = v[i];
      } else {
        v[kept++] = v[i];
      }
    }
    v.resize(kept);
  }
  return out;
}

}  // namespace

const RigidMove ScanMoves::kNone{};

RigidMove RigidMove::of(const Pose2& p) { return {std::cos(p.theta_rad), std::sin(p.theta_rad), p.x_m, p.y_m}; }

ScanPlacement ScanPlacement::on(std::shared_ptr<const GraphEstimate> estimate) {
  ScanPlacement out;
  if (estimate) {
    const auto newest = estimate->newest_scans();
    for (std::size_t r = 1; r <= kMaxRobots; ++r)
      if (newest[r]) out.tail[r] = newest[r]->graph * newest[r]->odom.inverse();
  }
  out.estimate = std::move(estimate);
  return out;
}

ScanMoves::ScanMoves(const ScanPlacement& from, const ScanPlacement& to) {
  const Corrections a = corrections_of(from.estimate.get()), b = corrections_of(to.estimate.get());
  for (std::size_t r = 1; r <= kMaxRobots; ++r) {
    Robot& robot = robots_[r];
    robot.tail = RigidMove::of(to.tail[r] * from.tail[r].inverse());
    // Every number either estimate holds, in order: where `to` puts it after where `from` put it.
    robot.by_seq.reserve(std::max(a[r].size(), b[r].size()));
    auto ia = a[r].begin(), ib = b[r].begin();
    while (ia != a[r].end() || ib != b[r].end()) {
      const bool take_a = ia != a[r].end() && (ib == b[r].end() || ia->seq <= ib->seq);
      const bool take_b = ib != b[r].end() && (ia == a[r].end() || ib->seq <= ia->seq);
      const std::uint32_t seq = take_a ? ia->seq : ib->seq;
      const Pose2& was = take_a ? ia->correction : from.tail[r];
      const Pose2& now = take_b ? ib->correction : to.tail[r];
      const Pose2 move = now * was.inverse();
      robot.by_seq.emplace_back(seq, RigidMove::of(move));
      if (take_b) {
        const Vec2 at = was.apply(ib->odom_m);
        const Vec2 to_m = move.apply(at);
        largest_position_shift_m_ = std::max(largest_position_shift_m_, std::hypot(to_m.x - at.x, to_m.y - at.y));
        largest_turn_rad_ = std::max(largest_turn_rad_, std::abs(normalize_angle(move.theta_rad)));
      }
      if (take_a) ++ia;
      if (take_b) ++ib;
    }
  }
}

const RigidMove& ScanMoves::at(std::uint8_t robot, std::uint32_t seq) const {
  if (robot == 0 || robot > kMaxRobots) return kNone;
  const Robot& r = robots_[robot];
  const auto it = std::lower_bound(r.by_seq.begin(), r.by_seq.end(), seq,
                                   [](const std::pair<std::uint32_t, RigidMove>& e, std::uint32_t s) { return e.first < s; });
  return it != r.by_seq.end() && it->first == seq ? it->second : r.tail;
}

std::size_t ScanMoves::scans() const {
  std::size_t n = 0;
  for (const Robot& r : robots_) n += r.by_seq.size();
  return n;
}

}  // namespace teamscan::fusion
