// Fuzz target: arbitrary bytes through LmsParser in both directions, every accepted 0xB0 through
// decode_scan in every measuring mode. Checks the invariants the driver relies on: accepted
// telegrams verify, statistics add up, nothing reads out of bounds.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "drivers/lms200/codec.hpp"
#include "drivers/lms200/parser.hpp"
#include "drivers/lms200/scan.hpp"

namespace {

using namespace teamscan::lms200;

void check(bool ok) {
  if (!ok) std::abort();
}

void run(std::span<const std::uint8_t> data, StreamDirection dir, std::size_t chunk) {
  LmsParser p{dir};
  ScanTelegram scan;
  std::uint64_t event_bytes = 0;
  std::uint64_t fed = 0;
  while (!data.empty()) {
    auto piece = data.first(std::min(chunk, data.size()));
    data = data.subspan(piece.size());
    while (!piece.empty()) {
      const std::size_t n = p.feed(piece);
      fed += n;
      piece = piece.subspan(n);
      LmsEvent e;
      while (p.next(e)) {
        event_bytes += e.bytes.size();
        if (e.kind != LmsEvent::Kind::telegram) continue;
        check(verify_telegram(e.bytes));
        const TelegramView t{e.bytes};
        check(t.data().size() + 5 + (t.from_device() ? 1u : 0u) + 2 == e.bytes.size());
        if (t.code() == static_cast<std::uint8_t>(Reply::measured_values) && t.from_device()) {
          for (const auto mode : {MeasuringMode::m8_fields_dazzle, MeasuringMode::m16_fields_ab,
                                  MeasuringMode::m32_reflector, MeasuringMode::energy}) {
            if (decode_scan(e.bytes, mode, scan).ok()) check(scan.count <= teamscan::kMaxBeams);
          }
        }
      }
    }
  }
  // Every byte fed is either still buffered or was handed out in exactly one event.
  check(event_bytes + p.buffered() == fed);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> in{data, size};
  const std::size_t chunk = size > 0 ? static_cast<std::size_t>(data[0] % 64) + 1 : 1;
  run(in, StreamDirection::from_device, chunk);
  run(in, StreamDirection::to_device, 4096);
  // Scan decoding directly on the raw input as if it were a verified telegram (defence in depth).
  ScanTelegram scan;
  (void)decode_scan(in, MeasuringMode::m8_fields_dazzle, scan);
  return 0;
}
