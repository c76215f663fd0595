// Request handling of the view: routing, listen address, counters (requests.hpp).
#include "groundstation/view/requests.hpp"

#include <charconv>
#include <cstdio>

namespace teamscan::view {
namespace detail {

bool valid_file_name(std::string_view name) {
  if (name.empty() || name.size() > 128 || name.front() == '.') return false;
  for (const char c : name) {
    const bool ok =
        (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '-' || c == '_';
    if (!ok) return false;
  }
  return true;
}

bool parse_seq_query(std::string_view query, std::optional<std::uint64_t>& seq) {
  if (query.empty()) return true;
  if (query.substr(0, 4) != "seq=") return false;
  const std::string_view v = query.substr(4);
  std::uint64_t n = 0;
  const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), n);
  if (ec != std::errc{} || end != v.data() + v.size() || v.empty()) return false;
  seq = n;
  return true;
}

}  // namespace detail

void ViewCounters::count_error(int status) {
  switch (status) {
    case 404:
      ++not_found;
      break;
    case 405:
      ++bad_method;
      break;
    case 413:
    case 414:
    case 431:
      ++oversized;
      break;
    case 503:
      ++refused;
      break;
    case 400:
    default:
      ++malformed;
      break;
  }
}

bool is_foxglove_upgrade(std::string_view method, std::string_view target, bool websocket_upgrade,
                         std::string_view protocols_header, std::string_view protocol) {
  if (!websocket_upgrade || method != "GET") return false;
  const std::string_view path = target.substr(0, target.find('?'));
  if (path != "/" && path != "/ws" && path != "/foxglove") return false;
  while (!protocols_header.empty()) {
    const std::size_t comma = protocols_header.find(',');
    std::string_view token = protocols_header.substr(0, comma);
    while (!token.empty() && (token.front() == ' ' || token.front() == '\t')) token.remove_prefix(1);
    while (!token.empty() && (token.back() == ' ' || token.back() == '\t')) token.remove_suffix(1);
    if (token == protocol) return true;
    if (comma == std::string_view::npos) break;
    protocols_header.remove_prefix(comma + 1);
  }
  return false;
}

std::string ViewCounters::json() const {
  char b[900];
  std::snprintf(b, sizeof b,
                "{\"requests\":%llu,\"malformed\":%llu,\"oversized\":%llu,\"not_found\":%llu,\"bad_method\":%llu,"
                "\"bad_query\":%llu,\"refused\":%llu,\"ws_opened\":%llu,\"ws_open\":%llu,\"ws_rejected\":%llu,"
                "\"skips\":%llu,\"messages_sent\":%llu,\"bytes_sent\":%llu,\"hub_bytes\":%llu,\"queued_bytes\":%llu,"
                "\"foxglove_opened\":%llu,\"foxglove_open\":%llu,\"foxglove_refused\":%llu,\"foxglove_malformed\":%llu,"
                "\"foxglove_skips\":%llu}",
                static_cast<unsigned long long>(requests.load()), static_cast<unsigned long long>(malformed.load()),
                static_cast<unsigned long long>(oversized.load()), static_cast<unsigned long long>(not_found.load()),
                static_cast<unsigned long long>(bad_method.load()), static_cast<unsigned long long>(bad_query.load()),
                static_cast<unsigned long long>(refused.load()), static_cast<unsigned long long>(ws_opened.load()),
                static_cast<unsigned long long>(ws_open.load()), static_cast<unsigned long long>(ws_rejected.load()),
                static_cast<unsigned long long>(skips.load()), static_cast<unsigned long long>(messages_sent.load()),
                static_cast<unsigned long long>(bytes_sent.load()), static_cast<unsigned long long>(hub_bytes.load()),
                static_cast<unsigned long long>(queued_bytes.load()), static_cast<unsigned long long>(foxglove_opened.load()),
                static_cast<unsigned long long>(foxglove_open.load()), static_cast<unsigned long long>(foxglove_refused.load()),
                static_cast<unsigned long long>(foxglove_malformed.load()),
                static_cast<unsigned long long>(foxglove_skips.load()));
  return b;
}

std::string ViewCounters::line() const {
  char b[600];
  std::snprintf(b, sizeof b,
                "view: %llu requests (%llu malformed, %llu oversized, %llu not found, %llu bad method, %llu refused), "
                "%llu WebSocket clients (%llu open, %llu messages rejected, %llu skips), %llu Foxglove clients (%llu "
                "requests refused, %llu malformed, %llu skips), %llu messages %.1f MB sent",
                static_cast<unsigned long long>(requests.load()), static_cast<unsigned long long>(malformed.load()),
                static_cast<unsigned long long>(oversized.load()), static_cast<unsigned long long>(not_found.load()),
                static_cast<unsigned long long>(bad_method.load()), static_cast<unsigned long long>(refused.load()),
                static_cast<unsigned long long>(ws_opened.load()), static_cast<unsigned long long>(ws_open.load()),
                static_cast<unsigned long long>(ws_rejected.load()), static_cast<unsigned long long>(skips.load()),
                static_cast<unsigned long long>(foxglove_opened.load()),
                static_cast<unsigned long long>(foxglove_refused.load()),
                static_cast<unsigned long long>(foxglove_malformed.load()),
                static_cast<unsigned long long>(foxglove_skips.load()),
                static_cast<unsigned long long>(messages_sent.load()), static_cast<double>(bytes_sent.load()) * 1e-6);
  return b;
}

bool parse_listen(std::string_view text, ListenAddress& out, std::string& error) {
  const std::size_t colon = text.rfind(':');
  if (colon == std::string_view::npos) {
    error = "must be HOST:PORT, e.g. \"127.0.0.1:8080\"";
    return false;
  }
  std::string host(text.substr(0, colon));
  const std::string_view port_text = text.substr(colon + 1);
  if (host == "localhost") host = "127.0.0.1";
  unsigned parts[4];
  char tail = 0;
  const bool digits_and_dots = host.find_first_not_of("0123456789.") == std::string::npos;
  if (!digits_and_dots ||
      std::sscanf(host.c_str(), "%3u.%3u.%3u.%3u%c", &parts[0], &parts[1], &parts[2], &parts[3], &tail) != 4 ||
      parts[0] > 255 || parts[1] > 255 || parts[2] > 255 || parts[3] > 255) {
    error = "host must be an IPv4 address (e.g. 127.0.0.1) or localhost, got \"" + host + "\"";
    return false;
  }
  unsigned port = 0;
  const auto [end, ec] = std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
  if (port_text.empty() || ec != std::errc{} || end != port_text.data() + port_text.size() || port > 65535) {
    error = "port must be an integer in [0, 65535], got \"" + std::string(port_text) + "\"";
    return false;
  }
  out.host = host;
  out.port = static_cast<std::uint16_t>(port);
  return true;
}

std::string_view content_type_of(std::string_view file) {
  auto ends = [&](std::string_view ext) {
    return file.size() >= ext.size() && file.substr(file.size() - ext.size()) == ext;
  };
  if (ends(".html")) return "text/html; charset=utf-8";
  if (ends(".js")) return "text/javascript; charset=utf-8";
  if (ends(".css")) return "text/css; charset=utf-8";
  if (ends(".json")) return "application/json";
  if (ends(".png")) return "image/png";
  if (ends(".svg")) return "image/svg+xml";
  if (ends(".map")) return "application/json";
  if (ends(".txt")) return "text/plain; charset=utf-8";
  return "application/octet-stream";
}

}  // namespace teamscan::view
