#!/usr/bin/env bash
# The pose graph's pose error on simulated scenarios over several seeds: for each scenario and seed,
# `teamscan sim S --seed N --direct`, then `teamscan eval --method best --no-registration --pose-graph
# --json` (plus EVAL_ARGS), and one line of the graph's pose error against the truth (translation p50 /
# p99 / max in cm, rotation p50 / p99 / max in degrees) beside odometry alone's p99; then, per scenario,
# the worst and the mean of the graph's p99 over the seeds. Figures, not a test: the graph's result on
# one seed moves with which closures it finds, so a change is judged on several (docs/slam.md "Tilted
# lasers").
#
# usage: [SEEDS="own 101 102"] [EVAL_ARGS="..."] [WORK=dir] [NICE=5] \
#        tests/bench/posegraph/run_sim_seeds.sh [BUILD_DIR] [SCENARIO ...]
#        default: build/dev, the drift scenarios lap2-drift corridor2 team3-drift loops2-drift
#   "own" in SEEDS is the scenario's own seed (its file's `seed`). Data sets and reports go to WORK
#   (default: a temporary folder, removed at the end unless WORK is given).
set -u
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
build="${1:-$root/build/dev}"
shift 2>/dev/null || true
scenarios=("$@")
[ ${#scenarios[@]} -eq 0 ] && scenarios=(lap2-drift corridor2 team3-drift loops2-drift)
teamscan="$build/tools/teamscan/teamscan"
[ -x "$teamscan" ] || { echo "build the teamscan target first ($teamscan)" >&2; exit 2; }
command -v python3 > /dev/null || { echo "python3 is needed to read the JSON reports" >&2; exit 2; }
export CYCLONEDDS_URI="file://$root/deploy/cyclonedds-lo.xml"  # eval uses no DDS; set as every run here
seeds="${SEEDS:-own 101 102}"
nice_level="${NICE:-5}"
if [ -n "${WORK:-}" ]; then
  work="$WORK"
  mkdir -p "$work"
else
  work="$(mktemp -d)"
  trap 'rm -rf "$work"' EXIT
fi

echo "# pose graph over odometry, $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) CPUs, load $(cut -d' ' -f1 /proc/loadavg); eval args: --method best --no-registration --pose-graph ${EVAL_ARGS:-}"
printf '%-14s %6s | %-22s %-22s | %-18s | %6s\n' scenario seed "graph cm p50/p99/max" "graph deg p50/p99/max" "odometry p99 cm/deg" "wall s"
summary=()
for s in "${scenarios[@]}"; do
  p99s=()
  for seed in $seeds; do
    out="$work/$s-$seed"
    seed_args=()
    [ "$seed" != own ] && seed_args=(--seed "$seed")
    if ! nice -n "$nice_level" "$teamscan" sim "$s" "${seed_args[@]}" --direct --out "$out" -q > "$out.sim.log" 2>&1; then
      echo "$s seed $seed: sim failed (see $out.sim.log)" >&2
      continue
    fi
    start_ns=$(date +%s%N)
    # shellcheck disable=SC2086  # EVAL_ARGS is a list of arguments
    if ! nice -n "$nice_level" "$teamscan" eval "$out" --method best --no-registration --pose-graph ${EVAL_ARGS:-} --json "$out.json" -q > "$out.eval.log" 2>&1; then
      echo "$s seed $seed: eval failed (see $out.eval.log)" >&2
      rm -rf "$out"
      continue
    fi
    wall_ds=$((($(date +%s%N) - start_ns) / 100000000))  # tenths of a second
    rm -rf "$out"  # the data set (up to a few GB); its report stays
    line=$(python3 - "$out.json" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1]))
g = r.get("pose_graph")
if not g:
    sys.exit("no pose_graph in the report (a data set without truth?)")
m, d = g["pose_m_graph"], g["pose_deg_graph"]
om, od = g["pose_m_odometry"], g["pose_deg_odometry"]
seed = r.get("seed", "")
print(f"{seed} {100*m['p50']:.1f}/{100*m['p99']:.1f}/{100*m['max']:.1f} {d['p50']:.2f}/{d['p99']:.2f}/{d['max']:.2f} "
      f"{100*om['p99']:.1f}/{od['p99']:.2f} {100*m['p99']:.2f} {d['p99']:.3f}")
EOF
    ) || { echo "$s seed $seed: $line" >&2; continue; }
    read -r used gm gd od pm pd <<< "$line"
    printf '%-14s %6s | %-22s %-22s | %-18s | %4d.%d\n' "$s" "$used" "$gm" "$gd" "$od" $((wall_ds / 10)) $((wall_ds % 10))
    p99s+=("$pm $pd")
  done
  [ ${#p99s[@]} -eq 0 ] && continue
  summary+=("$(printf '%s\n' "${p99s[@]}" | awk -v s="$s" '{ t += $1; r += $2; if ($1 > wt) wt = $1; if ($2 > wr) wr = $2; n++ }
    END { printf "%-14s %d seeds: graph p99 worst %.1f cm / %.2f deg, mean %.1f cm / %.2f deg", s, n, wt, wr, t / n, r / n }')")
done
echo
printf '%s\n' "${summary[@]}"
