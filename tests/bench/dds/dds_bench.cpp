// DDS bridge benchmarks (figures, not pass/fail): encode cost, publish_scan cost and allocations per
// write, and publish->take latency of a 401-point scan on loopback between two processes (ping-pong:
// this process publishes on teamscan/scan through DdsBridge, a child echoes each sample back on
// teamscan/bench_pong; one-way latency = round trip / 2). Run with the loopback config:
//   CYCLONEDDS_URI=file://$PWD/deploy/cyclonedds-lo.xml build/dev/tests/bench/dds/dds_bench
#include <benchmark/benchmark.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <dds/dds.h>

#include "common/clock.hpp"
#include "onboard/bridge/bridge.hpp"
#include "dds/qos.hpp"
#include "teamscan.h"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/test_domain.hpp"

namespace {

using namespace teamscan;
using namespace teamscan::onboard;
using namespace teamscan::dds;
constexpr const char* kPongTopic = "teamscan/bench_pong";

ScanPoints& full_scan(std::uint32_t robot) {
  static ScanPoints s;
  s.robot_id = robot;
  s.count = kMaxBeams;
  for (std::uint16_t b = 0; b < kMaxBeams; ++b) s.points[b] = ScanPoint{b * 10, -b * 10, 300, b, 0};
  return s;
}

void BM_EncodeScan(benchmark::State& state) {
  ScanPoints& in = full_scan(1);
  static teamscan_msg_ScanPoints out;
  for (auto _ : state) {
    encode_scan(in, out);
    benchmark::DoNotOptimize(out.points[400].x_mm);
  }
}
BENCHMARK(BM_EncodeScan);

// publish_scan with no reader matched: the cost of encoding + serialising + the writer history.
void BM_PublishScan(benchmark::State& state) {
  DdsBridgeOptions o;
  o.robot_id = 2;
  o.domain_id = test::test_domain_id();
  auto b = DdsBridge::create(o);
  if (!b) {
    state.SkipWithError(b.error().what);
    return;
  }
  ScanPoints& s = full_scan(2);
  for (std::uint32_t i = 0; i < 2 * o.scan_history_depth; ++i) {  // fill the history first
    s.seq = i;
    (void)b->publish_scan(s);
  }
  const test::AllocStats before = test::thread_alloc_stats();
  std::uint64_t n = 0;
  for (auto _ : state) {
    s.seq = static_cast<std::uint32_t>(++n);
    benchmark::DoNotOptimize(b->publish_scan(s).ok());
  }
  const test::AllocStats d = test::thread_alloc_stats() - before;
  state.counters["allocs_per_write"] = static_cast<double>(d.allocs) / static_cast<double>(n);
  state.counters["bytes_per_write"] = static_cast<double>(d.bytes) / static_cast<double>(n);
}
BENCHMARK(BM_PublishScan);

pid_t g_pong = -1;

void start_pong() {
  if (g_pong > 0) return;
  (void)test::test_domain_id();  // fix the id before forking
  g_pong = ::fork();
  if (g_pong == 0) {
    const std::string domain = test::test_domain_arg();  // the parent's id (pid-derived), not the child's
    ::execl("/proc/self/exe", "dds_bench", "--pong", domain.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
}

// Round trips at a given rate (0 = flat out); reports one-way p50/p99/max in microseconds.
void BM_PublishToTakeLatency(benchmark::State& state) {
  start_pong();
  DdsBridgeOptions o;
  o.robot_id = 3;
  o.domain_id = test::test_domain_id();
  auto b = DdsBridge::create(o);
  if (!b) {
    state.SkipWithError(b.error().what);
    return;
  }
  const dds_entity_t pp = dds_create_participant(test::test_domain_id(), nullptr, nullptr);
  const dds_entity_t tp = dds_create_topic(pp, &teamscan_msg_ScanPoints_desc, kPongTopic, nullptr, nullptr);
  dds_qos_t* q = make_scan_reader_qos();
  dds_qset_durability(q, DDS_DURABILITY_VOLATILE);
  const dds_entity_t rd = dds_create_reader(pp, tp, q, nullptr);
  dds_delete_qos(q);
  const dds_entity_t ws = dds_create_waitset(pp);
  const dds_entity_t rc = dds_create_readcondition(rd, DDS_ANY_STATE);
  dds_waitset_attach(ws, rc, 0);
  // Wait for both directions to match.
  for (int i = 0; i < 1000; ++i) {
    dds_subscription_matched_status_t st{};
    dds_get_subscription_matched_status(rd, &st);
    if (st.current_count > 0 && b->scan_subscribers() > 0) break;
    dds_sleepfor(DDS_MSECS(10));
  }
  static teamscan_msg_ScanPoints rx;
  void* buf[1] = {&rx};
  dds_sample_info_t info;
  ScanPoints& s = full_scan(3);
  const double rate_hz = static_cast<double>(state.range(0));
  std::vector<double> one_way_us;
  one_way_us.reserve(100000);
  std::uint32_t seq = 0;
  std::uint64_t lost = 0;
  Time next = now_monotonic();
  const test::AllocStats before = test::thread_alloc_stats();
  std::uint64_t writes = 0;
  for (auto _ : state) {
    if (rate_hz > 0) {
      next += from_seconds(1.0 / rate_hz);
      const Duration wait = next - now_monotonic();
      if (wait.count() > 0) dds_sleepfor(wait.count());
    }
    s.seq = ++seq;
    const Time t0 = now_monotonic();
    (void)b->publish_scan(s);
    ++writes;
    bool got = false;
    while (!got) {
      dds_attach_t trig;
      if (dds_waitset_wait(ws, &trig, 1, DDS_SECS(1)) <= 0) break;
      while (dds_take(rd, buf, &info, 1, 1) > 0) {
        if (info.valid_data && rx.seq == seq) got = true;
      }
    }
    const Time t1 = now_monotonic();
    if (got) {
      one_way_us.push_back(static_cast<double>((t1 - t0).count()) / 2000.0);
    } else {
      ++lost;
    }
  }
  const test::AllocStats d = test::thread_alloc_stats() - before;
  std::sort(one_way_us.begin(), one_way_us.end());
  auto pct = [&](double p) {
    if (one_way_us.empty()) return 0.0;
    return one_way_us[std::min(one_way_us.size() - 1, static_cast<std::size_t>(p * static_cast<double>(one_way_us.size())))];
  };
  state.counters["one_way_p50_us"] = pct(0.50);
  state.counters["one_way_p99_us"] = pct(0.99);
  state.counters["one_way_max_us"] = one_way_us.empty() ? 0.0 : one_way_us.back();
  state.counters["lost"] = static_cast<double>(lost);
  // Allocations on this thread per round trip: the write (3) plus the take of the echo.
  state.counters["allocs_per_roundtrip"] = static_cast<double>(d.allocs) / static_cast<double>(writes);
  dds_delete(pp);
}
BENCHMARK(BM_PublishToTakeLatency)->Arg(0)->Iterations(5000)->UseRealTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_PublishToTakeLatency)->Arg(75)->Iterations(750)->UseRealTime()->Unit(benchmark::kMicrosecond);

volatile sig_atomic_t g_stop = 0;
void on_term(int) { g_stop = 1; }

// The echo process: takes every teamscan/scan sample and writes it back on teamscan/bench_pong.
int run_pong(dds_domainid_t domain) {
  signal(SIGTERM, on_term);
  const dds_entity_t pp = dds_create_participant(domain, nullptr, nullptr);
  const dds_entity_t tp_in = dds_create_topic(pp, &teamscan_msg_ScanPoints_desc, kTopicScan, nullptr, nullptr);
  const dds_entity_t tp_out = dds_create_topic(pp, &teamscan_msg_ScanPoints_desc, kPongTopic, nullptr, nullptr);
  dds_qos_t* q = make_scan_reader_qos();
  dds_qset_durability(q, DDS_DURABILITY_VOLATILE);
  const dds_entity_t rd = dds_create_reader(pp, tp_in, q, nullptr);
  dds_delete_qos(q);
  q = make_scan_writer_qos(1, 8, std::chrono::seconds(2), std::chrono::milliseconds(10));
  dds_qset_durability(q, DDS_DURABILITY_VOLATILE);
  const dds_entity_t wr = dds_create_writer(pp, tp_out, q, nullptr);
  dds_delete_qos(q);
  if (rd < 0 || wr < 0) return 1;
  const dds_entity_t ws = dds_create_waitset(pp);
  const dds_entity_t rc = dds_create_readcondition(rd, DDS_ANY_STATE);
  dds_waitset_attach(ws, rc, 0);
  static teamscan_msg_ScanPoints s;
  void* buf[1] = {&s};
  dds_sample_info_t info;
  while (g_stop == 0 && getppid() != 1) {
    dds_attach_t trig;
    if (dds_waitset_wait(ws, &trig, 1, DDS_MSECS(200)) <= 0) continue;
    while (dds_take(rd, buf, &info, 1, 1) > 0) {
      if (info.valid_data) (void)dds_write(wr, &s);
    }
  }
  dds_delete(pp);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 3 && std::strcmp(argv[1], "--pong") == 0) {
    return run_pong(static_cast<dds_domainid_t>(std::strtoul(argv[2], nullptr, 10)));
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (g_pong > 0) {
    ::kill(g_pong, SIGTERM);
    int st = 0;
    ::waitpid(g_pong, &st, 0);
  }
  return 0;
}
