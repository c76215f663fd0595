// libFuzzer target: any bytes through the relations-file parser and the metric. Must never crash;
// every line is a relation, a comment or malformed.
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

#include "groundstation/trajectory/relations.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const teamscan::trajectory::RelationsFile f = teamscan::trajectory::parse_relations(text);
  if (f.relations.size() + f.comments + f.malformed != f.lines) __builtin_trap();
  std::vector<teamscan::trajectory::StampedPose> poses;
  for (const auto& r : f.relations) poses.push_back({r.t1_us, r.t1_from_t2});
  (void)teamscan::trajectory::relation_errors(f.relations, poses);
  return 0;
}
