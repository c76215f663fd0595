#!/usr/bin/env python3
"""A ROS 1 bag of a 2-D SLAM benchmark log back to CARMEN text, for `teamscan import carmen`.

The Freiburg SLAM-evaluation logs (Kümmerle et al. 2009: ACES, MIT CSAIL, FR079, …) are published
with their relations in INESCTEC/ricoslam (`inesctec_mrdt_slam_2d_datasets/bag/NAME.orig.bag`,
`data/NAME.relations`), as bags their CARMEN-to-ROS converter wrote: `sensor_msgs/LaserScan` on /scan
stamped with the scan's CARMEN ipc_timestamp, `nav_msgs/Odometry` on /odom from its ODOM lines. This
writes one laser line per scan (its odometry pose: the last /odom before it) and one `ODOM` line per
/odom message, in the bag's order, each stamp to the microsecond (or, with --stamp-step-us, rounded half
up to that step; MIT CSAIL's own CARMEN log is published beside its relations and needs no bag). Out-of-range readings (NaN, inf) are
written as 0 (no return). The laser line is `FLASER` (the laser at the robot's origin), or, with
--mount-from-tf and /tf_static mounting the laser elsewhere (FR079's 4 cm ahead), `ROBOTLASER1` with
that offset and its beams 180°/n apart from −90°, as `teamscan import carmen --flaser-step-fov-over-n`
places a FLASER's. (FR079's relations fit the laser's own poses better: docs/slam.md.)

Standard library only (bz2 chunks; an lz4-compressed bag is refused).

usage: rosbag_to_carmen.py BAG [--stamp-step-us N] [--mount-from-tf] > LOG.clf
"""
import argparse
import bz2
import math
import struct
import sys


def header_fields(buf):
    out, i = {}, 0
    while i < len(buf):
        (n,) = struct.unpack_from('<I', buf, i)
        i += 4
        key, _, value = buf[i:i + n].partition(b'=')
        out[key.decode()] = value
        i += n
    return out


def records(buf, i=0):
    while i + 4 <= len(buf):
        (n,) = struct.unpack_from('<I', buf, i)
        head = header_fields(buf[i + 4:i + 4 + n])
        i += 4 + n
        (m,) = struct.unpack_from('<I', buf, i)
        yield head, buf[i + 4:i + 4 + m]
        i += 4 + m


def ros_string(data, i):
    (n,) = struct.unpack_from('<I', data, i)
    return data[i + 4:i + 4 + n].decode(errors='replace'), i + 4 + n


def ros_header(data):
    _seq, sec, nsec = struct.unpack_from('<III', data, 0)
    _frame, i = ros_string(data, 12)
    return sec, nsec, i


def stamp(sec, nsec, step_us):
    us = (nsec + 500) // 1000
    us = (us + step_us // 2) // step_us * step_us
    return '%d.%06d' % (sec + us // 1_000_000, us % 1_000_000)


def messages(path):
    data = open(path, 'rb').read()
    if not data.startswith(b'#ROSBAG V2.0\n'):
        sys.exit('%s: not a ROS bag (version 2.0)' % path)
    types = {}

    def take(head, body):
        op = head.get('op', b'\0')[0]
        if op == 7:  # connection
            types[struct.unpack('<I', head['conn'])[0]] = header_fields(body).get('type', b'').decode()
        elif op == 2:  # message data
            yield types.get(struct.unpack('<I', head['conn'])[0], ''), body

    for head, body in records(data, len(b'#ROSBAG V2.0\n')):
        if head.get('op', b'\0')[0] == 5:  # chunk
            kind = head['compression'].decode()
            if kind == 'bz2':
                body = bz2.decompress(body)
            elif kind != 'none':
                sys.exit('%s: %s-compressed chunks are not supported' % (path, kind))
            for inner_head, inner_body in records(body):
                yield from take(inner_head, inner_body)
        else:
            yield from take(head, body)


def laser_mount(body):
    """The first transform of a tf2_msgs/TFMessage whose child frame is the laser: (x, y, yaw) or None."""
    (count,) = struct.unpack_from('<I', body, 0)
    i = 4
    for _ in range(count):
        _seq, _sec, _nsec = struct.unpack_from('<III', body, i)
        _parent, i = ros_string(body, i + 12)
        child, i = ros_string(body, i)
        x, y, _z, qx, qy, qz, qw = struct.unpack_from('<7d', body, i)
        i += 56
        if 'laser' in child:
            return x, y, math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
    return None


def compose(pose, offset):
    x, y, th = pose
    c, s = math.cos(th), math.sin(th)
    return x + c * offset[0] - s * offset[1], y + s * offset[0] + c * offset[1], th + offset[2]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('bag')
    parser.add_argument('--stamp-step-us', type=int, default=1)
    parser.add_argument('--mount-from-tf', action='store_true', help='ROBOTLASER1 lines with the laser mount of /tf_static')
    args = parser.parse_args()
    out = sys.stdout
    odometry = (0.0, 0.0, 0.0)
    mount = None
    scans = odoms = 0
    for kind, body in messages(args.bag):
        if kind == 'tf2_msgs/TFMessage' and mount is None and args.mount_from_tf:
            found = laser_mount(body)
            if found and max(abs(v) for v in found) > 1e-9:
                mount = found
        elif kind == 'nav_msgs/Odometry':
            sec, nsec, i = ros_header(body)
            _child, i = ros_string(body, i)
            x, y, _z, qx, qy, qz, qw = struct.unpack_from('<7d', body, i)
            odometry = (x, y, math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz)))
            t = stamp(sec, nsec, args.stamp_step_us)
            out.write('ODOM %.6f %.6f %.6f 0 0 0 %s bag %s\n' % (*odometry, t, t))
            odoms += 1
        elif kind == 'sensor_msgs/LaserScan':
            sec, nsec, i = ros_header(body)
            range_max = struct.unpack_from('<f', body, i + 6 * 4)[0]
            i += 7 * 4  # angle_min, angle_max, angle_increment, time_increment, scan_time, range_min, range_max
            (n,) = struct.unpack_from('<I', body, i)
            ranges = struct.unpack_from('<%df' % n, body, i + 4)
            readings = ' '.join('%.3f' % r if math.isfinite(r) else '0.000' for r in ranges)
            t = stamp(sec, nsec, args.stamp_step_us)
            pose = '%.6f %.6f %.6f' % odometry
            if mount is None:
                out.write('FLASER %d %s %s %s %s bag %s\n' % (n, readings, pose, pose, t, t))
            else:
                # type start_angle fov resolution max_range accuracy remission_mode n ranges 0 (remissions)
                # laser pose, robot pose, tv rv forward_safety side_safety turn_axis, stamps.
                laser = '%.6f %.6f %.6f' % compose(odometry, mount)
                out.write('ROBOTLASER1 0 %.9f %.9f %.9f %.1f 0.01 0 %d %s 0 %s %s 0 0 0 0 0 %s bag %s\n' %
                          (-math.pi / 2, math.pi, math.pi / n, range_max, n, readings, laser, pose, t, t))
            scans += 1
    sys.stderr.write('%s: %d scans, %d odometry messages, laser mounted at %s\n' % (args.bag, scans, odoms, mount or 'the origin'))


if __name__ == '__main__':
    try:
        main()
    except (struct.error, KeyError, ValueError, OSError, EOFError) as e:
        sys.exit('rosbag_to_carmen: %s: not a readable ROS bag (%s: %s)' % (sys.argv[1] if len(sys.argv) > 1 else '?', type(e).__name__, e))
