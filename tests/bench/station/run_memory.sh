#!/usr/bin/env bash
# Station memory over a long mission: eight robots for one hour of robot time, as fast
# as the machine allows (WARP robot seconds per wall second; stamps stay the feeder's real clock, so the
# station's stamp validation needs no bench mode), with a fused-model write every 60 s of robot time.
# Prints the station's RSS curve (start, each quarter, end), the write times with each write's loop stall
# (the snapshot taken in the receive loop) and its time on the writer thread, and the scan -> fused-map
# p99 of the scans fused during a write and outside; then the same feed without writes (unless
# SKIP_NO_WRITES=1) and the two runs' scan -> fused-map p99 side by side (within 10 %).
# COMPARE=frequency,position,...: the station also decides these methods (fusion.compare_methods, one
# more core and model store each). A guard stops the feed if the station's RSS passes RSS_GUARD_MIB (a shared
# host must not run out of memory), MAX_WALL_S bounds each run. Figures, not a test.
#
# usage: [WARP=3] [ROBOTS=8] [POSE_GRAPH=1] [TEAM_LAG=0.15] [METHOD=best] [COMPARE=] [RSS_GUARD_MIB=4096] [MAX_WALL_S=1500] [STOP_TIMEOUT_S=30] [STATION_CPU=1] [FEEDER_CPU=0] [WRITER_CPUS=FEEDER_CPU]
#        [DDS_CONFIG=file] tests/bench/station/run_memory.sh [BUILD_DIR] [ROBOT_SECONDS]     default 3600
set -u
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
build="${1:-$root/build/dev}"
seconds="${2:-3600}"
feeder="$build/tests/bench/station/station_feeder"
station="$build/groundstation/station/teamscan-groundstation"
[ -x "$feeder" ] && [ -x "$station" ] || { echo "build the station_feeder and teamscan-groundstation targets first" >&2; exit 2; }
warp="${WARP:-3}"
robots="${ROBOTS:-8}"
write_s=$(awk -v w="$warp" 'BEGIN { printf "%.3f", 60.0 / w }')  # one write per 60 s of robot time
# The decision lag (fusion.team_lag_s, TEAM_LAG, default 0.15 s): without it every scan waits up to a pose
# period for the team state, and that wait, not the writes, would set the p99 compared below.
lag_toml="$(mktemp /tmp/teamscan-memory.XXXXXX.toml)"
printf 'team_lag_s = %s\n' "${TEAM_LAG:-0.15}" > "$lag_toml"
# The model writer thread's CPUs (fusion.writer_cpus): by default the feeder's, so the loop's pinned CPU
# carries the loop and the snapshot only (a station on a multi-core machine keeps its writer elsewhere);
# WRITER_CPUS= (empty) leaves the writer on the station's CPU.
writer_cpus="${WRITER_CPUS-${FEEDER_CPU:-0}}"
[ -n "$writer_cpus" ] && printf 'writer_cpus = [%s]\n' "$writer_cpus" >> "$lag_toml"
# The pose graph runs as at the station's defaults; POSE_GRAPH=0 turns it off ([pose_graph] enabled = false).
[ "${POSE_GRAPH:-1}" = 1 ] || printf '[pose_graph]\nenabled = false\n' >> "$lag_toml"
common=(-n "$robots" --duration "$seconds" --warp "$warp" --dds-config "${DDS_CONFIG:-$root/deploy/cyclonedds-lo.xml}"
        --station "$station" --station-cpu "${STATION_CPU:-1}" --method "${METHOD:-best}"
        --rss-guard-mib "${RSS_GUARD_MIB:-4096}" --max-wall "${MAX_WALL_S:-1500}" --stop-timeout "${STOP_TIMEOUT_S:-30}"
        --compare-methods "${COMPARE:-}" --station-config "$lag_toml")
out="$(mktemp -d /tmp/teamscan-run-memory-XXXXXX)"
# The "station: ..." line's scan -> fused map p99 (ms) of a run's output.
p99_of() { sed -n 's/^station: .* p99 \([0-9.]*\) ms,.*/\1/p' "$1" | head -n 1; }
echo "# $(date -u +%FT%TZ) station memory: $robots robots, pose graph ${POSE_GRAPH:-1}, $seconds s robot time at ${warp}x, a model write every 60 s of robot time ($write_s s wall), station on CPU ${STATION_CPU:-1}, writer thread on CPUs ${writer_cpus:-of the station}, $(nproc) CPUs, load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "## with model writes"
taskset -c "${FEEDER_CPU:-0}" "$feeder" "${common[@]}" --write-interval "$write_s" | tee "$out/with.txt"
# The station's shutdown lines of the pose graph (nodes, how many it was behind) and of the final model.
grep -E '^(pose graph: |fusion: the final model)' "$out/with.txt" | sed 's/^/   /'
if [ "${SKIP_NO_WRITES:-0}" != 1 ]; then
  echo "## without model writes"
  taskset -c "${FEEDER_CPU:-0}" "$feeder" "${common[@]}" --write-interval 0 | tee "$out/without.txt"
  with_p99="$(p99_of "$out/with.txt")"; without_p99="$(p99_of "$out/without.txt")"
  if [ -n "$with_p99" ] && [ -n "$without_p99" ]; then
    awk -v a="$with_p99" -v b="$without_p99" 'BEGIN {
      printf "## scan -> fused map p99: with writes %.1f ms, without %.1f ms: %+.1f %% (within 10 %%)\n", a, b, (b > 0 ? 100 * (a - b) / b : 0) }'
  else
    echo "## scan -> fused map p99: a run printed no station line (see above)"
  fi
fi
rm -rf "$out"
echo "# load after: $(cut -d' ' -f1-3 /proc/loadavg)"
