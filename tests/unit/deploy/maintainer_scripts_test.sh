#!/bin/sh
# The packages' maintainer scripts (deploy/debian) against services, as Debian's debhelper snippets
# behave: a first install starts nothing; an upgrade (postinst configure OLDVERSION) restarts a running
# station and running robot instances and leaves stopped ones stopped; remove (prerm remove) stops them;
# /usr/sbin/policy-rc.d answering 101 forbids both; without systemd the scripts touch no service.
# Runs the real scripts with the real deb-systemd-invoke, a stand-in systemctl first in PATH
# (tests/support/standin_systemctl.sh) and, in a private mount namespace, a /run/systemd/system of its
# own (root and unshare needed: skipped, exit 77, otherwise). policy-rc.d is read through DPKG_ROOT.
# Usage: maintainer_scripts_test.sh SOURCE_DIR
set -eu
src=$1
if [ "$(id -u)" -ne 0 ] || ! command -v deb-systemd-invoke >/dev/null || ! unshare -m true 2>/dev/null; then
  echo "skipped: needs root, deb-systemd-invoke and unshare -m"
  exit 77
fi
if [ -z "${IN_NAMESPACE:-}" ]; then
  exec env IN_NAMESPACE=1 unshare -m sh "$0" "$@"
fi
mount -t tmpfs teamscan-test-run /run
work=$(mktemp -d /tmp/maintainer-scripts-XXXXXX)
trap 'for f in "$work"/state/*.pid; do [ -e "$f" ] && kill "$(cat "$f")" 2>/dev/null; done; rm -rf "$work"' EXIT
mkdir -p "$work/bin" "$work/state" "$work/root/usr/sbin"
cp "$src/tests/support/standin_systemctl.sh" "$work/bin/systemctl"
printf '#!/bin/sh\necho "systemd-sysusers $*" >> "%s/state/calls"\n' "$work" > "$work/bin/systemd-sysusers"
chmod 755 "$work/bin/systemctl" "$work/bin/systemd-sysusers"
export PATH="$work/bin:$PATH" STANDIN_STATE="$work/state" DPKG_ROOT="$work/root"
d=$src/deploy/debian
failures=0
check() { if eval "$2"; then echo "ok: $1"; else echo "FAIL: $1"; failures=$((failures + 1)); fi; }
pid() { cat "$work/state/$1.pid" 2>/dev/null || echo none; }
running() { [ -f "$work/state/$1.pid" ] && kill -0 "$(cat "$work/state/$1.pid")" 2>/dev/null; }
policy() { printf '#!/bin/sh\nexit %s\n' "$1" > "$work/root/usr/sbin/policy-rc.d"; chmod 755 "$work/root/usr/sbin/policy-rc.d"; }
station=teamscan-groundstation.service

mkdir -p /run/systemd/system
policy 0
sh "$d/groundstation.postinst" configure ""
check "first install reloads systemd and starts nothing" "! running $station && [ \"\$(cat '$work/state/calls')\" = '--system daemon-reload' ]"

systemctl start $station
before=$(pid $station)
sh "$d/groundstation.prerm" upgrade 0.1.0-2
check "prerm upgrade leaves the station running" "[ '$(pid $station)' = '$before' ] && running $station"
sh "$d/groundstation.postinst" configure 0.1.0-1
after=$(pid $station)
check "postinst configure OLD (upgrade) restarts a running station" "[ '$after' != '$before' ] && running $station && ! kill -0 $before 2>/dev/null"

systemctl stop $station
sh "$d/groundstation.postinst" configure 0.1.0-1
check "upgrade leaves a stopped station stopped" "! running $station"

systemctl start $station
sh "$d/groundstation.prerm" remove
check "prerm remove stops the station" "! running $station"
sh "$d/service.postrm" remove
check "postrm remove reloads systemd" "[ \"\$(tail -n 1 '$work/state/calls')\" = '--system daemon-reload' ]"

systemctl start teamscan-onboard@robot1.service teamscan-onboard@robot2.service
r1=$(pid teamscan-onboard@robot1.service) r2=$(pid teamscan-onboard@robot2.service)
sh "$d/onboard.postinst" configure 0.1.0-1
check "onboard upgrade restarts every running instance" \
  "[ '$(pid teamscan-onboard@robot1.service)' != '$r1' ] && [ '$(pid teamscan-onboard@robot2.service)' != '$r2' ] && running teamscan-onboard@robot1.service && running teamscan-onboard@robot2.service"
check "onboard postinst runs systemd-sysusers" "grep -qx 'systemd-sysusers teamscan-onboard.conf' '$work/state/calls'"
sh "$d/onboard.prerm" remove
check "onboard prerm remove stops every instance" "! running teamscan-onboard@robot1.service && ! running teamscan-onboard@robot2.service"

policy 101
systemctl start $station
before=$(pid $station)
sh "$d/groundstation.postinst" configure 0.1.0-1
check "policy-rc.d 101: an upgrade does not restart" "[ '$(pid $station)' = '$before' ]"
sh "$d/groundstation.prerm" remove
check "policy-rc.d 101: remove does not stop" "running $station"
policy 0
systemctl stop $station

rmdir /run/systemd/system
: > "$work/state/calls"
systemctl start $station
: > "$work/state/calls"
before=$(pid $station)
sh "$d/groundstation.postinst" configure 0.1.0-1
sh "$d/groundstation.prerm" remove
sh "$d/service.postrm" remove
check "without systemd the scripts call no systemctl" "[ ! -s '$work/state/calls' ] && [ '$(pid $station)' = '$before' ]"

[ "$failures" -eq 0 ] || { echo "$failures failed"; exit 1; }
echo "all passed"
