// `teamscan eval`'s reports of an evaluation (groundstation/fusion/evaluation.hpp): the JSON report
// (`--json`, report.json, the demo's report-*.json) built with nlohmann-json, and the Markdown report.
#pragma once

#include <string>

#include "groundstation/fusion/evaluation.hpp"
#include "tools/demo/report_json.hpp"

namespace teamscan::demo {

// `command` is the command line that reproduces the report.
// Error statistics as the report gives them: {"p50", "p99", "max", "count"}, 10 significant digits.
[[nodiscard]] ReportJson stats_json(const mapping::ErrorStats& e);
[[nodiscard]] ReportJson report_json_value(const fusion::EvalReport& report, const std::string& command);
// report_json_value laid out by json_report (one top-level key per line, a method per line).
[[nodiscard]] std::string report_json(const fusion::EvalReport& report, const std::string& command);
[[nodiscard]] std::string report_markdown(const fusion::EvalReport& report, const std::string& command);

}  // namespace teamscan::demo
