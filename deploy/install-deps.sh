#!/usr/bin/env bash
# Installs every Debian 12 package teamscan needs to build, test, benchmark, package and run its demo.
# Packaging (scripts/check-install.sh): help2man (man pages from --help), file and dpkg-dev (cpack's
# dpkg-shlibdeps), lintian.
# The browser view (groundstation/view): Boost.Beast (libboost-dev) serves it; node + npm bundle its
# page at build time (npm ci from the npm registry, package-lock.json); chromium runs its browser test;
# nlohmann-json3-dev parses its JSON in the unit tests. libssl-dev: the site PKI tool (OpenSSL libcrypto).
# zlib1g-dev: the CRC-32 of the MCAP writer (common/mcap).
# libceres-dev: the pose graph's solver (groundstation/posegraph); liblzma-dev: logs read as .xz.
# iproute2: `ip netns`, veth and bridges for the demo's link faults and their test (docs/radio.md).
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
  libceres-dev liblzma-dev \
  libnanoflann-dev \
  cyclonedds-dev cyclonedds-tools \
  libsystemd-dev systemd \
  libgtest-dev libgmock-dev libbenchmark-dev \
  libtomlplusplus-dev libcli11-dev \
  libpng-dev zlib1g-dev \
  liboctomap-dev \
  pcl-tools \
  help2man file dpkg-dev lintian \
  libboost-dev nlohmann-json3-dev libssl-dev \
  chromium iproute2
# node + npm: Debian's nodejs and npm packages, unless a node with its npm is already installed (a
# NodeSource nodejs bundles npm and conflicts with Debian's npm package: asking for both fails).
if command -v node >/dev/null 2>&1 && command -v npm >/dev/null 2>&1; then
  echo "install-deps.sh: using the installed node $(node --version) and npm $(npm --version)"
else
  $SUDO apt-get install -y --no-install-recommends nodejs npm
fi
