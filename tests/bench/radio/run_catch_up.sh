#!/usr/bin/env bash
# The station's catch-up after radio shadows against the live scans (docs/radio.md "Measurements"):
# `teamscan demo` under 20 % loss with two shadows per robot, once with the whole catch-up in one loop
# turn ([fusion] catch_up_slice_scans = 0), once in slices (16, the default), and once without shadows;
# prints the connected robots' steady scan -> fused map latency of each (connected_latency.py) and the
# station's catch-ups (events.log). Root (network namespaces). Figures, no pass/fail.
#   tests/bench/radio/run_catch_up.sh [OUT]     BUILD=build/dev DURATION=60
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
build="${BUILD:-$root/build/dev}"
out="${1:-$(mktemp -d /tmp/radio-catch-up.XXXXXX)}"
mkdir -p "$out"
shadows=(1:5:10 1:30:12 2:12:12 2:38:10)
shadow_args=()
for s in "${shadows[@]}"; do shadow_args+=(--shadow "$s"); done
export CYCLONEDDS_URI="file://$root/deploy/cyclonedds-lo.xml"  # the demo's own process: loopback
# The station with the slice added to the [fusion] section of the config the demo writes for it.
for slice in 0 16; do
  cat > "$out/station-slice$slice.sh" <<SH
#!/usr/bin/env bash
args=()
while [ \$# -gt 0 ]; do
  if [ "\$1" = --config ]; then sed '/^\[fusion\]\$/a catch_up_slice_scans = $slice' "\$2" > "\$2.slice.toml"; args+=(--config "\$2.slice.toml"); shift 2; continue; fi
  args+=("\$1"); shift
done
exec "$build/groundstation/station/teamscan-groundstation" "\${args[@]}"
SH
  chmod +x "$out/station-slice$slice.sh"
done
for run in whole sliced none; do
  extra=("${shadow_args[@]}" --station-bin "$out/station-slice0.sh")
  [ "$run" = sliced ] && extra=("${shadow_args[@]}" --station-bin "$out/station-slice16.sh")
  [ "$run" = none ] && extra=(--station-bin "$out/station-slice16.sh")
  echo "== $run: $(date -u +%H:%M:%S) UTC, load $(cut -d' ' -f1-3 /proc/loadavg)"
  rm -rf "${out:?}/$run"
  nice -n 10 "$build/tools/teamscan/teamscan" demo --scenario lap2 --duration "${DURATION:-60}" --bringup 4 --method direction \
    --link-loss 20 "${extra[@]}" --out "$out/$run" > "$out/$run.log" 2>&1 || true
  if [ "$run" = none ]; then python3 "$here/connected_latency.py" "$out/$run"; else python3 "$here/connected_latency.py" "$out/$run" "${shadows[@]}"; fi
  grep -h "fusion: caught up" "$out/$run/session/events.log" | cut -d' ' -f3- || true
done
