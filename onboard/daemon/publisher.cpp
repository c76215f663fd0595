// make_publisher: the DDS bridge (onboard/bridge/bridge.hpp) behind the daemon's Publisher interface,
// written from a SendQueue's thread.
#include "onboard/daemon/publisher.hpp"

#include "onboard/bridge/bridge.hpp"
#include "onboard/daemon/send_queue.hpp"

namespace teamscan::onboard {

namespace {

class DdsPublisher final : public Publisher {
 public:
  explicit DdsPublisher(DdsBridge bridge) : bridge_{std::move(bridge)} {}
  Status publish_pose(const OnboardPose& pose) override { return bridge_.publish_pose(pose); }
  Status publish_scan(const ScanPoints& scan) override { return bridge_.publish_scan(scan); }
  Status publish_status(const OnboardStatus& status) override { return bridge_.publish_status(status); }
  bool take_team(TeamSnapshot& out) override { return bridge_.take_team(out); }
  Status publish_backfill(const ScanPoints& scan) override { return bridge_.publish_backfill(scan); }
  Status publish_backfill_pose(const OnboardPose& pose) override { return bridge_.publish_backfill_pose(pose); }
  bool take_stored(StoredSnapshot& out) override { return bridge_.take_stored(out); }
  std::uint32_t scan_reader_matches() const override { return bridge_.scan_reader_matches(); }
  const char* name() const override { return "dds"; }

 private:
  DdsBridge bridge_;
};

}  // namespace

Result<std::unique_ptr<Publisher>> make_publisher(const OnboardConfig& config, const char* pki_dir) {
  DdsBridgeOptions options;
  options.pki_dir = pki_dir;
  options.robot_id = config.robot_id;
  options.domain_id = config.dds_domain;
  options.scan_history_depth = config.scan_history_depth;
  options.store_and_forward = config.ring.enabled();
  if (options.store_and_forward) options.scan_late_joiner_depth = kRingLiveLateJoinerDepth;
  Result<DdsBridge> bridge = DdsBridge::create(options);
  if (!bridge.ok()) return bridge.error();
  Result<std::unique_ptr<SendQueue>> queue =
      SendQueue::create(std::unique_ptr<Publisher>(new DdsPublisher(std::move(bridge.value()))));
  if (!queue.ok()) return queue.error();
  return std::unique_ptr<Publisher>(std::move(queue.value()));
}

}  // namespace teamscan::onboard
