#!/usr/bin/env bash
# The goal run of docs/radio.md "Measurements": `teamscan demo` with 20 % loss on every link and radio
# shadows, and the same run without shadows; prints per run the scans missing, each shadow's time to whole
# (report.md "Faults"), whether the station's model equals `teamscan eval` of its session, and the connected
# robots' scan -> fused map latency (connected_latency.py). Root (network namespaces). Figures, no pass/fail.
#   tests/bench/radio/run_shadows.sh [OUT]   BUILD=build/dev DURATION=420
#                                            SHADOWS="1:20:120 1:200:120 2:60:120 2:230:120"
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
build="${BUILD:-$root/build/dev}"
out="${1:-$(mktemp -d /tmp/radio-shadows.XXXXXX)}"
duration="${DURATION:-420}"
read -r -a shadows <<< "${SHADOWS:-1:20:120 1:200:120 2:60:120 2:230:120}"
shadow_args=()
for s in "${shadows[@]}"; do shadow_args+=(--shadow "$s"); done
export CYCLONEDDS_URI="file://$root/deploy/cyclonedds-lo.xml"  # the demo's own process: loopback
mkdir -p "$out"
for run in shadows none; do
  extra=("${shadow_args[@]}")
  [ "$run" = none ] && extra=()
  echo "== $run: $(date -u +%H:%M:%S) UTC, load $(cut -d' ' -f1-3 /proc/loadavg)"
  rm -rf "${out:?}/$run"
  nice -n 10 "$build/tools/teamscan/teamscan" demo --scenario lap2 --duration "$duration" --bringup 4 --method direction \
    --link-loss 20 ${extra[@]+"${extra[@]}"} --out "$out/$run" > "$out/$run.log" 2>&1 || true
  grep -E "delivery:|same decisions" "$out/$run.log" || true
  grep -E "shadow at t = " "$out/$run/report.md" || true
  if [ "$run" = none ]; then python3 "$here/connected_latency.py" "$out/$run" --duration "$duration"
  else python3 "$here/connected_latency.py" "$out/$run" --duration "$duration" "${shadows[@]}"; fi
done
