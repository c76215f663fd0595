// Firmware discipline of the DDS bridge (DDS_SYSTEMD.md 1.8): 10 000 publish_scan calls
// allocate nothing in our code and the same constant number of blocks inside Cyclone's dds_write on
// every call, while a subscriber in another process receives all of them in order.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <string>

#include <dds/dds.h>

#include "onboard/bridge/bridge.hpp"
#include "teamscan.h"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan::onboard {
namespace {

using namespace teamscan::dds;

constexpr std::uint32_t kScans = 10000;

TEST(DdsAllocations, CounterIsLinkedIn) { EXPECT_TRUE(test::alloc_counter_active()); }

TEST(DdsAllocations, EncodingAllocatesNothing) {
  static ScanPoints in;
  static teamscan_msg_ScanPoints out;
  in.robot_id = 1;
  in.count = kMaxBeams;
  test::AllocScope scope;
  for (std::uint32_t i = 0; i < kScans; ++i) {
    in.seq = i;
    encode_scan(in, out);
  }
  EXPECT_EQ(scope.delta().allocs, 0u);
}

TEST(DdsAllocations, PublishScanIsConstantAndEveryScanArrivesInOrder) {
  // The sink runs in its own process so that no local-delivery work lands on this thread.
  const std::string cmd = std::string(TEAMSCAN_TEST_PEER) + " sink --count " + std::to_string(kScans) +
                          " --timeout 60 --domain " + test::test_domain_arg();
  FILE* sink = ::popen(cmd.c_str(), "r");
  ASSERT_NE(sink, nullptr);
  char line[256] = {};
  ASSERT_NE(std::fgets(line, sizeof line, sink), nullptr);
  ASSERT_STREQ(line, "ready\n");

  DdsBridgeOptions o;
  o.robot_id = 11;
  o.domain_id = test::test_domain_id();
  o.scan_history_depth = 300;
  auto bridge = DdsBridge::create(o);
  ASSERT_TRUE(bridge.ok()) << bridge.error().what;
  for (int i = 0; i < 1000 && bridge->scan_subscribers() == 0; ++i) dds_sleepfor(DDS_MSECS(10));
  ASSERT_EQ(bridge->scan_subscribers(), 1u);

  static ScanPoints scan;
  scan.robot_id = 11;
  scan.count = kMaxBeams;
  for (std::uint16_t b = 0; b < kMaxBeams; ++b) scan.points[b] = ScanPoint{b, -b, 300, b, 0};
  std::vector<std::uint32_t> per_call(kScans);  // preallocated: the vector never grows while counting
  for (std::uint32_t i = 0; i < kScans; ++i) {
    scan.seq = i + 1;
    scan.stamp = Time::from_ns(i);
    test::AllocScope scope;
    const Status st = bridge->publish_scan(scan);
    per_call[i] = static_cast<std::uint32_t>(scope.delta().allocs);
    ASSERT_TRUE(st.ok()) << st.error().what << " " << st.error().detail;
    // Keep-last never blocks the writer; pace so the reader is never more than the history behind.
    if (i % 200 == 199) {
      ASSERT_TRUE(bridge->wait_for_scan_acks(std::chrono::seconds(10)).ok());
    }
  }
  ASSERT_TRUE(bridge->wait_for_scan_acks(std::chrono::seconds(10)).ok());

  // Warm-up: until the writer history holds `depth` samples each write adds one history node (4 allocs);
  // once it is full the oldest node is recycled. Count from twice the depth on.
  std::map<std::uint32_t, std::uint32_t> histogram;
  for (std::uint32_t i = 2 * o.scan_history_depth; i < kScans; ++i) ++histogram[per_call[i]];
  std::string h;
  for (const auto& [allocs, n] : histogram) h += std::to_string(allocs) + " allocs x" + std::to_string(n) + "; ";
  std::printf("publish_scan allocations per call after warm-up: %s\n", h.c_str());

  // Constant: one value for every call after warm-up, and it is Cyclone's 3 (serialisation buffer and
  // two 4 kB growth steps, DDS_SYSTEMD.md 1.8), so our code adds nothing.
  EXPECT_EQ(histogram.size(), 1u) << h;
  EXPECT_EQ(histogram.begin()->first, 3u) << h;

  char result[256] = {};
  ASSERT_NE(std::fgets(result, sizeof result, sink), nullptr);
  const int rc = ::pclose(sink);
  EXPECT_EQ(rc, 0);
  const std::string expected = "received " + std::to_string(kScans) + " in_order 1 first 1 last " +
                               std::to_string(kScans) + " distinct " + std::to_string(kScans) + "\n";
  EXPECT_EQ(std::string(result), expected);
}

}  // namespace
}  // namespace teamscan::onboard
