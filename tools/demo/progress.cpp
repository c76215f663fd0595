// Progress on stderr (progress.hpp).
#include "tools/demo/progress.hpp"

#include <unistd.h>

#include <algorithm>

namespace teamscan::demo {

namespace {
constexpr int kBarWidth = 30;
}

Progress::Progress(bool quiet, std::FILE* out) : Progress(quiet, out, ::isatty(::fileno(out)) == 1) {}

Progress::Progress(bool quiet, std::FILE* out, bool terminal, double line_period_s)
    : out_(out), quiet_(quiet), terminal_(terminal), line_period_s_(line_period_s) {}

Progress::~Progress() { finish(); }

void Progress::stage(const std::string& text) {
  if (quiet_) return;
  finish();
  std::fprintf(out_, "%s\n", text.c_str());
  std::fflush(out_);
  last_line_at_s_ = -1e300;
}

void Progress::update(double fraction, double at_s, const std::string& status) {
  if (quiet_) return;
  const double f = std::clamp(fraction, 0.0, 1.0);
  if (terminal_) {
    const int filled = static_cast<int>(f * kBarWidth + 0.5);
    std::fprintf(out_, "\r[%s%s] %3.0f %%  %s\033[K", std::string(static_cast<std::size_t>(filled), '#').c_str(),
                 std::string(static_cast<std::size_t>(kBarWidth - filled), ' ').c_str(), 100.0 * f, status.c_str());
    bar_open_ = true;
  } else {
    if (at_s - last_line_at_s_ < line_period_s_) return;
    last_line_at_s_ = at_s;
    std::fprintf(out_, "  %3.0f %%  %s\n", 100.0 * f, status.c_str());
  }
  std::fflush(out_);
}

void Progress::event(const std::string& text) {
  finish();
  std::fprintf(out_, "%s\n", text.c_str());
  std::fflush(out_);
}

void Progress::finish() {
  if (!bar_open_) return;
  std::fprintf(out_, "\n");
  std::fflush(out_);
  bar_open_ = false;
}

}  // namespace teamscan::demo
