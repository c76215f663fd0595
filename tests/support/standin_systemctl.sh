#!/bin/sh
# A stand-in for systemctl where systemd is not PID 1 (CI containers): enough of a service manager to
# watch what the packages' maintainer scripts (deploy/debian) do to running services, through dpkg and
# deb-systemd-invoke, when it is first in PATH. Every call is appended to $STANDIN_STATE/calls. A
# "started" unit is a process of its own: $STANDIN_EXEC (default: sleep 1000), run detached with
# STANDIN_UNIT set, its pid in $STANDIN_STATE/<unit>.pid. Unit arguments may be globs
# ('teamscan-onboard@*.service'), matched against the started units as systemctl matches loaded ones.
# Knows daemon-reload, is-enabled (every unit: enabled), is-active, start, stop, restart, try-restart.
set -u
state=${STANDIN_STATE:?set STANDIN_STATE to a state folder}
echo "$*" >> "$state/calls"
cmd=""
units=""
for a in "$@"; do
  case "$a" in
    -*) ;;
    *) if [ -z "$cmd" ]; then cmd=$a; else units="$units $a"; fi ;;
  esac
done
alive() { [ -f "$state/$1.pid" ] && kill -0 "$(cat "$state/$1.pid")" 2>/dev/null; }
start() {
  alive "$1" && return 0
  STANDIN_UNIT=$1 setsid sh -c "exec ${STANDIN_EXEC:-sleep 1000}" >> "$state/$1.log" 2>&1 < /dev/null &
  echo $! > "$state/$1.pid"
}
stop() {
  if alive "$1"; then
    pid=$(cat "$state/$1.pid")
    kill -TERM "$pid"
    i=0
    while kill -0 "$pid" 2>/dev/null && [ "$i" -lt 600 ]; do sleep 0.1; i=$((i + 1)); done
  fi
  rm -f "$state/$1.pid"
}
# The started units a unit argument names (a glob matches every started one it fits).
matching() {
  for f in "$state"/*.pid; do
    [ -e "$f" ] || continue
    u=$(basename "$f" .pid)
    # shellcheck disable=SC2254
    case "$u" in $1) echo "$u" ;; esac
  done
}
rc=0
for pattern in $units; do
  case "$cmd" in
    is-enabled) echo enabled ;;
    is-active) alive "$pattern" || rc=3 ;;
    start) start "$pattern" ;;
    stop) for u in $(matching "$pattern"); do stop "$u"; done ;;
    restart) for u in $(matching "$pattern"); do stop "$u"; done; start "$pattern" ;;
    try-restart) for u in $(matching "$pattern"); do alive "$u" && { stop "$u"; start "$u"; }; done ;;
  esac
done
exit $rc
