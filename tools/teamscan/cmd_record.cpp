// `teamscan record --device PATH --link PATH --out FILE.cap`: a transparent pty proxy between a host
// program and a real serial device that records both directions and every baud change the host makes
// (the device side follows the host's rate, so the host can switch rates as it would on the real port).
#include <poll.h>
#include <signal.h>
#include <unistd.h>

#include <csignal>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "common/capture.hpp"
#include "common/clock.hpp"
#include "drivers/serial/pty.hpp"
#include "drivers/serial/serial_port.hpp"
#include "tools/teamscan/subcommand.hpp"

namespace teamscan::tool {
namespace {

using namespace std::chrono_literals;

volatile std::sig_atomic_t g_stop = 0;
void on_stop_signal(int) { g_stop = 1; }

struct RecordOptions {
  std::string device_path;
  std::string link_path;
  std::string out_path;
  std::string device_kind = "arcos";
  std::uint32_t baud = 9600;
  double duration_s = 0;
};

void install_stop_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;  // no SA_RESTART: poll() returns at once
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
  ::signal(SIGPIPE, SIG_IGN);
}

// Writes all of `bytes` to the non-blocking pty master; false if the host stops reading for 2 s.
bool write_master(int fd, const std::uint8_t* data, std::size_t size) {
  const Time give_up = now_monotonic() + 2s;
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = ::write(fd, data + done, size - done);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EINTR) return false;
    if (now_monotonic() > give_up) return false;
    pollfd pfd{fd, POLLOUT, 0};
    (void)::poll(&pfd, 1, 10);
  }
  return true;
}

