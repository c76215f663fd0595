// Matching a scan against a submap's grid. Two matchers, as in Cartographer's 2-D SLAM (Hess et al.
// 2016): a least-squares refinement (Ceres, the grid bicubically interpolated) from a good first guess,
// and a correlative search with branch and bound over a window for loop closures, whose first guess
// may be metres and degrees off.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "common/pose.hpp"
#include "groundstation/posegraph/grid.hpp"

namespace teamscan::posegraph {

struct RefineOptions {
  double occupied_weight = 1.0;     // per point, scaled by 1/√n (the scan's weight does not grow with n)
  double translation_weight = 10.0; // pull towards the first guess (per metre)
  double rotation_weight = 40.0;    // (per radian)
  int max_iterations = 20;
};

// The pose (submap_from_robot) that best puts `points` (robot frame) on the grid's returns, from
// `guess`. Deterministic (one thread).
[[nodiscard]] Pose2 refine_pose(const Grid& grid, const std::vector<Vec2>& points, const Pose2& guess, const RefineOptions& options);

// How well a match pins the pose down, from the information of the grid residuals around `pose` (the
// outer products of the grid's gradients at the points, each displaced by one cell). The translation's
// principal axes: along a corridor the weak axis (the corridor's) has little information; in a room
// both axes have much. The rotation's, with the translation free to follow it, as a lever arm: the
// distance from the node at which the strongest translation information would tell as much about the
// heading. Returns on a single short piece of wall (a tilted laser's node beside a long wall) pin the
// node across the wall and hardly its heading, a lever of centimetres; a room's walls around it, metres.
struct MatchInformation {
  double strong_axis_rad = 0;   // direction (submap frame) of the most translation information
  double weak_ratio = 1;        // translation information along the weak axis over along the strong one (0..1)
  double rotation_lever_m = 0;  // √(rotation information, translation marginalised / strongest translation information)
};
[[nodiscard]] MatchInformation match_information(const Grid& grid, const std::vector<Vec2>& points, const Pose2& pose);

// The grid's score of a pose: the mean grid value at the points' nearest cells (0..1).
[[nodiscard]] double pose_score(const Grid& grid, const std::vector<Vec2>& points, const Pose2& pose);

struct SearchWindow {
  double linear_m = 4.0;   // ± around the guess, in x and y
  double angular_rad = 0.35;
  double angular_step_rad = 0.0;  // 0: from the scan's extent (the farthest point moves one cell)
  // Poses scoring within this of the best are a plateau (a corridor along its length): of them, the
  // nearest to the guess. 0: exact ties only.
  double plateau_score = 0.0;
};

struct SearchResult {
  bool found = false;
  double score = 0;  // mean grid value at the points (0..1)
  Pose2 pose;        // submap_from_robot
};

// Cartographer's fast correlative scan matcher ("Real-time loop closure in 2D LIDAR SLAM", Hess et al.
// 2016, section V.C): precomputed grids of the maximum over 2^d × 2^d cells bound the score of every
// pose in a block of the window, and a depth-first branch and bound visits only blocks whose bound comes
// within the plateau (SearchWindow::plateau_score) of the best pose found. Built once per finished submap.
class CorrelativeMatcher {
 public:
  // `pool`: the search's cells are pool × pool grid cells (their maximum), for speed and memory; the
  // refinement afterwards works on the full grid. Levels are stored as bytes (value · 255).
  CorrelativeMatcher(const Grid& grid, int depth, int pool = 1);

  // The best pose within `window` of `guess` scoring at least `min_score`; of poses scoring within
  // window.plateau_score of it, the nearest to the guess, whatever the order the search visits them in.
  [[nodiscard]] SearchResult search(const std::vector<Vec2>& points, const Pose2& guess, const SearchWindow& window,
                                    double min_score) const;
  // The search levels' bytes.
  [[nodiscard]] std::size_t memory_bytes() const {
    std::size_t n = 0;
    for (const Level& l : levels_) n += l.values.capacity();
    return n;
  }

 private:
  struct Level {
    int pad = 0;  // cells of padding below x0 and y0 (the windows that start left of the grid)
    int width = 0, height = 0;
    std::vector<std::uint8_t> values;  // row-major, index (x − x0 + pad, y − y0 + pad)
    [[nodiscard]] std::uint8_t at(int x, int y) const {
      return (x < 0 || y < 0 || x >= width || y >= height) ? 0 : values[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)];
    }
  };
  struct Candidate;
  // A rotation's points as level cells (every level has the same width and height), their bounding
  // box, and their row-major indices: where the box stays inside the level, a score reads no bounds.
  struct RotatedScan {
    std::vector<std::array<int, 2>> cells;
    std::vector<std::ptrdiff_t> index;
    int x_min = 0, y_min = 0, x_max = -1, y_max = -1;
  };
  void branch(const std::vector<RotatedScan>& scans, std::vector<Candidate>& candidates, int depth, int max_x, int max_y,
              float min_score, float tolerance, float& best_score, std::vector<Candidate>& leaves) const;
  [[nodiscard]] float score(const Level& level, const RotatedScan& scan, int dx, int dy) const;

  CellBox box_;  // in search cells
  double resolution_m_;  // of a search cell
  std::vector<Level> levels_;  // levels_[d]: the maximum over 2^d × 2^d cells from (x, y) up
};

}  // namespace teamscan::posegraph
