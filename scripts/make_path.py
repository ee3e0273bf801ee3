#!/usr/bin/python3
"""Writes a scalpel path CSV (t,x,y,z,qx,qy,qz,qw; mesh frame, seconds) for cut_replay.

  make_path.py OUT.csv --from X Y Z --to X Y Z [--via X Y Z] [--seconds S] [--rows N]
               [--tilt DEG --tilt-axis X Y Z] [--tremble M --seed K] [--back-and-forth N]

The tool origin moves from --from to --to (through --via on a quadratic Bezier curve when given);
the blade points along the tool's -z axis. --tilt turns the tool about --tilt-axis; --tremble adds
Gaussian noise of M metres to each row (and M/0.01 rad of twist); --back-and-forth repeats the
stroke N times, alternating direction."""
import argparse
import math
import random


def quat_axis_angle(axis, angle):
    n = math.sqrt(sum(a * a for a in axis)) or 1.0
    s = math.sin(angle / 2) / n
    return (axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle / 2))


def quat_mul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('out')
    p.add_argument('--from', dest='start', nargs=3, type=float, required=True)
    p.add_argument('--to', dest='end', nargs=3, type=float, required=True)
    p.add_argument('--via', nargs=3, type=float)
    p.add_argument('--seconds', type=float, default=2.0)
    p.add_argument('--rows', type=int, default=100)
    p.add_argument('--tilt', type=float, default=0.0)
    p.add_argument('--tilt-axis', nargs=3, type=float, default=[1.0, 0.0, 0.0])
    p.add_argument('--tremble', type=float, default=0.0)
    p.add_argument('--seed', type=int, default=1)
    p.add_argument('--back-and-forth', type=int, default=1)
    a = p.parse_args()
    rng = random.Random(a.seed)
    base_q = quat_axis_angle(a.tilt_axis, math.radians(a.tilt))
    rows = ['t,x,y,z,qx,qy,qz,qw']
    k = 0
    for stroke in range(a.back_and_forth):
        for i in range(a.rows + 1):
            if stroke > 0 and i == 0:
                continue
            s = i / a.rows
            if stroke % 2 == 1:
                s = 1.0 - s
            if a.via:
                pt = [(1 - s) ** 2 * a.start[j] + 2 * s * (1 - s) * a.via[j] + s * s * a.end[j] for j in range(3)]
            else:
                pt = [(1 - s) * a.start[j] + s * a.end[j] for j in range(3)]
            q = base_q
            if a.tremble > 0:
                pt = [c + rng.gauss(0.0, a.tremble) for c in pt]
                q = quat_mul(base_q, quat_axis_angle([0, 0, 1], rng.gauss(0.0, a.tremble / 0.01)))
            t = a.seconds * k / a.rows
            rows.append('%.4f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f' % ((t,) + tuple(pt) + q))
            k += 1
    with open(a.out, 'w') as f:
        f.write('\n'.join(rows) + '\n')


if __name__ == '__main__':
    main()
