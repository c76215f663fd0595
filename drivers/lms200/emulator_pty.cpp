// LmsEmulator on a pseudo-terminal via serial::PtyRunner.
#include "drivers/lms200/emulator_pty.hpp"

#include "common/clock.hpp"

namespace teamscan::lms200 {

Result<std::unique_ptr<LmsPtyEmulator>> LmsPtyEmulator::create(const LmsEmulatorOptions& options, RangeSource* ranges,
                                                               serial::PtyRunnerOptions runner) {
  std::unique_ptr<LmsPtyEmulator> self{new LmsPtyEmulator{options, ranges}};
  auto r = serial::PtyRunner::create(self->emulator_, std::move(runner));
  if (!r) return r.error();
  self->runner_ = std::move(r.value());
  return self;
}

LmsPtyEmulator::~LmsPtyEmulator() { stop(); }

Status LmsPtyEmulator::start() {
  runner_->locked([&] { emulator_.power_up(now_monotonic()); });
  return runner_->start();
}

void LmsPtyEmulator::stop() {
  if (runner_ && runner_->running()) runner_->stop();
}

}  // namespace teamscan::lms200
