#!/usr/bin/env bash
# The README's test command: configure (dev preset: warnings as errors), build, run every ctest.
# Unit and fuzz-corpus tests run in parallel; hardware-in-loop tests (label hil: ptys, DDS on the
# loopback domain, child processes) run one at a time, because DDS tests that share a domain see each
# other's samples and timing-sensitive pty tests should not compete for the two cores.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake --preset dev
cmake --build --preset dev -j "$(nproc)"
ctest --preset dev -LE hil
ctest --preset dev -L hil -j 1
