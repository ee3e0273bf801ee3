#!/usr/bin/python3
"""The seven deterministic replays of the bench organ, as fingerprints: a change meant to make the
cutter or the collapse queue faster without changing what they decide gives the same lines
before and after it.

Replays (the incision, blade and physics settings of scripts/bench_table.py, collapse budget 0 so
that no timing decides where the queue stops): the 5k and 20k organs with physics on one and two
threads, and the 5k, 20k and 80k organs without physics. Each line names the replay and gives the
md5 of its final mesh (.vtk: current and rest positions, tets, quality, cut region) and of its
statistics with every timing left out (counts, volumes, qualities, collapses, CG iterations).

usage: scripts/replay_bits.py [--build build] [--sizes 5000 20000 80000] [--out FILE]
Needs BUILD/bench/ made by scripts/bench_table.py (its meshes and path) or makes them the same
way (gmsh and tetgen)."""
import argparse
import hashlib
import json
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'scripts'))
import bench_table  # noqa: E402  (its incision, blade and configuration)

# Statistics that measure time (or heap use, which the clock's budget may move) rather than what
# the replay decided.
TIMED = {'time_ms', 'ticks', 'ns_per_spring_iteration', 'allocations', 'wall_s'}


def untimed(value):
    if isinstance(value, dict):
        return {k: untimed(v) for k, v in value.items() if k not in TIMED}
    if isinstance(value, list):
        return [untimed(v) for v in value]
    return value


def md5(data):
    return hashlib.md5(data).hexdigest()


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('--build', default=os.path.join(ROOT, 'build'))
    p.add_argument('--sizes', type=int, nargs='+', default=[5000, 20000, 80000])
    p.add_argument('--out', help='also write the lines to this file')
    a = p.parse_args()
    bench = os.path.join(a.build, 'bench')
    os.makedirs(bench, exist_ok=True)
    path = os.path.join(bench, 'incision.csv')
    if not os.path.exists(path):
        bench_table.run([sys.executable, os.path.join(ROOT, 'scripts', 'make_path.py'), path] +
                        bench_table.PATH_ARGS)
    replays = []
    for n in a.sizes:
        prefix = os.path.join(bench, 'organ%d' % n)
        if not os.path.exists(prefix + '.ele'):
            bench_table.run([sys.executable, os.path.join(ROOT, 'meshes', 'src', 'make_organ.py'),
                             prefix, '--tets', str(n)])
        if n <= 20000:
            replays += [(n, 1), (n, 2)]
        replays.append((n, 0))  # 0: no physics
    lines = []
    for n, threads in replays:
        name = 'organ%d %s' % (n, 'physics, %d thread%s' % (threads, 's' if threads > 1 else '')
                               if threads else 'no physics')
        config = os.path.join(bench, 'bits_%d.yaml' % threads)
        with open(config, 'w') as f:
            f.write(bench_table.CONFIG + ('  threads: %d\n' % threads if threads else '') +
                    'collapse:\n  budget_us: 0\n')
        mesh_out = os.path.join(bench, 'bits_%d_%d.vtk' % (n, threads))
        stats_out = os.path.join(bench, 'bits_%d_%d.json' % (n, threads))
        cmd = [os.path.join(a.build, 'devel/lib/tissue_cut/cut_replay'), '--mesh',
               os.path.join(bench, 'organ%d.node' % n), '--path', path, '--blade-length',
               bench_table.BLADE, '--config', config, '--quiet', '--out', mesh_out, '--stats',
               stats_out]
        if not threads:
            cmd.append('--no-physics')
        bench_table.run(cmd)
        with open(mesh_out, 'rb') as f:
            mesh_md5 = md5(f.read())
        with open(stats_out) as f:
            stats = untimed(json.load(f))
        line = '%-30s mesh %s stats %s' % (name, mesh_md5,
                                             md5(json.dumps(stats, sort_keys=True).encode()))
        print(line, flush=True)
        lines.append(line)
    if a.out:
        with open(a.out, 'w') as f:
            f.write('\n'.join(lines) + '\n')


if __name__ == '__main__':
    main()
