// The team's pose graph (pose_graph.hpp).
#include "groundstation/posegraph/pose_graph.hpp"

#include <ceres/ceres.h>

#include <array>
#include <cmath>
#include <map>

namespace teamscan::posegraph {
namespace {

template <typename T>
T wrap(const T& a) {
  const T two_pi = T(2.0 * kPi);
  return a - two_pi * ceres::floor((a + T(kPi)) / two_pi);
}

// a⁻¹·b against the measured relative pose, weighted: the sparse pose adjustment's residual. The
// translation error is taken along two axes of a's frame (at axis_rad and 90° from it), the second
// weighted by weak_factor (1: isotropic, the same cost whatever the axes).
struct RelativePoseCost {
  RelativePoseCost(const Pose2& measured, double tw, double rw, double axis_rad, double weak_factor)
      : m_(measured), tw_(tw), rw_(rw), axis_c_(std::cos(axis_rad)), axis_s_(std::sin(axis_rad)), weak_factor_(weak_factor) {}
  template <typename T>
  bool operator()(const T* const a, const T* const b, T* r) const {
    const T c = ceres::cos(a[2]), s = ceres::sin(a[2]);
    const T dx = b[0] - a[0], dy = b[1] - a[1];
    const T ex = c * dx + s * dy - m_.x_m, ey = -s * dx + c * dy - m_.y_m;
    r[0] = tw_ * (axis_c_ * ex + axis_s_ * ey);
    r[1] = (tw_ * weak_factor_) * (-axis_s_ * ex + axis_c_ * ey);
    r[2] = rw_ * wrap(b[2] - a[2] - m_.theta_rad);
    return true;
  }
  static ceres::CostFunction* create(const Pose2& m, double tw, double rw, double axis_rad = 0.0, double weak_factor = 1.0) {
    return new ceres::AutoDiffCostFunction<RelativePoseCost, 3, 3, 3>(new RelativePoseCost(m, tw, rw, axis_rad, weak_factor));
  }
  Pose2 m_;
  double tw_, rw_, axis_c_, axis_s_, weak_factor_;
};

// The motion between consecutive nodes corrected by its robot's calibration k (OdometryCalibration:
// distance scale, turn scale, heading drift per metre), against a⁻¹·b. The measured translation turns
// with half the correction of the turn: over a short link it points along the mean heading.
struct CalibratedOdometryCost {
  CalibratedOdometryCost(const Pose2& measured, double tw, double rw)
      : m_(measured), tw_(tw), rw_(rw), distance_m_(std::hypot(measured.x_m, measured.y_m)) {}
  template <typename T>
  bool operator()(const T* const a, const T* const b, const T* const k, T* r) const {
    const T turn = k[1] * (T(m_.theta_rad) - k[2] * T(distance_m_));
    const T half = T(0.5) * (turn - T(m_.theta_rad));
    const T mx = k[0] * (ceres::cos(half) * T(m_.x_m) - ceres::sin(half) * T(m_.y_m));
    const T my = k[0] * (ceres::sin(half) * T(m_.x_m) + ceres::cos(half) * T(m_.y_m));
    const T c = ceres::cos(a[2]), s = ceres::sin(a[2]);
    const T dx = b[0] - a[0], dy = b[1] - a[1];
    r[0] = tw_ * (c * dx + s * dy - mx);
    r[1] = tw_ * (-s * dx + c * dy - my);
    r[2] = rw_ * wrap(b[2] - a[2] - turn);
    return true;
  }
  static ceres::CostFunction* create(const Pose2& m, double tw, double rw) {
    return new ceres::AutoDiffCostFunction<CalibratedOdometryCost, 3, 3, 3, 3>(new CalibratedOdometryCost(m, tw, rw));
  }
  Pose2 m_;
  double tw_, rw_, distance_m_;
};

// The calibration's prior: no error, σ per parameter.
struct CalibrationPriorCost {
  CalibrationPriorCost(double scale_sigma, double drift_sigma) : scale_w_(1.0 / scale_sigma), drift_w_(1.0 / drift_sigma) {}
  template <typename T>
  bool operator()(const T* const k, T* r) const {
    r[0] = scale_w_ * (k[0] - T(1.0));
    r[1] = scale_w_ * (k[1] - T(1.0));
    r[2] = drift_w_ * k[2];
    return true;
  }
  double scale_w_, drift_w_;
};

}  // namespace

OdometryCalibration PoseGraph::calibration(std::uint8_t robot) const {
  const auto it = calibration_.find(robot);
  if (it == calibration_.end()) return {};
  return {it->second[0], it->second[1], it->second[2]};
}

std::size_t PoseGraph::add_node(const Pose2& global, bool anchor) {
  nodes_.push_back(global);
  anchored_.push_back(anchor ? 1 : 0);
  return nodes_.size() - 1;
}

std::size_t PoseGraph::add_submap(const Pose2& global) {
  submaps_.push_back(global);
  return submaps_.size() - 1;
}

std::size_t PoseGraph::closures() const {
  std::size_t n = 0;
  for (const Constraint& c : constraints_) n += c.kind == Constraint::Kind::closure ? 1 : 0;
  return n;
}

void PoseGraph::optimize(bool final) {
  if (nodes_.empty()) return;
  std::vector<std::array<double, 3>> n(nodes_.size()), s(submaps_.size());
  for (std::size_t i = 0; i < nodes_.size(); ++i) n[i] = {nodes_[i].x_m, nodes_[i].y_m, nodes_[i].theta_rad};
  for (std::size_t i = 0; i < submaps_.size(); ++i) s[i] = {submaps_[i].x_m, submaps_[i].y_m, submaps_[i].theta_rad};
  // Each robot's calibration starts from the last optimisation's (std::map: its blocks stay put).
  std::map<std::uint8_t, std::array<double, 3>> calibration = calibration_;
  ceres::Problem problem;
  if (options_.calibrate_odometry || options_.calibrate_local_links) {
    for (const NodeLink& l : links_) calibration.try_emplace(l.robot, std::array<double, 3>{1.0, 1.0, 0.0});
    for (auto& [robot, k] : calibration) {
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CalibrationPriorCost, 3, 3>(new CalibrationPriorCost(
                                   options_.calibration_scale_prior_sigma, options_.calibration_drift_prior_sigma_rad_per_m)),
                               nullptr, k.data());
      if (options_.calibrate_after_loop && calibration_free_.count(robot) == 0) problem.SetParameterBlockConstant(k.data());
    }
  }
  for (const Constraint& c : constraints_) {
    const bool closure = c.kind == Constraint::Kind::closure;
    problem.AddResidualBlock(
        RelativePoseCost::create(c.submap_from_node, closure ? options_.closure_translation_weight : options_.matcher_translation_weight,
                                 (closure ? options_.closure_rotation_weight : options_.matcher_rotation_weight) * c.rotation_factor,
                                 c.strong_axis_rad,
                                 c.weak_axis_factor),
        closure ? new ceres::HuberLoss(options_.closure_huber_scale) : nullptr, s[c.submap].data(), n[c.node].data());
  }
  // A link's measured motion, corrected by its robot's calibration or as measured.
  const auto add_motion = [&](const NodeLink& l, const Pose2& measured, double tw, double rw, bool calibrated) {
    if (calibrated)
      problem.AddResidualBlock(CalibratedOdometryCost::create(measured, tw, rw), nullptr, n[l.from].data(), n[l.to].data(),
                               calibration.at(l.robot).data());
    else
      problem.AddResidualBlock(RelativePoseCost::create(measured, tw, rw), nullptr, n[l.from].data(), n[l.to].data());
  };
  for (const NodeLink& l : links_) {
    const double turned_rad = std::abs(l.from_to_odometry.theta_rad);
    const bool rest = std::hypot(l.from_to_odometry.x_m, l.from_to_odometry.y_m) < options_.rest_translation_m &&
                      turned_rad < options_.rest_rotation_rad &&
                      std::hypot(l.from_to_local.x_m, l.from_to_local.y_m) < options_.rest_local_translation_m &&
                      std::abs(l.from_to_local.theta_rad) < options_.rest_local_rotation_rad;
    const double factor = rest ? options_.rest_weight_factor : 1.0;
    const double odometry_rotation_weight =
        factor / (1.0 / options_.odometry_rotation_weight + options_.odometry_turn_sigma_rad_per_rad * turned_rad);
    add_motion(l, l.from_to_odometry, factor * options_.odometry_translation_weight, odometry_rotation_weight, options_.calibrate_odometry);
    add_motion(l, l.from_to_local, options_.local_translation_weight, options_.local_rotation_weight, options_.calibrate_local_links);
  }
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    if (anchored_[i] && problem.HasParameterBlock(n[i].data())) problem.SetParameterBlockConstant(n[i].data());
  ceres::Solver::Options o;
  o.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  o.max_num_iterations = final ? options_.final_max_iterations : options_.max_iterations;
  o.num_threads = 1;
  o.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(o, &problem, &summary);
  for (std::size_t i = 0; i < nodes_.size(); ++i) nodes_[i] = {n[i][0], n[i][1], normalize_angle(n[i][2])};
  for (std::size_t i = 0; i < submaps_.size(); ++i) submaps_[i] = {s[i][0], s[i][1], normalize_angle(s[i][2])};
  calibration_ = calibration;
  ++optimizations_;
}

}  // namespace teamscan::posegraph
