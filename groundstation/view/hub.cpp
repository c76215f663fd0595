// ViewHub: the view's copy of the map, tracks and states, and the messages made from them (hub.hpp).
#include "groundstation/view/hub.hpp"

#include <algorithm>
#include <cmath>

namespace teamscan::view {
namespace {

std::int64_t floor_div(std::int64_t a, std::int64_t b) {
  const std::int64_t q = a / b;
  return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

SharedMessage make_message(bool binary, std::string bytes) {
  auto m = std::make_shared<Message>();
  m->binary = binary;
  m->bytes = std::move(bytes);
  return m;
}

}  // namespace

ViewHub::ViewHub(HubOptions options) : options_{options}, extra_(kMaxRobots + 1) {
  if (options_.map_resolution_mm == 0) options_.map_resolution_mm = 100;
  if (options_.track_max_points < 2) options_.track_max_points = 2;
}

std::uint64_t ViewHub::key_of(std::int32_t x_mm, std::int32_t y_mm, std::int32_t z_mm) const {
  const std::int64_t r = options_.map_resolution_mm;
  auto part = [&](std::int32_t v) {
    return static_cast<std::uint64_t>(floor_div(v, r) + (std::int64_t{1} << 20)) & ((std::uint64_t{1} << 21) - 1);
  };
  return part(x_mm) | (part(y_mm) << 21) | (part(z_mm) << 42);
}

void ViewHub::add_track_point(RobotExtra& r, double x_m, double y_m) {
  Track& t = r.track;
  if (t.xy.size() >= 2) {
    const double dx = x_m - t.xy[t.xy.size() - 2], dy = y_m - t.xy[t.xy.size() - 1];
    if (std::hypot(dx, dy) * 1000.0 < options_.track_step_mm) return;
  }
  if (t.xy.size() / 2 >= options_.track_max_points) {
    // Thin to every other point (the newest kept) and send it whole again.
    std::vector<float> thin;
    thin.reserve(t.xy.size() / 2 + 2);
    const std::size_t n = t.xy.size() / 2;
    for (std::size_t i = n % 2 == 0 ? 1 : 0; i < n; i += 2) {
      thin.push_back(t.xy[2 * i]);
      thin.push_back(t.xy[2 * i + 1]);
    }
    t.xy = std::move(thin);
    t.resend = true;
  }
  t.xy.push_back(static_cast<float>(x_m));
  t.xy.push_back(static_cast<float>(y_m));
}

StateHeader ViewHub::header(bool whole) const {
  StateHeader h;
  h.seq = seq_;
  h.whole = whole;
  h.map_resolution_mm = options_.map_resolution_mm;
  h.map_voxels = static_cast<std::uint32_t>(in_map_);
  if (latest_) {
    h.stamp_ns = latest_->stamp_ns;
    if (latest_->map_voxels != 0) h.map_voxels = latest_->map_voxels;
    h.map_release = latest_->map_release;
  }
  return h;
}

std::vector<RobotView> ViewHub::robot_views(bool whole_tracks) const {
  std::vector<RobotView> out;
  if (!latest_) return out;
  out.reserve(latest_->count);
  for (std::uint32_t i = 0; i < latest_->count && i < latest_->robots.size(); ++i) {
    const RobotState& s = latest_->robots[i];
    if (s.robot_id == 0 || s.robot_id > kMaxRobots) continue;
    const RobotExtra& e = extra_[s.robot_id];
    RobotView v;
    v.state = s;
    v.scan_rate_hz = e.rate_hz;
    v.track_whole = whole_tracks || e.track.resend;
    const std::size_t from = v.track_whole ? 0 : std::min(e.track.sent, e.track.xy.size());
    v.track_xy = std::span<const float>(e.track.xy).subspan(from);
    out.push_back(v);
  }
  return out;
}

void ViewHub::apply(const FeedBatch& batch, std::vector<SharedMessage>& out) {
  ++counters_.batches;
  // The tap scans are the Foxglove channels' (/robotN/scan); a voxel's robot comes with its update, from
  // the fused model, never from the points as received.
  counters_.tap_scans += batch.scan_count;
  if (batch.voxels_are_full_map) ++counters_.whole_maps;
  const auto take = [&] {
    changed_scratch_.clear();
    for (const VoxelUpdate& u : batch.voxels) {
      WireVoxel& v = voxels_[key_of(u.x_mm, u.y_mm, u.z_mm)];
      if (v.hits == 0 && u.hits != 0) ++in_map_;
      v.x_mm = u.x_mm;
      v.y_mm = u.y_mm;
      v.z_mm = u.z_mm;
      v.hits = u.hits;
      v.flags = u.removed ? 1 : 0;
      if (u.robot != 0) v.robot = u.robot;
      changed_scratch_.push_back(v);
    }
  };
  take();
  // A whole map holds each of the station's voxels once. If the map now holds more, the station's map
  // left some out (decided again: a catch-up, the final model on the pose graph's poses): it replaces
  // the map, and the pages clear and take it whole.
  bool replaces = false;
  if (batch.voxels_are_full_map &&
      in_map_ > static_cast<std::size_t>(std::count_if(batch.voxels.begin(), batch.voxels.end(), [](const VoxelUpdate& u) { return u.hits != 0; }))) {
    voxels_.clear();
    in_map_ = 0;
    take();
    replaces = true;
    ++counters_.replacing_maps;
  }
  counters_.voxels_changed += changed_scratch_.size();

  if (batch.snapshot) {
    latest_ = *batch.snapshot;
    ++seq_;
    ++counters_.states;
    for (std::uint32_t i = 0; i < latest_->count && i < latest_->robots.size(); ++i) {
      const RobotState& s = latest_->robots[i];
      if (s.robot_id == 0 || s.robot_id > kMaxRobots) continue;
      RobotExtra& e = extra_[s.robot_id];
      add_track_point(e, s.x_m, s.y_m);
      const double dt_s = static_cast<double>(latest_->stamp_ns - e.rate_stamp_ns) * 1e-9;
      if (e.rate_stamp_ns == 0 || s.scans < e.rate_scans) {
        e.rate_stamp_ns = latest_->stamp_ns;
        e.rate_scans = s.scans;
      } else if (dt_s >= options_.scan_rate_window_s) {
        e.rate_hz = static_cast<double>(s.scans - e.rate_scans) / dt_s;
        e.rate_stamp_ns = latest_->stamp_ns;
        e.rate_scans = s.scans;
      }
    }
  }

  if (replaces) {
    out.push_back(whole_map_message());
  } else if (!changed_scratch_.empty()) {
    VoxelMessage m;
    m.kind = VoxelKind::kChanged;
    m.seq = static_cast<std::uint32_t>(seq_);
    m.resolution_mm = options_.map_resolution_mm;
    m.total_voxels = static_cast<std::uint32_t>(in_map_);
    m.voxels = changed_scratch_;
    out.push_back(make_message(true, encode_voxels(m)));
  }
  if (batch.snapshot) {
    const std::vector<RobotView> views = robot_views(false);
    out.push_back(make_message(false, encode_state(header(false), views, true)));
    history_.emplace_back(seq_, encode_state(header(false), views, false));
    while (history_.size() > options_.state_history) history_.pop_front();
    for (const RobotView& v : views) {
      Track& t = extra_[v.state.robot_id].track;
      t.sent = t.xy.size();
      t.resend = false;
    }
  }
}

SharedMessage ViewHub::whole_map_message() const {
  VoxelMessage m;
  m.kind = VoxelKind::kWholeMap;
  m.seq = static_cast<std::uint32_t>(seq_);
  m.resolution_mm = options_.map_resolution_mm;
  m.total_voxels = static_cast<std::uint32_t>(in_map_);
  m.voxels.reserve(in_map_);
  for (const auto& [key, v] : voxels_) {
    if (v.hits != 0) m.voxels.push_back(v);
  }
  return make_message(true, encode_voxels(m));
}

void ViewHub::whole(std::vector<SharedMessage>& out) const {
  out.push_back(whole_map_message());
  if (latest_) out.push_back(make_message(false, encode_state(header(true), robot_views(true), true)));
}

std::optional<std::string> ViewHub::state_json(std::optional<std::uint64_t> seq) const {
  if (history_.empty()) return std::nullopt;
  if (!seq) return history_.back().second;
  for (const auto& [s, text] : history_) {
    if (s == *seq) return text;
  }
  return std::nullopt;
}

std::size_t ViewHub::memory_bytes() const {
  std::size_t n = voxels_.size() * (sizeof(std::uint64_t) + sizeof(WireVoxel) + 2 * sizeof(void*)) +
                  voxels_.bucket_count() * sizeof(void*);
  for (const RobotExtra& e : extra_) n += e.track.xy.capacity() * sizeof(float);
  for (const auto& h : history_) n += h.second.capacity();
  return n;
}

}  // namespace teamscan::view
