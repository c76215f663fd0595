// Open-addressing hash map from a packed 63-bit integer key to a small value: the storage of the
// sparse voxel map (PAPER_NOTES eq. 2: store only occupied voxels). Linear probing, power-of-two
// capacity, load factor ≤ 0.7; memory is exactly two flat arrays (four while it grows), so bytes per
// entry are measurable.
//
// Growth is incremental: when the table is full it allocates one twice the size and moves a few old
// slots into it on every get_or_insert(), looking keys up in both until the old one is empty. A map of
// millions of voxels on the station's receive loop therefore never stops a scan for a whole-table
// rehash, whose cost grows with the table. The new table comes zeroed from
// calloc (a stored key is the key's complement, 0 is an empty slot), so its pages are faulted in
// piece by piece as slots are written, not all at once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>

namespace teamscan {

template <class V>
class FlatKeyMap {
  static_assert(std::is_trivially_copyable_v<V> && std::is_trivially_destructible_v<V>,
                "values live in malloc'd arrays and are moved by copying bytes");

 public:
  // Keys use at most 63 bits (three 21-bit fields), so all-ones never is a key.
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  // Old slots moved per get_or_insert() while the map grows. Growth starts at 0.7 of the old capacity
  // C and the next one at 0.7 of 2C: 0.7·C calls away, while moving C slots takes C / 4 calls.
  static constexpr std::size_t kMovesPerCall = 4;

  FlatKeyMap() = default;
  FlatKeyMap(const FlatKeyMap& o) { copy_from(o); }
  FlatKeyMap& operator=(const FlatKeyMap& o) {
    if (this != &o) copy_from(o);
    return *this;
  }
  FlatKeyMap(FlatKeyMap&& o) noexcept
      : table_{std::move(o.table_)},
        old_{std::move(o.old_)},
        moved_{std::exchange(o.moved_, 0)},
        size_{std::exchange(o.size_, 0)} {}
  FlatKeyMap& operator=(FlatKeyMap&& o) noexcept {
    table_ = std::move(o.table_);
    old_ = std::move(o.old_);
    moved_ = std::exchange(o.moved_, 0);
    size_ = std::exchange(o.size_, 0);
    return *this;
  }

  [[nodiscard]] std::size_t size() const { return size_; }
  [[nodiscard]] std::size_t capacity() const { return table_.capacity; }
  [[nodiscard]] bool growing() const { return old_.capacity != 0; }
  [[nodiscard]] std::size_t memory_bytes() const { return table_.bytes() + old_.bytes(); }

  void clear() {
    table_ = Table{};
    old_ = Table{};
    size_ = 0;
    moved_ = 0;
  }

  // Room for `n` entries without growing (any growth under way is finished first). For start-up: it
  // rehashes at once.
  void reserve(std::size_t n) {
    finish_growth();
    std::size_t cap = 16;
    while (cap * 7 < n * 10) cap *= 2;
    if (cap <= table_.capacity) return;
    start_growth(cap);
    finish_growth();
  }

  [[nodiscard]] const V* find(std::uint64_t key) const {
    if (const V* v = table_.find(stored(key))) return v;
    return old_.capacity != 0 ? old_.find(stored(key)) : nullptr;
  }

  [[nodiscard]] V* find(std::uint64_t key) {
    return const_cast<V*>(static_cast<const FlatKeyMap&>(*this).find(key));
  }

  // Empties the map but keeps its capacity (a map refilled to about the same size, e.g. per match,
  // does not grow again from 16 entries through every doubling).
  void clear_keep_capacity() {
    old_ = Table{};
    moved_ = 0;
    if (table_.capacity != 0) std::memset(table_.keys.get(), 0, table_.capacity * sizeof(std::uint64_t));
    size_ = 0;
  }

  // Starts loading the slot where `key` is (or would be inserted) into the cache: a caller with a batch
  // of keys prefetches them all, then looks them up, and the misses overlap.
  void prefetch(std::uint64_t key) const {
    table_.prefetch(key);
    if (old_.capacity != 0) old_.prefetch(key);
  }

  // The value for `key`, inserted as `initial` if absent; `*inserted` tells which. The reference is
  // valid until the next get_or_insert().
  V& get_or_insert(std::uint64_t key, const V& initial, bool* inserted = nullptr) {
    if (old_.capacity != 0) move_some(kMovesPerCall);
    const std::uint64_t s = stored(key);
    std::size_t i = 0;
    if (table_.capacity != 0) {
      const std::size_t mask = table_.capacity - 1;
      for (i = hash(key) & mask; table_.keys[i] != 0; i = (i + 1) & mask) {
        if (table_.keys[i] == s) {
          if (inserted) *inserted = false;
          return table_.values[i];
        }
      }
    }
    if (old_.capacity != 0) {
      if (V* v = old_.find(s)) {  // not moved yet (a moved key is in the new table): moved in its turn
        if (inserted) *inserted = false;
        return *v;
      }
    }
    if ((size_ + 1) * 10 > table_.capacity * 7) {
      finish_growth();  // never under way here (see kMovesPerCall); kept for safety
      start_growth(table_.capacity == 0 ? 16 : table_.capacity * 2);
      move_some(kMovesPerCall);
      const std::size_t mask = table_.capacity - 1;
      for (i = hash(key) & mask; table_.keys[i] != 0; i = (i + 1) & mask) {
      }
    }
    table_.keys[i] = s;
    table_.values[i] = initial;
    ++size_;
    if (inserted) *inserted = true;
    return table_.values[i];
  }

