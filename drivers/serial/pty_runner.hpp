// PtyRunner: puts a device model (a SerialEndpoint such as an emulated Pioneer or LMS-200) on a
// pseudo-terminal in real time, so that a host program opens it like the real /dev/ttyS*. The pty
// itself moves bytes instantly at any rate (DDS_SYSTEMD.md §6), so the runner adds what a cable
// would: the device's bytes leave no faster than its baud allows (10 bits per byte), and when the
// host's slave rate differs from the device's rate both directions turn to garbage. It can unplug
// and replug the device and record both directions into a capture file.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "common/capture.hpp"
#include "common/result.hpp"
#include "common/time.hpp"
#include "drivers/serial/endpoint.hpp"
#include "drivers/serial/line_model.hpp"
#include "drivers/serial/pty.hpp"

namespace teamscan::serial {

struct PtyRunnerOptions {
  std::string link_path;            // symlink to the slave for the host program ("" = none)
  bool pace_tx = true;              // device -> host at the device's baud (a 9600 device is slow)
  bool garble_on_mismatch = true;   // host rate != device rate: both directions garbled
  Duration max_wait = 5ms;          // longest sleep in one step (bounds stop()/unplug latency)
};

struct PtyRunnerStats {
  std::uint64_t bytes_to_device = 0;
  std::uint64_t bytes_to_host = 0;
  std::uint64_t garbled_bytes = 0;
  std::uint64_t dropped_while_unplugged = 0;  // device bytes sent while no pty was attached
  std::uint64_t io_errors = 0;
  std::uint32_t host_baud = 0;  // the slave's rate as last seen
};

class PtyRunner {
 public:
  // Creates the pty (and the symlink). The device must outlive the runner (or a replug replacing it).
  [[nodiscard]] static Result<std::unique_ptr<PtyRunner>> create(SerialEndpoint& device, PtyRunnerOptions options = {});
  PtyRunner(const PtyRunner&) = delete;
  PtyRunner& operator=(const PtyRunner&) = delete;
  ~PtyRunner();

  // The path the host opens: the symlink if one was given, else /dev/pts/N.
  [[nodiscard]] std::string host_path() const;
  [[nodiscard]] std::uint32_t host_baud() const;

  // Blocking mode: run the device for `d`, or until `pred()` is true (checked every step; an Error
  // when `timeout` passes first). Must not be mixed with start()/stop().
  [[nodiscard]] Status run_for(Duration d);
  [[nodiscard]] Status run_until(const std::function<bool()>& pred, Duration timeout = std::chrono::seconds(60));
  // One step: tick if due, move host bytes to the device, release paced device bytes, then sleep at
  // most `max_wait` until something is due or the host writes.
  [[nodiscard]] Status step(Duration max_wait);

  // Background mode: a thread runs step() until stop(). with_device() runs `f` with the device model
  // under the runner's lock (to drive it from the test while the thread runs).
  [[nodiscard]] Status start();
  void stop();
  [[nodiscard]] bool running() const { return thread_.joinable(); }
  template <class F>
  auto with_device(F&& f) {
    std::lock_guard<std::mutex> lock{mutex_};
    return f(*device_);
  }
  // Runs `f()` under the runner's lock: for a caller that holds its own typed reference to the model.
  template <class F>
  auto locked(F&& f) {
    std::lock_guard<std::mutex> lock{mutex_};
    return f();
  }

  // "Unplug": closes the pty, the host sees EIO/hang-up, the symlink disappears. The device model keeps
  // running; whatever it sends meanwhile is dropped.
  void unplug();
  // "Replug": a new pty behind the same symlink. With `replacement`, that model takes over (a reset or
  // power-cycled device); otherwise the old model carries on.
  [[nodiscard]] Status replug(SerialEndpoint* replacement = nullptr);
  [[nodiscard]] bool plugged() const;

  // Records both directions to `path` (rx = device -> host as delivered, tx = host -> device, #baud =
  // the host's rate), times in µs since the runner was created.
  [[nodiscard]] Status record(const std::string& path, DeviceKind kind);
  [[nodiscard]] Status stop_recording();

  [[nodiscard]] PtyRunnerStats stats() const;

 private:
  PtyRunner(SerialEndpoint& device, PtyRunnerOptions options);
  Status step_locked(Time now, Duration& wait);
  void record_chunk(Time now, CaptureDirection dir, std::span<const std::uint8_t> bytes);
  [[nodiscard]] std::int64_t capture_us(Time t) const { return (t - epoch_).count() / 1000; }

  static constexpr std::size_t kTxQueueBytes = 1u << 16;

  SerialEndpoint* device_;
  PtyRunnerOptions options_;
  PtyPair pty_;
  mutable std::mutex mutex_;
  std::thread thread_;
  std::atomic<bool> stop_requested_{false};
  Status thread_status_ = ok_status();

  // Device -> host queue (ring buffer) and its line timing: the first queued byte started on the wire
  // at tx_origin_; byte k of the queue has fully arrived at tx_origin_ + (k + 1) byte times.
  std::array<std::uint8_t, kTxQueueBytes> tx_queue_{};
  std::size_t tx_head_ = 0;
  std::size_t tx_size_ = 0;
  Time tx_origin_{};
  Time line_free_at_{};
  std::uint32_t tx_baud_ = 9600;  // the device's rate when the queued bytes were handed over

  BaudMismatchGarbler to_device_garbler_{0x1234567u};
  BaudMismatchGarbler to_host_garbler_{0x89ABCDEu};
  CaptureWriter capture_;
  Time epoch_{};
  PtyRunnerStats stats_;
};

}  // namespace teamscan::serial
