#!/usr/bin/env bash
# Cyclone settings on a lossy radio link (docs/radio.md "Measurements"): `teamscan demo` with every
# process in a network namespace and LOSS of the datagrams each one sends dropped, once per Cyclone
# config given; prints per config the scans missing from the session and the scan -> stored and
# scan -> fused map latency. Root (network namespaces). Figures, no pass/fail.
#   tests/bench/radio/run_link_loss.sh [CONFIG.xml ...]   (default: deploy/cyclonedds-site.xml)
#   LOSS=20 DURATION=30 SHADOWS="1:8:10 2:14:10" PREFIX=tsradio- BUILD=build/dev
set -euo pipefail
root="$(cd "$(dirname "$0")/../../.." && pwd)"
build="${BUILD:-$root/build/dev}"
loss="${LOSS:-20}"
duration="${DURATION:-30}"
prefix="${PREFIX:-tsradio$$-}"
configs=("$@")
[ "${#configs[@]}" -gt 0 ] || configs=("$root/deploy/cyclonedds-site.xml")
shadow_args=()
for s in ${SHADOWS:-}; do shadow_args+=(--shadow "$s"); done
export CYCLONEDDS_URI="file://$root/deploy/cyclonedds-lo.xml"  # the demo's own process: loopback
printf '%-40s %8s %8s %12s %12s %12s\n' config loss missing "stored p99" "fused p50" "fused p99"
for cfg in "${configs[@]}"; do
  out="$(mktemp -d /tmp/radio-loss.XXXXXX)"
  rc=0
  "$build/tools/teamscan/teamscan" demo --quiet --scenario lap2 --duration "$duration" --bringup 4 --method direction \
    --link-loss "$loss" "${shadow_args[@]}" --dds-config "$cfg" --netns-prefix "$prefix" --out "$out" \
    > "$out/demo.out" 2> "$out/demo.err" || rc=$?
  python3 - "$out/summary.json" "$(basename "$cfg")" "$loss" "$rc" <<'PY'
import json, sys
path, name, loss, rc = sys.argv[1:5]
try:
    s = json.load(open(path))
except OSError:
    print(f"{name:<40} {loss:>7}% no summary (exit {rc})"); sys.exit(0)
missing = sum(r["missing"] for r in s["robots"])
print(f"{name:<40} {loss:>7}% {missing:8d} {s['latency_ms_p99']:9.0f} ms {s['fused_latency_ms_p50']:9.0f} ms "
      f"{s['fused_latency_ms_p99']:9.0f} ms   (exit {rc}, {path})")
PY
done
