// teamscan-groundstation: receives every robot's poses, scans and status over DDS, stores them in a
// session folder, marks robots that stop as lost, and publishes teamscan/team. A systemd
// Type=notify service: READY=1 once subscribed, WATCHDOG=1 from the loop, STOPPING=1 on SIGTERM.
// The command line and config: daemon_cli.hpp; the parts and their hooks: daemon_wiring.hpp; the run
// loop and the orderly stop: daemon_loop.hpp.
#include <string>

#include "groundstation/station/config.hpp"
#include "groundstation/station/daemon_cli.hpp"
#include "groundstation/station/daemon_loop.hpp"
#include "groundstation/station/daemon_wiring.hpp"
#include "groundstation/station/huge_page_heap.hpp"

int main(int argc, char** argv) {
  using namespace teamscan::station;
  std::string heap_why;
  const HeapPages heap = use_huge_page_heap(argv, &heap_why);  // may re-execute: first, before any thread
  daemon::CommandLine cli;
  if (auto exit = daemon::parse_command_line(argc, argv, cli)) return *exit;
  GroundStationConfig cfg;
  if (auto exit = daemon::load_effective_config(cli, cfg)) return *exit;
  if (cli.check_only) {
    daemon::print_effective_config(cfg);
    return 0;
  }
  daemon::install_stop_signals();
  daemon::Daemon d;
  if (auto exit = daemon::start_daemon(cfg, cli.session_dir, heap, heap_why, d)) return *exit;
  if (auto exit = daemon::run_until_stopped(cfg, d)) return *exit;
  daemon::stop_daemon(d);
  return 0;
}
