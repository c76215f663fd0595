// 2-D SLAM for the team (slam.hpp).
#include "groundstation/posegraph/slam.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <optional>
#include <thread>

namespace teamscan::posegraph {
namespace {

// Branch and bound levels of local SLAM's search: blocks of up to 2^3 cells cover its small window.
constexpr int kLocalSearchDepth = 3;

// f(0) … f(n − 1) on `threads` threads (the caller's one of them), each index once, in no fixed order:
// f must write only its own index's result.
template <typename F>
void parallel_for(std::size_t n, int threads, const F& f) {
  const std::size_t extra = std::min(n, static_cast<std::size_t>(std::max(1, threads))) - (n > 0 ? 1 : 0);
  if (extra == 0) {
    for (std::size_t i = 0; i < n; ++i) f(i);
    return;
  }
  std::atomic<std::size_t> next{0};
  const auto work = [&] {
    for (std::size_t i = next.fetch_add(1); i < n; i = next.fetch_add(1)) f(i);
  };
  std::vector<std::thread> pool;
  pool.reserve(extra);
  for (std::size_t t = 0; t < extra; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
}

// A node's returns as kept for the second search: in single precision, and with `thin_m` > 0 the first
// of them in each square of that size, in their order.
std::vector<std::array<float, 2>> kept_returns(const std::vector<Vec2>& points, double thin_m) {
  std::vector<std::size_t> keep(points.size());
  for (std::size_t i = 0; i < keep.size(); ++i) keep[i] = i;
  if (thin_m > 0.0) {
    const auto square = [&](std::size_t i) {
      return std::pair{static_cast<std::int64_t>(std::floor(points[i].x / thin_m)), static_cast<std::int64_t>(std::floor(points[i].y / thin_m))};
    };
    std::stable_sort(keep.begin(), keep.end(), [&](std::size_t a, std::size_t b) { return square(a) < square(b); });
    keep.erase(std::unique(keep.begin(), keep.end(), [&](std::size_t a, std::size_t b) { return square(a) == square(b); }), keep.end());
    std::sort(keep.begin(), keep.end());
  }
  std::vector<std::array<float, 2>> out;
  out.reserve(keep.size());
  for (std::size_t i : keep) out.push_back({static_cast<float>(points[i].x), static_cast<float>(points[i].y)});
  return out;
}

}  // namespace

struct PlanarSlam::Submap {
  Submap(std::uint8_t robot_id, const Pose2& local_pose, const SlamOptions& o)
      : robot(robot_id), local(local_pose), grid(o.resolution_m, o.hit_sigma_m) {}
  std::uint8_t robot;
  Pose2 local;  // local_from_submap: the frame of its grid in its robot's local SLAM frame
  Grid grid;
  int scans = 0;
  std::size_t last_robot_node = 0;  // its robot's count of nodes when the last scan went in
  double driven_m = 0;              // how far its robot had driven (odometry) when it was started
  std::unique_ptr<CorrelativeMatcher> matcher;  // once finished, until retired
  bool retired = false;
};

struct PlanarSlam::Robot {
  std::uint8_t id = 0;
  bool started = false;
  Pose2 last_odometry, last_local;
  Pose2 last_motion;                // local SLAM's, from its previous node to its last one
  std::int64_t last_stamp_ns = 0, last_interval_ns = 0;  // its last node's time, and the time since the one before
  std::size_t last_node = 0;
  std::size_t nodes = 0;            // its nodes so far
  std::size_t below_search_score = 0;  // its scans that scored below local_search_score on their submap
  double driven_m = 0;              // the distance its odometry moved, node to node
  Pose2 global_from_local;          // from the last optimisation
  std::vector<std::size_t> active;  // its submaps being built, oldest first (at most two)
  struct Followed {
    std::size_t submap = 0, node = 0;
    std::size_t robot_node = 0;  // the node's index among its robot's nodes
    Pose2 submap_from_node;
  };
  std::vector<Followed> followed;  // its last closure with each submap, while recent
};

SlamOptions tilted_laser_options(SlamOptions base) {
  base.local.translation_weight = 100.0;
  base.local.rotation_weight = 400.0;
  base.graph.local_translation_weight = 1e5;
  base.graph.local_rotation_weight = 1e5;
  base.graph.odometry_translation_weight = 1e4;
  base.graph.odometry_rotation_weight = 1e5;
  base.graph.odometry_turn_sigma_rad_per_rad = 0.003;
  base.graph.calibrate_odometry = true;
  base.graph.calibrate_local_links = true;
  base.graph.closure_huber_scale = 5.0;
  base.calibration_loop_m = 10.0;
  // A node's few wall returns score low on any submap; its odometry is what places it between nodes.
  base.local_search_score = 0.0;
  base.coast_guess = false;
  // Searched against the 3 nearest submaps: a tilted node every quarter second of every robot, and the
  // simulator's scenarios and the team's live budget were measured at 3.
  base.closure_submaps = 3;
  return base;
}

namespace {
GraphOptions graph_options(const SlamOptions& o) {
  GraphOptions g = o.graph;
  g.calibrate_after_loop = o.calibration_loop_m > 0.0;
  return g;
}
}  // namespace

PlanarSlam::PlanarSlam(SlamOptions options) : options_(options), graph_(graph_options(options)) {}
PlanarSlam::~PlanarSlam() = default;

PlanarSlam::Robot& PlanarSlam::robot(std::uint8_t id) {
  for (auto& r : robots_)
    if (r->id == id) return *r;
  robots_.push_back(std::make_unique<Robot>());
  robots_.back()->id = id;
  return *robots_.back();
}

std::size_t PlanarSlam::add_scan(std::uint8_t robot_id, std::int64_t stamp_ns, const Pose2& odometry, const std::vector<Vec2>& all_points) {
  std::vector<Vec2> points;
  points.reserve(all_points.size());
  for (const Vec2& p : all_points) {
    const double r = p.norm();
    if (r >= options_.min_range_m && r <= options_.max_range_m) points.push_back(p);
  }
  Robot& r = robot(robot_id);
  // Local SLAM: the odometry's motion since the last scan, then the match against the oldest active
  // submap (the one with the most scans in it). A robot's local frame starts as its odometry frame.
  Pose2 local = r.started ? r.last_local * (r.last_odometry.inverse() * odometry) : odometry;
  if (!r.active.empty()) {
    const Submap& m = *submaps_[r.active.front()];
    std::optional<Pose2> coast;
    if (options_.coast_guess && r.nodes >= 2 && r.last_interval_ns > 0) {
      const double k = static_cast<double>(stamp_ns - r.last_stamp_ns) / static_cast<double>(r.last_interval_ns);
      if (k * options_.coast_max_ratio >= 1.0 && k <= options_.coast_max_ratio)
        coast = m.local.inverse() * (r.last_local * Pose2{k * r.last_motion.x_m, k * r.last_motion.y_m, k * r.last_motion.theta_rad});
    }
    local = m.local * match_locally(r, m, points, m.local.inverse() * local, coast);
  }
  // The first node is held; with anchor_robot_starts every robot's first one (the robots start in
  // the common map frame).
  const bool anchor = graph_.nodes().empty() || (!r.started && options_.anchor_robot_starts);
  const std::size_t node = graph_.add_node(r.global_from_local * local, anchor);
  node_local_.push_back(local);
  node_robot_.push_back(robot_id);
  bool still = false;
  if (r.started) {
    const Pose2 moved = r.last_odometry.inverse() * odometry;
    still = std::hypot(moved.x_m, moved.y_m) < options_.still_translation_m && std::abs(moved.theta_rad) < options_.still_rotation_rad;
    if (still) ++still_;
    r.driven_m += std::hypot(moved.x_m, moved.y_m);
    graph_.add_link({r.last_node, node, robot_id, moved, r.last_local.inverse() * local});
  }
  r.started = true;
  node_driven_m_.push_back(r.driven_m);
  // The cadences below count the robot's own nodes: the team's nodes interleave, and counted by the
  // graph's index a teammate's nodes would never fall on the searched ones.
  const std::size_t robot_node = r.nodes++;
  r.last_odometry = odometry;
  r.last_motion = r.last_local.inverse() * local;
  r.last_interval_ns = robot_node > 0 ? stamp_ns - r.last_stamp_ns : 0;
  r.last_stamp_ns = stamp_ns;
  r.last_local = local;
  r.last_node = node;
  if (!still && options_.closure_every_n_nodes > 0 && robot_node % static_cast<std::size_t>(options_.closure_every_n_nodes) == 0)
    close_loops(r, node, points);
  node_points_.emplace_back();
  if (!still && options_.rematch_submaps > 0 && options_.rematch_every_n_nodes > 0 && points.size() >= 20 &&
      robot_node % static_cast<std::size_t>(options_.rematch_every_n_nodes) == 0 && keep_returns(node))
    node_points_.back() = kept_returns(points, options_.rematch_thin_m);
  insert(r, node, local, points);
  if (options_.optimize_every_n_nodes > 0 && (node + 1) % static_cast<std::size_t>(options_.optimize_every_n_nodes) == 0) {
    graph_.optimize();
    after_optimization();
  }
  return node;
}

Pose2 PlanarSlam::match_locally(Robot& r, const Submap& m, const std::vector<Vec2>& points, const Pose2& odometry_guess,
                                const std::optional<Pose2>& coast) {
  Pose2 guess = odometry_guess;
  Pose2 refined = refine_pose(m.grid, points, guess, options_.local);
  std::optional<double> refined_score;
  if (coast && std::abs(normalize_angle(coast->theta_rad - odometry_guess.theta_rad)) > options_.coast_differs_rad) {
    const Pose2 coasted = refine_pose(m.grid, points, *coast, options_.local);
    const double odometry_score = pose_score(m.grid, points, refined), coast_score = pose_score(m.grid, points, coasted);
    refined_score = odometry_score;
    if (coast_score > odometry_score) {
      ++coasted_;
      guess = *coast;
      refined = coasted;
      refined_score = coast_score;
    }
  }
  if (options_.local_search_score <= 0.0 || m.scans < options_.local_search_min_scans) return refined;
  const double score = refined_score ? *refined_score : pose_score(m.grid, points, refined);
  if (score >= options_.local_search_score) return refined;
  ++r.below_search_score;
  if (r.nodes >= static_cast<std::size_t>(std::max(options_.local_search_share_after_scans, 0)) &&
      static_cast<double>(r.below_search_score) > options_.local_search_max_share * static_cast<double>(r.nodes)) {
    ++local_declined_;
    return refined;
  }
  ++local_searches_;
  const CorrelativeMatcher matcher(m.grid, kLocalSearchDepth);
  const SearchResult found = matcher.search(points, guess, options_.local_search_window, score);
  if (!found.found) return refined;
  const Pose2 searched = refine_pose(m.grid, points, found.pose, options_.local);
  if (pose_score(m.grid, points, searched) <= score) return refined;
  ++local_found_;
  return searched;
}

void PlanarSlam::insert(Robot& r, std::size_t node, const Pose2& local, const std::vector<Vec2>& points) {
  if (r.active.empty() || submaps_[r.active.back()]->scans >= options_.scans_per_submap) {
    const Pose2 origin{local.x_m, local.y_m, 0.0};
    const std::size_t id = graph_.add_submap(r.global_from_local * origin);
    submaps_.push_back(std::make_unique<Submap>(r.id, origin, options_));
    submaps_.back()->driven_m = r.driven_m;
    r.active.push_back(id);
  }
  std::vector<Vec2> moved(points.size());
  for (std::size_t id : r.active) {
    Submap& m = *submaps_[id];
    const Pose2 submap_from_node = m.local.inverse() * local;
    for (std::size_t i = 0; i < points.size(); ++i) moved[i] = submap_from_node.apply(points[i]);
    m.grid.insert(moved);
    ++m.scans;
    m.last_robot_node = r.nodes;
    graph_.add_constraint({id, node, submap_from_node, Constraint::Kind::inserted});
  }
  if (r.active.size() > 2) {
    const std::size_t finished = r.active.front();
    Submap& done = *submaps_[finished];
    done.matcher = std::make_unique<CorrelativeMatcher>(done.grid, options_.closure_depth, options_.closure_pool);
    r.active.erase(r.active.begin());
    retire_covered(finished);
  }
}

void PlanarSlam::retire_covered(std::size_t finished) {
  if (options_.retire_after_submaps <= 0) return;
  const auto live = [&](std::size_t i) { return submaps_[i]->matcher != nullptr; };
  const auto near = [&](std::size_t a, std::size_t b) {
    const Pose2 &p = graph_.submaps()[a], &q = graph_.submaps()[b];
    return std::hypot(p.x_m - q.x_m, p.y_m - q.y_m) <= options_.retire_distance_m;
  };
  // Only the submaps near the one just finished have one more newer neighbour; oldest first (a retired
  // submap no longer counts for the older ones).
  for (std::size_t i = 0; i < finished; ++i) {
    if (!live(i) || !near(i, finished)) continue;
    int newer = 0;
    for (std::size_t j = i + 1; j < submaps_.size() && newer < options_.retire_after_submaps; ++j)
      if (live(j) && near(i, j)) ++newer;
    if (newer < options_.retire_after_submaps) continue;
    Submap& m = *submaps_[i];
    m.matcher.reset();
    m.grid = Grid(options_.resolution_m, options_.hit_sigma_m);
    m.retired = true;
    ++retired_;
  }
}

bool PlanarSlam::keep_returns(std::size_t node) {
  if (options_.rematch_nodes_per_cell > 0) {
    const Pose2& p = graph_.nodes()[node];
    const std::pair<std::int64_t, std::int64_t> cell{static_cast<std::int64_t>(std::floor(p.x_m / options_.rematch_cell_m)),
                                                     static_cast<std::int64_t>(std::floor(p.y_m / options_.rematch_cell_m))};
    int& kept = kept_per_cell_[cell];
    if (kept >= options_.rematch_nodes_per_cell) return false;
    ++kept;
  }
  ++kept_returns_;
  return true;
}

void PlanarSlam::close_loops(Robot& r, std::size_t node, const std::vector<Vec2>& points) {
  if (points.size() < 20) return;
  const Pose2 global = graph_.nodes()[node];
  // The nearest finished submaps (by their origin), ties by index: a fixed order.
  std::vector<std::pair<double, std::size_t>> near;
  for (std::size_t i = 0; i < submaps_.size(); ++i) {
    const Submap& candidate = *submaps_[i];
    if (!candidate.matcher) continue;
    // The robot's own latest submaps are already tied to it by local SLAM: the closures worth the
    // search are with what it mapped before (or a teammate did).
    if (candidate.robot == r.id && r.nodes - candidate.last_robot_node < static_cast<std::size_t>(std::max(0, options_.closure_skip_recent_nodes)))
      continue;
    const Pose2& s = graph_.submaps()[i];
    const double d = std::hypot(s.x_m - global.x_m, s.y_m - global.y_m);
    if (d <= options_.closure_max_distance_m) near.emplace_back(d, i);
  }
  std::sort(near.begin(), near.end());
  if (near.size() > static_cast<std::size_t>(options_.closure_submaps)) near.resize(static_cast<std::size_t>(options_.closure_submaps));
  const auto recent = static_cast<std::size_t>(std::max(0, options_.closure_track_nodes));
  const std::size_t robot_node = r.nodes - 1;
  std::erase_if(r.followed, [&](const Robot::Followed& f) { return robot_node - f.robot_node > recent; });
  // Which submaps are followed (a start without a search) is decided first; the searches and
  // refinements then run in parallel, and their closures join the graph in the order of `near`.
  struct Job {
    std::size_t submap = 0;
    std::size_t followed = 0;  // index in r.followed, or its size: searched
    Pose2 start;
    std::optional<Constraint> closure;
  };
  std::vector<Job> jobs;
  for (const auto& [distance, id] : near) {
    const auto it = std::find_if(r.followed.begin(), r.followed.end(), [id = id](const Robot::Followed& f) { return f.submap == id; });
    Job job{id, static_cast<std::size_t>(it - r.followed.begin()), {}, {}};
    if (it != r.followed.end()) {
      job.start = it->submap_from_node * (node_local_[it->node].inverse() * node_local_[node]);
      ++tracked_;
    } else {
      ++searches_;
    }
    jobs.push_back(job);
  }
  parallel_for(jobs.size(), options_.threads, [&](std::size_t k) {
    Job& job = jobs[k];
    Pose2 start = job.start;
    if (job.followed == r.followed.size()) {
      const SearchResult found = submaps_[job.submap]->matcher->search(points, graph_.submaps()[job.submap].inverse() * global,
                                                                      options_.closure_window, options_.closure_min_score);
      if (!found.found) return;
      start = found.pose;
    }
    job.closure = make_closure(job.submap, node, points, start);
  });
  const std::size_t followed = r.followed.size();
  for (const Job& job : jobs) {
    if (!job.closure) continue;
    graph_.add_constraint(*job.closure);
    note_loop(*job.closure);
    const Pose2 refined = job.closure->submap_from_node;
    if (job.followed < followed) r.followed[job.followed] = {job.submap, node, robot_node, refined};
    else if (recent > 0) r.followed.push_back({job.submap, node, robot_node, refined});
  }
}

// Refines `start` (submap_from_node) on the submap's grid: the closure, if it scores. Reads only.
std::optional<Constraint> PlanarSlam::make_closure(std::size_t submap, std::size_t node, const std::vector<Vec2>& points,
                                                   const Pose2& start) const {
  const Submap& m = *submaps_[submap];
  const Pose2 refined = refine_pose(m.grid, points, start, options_.closure_refine);
  if (pose_score(m.grid, points, refined) < options_.closure_min_refined_score) return std::nullopt;
  Constraint closure{submap, node, refined, Constraint::Kind::closure};
  if (options_.closure_weak_axis_floor < 1.0 || options_.closure_rotation_lever_m > 0.0) {
    const MatchInformation info = match_information(m.grid, points, refined);
    if (options_.closure_weak_axis_floor < 1.0) {
      closure.strong_axis_rad = info.strong_axis_rad;
      closure.weak_axis_factor = std::max(options_.closure_weak_axis_floor, std::sqrt(info.weak_ratio));
    }
    if (options_.closure_rotation_lever_m > 0.0)
      closure.rotation_factor = std::clamp(info.rotation_lever_m / options_.closure_rotation_lever_m, options_.closure_rotation_floor, 1.0);
  }
  return closure;
}

void PlanarSlam::note_loop(const Constraint& closure) {
  if (options_.calibration_loop_m <= 0.0) return;
  const Submap& m = *submaps_[closure.submap];
  const std::uint8_t robot = node_robot_[closure.node];
  if (m.robot == robot && node_driven_m_[closure.node] - m.driven_m >= options_.calibration_loop_m) graph_.free_calibration(robot);
}

void PlanarSlam::rematch() {
  // The pairs already tied, sorted for lookup.
  std::vector<std::pair<std::size_t, std::size_t>> tied;  // (node, submap)
  tied.reserve(graph_.constraints().size());
  for (const Constraint& c : graph_.constraints()) tied.emplace_back(c.node, c.submap);
  std::sort(tied.begin(), tied.end());
  std::vector<std::size_t> kept;  // the nodes whose returns were kept
  for (std::size_t node = 0; node < node_points_.size(); ++node)
    if (!node_points_[node].empty()) kept.push_back(node);
  // Each node's searches read the graph and the submaps only: in parallel, each node's closures in
  // its own slot, joined to the graph in node order afterwards (the same graph whatever the threads did).
  std::vector<std::vector<Constraint>> found(kept.size());
  parallel_for(kept.size(), options_.threads, [&](std::size_t k) {
    const std::size_t node = kept[k];
    std::vector<Vec2> points;
    points.reserve(node_points_[node].size());
    for (const auto& [x, y] : node_points_[node]) points.push_back({x, y});
    const Pose2& global = graph_.nodes()[node];
    std::vector<std::pair<double, std::size_t>> near;
    for (std::size_t i = 0; i < submaps_.size(); ++i) {
      if (!submaps_[i]->matcher || std::binary_search(tied.begin(), tied.end(), std::pair{node, i})) continue;
      const Pose2& s = graph_.submaps()[i];
      const double d = std::hypot(s.x_m - global.x_m, s.y_m - global.y_m);
      if (d <= options_.closure_max_distance_m) near.emplace_back(d, i);
    }
    std::sort(near.begin(), near.end());
    if (near.size() > static_cast<std::size_t>(options_.rematch_submaps)) near.resize(static_cast<std::size_t>(options_.rematch_submaps));
    for (const auto& [distance, id] : near) {
      const SearchResult result = submaps_[id]->matcher->search(points, graph_.submaps()[id].inverse() * global, options_.rematch_window,
                                                                options_.closure_min_score);
      if (!result.found) continue;
      if (std::optional<Constraint> closure = make_closure(id, node, points, result.pose)) found[k].push_back(*closure);
    }
  });
  for (const std::vector<Constraint>& closures : found)
    for (const Constraint& c : closures) {
      graph_.add_constraint(c);
      note_loop(c);
      ++rematches_;
    }
}

void PlanarSlam::after_optimization() {
  for (auto& r : robots_)
    if (r->started) r->global_from_local = graph_.nodes()[r->last_node] * node_local_[r->last_node].inverse();
}

void PlanarSlam::finish() {
  for (int round = 0; options_.rematch_submaps > 0 && round < options_.rematch_rounds; ++round) {
    graph_.optimize();
    rematch();
  }
  graph_.optimize(true);
  after_optimization();
}

std::vector<Pose2> PlanarSlam::estimate() const {
  PoseGraph copy = graph_;
  copy.optimize();
  return copy.nodes();
}

SlamStats PlanarSlam::stats() const {
  std::size_t bytes = 0;
  for (const auto& m : submaps_) bytes += m->grid.values().capacity() * sizeof(float) + (m->matcher ? m->matcher->memory_bytes() : 0);
  for (const auto& p : node_points_) bytes += p.capacity() * sizeof(p[0]);
  SlamStats out{graph_.nodes().size(), submaps_.size(), searches_, graph_.closures(), graph_.optimizations(), tracked_, rematches_,
                  retired_, kept_returns_, still_, bytes, {}, local_searches_, local_found_, local_declined_, coasted_};
  if (options_.graph.calibrate_odometry || options_.graph.calibrate_local_links) {
    for (const auto& r : robots_) out.calibrations.push_back({r->id, graph_.calibration(r->id)});
    std::sort(out.calibrations.begin(), out.calibrations.end(),
              [](const SlamStats::Calibration& a, const SlamStats::Calibration& b) { return a.robot < b.robot; });
  }
  return out;
}

}  // namespace teamscan::posegraph
