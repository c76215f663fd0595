// FlatKeyMap: the voxel tables' hash map, checked against std::unordered_map through many incremental
// growths (lookups, inserts, iteration, copies and clears while a growth is under way).
#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <random>
#include <unordered_map>
#include <utility>
#include <vector>

#include "common/flat_key_map.hpp"

namespace teamscan {
namespace {

using Map = FlatKeyMap<std::uint32_t>;

std::map<std::uint64_t, std::uint32_t> entries(const Map& m) {
  std::map<std::uint64_t, std::uint32_t> out;
  m.for_each([&](std::uint64_t k, std::uint32_t v) { EXPECT_TRUE(out.emplace(k, v).second) << "key twice: " << k; });
  return out;
}

std::map<std::uint64_t, std::uint32_t> entries(const std::unordered_map<std::uint64_t, std::uint32_t>& m) {
  return {m.begin(), m.end()};
}

// Keys as the voxel maps pack them (three 21-bit fields: regular, clustered) and arbitrary 63-bit ones.
std::uint64_t random_key(std::mt19937_64& rng, bool packed) {
  if (!packed) return rng() >> 1;
  std::uniform_int_distribution<std::uint64_t> axis(1'000'000, 1'000'100);
  return (axis(rng) << 42) | (axis(rng) << 21) | axis(rng);
}

TEST(FlatKeyMap, AgreesWithUnorderedMapThroughIncrementalGrowth) {
  for (const bool packed : {true, false}) {
    std::mt19937_64 rng(packed ? 7 : 8);
    Map m;
    std::unordered_map<std::uint64_t, std::uint32_t> truth;
    std::vector<std::uint64_t> known;
    int calls_while_growing = 0, growths = 0;
    bool was_growing = false;
    for (int op = 0; op < 300'000; ++op) {
      // Half the calls hit a key already in, half insert a new one (or hit by chance).
      const bool reuse = !known.empty() && (rng() & 1);
      const std::uint64_t key = reuse ? known[rng() % known.size()] : random_key(rng, packed);
      bool inserted = false;
      std::uint32_t& v = m.get_or_insert(key, 5u, &inserted);
      const auto [it, fresh] = truth.emplace(key, 5u);
      ASSERT_EQ(inserted, fresh) << "op " << op;
      if (fresh) known.push_back(key);
      ASSERT_EQ(v, it->second) << "op " << op;
      v += static_cast<std::uint32_t>(op);
      it->second += static_cast<std::uint32_t>(op);
      ASSERT_EQ(m.size(), truth.size());
      if (m.growing()) {
        ++calls_while_growing;
        growths += was_growing ? 0 : 1;
      }
      was_growing = m.growing();
      // Lookups of present and absent keys, whatever the stage of a growth.
      if (op % 7 == 0) {
        const std::uint64_t probe = known[rng() % known.size()];
        const std::uint32_t* f = m.find(probe);
        ASSERT_NE(f, nullptr);
        ASSERT_EQ(*f, truth.at(probe));
        const std::uint64_t absent = random_key(rng, packed);
        ASSERT_EQ(m.find(absent) == nullptr, truth.count(absent) == 0);
      }
      if (op % 20'011 == 0) {
        ASSERT_EQ(entries(m), entries(truth)) << "op " << op << (m.growing() ? " growing" : "");
      }
    }
    EXPECT_EQ(entries(m), entries(truth));
    EXPECT_GE(growths, 10) << "the run should cross many growths";
    EXPECT_GT(calls_while_growing, 0);
  }
}

TEST(FlatKeyMap, AGrowthMovesAFewSlotsPerCallAndEndsBeforeTheNextIsDue) {
  Map m;
  std::uint64_t next = 0;
  while (!m.growing()) m.get_or_insert(next++, 0u);
  const std::size_t old_capacity = m.capacity() / 2;
  // Every entry is still found while the old table is being emptied.
  for (std::uint64_t k = 0; k < next; ++k) ASSERT_NE(m.find(k), nullptr) << k;
  std::size_t calls = 1;
  while (m.growing()) {
    m.get_or_insert(next++, 0u);
    ++calls;
  }
  // One call moves kMovesPerCall old slots: the growth takes capacity / kMovesPerCall calls, well within
  // the 0.7 × capacity inserts before the next one is due.
  EXPECT_EQ(calls, (old_capacity + Map::kMovesPerCall - 1) / Map::kMovesPerCall);
  EXPECT_LT(m.size() * 10, m.capacity() * 7);
  for (std::uint64_t k = 0; k < next; ++k) ASSERT_NE(m.find(k), nullptr) << k;
  EXPECT_EQ(m.memory_bytes(), m.capacity() * (sizeof(std::uint64_t) + sizeof(std::uint32_t)));
}

TEST(FlatKeyMap, CopiesMovesClearsAndReservesWhileGrowing) {
  Map m;
  std::uint64_t next = 0;
  while (!m.growing() || m.capacity() < 4096) {
    m.get_or_insert(next * 977, static_cast<std::uint32_t>(next));
    ++next;
  }
  ASSERT_TRUE(m.growing());
  const auto before = entries(m);
  EXPECT_EQ(before.size(), next);

  Map copy = m;  // a copy taken mid-growth goes on growing on its own
  EXPECT_TRUE(copy.growing());
  EXPECT_EQ(entries(copy), before);
  copy.get_or_insert(1, 1u);
  EXPECT_EQ(copy.size(), m.size() + 1);
  EXPECT_EQ(entries(m), before);

  Map moved = std::move(copy);
  EXPECT_EQ(moved.size(), before.size() + 1);
  EXPECT_EQ(copy.size(), 0u);  // NOLINT(bugprone-use-after-move): a moved-from map is empty and usable
  copy.get_or_insert(3, 4u);
  EXPECT_EQ(*copy.find(3), 4u);

  Map reserved = m;
  reserved.reserve(100'000);  // finishes the growth, then rehashes at once
  EXPECT_FALSE(reserved.growing());
  EXPECT_EQ(entries(reserved), before);
  const std::size_t capacity = reserved.capacity();
  for (std::uint64_t k = 0; k < 60'000; ++k) reserved.get_or_insert(k * 977 + 1, 0u);
  EXPECT_EQ(reserved.capacity(), capacity);
  EXPECT_FALSE(reserved.growing());

  m.clear_keep_capacity();
  EXPECT_FALSE(m.growing());
  EXPECT_EQ(m.size(), 0u);
  EXPECT_TRUE(entries(m).empty());
  EXPECT_EQ(m.find(977), nullptr);
  m.get_or_insert(977, 9u);
  EXPECT_EQ(*m.find(977), 9u);
}

TEST(FlatKeyMap, IterationOrderDependsOnlyOnTheCallsThatBuiltTheMap) {
  auto build = [](int n) {
    Map m;
    std::mt19937_64 rng(3);
    for (int i = 0; i < n; ++i) m.get_or_insert(rng() >> 1, static_cast<std::uint32_t>(i));
    std::vector<std::pair<std::uint64_t, std::uint32_t>> order;
    m.for_each([&](std::uint64_t k, std::uint32_t v) { order.emplace_back(k, v); });
    return order;
  };
  for (const int n : {0, 11, 12, 5'000, 12'000}) EXPECT_EQ(build(n), build(n)) << n;
}

}  // namespace
}  // namespace teamscan
