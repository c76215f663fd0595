// Both matchers on a synthetic room: the refinement from a close guess, the correlative search with
// branch and bound from a guess a metre and ten degrees off (and its refusal of a scan of elsewhere);
// on a corridor, the search keeping the guess along it (its plateau), the translation's weak axis and
// the rotation's lever.
#include <gtest/gtest.h>

#include <cmath>

#include "groundstation/posegraph/matching.hpp"
#include "tests/unit/posegraph/room.hpp"

namespace teamscan::posegraph {
namespace {

Grid room_grid() {
  Grid g(0.05, 0.05);
  for (const Pose2& at : {Pose2{2, 1.5, 0}, Pose2{5.5, 3, 1.0}, Pose2{1.5, 4.5, -0.5}}) {
    std::vector<Vec2> pts;
    for (const Vec2& p : test::scan(at)) pts.push_back(at.apply(p));
    g.insert(pts);
  }
  return g;
}

TEST(Matching, RefinementRecoversASmallOffset) {
  const Grid g = room_grid();
  const Pose2 truth{4.0, 3.5, 0.3};
  const std::vector<Vec2> points = test::scan(truth);
  RefineOptions o;
  o.translation_weight = o.rotation_weight = 0.1;  // a weak pull towards the guess
  const Pose2 found = refine_pose(g, points, {4.06, 3.45, 0.33}, o);
  EXPECT_NEAR(found.x_m, truth.x_m, 0.01);
  EXPECT_NEAR(found.y_m, truth.y_m, 0.01);
  EXPECT_NEAR(found.theta_rad, truth.theta_rad, 0.004);
  EXPECT_GT(pose_score(g, points, found), pose_score(g, points, {4.06, 3.45, 0.33}));
}

TEST(Matching, CorrelativeSearchFindsAFarGuess) {
  const Grid g = room_grid();
  const CorrelativeMatcher m(g, 6);
  const Pose2 truth{4.0, 3.5, 0.3};
  const std::vector<Vec2> points = test::scan(truth);
  const SearchResult r = m.search(points, {4.9, 2.7, 0.3 + 0.17}, {1.5, 0.3, 0.005}, 0.5);
  ASSERT_TRUE(r.found);
  EXPECT_NEAR(r.pose.x_m, truth.x_m, 0.051);
  EXPECT_NEAR(r.pose.y_m, truth.y_m, 0.051);
  EXPECT_NEAR(r.pose.theta_rad, truth.theta_rad, 0.006);
  EXPECT_GT(r.score, 0.8);
  // Branch and bound returns the best pose of the window: no pose on the search's lattice beats it.
  EXPECT_GE(r.score + 1e-6, pose_score(g, points, {truth.x_m, truth.y_m, truth.theta_rad}) - 0.05);
  // Pooled search cells (2 × 2 grid cells): the same place within a search cell.
  const CorrelativeMatcher pooled(g, 5, 2);
  const SearchResult p = pooled.search(points, {4.9, 2.7, 0.47}, {1.5, 0.3, 0.005}, 0.5);
  ASSERT_TRUE(p.found);
  EXPECT_NEAR(p.pose.x_m, truth.x_m, 0.11);
  EXPECT_NEAR(p.pose.y_m, truth.y_m, 0.11);
  EXPECT_NEAR(p.pose.theta_rad, truth.theta_rad, 0.011);
  // Too demanding a score: nothing.
  EXPECT_FALSE(m.search(points, {4.9, 2.7, 0.47}, {1.5, 0.3, 0.005}, 0.999).found);
  // A scan of a place outside the window is not forced onto the room.
  std::vector<Vec2> line;
  for (int i = 0; i < 100; ++i) line.push_back({1.0, -1.0 + 0.02 * i});
  const SearchResult wrong = m.search(line, {4, 3, 0}, {1.0, 0.2, 0.01}, 0.9);
  EXPECT_FALSE(wrong.found);
}

// A corridor along x (walls at y = 0 and y = 2, 20 m long) and a scan of its walls from (0, 1): the
// scan pins y down, not x.
struct Corridor {
  Grid grid{0.03, 0.03};
  std::vector<Vec2> seen;
  Corridor() {
    std::vector<Vec2> walls;
    for (int i = 0; i <= 1000; ++i) {
      walls.push_back({-10.0 + 0.02 * i, 0.0});
      walls.push_back({-10.0 + 0.02 * i, 2.0});
    }
    grid.insert(walls);
    for (int i = 0; i <= 200; ++i) {
      seen.push_back({-2.0 + 0.02 * i, -1.0});
      seen.push_back({-2.0 + 0.02 * i, 1.0});
    }
  }
};

TEST(Matching, CorrelativeSearchOnAPlateauKeepsTheGuess) {
  // Along the corridor the score only ripples (the wall's samples against the cells): the search must
  // not slide to the window's corner (the first of the near-ties it happens to visit) but stay at the
  // guess's x, and find y. Exact ties only: the nearest of the ripple's tops (period 3 cells).
  const Corridor c;
  const CorrelativeMatcher m(c.grid, 5);
  for (const double guess_x : {-0.7, 0.0, 0.4}) {
    const SearchResult exact = m.search(c.seen, {guess_x, 1.2, 0.0}, {1.0, 0.1, 0.01}, 0.5);
    ASSERT_TRUE(exact.found);
    EXPECT_NEAR(exact.pose.x_m, guess_x, 0.061);
    EXPECT_NEAR(exact.pose.y_m, 1.0, 0.031);
    EXPECT_NEAR(exact.pose.theta_rad, 0.0, 0.011);
    // Scores within 0.02 of the best are one plateau: its pose nearest the guess.
    const SearchResult plateau = m.search(c.seen, {guess_x, 1.2, 0.0}, {1.0, 0.1, 0.01, 0.02}, 0.5);
    ASSERT_TRUE(plateau.found);
    EXPECT_NEAR(plateau.pose.x_m, guess_x, 1e-9);
    EXPECT_NEAR(plateau.pose.y_m, 1.0, 0.031);
    EXPECT_GE(plateau.score, exact.score - 0.02);
  }
  // A true peak still wins over a plateau's pose nearer the guess: the room from afar.
  const Grid g = room_grid();
  const Pose2 truth{4.0, 3.5, 0.3};
  const SearchResult room = CorrelativeMatcher(g, 6).search(test::scan(truth), {4.9, 2.7, 0.47}, {1.5, 0.3, 0.005, 0.02}, 0.5);
  ASSERT_TRUE(room.found);
  EXPECT_NEAR(room.pose.x_m, truth.x_m, 0.051);
  EXPECT_NEAR(room.pose.y_m, truth.y_m, 0.051);
  EXPECT_NEAR(room.pose.theta_rad, truth.theta_rad, 0.006);
}

TEST(Matching, InformationOfACorridorAndOfARoom) {
  const Corridor corridor;
  const MatchInformation c = match_information(corridor.grid, corridor.seen, {0.0, 1.0, 0.0});
  EXPECT_NEAR(std::abs(std::sin(c.strong_axis_rad)), 1.0, 0.01);  // across the corridor
  EXPECT_LT(c.weak_ratio, 0.05);
  // Its walls seen over 4 m pin the heading: a lever of the returns' spread along them (2 / √3 m rms);
  // 8 cm of the same walls hardly (a tilted laser's node beside a long wall): what is left is the grid's
  // ripple along the walls, which the weak axis's ratio has too.
  EXPECT_NEAR(c.rotation_lever_m, 2.0 / std::sqrt(3.0), 0.15);
  std::vector<Vec2> piece;
  for (const Vec2& p : corridor.seen)
    if (std::abs(p.x) <= 0.04) piece.push_back(p);
  EXPECT_LT(match_information(corridor.grid, piece, {0.0, 1.0, 0.0}).rotation_lever_m, 0.2);  // the ripple along the walls
  const Grid g = room_grid();
  const Pose2 at{4.0, 3.5, 0.3};
  const MatchInformation r = match_information(g, test::scan(at), at);
  EXPECT_GT(r.weak_ratio, 0.2);
  EXPECT_LE(r.weak_ratio, 1.0);
  EXPECT_GT(r.rotation_lever_m, 1.0);
}

}  // namespace
}  // namespace teamscan::posegraph
