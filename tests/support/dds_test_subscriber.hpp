// A DDS reader for tests: its own participant, one topic, preallocated samples, and blocking helpers
// (wait until matched, take until N samples or a timeout). Run only with the loopback config
// (CYCLONEDDS_URI, set by ctest).
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include <dds/dds.h>

#include "common/time.hpp"

namespace teamscan::test {

template <class T>
class DdsTestSubscriber {
 public:
  // `qos` stays owned by the caller (may be null for defaults). `batch` samples are preallocated.
  DdsTestSubscriber(const dds_topic_descriptor_t* desc, const char* topic_name, const dds_qos_t* qos,
                    std::size_t batch = 64, dds_domainid_t domain = DDS_DOMAIN_DEFAULT)
      : samples_(batch), ptrs_(batch), infos_(batch) {
    participant_ = dds_create_participant(domain, nullptr, nullptr);
    if (participant_ < 0) return;
    const dds_entity_t topic = dds_create_topic(participant_, desc, topic_name, nullptr, nullptr);
    if (topic < 0) return;
    reader_ = dds_create_reader(participant_, topic, qos, nullptr);
    if (reader_ < 0) return;
    waitset_ = dds_create_waitset(participant_);
    readcond_ = dds_create_readcondition(reader_, DDS_ANY_STATE);
    (void)dds_waitset_attach(waitset_, readcond_, reader_);
    for (std::size_t i = 0; i < batch; ++i) ptrs_[i] = &samples_[i];
  }
  ~DdsTestSubscriber() {
    if (participant_ > 0) (void)dds_delete(participant_);
  }
  DdsTestSubscriber(const DdsTestSubscriber&) = delete;
  DdsTestSubscriber& operator=(const DdsTestSubscriber&) = delete;

  [[nodiscard]] bool ok() const { return participant_ > 0 && reader_ > 0 && waitset_ > 0 && readcond_ > 0; }
  [[nodiscard]] dds_entity_t reader() const { return reader_; }
  [[nodiscard]] dds_entity_t participant() const { return participant_; }

  // Waits until at least `n` writers are matched.
  bool wait_matched(std::uint32_t n, Duration timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      dds_subscription_matched_status_t st{};
      if (dds_get_subscription_matched_status(reader_, &st) == DDS_RETCODE_OK && st.current_count >= n) return true;
      dds_sleepfor(DDS_MSECS(10));
    }
    return false;
  }

  // Takes valid samples into `out` until it holds `total` or `timeout` passes. Invalid samples (dispose,
  // no writers) are counted in invalid(). Returns out.size() >= total.
  bool take_until(std::vector<T>& out, std::size_t total, Duration timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (out.size() < total) {
      take_available(out);
      if (out.size() >= total) break;
      const auto left = deadline - std::chrono::steady_clock::now();
      if (left <= Duration::zero()) break;
      dds_attach_t trig[1];
      (void)dds_waitset_wait(waitset_, trig, 1, static_cast<dds_duration_t>(std::min<Duration>(left, std::chrono::milliseconds(100)).count()));
    }
    return out.size() >= total;
  }

  // Takes whatever is available now.
  std::size_t take_available(std::vector<T>& out) {
    std::size_t got = 0;
    for (;;) {
      const int n = dds_take(reader_, ptrs_.data(), infos_.data(), samples_.size(),
                             static_cast<std::uint32_t>(samples_.size()));
      if (n <= 0) break;
      for (int i = 0; i < n; ++i) {
        if (infos_[static_cast<std::size_t>(i)].valid_data) {
          out.push_back(samples_[static_cast<std::size_t>(i)]);
          publications_.push_back(infos_[static_cast<std::size_t>(i)].publication_handle);
          ++got;
        } else {
          ++invalid_;
        }
      }
    }
    return got;
  }

  [[nodiscard]] std::uint64_t invalid() const { return invalid_; }
  // The publication (writer) handle of every valid sample taken so far, in the order taken.
  [[nodiscard]] const std::vector<dds_instance_handle_t>& publications() const { return publications_; }

 private:
  dds_entity_t participant_ = -1;
  dds_entity_t reader_ = -1;
  dds_entity_t waitset_ = -1;
  dds_entity_t readcond_ = -1;
  std::vector<T> samples_;
  std::vector<void*> ptrs_;
  std::vector<dds_sample_info_t> infos_;
  std::vector<dds_instance_handle_t> publications_;
  std::uint64_t invalid_ = 0;
};

}  // namespace teamscan::test
