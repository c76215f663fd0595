// An emulated LMS 200 on a pseudo-terminal in real time (serial::PtyRunner): the entry point for the
// hardware-in-loop tests and `teamscan emulate`. The host program opens host_path() like /dev/ttyS1.
#pragma once

#include <memory>
#include <string>

#include "common/result.hpp"
#include "common/time.hpp"
#include "drivers/lms200/emulator.hpp"
#include "drivers/serial/pty_runner.hpp"

namespace teamscan::lms200 {

class LmsPtyEmulator {
 public:
  // Creates the emulator and its pty (and the symlink `runner.link_path`, if given). `ranges` may be
  // null (a flat 3 m wall) and must outlive the emulator; it is called from the runner's thread.
  // `options.pace_output` is ignored: the runner paces the line.
  [[nodiscard]] static Result<std::unique_ptr<LmsPtyEmulator>> create(const LmsEmulatorOptions& options,
                                                                      RangeSource* ranges,
                                                                      serial::PtyRunnerOptions runner = {});
  LmsPtyEmulator(const LmsPtyEmulator&) = delete;
  LmsPtyEmulator& operator=(const LmsPtyEmulator&) = delete;
  ~LmsPtyEmulator();

  // Powers the scanner up now (CLOCK_MONOTONIC, the runner's clock) and runs it on a thread.
  [[nodiscard]] Status start();
  void stop();
  [[nodiscard]] std::string host_path() const { return runner_->host_path(); }
  // Cable out / cable in: the host sees EIO, then a new pty behind the same symlink.
  void unplug() { runner_->unplug(); }
  [[nodiscard]] Status replug() { return runner_->replug(); }

  // Runs `f(LmsEmulator&)` under the runner's lock (the thread may be running).
  template <class F>
  auto with_emulator(F&& f) {
    return runner_->locked([&] { return f(emulator_); });
  }
  [[nodiscard]] serial::PtyRunner& runner() { return *runner_; }

 private:
  LmsPtyEmulator(LmsEmulatorOptions options, RangeSource* ranges) : emulator_{unpaced(options), ranges} {}
  // The runner paces the line at the device's rate; the emulator must not pace a second time.
  static LmsEmulatorOptions unpaced(LmsEmulatorOptions o) {
    o.pace_output = false;
    return o;
  }
  LmsEmulator emulator_;
  std::unique_ptr<serial::PtyRunner> runner_;
};

}  // namespace teamscan::lms200
