#!/usr/bin/python3
"""End-to-end performance table (issue 7): replays a trembling, tilted incision over TetGen meshes
of an ellipsoid organ (semi-axes 15 x 10 x 8 cm) of about 5k, 20k and 80k tets with cut_replay and
prints the medians over --repeats runs of each:

  tick p50/p99/max [ms]   every tick of a run with physics (implicit, CG) and collapse, 1 kHz:
                          wall time, and the tick thread's CPU time (the same without waiting
                          for a core; on a busy machine the two differ; with 2 threads the
                          helper's CPU time is not in it, the tick thread's waits for it are)
  threads                 physics/threads of that run: 1 (one core, as issue 7's targets are
                          set) and 2 (the default; the machine's second core)
  RTF                     simulated time over wall time of that run
  CG it, ns/spring/it     CG iterations per step; step time per spring per CG iteration
  us/cut tet              (t.Repl + t.EC) / #CuT of a run without physics (as in the paper; the
                          cutter's time includes its search near the blade on every tick); and
                          the CPU time of all ticks of that run over #CuT
  split                   the same (t.Repl + t.EC) / #CuT in three parts, from that run's tick
                          log: the cutter on the ticks that replace no tet (following the blade,
                          and opening the cut where that waited), the cutter on the ticks that
                          replace tets, and the collapse queue
  paper's collapse        us/cut tet of the same run with collapse/flips and collapse/smoothing
                          off (the queue only collapses edges, as the paper's does), beside the
                          region's mean Q in both runs: what our extensions cost and buy
  4x ratio                us/cut tet of the 80k mesh over that of the 20k mesh (the medians'
                          ratio, and the median and range of each repeat's own ratio; a
                          repeat replays every size in turn, so the sizes' runs alternate)
  machine check           bench_core's implicit step of its 20k block on one thread and on two,
                          before and after the replays (the machine's speed drifts, and its
                          second vCPU is at times worth a quarter of a core), and on one thread
                          on each vCPU alone (at times one vCPU runs the replays 1.5x slower
                          than the other for minutes on end)

--cpu N pins the one-thread replays with physics, the replays without physics and the one-thread
machine check to vCPU N (the two-thread runs use both). Unpinned, the scheduler moves a replay
between the vCPUs, and where their speeds differ the runs mix the two. --cpu auto pins each of
those replays to the vCPU whose one-thread step (bench_core, 0.1 s on each) is the faster just
before it, and prints how often each was chosen and the two times: the table then measures a
vCPU the host is not slowing at that moment (see the Performance section of the README).

usage: scripts/bench_table.py [--build build] [--repeats 5] [--sizes 5000 20000 80000]
                              [--threads 1 2] [--cpu N|auto]
Meshes, path and configuration go to BUILD/bench/ (made once, by meshes/src/make_organ.py and
scripts/make_path.py). Needs gmsh and tetgen. Run it on a quiet machine: it measures time."""
import argparse
import csv
import json
import os
import platform
import statistics
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# The incision: 3.6 cm long across the top of the organ, the tool tilted 20 degrees about the
# cut direction, 0.1 mm of hand tremble (and 0.01 rad of twist) on each of 100 rows over 1 s;
# a 3 cm blade from 1.5 cm above the top reaches 1.5 cm into the tissue.
PATH_ARGS = ['--from', '-0.018', '0.005', '0.095', '--to', '0.018', '-0.005', '0.095',
             '--tilt', '20', '--tilt-axis', '1', '-0.3', '0', '--tremble', '0.0001',
             '--seed', '1', '--seconds', '1', '--rows', '100']
BLADE = '0.03'
# Default physics except where the organ rests: its lowest 3 cm are fixed (a tray), and E =
# 20 kPa (liver-like); at the default 5 kPa the mass-spring organ folds under its own weight.
CONFIG = """physics:
  fixed_band: 0.03
  young_modulus: 20000.0
"""


def pinned(cpu):
    """A preexec_fn that runs the child on vCPU `cpu` alone (None: wherever it is scheduled)."""
    if cpu is None:
        return None
    return lambda: os.sched_setaffinity(0, {cpu})


def run(cmd, cpu=None):
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, preexec_fn=pinned(cpu))


