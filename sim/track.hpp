// Robot tracks and motion: closed or open planar curves parametrised by arc length (an ellipse for
// the Lap2 oval, a lemniscate for the Fig8 figure-eight, a Catmull–Rom spline through waypoints),
// and a motion along a track at constant speed with a start offset and pauses. The true pose is a
// smooth function of time: position and heading are continuous, heading follows the tangent.
#pragma once

#include <cstdint>
#include <vector>

#include "common/pose.hpp"

namespace teamscan::sim {

class Track {
 public:
  enum class Kind : std::uint8_t { oval, figure8, waypoints };

  // Ellipse with semi-axes (a along x, b along y), centred and yawed; ccw = counter-clockwise.
  static Track oval(Vec2 center_m, double semi_x_m, double semi_y_m, double yaw_rad, bool ccw);
  // Lemniscate of Gerono: x = a·sin u, y = b·sin u·cos u; lobes reach ±a along x, ±b/2 along y.
  static Track figure8(Vec2 center_m, double half_length_m, double width_m, double yaw_rad, bool ccw);
  // How a waypoints spline's segments are parametrised. Uniform (every segment one unit) overshoots
  // where short and long segments meet and can loop at a tight corner; centripetal (each segment the
  // square root of its chord) never forms a cusp or a loop inside a segment (Yuksel, Schaefer and
  // Keyser 2011, "Parameterization and applications of Catmull–Rom curves").
  enum class Spline : std::uint8_t { uniform, centripetal };
  // Catmull–Rom spline through the points (at least 2); closed joins the last point to the first.
  static Track waypoints(std::vector<Vec2> points_m, bool closed, Spline spline = Spline::uniform);

  [[nodiscard]] Kind kind() const { return kind_; }
  [[nodiscard]] bool closed() const { return closed_; }
  [[nodiscard]] double length_m() const { return cumulative_m_.back(); }
  // Pose at arc length s (wraps on a closed track, clamps on an open one); heading = tangent.
  [[nodiscard]] Pose2 pose_at(double s_m) const;

 private:
  Track() = default;
  void build_table();
  // Point and tangent (d point / du) at u in [0, 1], map frame.
  void evaluate(double u, Vec2& point_m, Vec2& tangent_m) const;
  [[nodiscard]] Vec2 point(double u) const {
    Vec2 p, d;
    evaluate(u, p, d);
    return p;
  }

  Kind kind_ = Kind::oval;
  bool closed_ = true;
  bool reverse_ = false;
  Spline spline_ = Spline::uniform;
  Pose2 map_from_track_;
  double cos_yaw_ = 1, sin_yaw_ = 0;  // of map_from_track_, cached: pose_at runs for every beam
  double a_ = 0, b_ = 0;
  std::vector<Vec2> points_;
  std::vector<double> cumulative_m_;  // arc length at u = k / (size − 1)
};

// A stop during the run: at time `at_s` (seconds from the start) the robot stands still for `for_s`.
struct Pause {
  double at_s = 0;
  double for_s = 0;
};

// Motion along a track: starts `start_offset_m` along it at `start_s`, drives `distance_m` (e.g.
// laps × length) at `speed_mps`, stops during pauses and at the end. With `accel_mps2` > 0 every start
// and stop is a linear speed ramp (trapezoidal profile, triangular if a drive is too short), so the
// speed is continuous; 0 = instant starts and stops. With `max_yaw_rate_radps` > 0 the robot slows
// wherever that speed would turn it faster (a skid-steer base turns at most so fast however tight the
// curve): it then goes through the same poses on a stretched clock, turning at exactly that rate, and
// everything after (pauses, the finish) comes later by the time lost. A motion that never turns that
// fast is the same to the bit as one without the limit.
class Motion {
 public:
  Motion(Track track, double speed_mps, double start_offset_m, double distance_m, double start_s,
         std::vector<Pause> pauses, double accel_mps2 = 0.0, double max_yaw_rate_radps = 0.0);

  [[nodiscard]] const Track& track() const { return track_; }
  // Distance driven by time t (seconds from the start of the run).
  [[nodiscard]] double distance_at(double t_s) const { return planned_distance_at(planned_time(t_s)); }
  [[nodiscard]] Pose2 pose_at(double t_s) const { return track_.pose_at(start_offset_m_ + distance_at(t_s)); }
  [[nodiscard]] bool moving_at(double t_s) const;
  // Forward speed and yaw rate at t (the yaw rate by a central difference of the heading).
  [[nodiscard]] double speed_at(double t_s) const;
  [[nodiscard]] double yaw_rate_at(double t_s) const;
  // Time at which the robot has driven its whole distance.
  [[nodiscard]] double finish_s() const { return finish_s_; }

 private:
  // The clock stretch of the turn-rate limit: the planned time (the schedule of drives and pauses) at
  // real time t. Between a knot marked `stretched` and the next the planned time runs slower and is
  // interpolated; elsewhere it runs with real time from the knot before.
  struct StretchKnot {
    double t_s = 0, planned_s = 0;
    bool stretched = false;
  };
  void stretch_for_turns(double max_yaw_rate_radps);
  // The knot at or before t (none before the first) and, inside a stretch, the knot after it.
  struct StretchSpan {
    const StretchKnot* from = nullptr;
    const StretchKnot* to = nullptr;
  };
  [[nodiscard]] StretchSpan stretch_at(double t_s) const;
  [[nodiscard]] double planned_time(double t_s) const;
  [[nodiscard]] double planned_clock_rate(double t_s) const;  // d planned time / dt
  [[nodiscard]] double planned_distance_at(double planned_s) const;
  [[nodiscard]] double planned_speed_at(double planned_s) const;
  [[nodiscard]] double planned_yaw_rate_at(double planned_s) const;

  // One drive between stops: [from_s, to_s), ramps of `ramp_s` at both ends, `distance_m` driven.
  struct Drive {
    double from_s = 0, to_s = 0, ramp_s = 0, distance_m = 0;
  };
  [[nodiscard]] Drive make_drive(double from_s, double to_s) const;
  [[nodiscard]] double driven_in(const Drive& d, double t_s) const;  // distance since d.from_s
  [[nodiscard]] double speed_in(const Drive& d, double t_s) const;

  Track track_;
  double speed_mps_, start_offset_m_, distance_m_, start_s_, accel_mps2_;
  std::vector<Pause> pauses_;
  std::vector<Drive> drives_;   // in time order; the last one ends when distance_m is driven
  double finish_s_ = 0;
  std::vector<StretchKnot> stretch_;  // empty: real time is planned time
};

}  // namespace teamscan::sim