int run_record(const RecordOptions& opt) {
  const DeviceKind kind = device_kind_from_string(opt.device_kind);
  if (!serial::is_supported_baud(opt.baud)) {
    std::fprintf(stderr, "teamscan record: unsupported --baud %u\n", opt.baud);
    return 2;
  }
  auto device = serial::SerialPort::open(opt.device_path.c_str(), opt.baud);
  if (!device) {
    std::fprintf(stderr, "teamscan record: cannot open %s: %s (%s)\n", opt.device_path.c_str(), device.error().what,
                 std::strerror(device.error().sys_errno));
    return 1;
  }
  auto pty = serial::PtyPair::create();
  if (!pty) {
    std::fprintf(stderr, "teamscan record: %s (%s)\n", pty.error().what, std::strerror(pty.error().sys_errno));
    return 1;
  }
  if (auto s = pty->set_slave_baud(opt.baud); !s) {
    std::fprintf(stderr, "teamscan record: %s\n", s.error().what);
    return 1;
  }
  auto writer = CaptureWriter::create(opt.out_path, kind, opt.baud);
  if (!writer) {
    std::fprintf(stderr, "teamscan record: cannot create %s: %s\n", opt.out_path.c_str(), std::strerror(writer.error().sys_errno));
    return 1;
  }
  if (auto s = pty->link(opt.link_path); !s) {
    std::fprintf(stderr, "teamscan record: cannot create link %s: %s (%s)\n", opt.link_path.c_str(), s.error().what,
                 std::strerror(s.error().sys_errno));
    return 1;
  }
  install_stop_handlers();
  std::fprintf(stderr, "teamscan record: %s <-> %s (%s), recording to %s; Ctrl-C to stop\n", opt.link_path.c_str(),
               opt.device_path.c_str(), pty->slave_path(), opt.out_path.c_str());

  const Time start = now_monotonic();
  const Time end = opt.duration_s > 0 ? start + from_seconds(opt.duration_s) : Time::from_ns(INT64_MAX);
  auto since_start_us = [&] { return (now_monotonic() - start).count() / 1000; };
  std::uint32_t current_baud = opt.baud;
  std::uint64_t to_device = 0, to_host = 0, baud_changes = 0;
  int rc = 0;
  std::vector<std::uint8_t> buf(4096);

  while (g_stop == 0 && now_monotonic() < end) {
    pollfd fds[2] = {{pty->master_fd(), POLLIN, 0}, {device->fd(), POLLIN, 0}};
    (void)::poll(fds, 2, 5);

    // Follow the host's rate before moving its bytes: a host sets the rate and then writes, so once
    // its bytes are readable, a change made before them is visible. The pty gives no notification
    // without EXTPROC (DDS_SYSTEMD.md §6), so the slave's termios is read every turn (≤ 5 ms apart).
    const std::uint32_t host_baud = pty->slave_baud();
    if (host_baud != 0 && host_baud != current_baud) {
      if (auto s = device->set_baud(host_baud); !s)
        std::fprintf(stderr, "teamscan record: device refused %u baud: %s\n", host_baud, s.error().what);
      if (!writer->baud(since_start_us(), host_baud)) rc = 1;
      current_baud = host_baud;
      ++baud_changes;
    }

    // Host -> device.
    for (;;) {
      const ssize_t n = ::read(pty->master_fd(), buf.data(), buf.size());
      if (n <= 0) break;
      const std::span<const std::uint8_t> bytes{buf.data(), static_cast<std::size_t>(n)};
      if (!writer->chunk(since_start_us(), CaptureDirection::tx, bytes)) rc = 1;
      to_device += bytes.size();
      if (auto s = device->write_all(bytes, 2s); !s) {
        std::fprintf(stderr, "teamscan record: device %s lost on write: %s (%s)\n", opt.device_path.c_str(),
                     s.error().what, std::strerror(s.error().sys_errno));
        g_stop = 1;
        rc = 1;
        break;
      }
    }
    // Device -> host.
    for (int round = 0; round < 16 && g_stop == 0; ++round) {
      auto n = device->read(buf, 0ms);
      if (!n) {
        std::fprintf(stderr, "teamscan record: device %s lost: %s (%s)\n", opt.device_path.c_str(), n.error().what,
                     std::strerror(n.error().sys_errno));
        g_stop = 1;
        rc = 1;
        break;
      }
      if (*n == 0) break;
      if (!writer->chunk(since_start_us(), CaptureDirection::rx, std::span<const std::uint8_t>{buf.data(), *n})) rc = 1;
      to_host += *n;
      if (!write_master(pty->master_fd(), buf.data(), *n))
        std::fprintf(stderr, "teamscan record: host is not reading; %zu bytes not delivered (still recorded)\n", *n);
    }
  }
  if (auto s = writer->close(); !s) rc = 1;
  std::fprintf(stderr, "teamscan record: %llu bytes to the device, %llu from it, %llu baud changes -> %s\n",
               static_cast<unsigned long long>(to_device), static_cast<unsigned long long>(to_host),
               static_cast<unsigned long long>(baud_changes), opt.out_path.c_str());
  return rc;
}

const SubcommandRegistration kRecord{
    {"record", "Proxy a serial device through a pty and record both directions to a .cap file",
     [](CLI::App& app) {
       auto opt = std::make_shared<RecordOptions>();
       app.add_option("--device", opt->device_path, "The real serial device (e.g. /dev/ttyUSB0)")->required();
       app.add_option("--link", opt->link_path, "Symlink to create for the host program (e.g. /tmp/ttyLMS)")->required();
       app.add_option("--out", opt->out_path, "Capture file to write (.cap)")->required();
       app.add_option("--device-kind", opt->device_kind, "Device kind for the capture header")
           ->capture_default_str()
           ->check(CLI::IsMember({"arcos", "lms200"}));
       app.add_option("--baud", opt->baud, "Initial rate of the device (the host's later changes are followed)")
           ->capture_default_str();
       app.add_option("--duration", opt->duration_s, "Stop after S seconds (0 = until SIGINT/SIGTERM)")
           ->capture_default_str();
       return [opt] { return run_record(*opt); };
     }}};

}  // namespace
}  // namespace teamscan::tool
