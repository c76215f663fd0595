// LatencyHistogram (groundstation/station/latency_histogram.hpp): quantiles bracket the true order
// statistic within one 0.1 ms bucket, negative and overflowing samples are counted, the CSV adds up.
#include "groundstation/station/latency_histogram.hpp"

#include <gtest/gtest.h>

#include <sstream>
#include <string>

namespace teamscan::station {
namespace {

constexpr std::int64_t kMs = 1'000'000;

TEST(LatencyHistogram, EmptyAnswersZero) {
  LatencyHistogram h;
  EXPECT_EQ(h.count(), 0u);
  EXPECT_EQ(h.quantile_ns(0.5), 0);
  EXPECT_EQ(h.quantile_ns(0.99), 0);
}

TEST(LatencyHistogram, QuantilesWithinOneBucketOfTheOrderStatistic) {
  LatencyHistogram h;
  // 1, 2, ..., 200 ms in a scrambled order: the p-quantile is the ceil(p·n)-th smallest.
  for (int i = 0; i < 200; ++i) h.add(((i * 77) % 200 + 1) * kMs + 30'000);
  ASSERT_EQ(h.count(), 200u);
  const std::int64_t p50_true = 100 * kMs + 30'000, p99_true = 198 * kMs + 30'000;
  EXPECT_GE(h.quantile_ns(0.5), p50_true);
  EXPECT_LE(h.quantile_ns(0.5), p50_true + LatencyHistogram::kBucketNs);
  EXPECT_GE(h.quantile_ns(0.99), p99_true);
  EXPECT_LE(h.quantile_ns(0.99), p99_true + LatencyHistogram::kBucketNs);
  EXPECT_EQ(h.quantile_ns(1.0), 200 * kMs + 30'000);  // capped at the maximum
  EXPECT_EQ(h.max_ns(), 200 * kMs + 30'000);
  EXPECT_NEAR(h.mean_ns(), 100.5 * kMs + 30'000, 1.0);
}

TEST(LatencyHistogram, OneSampleIsEveryQuantile) {
  LatencyHistogram h;
  h.add(12'345'678);
  EXPECT_EQ(h.quantile_ns(0.01), 12'345'678);
  EXPECT_EQ(h.quantile_ns(0.99), 12'345'678);
}

TEST(LatencyHistogram, NegativeAndOverflowAreCounted) {
  LatencyHistogram h;
  h.add(-5 * kMs);        // clocks apart: counted, lands in bucket 0
  h.add(3'000 * kMs);     // beyond 1 s: overflow bucket, exact maximum
  h.add(2 * kMs);
  EXPECT_EQ(h.count(), 3u);
  EXPECT_EQ(h.negative(), 1u);
  EXPECT_EQ(h.overflow(), 1u);
  EXPECT_EQ(h.bucket(0), 1u);
  EXPECT_EQ(h.max_ns(), 3'000 * kMs);
  EXPECT_EQ(h.quantile_ns(1.0), 3'000 * kMs);
  EXPECT_LE(h.quantile_ns(0.33), LatencyHistogram::kBucketNs);  // the smallest of three
  EXPECT_GE(h.quantile_ns(0.34), 2 * kMs);                       // the second
}

TEST(LatencyHistogram, CsvBucketsAddUpToTheCount) {
  LatencyHistogram h;
  for (int i = 0; i < 50; ++i) h.add(i * 7 * kMs / 3);
  h.add(5'000 * kMs);
  std::istringstream in{h.csv("test")};
  std::uint64_t total = 0;
  bool in_buckets = false;
  std::string p99;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("p99,", 0) == 0) p99 = line.substr(4);
    if (line == "lower_ms,upper_ms,count") {
      in_buckets = true;
      continue;
    }
    if (!in_buckets) continue;
    total += std::stoull(line.substr(line.rfind(',') + 1));
  }
  EXPECT_EQ(total, 51u);
  EXPECT_FALSE(p99.empty());
}

}  // namespace
}  // namespace teamscan::station
