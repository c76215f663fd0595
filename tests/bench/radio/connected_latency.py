#!/usr/bin/env python3
# The connected robots' steady scan -> fused map latency of a `teamscan demo` run (docs/radio.md
# "Measurements"); figures, no pass/fail.
#   connected_latency.py OUT [ROBOT:AT:FOR ...]   (the run's --out and its --shadow faults)
# session/fused_latency.csv, every
# scan once (first line), world time t = (stamp - t0); t0 from the first "robot 1 LOST" in events.log
# (robot 1's first shadow at world 5.0 s, its link down at 5.1 s, the 2 s lease) or, without shadows,
# the last stamp - 61.6 s (the same offset in the shadow runs). Window t in [2, 58] s;
# a robot's scans stamped in its own shadow [AT - 0.2, AT + FOR + 0.5] (back-filled) are left out.
import sys, re
out = sys.argv[1]
shadows = [tuple(float(x) for x in s.split(':')) for s in sys.argv[2:]]  # ROBOT:AT:FOR
rows = []
for line in open(out + '/session/fused_latency.csv'):
    p = line.strip().split(',')
    if len(p) == 5 and p[0].isdigit(): rows.append(tuple(int(x) for x in p))
t0 = None
for line in (open(out + '/session/events.log') if len(sys.argv) > 2 else []):
    if 'robot 1 LOST' in line: t0 = int(line.split()[0]) - int(7.1e9); break
if t0 is None: t0 = max(r[2] for r in rows) - int(61.6e9)
seen = set(); lat = []
for r, seq, st, rc, fu in rows:
    if (r, seq) in seen: continue
    seen.add((r, seq))
    t = (st - t0) / 1e9
    if t < 2 or t > 58: continue
    if any(int(R) == r and AT - 0.2 <= t <= AT + FOR + 0.5 for R, AT, FOR in shadows): continue
    lat.append((fu - st) / 1e6)
lat.sort()
q = lambda f: lat[min(len(lat) - 1, int(f * (len(lat) - 1)))]
print(f"{out}: {len(lat)} connected scans, scan -> fused map p50 {q(.5):.0f} ms, p90 {q(.9):.0f} ms, p99 {q(.99):.0f} ms, max {lat[-1]:.0f} ms")
