// The one wire -> data-set point-flag mapping (common/point_flags.hpp): every wire flag, alone and
// together, unknown bits, and the data-set flags it can and cannot produce.
#include "common/point_flags.hpp"

#include <gtest/gtest.h>

namespace teamscan {
namespace {

TEST(PointFlags, NoFlagsMapToNoFlags) { EXPECT_EQ(dataset_flags_from_wire(0), 0); }

TEST(PointFlags, EveryWireFlagAlone) {
  EXPECT_EQ(dataset_flags_from_wire(kPointDirectionFiltered), point_flags::kDirectionFiltered);
  EXPECT_EQ(dataset_flags_from_wire(kPointInvalid), point_flags::kInvalid);
  EXPECT_EQ(dataset_flags_from_wire(kPointDazzled), point_flags::kDazzled);
  EXPECT_EQ(dataset_flags_from_wire(kPointOutOfRange), point_flags::kOutOfRange);
  EXPECT_EQ(dataset_flags_from_wire(kPointTeamStale), point_flags::kTeamStale);
  // No 3-D position, like an invalid beam.
  EXPECT_EQ(dataset_flags_from_wire(kPointNoPose), point_flags::kInvalid);
  // A ground-station decision: whoever reads the data set recomputes it.
  EXPECT_EQ(dataset_flags_from_wire(kPointPositionFiltered), 0);
}

TEST(PointFlags, TheTableHasOneRowPerWireBit) {
  // The wire flags are the bits 0..6 (idl/teamscan.idl POINT_*); each appears exactly once.
  std::uint16_t seen = 0;
  for (const PointFlagPair& p : kPointFlagPairs) {
    ASSERT_EQ(p.wire & (p.wire - 1), 0) << "one bit per row: " << p.wire;
    EXPECT_EQ(seen & p.wire, 0) << "wire flag listed twice: " << p.wire;
    seen = static_cast<std::uint16_t>(seen | p.wire);
  }
  EXPECT_EQ(seen, 0x7F);
}

TEST(PointFlags, WireFlagsCombine) {
  const std::uint16_t all = 0x7F;
  EXPECT_EQ(dataset_flags_from_wire(all), point_flags::kDirectionFiltered | point_flags::kInvalid |
                                              point_flags::kDazzled | point_flags::kOutOfRange |
                                              point_flags::kTeamStale);
  EXPECT_EQ(dataset_flags_from_wire(kPointDazzled | kPointInvalid), point_flags::kDazzled | point_flags::kInvalid);
}

TEST(PointFlags, UnknownWireBitsAreDropped) {
  EXPECT_EQ(dataset_flags_from_wire(0xFF80), 0);
  EXPECT_EQ(dataset_flags_from_wire(0xFF80 | kPointDazzled), point_flags::kDazzled);
}

TEST(PointFlags, LmsFieldBitsHaveNoWireFlag) {
  // kFieldA/kFieldB come from captured LMS telegrams only; no wire flag produces them.
  for (unsigned w = 0; w < 0x80; ++w) {
    const std::uint16_t f = dataset_flags_from_wire(static_cast<std::uint16_t>(w));
    EXPECT_EQ(f & (point_flags::kFieldA | point_flags::kFieldB), 0) << w;
  }
}

TEST(PointFlags, UnplacedMeansNoTrustworthyPosition) {
  EXPECT_EQ(kPointUnplaced, kPointInvalid | kPointDazzled | kPointNoPose);
}

}  // namespace
}  // namespace teamscan
