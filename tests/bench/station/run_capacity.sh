#!/usr/bin/env bash
# Station capacity: station_feeder publishes N robots x 75 Hz scans + 10 Hz poses
# over loopback DDS to a real teamscan-groundstation pinned to one CPU (the feeder on the other), for each
# N; prints one line per N and the largest N with scan -> fused-map p99 <= 50 ms and nothing lost.
# Figures, not a test. Then, unless SKIP_COLOCATED=1, the co-located figure: tests/bench/scale/run_scale.sh
# with 32 robots (32 daemons + emulators + the station on the same cores) and the machine's CPU share.
#
# The station runs with the decision lag TEAM_LAG (fusion.team_lag_s, default 0.15 s: a scan is decided
# on arrival instead of waiting up to a pose period, 100 ms, for every robot's next pose; 0: the exact
# team, whose wait alone exceeds 50 ms). p50/p99 are the steady state (scans stamped after the feed's
# first 2 s: the core releases nothing in its first hold_s); the all-scans p99 is printed beside them.
#
# The pose graph runs as the fusion core's back end, as in a station at its defaults ([pose_graph],
# docs/slam.md "The back end"), its thread on MATCH_CPUS as the registration's match thread; the station's
# shutdown line of the graph (scans, nodes, how many it was behind) is printed after each N. POSE_GRAPH=0
# turns it off ([pose_graph] enabled = false). The live map follows the graph's estimates as at the
# station's defaults (every 5 s, rigidly, when one moves a scan 2 cm); FOLLOW_S=S sets [pose_graph]
# follow_s (0: only the final model), FOLLOW_MIN_SHIFT=M its follow_min_shift_m (0: every estimate is
# followed), FOLLOW_RIGIDLY=false its follow_rigidly (every estimate decided again; docs/slam.md "The
# live map follows the graph"); the station's follow lines from its event log are printed too.
#
# REGISTRATION=1 turns the station's scan-to-map registration on (a [registration] section, its defaults;
# docs/registration.md "Cost"), its match thread on MATCH_CPUS (default: the feeder's CPU, as a station
# with a second core would place it; MATCH_CPUS= keeps it on the station's); DATASET=DIR feeds a recorded data set (`teamscan sim ... --out DIR`, e.g.
# lap2-drift) instead of the synthetic survey. cpu_ms_per_scan = the station's CPU seconds over the feed
# and the drain / the scans it stored: on a shared machine a steadier figure than the latency.
#
# usage: [METHOD=best] [TEAM_LAG=0.15] [REGISTRATION=0] [POSE_GRAPH=1] [FOLLOW_S=5] [FOLLOW_MIN_SHIFT=0.02] [FOLLOW_RIGIDLY=true] [MATCH_CPUS=0] [DATASET=dir] [DOMAIN=id] [STATION_CPU=1] [FEEDER_CPU=0] [DDS_CONFIG=file] \
#          tests/bench/station/run_capacity.sh [BUILD_DIR] [DURATION_S] [N ...]   default: build/dev, 20 s, N = 8 16 24 32
set -u
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
build="${1:-$root/build/dev}"
duration="${2:-20}"
shift 2 2>/dev/null || shift $#
counts=("$@")
[ ${#counts[@]} -eq 0 ] && counts=(8 16 24 32)
feeder="$build/tests/bench/station/station_feeder"
station="$build/groundstation/station/teamscan-groundstation"
[ -x "$feeder" ] && [ -x "$station" ] || { echo "build the station_feeder and teamscan-groundstation targets first" >&2; exit 2; }
dds="${DDS_CONFIG:-$root/deploy/cyclonedds-lo.xml}"
method="${METHOD:-best}"
scpu="${STATION_CPU:-1}"
fcpu="${FEEDER_CPU:-0}"
lag="${TEAM_LAG:-0.15}"
extra="$(mktemp /tmp/teamscan-capacity.XXXXXX.toml)"
# Appended to the feeder's generated config, inside its [fusion] table; the view off (no clients here).
printf 'team_lag_s = %s\n[view]\nlisten = ""\n' "$lag" > "$extra"
registration="${REGISTRATION:-0}"
match_cpus="${MATCH_CPUS-$fcpu}"
[ "$registration" = 1 ] && printf '[registration]\nenabled = true\ncpus = [%s]\n' "$match_cpus" >> "$extra"
pose_graph="${POSE_GRAPH:-1}"
if [ "$pose_graph" = 1 ]; then
  printf '[pose_graph]\ncpus = [%s]\n' "$match_cpus" >> "$extra"
  [ -n "${FOLLOW_S:-}" ] && printf 'follow_s = %s\n' "$FOLLOW_S" >> "$extra"
  [ -n "${FOLLOW_MIN_SHIFT:-}" ] && printf 'follow_min_shift_m = %s\n' "$FOLLOW_MIN_SHIFT" >> "$extra"
  [ -n "${FOLLOW_RIGIDLY:-}" ] && printf 'follow_rigidly = %s\n' "$FOLLOW_RIGIDLY" >> "$extra"
else
  printf '[pose_graph]\nenabled = false\n' >> "$extra"
fi
dataset_args=()
[ -n "${DATASET:-}" ] && dataset_args=(--dataset "$DATASET")
[ -n "${DOMAIN:-}" ] && dataset_args+=(--domain "$DOMAIN")  # a fixed DDS domain (default: from the feeder's pid)
echo "# $(date -u +%FT%TZ) station capacity: ${duration} s robot time per N, method $method, team_lag_s $lag, registration $registration, pose graph $pose_graph (follow_s ${FOLLOW_S:-5}, follow_min_shift_m ${FOLLOW_MIN_SHIFT:-0.02})${match_cpus:+ (matches and graph on CPU $match_cpus)}, template ${DATASET:-synthetic survey}, station on CPU $scpu, feeder on CPU $fcpu, $(nproc) CPUs, load $(cut -d' ' -f1-3 /proc/loadavg)"
printf '%4s %8s %8s %6s %8s %8s %8s %10s %7s %8s %8s %15s\n' N published stored lost p50_ms p99_ms max_ms all_p99_ms cpu_% rss_MiB cpu_s cpu_ms_per_scan
best=0
for n in "${counts[@]}"; do
  out="$(taskset -c "$fcpu" "$feeder" -n "$n" --duration "$duration" --dds-config "$dds" --station "$station" \
         --station-cpu "$scpu" --method "$method" --station-config "$extra" "${dataset_args[@]}" 2>&1)"
  fed=$(echo "$out" | sed -n 's/^fed: \([0-9]*\) scans.*/\1/p')
  line=$(echo "$out" | grep '^station: stored')
  stored=$(echo "$line" | sed -n 's/^station: stored \([0-9]*\).*/\1/p')
  lost=$(echo "$line" | sed -n 's/.*, lost \([0-9]*\);.*/\1/p')
  steady=$(echo "$out" | grep '^steady')
  all_p99=$(echo "$line" | sed -n 's/.*p99 \([0-9.]*\) ms.*/\1/p')
  p50=$(echo "$steady" | sed -n 's/.*fused map p50 \([0-9.]*\) ms.*/\1/p')
  p99=$(echo "$steady" | sed -n 's/.*fused map p50 [0-9.]* ms, p99 \([0-9.]*\) ms.*/\1/p')
  max=$(echo "$steady" | sed -n 's/.*fused map p50 [0-9.]* ms, p99 [0-9.]* ms, max \([0-9.]*\) ms.*/\1/p')
  cpu=$(echo "$line" | sed -n 's/.* = \([0-9]*\) % of one core.*/\1/p')
  rss=$(echo "$out" | sed -n 's/.*end [0-9.]* s: \([0-9.]*\).*/\1/p')
  cpu_s=$(echo "$line" | sed -n 's/.*; CPU \([0-9.]*\) s over.*/\1/p')
  per_scan=$(awk -v c="$cpu_s" -v n="$stored" 'BEGIN { if (n > 0) printf "%.3f", 1000 * c / n; else print "-" }')
  if [ -z "$line" ]; then echo "N=$n: no result:"; echo "$out" | tail -5; continue; fi
  printf '%4d %8s %8s %6s %8s %8s %8s %10s %7s %8s %8s %15s\n' "$n" "$fed" "$stored" "$lost" "$p50" "$p99" "$max" "$all_p99" "$cpu" "$rss" "$cpu_s" "$per_scan"
  [ "$pose_graph" = 1 ] && echo "$out" | grep -E '^(pose graph: |fusion: the final model|graph follows: |fusion: the live map followed)' | sed 's/^/     /'
  if [ "$lost" = "0" ] && awk -v p="$p99" 'BEGIN { exit !(p <= 50.0) }'; then best=$n; fi
done
echo "largest N with steady p99 <= 50 ms and nothing lost: $best (goal 32 on one core; load after: $(cut -d' ' -f1-3 /proc/loadavg))"
if [ "${SKIP_COLOCATED:-0}" != 1 ]; then
  echo "# co-located: tests/bench/scale/run_scale.sh $build 10 32 (32 daemons + emulators + station on all CPUs)"
  cpu0=$(awk '/^cpu / { print $2+$3+$4+$5+$6+$7+$8, $5+$6 }' /proc/stat)
  STATION_METHOD="$method" "$root/tests/bench/scale/run_scale.sh" "$build" 10 32
  cpu1=$(awk '/^cpu / { print $2+$3+$4+$5+$6+$7+$8, $5+$6 }' /proc/stat)
  echo "$cpu0 $cpu1" | awk '{ busy = ($3 - $4) - ($1 - $2); total = $3 - $1; printf "machine CPU share during the co-located run: %.0f %% of %d CPUs busy\n", 100 * busy / total, '"$(nproc)"' }'
fi
