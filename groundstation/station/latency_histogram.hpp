// A fixed-bucket latency histogram (0.1 ms buckets up to 1 s, then one overflow bucket with the maximum
// kept exactly): records per scan without allocating, answers p50/p99 at any time (docs/demo.md).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>

namespace teamscan::station {

class LatencyHistogram {
 public:
  static constexpr std::int64_t kBucketNs = 100'000;  // 0.1 ms
  static constexpr std::size_t kBuckets = 10'000;     // 0 .. 1 s; beyond: the overflow bucket

  // Adds one sample. A negative latency (clocks of two hosts apart) is counted in `negative()` and in
  // bucket 0, so it shows and is not lost.
  void add(std::int64_t latency_ns) {
    ++count_;
    if (latency_ns < 0) {
      ++negative_;
      latency_ns = 0;
    }
    max_ns_ = std::max(max_ns_, latency_ns);
    sum_ns_ += latency_ns;
    const auto b = static_cast<std::uint64_t>(latency_ns / kBucketNs);
    if (b >= kBuckets) {
      ++overflow_;
    } else {
      ++buckets_[static_cast<std::size_t>(b)];
    }
  }

  // The q-quantile (0 < q ≤ 1) as the upper edge of the bucket holding the ceil(q·n)-th smallest sample
  // (so never below the true quantile, at most 0.1 ms above it); the maximum if it is in the overflow
  // bucket; 0 when empty.
  [[nodiscard]] std::int64_t quantile_ns(double q) const {
    if (count_ == 0) return 0;
    // ceil(q·n), with a margin so that 0.99 · 200 (198.00000000000003 in binary) stays 198.
    auto rank = static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(count_) - 1e-9));
    rank = std::clamp<std::uint64_t>(rank, 1, count_);
    std::uint64_t seen = 0;
    for (std::size_t b = 0; b < kBuckets; ++b) {
      seen += buckets_[b];
      if (seen >= rank) return std::min(max_ns_, static_cast<std::int64_t>(b + 1) * kBucketNs);
    }
    return max_ns_;
  }

  [[nodiscard]] std::uint64_t count() const { return count_; }
  [[nodiscard]] std::uint64_t negative() const { return negative_; }
  [[nodiscard]] std::uint64_t overflow() const { return overflow_; }
  [[nodiscard]] std::int64_t max_ns() const { return max_ns_; }
  [[nodiscard]] double mean_ns() const { return count_ ? static_cast<double>(sum_ns_) / static_cast<double>(count_) : 0.0; }
  [[nodiscard]] std::uint32_t bucket(std::size_t b) const { return buckets_[b]; }

  // CSV for the session folder: a header comment, `quantile,ms` lines, then the non-empty buckets as
  // `lower_ms,upper_ms,count` (the overflow bucket's upper edge is the maximum).
  [[nodiscard]] std::string csv(const std::string& what) const {
    std::string o = "# " + what + " latency (ms): fixed 0.1 ms buckets, groundstation/station/latency_histogram.hpp\n";
    auto ms = [](std::int64_t ns) {
      char b[32];
      std::snprintf(b, sizeof b, "%.1f", static_cast<double>(ns) * 1e-6);
      return std::string{b};
    };
    o += "count," + std::to_string(count_) + "\nnegative," + std::to_string(negative_) + "\np50," + ms(quantile_ns(0.5)) +
         "\np90," + ms(quantile_ns(0.9)) + "\np99," + ms(quantile_ns(0.99)) + "\nmax," + ms(max_ns_) + "\n";
    o += "lower_ms,upper_ms,count\n";
    for (std::size_t b = 0; b < kBuckets; ++b) {
      if (buckets_[b] == 0) continue;
      o += ms(static_cast<std::int64_t>(b) * kBucketNs) + "," + ms(static_cast<std::int64_t>(b + 1) * kBucketNs) + "," +
           std::to_string(buckets_[b]) + "\n";
    }
    if (overflow_ > 0) o += ms(static_cast<std::int64_t>(kBuckets) * kBucketNs) + "," + ms(max_ns_) + "," + std::to_string(overflow_) + "\n";
    return o;
  }

 private:
  std::array<std::uint32_t, kBuckets> buckets_{};
  std::uint64_t count_ = 0;
  std::uint64_t negative_ = 0;
  std::uint64_t overflow_ = 0;
  std::int64_t max_ns_ = 0;
  std::int64_t sum_ns_ = 0;
};

}  // namespace teamscan::station
