// The daemon's network writes off its loop: a Publisher in front of another that copies each message
// into a fixed-capacity queue and writes it from a thread of its own. A write that blocks (a radio link
// going down fills the socket's send buffer and Cyclone's sendmsg waits for room) then never stops the
// loop that reads the Pioneer and the laser: the devices keep streaming, every scan still reaches the
// ring, and the queue carries the writes as soon as the link takes them again (docs/onboard.md
// "Writes off the loop").
#pragma once

#include <pthread.h>
#include <semaphore.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <variant>

#include "common/result.hpp"
#include "common/time.hpp"
#include "onboard/daemon/publisher.hpp"

namespace teamscan::onboard {

// Messages the queue holds: 1 024 ≈ 12 s of a robot's traffic (75 scans, 10 poses and a status a
// second; 6.5 KB a slot), twice the backlog of a link going down (docs/radio.md "A link going down, on the robot").
inline constexpr std::size_t kSendQueueItems = 1024;

struct SendQueueOptions {
  // At the stop (destructor): at most this long to write what is still queued; the rest is counted as
  // dropped (with [ring] the station back-fills it from the ring after the restart).
  Duration drain_timeout = std::chrono::seconds(1);
  // How often the sender reads the writer's reader-match count for scan_reader_matches().
  Duration matches_refresh = std::chrono::milliseconds(100);
};

class SendQueue final : public Publisher {
 public:
  // Allocates the queue and starts the sender thread (start-up). `inner` is used from that thread only,
  // except take_team and take_stored, which read the DDS readers and are called from the caller's thread
  // (the DDS bridge's are thread-safe and never wait for a write).
  [[nodiscard]] static Result<std::unique_ptr<SendQueue>> create(std::unique_ptr<Publisher> inner,
                                                                 const SendQueueOptions& options = {});
  ~SendQueue() override;
  SendQueue(const SendQueue&) = delete;
  SendQueue& operator=(const SendQueue&) = delete;

  // Copy the message into the queue and return at once; an error (counted in refused) when it is full.
  // Back-fill takes at most half the queue, so the live scans always find room first.
  Status publish_pose(const OnboardPose& pose) override;
  Status publish_scan(const ScanPoints& scan) override;
  Status publish_status(const OnboardStatus& status) override;
  Status publish_backfill(const ScanPoints& scan) override;
  Status publish_backfill_pose(const OnboardPose& pose) override;
  bool take_team(TeamSnapshot& out) override { return inner_->take_team(out); }
  bool take_stored(StoredSnapshot& out) override { return inner_->take_stored(out); }
  // The sender's latest reading (every matches_refresh). Not read on the caller's thread: Cyclone's
  // dds_get_publication_matched_status takes the writer's lock, which dds_write holds for as long as
  // its sendmsg blocks.
  std::uint32_t scan_reader_matches() const override { return scan_reader_matches_.load(std::memory_order_relaxed); }
  const char* name() const override { return name_; }
  PublisherHealth health() const override;

 private:
  struct Item {
    std::variant<OnboardPose, ScanPoints, OnboardStatus> message;
    bool backfill = false;
  };
  SendQueue(std::unique_ptr<Publisher> inner, const SendQueueOptions& options);
  template <class M>
  Status push(const M& message, bool backfill);
  void run();
  Status write(const Item& item);

  std::unique_ptr<Publisher> inner_;
  SendQueueOptions options_;
  char name_[48] = {};
  std::array<Item, kSendQueueItems> items_{};
  // Single producer (the daemon's loop) and single consumer (the sender thread).
  std::atomic<std::uint64_t> tail_{0};  // written by the producer
  std::atomic<std::uint64_t> head_{0};  // written by the consumer
  sem_t ready_{};                       // one post per item, and one for the stop
  std::atomic<bool> stopping_{false};
  pthread_t sender_{};
  bool started_ = false;
  // The producer's counters (read by health() on the same thread).
  std::uint64_t refused_ = 0;
  std::uint32_t high_water_ = 0;
  // The sender's.
  std::atomic<std::uint64_t> written_{0};
  std::atomic<std::uint64_t> write_errors_{0};
  std::atomic<std::uint64_t> dropped_at_stop_{0};
  std::atomic<std::int64_t> longest_write_ns_{0};
  std::atomic<std::uint32_t> scan_reader_matches_{0};
};

}  // namespace teamscan::onboard
