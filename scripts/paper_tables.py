#!/usr/bin/python3
"""Reproduces the experiments of Ganovelli & O'Sullivan 2001 with cut_replay: each incision is
replayed without and with edge collapse (no physics, as in the paper), then prints Table 1
(#CuT, #CrT, #RmT, t.Repl, t.EC), Table 2 (cut tets, created tets, mean quality without and
with collapse), a collapse detail table (collapses, smoothing moves, refusals by reason, rest
volume change, region tets below Q 0.05), and draws Figure 8 (quality of the tets made by cuts,
without vs with collapse) and Figure 7 (volumes of the created tets with Q < 0.3) as PNG files.

--unbounded replays with collapse/budget_us = 0 (all queued work done on the tick it is
queued), so that the figures do not depend on the machine's speed; the default is the
configuration's 300 us a tick, as the node runs.

usage: scripts/paper_tables.py [--build build] [--out build/paper] [--unbounded]
Needs python3-matplotlib, python3-meshio, python3-numpy (Debian)."""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MAKE_PATH = os.path.join(ROOT, 'scripts', 'make_path.py')

# name, mesh (None = built-in block), blade length [m], make_path.py arguments
INCISIONS = [
    ('block straight', None, 0.03,
     ['--from', '-0.07', '0.002', '0.042', '--to', '0.07', '0.002', '0.042', '--seconds', '2']),
    ('block curved', None, 0.025,
     ['--from', '-0.07', '-0.015', '0.045', '--via', '0.0', '0.03', '0.045', '--to', '0.07',
      '-0.01', '0.045', '--seconds', '2']),
    ('ellipsoid severing', 'meshes/ellipsoid_v22.msh', 0.25,
     ['--from', '0.013', '-0.13', '0.12', '--to', '0.013', '0.13', '0.12', '--seconds', '1']),
    ('sphere tilted', 'meshes/sphere_tetgen.node', 0.08,
     ['--from', '-0.14', '0.01', '0.13', '--to', '0.14', '-0.02', '0.13', '--tilt', '20',
      '--seconds', '2']),
]


def replay(build, out, name, mesh, blade, path, collapse, config=None):
    tag = name.replace(' ', '_') + ('_collapse' if collapse else '_plain')
    stats = os.path.join(out, tag + '.json')
    vtk = os.path.join(out, tag + '.vtk')
    cmd = [os.path.join(build, 'devel/lib/tissue_cut/cut_replay'), '--path', path,
           '--blade-length', str(blade), '--no-physics', '--settle', '2', '--quiet',
           '--stats', stats, '--out', vtk]
    if mesh:
        cmd += ['--mesh', os.path.join(ROOT, mesh)]
    if not collapse:
        cmd.append('--no-collapse')
    if config:
        cmd += ['--config', config]
    subprocess.run(cmd, check=True)
    with open(stats) as f:
        return json.load(f), vtk


