// The onboard [odometry] max_hold_s key (docs/demo.md "Latency"): default = the extrapolation limit (the
// behaviour before the key), 0 allowed (publish at once), bounded by max_extrapolation_s, bad values named.
#include "onboard/core/config.hpp"

#include <gtest/gtest.h>

#include <string>

namespace teamscan::onboard {
namespace {

constexpr const char* kBase = R"(
[robot]
id = 3
[arcos]
device = "/dev/ttyUSB0"
[lms]
device = "/dev/ttyUSB1"
[mount]
x_m = 0.1
y_m = 0
z_m = 0.5
pitch_deg = 10
)";

Result<OnboardConfig> parse(const std::string& odometry, std::string& msg) {
  return parse_onboard_config(std::string{kBase} + "[odometry]\n" + odometry, msg);
}

TEST(OnboardConfigHold, DefaultsToTheExtrapolationLimit) {
  std::string msg;
  auto c = parse_onboard_config(kBase, msg);
  ASSERT_TRUE(c.ok()) << msg;
  EXPECT_EQ(c->odometry_max_hold, c->odometry_max_extrapolation);
  c = parse("max_extrapolation_s = 0.3\n", msg);
  ASSERT_TRUE(c.ok()) << msg;
  EXPECT_EQ(c->odometry_max_hold, from_seconds(0.3));
}

TEST(OnboardConfigHold, ZeroAndBoundaryAccepted) {
  std::string msg;
  auto c = parse("max_hold_s = 0\n", msg);
  ASSERT_TRUE(c.ok()) << msg;
  EXPECT_EQ(c->odometry_max_hold, Duration::zero());
  c = parse("max_extrapolation_s = 0.2\nmax_hold_s = 0.2\n", msg);
  ASSERT_TRUE(c.ok()) << msg;
  EXPECT_EQ(c->odometry_max_hold, from_seconds(0.2));
  c = parse("max_hold_s = 0.05\n", msg);
  ASSERT_TRUE(c.ok()) << msg;
  EXPECT_EQ(c->odometry_max_hold, from_seconds(0.05));
  EXPECT_NE(describe(*c).find("hold 0.050 s"), std::string::npos) << describe(*c);
}

TEST(OnboardConfigHold, OutOfRangeIsRefusedByName) {
  for (const char* bad : {"max_hold_s = -0.01\n", "max_extrapolation_s = 0.1\nmax_hold_s = 0.15\n", "max_hold_s = 2\n",
                          "max_hold_s = \"soon\"\n"}) {
    std::string msg;
    const auto c = parse(bad, msg);
    EXPECT_FALSE(c.ok()) << bad;
    EXPECT_NE(msg.find("odometry.max_hold_s"), std::string::npos) << bad << " -> " << msg;
  }
}

}  // namespace
}  // namespace teamscan::onboard
