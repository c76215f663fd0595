// Radio link faults for `teamscan demo` (docs/radio.md "Link faults"): the station and every robot in
// a network namespace of their own, each joined by a veth pair to a bridge in a hub namespace (the
// host's interfaces are never touched). A shadow takes a robot's link down for a while and up again;
// packet loss is Cyclone's Internal/Test/XmitLossiness (per mille of the datagrams each process sends),
// set in each process's own Cyclone config. Needs root and network namespaces; without them the demo
// stops with a message (exit 1), never runs without the faults asked for.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/result.hpp"
#include "tools/demo/report_json.hpp"
#include "tools/demo/session_csv.hpp"

namespace teamscan::demo {

// One --shadow ROBOT:AT:FOR: robot ROBOT's link down from world time AT for FOR seconds.
struct LinkShadow {
  int robot_id = 0;
  double at_s = 0.0;
  double for_s = 0.0;
};

// "20" or "20%" (percent, decimals allowed) or "200pm" (per mille) as per mille in [0, 1000].
[[nodiscard]] Result<int> parse_link_loss_permille(std::string_view text);
// "ROBOT:AT:FOR": robot id in [1, 32], AT ≥ 0, FOR > 0 seconds.
[[nodiscard]] Result<LinkShadow> parse_shadow(std::string_view text);
// Two shadows of one robot that overlap (the second would start while the link is down): an error naming them.
[[nodiscard]] Status check_shadows(const std::vector<LinkShadow>& shadows);

// `base_xml` (a Cyclone config: the site's or the loopback one) for one namespace: its network interface
// the namespace's address, multicast off, the peers `peers`, and XmitLossiness `loss_permille`. An error
// if the base lacks one of the elements replaced (NetworkInterface, AllowMulticast, Peers).
[[nodiscard]] Result<std::string> namespace_dds_config(std::string_view base_xml, const std::string& address,
                                                       const std::vector<std::string>& peers, int loss_permille);

struct LinkNetworkOptions {
  std::string prefix;          // namespace names start with it (e.g. "tsdemo1234-")
  std::vector<int> robot_ids;  // one namespace per robot
  int loss_permille = 0;       // XmitLossiness of every process
  std::string base_dds_xml;    // the Cyclone config text the per-process configs derive from
  std::string config_dir;      // where the per-process Cyclone configs are written
};

// The namespaces, veth pairs and per-process configs of one run; the destructor deletes every namespace
// it made (also when create fails half-way).
class LinkNetwork {
 public:
  // Needs root, the `ip` program and network namespaces: else an error that says which is missing.
  [[nodiscard]] static Result<std::unique_ptr<LinkNetwork>> create(const LinkNetworkOptions& options);
  ~LinkNetwork();
  LinkNetwork(const LinkNetwork&) = delete;
  LinkNetwork& operator=(const LinkNetwork&) = delete;

  // The argv to put in front of a program so that it runs in the station's (robot's) namespace with its
  // own Cyclone config (`ip netns exec NS env CYCLONEDDS_URI=file://... `: the program keeps the pid).
  [[nodiscard]] std::vector<std::string> station_prefix() const;
  [[nodiscard]] std::vector<std::string> robot_prefix(int robot_id) const;
  // Robot `robot_id`'s link down (its hub-side veth end) or up again.
  [[nodiscard]] Status set_robot_link(int robot_id, bool up);
  [[nodiscard]] const std::vector<std::string>& namespaces() const { return namespaces_; }
  [[nodiscard]] std::string address_of_station() const;
  [[nodiscard]] std::string address_of_robot(int robot_id) const;

 private:
  explicit LinkNetwork(LinkNetworkOptions options) : options_(std::move(options)) {}
  [[nodiscard]] Status build();
  [[nodiscard]] Status add_node(const std::string& ns, const std::string& hub_port, const std::string& address);
  [[nodiscard]] std::vector<std::string> prefix_for(const std::string& ns, const std::string& config) const;

  LinkNetworkOptions options_;
  std::vector<std::string> namespaces_;  // made so far, deleted by the destructor
  std::string ip_;                       // the ip program
  std::string station_config_;
  std::vector<std::string> robot_configs_;  // by index in options_.robot_ids
};

// Steps the shadows by world time: each one's link down at AT, up at AT + FOR; one line per change.
class ShadowSchedule {
 public:
  ShadowSchedule(LinkNetwork* network, std::vector<LinkShadow> shadows);
  // The lines of the changes made at world time `world_s` ("robot1 link down (shadow) at t = 12.0 s").
  [[nodiscard]] std::vector<std::string> step(double world_s);

 private:
  enum class State { pending, down, done };
  LinkNetwork* network_;
  std::vector<LinkShadow> shadows_;
  std::vector<State> states_;
};

// One shadow as the robot's statuses in the session (status.csv) tell it: what an operator saw.
struct ShadowReport {
  LinkShadow shadow;
  double robot_shadow_s = -1;        // the robot's own count (last_shadow_ms once it is back); -1: none seen
  std::uint32_t buffered_max = 0;    // most scans unconfirmed in its ring, from the link down to whole again
  std::uint32_t backfill_total = 0;  // scans it back-filled after the return
  double whole_after_s = -1;         // link up -> the first status with nothing left to back-fill; -1: never
};
// `rows` of every robot; `down_ns` / `up_ns` the link's change as the robots' clock (CLOCK_REALTIME) reads.
[[nodiscard]] ShadowReport shadow_report(const std::vector<StatusRow>& rows, const LinkShadow& shadow,
                                         std::int64_t down_ns, std::int64_t up_ns);
// "robot1 shadow at t = 8.0 s for 12.0 s: in shadow for 12.9 s, 1380 scans buffered, 979 back-filled, whole
// again 6.2 s after its return" (or "NOT whole again by the end of the run").
[[nodiscard]] std::string shadow_text(const ShadowReport& r);
[[nodiscard]] ReportJson shadow_json(const ShadowReport& r);
// Each robot entry of `robots` (summary.json's array) gets its shadows' count, whether it was whole again
// after each, the slowest return to whole and the most scans buffered.
void add_shadows_to_robots(const std::vector<ShadowReport>& shadows, ReportJson& robots);

}  // namespace teamscan::demo
