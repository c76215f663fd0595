#!/usr/bin/env bash
# Installs every Debian 12 package teamscan needs to build, test, benchmark and run its demo.
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
if [ -n "$SUDO" ] && ! command -v sudo >/dev/null 2>&1; then
  echo "install-deps.sh: not root and no sudo: run it as root (su -c deploy/install-deps.sh) or install sudo" >&2
  exit 1
fi
$SUDO apt-get update
$SUDO apt-get install -y --no-install-recommends \
  build-essential cmake ninja-build pkg-config git python3 \
  clang libclang-rt-14-dev \
  libeigen3-dev \
  libnanoflann-dev \
  cyclonedds-dev cyclonedds-tools \
  libsystemd-dev systemd \
  libgtest-dev libgmock-dev libbenchmark-dev \
  libtomlplusplus-dev libcli11-dev libfmt-dev \
  libpng-dev \
  liboctomap-dev \
  pcl-tools