def replay(build, mesh, path, config, stats, physics, tick_log=None, cpu=None):
    cmd = [os.path.join(build, 'devel/lib/tissue_cut/cut_replay'), '--mesh', mesh, '--path', path,
           '--blade-length', BLADE, '--config', config, '--quiet', '--stats', stats]
    if not physics:
        cmd.append('--no-physics')
    if tick_log:
        cmd += ['--tick-log', tick_log]
    run(cmd, cpu)
    with open(stats) as f:
        result = json.load(f)
    if tick_log:
        # The cutter's time on the ticks that replace no tet and on those that do [ms].
        idle = busy = 0.0
        with open(tick_log) as f:
            for row in csv.DictReader(f):
                if int(row['cut_tets']) > 0:
                    busy += float(row['cut_ms'])
                else:
                    idle += float(row['cut_ms'])
        result['cut_split_ms'] = (idle, busy)
    return result


def step_times(bench, threads, cpu=None, min_time=0.3):
    """bench_core's implicit step of its 20k block [us] by thread count (`threads`: a filter)."""
    out = subprocess.run([bench, '--benchmark_filter=PhysicsStep/20000/%s' % threads,
                          '--benchmark_min_time=%g' % min_time, '--benchmark_format=json'],
                         check=True, capture_output=True, text=True, preexec_fn=pinned(cpu))
    times = {}
    for b in json.loads(out.stdout)['benchmarks']:
        times[int(b['name'].split('/')[2])] = b['real_time']
    return times


def faster_cpu(build, chosen):
    """The vCPU whose one-thread 20k step is the faster now (bench_core, 0.1 s on each); appends
    (vCPU, [us on each]) to `chosen`. None without bench_core."""
    bench = os.path.join(build, 'devel/lib/tissue_cut/bench_core')
    if not os.path.exists(bench):
        return None
    cpus = sorted(os.sched_getaffinity(0))
    times = [step_times(bench, '1/', c, 0.1)[1] for c in cpus]
    best = cpus[times.index(min(times))]
    chosen.append((best, times))
    return best


def machine_check(build, cpu=None):
    """One implicit step of bench_core's 20k block on one thread (on vCPU `cpu` if given) and on
    two [us], and on one thread on each vCPU alone, or None. The machine's speed drifts, and its
    second vCPU is at times worth a quarter of a core: taken before and after the replays, this
    says which machine the table was measured on."""
    bench = os.path.join(build, 'devel/lib/tissue_cut/bench_core')
    if not os.path.exists(bench):
        return None
    one = step_times(bench, '1/', cpu).get(1)
    two = step_times(bench, '2/').get(2)
    each = [step_times(bench, '1/', c).get(1) for c in sorted(os.sched_getaffinity(0))]
    return one, two, each


def describe_check(when, check):
    if check is None:
        return 'machine check %s: bench_core not built' % when
    one, two, each = check
    return ('machine check %s: one implicit step of the 20k block %.0f us on one thread, %.0f on '
            'two (%.2fx); on one thread on each vCPU: %s us' %
            (when, one, two, one / two, ', '.join('%.0f' % t for t in each)))


