// SerialPort and PtyPair over real pseudo-terminals (DDS_SYSTEMD.md §6): bytes, rates, timeouts, EINTR,
// device loss and replug.
#include <gtest/gtest.h>
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <thread>

#include "common/clock.hpp"
#include "drivers/serial/pty.hpp"
#include "drivers/serial/serial_port.hpp"
#include "tests/hil/serial/pty_test_util.hpp"

namespace teamscan::serial {
namespace {

using testing::read_fd;
using testing::TempDir;
using testing::write_fd;
using namespace std::chrono_literals;

std::vector<std::uint8_t> all_byte_values() {
  std::vector<std::uint8_t> v(256);
  for (int i = 0; i < 256; ++i) v[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(i);
  return v;
}

// Reads from a SerialPort until `want` bytes or `timeout`.
std::vector<std::uint8_t> read_port(SerialPort& port, std::size_t want, Duration timeout) {
  std::vector<std::uint8_t> out;
  const Time deadline = now_monotonic() + timeout;
  while (out.size() < want && now_monotonic() < deadline) {
    std::uint8_t buf[512];
    auto n = port.read(buf, 20ms);
    if (!n) break;
    out.insert(out.end(), buf, buf + *n);
  }
  return out;
}

TEST(SerialPortTest, AllByteValuesPassBothWays) {
  auto pty = PtyPair::create();
  ASSERT_TRUE(pty.ok()) << pty.error().what;
  auto port = SerialPort::open(pty->slave_path(), 9600);
  ASSERT_TRUE(port.ok()) << port.error().what;
  const auto bytes = all_byte_values();

  ASSERT_TRUE(port->write_all(bytes, 1s).ok());
  EXPECT_EQ(read_fd(pty->master_fd(), bytes.size(), 2000ms), bytes);

  ASSERT_TRUE(write_fd(pty->master_fd(), bytes));
  EXPECT_EQ(read_port(*port, bytes.size(), 2s), bytes);
}

TEST(SerialPortTest, EveryRateIsSetAndReadBackIncluding500000) {
  auto pty = PtyPair::create();
  ASSERT_TRUE(pty.ok());
  auto port = SerialPort::open(pty->slave_path(), 9600);
  ASSERT_TRUE(port.ok());
  EXPECT_EQ(pty->slave_baud(), 9600u);
  for (std::uint32_t rate : {1200u, 2400u, 4800u, 9600u, 19200u, 38400u, 57600u, 115200u, 230400u, 500000u}) {
    SCOPED_TRACE(rate);
    EXPECT_TRUE(is_supported_baud(rate));
    ASSERT_TRUE(port->set_baud(rate).ok());
    EXPECT_EQ(port->baud(), rate);
    EXPECT_EQ(pty->slave_baud(), rate);  // what the device side (master) sees
  }
}

TEST(SerialPortTest, UnsupportedRateIsAnErrorAndKeepsTheOldRate) {
  auto pty = PtyPair::create();
  ASSERT_TRUE(pty.ok());
  auto port = SerialPort::open(pty->slave_path(), 38400);
  ASSERT_TRUE(port.ok());
  for (std::uint32_t rate : {0u, 12345u, 250000u, 1000000u}) {
    EXPECT_FALSE(is_supported_baud(rate));
    EXPECT_FALSE(port->set_baud(rate).ok());
  }
  EXPECT_EQ(port->baud(), 38400u);
  EXPECT_EQ(pty->slave_baud(), 38400u);
  EXPECT_FALSE(SerialPort::open(pty->slave_path(), 12345).ok());
}

TEST(SerialPortTest, OpenFailsCleanlyOnMissingOrNonTtyPaths) {
  auto missing = SerialPort::open("/nonexistent/ttyS99", 9600);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().sys_errno, ENOENT);
  auto not_tty = SerialPort::open("/dev/null", 9600);
  EXPECT_FALSE(not_tty.ok());
}

TEST(SerialPortTest, ReadTimesOutWithZeroAfterAtLeastTheTimeout) {
  auto pty = PtyPair::create();
  ASSERT_TRUE(pty.ok());
  auto port = SerialPort::open(pty->slave_path(), 9600);
  ASSERT_TRUE(port.ok());
  std::uint8_t buf[16];
  const Time t0 = now_monotonic();
  auto n = port->read(buf, 80ms);
  const Duration waited = now_monotonic() - t0;
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(*n, 0u);
  EXPECT_GE(waited, 80ms);
  auto zero = port->read(buf, 0ms);
  ASSERT_TRUE(zero.ok());
  EXPECT_EQ(*zero, 0u);
}

std::atomic<int> g_signals{0};
void count_signal(int) { g_signals.fetch_add(1); }

TEST(SerialPortTest, SignalDuringReadIsRetriedNotAnError) {
  // A handler without SA_RESTART makes poll()/read() fail with EINTR; the port must retry.
  struct sigaction sa {};
  sa.sa_handler = count_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;
  struct sigaction old {};
  ASSERT_EQ(::sigaction(SIGUSR1, &sa, &old), 0);
  g_signals = 0;

  auto pty = PtyPair::create();
  ASSERT_TRUE(pty.ok());
  auto port = SerialPort::open(pty->slave_path(), 9600);
  ASSERT_TRUE(port.ok());
  const pthread_t reader = ::pthread_self();
  const int master = pty->master_fd();
  std::thread poker([reader, master] {
    std::this_thread::sleep_for(60ms);
    ::pthread_kill(reader, SIGUSR1);
    std::this_thread::sleep_for(60ms);
    ::pthread_kill(reader, SIGUSR1);
    std::this_thread::sleep_for(60ms);
    const std::uint8_t msg[] = {0xFA, 0xFB, 0x03};
    (void)!::write(master, msg, sizeof msg);
  });
  std::vector<std::uint8_t> got;
  const Time deadline = now_monotonic() + 3s;
  while (got.size() < 3 && now_monotonic() < deadline) {
    std::uint8_t buf[8];
    auto n = port->read(buf, 2s);
    ASSERT_TRUE(n.ok()) << n.error().what;
    got.insert(got.end(), buf, buf + *n);
  }
  poker.join();
  ::sigaction(SIGUSR1, &old, nullptr);
  EXPECT_EQ(g_signals.load(), 2);
  EXPECT_EQ(got, (std::vector<std::uint8_t>{0xFA, 0xFB, 0x03}));
}

TEST(SerialPortTest, FlushInputDiscardsPendingBytes) {
  auto pty = PtyPair::create();
  ASSERT_TRUE(pty.ok());
  auto port = SerialPort::open(pty->slave_path(), 9600);
  ASSERT_TRUE(port.ok());
  ASSERT_TRUE(write_fd(pty->master_fd(), {1, 2, 3, 4}));
  std::this_thread::sleep_for(50ms);  // let the pty move the bytes to the slave's queue
  ASSERT_TRUE(port->flush_input().ok());
  std::uint8_t buf[8];
  auto n = port->read(buf, 50ms);
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(*n, 0u);
  ASSERT_TRUE(write_fd(pty->master_fd(), {9}));
  EXPECT_EQ(read_port(*port, 1, 1s), std::vector<std::uint8_t>{9});
}

TEST(SerialPortTest, DrainReturnsOnceOutputIsSent) {
  auto pty = PtyPair::create();
  ASSERT_TRUE(pty.ok());
  auto port = SerialPort::open(pty->slave_path(), 500000);
  ASSERT_TRUE(port.ok());
  ASSERT_TRUE(port->write_all(all_byte_values(), 1s).ok());
  EXPECT_TRUE(port->drain(1s).ok());
  EXPECT_EQ(read_fd(pty->master_fd(), 256, 1000ms).size(), 256u);
}

TEST(SerialPortTest, DeviceLossIsAnErrorAndThePortReopensAfterReplug) {
  TempDir dir;
  const std::string link = (dir.path / "ttyLMS").string();
  auto pty = PtyPair::create();
  ASSERT_TRUE(pty.ok());
  ASSERT_TRUE(pty->link(link).ok());
  auto port = SerialPort::open(link.c_str(), 9600);
  ASSERT_TRUE(port.ok()) << port.error().what;

  pty->close();  // unplug
  EXPECT_FALSE(std::filesystem::exists(std::filesystem::symlink_status(link)));
  std::uint8_t buf[8];
  auto n = port->read(buf, 500ms);
  ASSERT_FALSE(n.ok());
  EXPECT_NE(n.error().sys_errno, 0);
  const std::uint8_t msg[] = {0x02, 0x80};
  EXPECT_FALSE(port->write_all(msg, 200ms).ok());
  // Reopening while unplugged fails as a value too.
  EXPECT_FALSE(SerialPort::open(link.c_str(), 9600).ok());

  auto replug = PtyPair::create();  // replug: a new pty behind the same name
  ASSERT_TRUE(replug.ok());
  ASSERT_TRUE(replug->link(link).ok());
  port->close();
  EXPECT_FALSE(port->is_open());
  auto again = SerialPort::open(link.c_str(), 38400);
  ASSERT_TRUE(again.ok()) << again.error().what;
  EXPECT_EQ(replug->slave_baud(), 38400u);
  ASSERT_TRUE(again->write_all(msg, 200ms).ok());
  EXPECT_EQ(read_fd(replug->master_fd(), 2, 1000ms), (std::vector<std::uint8_t>{0x02, 0x80}));
}

TEST(SerialPortTest, ClosedOrMovedFromPortReportsErrors) {
  auto pty = PtyPair::create();
  ASSERT_TRUE(pty.ok());
  auto port = SerialPort::open(pty->slave_path(), 9600);
  ASSERT_TRUE(port.ok());
  SerialPort moved = std::move(*port);
  EXPECT_TRUE(moved.is_open());
  EXPECT_FALSE(port->is_open());
  std::uint8_t buf[4];
  EXPECT_FALSE(port->read(buf, 1ms).ok());
  EXPECT_FALSE(port->set_baud(9600).ok());
  EXPECT_FALSE(port->flush_input().ok());
  EXPECT_FALSE(port->drain(1ms).ok());
}

TEST(PtyPairTest, LinkIsReplacedAtomicallyAndRemovedOnlyByItsOwner) {
  TempDir dir;
  const auto link = dir.path / "ttyP0";
  auto a = PtyPair::create();
  auto b = PtyPair::create();
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_STRNE(a->slave_path(), b->slave_path());
  ASSERT_TRUE(a->link(link.string()).ok());
  EXPECT_EQ(std::filesystem::read_symlink(link).string(), a->slave_path());
  ASSERT_TRUE(b->link(link.string()).ok());  // replaces a's link
  EXPECT_EQ(std::filesystem::read_symlink(link).string(), b->slave_path());
  a->close();  // a no longer owns the name: the link stays
  EXPECT_EQ(std::filesystem::read_symlink(link).string(), b->slave_path());
  {
    PtyPair moved = std::move(*b);
    EXPECT_FALSE(b->is_open());
  }  // destruction removes the link
  EXPECT_FALSE(std::filesystem::exists(std::filesystem::symlink_status(link)));
}

TEST(PtyPairTest, SlaveIsRawAndMasterSurvivesHostReopen) {
  auto pty = PtyPair::create();
  ASSERT_TRUE(pty.ok());
  {
    auto host = SerialPort::open(pty->slave_path(), 9600);
    ASSERT_TRUE(host.ok());
  }  // the host closes its port; the pair's own slave fd keeps the master usable
  ASSERT_TRUE(write_fd(pty->master_fd(), {'\n', '\r', 0x03}));
  auto host = SerialPort::open(pty->slave_path(), 9600);
  ASSERT_TRUE(host.ok());
  // Raw mode: no CR/LF mapping, no echo, no signal characters; the bytes queued while the host was away
  // are still there, as on a real UART.
  EXPECT_EQ(read_port(*host, 3, 1s), (std::vector<std::uint8_t>{'\n', '\r', 0x03}));
  EXPECT_TRUE(read_fd(pty->master_fd(), 1, 50ms).empty());  // nothing echoed
}

}  // namespace
}  // namespace teamscan::serial
