#!/bin/sh
# A short live lap2 session (teamscan demo), exported to MCAP and read back by read_mcap.cjs.
# Usage: export_and_read.sh TEAMSCAN NODE READ_MCAP_CJS WORKDIR
set -eu
teamscan=$1 node=$2 reader=$3 work=$4
rm -rf "$work" && mkdir -p "$work"
"$teamscan" demo --scenario lap2 --duration 8 --out "$work/demo" --quiet --method best --station-compare none \
  > "$work/demo.log" 2>&1 || { tail -20 "$work/demo.log"; exit 1; }
"$teamscan" export "$work/demo/session" --format mcap --out "$work/session.mcap" \
  --robot-config "$work/demo/config/onboard-robot1.toml" --robot-config "$work/demo/config/onboard-robot2.toml"
"$node" "$reader" "$work/demo/session" "$work/session.mcap" --laser-frames 2 --max-size-ratio 0.2
# A malformed session: a clear message and exit status 1, no output file.
mkdir -p "$work/bad" && echo "garbage" > "$work/bad/scans.bin"
rc=0
"$teamscan" export "$work/bad" --format mcap --out "$work/bad.mcap" 2> "$work/bad.err" || rc=$?
[ "$rc" -eq 1 ] && grep -q "scans.bin" "$work/bad.err" && [ ! -e "$work/bad.mcap" ] ||
  { echo "malformed session: exit $rc, stderr: $(cat "$work/bad.err")"; exit 1; }
echo "malformed session refused: $(cat "$work/bad.err")"
