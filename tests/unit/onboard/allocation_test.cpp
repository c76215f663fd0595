// Firmware discipline (STYLE.md 5): after start-up the onboard data path allocates nothing. This binary
// replaces malloc & co. (glibc's __libc_* underneath) and counts the calls made while armed, then
// pushes 10 000 scans through decode (when drivers/lms200 is built) -> 3-D points -> direction filter ->
// scan message, with odometry at 10 Hz and team updates in between (each with a new odometry correction
// of this robot: applied to the projection, or refused as an absurd step).
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>

#include "onboard/core/pipeline.hpp"
#include "tests/support/onboard_config_fixture.hpp"
#include "drivers/lms200/codec.hpp"
#include "drivers/lms200/scan.hpp"

extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
}

namespace {
std::atomic<bool> g_armed{false};
std::atomic<long> g_allocations{0};
void count() {
  if (g_armed.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace

extern "C" {
void* malloc(std::size_t n) { count(); return __libc_malloc(n); }
void* calloc(std::size_t a, std::size_t b) { count(); return __libc_calloc(a, b); }
void* realloc(void* p, std::size_t n) { count(); return __libc_realloc(p, n); }
void* aligned_alloc(std::size_t al, std::size_t n) { count(); return __libc_memalign(al, n); }
void* memalign(std::size_t al, std::size_t n) { count(); return __libc_memalign(al, n); }
int posix_memalign(void** out, std::size_t al, std::size_t n) {
  count();
  *out = __libc_memalign(al, n);
  return *out != nullptr ? 0 : 12;  // ENOMEM
}
}

namespace teamscan::onboard {
namespace {

struct Armed {
  Armed() { g_allocations = 0; g_armed = true; }
  ~Armed() { g_armed = false; }
  long count() const { return g_allocations.load(); }
};

TEST(Allocation, TheCounterSeesAllocations) {
  long n = 0;
  {
    Armed armed;
    void* p = std::malloc(16);
    std::string* s = new std::string(100, 'x');  // operator new -> malloc
    n = armed.count();
    delete s;
    std::free(p);
  }
  EXPECT_GE(n, 2);
}

TEST(Allocation, TenThousandScansAllocateNothing) {
  std::string msg;
  auto config = parse_onboard_config(test::pipeline_test_config_toml(1, true), msg);
  ASSERT_TRUE(config.ok()) << msg;
  auto pipeline = OnboardPipeline::create(config.value());
  ASSERT_TRUE(pipeline.ok());
  std::array<std::uint32_t, kMaxBeams> ranges{};
  for (std::size_t i = 0; i < 361; ++i) ranges[i] = 500 + static_cast<std::uint32_t>(i * 17 % 7000);
  // One 361-value telegram as the scanner sends it (mm, measuring mode 0), decoded on every scan.
  std::array<std::uint16_t, 361> words{};
  for (std::size_t i = 0; i < 361; ++i)
    words[i] = lms200::encode_value_word(ranges[i], 0, i % 50 == 7 ? lms200::BeamInvalid::dazzled : lms200::BeamInvalid::none,
                                         lms200::Unit::mm, lms200::MeasuringMode::m8_fields_dazzle);
  lms200::CountWord cw;
  cw.values = 361;
  cw.unit_bits = static_cast<std::uint8_t>(lms200::Unit::mm);
  std::array<std::uint8_t, kMaxLmsTelegram> telegram{};
  const std::size_t telegram_len = lms200::build_scan_reply(telegram, cw.encode(), words, std::nullopt);
  ASSERT_GT(telegram_len, 722u);
  lms200::ScanTelegram decoded;

  TeamSnapshot team;
  team.count = 9;
  // Member 8 is this robot (id 1): its odometry correction changes with every team state (a new one
  // taken into use, every fifth an absurd step that is refused), so the correction path runs too.
  team.members[8].robot_id = 1;
  team.members[8].x_mm = 500;
  for (std::uint32_t m = 0; m < 8; ++m) {
    team.members[m].robot_id = m + 2;
    team.members[m].x_mm = 2000 + static_cast<std::int32_t>(m) * 700;
    team.members[m].y_mm = static_cast<std::int32_t>(m % 3) * 400 - 400;
    team.members[m].length_mm = 508;
    team.members[m].width_mm = 497;
    team.members[m].height_mm = 500;
  }

  // Malformed team states (a publisher at 50 Hz) go through the check between the good ones:
  // refusing them allocates nothing either.
  TeamSnapshot malformed = team;
  malformed.members[3].cov_xx = std::numeric_limits<float>::quiet_NaN();
  TeamSnapshot too_many = team;
  too_many.count = 200;

  const Time t0 = Time::from_ns(1'700'000'000'000'000'000);
  OnboardPose pose;
  std::uint64_t filtered = 0, published = 0;
  long allocations = 0;
  {
    Armed armed;
    for (int k = 0; k < 10'000; ++k) {
      const Time stamp = t0 + Duration{static_cast<std::int64_t>(k) * 13'333'333 * 2};  // 37.5 Hz (0.5°: 2 revolutions)
      if (k % 4 == 0) (void)pipeline->on_odometry(stamp, {0.001 * k, 0.0, 0.0001 * k}, 100, 0.01, pose);
      if (k % 10 == 0) {
        for (std::uint32_t m = 0; m < 9; ++m) team.members[m].valid_ns = stamp.ns();
        const auto step = static_cast<std::uint32_t>(k / 10);
        team.members[8].correction =
            OdomCorrection{static_cast<std::int32_t>(step % 50) * 10 + (step % 5 == 4 ? 9000 : 0), -150,
                           static_cast<std::int32_t>(step % 40) * 1000, step + 1};
        pipeline->on_team(team, stamp);
      }
      if (k % 4 == 1) {
        for (std::uint32_t m = 0; m < 8; ++m) malformed.members[m].valid_ns = stamp.ns();
        (void)pipeline->on_team(k % 8 == 1 ? malformed : too_many, stamp);
      }
      if (!lms200::decode_scan(std::span<const std::uint8_t>(telegram.data(), telegram_len),
                               lms200::MeasuringMode::m8_fields_dazzle, decoded).ok())
        break;
      const ScanPoints* s = pipeline->on_scan(decoded.sweep(), stamp);
      if (s == nullptr) break;
      published += s->count;
      filtered += pipeline->last_filter_stats().filtered;
    }
    allocations = armed.count();
  }
  EXPECT_EQ(pipeline->counters().scans, 10'000u);
  EXPECT_EQ(published, 10'000u * 361u);
  EXPECT_GT(filtered, 0u);  // the filter really ran against the 8 teammates
  EXPECT_EQ(pipeline->team_checks().rejected, 2'500u);  // every malformed team state refused
  EXPECT_EQ(pipeline->team_checks().accepted, 1'000u);
  // Every fifth correction is a 9 m step from the applied one: refused; the others are taken.
  EXPECT_EQ(pipeline->counters().corrections_rejected, 200u);
  EXPECT_EQ(pipeline->counters().corrections_applied, 800u);
  EXPECT_EQ(allocations, 0);
}

}  // namespace
}  // namespace teamscan::onboard
