#!/usr/bin/env bash
# The README's test command: configure (dev preset: warnings as errors), build, run every ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake --preset dev
cmake --build --preset dev -j "$(nproc)"
ctest --preset dev
