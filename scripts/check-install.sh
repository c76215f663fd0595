#!/usr/bin/env bash
# Builds the Debian packages (cmake/cpack preset `package`), runs lintian on them, installs them on this
# machine with apt-get (root), and checks the installed result: the teamscan user, no service enabled,
# `--version` of the three programs, `--check-config` on the installed example configs,
# `systemd-analyze verify` (silent) and `systemd-analyze security` (exposure <= 2.0) on the installed
# units, a short `teamscan demo` from /usr/bin with the installed loopback DDS config, and the upgrade
# path (scripts/check-upgrade.sh): `apt-get install` of newer packages restarts a running station,
# `apt-get remove` stops it.
# The packages are removed again at the end (also on failure) unless --keep is given; the teamscan
# user stays, as Debian leaves system users. Called by .ci/run; runnable by hand as root.
#   bash scripts/check-install.sh [--keep] [--skip-build]
set -euo pipefail
cd "$(dirname "$0")/.."
keep=0
build=1
for arg in "$@"; do
  case "$arg" in
    --keep) keep=1 ;;
    --skip-build) build=0 ;;
    *) echo "usage: $0 [--keep] [--skip-build]" >&2; exit 2 ;;
  esac
done
if [ "$(id -u)" -ne 0 ]; then
  echo "check-install: installs packages system-wide: run it as root" >&2
  exit 2
fi
export DEBIAN_FRONTEND=noninteractive
packages=(teamscan-common teamscan-onboard teamscan-groundstation teamscan-tools)
debs=build/package/debs
started=$SECONDS
phase() { echo "== check-install: $* ($((SECONDS - started)) s)"; }
fail() { echo "check-install: FAILED: $*" >&2; exit 1; }

if [ "$build" -eq 1 ]; then
  phase "build the packages"
  rm -rf "$debs"
  cmake --preset package
  cmake --build --preset package -j "$(nproc)"
  cpack --preset package
fi
mapfile -t files < <(ls "$debs"/teamscan-*.deb)
[ "${#files[@]}" -eq "${#packages[@]}" ] || fail "expected ${#packages[@]} packages in $debs, found ${#files[@]}"
for f in "${files[@]}"; do
  echo "-- $f"
  dpkg-deb --field "$f" Package Version Architecture Depends Recommends
done

phase "lintian"
# Errors fail the check; warnings and notes are printed (the accepted ones: deploy/debian/README.md).
lintian --fail-on error --display-info "${files[@]}" || fail "lintian reports errors"

phase "install"
tmp="$(mktemp -d /tmp/teamscan-check-install-XXXXXX)"
cleanup() {
  if [ "$keep" -eq 0 ]; then
    echo "== check-install: remove the packages"
    apt-get remove -y --purge "${packages[@]}" >/dev/null || true
  fi
  rm -rf "$tmp"
}
trap cleanup EXIT
apt-get install -y --no-install-recommends "${files[@]/#/./}"

phase "the installed result"
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}\n' "$p" | grep -qx "install ok installed" || fail "$p is not installed"
done
getent passwd teamscan >/dev/null || fail "no teamscan user"
id -nG teamscan | tr ' ' '\n' | grep -qx dialout || fail "the teamscan user is not in dialout"
enabled="$(find /etc/systemd/system -name 'teamscan*' 2>/dev/null || true)"
[ -z "$enabled" ] || fail "a package enabled a unit: $enabled"

commit="unknown"
if git rev-parse --show-toplevel >/dev/null 2>&1; then commit="$(git rev-parse --short=12 HEAD)"; fi
for prog in teamscan teamscan-onboard teamscan-groundstation; do
  line="$("/usr/bin/$prog" --version)"
  echo "$line"
  [[ "$line" =~ ^$prog\ [0-9]+\.[0-9]+\.[0-9]+\ \(git\ ([0-9a-f]{12}(-dirty)?|unknown)\)$ ]] || fail "$prog --version: '$line'"
  [[ "$line" == *"$commit"* ]] || fail "$prog --version does not name the commit $commit"
  [ -f "/usr/share/man/man1/$prog.1.gz" ] || fail "no man page for $prog"
done

examples=/usr/share/teamscan/examples
for cfg in onboard-down-laser onboard-up-laser; do
  /usr/bin/teamscan-onboard --config "$examples/$cfg.toml" --check-config >/dev/null || fail "--check-config $cfg.toml"
done
/usr/bin/teamscan-groundstation --config "$examples/groundstation.toml" --check-config >/dev/null ||
  fail "--check-config groundstation.toml"
echo "check-config: the installed examples are valid"

units=/usr/lib/systemd/system
cp "$units/teamscan-onboard@.service" "$tmp/teamscan-onboard@robot1.service"
cp "$units/teamscan-groundstation.service" "$tmp/teamscan-groundstation.service"
for unit in "$tmp/teamscan-onboard@robot1.service" "$tmp/teamscan-groundstation.service"; do
  name="$(basename "$unit")"
  # verify exits 0 on unknown keys and bad values: any message is a failure.
  messages="$(systemd-analyze verify "$unit" 2>&1 >/dev/null || echo "exit status $?")"
  [ -z "$messages" ] || fail "systemd-analyze verify $name: $messages"
  exposure="$(systemd-analyze security --offline=yes "$unit" 2>&1 | sed -n 's/.*Overall exposure level for [^:]*: \([0-9.]*\).*/\1/p')"
  [ -n "$exposure" ] || fail "systemd-analyze security $name printed no exposure"
  awk -v e="$exposure" 'BEGIN { exit !(e <= 2.0) }' || fail "$name: exposure $exposure > 2.0"
  echo "systemd: $name verifies silently, exposure $exposure"
done

phase "teamscan demo from /usr/bin"
demo_s="${DEMO_SECONDS:-10}"
rc=0
(cd "$tmp" && /usr/bin/teamscan demo --scenario lap2 --duration "$demo_s" --out "$tmp/demo" --quiet) > "$tmp/demo.log" 2>&1 || rc=$?
[ "$rc" -eq 0 ] || { tail -n 40 "$tmp/demo.log"; fail "teamscan demo exited $rc"; }
grep -q "on loopback (/usr/share/teamscan/cyclonedds-lo.xml)" "$tmp/demo.log" ||
  { head -n 5 "$tmp/demo.log"; fail "the demo did not use the installed loopback DDS config"; }
tail -n 12 "$tmp/demo.log"

phase "upgrade restarts a running station, remove stops it"
bash scripts/check-upgrade.sh "$debs" || fail "scripts/check-upgrade.sh"

phase "passed"
