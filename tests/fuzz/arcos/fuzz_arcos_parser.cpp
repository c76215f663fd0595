// libFuzzer target for the ARCOS stream parser and every decoder behind it (STYLE.md 3). Invariants
// checked on any input: each accepted packet verifies on its own; after finish() every byte is
// either in an accepted packet or counted as discarded; decoders never read past the packet.
#include <cstdint>
#include <cstdlib>
#include <span>

#include "drivers/arcos/codec.hpp"
#include "drivers/arcos/parser.hpp"

using namespace teamscan::arcos;

namespace {
void check(bool c) {
  if (!c) std::abort();
}

void decode_everything(const PacketView& p) {
  check(verify_packet(p.wire).ok());
  if (is_sip_type(p.type)) {
    auto s = decode_sip(p);
    if (s.ok()) {
      check(s->sonar_count <= kMaxSonarReadings);
      check(s->tail_fields <= kSipTailFieldCount);
      // Re-encoding what was decoded gives back the packet when nothing trailed the known fields.
      if (s->trailing_bytes == 0) {
        const auto again = encode_sip(s.value());
        check(again.size == p.wire.size());
        for (std::size_t i = 0; i < again.size; ++i) check(again.bytes[i] == p.wire[i]);
      }
    }
  }
  (void)decode_config(p);
  (void)decode_sync2_reply(p);
  (void)decode_encoder(p);
  auto c = decode_command(p);
  if (c.ok() && c->arg == CommandPacket::Arg::kString) check(c->string.size() <= p.data.size());
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static ArcosParser parser;  // static: no allocation per input; reset between inputs
  parser.reset();
  const auto before = parser.statistics();
  std::size_t accepted = 0;
  const std::span<const std::uint8_t> in{data, size};
  // Split the input in two uneven feeds to exercise buffering across calls.
  const std::size_t cut = size / 3;
  auto on_packet = [&](const PacketView& p) {
    accepted += p.wire.size();
    decode_everything(p);
  };
  parser.push(in.first(cut), on_packet);
  parser.push(in.subspan(cut), on_packet);
  parser.finish();
  parser.push({}, on_packet);
  check(parser.buffered() == 0);
  const auto after = parser.statistics();
  check(accepted + (after.discarded_bytes - before.discarded_bytes) == size);
  return 0;
}
