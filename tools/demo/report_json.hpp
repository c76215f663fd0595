// The layout of the JSON reports (`teamscan eval --json`, the demo's summary.json): nlohmann-json
// builds and escapes the values; this prints them one top-level key per line, an array of objects one
// element per line, everything deeper on that line, so a report reads (and greps) line by line.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace teamscan::demo {

using ReportJson = nlohmann::ordered_json;

// `value` on one line: {"key": value, ...}, [a, b], numbers and strings as nlohmann-json writes them
// (a non-finite number as null).
[[nodiscard]] std::string json_inline(const ReportJson& value);
// A report object: one top-level key per line, arrays of objects one element per line; ends with "\n".
[[nodiscard]] std::string json_report(const ReportJson& report);

}  // namespace teamscan::demo
