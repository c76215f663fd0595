// StoredSeqs (groundstation/station/stored_seqs.hpp): each seq stored once, the contiguous run from the
// first one that the station confirms, holes filled in any order (a back-fill), seqs older than the first.
#include "groundstation/station/stored_seqs.hpp"

#include <gtest/gtest.h>

namespace teamscan::station {
namespace {

TEST(StoredSeqs, EmptyThenOne) {
  StoredSeqs q;
  EXPECT_FALSE(q.any());
  EXPECT_EQ(q.contiguous(), 0u);
  EXPECT_TRUE(q.insert(500));
  EXPECT_TRUE(q.any());
  EXPECT_EQ(q.first(), 500u);
  EXPECT_EQ(q.contiguous(), 500u);
  EXPECT_FALSE(q.insert(500));
  EXPECT_EQ(q.count(), 1u);
}

TEST(StoredSeqs, AShadowAndItsBackfill) {
  StoredSeqs q;
  for (std::uint32_t s = 1; s <= 100; ++s) ASSERT_TRUE(q.insert(s));
  // The shadow: 101..400 never arrive live; 401.. do.
  for (std::uint32_t s = 401; s <= 450; ++s) ASSERT_TRUE(q.insert(s));
  EXPECT_EQ(q.contiguous(), 100u);
  EXPECT_EQ(q.holes(), 300u);
  // A history replay of 440..450: duplicates.
  for (std::uint32_t s = 440; s <= 450; ++s) EXPECT_FALSE(q.insert(s));
  // The back-fill, oldest first: the run joins the stored one above it when the hole closes.
  for (std::uint32_t s = 101; s <= 399; ++s) ASSERT_TRUE(q.insert(s));
  EXPECT_EQ(q.contiguous(), 399u);
  ASSERT_TRUE(q.insert(400));
  EXPECT_EQ(q.contiguous(), 450u);
  EXPECT_EQ(q.holes(), 0u);
  EXPECT_EQ(q.count(), 450u);
  for (std::uint32_t s : {1u, 250u, 450u}) EXPECT_FALSE(q.insert(s));
}

TEST(StoredSeqs, SeqsOlderThanTheFirstOne) {
  StoredSeqs q;
  ASSERT_TRUE(q.insert(1000));
  ASSERT_TRUE(q.insert(998));  // not adjacent: below
  EXPECT_EQ(q.first(), 1000u);
  EXPECT_EQ(q.holes(), 1u);
  ASSERT_TRUE(q.insert(999));  // joins, and 998 with it
  EXPECT_EQ(q.first(), 998u);
  EXPECT_EQ(q.contiguous(), 1000u);
  EXPECT_FALSE(q.insert(998));
  EXPECT_EQ(q.count(), 3u);
  q.reset();
  EXPECT_FALSE(q.any());
  EXPECT_TRUE(q.insert(1));
}

}  // namespace
}  // namespace teamscan::station
