// Open-addressing hash map from a packed 63-bit integer key to a small value: the storage of the
// sparse voxel map (PAPER_NOTES eq. 2: store only occupied voxels). Linear probing, power-of-two
// capacity, load factor ≤ 0.7; memory is exactly two flat arrays, so bytes per entry are measurable.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace teamscan::mapping {

template <class V>
class FlatKeyMap {
 public:
  // Keys use at most 63 bits (three 21-bit fields), so all-ones never is a key.
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};

  [[nodiscard]] std::size_t size() const { return size_; }
  [[nodiscard]] std::size_t capacity() const { return keys_.size(); }
  [[nodiscard]] std::size_t memory_bytes() const {
    return keys_.capacity() * sizeof(std::uint64_t) + values_.capacity() * sizeof(V);
  }

  void clear() {
    keys_.clear();
    values_.clear();
    size_ = 0;
  }

  // Room for `n` entries without rehashing.
  void reserve(std::size_t n) {
    std::size_t cap = 16;
    while (cap * 7 < n * 10) cap *= 2;
    if (cap > keys_.size()) rehash(cap);
  }

  [[nodiscard]] const V* find(std::uint64_t key) const {
    if (keys_.empty()) return nullptr;
    const std::size_t mask = keys_.size() - 1;
    for (std::size_t i = hash(key) & mask;; i = (i + 1) & mask) {
      if (keys_[i] == key) return &values_[i];
      if (keys_[i] == kEmpty) return nullptr;
    }
  }

  [[nodiscard]] V* find(std::uint64_t key) {
    return const_cast<V*>(static_cast<const FlatKeyMap&>(*this).find(key));
  }

  // Empties the map but keeps its capacity (a map refilled to about the same size, e.g. per match,
  // does not grow again from 16 entries through every doubling).
  void clear_keep_capacity() {
    std::fill(keys_.begin(), keys_.end(), kEmpty);
    size_ = 0;
  }

  // Starts loading the slot where `key` is (or would be inserted) into the cache: a caller with a batch
  // of keys prefetches them all, then looks them up, and the misses overlap.
  void prefetch(std::uint64_t key) const {
    if (keys_.empty()) return;
    const std::size_t i = hash(key) & (keys_.size() - 1);
    __builtin_prefetch(&keys_[i]);
    __builtin_prefetch(&values_[i]);
  }

  // The value for `key`, inserted as `initial` if absent; `*inserted` tells which.
  V& get_or_insert(std::uint64_t key, const V& initial, bool* inserted = nullptr) {
    if ((size_ + 1) * 10 > keys_.size() * 7) rehash(keys_.empty() ? 16 : keys_.size() * 2);
    const std::size_t mask = keys_.size() - 1;
    std::size_t i = hash(key) & mask;
    for (; keys_[i] != kEmpty; i = (i + 1) & mask) {
      if (keys_[i] == key) {
        if (inserted) *inserted = false;
        return values_[i];
      }
    }
    keys_[i] = key;
    values_[i] = initial;
    ++size_;
    if (inserted) *inserted = true;
    return values_[i];
  }

  template <class F>
  void for_each(F&& f) const {
    for (std::size_t i = 0; i < keys_.size(); ++i)
      if (keys_[i] != kEmpty) f(keys_[i], values_[i]);
  }

 private:
  // splitmix64 finaliser: packed voxel keys are highly regular, the low bits need mixing.
  static std::size_t hash(std::uint64_t k) {
    k ^= k >> 30;
    k *= 0xbf58476d1ce4e5b9ULL;
    k ^= k >> 27;
    k *= 0x94d049bb133111ebULL;
    k ^= k >> 31;
    return static_cast<std::size_t>(k);
  }

  void rehash(std::size_t new_capacity) {
    std::vector<std::uint64_t> old_keys(new_capacity, kEmpty);
    std::vector<V> old_values(new_capacity);
    old_keys.swap(keys_);
    old_values.swap(values_);
    const std::size_t mask = new_capacity - 1;
    for (std::size_t j = 0; j < old_keys.size(); ++j) {
      if (old_keys[j] == kEmpty) continue;
      std::size_t i = hash(old_keys[j]) & mask;
      while (keys_[i] != kEmpty) i = (i + 1) & mask;
      keys_[i] = old_keys[j];
      values_[i] = old_values[j];
    }
  }

  std::vector<std::uint64_t> keys_;
  std::vector<V> values_;
  std::size_t size_ = 0;
};

}  // namespace teamscan::mapping