def region_cells(vtk):
    import meshio
    m = meshio.read(vtk)
    tets = m.cells_dict['tetra']
    rest = m.point_data['rest']
    flag = np.asarray(m.cell_data['cut_region'][0]).ravel().astype(bool)
    quality = np.asarray(m.cell_data['quality'][0]).ravel()
    a, b, c, d = (rest[tets[:, i]] for i in range(4))
    volume = np.einsum('ij,ij->i', b - a, np.cross(c - a, d - a)) / 6.0
    return quality[flag], volume[flag]


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('--build', default=os.path.join(ROOT, 'build'))
    p.add_argument('--out', default=os.path.join(ROOT, 'build', 'paper'))
    p.add_argument('--unbounded', action='store_true', help='collapse/budget_us = 0')
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    config = None
    if a.unbounded:
        config = os.path.join(a.out, 'unbounded.yaml')
        with open(config, 'w') as f:
            f.write('collapse:\n  budget_us: 0\n')
    rows = []
    for name, mesh, blade, args in INCISIONS:
        path = os.path.join(a.out, name.replace(' ', '_') + '.csv')
        subprocess.run([sys.executable, MAKE_PATH, path] + args, check=True)
        plain, plain_vtk = replay(a.build, a.out, name, mesh, blade, path, False, config)
        coll, coll_vtk = replay(a.build, a.out, name, mesh, blade, path, True, config)
        rows.append((name, plain, coll, plain_vtk, coll_vtk))

    print('Table 1: cutting and collapse (no physics; times on this machine)')
    print('%-20s %6s %6s %6s %10s %10s' % ('incision', '#CuT', '#CrT', '#RmT', 't.Repl ms', 't.EC ms'))
    for name, plain, coll, _, _ in rows:
        print('%-20s %6d %6d %6d %10.1f %10.1f' % (
            name, coll['cut']['cut_tetrahedra'], coll['cut']['created_tetrahedra'],
            coll['collapse']['removed_tetrahedra'], coll['cut']['time_ms'], coll['collapse']['time_ms']))
    print('paper (1 GHz Pentium II): 85 cut, 455 created, 335 removed, 254 ms, 651 ms')
    print()
    print('Table 2: tets made by cuts that remain, and their mean quality Q = 3 r_in / R_circ')
    print('%-20s %8s %12s %12s %10s %10s %12s' % ('incision', 'cut tets', 'region plain', 'region coll',
                                                   'Q plain', 'Q coll', 'per cut tet'))
    for name, plain, coll, _, _ in rows:
        cut = coll['cut']['cut_tetrahedra']
        print('%-20s %8d %12d %12d %10.3f %10.3f %12.2f' % (
            name, cut, plain['region']['tetrahedra'], coll['region']['tetrahedra'],
            plain['region']['quality_mean'], coll['region']['quality_mean'],
            coll['region']['tetrahedra'] / max(cut, 1)))
    print('paper: mean quality 0.28 without collapse, 0.46 with; 2.4-2.8 tets per cut tet')
    print()
    print('Collapse detail: collapses, smoothing moves and flips (our extensions), refusals by')
    print('reason, rest volume change, region tets with Q < 0.05 without and with collapse')
    print('%-20s %6s %6s %6s %6s %6s %6s %6s %10s %8s %8s' % (
        'incision', 'coll', 'smooth', 'flip', 'link', 'bound', 'invert', 'qual', 'dV rest %',
        '<.05 pl', '<.05 co'))
    for name, plain, coll, plain_vtk, coll_vtk in rows:
        c = coll['collapse']
        dv = 100.0 * (coll['volume_rest'] - coll['initial']['volume_rest']) / coll['initial']['volume_rest']
        qp, qc = region_cells(plain_vtk)[0], region_cells(coll_vtk)[0]
        print('%-20s %6d %6d %6d %6d %6d %6d %6d %10.4f %7.1f%% %7.1f%%' % (
            name, c['collapsed_edges'], c.get('smoothed_vertices', 0), c.get('flips', 0),
            c['rejected']['link'],
            c['rejected']['boundary'], c['rejected']['inversion'], c['rejected']['quality'], dv,
            100.0 * np.mean(qp < 0.05), 100.0 * np.mean(qc < 0.05)))
    print('issue 4: <= 2.5 tets per cut tet, mean Q >= 0.5, < 1% below 0.05, volume within 0.1%')

    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    q_plain = np.concatenate([region_cells(r[3])[0] for r in rows])
    q_coll = np.concatenate([region_cells(r[4])[0] for r in rows])
    fig, ax = plt.subplots(figsize=(6, 4))
    bins = np.linspace(0, 1, 21)
    ax.hist(q_plain, bins=bins, alpha=0.6, label='without collapse (%d tets)' % len(q_plain))
    ax.hist(q_coll, bins=bins, alpha=0.6, label='with collapse (%d tets)' % len(q_coll))
    ax.set_xlabel('quality Q = 3 r_in / R_circ')
    ax.set_ylabel('tets made by cuts')
    ax.set_title('Figure 8: quality distribution')
    ax.legend()
    fig.tight_layout()
    fig8 = os.path.join(a.out, 'figure8_quality.png')
    fig.savefig(fig8, dpi=120)

    q, v = zip(*[region_cells(r[3]) for r in rows])
    q, v = np.concatenate(q), np.concatenate(v)
    bad = v[q < 0.3]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.hist(np.log10(bad * 1e9), bins=30)
    ax.set_xlabel('log10 volume [mm^3]')
    ax.set_ylabel('created tets with Q < 0.3 (without collapse)')
    ax.set_title('Figure 7: volume of bad created tets')
    fig.tight_layout()
    fig7 = os.path.join(a.out, 'figure7_volume.png')
    fig.savefig(fig7, dpi=120)
    print('\nwrote', fig8, 'and', fig7)


if __name__ == '__main__':
    main()
