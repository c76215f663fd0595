#!/usr/bin/env bash
# Scale benchmark for the live system: N emulated robots (each an oval in its own cell
# of a large room, down- and up-lasers alternating, LMS-200 at 500 kBd = 75 scans/s) through real
# teamscan-onboard processes and one teamscan-groundstation on loopback DDS, at real time.
# Prints per N: scans sent by the emulated scanners / published by the daemons (their last status) /
# stored by the station (incl. history replays at shutdown) / fused into its live map (does it keep
# up?), missing sequence numbers, CPU seconds over the run (bring-up + run, without the station's final
# model write) of the station, of all daemons together and of the device feeder (the demo process), the
# scan -> stored and scan -> fused-map latency p50/p99 (ms; scan stamp = end of sweep) of the scans
# stamped in the run window, the wall time and the 1-minute load average before/after the run (other
# work on the machine shows there). Per-process detail: outN/summary.json, demoN.log.
#
# VIEW_CLIENTS=K: the station serves its browser view (demo --view PORT) and K WebSocket clients
# (tests/bench/view/view_bench_clients) stay connected through the run; the view column then gives the
# station's peak resident memory (VmHWM, MB) and what the clients received. Without it: no view.
# With SECURITY=both each N runs without and with DDS Security (`teamscan demo --secure`, docs/security.md)
# one after the other (SECURITY=on: secured only); with NETNS=1 each run is in its own network namespace
# (`unshare -n`, root), where only this run's traffic crosses lo: the lo_MB column is the bytes on the
# wire (/proc/net/dev lo, received), obd_cpu1 the CPU of one onboard daemon (all daemons / N).
#
# usage: [MAX_HOLD=S] [FEED_PERIOD=MS] [WRITE_INTERVAL=S] [STATION_METHOD=M] [STATION_ROS2=true|false] [VIEW_CLIENTS=K]
#        [SECURITY=off|on|both] [NETNS=1]
#        tests/bench/scale/run_scale.sh [BUILD_DIR] [DURATION_S] [N ...]
#   default: build/dev, 10 s of robot time, N = 2 8 16 32; MAX_HOLD: onboard [odometry] max_hold_s
#   (unset: the daemon's default); FEED_PERIOD: the demo's --feed-period (0: a thread per pty)
set -u
here="$(cd "$(dirname "$0")" && pwd)"
build="${1:-$here/../../../build/dev}"
duration="${2:-10}"
shift 2 2>/dev/null || shift $#
counts=("$@")
[ ${#counts[@]} -eq 0 ] && counts=(2 8 16 32)
teamscan="$build/tools/teamscan/teamscan"
[ -x "$teamscan" ] || { echo "no $teamscan: build the teamscan, teamscan-onboard, teamscan-groundstation targets" >&2; exit 2; }
work="$(mktemp -d /tmp/teamscan-scale.XXXXXX)"

scenario() {  # N -> scenario TOML on stdout
  local n=$1 cols rows
  cols=$(awk -v n="$n" 'BEGIN { c = int(sqrt(n)); if (c * c < n) c++; print c }')
  rows=$(( (n + cols - 1) / cols ))
  local w h
  # The room is at most 10 x 10 m (the paper's space): N ovals share it, one per cell.
  w=10.0
  h=10.0
  local cw ch
  cw=$(awk -v c="$cols" 'BEGIN { printf "%.3f", 10.0 / c }')
  ch=$(awk -v r="$rows" 'BEGIN { printf "%.3f", 10.0 / r }')
  local sx sy
  sx=$(awk -v c="$cw" 'BEGIN { s = 0.5 * c - 0.45; if (s > 1.5) s = 1.5; printf "%.2f", s }')
  sy=$(awk -v c="$ch" 'BEGIN { s = 0.5 * c - 0.45; if (s > 1.0) s = 1.0; printf "%.2f", s }')
  printf 'name = "scale%d"\nseed = 1\n\n[room]\nsize_m = [%s, %s, 3.0]\n' "$n" "$w" "$h"
  local i
  for ((i = 0; i < n; i++)); do
    local cx cy pitch role
    cx=$(awk -v i="$i" -v c="$cols" -v cw="$cw" 'BEGIN { printf "%.2f", -5.0 + cw * ((i % c) + 0.5) }')
    cy=$(awk -v i="$i" -v c="$cols" -v ch="$ch" 'BEGIN { printf "%.2f", -5.0 + ch * (int(i / c) + 0.5) }')
    if (( i % 2 == 0 )); then pitch=15.0; role=down-laser; else pitch=-20.0; role=up-laser; fi
    cat <<TOML

[[robot]]
id = $((i + 1))
role = "$role"
subclass = "p3at-sh"
speed_mps = 0.3
laps = 5
start_phase = 0.$((i % 10))
  [robot.track]
  kind = "oval"
  center_m = [$cx, $cy]
  semi_axes_m = [$sx, $sy]
  direction = "ccw"
  [robot.laser]
  mount_xyz_m = [0.125, 0.0, 0.462]
  mount_rpy_deg = [0.0, $pitch, 0.0]
  fov_deg = 180
  resolution_deg = 1.0
  baud = 500000
  range_noise_mm = 5.0
TOML
  done
}

extra=()
[ -n "${MAX_HOLD:-}" ] && extra+=(--max-hold "$MAX_HOLD")
[ -n "${FEED_PERIOD:-}" ] && extra+=(--feed-period "$FEED_PERIOD")
[ -n "${WRITE_INTERVAL:-}" ] && extra+=(--write-interval "$WRITE_INTERVAL")
[ -n "${STATION_METHOD:-}" ] && extra+=(--station-method "$STATION_METHOD")
[ -n "${STATION_ROS2:-}" ] && extra+=(--station-ros2 "$STATION_ROS2")
echo "# $(date -u +%FT%TZ) build $build, ${duration} s of robot time + 4 s bring-up, max_hold_s ${MAX_HOLD:-default}, feed period ${FEED_PERIOD:-1} ms, station write_interval_s ${WRITE_INTERVAL:-0}, station method ${STATION_METHOD:-the demo default}, station ros2 ${STATION_ROS2:-true}, view clients ${VIEW_CLIENTS:-none (view off)}"
case "${SECURITY:-off}" in
  both) modes=(plain secure) ;;
  on) modes=(secure) ;;
  *) modes=(plain) ;;
