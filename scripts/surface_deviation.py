#!/usr/bin/python3
"""How far collapse moved the surface: every boundary vertex of REFERENCE (a replay without
collapse) against the boundary triangles of COLLAPSED (the same replay with collapse), in rest
positions (point data `rest` of cut_replay's .vtk, else the points). Prints the largest, the 99th
percentile and how many lie off by more than 10 um; with --mean-edge L also relative to L.

usage: scripts/surface_deviation.py REFERENCE.vtk COLLAPSED.vtk [--mean-edge L] [--json]
Needs python3-meshio, python3-numpy (Debian)."""
import argparse
import json
import sys
from collections import Counter

import numpy as np


def boundary(path):
    import meshio
    m = meshio.read(path)
    points = np.asarray(m.point_data.get('rest', m.points), dtype=float)
    tets = m.cells_dict.get('tetra')
    if tets is None or len(tets) == 0:
        sys.exit('surface_deviation.py: %s has no tetrahedra' % path)
    count = Counter()
    for t in tets:
        for f in ((1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2)):
            count[tuple(sorted(int(t[i]) for i in f))] += 1
    faces = np.array([f for f, c in count.items() if c == 1], dtype=int)
    return points, faces


def segment_distance(p, a, b):
    d = b - a
    t = np.clip(((p - a) * d).sum(1) / np.maximum((d * d).sum(1), 1e-300), 0.0, 1.0)
    return np.linalg.norm(p - (a + d * t[:, None]), axis=1)


def triangle_distance(p, a, b, c):
    """Distance from point p to each triangle (a[i], b[i], c[i])."""
    ab, ac = b - a, c - a
    n = np.cross(ab, ac)
    n2 = (n * n).sum(1)
    ok = n2 > 0
    # Projection onto the plane and its barycentric coordinates.
    w = p - a
    s = np.zeros(len(a))
    t = np.zeros(len(a))
    s[ok] = (np.cross(w, ac) * n).sum(1)[ok] / n2[ok]
    t[ok] = (np.cross(ab, w) * n).sum(1)[ok] / n2[ok]
    inside = ok & (s >= 0) & (t >= 0) & (s + t <= 1)
    edges = np.min([segment_distance(p, a, b), segment_distance(p, a, c),
                    segment_distance(p, b, c)], axis=0)
    plane = np.zeros(len(a))
    plane[ok] = np.abs((w * n).sum(1)[ok]) / np.sqrt(n2[ok])
    return np.where(inside, plane, edges)


def main():
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('reference')
    p.add_argument('collapsed')
    p.add_argument('--mean-edge', type=float, default=0.0)
    p.add_argument('--json', action='store_true')
    a = p.parse_args()
    ref_points, ref_faces = boundary(a.reference)
    points, faces = boundary(a.collapsed)
    ta, tb, tc = points[faces[:, 0]], points[faces[:, 1]], points[faces[:, 2]]
    vertices = np.unique(ref_faces)
    d = np.array([triangle_distance(ref_points[v], ta, tb, tc).min() for v in vertices])
    out = {'vertices': int(len(d)), 'max_m': float(d.max()), 'p99_m': float(np.percentile(d, 99)),
           'off_by_more_than_10um': int((d > 1e-5).sum())}
    if a.mean_edge > 0:
        out['max_per_mean_edge'] = out['max_m'] / a.mean_edge
    if a.json:
        print(json.dumps(out))
        return
    line = 'boundary vertices %d: max %.3f mm, p99 %.3f mm, %d off by more than 10 um' % (
        out['vertices'], 1e3 * out['max_m'], 1e3 * out['p99_m'], out['off_by_more_than_10um'])
    if a.mean_edge > 0:
        line += ' (max %.3f of the mean edge)' % out['max_per_mean_edge']
    print(line)


if __name__ == '__main__':
    main()
