// The layout of the JSON reports (report_json.hpp).
#include "tools/demo/report_json.hpp"

#include <algorithm>

namespace teamscan::demo {

std::string json_inline(const ReportJson& value) {
  if (value.is_object()) {
    std::string o = "{";
    bool first = true;
    for (const auto& [key, v] : value.items()) {
      o += (first ? "" : ", ") + ReportJson(key).dump() + ": " + json_inline(v);
      first = false;
    }
    return o + "}";
  }
  if (value.is_array()) {
    std::string o = "[";
    for (std::size_t i = 0; i < value.size(); ++i) o += (i ? ", " : "") + json_inline(value[i]);
    return o + "]";
  }
  return value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string json_report(const ReportJson& report) {
  if (!report.is_object()) return json_inline(report) + "\n";
  std::string o = "{";
  bool first = true;
  for (const auto& [key, v] : report.items()) {
    o += (first ? "\n  " : ",\n  ") + ReportJson(key).dump() + ": ";
    first = false;
    const bool rows = v.is_array() && !v.empty() &&
                      std::all_of(v.begin(), v.end(), [](const ReportJson& e) { return e.is_object(); });
    if (!rows) {
      o += json_inline(v);
      continue;
    }
    o += "[";
    for (std::size_t i = 0; i < v.size(); ++i) o += (i ? ",\n    " : "\n    ") + json_inline(v[i]);
    o += "\n  ]";
  }
  return o + "\n}\n";
}

}  // namespace teamscan::demo
