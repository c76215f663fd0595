// File-reading half of scan_record.hpp (kept apart so the decoder itself stays pure).
#pragma once

#include <fstream>
#include <iterator>
#include <vector>

namespace teamscan::station {

template <class F>
bool read_scan_file(const std::string& path, F&& on_scan, ScanDecodeStats& stats, std::string& error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    error = "cannot open " + path;
    return false;
  }
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  stats = decode_scan_file(std::span<const std::uint8_t>(bytes), std::forward<F>(on_scan));
  if (stats.bad_header) {
    error = path + ": not a teamscan scans.bin file (bad header)";
    return false;
  }
  return true;
}

}  // namespace teamscan::station
