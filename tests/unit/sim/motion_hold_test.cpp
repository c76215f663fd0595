// MotionHold (sim/motion_hold.hpp): the track stops while the robot is held and drives on from there.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/motion_hold.hpp"

namespace teamscan::sim {
namespace {

TEST(MotionHold, NeverHeldIsWorldTime) {
  const MotionHold h;
  EXPECT_EQ(h.track_time(0.0), 0.0);
  EXPECT_EQ(h.track_time(12.5), 12.5);
  EXPECT_FALSE(h.held_at(3.0));
  EXPECT_EQ(h.holds(), 0u);
}

TEST(MotionHold, HeldTheTrackStandsStill) {
  MotionHold h;
  h.hold(10.0);
  EXPECT_EQ(h.track_time(5.0), 5.0);    // before: unchanged
  EXPECT_EQ(h.track_time(10.0), 10.0);
  EXPECT_EQ(h.track_time(25.0), 10.0);  // held: stands at the hold's start
  EXPECT_TRUE(h.held_at(10.0));
  EXPECT_TRUE(h.held_at(1e6));
  EXPECT_FALSE(h.held_at(9.999));
}

TEST(MotionHold, ReleasedTheTrackDrivesOnFromWhereItStopped) {
  MotionHold h;
  h.hold(10.0);
  h.release(14.0);
  EXPECT_EQ(h.track_time(12.0), 10.0);
  EXPECT_EQ(h.track_time(14.0), 10.0);
  EXPECT_EQ(h.track_time(20.0), 16.0);  // 4 s held
  EXPECT_FALSE(h.held_at(14.0));
  h.hold(30.0);
  h.release(31.5);
  EXPECT_EQ(h.track_time(40.0), 34.5);  // 5.5 s held in all
  EXPECT_EQ(h.holds(), 2u);
}

TEST(MotionHold, RepeatedAndOutOfOrderCallsKeepTheIntervalsSane) {
  MotionHold h;
  h.release(3.0);  // not held: nothing
  EXPECT_EQ(h.holds(), 0u);
  h.hold(10.0);
  h.hold(11.0);  // already held: the first start stays
  EXPECT_EQ(h.track_time(12.0), 10.0);
  h.release(9.0);  // before the start: released at the start (no negative hold)
  EXPECT_EQ(h.track_time(12.0), 12.0);
  h.hold(5.0);  // before the last release: starts at it
  EXPECT_EQ(h.track_time(12.0), 10.0);
  EXPECT_EQ(h.holds(), 2u);
}

}  // namespace
}  // namespace teamscan::sim
