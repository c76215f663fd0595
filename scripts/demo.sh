#!/usr/bin/env bash
# The one command a newcomer runs after a clean clone: installs the Debian 12 packages, builds the
# release preset, and runs `teamscan demo --scenario lap2` (two emulated robots, their onboard daemons
# and the ground station, live on loopback DDS) for 60 s of robot time, about 2 minutes in all on
# 2 cores. Extra arguments go to `teamscan demo` (e.g. --duration 120 --out my-demo).
# Set TEAMSCAN_SKIP_DEPS=1 to skip the package installation.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ "${TEAMSCAN_SKIP_DEPS:-0}" != "1" ]; then
  deploy/install-deps.sh
fi
cmake --preset release
jobs="$(nproc)"
[ "$jobs" -gt 2 ] || jobs=2
cmake --build --preset release -j "$jobs" --target teamscan teamscan-onboard teamscan-groundstation
exec build/release/tools/teamscan/teamscan demo --scenario lap2 --duration 60 --out demo-out "$@"
