#!/bin/sh
# `teamscan eval` on a real CARMEN log with a level laser's graph options (docs/slam.md "A held-out log in
# open spaces"): MIT CSAIL imported, evaluated against its relations with local SLAM's search off and the
# heading pull, closure window and closure distance set; the summary counts no local search, every
# relation is used and the Reproduce line carries the options. With every scan below the search's score
# eval warns of open spaces. A value out of range is refused.
# Usage: eval_pose_graph_options.sh TEAMSCAN SOURCE_DIR WORKDIR
set -eu
teamscan=$1 src=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
"$teamscan" import carmen "$src/tests/data/real/mit-csail.clf.xz" --out "$work/mit" --flaser-step-fov-over-n > "$work/import.log" 2>&1 ||
  { cat "$work/import.log"; exit 1; }
"$teamscan" eval "$work/mit" --method frequency --resolution 0.1 --relations "$src/tests/data/real/mit-csail.relations" \
  --pose-graph-local-search-score 0 --pose-graph-local-rotation-weight 10 --pose-graph-closure-window 4 \
  --pose-graph-closure-max-distance 9 > "$work/eval.out" 2> "$work/eval.err" || { tail -20 "$work/eval.err"; exit 1; }
fail() { echo "$1"; echo "--- stdout"; cat "$work/eval.out"; echo "--- stderr"; cat "$work/eval.err"; exit 1; }
grep -q "placed by local SLAM's search of 0, 0 below its score not searched," "$work/eval.err" || fail "local SLAM searched with --pose-graph-local-search-score 0"
grep -q "^| pose graph | 1172 of 1172 |" "$work/eval.out" || fail "not every relation used"
grep -q -- "--pose-graph-local-search-score 0 --pose-graph-local-rotation-weight 10 --pose-graph-closure-window 4 --pose-graph-closure-max-distance 9" \
  "$work/eval.out" || fail "the Reproduce line does not carry the options"
grep -q "warning: .* scored below local SLAM" "$work/eval.err" && fail "an open-space warning without a search"
grep "^| pose graph" "$work/eval.out"
# Every scan below the search's score: searched for the robot's first scans only, and eval warns of open
# spaces.
"$teamscan" eval "$work/mit" --method frequency --resolution 0.1 --pose-graph-local-search-score 1 > "$work/searched.out" 2> "$work/searched.err" ||
  { tail -20 "$work/searched.err"; exit 1; }
grep -q "placed by local SLAM's search of [1-9][0-9]*, [1-9][0-9]* below its score not searched," "$work/searched.err" ||
  { echo "every scan below the search's score: not searched at first and then declined"; cat "$work/searched.err"; exit 1; }
grep "warning: .* scored below local SLAM" "$work/searched.err" ||
  { echo "no open-space warning with every scan below the search's score"; cat "$work/searched.err"; exit 1; }
# Out of range: refused before anything runs, with the option named.
rc=0
"$teamscan" eval "$work/mit" --pose-graph-closure-window 0 > /dev/null 2> "$work/bad.err" || rc=$?
[ "$rc" -ne 0 ] && grep -q -- "--pose-graph-closure-window" "$work/bad.err" ||
  { echo "a closure window of 0: exit $rc, stderr: $(cat "$work/bad.err")"; exit 1; }
echo "refused: $(head -1 "$work/bad.err")"