def cpu_model():
    try:
        with open('/proc/cpuinfo') as f:
            for line in f:
                if line.startswith('model name'):
                    return line.split(':', 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def us_per_cut(stats):
    """(t.Repl + t.EC) / #CuT of a run without physics [us]."""
    return ((stats['cut']['time_ms'] + stats['collapse']['time_ms']) * 1000.0 /
            max(1, stats['cut']['cut_tetrahedra']))


def median(values):
    return statistics.median(values) if values else float('nan')


def main():
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('--build', default=os.path.join(ROOT, 'build'))
    p.add_argument('--repeats', type=int, default=5)
    p.add_argument('--sizes', type=int, nargs='+', default=[5000, 20000, 80000])
    p.add_argument('--threads', type=int, nargs='+', default=[1, 2])
    p.add_argument('--cpu', default=None,
                   help='run the one-thread and no-physics replays on this vCPU alone, or '
                        '"auto": each on the faster vCPU just before it')
    a = p.parse_args()
    auto = a.cpu == 'auto'
    if auto:
        a.cpu = None
    elif a.cpu is not None:
        try:
            a.cpu = int(a.cpu)
        except ValueError:
            sys.exit('bench_table.py: --cpu %s: a vCPU number or "auto"' % a.cpu)
    if a.cpu is not None and a.cpu not in os.sched_getaffinity(0):
        sys.exit('bench_table.py: --cpu %d: not one of this process\'s vCPUs %s' %
                 (a.cpu, sorted(os.sched_getaffinity(0))))
    replay_bin = os.path.join(a.build, 'devel/lib/tissue_cut/cut_replay')
    if not os.path.exists(replay_bin):
        sys.exit('bench_table.py: %s not found: build first' % replay_bin)
    out = os.path.join(a.build, 'bench')
    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, 'incision.csv')
    run([sys.executable, os.path.join(ROOT, 'scripts', 'make_path.py'), path] + PATH_ARGS)
    config = os.path.join(out, 'bench.yaml')
    with open(config, 'w') as f:
        f.write(CONFIG)
    paper_config = os.path.join(out, 'bench_paper.yaml')
    with open(paper_config, 'w') as f:
        f.write(CONFIG + 'collapse:\n  flips: false\n  smoothing: false\n')
    threaded = {}
    for t in a.threads:
        threaded[t] = os.path.join(out, 'bench_threads%d.yaml' % t)
        with open(threaded[t], 'w') as f:
            f.write(CONFIG + '  threads: %d\n' % t)
    rows, physics_rows = [], []
    prefixes = {}
    for n in a.sizes:
        prefixes[n] = os.path.join(out, 'organ%d' % n)
        if not os.path.exists(prefixes[n] + '.ele'):
            run([sys.executable, os.path.join(ROOT, 'meshes', 'src', 'make_organ.py'), prefixes[n],
                 '--tets', str(n)])
    check_before = machine_check(a.build, a.cpu)
    # Each repeat replays every size in turn, so that the sizes share the machine's drifts in
    # speed and the 4x ratio compares runs taken alternately (run size by size, the 80k replays
    # came minutes after the 20k ones: once 1.60 where the runs before and after gave 1.30).
    full = {n: {t: [] for t in a.threads} for n in a.sizes}
    plain = {n: [] for n in a.sizes}
    paper = {n: [] for n in a.sizes}
    chosen = []  # --cpu auto: (vCPU, its and the other's step [us]) for each pinned replay

    def where():
        return faster_cpu(a.build, chosen) if auto else a.cpu

    for k in range(a.repeats):
        for n in a.sizes:
            mesh = prefixes[n] + '.node'
            for t in a.threads:
                full[n][t].append(replay(a.build, mesh, path, threaded[t],
                                         os.path.join(out, 'full%d_t%d_%d.json' % (n, t, k)),
                                         True, cpu=where() if t == 1 else None))
            plain[n].append(replay(a.build, mesh, path, config,
                                   os.path.join(out, 'plain%d_%d.json' % (n, k)), False,
                                   os.path.join(out, 'plain%d_%d_ticks.csv' % (n, k)), where()))
            paper[n].append(replay(a.build, mesh, path, paper_config,
                                   os.path.join(out, 'paper%d_%d.json' % (n, k)), False,
                                   cpu=where()))
    for n in a.sizes:
        for t in a.threads:
            runs = full[n][t]
            physics_rows.append({
                'tets': runs[0]['initial']['tetrahedra'],
                'springs': runs[0]['physics']['springs'],
                'threads': runs[0]['physics'].get('threads', t),
                'cut_full': median([s['cut']['cut_tetrahedra'] for s in runs]),
                'p50': median([s['ticks']['p50_ms'] for s in runs]),
                'p99': median([s['ticks']['p99_ms'] for s in runs]),
                'max': median([s['ticks']['max_ms'] for s in runs]),
                'cpu50': median([s['ticks']['cpu_p50_ms'] for s in runs]),
                'cpu99': median([s['ticks']['cpu_p99_ms'] for s in runs]),
                'cpumax': median([s['ticks']['cpu_max_ms'] for s in runs]),
                'rtf': median([s['ticks']['real_time_factor'] for s in runs]),
                'cg': median([s['physics']['cg_iterations_mean'] for s in runs]),
                'ns': median([s['physics']['ns_per_spring_iteration'] for s in runs]),
                'physics_ms': median([s['physics']['time_ms'] / max(1, s['physics']['steps'])
                                      for s in runs]),
            })
        cut_cost = [us_per_cut(s) for s in plain[n]]
        rows.append({
            'tets': plain[n][0]['initial']['tetrahedra'],
            'cut_plain': median([s['cut']['cut_tetrahedra'] for s in plain[n]]),
            'repl_ms': median([s['cut']['time_ms'] for s in plain[n]]),
            'ec_ms': median([s['collapse']['time_ms'] for s in plain[n]]),
            'p99_plain': median([s['ticks']['p99_ms'] for s in plain[n]]),
            'us_per_cut': median(cut_cost),
            'cpu_per_cut': median([s['ticks']['cpu_total_ms'] * 1000.0 /
                                   max(1, s['cut']['cut_tetrahedra']) for s in plain[n]]),
            'idle_per_cut': median([s['cut_split_ms'][0] * 1000.0 /
                                    max(1, s['cut']['cut_tetrahedra']) for s in plain[n]]),
            'busy_per_cut': median([s['cut_split_ms'][1] * 1000.0 /
                                    max(1, s['cut']['cut_tetrahedra']) for s in plain[n]]),
            'ec_per_cut': median([s['collapse']['time_ms'] * 1000.0 /
                                  max(1, s['cut']['cut_tetrahedra']) for s in plain[n]]),
            'q_plain': median([s['region']['quality_mean'] for s in plain[n]]),
            'us_paper': median([us_per_cut(s) for s in paper[n]]),
            'q_paper': median([s['region']['quality_mean'] for s in paper[n]]),
        })
    check_after = machine_check(a.build, a.cpu)
    print('machine: %s, %d cores, %s; %d runs each, medians' %
          (cpu_model(), os.cpu_count(), platform.platform(), a.repeats))
    if auto and chosen:
        counts = ', '.join('vCPU %d for %d' % (c, sum(1 for x, _ in chosen if x == c))
                           for c in sorted(set(x for x, _ in chosen)))
        ratios = sorted(max(t) / min(t) for _, t in chosen)
        print('one-thread and no-physics replays each pinned to the faster vCPU just before it '
              '(--cpu auto): %s of %d; slower over faster vCPU: median %.2f, %.2f-%.2f' %
              (counts, len(chosen), median(ratios), ratios[0], ratios[-1]))
    else:
        print('one-thread and no-physics replays %s' %
              ('pinned to vCPU %d' % a.cpu if a.cpu is not None else 'not pinned (see --cpu)'))
    print(describe_check('before', check_before))
    print(describe_check('after', check_after))
    print('With physics and collapse:')
    print('| tets | springs | threads | cut tets | tick p50/p99/max ms (wall) | '
          'tick p50/p99/max ms (CPU) | RTF | physics ms/step | CG it/step | ns/spring/it |')
    print('|---|---|---|---|---|---|---|---|---|---|')
    for r in physics_rows:
        print('| %d | %d | %d | %d | %.2f / %.2f / %.2f | %.2f / %.2f / %.2f | %.2f | %.2f | '
              '%.1f | %.2f |' %
              (r['tets'], r['springs'], r['threads'], r['cut_full'], r['p50'], r['p99'],
               r['max'], r['cpu50'], r['cpu99'], r['cpumax'], r['rtf'], r['physics_ms'], r['cg'],
               r['ns']))
    print()
    print('Without physics (collapse on):')
    print('| tets | cut tets | t.Repl ms | t.EC ms | us per cut tet (t.Repl + t.EC) | '
          'split: cutter on ticks replacing none + on ticks replacing + collapse | '
          'us per cut tet (CPU of all ticks) | tick p99 ms (wall) | region mean Q | '
          'paper\'s collapse alone: us per cut tet, region mean Q |')
    print('|---|---|---|---|---|---|---|---|---|---|')
    for r in rows:
        print('| %d | %d | %.1f | %.1f | %.0f | %.0f + %.0f + %.0f | %.0f | %.2f | %.3f | '
              '%.0f, %.3f |' %
              (r['tets'], r['cut_plain'], r['repl_ms'], r['ec_ms'], r['us_per_cut'],
               r['idle_per_cut'], r['busy_per_cut'], r['ec_per_cut'], r['cpu_per_cut'],
               r['p99_plain'], r['q_plain'], r['us_paper'], r['q_paper']))
    by_size = dict(zip(a.sizes, rows))
    if 20000 in by_size and 80000 in by_size:
        # Also each repeat's 80k run over its 20k run, taken one after the other.
        paired = sorted(us_per_cut(big) / us_per_cut(small)
                        for big, small in zip(plain[80000], plain[20000]))
        print('4x ratio (us per cut tet, 80k over 20k): %.2f (t.Repl + t.EC), %.2f (CPU); '
              'each repeat\'s own: median %.2f, %.2f-%.2f' %
              (by_size[80000]['us_per_cut'] / by_size[20000]['us_per_cut'],
               by_size[80000]['cpu_per_cut'] / by_size[20000]['cpu_per_cut'], median(paired),
               paired[0], paired[-1]))


if __name__ == '__main__':
    main()
