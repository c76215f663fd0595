// Errors as values (STYLE.md 6): a runtime fault is a [[nodiscard]] Result; a programming error is a
// contract check that aborts. No exceptions: usable in -fno-exceptions code.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <new>
#include <string>
#include <type_traits>
#include <utility>

namespace teamscan {

// A runtime error: its message, where it came from the OS errno, and a number the message refers to.
// The message is a string literal (`Error{"lms200: bad CRC"}`; the only kind in the firmware
// libraries, which allocate nothing after start-up) or, in the host layers, a message built where the
// error happened and owned by the error (`make_error("cannot open " + path, errno)`,
// common/error_message.hpp). Either way `what` is the text; copies of an Error share its message, so
// `what` stays valid as long as any copy lives.
struct Error {
  const char* what = "unknown error";
  int sys_errno = 0;
  long detail = 0;  // e.g. the line number of a malformed file
  std::shared_ptr<const std::string> owned{};  // a built message (what points into it); empty for a literal
};

template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : ok_{true} { new (&storage_.value) T(std::move(value)); }  // NOLINT: implicit by design
  Result(Error e) : ok_{false} { new (&storage_.error) Error(std::move(e)); }  // NOLINT: implicit by design
  Result(const Result& o) : ok_{o.ok_} {
    if (ok_) new (&storage_.value) T(o.storage_.value); else new (&storage_.error) Error(o.storage_.error);
  }
  Result(Result&& o) noexcept : ok_{o.ok_} {
    // The error is copied, not moved: a moved-from Result's error() still reads its message.
    if (ok_) new (&storage_.value) T(std::move(o.storage_.value)); else new (&storage_.error) Error(o.storage_.error);
  }
  Result& operator=(Result o) noexcept {
    this->~Result();
    new (this) Result(std::move(o));
    return *this;
  }
  ~Result() {
    if (ok_) storage_.value.~T(); else storage_.error.~Error();
  }

  [[nodiscard]] bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  [[nodiscard]] T& value() { check(ok_); return storage_.value; }
  [[nodiscard]] const T& value() const { check(ok_); return storage_.value; }
  [[nodiscard]] const Error& error() const { check(!ok_); return storage_.error; }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() { return value(); }
  const T& operator*() const { return value(); }

 private:
  static void check(bool c) {
    if (!c) { std::fputs("teamscan: Result accessed in the wrong state\n", stderr); std::abort(); }
  }
  union Storage { Storage() {} ~Storage() {} T value; Error error; } storage_;
  bool ok_;
};

// Result<void>.
struct Ok {};
using Status = Result<Ok>;
inline Status ok_status() { return Ok{}; }

// Contract check: a programming error aborts with the location (STYLE.md 6).
#define TEAMSCAN_EXPECTS(cond)                                                                   \
  do {                                                                                           \
    if (!(cond)) {                                                                               \
      std::fprintf(stderr, "teamscan: contract violated: %s at %s:%d\n", #cond, __FILE__, __LINE__); \
      std::abort();                                                                              \
    }                                                                                            \
  } while (0)

}  // namespace teamscan
