// Real data: the full Intel Research Lab CARMEN log (tests/data/real/intel.clf.xz) read from its xz
// file and imported: every scan with its exact stamp in file order, the ODOM lines as odometry.
#include <gtest/gtest.h>

#include <cstdint>
#include <set>
#include <string>

#include "common/dataset/carmen.hpp"
#include "common/dataset/log_text.hpp"
#include "tests/support/real_data.hpp"

namespace teamscan {
namespace {

TEST(CarmenReal, IntelLogKeepsEveryStampInFileOrder) {
  const Result<std::string> text = read_log_text(test::real_data_path("intel.clf.xz"));
  ASSERT_TRUE(text) << text.error().what;
  const CarmenLog log = parse_carmen(text.value());
  // SOURCES.md: 13 631 FLASER scans, 26 915 ODOM lines, one comment line.
  EXPECT_EQ(log.lasers.size(), 13631u);
  EXPECT_EQ(log.odom.size(), 26915u);
  EXPECT_EQ(log.malformed, 0u) << log.first_error;
  const Result<Dataset> d = carmen_to_dataset(log, CarmenImportOptions{});
  ASSERT_TRUE(d) << d.error().what;
  ASSERT_EQ(d->scans.size(), 13631u);
  EXPECT_EQ(d->odom.size(), 26915u);
  std::size_t steps_back = 0;
  for (std::size_t i = 0; i < d->scans.size(); ++i) {
    EXPECT_EQ(d->scans[i].source_stamp_us, log.lasers[i].stamp_us);
    if (i == 0) continue;
    EXPECT_GT(d->scans[i].stamp_ns, d->scans[i - 1].stamp_ns) << i;
    steps_back += d->scans[i].source_stamp_us < d->scans[i - 1].source_stamp_us ? 1 : 0;
  }
  EXPECT_EQ(steps_back, 631u);  // SOURCES.md
  EXPECT_EQ(d->scans.front().source_stamp_us, 976052857337530);  // the first FLASER line's stamp
  EXPECT_NEAR(d->duration_s, 2691.0, 1.0);
  // Every relation names a scan by its exact stamp.
  const Result<std::string> relations = read_log_text(test::real_data_path("intel.relations"));
  ASSERT_TRUE(relations);
  std::set<std::int64_t> stamps;
  for (const ScanRecord& s : d->scans) stamps.insert(s.source_stamp_us);
  std::size_t named = 0, found = 0;
  std::size_t pos = 0;
  const std::string& r = relations.value();
  while (pos < r.size()) {
    std::size_t nl = r.find('\n', pos);
    if (nl == std::string::npos) nl = r.size();
    const std::string line = r.substr(pos, nl - pos);
    pos = nl + 1;
    const std::size_t sp1 = line.find(' ');
    const std::size_t sp2 = line.find(' ', sp1 + 1);
    if (sp1 == std::string::npos || sp2 == std::string::npos) continue;
    std::int64_t t1 = 0, t2 = 0;
    ASSERT_TRUE(parse_carmen_stamp_us(line.substr(0, sp1), t1));
    ASSERT_TRUE(parse_carmen_stamp_us(line.substr(sp1 + 1, sp2 - sp1 - 1), t2));
    named += 2;
    found += stamps.count(t1) + stamps.count(t2);
  }
  EXPECT_EQ(named, 2u * 2984u);
  EXPECT_EQ(found, named);
}

}  // namespace
}  // namespace teamscan
