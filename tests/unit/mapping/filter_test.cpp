// The paper's filters on hand-built clouds where the right answer is known (PAPER_NOTES eqs. 4–8).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "groundstation/mapping/filter.hpp"
#include "onboard/core/direction_reference.hpp"

namespace teamscan::mapping {
namespace {

ScanView make_scan(std::uint8_t robot, const std::vector<MapPoint>& points, const TeamState* team = nullptr,
                   Pose2 pose = {}) {
  ScanView v;
  v.robot = robot;
  v.points = points;
  v.team = team;
  v.map_from_robot = pose;
  return v;
}

std::vector<std::uint8_t> classify(const Filter& f, const ScanView& v) {
  std::vector<std::uint8_t> removed(v.points.size(), 7);  // 7: a value the filter must overwrite
  f.classify(v, removed);
  return removed;
}

TeamState team_with(std::uint8_t robot, Vec2 position, bool valid = true) {
  TeamState t;
  RobotEstimate e;
  e.robot = robot;
  e.valid = valid;
  e.position_m = position;
  t.robots.push_back(e);
  return t;
}

// ---- visibility (eq. 5) ----

TEST(VisibilityFilter, RemovesARobotVoxelAboveAFloorVoxelInTheSameColumn) {
  VisibilityFilter f({0.1});
  const std::vector<MapPoint> pts{{0.05f, 0.05f, 0.02f},   // floor voxel z 0
                                  {0.06f, 0.04f, 0.35f},   // robot body above it: z 3
                                  {0.07f, 0.03f, 0.03f},   // same floor voxel: kept
                                  {0.55f, 0.05f, 0.35f}};  // alone in its column: kept
  const ScanView v = make_scan(1, pts);
  f.observe(v);
  EXPECT_EQ(classify(f, v), (std::vector<std::uint8_t>{0, 1, 0, 0}));
}

TEST(VisibilityFilter, FloorNoiseStraddlingAVoxelBoundaryAndTheGridOffset) {
  // A floor at z = 0 with ±3 mm noise: with the paper's grid (origin 0) the points above 0 sit one voxel
  // above those below and are filtered; a grid offset of −r/2 puts the whole floor in one voxel.
  const std::vector<MapPoint> floor{{0.05f, 0.05f, -0.003f}, {0.06f, 0.05f, 0.003f}, {0.07f, 0.05f, 0.001f}};
  VisibilityFilter paper({0.1, 0.0});
  paper.observe(make_scan(1, floor));
  EXPECT_EQ(classify(paper, make_scan(1, floor)), (std::vector<std::uint8_t>{0, 1, 1}));
  VisibilityFilter centred({0.1, -0.05});
  centred.observe(make_scan(1, floor));
  EXPECT_EQ(classify(centred, make_scan(1, floor)), (std::vector<std::uint8_t>{0, 0, 0}));
  EXPECT_EQ(centred.map().key_of({0.0f, 0.0f, 0.049f}).z, 0);
  EXPECT_EQ(centred.map().key_of({0.0f, 0.0f, 0.051f}).z, 1);
}

TEST(VisibilityFilter, LiveDecisionUsesTheMapSoFar) {
  VisibilityFilter f({0.1});
  const std::vector<MapPoint> high{{0.05f, 0.05f, 0.45f}};
  const std::vector<MapPoint> low{{0.05f, 0.05f, 0.01f}};
  f.observe(make_scan(1, high));
  EXPECT_EQ(classify(f, make_scan(1, high)), (std::vector<std::uint8_t>{0}));  // nothing below yet
  f.observe(make_scan(2, low));
  EXPECT_EQ(classify(f, make_scan(1, high)), (std::vector<std::uint8_t>{1}));  // the floor arrived
  f.reset();
  EXPECT_EQ(f.map().occupied_voxels(), 0u);
}

// ---- frequency (eq. 4) ----

TEST(FrequencyFilter, RemovesVoxelsBelowMeanMinusKSigma) {
  // Voxel counts 1, 2, 3, 6: μ = 3, σ = √3.5 ≈ 1.871. k = 0 → threshold 3: counts 1 and 2 go.
  // k = 0.6 → threshold ≈ 1.88: only count 1 goes. k = 1.5 → threshold ≈ 0.19: only a free voxel
  // (count 0) is below it. k = 2 → threshold < 0: nothing goes.
  std::vector<MapPoint> pts;
  const int counts[] = {1, 2, 3, 6};
  for (int v = 0; v < 4; ++v)
    for (int i = 0; i < counts[v]; ++i) pts.push_back({static_cast<float>(v) + 0.5f, 0.5f, 0.5f});
  const std::vector<MapPoint> probe{{0.5f, 0.5f, 0.5f}, {1.5f, 0.5f, 0.5f}, {2.5f, 0.5f, 0.5f}, {3.5f, 0.5f, 0.5f}, {9.5f, 0.5f, 0.5f}};
  auto run = [&](double k) {
    FrequencyFilter f({1.0, k});
    f.observe(make_scan(1, pts));
    return classify(f, make_scan(1, probe));
  };
  // A point in a free voxel (count 0) is below any positive threshold.
  EXPECT_EQ(run(0.0), (std::vector<std::uint8_t>{1, 1, 0, 0, 1}));
  EXPECT_EQ(run(0.6), (std::vector<std::uint8_t>{1, 0, 0, 0, 1}));
  EXPECT_EQ(run(1.5), (std::vector<std::uint8_t>{0, 0, 0, 0, 1}));
  EXPECT_EQ(run(2.0), (std::vector<std::uint8_t>{0, 0, 0, 0, 0}));
  FrequencyFilter f({1.0, 0.5});
  f.observe(make_scan(1, pts));
  EXPECT_NEAR(f.threshold(), 3.0 - 0.5 * std::sqrt(3.5), 1e-12);
}

TEST(FrequencyFilter, UniformCountsRemoveNothingAtKZero) {
  FrequencyFilter f({0.1, 0.0});
  const std::vector<MapPoint> pts{{0.05f, 0.05f, 0.05f}, {0.15f, 0.05f, 0.05f}, {0.25f, 0.05f, 0.05f}};
  f.observe(make_scan(1, pts));
  EXPECT_EQ(classify(f, make_scan(1, pts)), (std::vector<std::uint8_t>{0, 0, 0}));  // count 1 is not < μ = 1
}

// ---- position (eq. 6) ----

TEST(PositionFilter, RemovesPointsWithinNSigmaHorizontallyOfAnotherRobot) {
  PositionFilter f({0.35, 1.0});
  const TeamState team = team_with(2, {1.0, 0.0});
  const std::vector<MapPoint> pts{{1.34f, 0.0f, 0.3f},   // 0.34 m < 0.35: removed
                                  {1.36f, 0.0f, 0.3f},   // 0.36 m: kept
                                  {1.0f, 0.2f, 2.5f},    // horizontal test only: removed at any height
                                  {0.0f, 0.0f, 0.1f}};   // far: kept
  EXPECT_EQ(classify(f, make_scan(1, pts, &team)), (std::vector<std::uint8_t>{1, 0, 1, 0}));
}

TEST(PositionFilter, IgnoresTheScanningRobotItselfInvalidTracksAndMissingTeam) {
  PositionFilter f({0.35, 2.0});
  const std::vector<MapPoint> pts{{1.0f, 0.0f, 0.3f}};
  const TeamState self = team_with(1, {1.0, 0.0});
  const TeamState lost = team_with(2, {1.0, 0.0}, false);
  EXPECT_EQ(classify(f, make_scan(1, pts, &self)), (std::vector<std::uint8_t>{0}));
  EXPECT_EQ(classify(f, make_scan(1, pts, &lost)), (std::vector<std::uint8_t>{0}));
  EXPECT_EQ(classify(f, make_scan(1, pts, nullptr)), (std::vector<std::uint8_t>{0}));
}

// ---- direction (eq. 7) ----

TEST(DirectionFilter, PointJustInsideAndJustOutsideTheCone) {
  // R1 at the origin, R2 at (2, 0); ha = 7°. At 3 m along L the cone's half-width is 3·tan 7° ≈ 0.3684 m.
  DirectionOptions o;
  o.half_angle_rad = 7.0 * kPi / 180.0;
  DirectionFilter f(o);
  const TeamState team = team_with(2, {2.0, 0.0});
  const double half_width = 3.0 * std::tan(o.half_angle_rad);
  const std::vector<MapPoint> pts{{3.0f, static_cast<float>(half_width - 0.005), 0.2f},    // inside
                                  {3.0f, static_cast<float>(half_width + 0.005), 0.2f},    // outside
                                  {3.0f, static_cast<float>(-(half_width - 0.005)), 0.2f}, // inside, other side
                                  {-3.0f, 0.0f, 0.2f},                                     // behind R1
                                  {8.0f, 0.0f, 0.2f}};  // far behind R2 on L: the paper's rule removes it
  EXPECT_EQ(classify(f, make_scan(1, pts, &team)), (std::vector<std::uint8_t>{1, 0, 1, 0, 1}));
}

TEST(DirectionFilter, ConeFollowsTheOwnPoseAndAnyDirection) {
  DirectionOptions o;
  o.half_angle_rad = 5.0 * kPi / 180.0;
  DirectionFilter f(o);
  const TeamState team = team_with(2, {1.0, 3.0});
  // R1 at (1, 1): L points along +y. A point at (1.1, 4) is 3 m along, 0.1 m across: tan⁻¹(0.1/3) = 1.9° < 5°.
  const std::vector<MapPoint> pts{{1.1f, 4.0f, 0.0f}, {1.4f, 4.0f, 0.0f}};  // 0.4/3 → 7.6°: outside
  EXPECT_EQ(classify(f, make_scan(1, pts, &team, Pose2{1.0, 1.0, 0.3})), (std::vector<std::uint8_t>{1, 0}));
}

TEST(DirectionFilter, RangeAndHeightGatesWorkWhenSet) {
  // Onboard variant: range gate |along − |R1R2|| ≤ body radius 0.36 + margin 0.3 = 0.66 m;
  // height gate z ≤ height 0.5 + margin 0.1 = 0.6 m.
  DirectionOptions o;
  o.half_angle_rad = 7.0 * kPi / 180.0;
  o.range_gate = true;
  o.height_gate = true;
  DirectionFilter f(o);
  const TeamState team = team_with(2, {2.0, 0.0});
  const std::vector<MapPoint> pts{{2.2f, 0.0f, 0.3f},    // on R2: removed
                                  {2.6f, 0.0f, 0.55f},   // 0.6 m beyond, 0.55 high: inside both gates
                                  {2.7f, 0.0f, 0.3f},    // 0.7 m beyond R2: gated out
                                  {1.3f, 0.0f, 0.3f},    // 0.7 m before R2: gated out
                                  {2.2f, 0.0f, 0.65f}};  // above the height gate
  EXPECT_EQ(classify(f, make_scan(1, pts, &team)), (std::vector<std::uint8_t>{1, 1, 0, 0, 0}));
  // Without the gates (the paper's rule) every one of them is in the cone.
  DirectionFilter paper(DirectionOptions{});
  EXPECT_EQ(classify(paper, make_scan(1, pts, &team)), (std::vector<std::uint8_t>{1, 1, 1, 1, 1}));
}

TEST(DirectionFilter, AgreesWithTheOnboardDoublePrecisionReferenceAwayFromTheBoundary) {
  // The ground station evaluates eq. 7 with the robot's fixed-point code; compare it with the paper's
  // formula in double precision (onboard/core/direction_reference.hpp) on random points.
  DirectionOptions o;
  o.half_angle_rad = 5.0 * kPi / 180.0;
  DirectionFilter f(o);
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> u(-6.0, 6.0);
  int compared = 0, inside = 0;
  for (int i = 0; i < 20000; ++i) {
    const Vec2 self{u(rng), u(rng)}, other{u(rng), u(rng)};
    const MapPoint p{static_cast<float>(u(rng)), static_cast<float>(u(rng)), 0.2f};
    onboard::ConeReference ref;
    ref.apex_x_m = std::nearbyint(self.x * 1000) / 1000;
    ref.apex_y_m = std::nearbyint(self.y * 1000) / 1000;
    ref.mate_x_m = std::nearbyint(other.x * 1000) / 1000;
    ref.mate_y_m = std::nearbyint(other.y * 1000) / 1000;
    ref.half_angle_rad = o.half_angle_rad;
    const onboard::ConeDecision d =
        onboard::cone_reference(ref, std::nearbyint(p.x * 1000.0) / 1000, std::nearbyint(p.y * 1000.0) / 1000, p.z);
    if (d.boundary_distance_m < 0.002) continue;  // fixed point may differ within a couple of mm of the edge
    ++compared;
    inside += d.inside ? 1 : 0;
    ASSERT_EQ(f.cone_contains(self, other, p), d.inside) << i;
  }
  EXPECT_GT(compared, 19000);
  EXPECT_GT(inside, 100);
}

TEST(DirectionFilter, FlagsSourceUsesTheOnboardDecision) {
  DirectionOptions o;
  o.source = DirectionSource::flags;
  DirectionFilter f(o);
  const std::vector<MapPoint> pts{{1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
  const std::vector<std::uint16_t> flags{0, point_flags::kDirectionFiltered,
                                         point_flags::kDirectionFiltered | point_flags::kFieldA};
  ScanView v = make_scan(1, pts);
  v.flags = flags;
  EXPECT_EQ(classify(f, v), (std::vector<std::uint8_t>{0, 1, 1}));
}

// ---- combined (PAPER_NOTES 8) ----

TEST(CombinedFilter, VisibilityMapIsBuiltFromTheDirectionFilterSurvivorsOnly) {
  MethodOptions options;
  options.combined_half_angle_rad = 7.0 * kPi / 180.0;
  options.combined_resolution_m = 0.1;
  auto f = make_filter("combined", options);
  ASSERT_NE(f, nullptr);
  const TeamState team = team_with(2, {2.0, 0.0});
  // Robot 1 (R2 at (2, 0) ahead): a floor point and a table top in a column off the cone, and a low
  // point in the cone. Robot 3 (no teammate in view) sees a point above that cone point.
  const std::vector<MapPoint> scan1{{5.05f, 5.05f, 0.02f}, {5.05f, 5.05f, 0.75f}, {2.05f, 0.05f, 0.05f}};
  ScanView v1 = make_scan(1, scan1, &team);
  // Robot 3 sees the point above (2.05, 0.05) from elsewhere, with no teammate in its direction.
  const TeamState no_team;
  const std::vector<MapPoint> scan2{{2.05f, 0.05f, 0.45f}};
  ScanView v2 = make_scan(3, scan2, &no_team);
  f->observe(v1);
  f->observe(v2);
  EXPECT_EQ(classify(*f, v1), (std::vector<std::uint8_t>{0, 1, 1}));
  // Robot 1's cone point never entered the map, so robot 3's point is the column's lowest: kept.
  EXPECT_EQ(classify(*f, v2), (std::vector<std::uint8_t>{0}));
}

TEST(FilterFactory, KnowsThePaperMethodsAndRejectsOthers) {
  for (const std::string& m : known_methods()) {
    auto f = make_filter(m, {});
    ASSERT_NE(f, nullptr) << m;
    EXPECT_EQ(f->method(), m);
    EXPECT_FALSE(f->params().empty());
  }
  EXPECT_EQ(make_filter("freespace-typo", {}), nullptr);
}

}  // namespace
}  // namespace teamscan::mapping
