#!/usr/bin/env bash
# The cost of the browser view to the fusion (docs/view.md "Cost"): station_feeder publishes N robots x
# 75 Hz scans + 10 Hz poses (one light process) to a real teamscan-groundstation pinned to one CPU, once
# with the view off and once with the view on and CLIENTS WebSocket clients connected through the run
# (tests/bench/view/view_bench_clients: they decode every message as a browser would; they run on the
# feeder's CPU, as browsers run on other machines). Runs alternate off/on REPEAT times so that drift of
# the machine shows as spread, not as a difference. Prints per run: scans published / stored / lost, the
# station's scan -> fused map p50/p99/max (all scans), its CPU share and peak resident memory (the feeder's figures),
# and what the clients received. p50/p99/max are the steady state (scans stamped after the feed's first
# 2 s; station_feeder's "steady" line), the station deciding with the decision lag TEAM_LAG
# (fusion.team_lag_s, default 0.15 s). The view's server thread runs on VIEW_CPUS ([view] cpus; default
# the feeder's CPU: the receive loop keeps its core, as on a station with more than one; VIEW_CPUS= puts
# it on the station's pinned CPU beside the loop). Figures, not a test.
#
# usage: [REPEAT=2] [TEAM_LAG=0.15] [STATION_CPU=1] [FEEDER_CPU=0] [VIEW_CPUS=0] tests/bench/view/run_view_cost.sh [BUILD_DIR] [N] [SECONDS] [CLIENTS]
#        default: build/dev 32 20 3
set -u
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
build="$(cd "${1:-$root/build/dev}" && pwd)"
n="${2:-32}"; seconds="${3:-20}"; clients="${4:-3}"
repeat="${REPEAT:-2}"; scpu="${STATION_CPU:-1}"; fcpu="${FEEDER_CPU:-0}"; vcpus="${VIEW_CPUS-$fcpu}"
feeder="$build/tests/bench/station/station_feeder"
station="$build/groundstation/station/teamscan-groundstation"
viewers="$build/tests/bench/view/view_bench_clients"
for b in "$feeder" "$station" "$viewers"; do
  [ -x "$b" ] || { echo "missing $b (build station_feeder, teamscan-groundstation, view_bench_clients)" >&2; exit 2; }
done
work="$(mktemp -d /tmp/teamscan-viewcost.XXXXXX)"
port=$(( 20000 + $$ % 20000 ))
lag="${TEAM_LAG:-0.15}"
# Appended to the feeder's generated config, inside its [fusion] table, then the [view] table.
printf 'team_lag_s = %s\n[view]\nlisten = ""\n' "$lag" > "$work/off.toml"
printf 'team_lag_s = %s\n[view]\nlisten = "127.0.0.1:%d"\ncpus = [%s]\n' "$lag" "$port" "$vcpus" > "$work/on.toml"
echo "# $(date -u +%FT%TZ) view cost: $n robots x 75 Hz x $seconds s robot time, team_lag_s $lag, $clients clients, station on CPU $scpu, view thread on CPUs ${vcpus:-(the station CPU)}, feeder + clients on CPU $fcpu, load $(cut -d' ' -f1-3 /proc/loadavg)"
printf '%-5s %3s %9s %8s %5s %8s %8s %8s %6s %8s  %s\n' view run published stored lost p50_ms p99_ms max_ms cpu_% rss_MiB clients
for ((r = 1; r <= repeat; r++)); do
  for mode in off on; do
    vpid=""
    if [ "$mode" = on ]; then
      taskset -c "$fcpu" "$viewers" "$port" --clients "$clients" --seconds $((seconds + 30)) > "$work/clients-$r.log" 2>&1 &
      vpid=$!
    fi
    out="$(taskset -c "$fcpu" "$feeder" -n "$n" --duration "$seconds" --dds-config "$root/deploy/cyclonedds-lo.xml" \
           --station "$station" --station-cpu "$scpu" --station-config "$work/$mode.toml" 2>&1)"
    got="-"
    if [ -n "$vpid" ]; then
      wait "$vpid"
      got="$(grep -c NEVER "$work/clients-$r.log") never connected; client 1: $(head -1 "$work/clients-$r.log" | cut -c1-100)"
    fi
    line=$(echo "$out" | grep '^station: stored')
    steady=$(echo "$out" | grep '^steady')
    if [ -z "$line" ]; then echo "$mode run $r: no result:"; echo "$out" | tail -5; continue; fi
    printf '%-5s %3d %9s %8s %5s %8s %8s %8s %6s %8s  %s\n' "$mode" "$r" \
      "$(echo "$out" | sed -n 's/^fed: \([0-9]*\) scans.*/\1/p')" \
      "$(echo "$line" | sed -n 's/^station: stored \([0-9]*\).*/\1/p')" \
      "$(echo "$line" | sed -n 's/.*, lost \([0-9]*\);.*/\1/p')" \
      "$(echo "$steady" | sed -n 's/.*fused map p50 \([0-9.]*\) ms.*/\1/p')" \
      "$(echo "$steady" | sed -n 's/.*fused map p50 [0-9.]* ms, p99 \([0-9.]*\) ms.*/\1/p')" \
      "$(echo "$steady" | sed -n 's/.*fused map p50 [0-9.]* ms, p99 [0-9.]* ms, max \([0-9.]*\) ms.*/\1/p')" \
      "$(echo "$line" | sed -n 's/.* = \([0-9]*\) % of one core.*/\1/p')" \
      "$(echo "$out" | sed -n 's/^station RSS.*; max \([0-9.]*\)$/\1/p')" \
      "$got"
    echo "$out" > "$work/feeder-$mode-$r.log"
  done
done
echo "# logs: $work"
