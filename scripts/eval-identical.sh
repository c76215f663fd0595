#!/usr/bin/env bash
# Proves a refactoring left every `teamscan eval` figure unchanged: two builds' `teamscan eval`, with and
# without --registration, on every simulator scenario, compared byte for byte (the Markdown report on
# stdout and the --json report).
#
# usage: scripts/eval-identical.sh OLD_TEAMSCAN NEW_TEAMSCAN [DURATION_S]
#   DURATION_S: simulated seconds per scenario (default 20), the scenario's default seed.
#   SCENARIOS="lap2 fig8 ..." narrows the list (default: every sim/scenarios/*.toml of this tree).
#   KEEP=DIR keeps the data sets and reports in DIR (default: a temporary folder, removed).
#
# Each data set is simulated once, by OLD, and both builds evaluate that same folder (the report's
# "Reproduce:" line names it, so the path must be the same). NEW's simulation of the scenario is also
# compared with OLD's (every file of the data set), so a change in the simulator shows too.
# Excluded: stderr (the progress lines, which carry wall-clock times); the reports themselves carry no
# wall-clock figure. Exit 0: all identical; 3: every report identical and every JSON report equal in keys
# (same order) and values but not byte for byte (a JSON writer's layout changed); 1: a difference
# (listed); 2: usage.
set -u
[ $# -ge 2 ] || { echo "usage: [SCENARIOS=\"lap2 ...\"] [KEEP=DIR] scripts/eval-identical.sh OLD_TEAMSCAN NEW_TEAMSCAN [DURATION_S]" >&2; exit 2; }
[ -x "$1" ] && [ -x "$2" ] || { echo "eval-identical: OLD and NEW must be teamscan executables" >&2; exit 2; }
old="$(realpath "$1")"
new="$(realpath "$2")"
duration="${3:-20}"
root="$(cd "$(dirname "$0")/.." && pwd)"
if [ -n "${SCENARIOS:-}" ]; then
  read -r -a scenarios <<< "$SCENARIOS"
else
  scenarios=()
  for f in "$root"/sim/scenarios/*.toml; do scenarios+=("$(basename "$f" .toml)"); done
fi
work="${KEEP:-$(mktemp -d /tmp/eval-identical.XXXXXX)}"
mkdir -p "$work"
[ -z "${KEEP:-}" ] && trap 'rm -rf "$work"' EXIT
cd "$work" || exit 2

echo "# $(date -u +%FT%TZ) eval-identical: ${#scenarios[@]} scenarios, ${duration} s each, default seeds"
echo "# OLD $old ($("$old" version 2>/dev/null | head -1))"
echo "# NEW $new ($("$new" version 2>/dev/null | head -1))"
differ=0
compared=0
layout=0
# Two JSON files with the same keys in the same order and equal values (15 and 15.0 are equal; a
# value's digits are compared as the numbers they spell): a change of layout, not of a figure.
json_values_equal() {
  python3 - "$1" "$2" <<'PY'
import json, sys
def load(p):
    return json.load(open(p), object_pairs_hook=lambda kv: kv)
sys.exit(0 if load(sys.argv[1]) == load(sys.argv[2]) else 1)
PY
}
for sc in "${scenarios[@]}"; do
  if ! "$old" sim "$sc" --out "ds-$sc" --duration "$duration" --quiet > /dev/null 2> "sim-$sc.old.err"; then
    echo "FAIL $sc: OLD's simulation failed: $(tail -1 "sim-$sc.old.err")"
    differ=1
    continue
  fi
  if ! "$new" sim "$sc" --out "ds-$sc.new" --duration "$duration" --quiet > /dev/null 2> "sim-$sc.new.err"; then
    echo "DIFFERS  $sc: NEW's simulation failed: $(tail -1 "sim-$sc.new.err")"
    differ=1
  elif diff -r -q "ds-$sc" "ds-$sc.new" > "sim-$sc.diff"; then
    echo "same     $sc: data set (NEW's simulation byte-identical)"
  else
    echo "DIFFERS  $sc: data set: $(head -3 "sim-$sc.diff" | tr '\n' ' ')"
    differ=1
  fi
  rm -rf "ds-$sc.new"
  for mode in off on; do
    args=()
    [ "$mode" = on ] && args=(--registration)
    for which in old new; do
      bin="$old"
      [ "$which" = new ] && bin="$new"
      "$bin" eval "ds-$sc" "${args[@]}" --json "$sc.$mode.$which.json" > "$sc.$mode.$which.md" 2> "$sc.$mode.$which.err"
      echo $? > "$sc.$mode.$which.rc"
    done
    compared=$((compared + 1))
    what="eval $sc, registration $mode"
    if cmp -s "$sc.$mode.old.md" "$sc.$mode.new.md" && cmp -s "$sc.$mode.old.json" "$sc.$mode.new.json" &&
       cmp -s "$sc.$mode.old.rc" "$sc.$mode.new.rc"; then
      echo "same     $what: exit $(cat "$sc.$mode.old.rc"), report $(wc -c < "$sc.$mode.old.md") B, json $(wc -c < "$sc.$mode.old.json") B"
    elif cmp -s "$sc.$mode.old.md" "$sc.$mode.new.md" && cmp -s "$sc.$mode.old.rc" "$sc.$mode.new.rc" &&
         json_values_equal "$sc.$mode.old.json" "$sc.$mode.new.json"; then
      echo "VALUES   $what: report byte-identical; JSON not byte-identical, but the same keys in the same order with equal values"
      layout=$((layout + 1))
    else
      echo "DIFFERS  $what (exit $(cat "$sc.$mode.old.rc") / $(cat "$sc.$mode.new.rc")):"
      diff "$sc.$mode.old.md" "$sc.$mode.new.md" | head -10
      diff "$sc.$mode.old.json" "$sc.$mode.new.json" | head -10
      differ=1
    fi
  done
done
if [ "$differ" = 0 ] && [ "$layout" = 0 ]; then
  echo "## identical: $compared evaluations (${#scenarios[@]} scenarios x registration off/on), every report and JSON byte for byte"
  exit 0
fi
if [ "$differ" = 0 ]; then
  echo "## same figures: $compared evaluations, every report byte for byte; $layout JSON reports equal in keys and values but not byte for byte"
  exit 3
fi
echo "## DIFFERENCES found (files in ${KEEP:-a removed temporary folder; KEEP=DIR keeps them})"
exit 1
