#!/usr/bin/env bash
# The cost of DDS Security (docs/security.md "Cost"): N robots x RATE Hz of 181-point scans (+ 10 Hz
# poses) from teamscan_secure_feed into the real teamscan-groundstation (fusion on, its default method),
# once without and once with DDS Security, one after the other in one run. Each mode runs in its own
# network namespace (`unshare -n`, root) so that lo carries this run's traffic only. Prints per mode: the
# feeder's match time, scans written, the station's scan -> fused map p50/p99/max (its events.log, all
# scans), the station's CPU over the feed (utime+stime from /proc, before its final model write), the
# feeder's CPU per robot (one process per robot: the DDS publishing cost of one robot), the slowest
# robot's match time, and the bytes on lo, and the steady-state scan -> fused map p50/p99 (after the
# feed's first 2 s, up to 1.5 s before its end) from the station's fused_latency.csv. The station decides with the decision lag
# TEAM_LAG (fusion.team_lag_s, default 0.15 s; docs/groundstation.md).
# TOPOLOGY=star (default): the robots' Cyclone config names the station as their only peer (participant
# index none, the station's discovery port), as a site whose robots peer with the ground station only
# (docs/security.md "Discovery: robots peer with the station"): each robot authenticates the station
# alone. TOPOLOGY=mesh: every participant uses deploy/cyclonedds-lo.xml and finds every other one (the
# robots authenticate each other too: N(N+1)/2 handshakes).
#
# usage: [TEAM_LAG=S] [TOPOLOGY=star|mesh] tests/bench/security/run_security_cost.sh [BUILD_DIR] [N] [RATE_HZ] [SECONDS]   (default build/dev 32 75 10)
set -u
here="$(cd "$(dirname "$0")" && pwd)"
build="$(cd "${1:-$here/../../../build/dev}" && pwd)"
n="${2:-32}"; rate="${3:-75}"; seconds="${4:-10}"
teamscan="$build/tools/teamscan/teamscan"
station="$(find "$build/groundstation" -name teamscan-groundstation -type f | head -1)"
feed="$build/tests/bench/security/teamscan_secure_feed"
for b in "$teamscan" "$station" "$feed"; do [ -x "$b" ] || { echo "missing $b (build teamscan, teamscan-groundstation, teamscan_secure_feed)" >&2; exit 2; }; done
lo_xml="$here/../../../deploy/cyclonedds-lo.xml"
work="$(mktemp -d /tmp/teamscan-seccost.XXXXXX)"
domain=7
topology="${TOPOLOGY:-star}"
station_uri="file://$lo_xml"; robot_uri="file://$lo_xml"
if [ "$topology" = star ]; then
  # The station on participant index 0, whose discovery port is 7400 + 250 x domain + 10 (DDSI's
  # default port mapping); a robot has no index of its own (it is reached at the address it announces).
  sed 's|<ParticipantIndex>auto</ParticipantIndex>|<ParticipantIndex>0</ParticipantIndex>|' "$lo_xml" > "$work/cyclone-station.xml"
  sed -e 's|<ParticipantIndex>auto</ParticipantIndex>|<ParticipantIndex>none</ParticipantIndex>|' \
      -e "s|<Peer address=\"127.0.0.1\"/>|<Peer address=\"127.0.0.1:$((7400 + 250 * domain + 10))\"/>|" "$lo_xml" > "$work/cyclone-robot.xml"
  grep -q '<ParticipantIndex>0<' "$work/cyclone-station.xml" && grep -q "127.0.0.1:$((7400 + 250 * domain + 10))" "$work/cyclone-robot.xml" ||
    { echo "cannot derive the star configs from $lo_xml" >&2; exit 2; }
  station_uri="file://$work/cyclone-station.xml"; robot_uri="file://$work/cyclone-robot.xml"
elif [ "$topology" != mesh ]; then
  echo "TOPOLOGY must be star or mesh, got $topology" >&2; exit 2
