// The onboard pipeline's scan of test beams, for the tests that drive OnboardPipeline with hand-made
// ranges and beam flags (what lms200::ScanTelegram::sweep() views on the robot): a refused sweep fails
// the test instead of crashing it.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>

#include "common/laser_geometry.hpp"
#include "common/scan_points.hpp"
#include "onboard/core/pipeline.hpp"

namespace teamscan::test {

inline const ScanPoints& scan_of(onboard::OnboardPipeline& pipeline, BeamSpans beams, Time stamp) {
  static const ScanPoints kRefused{};
  const ScanPoints* scan = pipeline.on_scan(beams, stamp);
  EXPECT_NE(scan, nullptr) << "the pipeline refused the sweep (not one full sweep of the configured variant)";
  return scan != nullptr ? *scan : kRefused;
}

}  // namespace teamscan::test
