// `teamscan eval`'s trajectory outputs: `--trajectory-out DIR` (robot<N>.tum per robot) and
// `--relations FILE` (Kümmerle et al. 2009's figures for the corrected trajectory beside odometry
// alone, in the report and its JSON). Kept apart from cmd_eval.cpp so the evaluation stays thin.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "common/dataset/dataset.hpp"
#include "common/pose.hpp"
#include "groundstation/fusion/evaluation.hpp"

namespace teamscan::tool {

struct SlamEvalArgs {
  std::string trajectory_dir;  // empty: none written
  std::string relations_path;  // empty: no relations figures
  // The pose graph (groundstation/posegraph) as the fusion core's back end: on by default; --no-pose-graph
  // or --no-registration (odometry alone) turn it off, --pose-graph keeps it on with --no-registration
  // (the graph over odometry alone). resolve_pose_graph() sets pose_graph from the flags.
  bool pose_graph = true;
  bool pose_graph_flag = false, no_pose_graph_flag = false;
  // A tilted laser's returns in the graph: the height band and the span of scans one node gathers
  // (fusion::PlanarReturnOptions; unset: its defaults).
  std::optional<double> min_height_m, max_height_m, node_span_s;
  // A level laser's local SLAM and loop closures (posegraph::SlamOptions; unset: its defaults): the
  // local search's score (0: never searched), the pull towards the odometry's heading (per radian),
  // the closure search's window (± m) and how far from a submap a node is searched against it (m).
  std::optional<double> local_search_score, local_rotation_weight, closure_window_m, closure_max_distance_m;
};

void add_slam_eval_options(CLI::App& app, SlamEvalArgs& args);
// After parsing: whether the graph runs, from its flags and --no-registration (`odometry_alone`).
void resolve_pose_graph(SlamEvalArgs& args, bool odometry_alone);

struct SlamEvalOutput {
  std::string markdown;     // the relations table (empty without --relations)
  nlohmann::ordered_json relations;  // the report's "relations" member (null without --relations)
  // --pose-graph on a data set with truth: the graph's pose error per scan beside odometry alone
  // (translation m, rotation °: p50, p99, max), as a table and as the report's "pose_graph" member.
  std::string pose_markdown;
  nlohmann::ordered_json pose_errors;
  bool ok = true;           // false: a file could not be read or written (the reason is on stderr)
};

// `corrected[i]` is the pose the run decided scan i with (`decided[i]` = 1 where it did); `method`
// names it in the table ("odometry" when the run had no correction: then only odometry is shown).
[[nodiscard]] SlamEvalOutput slam_eval_outputs(const SlamEvalArgs& args, const Dataset& dataset, const std::vector<Pose2>& corrected,
                                               const std::vector<std::uint8_t>& decided, const std::string& method);

// The back end's options for the evaluation (fusion::EvalOptions::pose_graph); unset when the graph is
// off.
[[nodiscard]] std::optional<fusion::GraphBackendOptions> pose_graph_options(const SlamEvalArgs& args);
// What the back end did and its time, on stderr.
void print_pose_graph_summary(const fusion::EvalReport& report);

}  // namespace teamscan::tool
