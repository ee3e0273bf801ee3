#!/usr/bin/python3
"""Makes a TetGen mesh of the ellipsoid organ (organ.geo: semi-axes 15 x 10 x 8 cm) with about
--tets tetrahedra, for the benchmarks: Gmsh meshes the surface with element size h, TetGen fills
it (-pq1.414, max volume proportional to h^3); h is searched until the count is within --tolerance.

  make_organ.py OUT_PREFIX --tets N [--tolerance 0.1]

Writes OUT_PREFIX.node and OUT_PREFIX.ele and prints the tet count. Needs gmsh and tetgen."""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))


def tetgen_count(h, scratch):
    """Meshes the organ at surface size h [dm]; returns the tet count (files left in scratch)."""
    stl = os.path.join(scratch, 'organ.stl')
    subprocess.run(['gmsh', '-v', '1', '-2', os.path.join(HERE, 'organ.geo'), '-setnumber', 'h',
                    repr(h), '-format', 'stl', '-o', stl], check=True, stdout=subprocess.DEVNULL)
    volume = 6.0 * (h * 0.1) ** 3 / 8.48  # [m^3]: six regular tets of edge h
    subprocess.run(['tetgen', '-pq1.414a%.6gQ' % volume, 'organ.stl'], cwd=scratch, check=True,
                   stdout=subprocess.DEVNULL)
    with open(os.path.join(scratch, 'organ.1.ele')) as f:
        return int(f.readline().split()[0])


def main():
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('out_prefix')
    p.add_argument('--tets', type=int, required=True)
    p.add_argument('--tolerance', type=float, default=0.1)
    a = p.parse_args()
    if a.tets < 500:
        sys.exit('make_organ.py: --tets must be at least 500')
    for tool in ('gmsh', 'tetgen'):
        if shutil.which(tool) is None:
            sys.exit('make_organ.py: %s is not on PATH' % tool)
    # Counts go roughly as h^-2.3 (measured): start there, then refine by secant steps in log-log.
    h = 0.16 * (a.tets / 16600.0) ** (-1.0 / 2.3)
    with tempfile.TemporaryDirectory() as scratch:
        for _ in range(12):
            n = tetgen_count(h, scratch)
            if abs(n - a.tets) <= a.tolerance * a.tets:
                break
            h *= (n / a.tets) ** (1.0 / 2.3)
        else:
            sys.exit('make_organ.py: no size gave %d tets within %g (last %d)' %
                     (a.tets, a.tolerance, n))
        os.makedirs(os.path.dirname(os.path.abspath(a.out_prefix)), exist_ok=True)
        shutil.copy(os.path.join(scratch, 'organ.1.node'), a.out_prefix + '.node')
        shutil.copy(os.path.join(scratch, 'organ.1.ele'), a.out_prefix + '.ele')
    print('%s: %d tets (surface size %.4f dm)' % (a.out_prefix, n, h))


if __name__ == '__main__':
    main()
