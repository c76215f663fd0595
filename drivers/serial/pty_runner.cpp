// PtyRunner: a device model on a pty master with real time, line pacing and rate-mismatch garbling.
#include "drivers/serial/pty_runner.hpp"

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <ctime>

#include "common/capacities.hpp"
#include "common/clock.hpp"
#include "drivers/serial/posix_call.hpp"

namespace teamscan::serial {
namespace {

timespec to_timespec(Duration d) {
  if (d < Duration::zero()) d = Duration::zero();
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(d.count() / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(d.count() % 1'000'000'000);
  return ts;
}

}  // namespace

PtyRunner::PtyRunner(SerialEndpoint& device, PtyRunnerOptions options)
    : device_{&device}, options_{std::move(options)}, epoch_{now_monotonic()} {}

PtyRunner::~PtyRunner() {
  stop();
  (void)capture_.close();
}

Result<std::unique_ptr<PtyRunner>> PtyRunner::create(SerialEndpoint& device, PtyRunnerOptions options) {
  std::unique_ptr<PtyRunner> runner{new PtyRunner(device, std::move(options))};
  auto pty = PtyPair::create();
  if (!pty) return pty.error();
  runner->pty_ = std::move(*pty);
  if (!runner->options_.link_path.empty()) {
    const Status s = runner->pty_.link(runner->options_.link_path);
    if (!s) return s.error();
  }
  return Result<std::unique_ptr<PtyRunner>>{std::move(runner)};
}

std::string PtyRunner::host_path() const {
  std::lock_guard<std::mutex> lock{mutex_};
  return options_.link_path.empty() ? std::string{pty_.slave_path()} : options_.link_path;
}

std::uint32_t PtyRunner::host_baud() const {
  std::lock_guard<std::mutex> lock{mutex_};
  return pty_.slave_baud();
}

bool PtyRunner::plugged() const {
  std::lock_guard<std::mutex> lock{mutex_};
  return pty_.is_open();
}

PtyRunnerStats PtyRunner::stats() const {
  std::lock_guard<std::mutex> lock{mutex_};
  return stats_;
}

void PtyRunner::record_chunk(Time now, CaptureDirection dir, std::span<const std::uint8_t> bytes) {
  if (!capture_.is_open() || bytes.empty()) return;
  if (!capture_.chunk(capture_us(now), dir, bytes)) ++stats_.io_errors;
}

Status PtyRunner::step_locked(Time now, Duration& wait) {
  if (device_->next_deadline() <= now) device_->on_tick(now);

  const bool plugged = pty_.is_open();
  std::uint32_t host_baud = 0;
  if (plugged) {
    // Polled every step: a pty gives no notification of the host's tcsetattr without EXTPROC
    // (DDS_SYSTEMD.md §6), and a step is at most max_wait apart.
    host_baud = pty_.slave_baud();
    if (host_baud != stats_.host_baud) {
      stats_.host_baud = host_baud;
      if (capture_.is_open() && !capture_.baud(capture_us(now), host_baud)) ++stats_.io_errors;
    }
  }

  // Host -> device: instant on a pty; garbled when the device listens at another rate.
  if (plugged) {
    const bool mismatch = options_.garble_on_mismatch && host_baud != device_->baud();
    std::array<std::uint8_t, kSerialRxChunk> buf{};
    for (int round = 0; round < 16; ++round) {
      const SysResult n = posix_call([&] { return ::read(pty_.master_fd(), buf.data(), buf.size()); });
      if (!n.ok()) {
        if (n.err == EAGAIN || n.err == EWOULDBLOCK) break;
        ++stats_.io_errors;
        return Error{"read from pty master failed", n.err};
      }
      if (n.value == 0) break;
      const std::span<std::uint8_t> got{buf.data(), static_cast<std::size_t>(n.value)};
      record_chunk(now, CaptureDirection::tx, got);
      if (mismatch) {
        to_device_garbler_.garble(got);
        stats_.garbled_bytes += got.size();
      }
      stats_.bytes_to_device += got.size();
      device_->on_rx(got, now);
    }
  }

  // Device -> queue. A new rate starts only once the bytes queued at the old rate are out, so a
  // device that switches rate right after its ACK still sends that ACK at the old rate.
  for (int round = 0; round < 16; ++round) {
    const std::uint32_t device_baud = device_->baud();
    if (tx_size_ > 0 && device_baud != tx_baud_) break;
    if (tx_size_ == kTxQueueBytes) break;
    const std::size_t tail = (tx_head_ + tx_size_) % kTxQueueBytes;
    const std::size_t room = std::min(kTxQueueBytes - tx_size_, kTxQueueBytes - tail);
    const std::size_t n = device_->take_tx(std::span<std::uint8_t>{tx_queue_.data() + tail, room});
    if (n == 0) break;
    TEAMSCAN_EXPECTS(n <= room);
    if (!plugged) {
      stats_.dropped_while_unplugged += n;
      continue;
    }
    if (tx_size_ == 0) {
      tx_baud_ = device_baud;
      tx_origin_ = std::max(now, line_free_at_);
    }
    tx_size_ += n;
  }

  // Queue -> host: a byte is released once its last bit would have arrived.
  bool blocked = false;
  if (plugged && tx_size_ > 0) {
    std::size_t due = tx_size_;
    if (options_.pace_tx) due = std::min<std::size_t>(tx_size_, static_cast<std::size_t>(bytes_in(now - tx_origin_, tx_baud_)));
    const bool mismatch = options_.garble_on_mismatch && host_baud != tx_baud_;
    std::array<std::uint8_t, kSerialRxChunk> out{};
    while (due > 0) {
      const std::size_t len = std::min({due, kTxQueueBytes - tx_head_, out.size()});
      std::copy_n(tx_queue_.begin() + static_cast<std::ptrdiff_t>(tx_head_), len, out.begin());
      if (mismatch) to_host_garbler_.garble(std::span<std::uint8_t>{out.data(), len});
      const SysResult w = posix_call([&] { return ::write(pty_.master_fd(), out.data(), len); });
      std::size_t written = 0;
      if (w.ok()) {
        written = static_cast<std::size_t>(w.value);
      } else if (w.err != EAGAIN && w.err != EWOULDBLOCK) {
        ++stats_.io_errors;
        return Error{"write to pty master failed", w.err};
      }
      record_chunk(now, CaptureDirection::rx, std::span<const std::uint8_t>{out.data(), written});
      if (mismatch) stats_.garbled_bytes += written;
      stats_.bytes_to_host += written;
      tx_head_ = (tx_head_ + written) % kTxQueueBytes;
      tx_size_ -= written;
      due -= written;
      if (options_.pace_tx) tx_origin_ += serial_transmission_time(static_cast<std::int64_t>(written), tx_baud_);
      if (written < len) {
        blocked = true;  // the host is not reading: its input queue is full
        break;
      }
    }
    if (tx_size_ == 0) line_free_at_ = options_.pace_tx ? tx_origin_ : now;
  }

  Time next = device_->next_deadline();
  if (plugged && tx_size_ > 0) {
    const Time release = options_.pace_tx ? tx_origin_ + byte_time(tx_baud_) : now;
    next = std::min(next, blocked ? now + 1ms : release);
  }
  wait = std::clamp(next - now, Duration::zero(), options_.max_wait);
  return ok_status();
}

Status PtyRunner::step(Duration max_wait) {
  Duration wait{};
  int fd = -1;
  {
    std::lock_guard<std::mutex> lock{mutex_};
    const Status s = step_locked(now_monotonic(), wait);
    if (!s) return s;
    fd = pty_.master_fd();
  }
  wait = std::min(wait, max_wait);
  if (wait <= Duration::zero()) return ok_status();
  const timespec ts = to_timespec(wait);
  if (fd >= 0) {
    // Wakes early when the host writes. The fd may be closed by a concurrent unplug(): then poll
    // returns POLLNVAL at once or waits on nothing, which only ends this sleep early.
    pollfd pfd{fd, POLLIN, 0};
    (void)::ppoll(&pfd, 1, &ts, nullptr);
  } else {
    (void)::nanosleep(&ts, nullptr);
  }
  return ok_status();
}

Status PtyRunner::run_for(Duration d) {
  const Time end = now_monotonic() + d;
  for (Time now = now_monotonic(); now < end; now = now_monotonic()) {
    const Status s = step(std::min(options_.max_wait, end - now));
    if (!s) return s;
  }
  return ok_status();
}

Status PtyRunner::run_until(const std::function<bool()>& pred, Duration timeout) {
  const Time end = now_monotonic() + timeout;
  while (!pred()) {
    const Time now = now_monotonic();
    if (now >= end) return Error{"PtyRunner::run_until: condition not met before the timeout", ETIMEDOUT};
    const Status s = step(std::min(options_.max_wait, end - now));
    if (!s) return s;
  }
  return ok_status();
}

Status PtyRunner::start() {
  if (thread_.joinable()) return Error{"PtyRunner already running", EBUSY};
  stop_requested_ = false;
  thread_ = std::thread([this] {
    while (!stop_requested_.load()) {
      // An I/O fault is counted in stats (io_errors) and the loop carries on, as a device would.
      if (!step(options_.max_wait)) {
        const timespec ts = to_timespec(options_.max_wait);
        (void)::nanosleep(&ts, nullptr);
      }
    }
  });
  return ok_status();
}

void PtyRunner::stop() {
  stop_requested_ = true;
  if (thread_.joinable()) thread_.join();
}

void PtyRunner::unplug() {
  std::lock_guard<std::mutex> lock{mutex_};
  stats_.dropped_while_unplugged += tx_size_;
  tx_size_ = 0;
  tx_head_ = 0;
  stats_.host_baud = 0;
  pty_.close();
}

Status PtyRunner::replug(SerialEndpoint* replacement) {
  std::lock_guard<std::mutex> lock{mutex_};
  if (replacement != nullptr) device_ = replacement;
  stats_.dropped_while_unplugged += tx_size_;
  tx_size_ = 0;
  tx_head_ = 0;
  pty_.close();
  auto pty = PtyPair::create();
  if (!pty) return pty.error();
  pty_ = std::move(*pty);
  if (!options_.link_path.empty()) return pty_.link(options_.link_path);
  return ok_status();
}

Status PtyRunner::record(const std::string& path, DeviceKind kind) {
  std::lock_guard<std::mutex> lock{mutex_};
  auto w = CaptureWriter::create(path, kind, 0);
  if (!w) return w.error();
  capture_ = std::move(*w);
  stats_.host_baud = 0;  // the next step writes the current rate as the first #baud line
  return ok_status();
}

Status PtyRunner::stop_recording() {
  std::lock_guard<std::mutex> lock{mutex_};
  return capture_.close();
}

}  // namespace teamscan::serial