esac
printf '%4s %6s %7s %7s %7s %7s %5s %7s %7s %8s %8s %8s %8s %8s %8s %8s %6s %s %s\n' N mode sent publ stored fused miss gs_cpu obd_cpu obd_cpu1 feed_cpu st_p50 st_p99 fu_p50 fu_p99 lo_MB wall load1 gs_rss_mb
sum() { grep -o "\"$1\": [0-9.e+-]*" "$2" | awk '{ t += $2 } END { printf "%d", t }'; }
val() { grep -o "\"$1\": [0-9.e+-]*" "$2" | head -1 | awk '{ print $2 }'; }
for n in "${counts[@]}"; do
 scenario "$n" > "$work/scale$n.toml"
 for mode in "${modes[@]}"; do
  tag="$n-$mode"
  out="$work/out$tag"
  sec=()
  [ "$mode" = secure ] && sec=(--secure)
  load_before=$(cut -d' ' -f1 /proc/loadavg)
  view=()
  port=""
  if [ -n "${VIEW_CLIENTS:-}" ]; then
    port=$(( 20000 + (RANDOM % 20000) ))
    view=(--view "$port")
  fi
  cmd=("$teamscan" demo --scenario "$work/scale$n.toml" --duration "$duration" --bringup 4 --method direction
       --quiet --out "$out" "${sec[@]}" "${extra[@]}" "${view[@]}")
  if [ "${NETNS:-0}" = 1 ]; then
    # lo of a fresh namespace counts this run's traffic only (every DDS process here uses 127.0.0.1).
    unshare -n bash -c 'ip link set lo up && "$@"; awk "/lo:/ { print \$2 }" /proc/net/dev > "'"$work/lo$tag"'"' \
      bash "${cmd[@]}" > "$work/demo$tag.log" 2>&1 &
  else
    "${cmd[@]}" > "$work/demo$tag.log" 2>&1 &
  fi
  demo_pid=$!
  clients_pid=""
  if [ -n "$port" ]; then
    "$build/tests/bench/view/view_bench_clients" "$port" --clients "$VIEW_CLIENTS" --seconds "$((duration + 60))" \
        > "$work/clients$tag.log" 2>&1 &
    clients_pid=$!
  fi
  # The station's peak resident memory (VmHWM), sampled while it runs (a descendant of the demo).
  rss_kb=0
  while kill -0 "$demo_pid" 2>/dev/null; do
    for gs in $(pgrep -f "teamscan-groundstation --config $out/" 2>/dev/null); do
      hwm=$(awk '/^VmHWM:/ { print $2 }' "/proc/$gs/status" 2>/dev/null)
      [ -n "$hwm" ] && [ "$hwm" -gt "$rss_kb" ] && rss_kb=$hwm
    done
    sleep 1
  done
  wait "$demo_pid"
  if [ -n "$clients_pid" ]; then kill "$clients_pid" 2>/dev/null; wait "$clients_pid" 2>/dev/null; fi
  load_after=$(cut -d' ' -f1 /proc/loadavg)
  s="$out/summary.json"
  if [ ! -f "$s" ]; then echo "N=$n $mode: no summary (see $work/demo$tag.log)"; continue; fi
  lo_mb=nan
  [ -s "$work/lo$tag" ] && lo_mb=$(awk '{ printf "%.1f", $1 / 1e6 }' "$work/lo$tag")
  printf '%4d %6s %7d %7d %7d %7d %5d %7.2f %7.2f %8.3f %8.2f %8.1f %8.1f %8.1f %8.1f %8s %6.1f %s %s\n' "$n" "$mode" \
    "$(sum lms_sent "$s")" "$(sum last_status_published "$s")" "$(sum stored "$s")" "$(val fused_latency_scans "$s")" \
    "$(sum missing "$s")" "$(val station_run_cpu_s "$s")" "$(val onboard_cpu_s "$s")" \
    "$(awk -v c="$(val onboard_cpu_s "$s")" -v n="$n" 'BEGIN { print c / n }')" "$(val feeder_cpu_s "$s")" \
    "$(val latency_ms_p50 "$s")" "$(val latency_ms_p99 "$s")" "$(val fused_latency_ms_p50 "$s")" "$(val fused_latency_ms_p99 "$s")" \
    "$lo_mb" "$(val wall_s "$s")" "$load_before/$load_after" "$((rss_kb / 1024))"
  grep -h "view:" "$out/session/events.log" 2>/dev/null | sed 's/^[0-9]* [^ ]* /    /' | grep -v serving
  [ -n "$clients_pid" ] && sed 's/^/    /' "$work/clients$tag.log"
 done
done
echo "outputs in $work (demoN-MODE.log: the demo's output; outN-MODE/: its folder)"
