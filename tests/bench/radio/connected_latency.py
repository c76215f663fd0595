#!/usr/bin/env python3
# The connected robots' steady scan -> fused map latency of a `teamscan demo` run (docs/radio.md
# "Measurements"); figures, no pass/fail.
#   connected_latency.py OUT [--duration D] [ROBOT:AT:FOR ...]   (the run's --out, --duration, --shadow faults)
# session/fused_latency.csv, every scan once (first line), world time t = (stamp - t0); t0 from the first
# "robot 1 LOST" in events.log (robot 1's first shadow at world AT, its link down at AT + 0.1 s, the 2 s
# lease) or, without shadows, the last stamp - (D + 1.6 s) (the same offset in the shadow runs). Window
# t in [2, D - 2] s. Two figures, by what counts as a robot's own shadow (its scans stamped in it are
# back-filled, left out):
#   link down:    [AT - 0.2, AT + FOR + 0.5], the radio link down;
#   DDS matched:  [AT - 0.2, the station hears it again] ("robot N back: heard again" in events.log):
#                 after the link is up, discovery takes a second or more, and what the robot scans
#                 until then can only reach the station by the back-fill.
import sys
args = sys.argv[1:]
out = args.pop(0)
duration = 60.0
if args and args[0] == '--duration':
    duration = float(args[1]); args = args[2:]
shadows = [tuple(float(x) for x in s.split(':')) for s in args]  # ROBOT:AT:FOR
rows = []
for line in open(out + '/session/fused_latency.csv'):
    p = line.strip().split(',')
    if len(p) == 5 and p[0].isdigit(): rows.append(tuple(int(x) for x in p))
events = open(out + '/session/events.log').read().splitlines()
t0 = None
r1 = sorted(AT for R, AT, FOR in shadows if int(R) == 1)
if r1:
    for line in events:
        if 'robot 1 LOST' in line: t0 = int(line.split()[0]) - int((r1[0] + 2.1) * 1e9); break
if t0 is None: t0 = max(r[2] for r in rows) - int((duration + 1.6) * 1e9)
heard = [(int(l.split()[3]), (int(l.split()[0]) - t0) / 1e9) for l in events if ' back: heard again' in l]
def matched_again(R, AT, FOR):
    after = [t for r, t in heard if r == int(R) and t >= AT + FOR]
    return min(after) if after else duration
windows = {
    'link down': [(int(R), AT - 0.2, AT + FOR + 0.5) for R, AT, FOR in shadows],
    'DDS matched': [(int(R), AT - 0.2, matched_again(R, AT, FOR)) for R, AT, FOR in shadows],
}
for name, win in windows.items():
    seen = set(); lat = []
    for r, seq, st, rc, fu in rows:
        if (r, seq) in seen: continue
        seen.add((r, seq))
        t = (st - t0) / 1e9
        if t < 2 or t > duration - 2: continue
        if any(R == r and a <= t <= b for R, a, b in win): continue
        lat.append((fu - st) / 1e6)
    lat.sort()
    q = lambda f: lat[min(len(lat) - 1, int(f * (len(lat) - 1)))]
    label = f" (shadow = {name})" if shadows else ""
    print(f"{out}{label}: {len(lat)} connected scans, scan -> fused map p50 {q(.5):.0f} ms, p90 {q(.9):.0f} ms, "
          f"p99 {q(.99):.0f} ms, max {lat[-1]:.0f} ms")
    if not shadows: break
if shadows:
    print("  back after its shadow (world s): " + ", ".join(
        f"robot {int(R)} at {AT:g}+{FOR:g}: heard again {matched_again(R, AT, FOR):.1f}" for R, AT, FOR in shadows))