  // Every entry: the new table's slots in order, then the old table's not yet moved. The order depends
  // only on the sequence of calls that built the map.
  template <class F>
  void for_each(F&& f) const {
    for (std::size_t i = 0; i < table_.capacity; ++i)
      if (table_.keys[i] != 0) f(~table_.keys[i], table_.values[i]);
    for (std::size_t i = moved_; i < old_.capacity; ++i)
      if (old_.keys[i] != 0) f(~old_.keys[i], old_.values[i]);
  }

 private:
  struct Free {
    void operator()(void* p) const { std::free(p); }
  };
  // One open-addressing table: stored keys (0: empty) and values, `capacity` a power of two or 0.
  struct Table {
    std::unique_ptr<std::uint64_t[], Free> keys;
    std::unique_ptr<V[], Free> values;
    std::size_t capacity = 0;

    Table() = default;
    Table(Table&& o) noexcept
        : keys{std::move(o.keys)}, values{std::move(o.values)}, capacity{std::exchange(o.capacity, 0)} {}
    Table& operator=(Table&& o) noexcept {
      keys = std::move(o.keys);
      values = std::move(o.values);
      capacity = std::exchange(o.capacity, 0);
      return *this;
    }

    [[nodiscard]] std::size_t bytes() const { return capacity * (sizeof(std::uint64_t) + sizeof(V)); }
    [[nodiscard]] const V* find(std::uint64_t s) const {
      if (capacity == 0) return nullptr;
      const std::size_t mask = capacity - 1;
      for (std::size_t i = hash(~s) & mask;; i = (i + 1) & mask) {
        if (keys[i] == s) return &values[i];
        if (keys[i] == 0) return nullptr;
      }
    }
    [[nodiscard]] V* find(std::uint64_t s) { return const_cast<V*>(static_cast<const Table&>(*this).find(s)); }
    void prefetch(std::uint64_t key) const {
      if (capacity == 0) return;
      const std::size_t i = hash(key) & (capacity - 1);
      __builtin_prefetch(&keys[i]);
      __builtin_prefetch(&values[i]);
    }
    // Zeroed keys (calloc: fresh pages are not touched until written), uninitialised values (a value
    // is written when its key is).
    static Table allocate(std::size_t capacity) {
      Table t;
      t.keys.reset(static_cast<std::uint64_t*>(std::calloc(capacity, sizeof(std::uint64_t))));
      t.values.reset(static_cast<V*>(std::malloc(capacity * sizeof(V))));
      if (!t.keys || !t.values) throw std::bad_alloc{};
      t.capacity = capacity;
      return t;
    }
  };

  static std::uint64_t stored(std::uint64_t key) { return ~key; }

  // splitmix64 finaliser: packed voxel keys are highly regular, the low bits need mixing.
  static std::size_t hash(std::uint64_t k) {
    k ^= k >> 30;
    k *= 0xbf58476d1ce4e5b9ULL;
    k ^= k >> 27;
    k *= 0x94d049bb133111ebULL;
    k ^= k >> 31;
    return static_cast<std::size_t>(k);
  }

  void start_growth(std::size_t new_capacity) {
    old_ = std::move(table_);
    table_ = Table::allocate(new_capacity);
    moved_ = 0;
  }

  // Moves the next `n` old slots into the new table; frees the old one after its last slot. A moved
  // slot's key stays in the old table (its probe chains stay intact for the keys not moved yet); it is
  // never found there because the new table is searched first.
  void move_some(std::size_t n) {
    const std::size_t end = moved_ + n < old_.capacity ? moved_ + n : old_.capacity;
    const std::size_t mask = table_.capacity - 1;
    for (; moved_ < end; ++moved_) {
      const std::uint64_t s = old_.keys[moved_];
      if (s == 0) continue;
      std::size_t i = hash(~s) & mask;
      while (table_.keys[i] != 0) i = (i + 1) & mask;
      table_.keys[i] = s;
      table_.values[i] = old_.values[moved_];
    }
    if (moved_ == old_.capacity) {
      old_ = Table{};
      moved_ = 0;
    }
  }

  void finish_growth() {
    if (old_.capacity != 0) move_some(old_.capacity);
  }

  void copy_from(const FlatKeyMap& o) {
    clear();
    size_ = o.size_;
    moved_ = o.moved_;
    for (auto [to, from] : {std::pair{&table_, &o.table_}, std::pair{&old_, &o.old_}}) {
      if (from->capacity == 0) continue;
      *to = Table::allocate(from->capacity);
      std::memcpy(to->keys.get(), from->keys.get(), from->capacity * sizeof(std::uint64_t));
      std::memcpy(static_cast<void*>(to->values.get()), from->values.get(), from->capacity * sizeof(V));
    }
  }

  Table table_;       // where new keys go
  Table old_;         // while growing: the previous table, slots [moved_, capacity) not moved yet
  std::size_t moved_ = 0;
  std::size_t size_ = 0;
};

}  // namespace teamscan
