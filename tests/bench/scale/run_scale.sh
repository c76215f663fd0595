#!/usr/bin/env bash
# Scale benchmark for the live system (issue 6 "Scale"): N emulated robots (each an oval in its own cell
# of a large room, down- and up-lasers alternating, LMS-200 at 500 kBd = 75 scans/s) through real
# teamscan-onboard processes and one teamscan-groundstation on loopback DDS, at real time.
# Prints per N: scans stored vs sent (does the station keep up?), missing scans, the station's CPU,
# and the scan -> stored latency p50/p99 (scan stamp = end of sweep, to the station's write).
#
# usage: tests/bench/scale/run_scale.sh [BUILD_DIR] [DURATION_S] [N ...]
#   default: build/dev, 10 s of robot time, N = 2 8 16 32
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

printf '%4s %9s %9s %8s %8s %10s %10s %10s %8s\n' N sent stored missing cpu_s cpu_%core p50_ms p99_ms wall_s
for n in "${counts[@]}"; do
  scenario "$n" > "$work/scale$n.toml"
  out="$work/out$n"
  "$teamscan" demo --scenario "$work/scale$n.toml" --duration "$duration" --bringup 4 --method direction \
      --quiet --out "$out" > "$work/demo$n.log" 2>&1
  s="$out/summary.json"
  if [ ! -f "$s" ]; then echo "N=$n: no summary (see $work/demo$n.log)"; continue; fi
  sent=$(grep -o '"lms_sent": [0-9]*' "$s" | awk '{ t += $2 } END { print t }')
  stored=$(grep -o '"stored": [0-9]*' "$s" | awk '{ t += $2 } END { print t }')
  missing=$(grep -o '"missing": [0-9]*' "$s" | awk '{ t += $2 } END { print t }')
  cpu=$(grep -o '"station_cpu_s": [0-9.e+-]*' "$s" | awk '{ print $2 }')
  p50=$(grep -o '"latency_ms_p50": [0-9.e+-]*' "$s" | awk '{ print $2 }')
  p99=$(grep -o '"latency_ms_p99": [0-9.e+-]*' "$s" | awk '{ print $2 }')
  wall=$(grep -o '"wall_s": [0-9.e+-]*' "$s" | awk '{ print $2 }')
  pct=$(awk -v c="$cpu" -v d="$duration" 'BEGIN { printf "%.1f", 100 * c / (d + 4) }')
  printf '%4d %9d %9d %8d %8.2f %10s %10.1f %10.1f %8.1f\n' "$n" "$sent" "$stored" "$missing" "$cpu" "$pct" "$p50" "$p99" "$wall"
done
echo "outputs in $work"
