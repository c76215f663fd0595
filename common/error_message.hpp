// Errors that own their message, for the host layers (ground station, tools, simulator, the data set
// files): the message names what failed ("scans.csv: cannot open", "team.publish_rate_hz: ...").
// The firmware libraries (onboard/, drivers/, dds/, common's firmware targets) keep literal messages:
// they allocate nothing after start-up, so this header refuses to compile without exceptions.
#pragma once

#if !defined(__cpp_exceptions)
#error "common/error_message.hpp builds messages at run time: host layers only (firmware keeps literal Error messages, common/README.md)"
#endif

#include "common/result.hpp"

#include <memory>
#include <string>
#include <string_view>
#include <utility>

namespace teamscan {

// An error whose message was built where it happened: make_error("cannot open " + path, errno).
[[nodiscard]] inline Error make_error(std::string message, int sys_errno = 0, long detail = 0) {
  auto owned = std::make_shared<const std::string>(std::move(message));
  const char* what = owned->c_str();
  return Error{what, sys_errno, detail, std::move(owned)};
}

// `e` with what the caller was doing in front: "<context>: <e.what>"; errno and detail are kept.
[[nodiscard]] inline Error with_context(std::string_view context, const Error& e) {
  std::string message{context};
  message += ": ";
  message += e.what;
  return make_error(std::move(message), e.sys_errno, e.detail);
}

}  // namespace teamscan
