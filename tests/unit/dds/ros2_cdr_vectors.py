#!/usr/bin/env python3
# Hand encoder of the expected XCDR1 bytes in cdr_test.cpp, written from the encoding rules of
# ROS2_WIRE.md section 4 (its reference encoder, extended to the 4-field map cloud and to
# nav_msgs/Odometry). Independent of the code under test: run it to regenerate the hex literals.
# Offsets from the first byte after the 4-byte encapsulation header; little-endian; primitives aligned
# to their size; strings uint32 length (with NUL), bytes, NUL; sequences uint32 count then elements.
import math, struct


class Cdr:
    def __init__(s): s.b = bytearray()
    def put(s, f, v): s.b += bytes(-len(s.b) % struct.calcsize(f)) + struct.pack('<' + f, v)
    def str(s, t): e = t.encode() + b'\0'; s.put('I', len(e)); s.b += e
    def sample(s):  # CDR_LE, pad count in the option byte, as Cyclone writes it
        p = -len(s.b) % 4; return bytes([0, 1, 0, p]) + s.b + bytes(p)


def hdr(c, sec, ns, frame): c.put('i', sec); c.put('I', ns); c.str(frame)


def map_cloud(sec, ns, frame, pts):  # fields x y z hits, FLOAT32 at 0 4 8 12, height 1
    c = Cdr(); hdr(c, sec, ns, frame)
    for v in (1, len(pts), 4): c.put('I', v)
    for i, n in enumerate(['x', 'y', 'z', 'hits']): c.str(n); c.put('I', 4 * i); c.put('B', 7); c.put('I', 1)
    c.put('B', 0)
    for v in (16, 16 * len(pts), 16 * len(pts)): c.put('I', v)  # point_step, row_step, data length
    for p in pts: c.b += struct.pack('<4f', *p)
    c.put('B', 1); return c.sample()


def tf_message(tfs):  # [(sec, ns, parent, child, (x, y, z), (qx, qy, qz, qw))]
    c = Cdr(); c.put('I', len(tfs))
    for sec, ns, parent, child, t, q in tfs:
        hdr(c, sec, ns, parent); c.str(child)
        for v in t + q: c.put('d', v)
    return c.sample()


def odometry(sec, ns, frame, child, pos, q, pose_cov, lin, ang, twist_cov):
    c = Cdr(); hdr(c, sec, ns, frame); c.str(child)
    for v in pos + q: c.put('d', v)
    for v in pose_cov: c.put('d', v)
    for v in lin + ang: c.put('d', v)
    for v in twist_cov: c.put('d', v)
    return c.sample()


def show(name, b):
    print('// %s: %d bytes' % (name, len(b)))
    h = b.hex()
    for i in range(0, len(h), 64): print('"%s"' % h[i:i + 64])


S = (1700000000, 500000000)
# PointCloudMessage.set(stamp, "map", {(1,2,3,hits 4), (-1.5,0.25,10,hits 1)})
show('map cloud', map_cloud(*S, 'map', [(1, 2, 3, 4), (-1.5, .25, 10, 1)]))
# TfMessage.set (REP-105: map -> robotN/odom = the correction, robotN/odom -> robotN/base_link =
# inverse(correction) * tracked pose): robot 1 at (1.5,-2) yaw 0, no correction; robot 7 at (-3.25, 0.5)
# yaw pi, correction (0.5, -1, 0.25); same stamp.
def inv_compose(c, p):  # inverse(c) * p for planar poses (x, y, yaw)
    dx, dy = p[0] - c[0], p[1] - c[1]
    co, si = math.cos(c[2]), math.sin(c[2])
    yaw = math.remainder(p[2] - c[2], 2 * math.pi)
    return (co * dx + si * dy, -si * dx + co * dy, yaw)

def yq(yaw): return (0, 0, math.sin(yaw / 2), math.cos(yaw / 2))

def rep105(robot, pose, corr):
    o = inv_compose(corr, pose)
    return [(*S, 'map', 'robot%d/odom' % robot, (corr[0], corr[1], 0), yq(corr[2])),
            (*S, 'robot%d/odom' % robot, 'robot%d/base_link' % robot, (o[0], o[1], 0), yq(o[2]))]

show('tf', tf_message(rep105(1, (1.5, -2, 0), (0, 0, 0)) + rep105(7, (-3.25, .5, math.pi), (.5, -1, .25))))
# OdometryMessage.set: robot 3 at (1.25, -0.5) yaw pi, map velocity (2, 0.5), yaw rate 0.25,
# cov xx 0.01 xy 0.002 yy 0.04 (map frame), yaw variance 0.0025, correction (0.2, 0.1, 0.3): the pose
# in robot3/odom, the covariance rotated into it (R^T C R, R the correction's rotation); twist in
# base_link = R(-yaw) v.
yaw = math.pi; c, s = math.cos(yaw), math.sin(yaw); vx, vy = 2.0, 0.5
corr = (.2, .1, .3); o = inv_compose(corr, (1.25, -.5, yaw))
R = [[math.cos(corr[2]), -math.sin(corr[2])], [math.sin(corr[2]), math.cos(corr[2])]]
C = [[0.01, 0.002], [0.002, 0.04]]
Co = [[sum(R[k][i] * C[k][l] * R[l][j] for k in range(2) for l in range(2)) for j in range(2)] for i in range(2)]
cov = [0.0] * 36; cov[0] = Co[0][0]; cov[1] = cov[6] = Co[0][1]; cov[7] = Co[1][1]; cov[35] = 0.0025
show('odometry', odometry(*S, 'robot3/odom', 'robot3/base_link', (o[0], o[1], 0), yq(o[2]),
                          cov, (c * vx + s * vy, -s * vx + c * vy, 0), (0, 0, .25), [0.0] * 36))
