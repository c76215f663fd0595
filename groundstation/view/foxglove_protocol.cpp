// Foxglove WebSocket protocol messages (foxglove_protocol.hpp), JSON through nlohmann-json.
#include "groundstation/view/foxglove_protocol.hpp"

#include <nlohmann/json.hpp>

namespace teamscan::view::foxglove {

using nlohmann::json;

std::string encode_server_info(std::string_view name, std::string_view session_id) {
  json j = {{"op", "serverInfo"},
            {"name", name},
            {"capabilities", json::array()},
            {"supportedEncodings", json::array()},
            {"metadata", {{"read_only", "true"}}},
            {"sessionId", session_id}};
  return j.dump();
}

std::string encode_advertise(std::span<const Channel> channels) {
  json list = json::array();
  for (const Channel& c : channels) {
    list.push_back({{"id", c.id},
                    {"topic", c.topic},
                    {"encoding", c.encoding},
                    {"schemaName", c.schema_name},
                    {"schema", c.schema},
                    {"schemaEncoding", c.schema_encoding}});
  }
  return json{{"op", "advertise"}, {"channels", std::move(list)}}.dump();
}

std::string encode_status(StatusLevel level, std::string_view message) {
  return json{{"op", "status"}, {"level", static_cast<int>(level)}, {"message", message}}.dump();
}

std::string encode_message_data(std::uint32_t subscription_id, std::uint64_t receive_ns, std::string_view payload) {
  std::string out;
  out.reserve(kMessageDataHeaderBytes + payload.size());
  out.push_back(static_cast<char>(kOpMessageData));
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((subscription_id >> (8 * i)) & 0xffu));
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>((receive_ns >> (8 * i)) & 0xffu));
  out.append(payload);
  return out;
}

namespace {

ClientRequest malformed(std::string why) {
  ClientRequest r;
  r.kind = ClientRequest::Kind::kMalformed;
  r.why = std::move(why);
  return r;
}

bool as_u32(const json& v, std::uint32_t& out) {
  if (!v.is_number_unsigned() && !(v.is_number_integer() && v.get<std::int64_t>() >= 0)) return false;
  const std::uint64_t u = v.get<std::uint64_t>();
  if (u > 0xffffffffu) return false;
  out = static_cast<std::uint32_t>(u);
  return true;
}

}  // namespace

ClientRequest decode_client_text(std::string_view text) {
  const json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return malformed("not a JSON object");
  const auto op_it = j.find("op");
  if (op_it == j.end() || !op_it->is_string()) return malformed("no op");
  ClientRequest r;
  r.op = op_it->get<std::string>();
  if (r.op == "subscribe") {
    const auto subs = j.find("subscriptions");
    if (subs == j.end() || !subs->is_array()) return malformed("subscribe without subscriptions");
    for (const json& s : *subs) {
      std::uint32_t id = 0, channel = 0;
      if (!s.is_object() || !s.contains("id") || !s.contains("channelId") || !as_u32(s["id"], id) ||
          !as_u32(s["channelId"], channel))
        return malformed("subscribe: each subscription needs id and channelId (unsigned 32-bit)");
      r.subscriptions.emplace_back(id, channel);
    }
    r.kind = ClientRequest::Kind::kSubscribe;
    return r;
  }
  if (r.op == "unsubscribe") {
    const auto ids = j.find("subscriptionIds");
    if (ids == j.end() || !ids->is_array()) return malformed("unsubscribe without subscriptionIds");
    for (const json& v : *ids) {
      std::uint32_t id = 0;
      if (!as_u32(v, id)) return malformed("unsubscribe: subscriptionIds are unsigned 32-bit");
      r.subscription_ids.push_back(id);
    }
    r.kind = ClientRequest::Kind::kUnsubscribe;
    return r;
  }
  static constexpr std::string_view kRefusedOps[] = {
      "advertise", "unadvertise", "getParameters", "setParameters", "subscribeParameterUpdates",
      "unsubscribeParameterUpdates", "subscribeConnectionGraph", "unsubscribeConnectionGraph", "fetchAsset"};
  for (std::string_view op : kRefusedOps) {
    if (r.op == op) {
      r.kind = ClientRequest::Kind::kRefused;
      return r;
    }
  }
  return malformed("unknown op " + r.op);
}

ClientRequest decode_client_binary(std::string_view bytes) {
  if (bytes.empty()) return malformed("empty binary message");
  ClientRequest r;
  switch (static_cast<std::uint8_t>(bytes.front())) {
    case 0x01:
      r.op = "clientMessageData";
      r.kind = ClientRequest::Kind::kRefused;
      return r;
    case 0x02:
      r.op = "serviceCallRequest";
      r.kind = ClientRequest::Kind::kRefused;
      return r;
    default:
      return malformed("unknown binary opcode");
  }
}

}  // namespace teamscan::view::foxglove