fi
"$teamscan" pki init "$work/site" --robots "$n" --domains "$domain" --days 2 > /dev/null || exit 1
cat > "$work/station.toml" <<TOML
[station]
session_root = "$work/sessions"
status_interval_s = 1.0
[dds]
domain_id = $domain
[fusion]
enabled = true
write_interval_s = 0
latency_log = true
team_lag_s = ${TEAM_LAG:-0.15}
[view]
listen = ""
TOML
# Steady state: scan -> fused map of the scans stamped after the first 2 s of the feed and more than 1.5 s
# before its end (fused_latency.csv: robot,seq,stamp_ns,received_ns,fused_ns), as p50/p99 (count). The
# histogram columns before it count every scan: the fusion core's start-up hold (its first hold_s) and
# the end, when every feeder leaves at once and the station handles N participants going (~0.9 s, in
# both modes), included.
steady() {
  [ -s "$1" ] || { echo "-"; return; }
  awk -F, '$3 !~ /^[0-9]+$/ { next }
           NR == FNR { if (first == "" || $3 + 0 < first) first = $3 + 0; if (last == "" || $3 + 0 > last) last = $3 + 0; next }
           $3 + 0 >= first + 2e9 && $3 + 0 <= last - 1.5e9 { print ($5 - $3) / 1e6 }' "$1" "$1" | sort -g |
    awk '{ v[NR] = $1 } END { if (NR == 0) { print "-"; exit } i50 = int(0.5 * NR); if (i50 < 1) i50 = 1; i99 = int(0.99 * NR); if (i99 < 1) i99 = 1; printf "%.1f/%.1f(%d)", v[i50], v[i99], NR }'
}
echo "# $(date -u +%FT%TZ) $n robots x $rate Hz x $seconds s, topology $topology, team_lag_s ${TEAM_LAG:-0.15}, 181-point scans, build $build, load $(cut -d' ' -f1-3 /proc/loadavg)"
printf '%-7s %8s %8s %9s %9s %9s %10s %12s %8s %22s\n' mode match_s scans p50_ms p99_ms max_ms gs_cpu_s feed_cpu/rb_s lo_MB "steady_p50/p99_ms(n)"
for mode in plain secure; do
  pki_station=(); pki_feed=()
  if [ "$mode" = secure ]; then pki_station=(--pki-dir "$work/site/station"); pki_feed=(--pki "$work/site"); fi
  unshare -n bash -c '
    ip link set lo up
    CYCLONEDDS_URI="${10}" "$1" --config "$2" --session-dir "$3/session-$4" '"${pki_station[*]:-}"' > "$3/station-$4.log" 2>&1 &
    spid=$!
    sleep 1
    for ((i = 1; i <= $6; i++)); do
      CYCLONEDDS_URI="${11}" "$5" --robots 1 --first $i --rate "$7" --seconds "$8" --domain "$9" '"${pki_feed[*]:-}"' > "$3/feed-$4-$i.log" 2>&1 &
    done
    wait $(jobs -p | grep -v "^$spid\$")
    read -r -a st < /proc/$spid/stat
    echo "$(( st[13] + st[14] ))" > "$3/station-cpu-$4"
    kill -TERM $spid; wait $spid
    awk "/lo:/ { print \$2 }" /proc/net/dev > "$3/lo-$4"
  ' bash "$station" "$work/station.toml" "$work" "$mode" "$feed" "$n" "$rate" "$seconds" "$domain" "$station_uri" "$robot_uri"
  lat=$(grep "scan -> fused map latency" "$work/session-$mode/events.log" | tail -1)
  tck=$(getconf CLK_TCK)
  printf '%-7s %8s %8s %9s %9s %9s %10.2f %12.3f %8.1f %22s\n' "$mode" \
    "$(cat "$work"/feed-$mode-*.log | sed -n 's/^matched 1 after \([0-9.]*\) s/\1/p' | sort -g | tail -1)" \
    "$(echo "$lat" | sed -n 's/.*latency: \([0-9]*\) scans.*/\1/p')" \
    "$(echo "$lat" | sed -n 's/.*p50 \([0-9.]*\) ms.*/\1/p')" \
    "$(echo "$lat" | sed -n 's/.*p99 \([0-9.]*\) ms.*/\1/p')" \
    "$(echo "$lat" | sed -n 's/.*max \([0-9.]*\) ms.*/\1/p')" \
    "$(awk -v t="$(cat "$work/station-cpu-$mode")" -v h="$tck" 'BEGIN { print t / h }')" \
    "$(cat "$work"/feed-$mode-*.log | sed -n 's/.*cpu \([0-9.]*\) s.*/\1/p' | awk -v n="$n" '{ t += $1 } END { print t / n }')" \
    "$(awk 'NR == 1 { print $1 / 1e6 }' "$work/lo-$mode")" \
    "$(steady "$work/session-$mode/fused_latency.csv")"
done
echo "outputs in $work (feed-MODE-ID.log, station-MODE.log, session-MODE/)"
