#!/usr/bin/env bash
# Part of scripts/check-install.sh, with teamscan's packages installed: `apt-get install` of newer
# teamscan-groundstation and teamscan-onboard packages restarts a running station (the new process runs
# the new binary), and `apt-get remove` stops it, through the packages' own maintainer scripts
# (deploy/debian) and Debian's deb-systemd-invoke.
# systemd is not PID 1 on the CI machines (containers), so the maintainer scripts would skip every
# service action. This check gives them, in a private mount namespace, a /run/systemd/system and a
# permissive /usr/sbin/policy-rc.d (a container's usually answers 101), and mounts a stand-in systemctl
# over /usr/bin/systemctl (tests/support/standin_systemctl.sh; apt-get runs dpkg with a PATH of its own,
# so a PATH entry would not reach the scripts) that runs the installed teamscan-groundstation as a
# plain process; robot instances need serial devices, so for them the calls are checked, not a process.
# Where no mount namespace can be made (a container without CAP_SYS_ADMIN; or CHECK_UPGRADE_IN_PLACE=1),
# the same is done in place and undone on exit: /run/systemd/system created, policy-rc.d moved aside,
# systemctl diverted (dpkg-divert) for the stand-in.
# The newer packages are the built ones with the Debian revision raised (same files: dpkg replaces them
# all, so an old process would show its executable as deleted).
#   bash scripts/check-upgrade.sh DEBS_DIR          (root)
set -euo pipefail
cd "$(dirname "$0")/.."
debs=$(realpath "$1")
fail() { echo "check-upgrade: FAILED: $*" >&2; exit 1; }
[ "$(id -u)" -eq 0 ] || fail "run it as root"
tmp=$(mktemp -d /tmp/teamscan-check-upgrade-XXXXXX)
state=$tmp/state
station=teamscan-groundstation.service
mkdir -p "$tmp/bin" "$state" "$tmp/sessions"
cp tests/support/standin_systemctl.sh "$tmp/bin/systemctl"
printf '#!/bin/sh\nexit 0\n' > "$tmp/policy-rc.d"
chmod 755 "$tmp/bin/systemctl" "$tmp/policy-rc.d"
[ -x /usr/bin/systemctl ] || fail "no /usr/bin/systemctl (the systemd package) to stand in for"
undo=()  # in place only: what to put back
cleanup() {
  for f in "$state"/*.pid; do [ -e "$f" ] && kill "$(cat "$f")" 2>/dev/null || true; done
  for ((i = ${#undo[@]} - 1; i >= 0; i--)); do eval "${undo[i]}" || true; done
  rm -rf "$tmp"
}
trap cleanup EXIT
if [ -z "${CHECK_UPGRADE_NS:-}" ] && [ -z "${CHECK_UPGRADE_IN_PLACE:-}" ] && unshare -m true 2>/dev/null; then
  # A private mount namespace: nothing of the machine's own files changes.
  rm -rf "$tmp"
  trap - EXIT
  exec env CHECK_UPGRADE_NS=1 unshare -m bash "$0" "$@"
elif [ -n "${CHECK_UPGRADE_NS:-}" ]; then
  if [ ! -d /run/systemd/system ]; then
    mount -t tmpfs check-upgrade-run /run
    mkdir -p /run/systemd/system /run/lock
  fi
  [ ! -e /usr/sbin/policy-rc.d ] || mount --bind "$tmp/policy-rc.d" /usr/sbin/policy-rc.d
  mount --bind "$tmp/bin/systemctl" /usr/bin/systemctl
else
  # No namespace (a container without CAP_SYS_ADMIN): the same in place, every change undone on exit;
  # systemctl is moved aside with dpkg-divert, as Debian's own tools divert a packaged file.
  echo "check-upgrade: no private mount namespace here: standing in for systemctl in place (undone on exit)"
  if [ ! -d /run/systemd ]; then
    mkdir /run/systemd
    undo+=("rmdir /run/systemd")
  fi
  if [ ! -d /run/systemd/system ]; then
    mkdir /run/systemd/system
    undo+=("rmdir /run/systemd/system")
  fi
  if [ -e /usr/sbin/policy-rc.d ]; then
    mv /usr/sbin/policy-rc.d "$tmp/policy-rc.d.saved"
    undo+=("mv '$tmp/policy-rc.d.saved' /usr/sbin/policy-rc.d")
  fi
  dpkg-divert --quiet --local --rename --divert /usr/bin/systemctl.check-upgrade --add /usr/bin/systemctl
  undo+=("dpkg-divert --quiet --local --rename --divert /usr/bin/systemctl.check-upgrade --remove /usr/bin/systemctl")
  cp "$tmp/bin/systemctl" /usr/bin/systemctl
  undo+=("rm -f /usr/bin/systemctl")
fi

# The station as its unit would run it, on loopback, its session folder under $tmp.
sed -e "s|^session_root = .*|session_root = \"$tmp/sessions\"|" -e 's|^listen = .*|listen = ""|' \
  /usr/share/teamscan/examples/groundstation.toml > "$tmp/groundstation.toml"
/usr/bin/teamscan-groundstation --config "$tmp/groundstation.toml" --check-config >/dev/null ||
  fail "the test config does not check"
export STANDIN_STATE="$state"
export STANDIN_EXEC="/usr/bin/teamscan-groundstation --config $tmp/groundstation.toml"
export CYCLONEDDS_URI=file:///usr/share/teamscan/cyclonedds-lo.xml
pid() { cat "$state/$station.pid" 2>/dev/null || echo none; }
running() { [ -f "$state/$station.pid" ] && kill -0 "$(pid)" 2>/dev/null; }

systemctl start "$station"
for _ in $(seq 50); do ls "$tmp"/sessions/session-*/scans.bin >/dev/null 2>&1 && break; sleep 0.2; done
running || { cat "$state/$station.log"; fail "the station did not start"; }
old=$(pid)
echo "check-upgrade: station running as pid $old ($(readlink /proc/"$old"/exe))"

# Newer packages: the same files, the Debian revision + 1.
newer=()
for p in teamscan-groundstation teamscan-onboard; do
  deb=$(ls "$debs"/${p}_*.deb)
  rm -rf "$tmp/repack" && dpkg-deb -R "$deb" "$tmp/repack"
  version=$(sed -n 's/^Version: //p' "$tmp/repack/DEBIAN/control")
  bumped="${version%-*}-$(( ${version##*-} + 1 ))"
  sed -i "s/^Version: .*/Version: $bumped/" "$tmp/repack/DEBIAN/control"
  dpkg-deb -b "$tmp/repack" "$tmp/${p}_${bumped}.deb" >/dev/null
  newer+=("$tmp/${p}_${bumped}.deb")
done
echo "check-upgrade: apt-get install ${newer[*]##*/}"
: > "$state/calls"
apt-get install -y --no-install-recommends "${newer[@]}" >/dev/null
new=$(pid)
running || { cat "$state/$station.log"; fail "no station runs after the upgrade"; }
[ "$new" != "$old" ] || fail "the upgrade did not restart the station (still pid $old)"
! kill -0 "$old" 2>/dev/null || fail "the old station (pid $old) still runs"
exe=$(readlink /proc/"$new"/exe)
[ "$exe" = /usr/bin/teamscan-groundstation ] || fail "the restarted station runs '$exe', not the new /usr/bin/teamscan-groundstation"
grep -q "try-restart $station" "$state/calls" || fail "no try-restart of the station: $(cat "$state/calls")"
grep -q "try-restart teamscan-onboard@\*.service" "$state/calls" || fail "no try-restart of the robot instances"
echo "check-upgrade: the upgrade restarted the station: pid $old -> $new ($exe)"

echo "check-upgrade: apt-get remove teamscan-groundstation teamscan-onboard"
apt-get remove -y teamscan-groundstation teamscan-onboard >/dev/null
! running || fail "the station (pid $new) still runs after apt-get remove"
! kill -0 "$new" 2>/dev/null || fail "the station process $new still runs"
grep -q "stop teamscan-onboard@\*.service" "$state/calls" || fail "remove did not stop the robot instances"
ls "$tmp"/sessions/session-*/scans.bin >/dev/null || fail "the station's session folder is gone"
echo "check-upgrade: apt-get remove stopped the station and the robot instances"
echo "check-upgrade: calls the maintainer scripts made:"
sed 's/^/  systemctl /' "$state/calls"
