#!/usr/bin/env bash
# Memory soak of teamscan-onboard ("resident memory ... flat over an hour of streaming"): one
# emulated robot (lap2 robot 1, `teamscan emulate --loop`: Pioneer + LMS-200 on ptys fed by the
# simulator in real time), the real daemon, and a DDS sink that reads and drops every scan
# (`teamscan_dds_test_peer drain`), all on the loopback Cyclone config. Samples the daemon's
# VmRSS/VmHWM from /proc every 10 s and prints start/min/max/end, the least-squares slope in KiB/hour
# and the daemon's CPU share. A benchmark: it prints figures and never fails on them.
#
#   tests/bench/onboard/rss_soak.sh [BUILD_DIR] [MINUTES]        (defaults: build/dev 60)
#   env: SOAK_OUT=DIR keeps the logs and samples there (default: a temporary folder, kept and printed)
#        SOAK_SAMPLE_S=10  SOAK_WARMUP_SCANS=600 (scans the sink must have read before "start": the
#        daemon's 300-scan transient-local history is full by then)
set -u

repo=$(cd "$(dirname "$0")/../../.." && pwd)
build=${1:-$repo/build/dev}
minutes=${2:-60}
sample_s=${SOAK_SAMPLE_S:-10}
warmup_scans=${SOAK_WARMUP_SCANS:-600}
case $build in /*) ;; *) build=$PWD/$build ;; esac

teamscan=$build/tools/teamscan/teamscan
onboard=$build/onboard/daemon/teamscan-onboard
peer=$build/tests/support/teamscan_dds_test_peer
for b in "$teamscan" "$onboard" "$peer"; do
  [ -x "$b" ] || { echo "rss_soak: missing $b (build targets teamscan teamscan-onboard teamscan_dds_test_peer)" >&2; exit 2; }
done

out=${SOAK_OUT:-$(mktemp -d /tmp/teamscan-rss-soak.XXXXXX)}
mkdir -p "$out/run"
export CYCLONEDDS_URI=file://$repo/deploy/cyclonedds-lo.xml  # loopback only, never the default config
domain=$((1 + $$ % 230))                                      # as tests/support/test_domain.hpp
hz=$(getconf CLK_TCK)
page_kib=$(( $(getconf PAGESIZE) / 1024 ))

pids=()
stop_all() {
  # Stop what this script started, by PID, newest first: daemon (closes the devices), sink, emulator.
  local p
  for ((i = ${#pids[@]} - 1; i >= 0; i--)); do
    p=${pids[$i]}
    kill -TERM "$p" 2>/dev/null || continue
    for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
    kill -0 "$p" 2>/dev/null && kill -KILL "$p" 2>/dev/null
    wait "$p" 2>/dev/null
  done
  pids=()
}
trap 'stop_all; exit 130' INT TERM

echo "rss_soak: $minutes min, samples every $sample_s s, domain $domain, output $out"
"$teamscan" emulate --scenario lap2 --robot 1 --run-dir "$out/run" --loop --bringup 3 >"$out/emulate.log" 2>&1 &
pids+=($!)
for _ in $(seq 100); do [ -e "$out/run/robot1-lms200" ] && [ -e "$out/run/robot1-arcos" ] && break; sleep 0.1; done
[ -e "$out/run/robot1-lms200" ] || { echo "rss_soak: the emulator did not come up (see $out/emulate.log)" >&2; stop_all; exit 1; }

# lap2 robot 1 (sim/scenarios/lap2.toml): down-laser, 180°/1°, 500 kBd; its oval starts at (3, 0)
# heading +y, which is the odometry frame's registration in the map.
cat >"$out/onboard.toml" <<EOF
# written by tests/bench/onboard/rss_soak.sh: lap2 robot 1 on the emulator's ptys
[robot]
id = 1
[arcos]
device = "$out/run/robot1-arcos"
baud = 38400                 # lap2 robots: p3at-sh at 38400 (sim/scenarios, RobotSpec::arcos_baud)
[lms]
device = "$out/run/robot1-lms200"
baud = 500000
fov_deg = 180
resolution_deg = 1
units = "mm"
max_range_m = 8.0
[mount]
x_m = 0.125
y_m = 0.0
z_m = 0.462
roll_deg = 0.0
pitch_deg = 15.0
yaw_deg = 0.0
[registration]
x_m = 3.0
y_m = 0.0
theta_deg = 90.0
[filter]
enabled = true
half_angle_deg = 7.0
range_gate = true
range_gate_margin_m = 0.3
height_gate = true
height_gate_margin_m = 0.1
body_radius_m = 0.36
height_m = 0.5
max_team_age_s = 0.5
stale_policy = "widen"
stale_growth_deg_per_s = 10.0
extrapolate_team = true
[dds]
domain = $domain
publish = "all"
scan_history_depth = 300
[status]
period_s = 1.0
[odometry]
max_extrapolation_s = 0.2
EOF

"$peer" drain --domain "$domain" --report "$sample_s" >"$out/drain.log" 2>&1 &
pids+=($!)
"$onboard" --config "$out/onboard.toml" >"$out/onboard.log" 2>&1 &
daemon=$!
pids+=($daemon)

field() { awk -v k="$1:" '$1 == k { print $2 }' "/proc/$daemon/status" 2>/dev/null; }
cpu_ticks() { awk '{ sub(/^.*\) /, ""); print $12 + $13 }' "/proc/$daemon/stat" 2>/dev/null; }
drained() { awk '$1 == "drained" { n = $2 } END { print n + 0 }' "$out/drain.log"; }

# Warm-up: both devices up, scans flowing through DDS, the writer's history full.
deadline=$((SECONDS + 120))
while [ "$(drained)" -lt "$warmup_scans" ]; do
  if ! kill -0 "$daemon" 2>/dev/null || [ $SECONDS -ge $deadline ]; then
    echo "rss_soak: no scans reached the sink within 120 s (see $out/*.log)" >&2
    stop_all
    exit 1
  fi
  sleep 1
done

echo "t_s,vmrss_kib,vmhwm_kib,cpu_ticks,drained" >"$out/samples.csv"
t0=$SECONDS
c0=$(cpu_ticks)
end=$((t0 + minutes * 60))
while :; do
  kill -0 "$daemon" 2>/dev/null || { echo "rss_soak: the daemon exited early (see $out/onboard.log)" >&2; break; }
  echo "$((SECONDS - t0)),$(field VmRSS),$(field VmHWM),$(cpu_ticks),$(drained)" >>"$out/samples.csv"
  [ $SECONDS -ge $end ] && break
  sleep "$sample_s"
done
c1=$(cpu_ticks)
wall_s=$((SECONDS - t0))
# Whole-life figures from /proc before stopping: CPU since the daemon started (bring-up included).
start_ticks=$(awk '{ sub(/^.*\) /, ""); print $20 }' "/proc/$daemon/stat" 2>/dev/null)
uptime_s=$(awk '{ print $1 }' /proc/uptime)
smaps=$(awk '/^(Rss|Pss|Private_Dirty|Anonymous):/ { a[$1] += $2 } END { printf "Rss %d Pss %d Private_Dirty %d Anonymous %d", a["Rss:"], a["Pss:"], a["Private_Dirty:"], a["Anonymous:"] }' "/proc/$daemon/smaps" 2>/dev/null)
stop_all
trap - INT TERM

echo "daemon log (last lines):"
tail -n 3 "$out/onboard.log"
echo "sink: $(tail -n 1 "$out/drain.log")"
echo "smaps at end (KiB): $smaps"
awk -F, -v c0="$c0" -v c1="$c1" -v wall="$wall_s" -v hz="$hz" -v st="$start_ticks" -v up="$uptime_s" '
  NR == 1 { next }
  { n++; t[n] = $1; r[n] = $2; h[n] = $3
    if (n == 1 || $2 < mn) mn = $2
    if (n == 1 || $2 > mx) mx = $2 }
  END {
    if (n < 2) { print "rss_soak: too few samples"; exit 1 }
    for (i = 1; i <= n; i++) { sx += t[i]; sy += r[i] }
    mxm = sx / n; mym = sy / n
    for (i = 1; i <= n; i++) { num += (t[i] - mxm) * (r[i] - mym); den += (t[i] - mxm) ^ 2 }
    slope = den > 0 ? num / den * 3600 : 0
    # Peak and trough of each half: the Cyclone 1 MiB receive buffer is touched page by page and then
    # replaced, so RSS is a sawtooth (~24 min period here); a leak raises the second-half peak and
    # trough, a sawtooth does not.
    h0 = int(n / 2) + 1
    for (i = 1; i <= n; i++) {
      if (i < h0) { if (i == 1 || r[i] > p1) p1 = r[i]; if (i == 1 || r[i] < q1) q1 = r[i] }
      else { if (i == h0 || r[i] > p2) p2 = r[i]; if (i == h0 || r[i] < q2) q2 = r[i] }
    }
    printf "samples %d over %d s\n", n, t[n]
    printf "VmRSS KiB: start %d  min %d  max %d  end %d  (end %.2f MiB)\n", r[1], mn, mx, r[n], r[n] / 1024
    printf "VmHWM KiB: start %d  end %d\n", h[1], h[n]
    printf "VmRSS slope (least squares): %.1f KiB/hour\n", slope
    printf "VmRSS KiB first half: min %d max %d; second half: min %d max %d\n", q1, p1, q2, p2
    printf "daemon CPU share over the soak: %.2f %% of one core (utime+stime %.1f s / wall %d s)\n",
           100 * (c1 - c0) / hz / wall, (c1 - c0) / hz, wall
    life = up - st / hz
    if (life > 0) printf "daemon CPU share over its life incl. bring-up: %.2f %% (%.1f s / %.0f s)\n", 100 * c1 / hz / life, c1 / hz, life
  }' "$out/samples.csv"
echo "rss_soak: samples and logs in $out"
