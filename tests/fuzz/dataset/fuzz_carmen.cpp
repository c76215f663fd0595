// libFuzzer target: any bytes through the CARMEN log parser and the data set conversion. Must never
// crash; every line is counted as a record, a comment, another message or malformed.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "common/dataset/carmen.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const teamscan::CarmenLog log = teamscan::parse_carmen(text);
  if (log.lasers.size() + log.odom.size() + log.comments + log.other_messages + log.malformed != log.lines) __builtin_trap();
  (void)teamscan::carmen_to_dataset(log, {});
  return 0;
}
