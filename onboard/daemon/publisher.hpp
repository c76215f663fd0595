// Where the daemon's messages go: the DDS bridge (onboard/bridge) on the robot, a stub in tests.
// The daemon's loop only sees this interface.
#pragma once

#include <cstdint>
#include <memory>

#include "common/result.hpp"
#include "onboard/core/config.hpp"
#include "onboard/core/messages.hpp"

namespace teamscan::onboard {

// A publisher that writes from a queue of its own (send_queue.hpp) reports its state here; a direct
// one has nothing to report.
struct PublisherHealth {
  bool queued = false;                 // the writes go through a queue
  std::uint32_t depth = 0;             // messages waiting now
  std::uint32_t high_water = 0;        // most messages ever waiting
  std::uint64_t refused = 0;           // not taken: the queue was full
  std::uint64_t write_errors = 0;      // taken, then refused by the writer underneath
  std::int64_t longest_write_ns = 0;   // the longest single write underneath (a link that blocked)
};

class Publisher {
 public:
  virtual ~Publisher() = default;
  [[nodiscard]] virtual Status publish_pose(const OnboardPose& pose) = 0;
  [[nodiscard]] virtual Status publish_scan(const ScanPoints& scan) = 0;
  [[nodiscard]] virtual Status publish_status(const OnboardStatus& status) = 0;
  // The newest team state since the last call, if any; never blocks.
  [[nodiscard]] virtual bool take_team(TeamSnapshot& out) = 0;
  // Store and forward (docs/onboard.md "The ring"): a scan re-published from the ring, and the newest
  // teamscan/stored since the last call. A publisher without them refuses and never has one.
  [[nodiscard]] virtual Status publish_backfill(const ScanPoints&) { return Error{"publisher: no back-fill writer"}; }
  [[nodiscard]] virtual Status publish_backfill_pose(const OnboardPose&) {
    return Error{"publisher: no pose back-fill writer"};
  }
  [[nodiscard]] virtual bool take_stored(StoredSnapshot&) { return false; }
  // How many readers (ground stations) have matched the live scan writer since it was created, including
  // each rematch after a restart or a radio shadow; never decreases.
  [[nodiscard]] virtual std::uint32_t scan_reader_matches() const { return 0; }
  [[nodiscard]] virtual const char* name() const = 0;
  [[nodiscard]] virtual PublisherHealth health() const { return {}; }
};

// Counts what it is given and drops it; never has a team state (the filter then flags points stale).
class NullPublisher final : public Publisher {
 public:
  Status publish_pose(const OnboardPose&) override { ++poses; return ok_status(); }
  Status publish_scan(const ScanPoints&) override { ++scans; return ok_status(); }
  Status publish_status(const OnboardStatus&) override { ++statuses; return ok_status(); }
  bool take_team(TeamSnapshot&) override { return false; }
  const char* name() const override { return "none (test stub)"; }
  unsigned long poses = 0, scans = 0, statuses = 0;
};

// The DDS bridge publisher (onboard/bridge), written from its own thread through a SendQueue
// (send_queue.hpp) so that no network write runs on the daemon's loop. pki_dir: the robot's DDS Security credential bundle, already
// checked (null: unsecured).
[[nodiscard]] Result<std::unique_ptr<Publisher>> make_publisher(const OnboardConfig& config, const char* pki_dir = nullptr);

}  // namespace teamscan::onboard
