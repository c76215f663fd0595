// The pose graph: a square loop whose odometry drifts is closed by one closure; a false closure under
// the Huber loss moves the poses far less than it would obeyed; a closure weak along one axis holds
// little along it; the odometry's rotation holds less in a turn; a robot's odometry slip and drift
// found by the calibration in the graph.
// (Closures are robust: each pulls with a bounded force, so a drifted loop needs several of them.)
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "groundstation/posegraph/pose_graph.hpp"
#include "groundstation/posegraph/slam.hpp"

namespace teamscan::posegraph {
namespace {

// Four 2 m sides, a node every metre (9 nodes: back at the start), odometry turning 95° at corners.
// The chain here is only odometry (both link kinds weighted as odometry): soft enough for three
// bounded pulls to close it.
GraphOptions soft_chain() {
  GraphOptions o;
  o.local_translation_weight = o.odometry_translation_weight;
  o.local_rotation_weight = o.odometry_rotation_weight;
  return o;
}

struct Loop {
  explicit Loop(const GraphOptions& o) : graph(o) {}
  PoseGraph graph;
  std::vector<Pose2> truth;
};

Loop drifted_loop(bool closure, bool false_closure, const GraphOptions& options = soft_chain()) {
  Loop l(options);
  Pose2 truth{0, 0, 0}, odo{0, 0, 0};
  const std::size_t s = l.graph.add_submap({0, 0, 0});
  for (int i = 0; i <= 8; ++i) {
    if (i > 0) {
      const bool corner = i % 2 == 0;
      const Pose2 step{1.0, 0.0, corner ? kPi / 2 : 0.0}, drifted{1.0, 0.0, corner ? kPi / 2 + 0.09 : 0.0};
      const Pose2 prev_odo = odo;
      truth = truth * step;
      odo = odo * drifted;
      l.graph.add_node(odo, false);
      l.graph.add_link({static_cast<std::size_t>(i - 1), static_cast<std::size_t>(i), 0, prev_odo.inverse() * odo, prev_odo.inverse() * odo});
    } else {
      l.graph.add_node(odo, true);
      l.graph.add_constraint({s, 0, {0, 0, 0}, Constraint::Kind::inserted});
    }
    l.truth.push_back(truth);
  }
  // The revisit: the last three nodes seen from the first submap (where they truly are).
  if (closure)
    for (std::size_t n : {6u, 7u, 8u}) l.graph.add_constraint({s, n, l.truth[n], Constraint::Kind::closure});
  if (false_closure) l.graph.add_constraint({s, 4, {3.0, -1.0, 1.0}, Constraint::Kind::closure});
  return l;
}

double end_error(const Loop& l) { return std::hypot(l.graph.nodes()[8].x_m - l.truth[8].x_m, l.graph.nodes()[8].y_m - l.truth[8].y_m); }

TEST(PoseGraph, ClosureClosesADriftedLoop) {
  Loop open = drifted_loop(false, false);
  const double before = end_error(open);
  EXPECT_GT(before, 0.3);
  open.graph.optimize();
  EXPECT_NEAR(end_error(open), before, 1e-6);  // nothing to correct it
  Loop closed = drifted_loop(true, false);
  closed.graph.optimize();
  EXPECT_LT(end_error(closed), 0.5 * before);  // bounded pulls against a stiff chain: part of the way
  EXPECT_EQ(closed.graph.closures(), 3u);
  EXPECT_DOUBLE_EQ(closed.graph.nodes()[0].x_m, 0.0);  // the anchor holds
}

TEST(PoseGraph, FalseClosureIsOutvoted) {
  Loop l = drifted_loop(true, true, GraphOptions{});  // the default chain: local SLAM's motions held stiffly
  l.graph.optimize();
  // The false closure wants node 4 at (3, −1); the chain and the true closure keep it near (2, 2).
  const Pose2 n4 = l.graph.nodes()[4];
  EXPECT_LT(std::hypot(n4.x_m - l.truth[4].x_m, n4.y_m - l.truth[4].y_m), 0.5);
}

// A closure whose match is weak along x (a corridor along x) moves its node across, not along.
TEST(PoseGraph, WeakAxisOfAClosureHoldsLittle) {
  auto place = [](double weak_axis_factor) {
    GraphOptions o;
    o.closure_huber_scale = 1e9;  // quadratic: the weights alone decide
    PoseGraph g(o);
    const std::size_t s = g.add_submap({0, 0, 0});
    g.add_node({0, 0, 0}, true);
    g.add_constraint({s, 0, {0, 0, 0}, Constraint::Kind::inserted});
    const std::size_t n = g.add_node({1, 0, 0}, false);
    g.add_constraint({s, n, {1, 0, 0}, Constraint::Kind::inserted});
    g.add_constraint({s, n, {1.5, 0.5, 0}, Constraint::Kind::closure, kPi / 2, weak_axis_factor});
    g.optimize();
    return g.nodes()[n];
  };
  const Pose2 isotropic = place(1.0), corridor = place(0.01);
  EXPECT_GT(isotropic.x_m, 1.4);
  EXPECT_NEAR(isotropic.y_m, 0.5, 0.01);
  EXPECT_LT(corridor.x_m, 1.1);  // the inserted scan's x wins along the weak axis
  EXPECT_NEAR(corridor.y_m, 0.5, 0.01);
}

// Two nodes, the first held, linked by the odometry alone (`moved`); a submap held where the first put
// it, and a closure of the second that disagrees with the odometry in yaw by 0.05 rad. Returns how far
// the closure turned the second node; the weights in `o` alone decide (quadratic loss).
double yaw_a_closure_turns(GraphOptions o, const Pose2& moved, double closure_rotation_factor = 1.0) {
  o.closure_huber_scale = 1e9;
  o.local_translation_weight = o.local_rotation_weight = 0;
  o.matcher_translation_weight = o.matcher_rotation_weight = 1e9;
  PoseGraph g(o);
  const std::size_t s = g.add_submap({0, 0, 0});
  g.add_node({0, 0, 0}, true);
  g.add_constraint({s, 0, {0, 0, 0}, Constraint::Kind::inserted});
  const std::size_t n = g.add_node(moved, false);
  g.add_link({0, n, 0, moved, moved});
  Constraint closure{s, n, {moved.x_m, moved.y_m, moved.theta_rad + 0.05}, Constraint::Kind::closure};
  closure.rotation_factor = closure_rotation_factor;
  g.add_constraint(closure);
  g.optimize();
  return g.nodes()[n].theta_rad - moved.theta_rad;
}

// The odometry's rotation is held less stiffly in a turn: a closure that disagrees with it in yaw
// moves a node that turned further than one that drove straight.
TEST(PoseGraph, OdometryInATurnHoldsItsRotationLessStiffly) {
  auto yaw_moved = [](double turn_rad, double turn_sigma_rad_per_rad) {
    GraphOptions o;
    o.odometry_rotation_weight = o.closure_rotation_weight;
    o.odometry_turn_sigma_rad_per_rad = turn_sigma_rad_per_rad;
    return yaw_a_closure_turns(o, {1, 0, turn_rad});
  };
  // Equal weights: the closure gets half of its 0.05 rad, whichever way the robot turned.
  EXPECT_NEAR(yaw_moved(0.0, 0.0), 0.025, 1e-3);
  EXPECT_NEAR(yaw_moved(kPi / 2, 0.0), 0.025, 1e-3);
  // With the turn's σ: straight as before, a quarter turn (σ 0.016 rad against the closure's 10⁻⁵) all of it.
  EXPECT_NEAR(yaw_moved(0.0, 0.01), 0.025, 1e-3);
  EXPECT_NEAR(yaw_moved(kPi / 2, 0.01), 0.05, 1e-3);
}

// A closure whose match says little about the heading (rotation_factor 0.1: a hundredth of the
// information) turns its node little: the odometry's heading stands.
TEST(PoseGraph, AClosureWithoutALeverHoldsTheHeadingLittle) {
  GraphOptions o;
  o.odometry_rotation_weight = o.closure_rotation_weight;
  EXPECT_NEAR(yaw_a_closure_turns(o, {1, 0, 0}, 1.0), 0.025, 1e-3);         // equal weights: half of the closure's 0.05 rad
  EXPECT_NEAR(yaw_a_closure_turns(o, {1, 0, 0}, 0.1), 0.05 / 101.0, 1e-4);  // information 1 : 100
}

// Wheels that did not turn between two nodes hold them together rest_weight_factor times as stiffly
// (a hundred times the information): a closure that disagrees in yaw hardly turns a robot at rest,
// where it turns one that drove a centimetre half way.
TEST(PoseGraph, WheelsAtRestHoldTheRobotWhereItStood) {
  auto yaw_moved = [](const Pose2& moved, double rest_weight_factor) {
    GraphOptions o;
    o.odometry_translation_weight = o.closure_translation_weight;
    o.odometry_rotation_weight = o.closure_rotation_weight;
    o.rest_weight_factor = rest_weight_factor;
    return yaw_a_closure_turns(o, moved);
  };
  const Pose2 at_rest{0.0002, 0, 0.0003}, drove{0.01, 0, 0};
  EXPECT_NEAR(yaw_moved(at_rest, 1.0), 0.025, 1e-3);          // as any link: half of the closure's 0.05 rad
  EXPECT_NEAR(yaw_moved(at_rest, 10.0), 0.05 / 101.0, 1e-4);  // information 100 : 1
  EXPECT_NEAR(yaw_moved(drove, 10.0), 0.025, 1e-3);           // it moved: as any link
}

// Odometry that stalls reports no motion while local SLAM sees the robot turn: not a robot at rest. Its
// link is held as any other (local SLAM's turn, ten times as stiff, wins), not as stiffly as local SLAM.
TEST(PoseGraph, OdometryThatStallsIsNotARobotAtRest) {
  auto turned = [](double local_turn_rad) {
    PoseGraph g{GraphOptions{}};  // odometry 10³, local SLAM 10⁴ per radian, at rest ten times the odometry's
    g.add_node({0, 0, 0}, true);
    const std::size_t n = g.add_node({0, 0, 0}, false);
    g.add_link({0, n, 1, Pose2{}, Pose2{0, 0, local_turn_rad}});
    g.optimize();
    return g.nodes()[n].theta_rad;
  };
  EXPECT_NEAR(turned(0.14), 0.14 * 100.0 / 101.0, 1e-4);  // information 1 : 100, as any link
  EXPECT_NEAR(turned(0.002), 0.001, 1e-5);                // local SLAM saw it stand too: at rest, 100 : 100
}

// A tilted laser's robot drives 2 m along a wall, a node every 2 cm, its odometry and local SLAM
// right; over the second metre every node has a closure that puts it 2 cm further along the wall,
// where the match cannot tell (the weak axis, at the floor's weight). With tilted_laser_options,
// local SLAM's motion held stiffly, the shared bias moves the chain about half as far as with local
// SLAM's links held only as stiffly as the odometry's translation (the odometry calibration takes up
// part of it either way).
double along_error_under_biased_closures(const GraphOptions& o) {
  PoseGraph g(o);
  const std::size_t s = g.add_submap({0, 0, 0});
  constexpr int kNodes = 100;
  constexpr double kStep = 0.02, kBias = 0.02;
  const Pose2 step{kStep, 0, 0};
  for (int i = 0; i < kNodes; ++i) {
    const Pose2 truth{kStep * i, 0, 0};
    g.add_node(truth, i == 0);
    if (i == 0) g.add_constraint({s, 0, truth, Constraint::Kind::inserted});
    if (i > 0) g.add_link({static_cast<std::size_t>(i - 1), static_cast<std::size_t>(i), 0, step, step});
    if (i >= kNodes / 2) {
      Constraint closure{s, static_cast<std::size_t>(i), {truth.x_m + kBias, 0, 0}, Constraint::Kind::closure};
      closure.strong_axis_rad = kPi / 2;  // across the wall; along it (x) the weak axis
      closure.weak_axis_factor = 0.1;
      g.add_constraint(closure);
    }
  }
  g.optimize(true);
  double worst = 0;
  for (int i = 0; i < kNodes; ++i) worst = std::max(worst, std::abs(g.nodes()[static_cast<std::size_t>(i)].x_m - kStep * i));
  return worst;
}

TEST(PoseGraph, TiltedLasersLocalSlamHoldsTheChainAgainstTheClosuresSharedBias) {
  const GraphOptions tilted = tilted_laser_options().graph;
  GraphOptions weak = tilted;
  weak.local_translation_weight = weak.odometry_translation_weight;
  const double held = along_error_under_biased_closures(tilted), gave = along_error_under_biased_closures(weak);
  std::printf("worst along-wall error: %.4f m with tilted_laser_options, %.4f m with local SLAM's links as the odometry's\n", held, gave);
  EXPECT_LT(held, 0.7 * gave);
}

// A robot lapping a circle whose odometry reports 2 % too far and turns 0.2° a metre too many: two laps, the
// second tied to where it truly is by closures. Both links held as stiffly as a tilted laser's; the
// calibration in the graph finds the slip and the drift and the poses follow the truth, where without
// it the closures' bounded pulls leave the chain bent.
struct CalibratedLap {
  double worst_m = 0;
  OdometryCalibration found;
};

// `gate`: GraphOptions::calibrate_after_loop, with the robot's calibration freed (free_calibration) or not.
enum class Gate { none, held, freed };

CalibratedLap lap_with_slip(bool calibrate, Gate gate = Gate::none) {
  GraphOptions o;
  o.odometry_translation_weight = 1e4;
  o.odometry_rotation_weight = 1e5;
  o.calibrate_odometry = o.calibrate_local_links = calibrate;
  o.calibrate_after_loop = gate != Gate::none;
  PoseGraph g(o);
  if (gate == Gate::freed) g.free_calibration(1);
  constexpr double kRadius = 1.5, kStep = 0.1, kScale = 1.02, kDriftRadPerM = 0.2 * kPi / 180.0;
  const int per_lap = static_cast<int>(2.0 * kPi * kRadius / kStep);
  const std::size_t s = g.add_submap({0, 0, 0});
  std::vector<Pose2> truth{{0, 0, 0}};
  g.add_node({0, 0, 0}, true);
  g.add_constraint({s, 0, {0, 0, 0}, Constraint::Kind::inserted});
  Pose2 odo{0, 0, 0};
  for (int i = 1; i <= 2 * per_lap; ++i) {
    const double turn = kStep / kRadius;
    const Pose2 step{kRadius * std::sin(turn), kRadius * (1.0 - std::cos(turn)), turn};
    const Pose2 reported{kScale * step.x_m, kScale * step.y_m, turn + kDriftRadPerM * kScale * kStep};
    const Pose2 prev = odo;
    odo = odo * reported;
    truth.push_back(truth.back() * step);
    const std::size_t n = g.add_node(odo, false);
    g.add_link({n - 1, n, 1, prev.inverse() * odo, prev.inverse() * odo});
    if (i > per_lap && i % 5 == 0) g.add_constraint({s, n, truth.back(), Constraint::Kind::closure});
  }
  g.optimize(true);
  CalibratedLap out;
  for (std::size_t i = 0; i < truth.size(); ++i)
    out.worst_m = std::max(out.worst_m, std::hypot(g.nodes()[i].x_m - truth[i].x_m, g.nodes()[i].y_m - truth[i].y_m));
  out.found = g.calibration(1);
  return out;
}

TEST(PoseGraph, CalibrationFindsTheOdometrysSlipAndTurn) {
  const CalibratedLap plain = lap_with_slip(false), calibrated = lap_with_slip(true);
  std::printf("worst %.3f m without, %.3f m with the calibration; found distance × %.4f, turn × %.4f, drift %.3f°/m\n", plain.worst_m,
              calibrated.worst_m, calibrated.found.distance_scale, calibrated.found.turn_scale,
              calibrated.found.heading_drift_rad_per_m * 180.0 / kPi);
  EXPECT_DOUBLE_EQ(plain.found.distance_scale, 1.0);  // not calibrated: no error
  EXPECT_NEAR(calibrated.found.distance_scale, 1.0 / 1.02, 0.003);
  // On a circle the turn is in proportion to the distance, so the turn scale and the drift per metre
  // trade against each other: what the laps fix is the turn per metre they give together, the truth's.
  const OdometryCalibration& k = calibrated.found;
  const double reported_turn_per_m = 1.0 / (1.5 * 1.02) + 0.2 * kPi / 180.0;  // per reported metre
  EXPECT_NEAR(k.turn_scale * (reported_turn_per_m - k.heading_drift_rad_per_m) / k.distance_scale, 1.0 / 1.5, 2e-4);
  EXPECT_GT(plain.worst_m, 0.05);
  EXPECT_LT(calibrated.worst_m, 0.02);
}

// Held until a loop measures it: the calibration stays at none and the chain as without it; freed, it
// is found as when always on, to the bit.
TEST(PoseGraph, CalibrationHeldUntilFreedByALoop) {
  const CalibratedLap always = lap_with_slip(true), held = lap_with_slip(true, Gate::held), freed = lap_with_slip(true, Gate::freed);
  EXPECT_DOUBLE_EQ(held.found.distance_scale, 1.0);
  EXPECT_DOUBLE_EQ(held.found.turn_scale, 1.0);
  EXPECT_DOUBLE_EQ(held.found.heading_drift_rad_per_m, 0.0);
  EXPECT_GT(held.worst_m, 0.05);
  EXPECT_EQ(freed.found.distance_scale, always.found.distance_scale);
  EXPECT_EQ(freed.worst_m, always.worst_m);
  EXPECT_LT(freed.worst_m, 0.02);
}

TEST(PoseGraph, SameInputSamePoses) {
  Loop a = drifted_loop(true, true), b = drifted_loop(true, true);
  a.graph.optimize();
  b.graph.optimize();
  for (std::size_t i = 0; i < a.graph.nodes().size(); ++i) EXPECT_EQ(a.graph.nodes()[i], b.graph.nodes()[i]);
}

}  // namespace
}  // namespace teamscan::posegraph
