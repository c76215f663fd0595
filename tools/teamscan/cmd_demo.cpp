// `teamscan demo`: the command line of the live demo; tools/demo/demo.hpp runs it (docs/demo.md).
#include <memory>

#include "tools/demo/demo.hpp"
#include "tools/teamscan/subcommand.hpp"

namespace teamscan::tool {
namespace {

const SubcommandRegistration kDemo{
    {"demo", "Run the whole system live (emulated robots, onboard daemons, ground station) and score the result",
     [](CLI::App& app) {
       auto a = std::make_shared<demo::DemoOptions>();
       app.add_option("--scenario", a->scenario, "lap2, fig8 or a scenario TOML file")->capture_default_str();
       app.add_option("--speed", a->speed, "World seconds per wall-clock second (1 = real time; see docs/demo.md)")
           ->capture_default_str()
           ->check(CLI::PositiveNumber);
       app.add_flag("--force-speed", a->force_speed,
                    "Run above real time anyway (the live ghost filters then see teammates --speed times staler)");
       app.add_option("--robots", a->robots, "Use only the first N robots of the scenario");
       app.add_option("--duration", a->duration_s, "Seconds of robot time (default: the scenario's)")
           ->check(CLI::PositiveNumber);
       app.add_option("--out", a->out, "Output folder (session, logs, configs, reports, PCD, pictures)")
           ->capture_default_str();
       app.add_option("--seed", a->seed, "Override the scenario's seed");
       app.add_option("--bringup", a->bringup_s, "Seconds for device bring-up before the robots drive")
           ->capture_default_str();
       app.add_option("--domain", a->domain, "DDS domain id (default: derived from the pid)");
       app.add_option(
           "--dds-config", a->dds_config,
           "Cyclone DDS config (default: the installed share/teamscan/cyclonedds-lo.xml; deploy/ in a build tree)");
       app.add_option("--onboard-bin", a->onboard_bin, "teamscan-onboard executable (default: found next to teamscan)");
       app.add_option("--station-bin", a->station_bin, "teamscan-groundstation executable (default: found)");
       app.add_option("--tolerance-da", a->tolerance_da_pct, "Allowed |live DA − offline DA| in points")
           ->capture_default_str();
       app.add_option("--tolerance-sa", a->tolerance_sa_pct, "Allowed |live SA − offline SA| in points")
           ->capture_default_str();
       app.add_option("--tolerance-map-da", a->tolerance_map_da_pct, "Allowed |ΔDA| for frequency/visibility/combined")
           ->capture_default_str();
       app.add_option("--tolerance-map-sa", a->tolerance_map_sa_pct, "Allowed |ΔSA| for frequency/visibility/combined")
           ->capture_default_str();
       app.add_option("--method", a->methods, "Methods as in `teamscan eval --method`")->capture_default_str();
       app.add_flag("--quiet", a->quiet,
                    "No progress on stderr (events such as faults and the view's address, and the summary on stdout, "
                    "still print)");
       app.add_option("--kill-station-at", a->kill_station_at_s,
                      "Fault: SIGKILL the ground station at this world time");
       app.add_option("--station-down", a->station_down_s, "Fault: ...and restart it this many seconds later")
           ->capture_default_str();
       app.add_option("--unplug-robot", a->unplug_robot, "Fault: unplug this robot's laser pty");
       app.add_option("--unplug-at", a->unplug_at_s, "Fault: ...at this world time")->capture_default_str();
       app.add_option("--unplug-for", a->unplug_for_s, "Fault: ...for this many seconds")->capture_default_str();
       app.add_option("--kill-robot", a->kill_robot, "Fault: SIGKILL this robot's onboard daemon");
       app.add_option("--kill-robot-at", a->kill_robot_at_s, "Fault: ...at this world time")->capture_default_str();
       app.add_option("--max-hold", a->max_hold_s,
                      "Onboard [odometry] max_hold_s: how long a scan waits for its covering SIP (0: publish at once)")
           ->check(CLI::Range(0.0, 0.2));
       app.add_option("--write-interval", a->write_interval_s,
                      "Station [fusion] write_interval_s: periodic fused-model writes (written off the receive loop)")
           ->capture_default_str()
           ->check(CLI::Range(0.0, 3600.0));
       app.add_option(
              "--feed-period", a->feed_period_ms,
              "Device feeder: one thread steps every pty this often, ms (0: a thread per pty, byte-exact pacing)")
           ->capture_default_str()
           ->check(CLI::Range(0.0, 10.0));
       app.add_option("--view", a->view_port,
                      "Serve the station's browser view on 127.0.0.1:PORT during the demo (docs/view.md)")
           ->check(CLI::Range(1, 65535));
       app.add_flag("--no-precast", a->no_precast, "Cast every scan in real time instead of ahead, during bring-up");
       app.add_flag(
           "--secure", a->secure,
           "DDS Security: a throwaway site PKI in <out>/pki, every daemon authenticated, encrypted, access-controlled");
       app.add_option("--station-method", a->station_method,
                      "The ground station's live fusion method ([fusion] method)")
           ->capture_default_str();
       app.add_option("--station-compare", a->station_compare,
                      "The station's [fusion] compare_methods, each model checked against eval: paper (the paper's "
                      "methods and best), none, or a comma-separated list")
           ->capture_default_str();
       app.add_option("--station-ros2", a->station_ros2,
                      "The station's ROS 2 publishers ([ros2] enabled: rt/teamscan/map_cloud, rt/tf, rt/robotN/odom)")
           ->capture_default_str();
       auto* reg_on = app.add_flag_callback(
           "--registration", [a] { a->registration = true; },
           "Scan-to-map registration in the station's fusion core ([registration]) and in the demo's evaluations "
           "(default: on when the scenario's robots drift; docs/demo.md \"Registration\")");
       auto* reg_off = app.add_flag_callback(
           "--no-registration", [a] { a->registration = false; },
           "Odometry alone, also for a scenario whose robots drift");
       reg_on->excludes(reg_off);
       auto* graph_on = app.add_flag_callback(
           "--pose-graph", [a] { a->pose_graph = true; },
           "The pose graph as the station's back end ([pose_graph], the default; with --no-registration the graph over "
           "odometry alone): the report gives its poses' error against the truth beside odometry's and the "
           "registration's (docs/slam.md \"The back end\")");
       auto* graph_off = app.add_flag_callback("--no-pose-graph", [a] { a->pose_graph = false; },
                                               "No pose graph at the station ([pose_graph] enabled = false)");
       graph_on->excludes(graph_off);
       app.add_option("--calibration", a->calibration_path,
                      "Each robot's odometry prior for the registration (`teamscan calibrate`'s output): appended to "
                      "the station's config, taken by the demo's evaluations (docs/registration.md)")
           ->check(CLI::ExistingFile)
           ->excludes(reg_off);
       app.add_option("--link-loss", a->link_loss,
                      "Link fault: drop this share of the datagrams every process sends (\"20\" or \"20%\": percent, "
                      "\"200pm\": per mille); every process in a network namespace (root; docs/radio.md)");
       app.add_option("--shadow", a->shadows,
                      "Link fault ROBOT:AT:FOR: the robot's radio link down at world time AT for FOR seconds "
                      "(repeatable; network namespaces, root)");
       app.add_option("--netns-prefix", a->netns_prefix, "Names of the link faults' network namespaces start with "
                                                          "this (default: tsdemo<pid>-)");
       return [a] { return demo::run_demo(*a); };
     }}};

}  // namespace
}  // namespace teamscan::tool
