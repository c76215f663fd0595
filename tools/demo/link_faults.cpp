// Radio link faults for the demo (link_faults.hpp): namespaces, veth pairs, per-process Cyclone configs.
#include "tools/demo/link_faults.hpp"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <regex>
#include <sstream>

#include "common/capacities.hpp"
#include "common/data_paths.hpp"
#include "common/error_message.hpp"
#include "tools/demo/demo_run.hpp"
#include "tools/demo/supervisor.hpp"

namespace teamscan::demo {
namespace {

// The namespaces' subnet: private to the run's namespaces, never on a host interface.
constexpr const char* kSubnet = "10.77.0.";
constexpr int kPrefixBits = 24;
constexpr const char* kRadioInterface = "radio0";  // each node's end of its veth pair

std::optional<double> parse_number(std::string_view t) {
  double v = 0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (ec != std::errc{} || end != t.data() + t.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

// Runs `argv` (argv[0] a path), waits; an error with its output if it fails.
Status run(const std::vector<std::string>& argv) {
  int pipe_fd[2];
  if (::pipe2(pipe_fd, O_CLOEXEC) != 0) return make_error("pipe failed", errno);
  const pid_t pid = ::fork();
  if (pid < 0) return make_error("fork failed", errno);
  if (pid == 0) {
    ::dup2(pipe_fd[1], 1);
    ::dup2(pipe_fd[1], 2);
    exec_or_exit(argv);
  }
  ::close(pipe_fd[1]);
  std::string output;
  char buf[512];
  for (ssize_t n; (n = ::read(pipe_fd[0], buf, sizeof buf)) != 0;) {
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) break;
    output.append(buf, static_cast<std::size_t>(n));
  }
  ::close(pipe_fd[0]);
  int st = 0;
  while (::waitpid(pid, &st, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(st) && WEXITSTATUS(st) == 0) return ok_status();
  std::string cmd;
  for (const std::string& a : argv) cmd += (cmd.empty() ? "" : " ") + a;
  while (!output.empty() && output.back() == '\n') output.pop_back();
  return make_error("`" + cmd + "` failed: " + (output.empty() ? "exit " + std::to_string(WEXITSTATUS(st)) : output));
}

std::string find_ip() {
  for (const char* p : {"/usr/sbin/ip", "/sbin/ip", "/usr/bin/ip", "/bin/ip"})
    if (::access(p, X_OK) == 0) return p;
  return {};
}

bool write_file(const std::string& path, const std::string& text) {
  std::ofstream o(path, std::ios::trunc);
  o << text;
  return static_cast<bool>(o);
}

}  // namespace

Result<int> parse_link_loss_permille(std::string_view text) {
  double scale = 10.0;  // percent
  std::string_view number = text;
  if (number.ends_with("%")) {
    number.remove_suffix(1);
  } else if (number.ends_with("pm")) {
    number.remove_suffix(2);
    scale = 1.0;
  }
  const std::optional<double> v = parse_number(number);
  if (!v || *v < 0 || *v * scale > 1000.0)
    return make_error("--link-loss " + std::string{text} +
                      ": expected a percentage in [0, 100] (\"20\" or \"20%\") or per mille (\"200pm\")");
  return static_cast<int>(std::lround(*v * scale));
}

Result<LinkShadow> parse_shadow(std::string_view text) {
  const auto bad = [&](const std::string& why) {
    return make_error("--shadow " + std::string{text} + ": " + why + " (expected ROBOT:AT:FOR, e.g. 1:20:12)");
  };
  const std::size_t c1 = text.find(':');
  const std::size_t c2 = c1 == std::string_view::npos ? c1 : text.find(':', c1 + 1);
  if (c2 == std::string_view::npos || text.find(':', c2 + 1) != std::string_view::npos)
    return bad("three fields separated by ':'");
  int robot = 0;
  const std::string_view r = text.substr(0, c1);
  const auto [end, ec] = std::from_chars(r.data(), r.data() + r.size(), robot);
  if (ec != std::errc{} || end != r.data() + r.size() || robot < 1 || robot > static_cast<int>(kMaxRobots))
    return bad("the robot id must be in [1, " + std::to_string(kMaxRobots) + "]");
  const std::optional<double> at = parse_number(text.substr(c1 + 1, c2 - c1 - 1));
  if (!at || *at < 0) return bad("AT must be a number of seconds >= 0");
  const std::optional<double> length = parse_number(text.substr(c2 + 1));
  if (!length || *length <= 0) return bad("FOR must be a number of seconds > 0");
  return LinkShadow{robot, *at, *length};
}

Status check_shadows(const std::vector<LinkShadow>& shadows) {
  for (std::size_t i = 0; i < shadows.size(); ++i)
    for (std::size_t j = i + 1; j < shadows.size(); ++j) {
      const LinkShadow& a = shadows[i];
      const LinkShadow& b = shadows[j];
      if (a.robot_id == b.robot_id && a.at_s < b.at_s + b.for_s && b.at_s < a.at_s + a.for_s)
        return make_error("--shadow: robot " + std::to_string(a.robot_id) + "'s shadows overlap (at " +
                          std::to_string(a.at_s) + " s and at " + std::to_string(b.at_s) + " s)");
    }
  return ok_status();
}

Result<std::string> namespace_dds_config(std::string_view base_xml, const std::string& address,
                                         const std::vector<std::string>& peers, int loss_permille) {
  // Comments first: they may name the elements replaced below.
  std::string x = std::regex_replace(std::string{base_xml}, std::regex("<!--[\\s\\S]*?-->"), "");
  x = std::regex_replace(x, std::regex("<\\?xml[^>]*>"), "");
  const std::regex interface("<NetworkInterface\\b[^>]*/>");
  const std::regex multicast("<AllowMulticast>[^<]*</AllowMulticast>");
  const std::regex peer_list("<Peers>[\\s\\S]*?</Peers>");
  for (const auto& [re, name] : {std::pair{&interface, "NetworkInterface"}, std::pair{&multicast, "AllowMulticast"},
                                 std::pair{&peer_list, "Peers"}})
    if (!std::regex_search(x, *re))
      return make_error(std::string{"the DDS config has no "} + name + " element to set for the link-fault namespaces");
  x = std::regex_replace(x, interface, "<NetworkInterface address=\"" + address + "\" multicast=\"false\"/>");
  x = std::regex_replace(x, multicast, "<AllowMulticast>false</AllowMulticast>");
  std::string list = "<Peers>";
  for (const std::string& p : peers) list += "<Peer address=\"" + p + "\"/>";
  x = std::regex_replace(x, peer_list, list + "</Peers>");
  // Cyclone's test hook drops this many per mille of the datagrams the process sends (every link, both ways).
  const std::string test = "<Test><XmitLossiness>" + std::to_string(loss_permille) + "</XmitLossiness></Test>";
  if (x.find("<Internal>") != std::string::npos)
    x.replace(x.find("<Internal>"), 10, "<Internal>" + test);
  else if (x.find("</Domain>") != std::string::npos)
    x.replace(x.find("</Domain>"), 9, "<Internal>" + test + "</Internal></Domain>");
  else
    return make_error("the DDS config has no Domain element");
  return x;
}

Result<std::unique_ptr<LinkNetwork>> LinkNetwork::create(const LinkNetworkOptions& options) {
  if (::geteuid() != 0)
    return make_error(
        "link faults (--link-loss, --shadow) need root: they put the robots and the station in network "
        "namespaces");
  std::unique_ptr<LinkNetwork> n{new LinkNetwork(options)};
  n->ip_ = find_ip();
  if (n->ip_.empty()) return make_error("link faults need the ip program (iproute2), not found");
  if (Status st = n->build(); !st) return with_context("link faults: network namespaces unavailable", st.error());
  return n;
}

LinkNetwork::~LinkNetwork() {
  // The robots' and the station's namespaces first (their veth pairs go with them), the hub last.
  for (auto it = namespaces_.rbegin(); it != namespaces_.rend(); ++it) (void)run({ip_, "netns", "delete", *it});
}

std::string LinkNetwork::address_of_station() const { return std::string{kSubnet} + "1"; }
std::string LinkNetwork::address_of_robot(int robot_id) const { return kSubnet + std::to_string(10 + robot_id); }

Status LinkNetwork::add_node(const std::string& ns, const std::string& hub_port, const std::string& address) {
  const std::string hub = options_.prefix + "hub";
  if (Status st = run({ip_, "netns", "add", ns}); !st) return st;
  namespaces_.push_back(ns);
  for (const std::vector<std::string>& cmd :
       {std::vector<std::string>{ip_, "-n", hub, "link", "add", hub_port, "type", "veth", "peer", "name",
                                 kRadioInterface, "netns", ns},
        {ip_, "-n", hub, "link", "set", hub_port, "master", "br0", "up"},
        {ip_, "-n", ns, "addr", "add", address + "/" + std::to_string(kPrefixBits), "dev", kRadioInterface},
        {ip_, "-n", ns, "link", "set", kRadioInterface, "up"},
        {ip_, "-n", ns, "link", "set", "lo", "up"}})
    if (Status st = run(cmd); !st) return st;
  return ok_status();
}

Status LinkNetwork::build() {
  const std::string hub = options_.prefix + "hub";
  if (Status st = run({ip_, "netns", "add", hub}); !st) return st;
  namespaces_.push_back(hub);
  if (Status st = run({ip_, "-n", hub, "link", "add", "br0", "type", "bridge"}); !st) return st;
  if (Status st = run({ip_, "-n", hub, "link", "set", "br0", "up"}); !st) return st;
  std::vector<std::string> peers{address_of_station()};
  for (int id : options_.robot_ids) peers.push_back(address_of_robot(id));
  const auto config = [&](const std::string& name, const std::string& address) -> Result<std::string> {
    Result<std::string> xml = namespace_dds_config(options_.base_dds_xml, address, peers, options_.loss_permille);
    if (!xml) return xml.error();
    const std::string path = options_.config_dir + "/cyclonedds-" + name + ".xml";
    if (!write_file(path, xml.value())) return make_error("cannot write " + path);
    return path;
  };
  if (Status st = add_node(options_.prefix + "station", "station", address_of_station()); !st) return st;
  Result<std::string> sc = config("station", address_of_station());
  if (!sc) return sc.error();
  station_config_ = sc.value();
  for (int id : options_.robot_ids) {
    const std::string name = "robot" + std::to_string(id);
    if (Status st = add_node(options_.prefix + name, name, address_of_robot(id)); !st) return st;
    Result<std::string> rc = config(name, address_of_robot(id));
    if (!rc) return rc.error();
    robot_configs_.push_back(rc.value());
  }
  return ok_status();
}

std::vector<std::string> LinkNetwork::prefix_for(const std::string& ns, const std::string& config) const {
  return {ip_, "netns", "exec", ns, "/usr/bin/env", "CYCLONEDDS_URI=file://" + config};
}

std::vector<std::string> LinkNetwork::station_prefix() const {
  return prefix_for(options_.prefix + "station", station_config_);
}

std::vector<std::string> LinkNetwork::robot_prefix(int robot_id) const {
  for (std::size_t i = 0; i < options_.robot_ids.size(); ++i)
    if (options_.robot_ids[i] == robot_id)
      return prefix_for(options_.prefix + "robot" + std::to_string(robot_id), robot_configs_[i]);
  return {};
}

Status LinkNetwork::set_robot_link(int robot_id, bool up) {
  return run(
      {ip_, "-n", options_.prefix + "hub", "link", "set", "robot" + std::to_string(robot_id), up ? "up" : "down"});
}

ShadowSchedule::ShadowSchedule(LinkNetwork* network, std::vector<LinkShadow> shadows)
    : network_(network), shadows_(std::move(shadows)), states_(shadows_.size(), State::pending) {}

std::vector<std::string> ShadowSchedule::step(double world_s) {
  std::vector<std::string> lines;
  if (network_ == nullptr) return lines;
  for (std::size_t i = 0; i < shadows_.size(); ++i) {
    const LinkShadow& sh = shadows_[i];
    const bool down = states_[i] == State::pending && world_s >= sh.at_s;
    const bool up = states_[i] == State::down && world_s >= sh.at_s + sh.for_s;
    if (!down && !up) continue;
    const Status st = network_->set_robot_link(sh.robot_id, up);
    char b[160];
    std::snprintf(b, sizeof b, "robot%d link %s at t = %.1f s%s%s", sh.robot_id,
                  up ? "up (shadow over)" : "down (shadow)", world_s, st ? "" : ": ", st ? "" : st.error().what);
    lines.emplace_back(b);
    states_[i] = up ? State::done : State::down;
  }
  return lines;
}

ShadowReport shadow_report(const std::vector<StatusRow>& rows, const LinkShadow& shadow, std::int64_t down_ns,
                           std::int64_t up_ns) {
  ShadowReport r{shadow};
  std::vector<const StatusRow*> own;
  for (const StatusRow& row : rows)
    if (static_cast<int>(row.robot_id) == shadow.robot_id && row.stamp_ns >= down_ns) own.push_back(&row);
  std::stable_sort(own.begin(), own.end(),
                   [](const StatusRow* a, const StatusRow* b) { return a->stamp_ns < b->stamp_ns; });
  for (const StatusRow* row : own) {
    r.buffered_max = std::max(r.buffered_max, row->ring_unconfirmed);
    // Back: the robot hears the station's confirmations again (shadow_ms 0 after the link came up).
    if (row->stamp_ns < up_ns || row->shadow_ms != 0) continue;
    if (r.robot_shadow_s < 0 && row->last_shadow_ms > 0) r.robot_shadow_s = row->last_shadow_ms * 1e-3;
    r.backfill_total = std::max(r.backfill_total, row->backfill_total);
    if (row->backfill_remaining == 0) {
      r.whole_after_s = static_cast<double>(row->stamp_ns - up_ns) * 1e-9;
      break;
    }
  }
  return r;
}

std::string shadow_text(const ShadowReport& r) {
  char shadow[64] = "? s (no status after it)";
  if (r.robot_shadow_s >= 0) std::snprintf(shadow, sizeof shadow, "%.1f s", r.robot_shadow_s);
  char whole[64] = "NOT whole again by the end of the run";
  if (r.whole_after_s >= 0) std::snprintf(whole, sizeof whole, "whole again %.1f s after its return", r.whole_after_s);
  char b[320];
  std::snprintf(b, sizeof b,
                "robot%d shadow at t = %.1f s for %.1f s: in shadow for %s, %u scans buffered, %u back-filled, %s",
                r.shadow.robot_id, r.shadow.at_s, r.shadow.for_s, shadow, r.buffered_max, r.backfill_total, whole);
  return b;
}

ReportJson shadow_json(const ShadowReport& r) {
  return {
      {"robot", r.shadow.robot_id},          {"at_s", r.shadow.at_s},           {"for_s", r.shadow.for_s},
      {"robot_shadow_s", r.robot_shadow_s},  {"buffered_max", r.buffered_max},  {"backfill_total", r.backfill_total},
      {"whole_again", r.whole_after_s >= 0}, {"whole_after_s", r.whole_after_s}};
}

void add_shadows_to_robots(const std::vector<ShadowReport>& shadows, ReportJson& robots) {
  for (ReportJson& robot : robots) {
    int count = 0;
    bool whole = true;
    double slowest_s = 0;
    std::uint32_t buffered = 0;
    for (const ShadowReport& r : shadows) {
      if (robot.value("id", 0) != r.shadow.robot_id) continue;
      ++count;
      whole = whole && r.whole_after_s >= 0;
      slowest_s = std::max(slowest_s, r.whole_after_s);
      buffered = std::max(buffered, r.buffered_max);
    }
    robot["shadows"] = count;
    robot["whole_again"] = whole;
    robot["whole_after_s_max"] = slowest_s;
    robot["buffered_max"] = buffered;
  }
}

int check_link_faults(const DemoOptions& a, DemoSetup& s) {
  if (a.link_loss.empty() && a.shadows.empty()) return 0;
  if (!a.link_loss.empty()) {
    Result<int> loss = parse_link_loss_permille(a.link_loss);
    if (!loss) {
      std::fprintf(stderr, "teamscan demo: %s\n", loss.error().what);
      return 2;
    }
    s.loss_permille = loss.value();
  }
  std::vector<int> ids;
  for (const sim::RobotSpec& r : s.scenario.robots) ids.push_back(r.id);
  s.namespaces = true;
  for (const std::string& text : a.shadows) {
    Result<LinkShadow> sh = parse_shadow(text);
    if (!sh) {
      std::fprintf(stderr, "teamscan demo: %s\n", sh.error().what);
      return 2;
    }
    if (std::find(ids.begin(), ids.end(), sh.value().robot_id) == ids.end()) {
      std::fprintf(stderr, "teamscan demo: --shadow %s: the run has no robot %d\n", text.c_str(), sh.value().robot_id);
      return 2;
    }
    s.shadows.push_back(sh.value());
  }
  if (Status st = check_shadows(s.shadows); !st) {
    std::fprintf(stderr, "teamscan demo: %s\n", st.error().what);
    return 2;
  }
  if (a.view_port) {
    std::fprintf(stderr,
                 "teamscan demo: --view with link faults: the station's 127.0.0.1 is in its own network "
                 "namespace, out of the browser's reach\n");
    return 2;
  }
  // The radio site config unless --dds-config names another (the loopback one's network parts are
  // replaced the same way).
  std::string base = a.dds_config;
  if (base.empty()) {
    const DataFile site = find_data_file("cyclonedds-site.xml", "deploy/cyclonedds-site.xml");
    if (site.path.empty()) {
      std::fprintf(stderr, "teamscan demo: cannot find cyclonedds-site.xml (looked in %s; give --dds-config)\n",
                   site.searched.c_str());
      return 2;
    }
    base = site.path;
  }
  s.dds = base;
  return 0;
}

int make_link_network(const DemoOptions& a, DemoSetup& s) {
  if (!s.namespaces) return 0;
  std::ifstream in(s.dds);
  std::ostringstream xml;
  xml << in.rdbuf();
  if (!in) {
    std::fprintf(stderr, "teamscan demo: cannot read %s\n", s.dds.c_str());
    return 2;
  }
  std::vector<int> ids;
  for (const sim::RobotSpec& r : s.scenario.robots) ids.push_back(r.id);
  LinkNetworkOptions o;
  o.prefix = a.netns_prefix.empty() ? "tsdemo" + std::to_string(::getpid()) + "-" : a.netns_prefix;
  o.robot_ids = ids;
  o.loss_permille = s.loss_permille;
  o.base_dds_xml = xml.str();
  o.config_dir = s.out + "/config";
  Result<std::unique_ptr<LinkNetwork>> n = LinkNetwork::create(o);
  if (!n) {
    std::fprintf(stderr, "teamscan demo: %s\n", n.error().what);
    return 1;
  }
  s.links = std::move(n.value());
  return 0;
}

}  // namespace teamscan::demo
