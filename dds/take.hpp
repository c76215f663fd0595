// The one take loop of teamscan's readers: samples taken into our own preallocated, fixed-size
// buffers (DDS_SYSTEMD.md 1.8: a take into caller-owned fixed-size samples allocates nothing),
// batch after batch until the reader is empty.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include <dds/dds.h>

namespace teamscan::dds {

// `capacity` samples of one generated type plus their sample infos; allocated once (start-up).
template <class Sample>
class TakeBuffer {
 public:
  explicit TakeBuffer(std::size_t capacity)
      : capacity_{capacity == 0 ? 1 : capacity},
        samples_{new Sample[capacity_]{}},
        infos_{new dds_sample_info_t[capacity_]{}},
        ptrs_{new void*[capacity_]} {
    for (std::size_t i = 0; i < capacity_; ++i) ptrs_[i] = &samples_[i];
  }

  [[nodiscard]] std::size_t capacity() const { return capacity_; }
  [[nodiscard]] const Sample& sample(std::size_t i) const { return samples_[i]; }
  [[nodiscard]] const dds_sample_info_t& info(std::size_t i) const { return infos_[i]; }

  // One dds_take of up to capacity() samples; the number taken (0 when empty or on error).
  [[nodiscard]] std::size_t take(dds_entity_t reader) {
    const dds_return_t n = dds_take(reader, ptrs_.get(), infos_.get(), capacity_, static_cast<std::uint32_t>(capacity_));
    return n > 0 ? static_cast<std::size_t>(n) : 0;
  }

 private:
  std::size_t capacity_;
  std::unique_ptr<Sample[]> samples_;
  std::unique_ptr<dds_sample_info_t[]> infos_;
  std::unique_ptr<void*[]> ptrs_;
};

// Takes `reader` empty, batch by batch. For each batch, `on_batch()` runs first (e.g. to read the
// receive time once per dds_take), then `on_sample(sample, info)` for every sample in it, valid or
// not (an invalid sample is a dispose or no-writers notice: info.valid_data == false).
// Returns the number of samples taken.
template <class Sample, class OnBatch, class OnSample>
std::size_t take_all(dds_entity_t reader, TakeBuffer<Sample>& buffer, OnBatch&& on_batch, OnSample&& on_sample) {
  std::size_t total = 0;
  for (;;) {
    const std::size_t n = buffer.take(reader);
    if (n == 0) break;
    on_batch();
    for (std::size_t i = 0; i < n; ++i) on_sample(buffer.sample(i), buffer.info(i));
    total += n;
  }
  return total;
}

}  // namespace teamscan::dds
