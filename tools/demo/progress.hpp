// Progress of a long run on stderr, for `teamscan demo` and `teamscan eval`: on a terminal one bar
// redrawn in place, otherwise a plain line at most every `line_period_s`; nothing when quiet. Events
// (a fault, the view's address) and warnings always go out, each on its own line.
#pragma once

#include <cstdio>
#include <string>

namespace teamscan::demo {

class Progress {
 public:
  // `out`: where to write (stderr); `terminal`: draw a bar (isatty of out's descriptor by default).
  explicit Progress(bool quiet, std::FILE* out = stderr);
  Progress(bool quiet, std::FILE* out, bool terminal, double line_period_s = 5.0);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // A stage begins ("evaluating the live map"): one line (not when quiet).
  void stage(const std::string& text);
  // Fraction done of the current stage (0..1) with a short status; a bar on a terminal, else a line
  // every line_period_s of `at_s` (not when quiet).
  void update(double fraction, double at_s, const std::string& status);
  // An event the user must see whatever --quiet says (a fault, the view's address, a warning).
  void event(const std::string& text);
  // Ends a bar in progress (a newline), so the next output starts on its own line.
  void finish();

  [[nodiscard]] bool terminal() const { return terminal_; }
  // Whether update() shows anything (not quiet): callers skip building a status nobody sees.
  [[nodiscard]] bool shows_progress() const { return !quiet_; }

 private:
  std::FILE* out_;
  bool quiet_, terminal_;
  double line_period_s_;
  double last_line_at_s_ = -1e300;
  bool bar_open_ = false;
};

}  // namespace teamscan::demo
