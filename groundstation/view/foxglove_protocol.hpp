// The Foxglove WebSocket protocol, subprotocol `foxglove.websocket.v1` (foxglove/ws-protocol docs/spec.md),
// as the read-only view speaks it: the server's JSON messages (serverInfo, advertise, status), the binary
// Message Data frame, and the client's messages decoded into what the view does with them -- subscribe and
// unsubscribe are served; publishing, services, parameters, the connection graph and assets are refused
// (the view announces none of those capabilities). Pure encoders and a decoder, no I/O.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace teamscan::view::foxglove {

inline constexpr char kSubprotocol[] = "foxglove.websocket.v1";
inline constexpr std::uint8_t kOpMessageData = 0x01;         // server binary opcode
inline constexpr std::size_t kMessageDataHeaderBytes = 13;   // opcode, u32 subscription id, u64 receive ns

// A channel as advertised. encoding "cdr" with schema_encoding "ros2msg" (ROS 2 messages), or "json" with
// "jsonschema".
struct Channel {
  std::uint32_t id = 0;
  std::string topic;
  std::string encoding;
  std::string schema_name;
  std::string schema;
  std::string schema_encoding;
};

// {"op":"serverInfo","name":..,"capabilities":[],"supportedEncodings":[],"metadata":{..},"sessionId":..}
[[nodiscard]] std::string encode_server_info(std::string_view name, std::string_view session_id);
// {"op":"advertise","channels":[{"id","topic","encoding","schemaName","schema","schemaEncoding"}, ...]}
[[nodiscard]] std::string encode_advertise(std::span<const Channel> channels);
enum class StatusLevel : int { kInfo = 0, kWarning = 1, kError = 2 };
// {"op":"status","level":L,"message":..}
[[nodiscard]] std::string encode_status(StatusLevel level, std::string_view message);
// Binary Message Data: 0x01 | u32 subscription id | u64 receive time ns | payload (little-endian).
[[nodiscard]] std::string encode_message_data(std::uint32_t subscription_id, std::uint64_t receive_ns,
                                              std::string_view payload);

// What a client's message asks, after decoding.
struct ClientRequest {
  enum class Kind {
    kSubscribe,    // subscriptions: (subscription id, channel id)
    kUnsubscribe,  // subscription_ids
    kRefused,      // a valid request of a capability the view does not offer (op names it)
    kMalformed,    // not JSON, no op, wrong field types, an unknown op or binary opcode (why says)
  };
  Kind kind = Kind::kMalformed;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> subscriptions;
  std::vector<std::uint32_t> subscription_ids;
  std::string op;
  std::string why;
};

// A text message from the client.
[[nodiscard]] ClientRequest decode_client_text(std::string_view text);
// A binary message from the client: 0x01 client message data (publish) and 0x02 service call request are
// refused; anything else is malformed.
[[nodiscard]] ClientRequest decode_client_binary(std::string_view bytes);

}  // namespace teamscan::view::foxglove
