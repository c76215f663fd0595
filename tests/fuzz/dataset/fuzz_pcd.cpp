// libFuzzer target: any bytes through the PCD parser (header, ascii, binary, binary_compressed/LZF) and
// the labelled-point reader. Must never crash, hang or allocate more than the input justifies.
#include <cstddef>
#include <cstdint>
#include <span>

#include "common/dataset/pcd.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> bytes(data, size);
  const auto cloud = teamscan::parse_pcd(bytes);
  if (cloud.ok()) {
    // Parsed: the columns and the xyz array agree on the point count.
    for (const auto& column : cloud->columns)
      if (column.size() != cloud->size()) __builtin_trap();
  }
  (void)teamscan::parse_labelled_pcd(bytes);
  return 0;
}
