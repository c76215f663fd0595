// Fuzz target: everything the view parses from outside — a voxel message (decode_voxels), a request line
// (route_request), a listen address (parse_listen), a Foxglove client's text and binary messages
// (decode_client_text / decode_client_binary) and its upgrade (is_foxglove_upgrade) — on arbitrary bytes.
// It must never crash; a decoded voxel message must re-encode to the same bytes; a route is either an
// answer or an error with a 4xx; a malformed Foxglove message says why, a refused one names its op.
#include <cstdint>
#include <string>
#include <string_view>

#include "groundstation/view/foxglove_protocol.hpp"
#include "groundstation/view/protocol.hpp"
#include "groundstation/view/requests.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace teamscan::view;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  if (auto m = decode_voxels(bytes); m.ok()) {
    if (encode_voxels(m.value()) != bytes) __builtin_trap();
  }
  // "METHOD TARGET" from the input; the first byte picks upgrade and body.
  const std::size_t space = bytes.find(' ');
  const std::string_view method = bytes.substr(0, space);
  const std::string_view target = space == std::string_view::npos ? std::string_view{} : bytes.substr(space + 1);
  const bool upgrade = size > 0 && (data[0] & 1);
  const RouteDecision d = route_request(method, target, upgrade, size > 0 ? (data[0] >> 1) % 3 : 0, RequestLimits{},
                                        [](std::string_view n) { return n == "index.html" || n == "app.js"; });
  if (d.route == Route::kError && (d.status < 400 || d.status > 499 || d.error.empty())) __builtin_trap();
  if (d.route == Route::kFile && d.file != "index.html" && d.file != "app.js") __builtin_trap();
  ListenAddress a;
  std::string why;
  if (!parse_listen(bytes, a, why) && why.empty()) __builtin_trap();
  (void)json_escape(bytes);
  for (const foxglove::ClientRequest& r : {foxglove::decode_client_text(bytes), foxglove::decode_client_binary(bytes)}) {
    if (r.kind == foxglove::ClientRequest::Kind::kMalformed && r.why.empty()) __builtin_trap();
    if (r.kind == foxglove::ClientRequest::Kind::kRefused && r.op.empty()) __builtin_trap();
  }
  (void)is_foxglove_upgrade(method, target, upgrade, bytes, foxglove::kSubprotocol);
  return 0;
}
