// Child-process supervision of the demo (tools/demo/supervisor.hpp) with /bin/sh children.
#include <gtest/gtest.h>

#include <signal.h>
#include <unistd.h>

#include <fstream>
#include <sstream>
#include <thread>

#include "tests/unit/demo/temp_dir.hpp"
#include "tools/demo/supervisor.hpp"

namespace teamscan::demo {
namespace {

Child start(Supervisor& s, const std::string& script, const std::string& log) {
  Child c{"sh", log};
  auto pid = s.spawn({"/bin/sh", "-c", script}, log);
  EXPECT_TRUE(pid.ok());
  if (pid.ok()) c.pid = pid.value();
  return c;
}

std::string read_all(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(Supervisor, ExitCodeAndLog) {
  test::TempDir dir;
  Supervisor s;
  Child c = start(s, "echo out; echo err >&2; exit 3", dir.path() + "/c.log");
  reap(c, true);
  EXPECT_TRUE(c.exited);
  EXPECT_EQ(c.exit_code, 3);
  const std::string log = read_all(dir.path() + "/c.log");
  EXPECT_NE(log.find("out"), std::string::npos);
  EXPECT_NE(log.find("err"), std::string::npos);
}

TEST(Supervisor, ChildrenShareOneProcessGroupLedByTheFirst) {
  test::TempDir dir;
  Supervisor s;
  Child a = start(s, "exec sleep 30", dir.path() + "/a.log");
  Child b = start(s, "exec sleep 30", dir.path() + "/b.log");
  EXPECT_EQ(s.group(), a.pid);
  EXPECT_EQ(::getpgid(a.pid), a.pid);
  EXPECT_EQ(::getpgid(b.pid), a.pid);
  kill_child(a);
  kill_child(b);
  EXPECT_EQ(a.exit_code, 128 + SIGKILL);
  EXPECT_EQ(b.exit_code, 128 + SIGKILL);
}

TEST(Supervisor, StopSendsTermThenKillAfterTheGrace) {
  test::TempDir dir;
  Supervisor s;
  Child polite = start(s, "exec sleep 30", dir.path() + "/p.log");
  stop_child(polite, std::chrono::milliseconds(5000));
  EXPECT_EQ(polite.exit_code, 128 + SIGTERM);
  Child stubborn = start(s, "trap '' TERM; while :; do sleep 0.1; done", dir.path() + "/s.log");
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the trap is set
  const auto t0 = std::chrono::steady_clock::now();
  stop_child(stubborn, std::chrono::milliseconds(300));
  EXPECT_EQ(stubborn.exit_code, 128 + SIGKILL);
  EXPECT_GE(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(300));
}

TEST(Supervisor, AProgramThatCannotStartExits127) {
  test::TempDir dir;
  Supervisor s;
  Child c{"missing", dir.path() + "/m.log"};
  auto pid = s.spawn({"/nonexistent/teamscan-onboard"}, c.log);
  ASSERT_TRUE(pid.ok());
  c.pid = pid.value();
  reap(c, true);
  EXPECT_EQ(c.exit_code, 127);
  EXPECT_NE(read_all(c.log).find("/nonexistent/teamscan-onboard"), std::string::npos);
  EXPECT_FALSE(s.spawn({}, c.log).ok());
}

TEST(Supervisor, CpuTimes) {
  EXPECT_GT(self_cpu_s(), 0.0);
  EXPECT_GE(proc_cpu_s(::getpid()), 0.0);
  EXPECT_EQ(proc_cpu_s(-1), 0.0);
}

}  // namespace
}  // namespace teamscan::demo
