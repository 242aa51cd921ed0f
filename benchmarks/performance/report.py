"""The markdown report of the performance benchmark: figures and tables."""
from __future__ import annotations

import datetime
import importlib.metadata
import io
import math
import os
import platform
import shlex
import subprocess
import timeit
from pathlib import Path
from typing import Sequence

import numpy as np

from flight_sim_dynamics.cli import bench_report
from flight_sim_dynamics.core import kernel

from .. import node_stream

from .common import (ROOT, TARGET_QS_US, TARGET_SOLVE_MEDIAN_US, TARGET_SOLVE_P99_US, fmt, Row,
                     summary_table, table)
from .node import (TARGET_LABELS, _timing_key)


# ----------------------------------------------------------------------------
# The report
# ----------------------------------------------------------------------------
def versions() -> str:
    def v(dist: str) -> str:
        try:
            return importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            return '?'
    rclpy = v('ros-jazzy-rclpy')
    if rclpy == '?':
        rclpy = v('rclpy')
    rmw = os.environ.get('RMW_IMPLEMENTATION') or 'rmw_fastrtps_cpp (default)'
    return (f'Python {platform.python_version()}, numpy {np.__version__}, rclpy {rclpy}, '
            f'{rmw} {v("ros-rmw-fastrtps-cpp")}, {platform.system()} {platform.release()}')


def tree_state() -> str:
    """The commit measured, and whether the package differs from it (read-only git)."""
    try:
        head = subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], cwd=ROOT,
                              capture_output=True, text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(['git', 'status', '--porcelain', '--', 'flight_sim_dynamics',
                                'config'], cwd=ROOT, capture_output=True, text=True,
                               timeout=10).stdout.split('\n')
    except (OSError, subprocess.SubprocessError):
        return 'not a git checkout'
    changed = [line[3:] for line in dirty if line.strip()]
    return (f'commit {head or "?"}' + (f', with uncommitted changes in: '
                                       f'{", ".join(changed)}' if changed else
                                       ', package and config as committed'))


def machine_lines(argv: Sequence[str], started: float,
                  tree_states: tuple[str, str]) -> list[str]:
    cpu, usable = bench_report.cpu_model() or '?', kernel.usable_cores()
    la = node_stream.load_average()
    date = datetime.datetime.fromtimestamp(started, datetime.timezone.utc).strftime(
        '%Y-%m-%d %H:%M UTC')
    start_state, end_state = tree_states
    source = (start_state if start_state == end_state else
              f'at the start {start_state}; at the end {end_state} (the tree changed during '
              f'the run)')
    return [
        f'- date: {date}',
        f'- source: {source}',
        f'- command: `python -m benchmarks.performance'
        f'{(" " + shlex.join(argv)) if argv else ""}`',
        f'- CPU: {cpu}, {os.cpu_count()} logical cores ({usable} usable), shared with other '
        f'jobs',
        f'- {versions()}',
        f'- load average (1, 5, 15 min) at the end: {la[0]:.2f}, {la[1]:.2f}, {la[2]:.2f}',
    ]


#: A fixed piece of pure-Python work, timed at the start and the end of a run,
#: so that runs on the same machine at different times can be compared.
SPEED_REFERENCE = 'sum(range(1000))'


def speed_reference_us() -> float:
    """Best of 5 x 2000 runs of :data:`SPEED_REFERENCE`, us per run."""
    return 1e6 * min(timeit.repeat(SPEED_REFERENCE, number=2000, repeat=5)) / 2000



def stream_table(runs: Sequence[dict]) -> str:
    header = ['target', 'round', 'executor', 'rate', 'seconds', 'answered / sent', 'lost',
              'median ms', 'p90 ms', 'p99 ms', 'p99.9 ms', 'max ms',
              'median first / last tenth ms', 'drain s', 'driver late p99 / max ms',
              'target CPU ms per setpoint (its Python thread)', 'target CPU % of a core',
              'load avg start / end', 'steal %']
    rows = [[TARGET_LABELS.get(r.get('key', ''), r['kind']), str(r.get('round') or '-'),
             r.get('executor', ''), f'{r["rate"]:g} Hz', f'{r["seconds"]:g}',
             f'{r["answered"]} / {r["sent"]}', str(r['lost']), fmt(r['median']), fmt(r['p90']),
             fmt(r['p99']), fmt(r['p999']), fmt(r['max'], 1),
             f'{fmt(r["first_tenth"])} / {fmt(r["last_tenth"])}', fmt(r['drain_s']),
             f'{fmt(r["late_p99"])} / {fmt(r["late_max"], 1)}',
             f'{fmt(r["cpu_ms"])} ({fmt(r.get("main_cpu_ms", math.nan))})',
             f'{100 * r["cpu_fraction"]:.0f} %',
             f'{r["load_start"][0]:.2f} / {r["load"][0]:.2f}',
             fmt(r.get('steal', math.nan), 1)] for r in runs]
    return table(header, rows, ['l', 'r', 'l'] + ['r'] * (len(header) - 3))


def markdown(res: dict, rows: list[Row], argv: Sequence[str], started: float,
             wall: float) -> str:
    buf = io.StringIO()
    w = buf.write
    w('# Performance\n\n')
    w('Generated by `python -m benchmarks.performance` (the figures below are from the run '
      'described under "Machine and command"; rerun it to refresh this file). Every figure '
      'is printed next to the target of the performance issue, with the gap when it is '
      'missed and the 1-minute load average of the shared machine when it was taken. No '
      'test asserts any of them.\n\n')
    w('## Summary\n\n')
    w(summary_table(rows) + '\n\n')
    missed = [r for r in rows if r.missed]
    w(f'- checked figures: {sum(1 for r in rows if r.verdict not in ("-",))}; missing their '
      f'target: {len(missed)}\n\n')
    w('## Machine and command\n\n')
    w('\n'.join(machine_lines(argv, started, res['tree'])) + '\n')
    if 'speed' in res:
        w(f'- speed reference (`{SPEED_REFERENCE}`, best of 5 x 2000 runs in this '
          f'process): {fmt(res["speed"][0], 1)} us at the start, {fmt(res["speed"][1], 1)} us at '
          f'the end. It moves with the host\'s load (a busy sibling hyperthread or a throttled '
          f'core make every instruction slower without showing as steal); compare it before '
          f'comparing the timings of two runs.\n')
    w(f'- whole run: {wall / 60:.1f} min\n')
    for note in res.get('notes', []):
        w(f'- {note}\n')
    loads = [r.load for r in rows if math.isfinite(r.load)]
    span = f'{min(loads):.2f}-{max(loads):.2f}' if loads else '?'
    w(f'\nThe machine has {os.cpu_count()} cores shared with other jobs (1-minute load '
      f'average {span} at the figures of the summary): every latency tail and p99 here '
      f'includes their preemptions. The node, the echo and the driver are separate processes '
      f'on the same cores.\n\n')

    if 'solve' in res:
        s = res['solve']
        w('## 1. Per-cycle solve\n\n')
        w(f'`fsd.solve(model, q, qd, qdd)` in this process, plain-float states cycling '
          f'through the {s["n_states"]} samples (100 Hz) of the paper\'s general motion, its '
          f'return to neutral and the motion-cueing sequence (`cueing.PlannerSequence`); '
          f'{s["full"]["n"]} calls per scene, each timed alone with `perf_counter_ns`, the two '
          f'scenes interleaved call by call (`bench_cases.time_cases`, blocks of '
          f'{res["args"]["block"]}'
          f'). "typical block p99" = median over the blocks of each block\'s p99 (less swayed by '
          f'one burst of load). Load average {s["load"][0]:.2f} -> {s["load"][1]:.2f}.\n\n')
        trows = []
        for name, target in (('full', f'<= {TARGET_SOLVE_MEDIAN_US:g} / '
                                      f'<= {TARGET_SOLVE_P99_US:g}'),
                             ('quasi_static', f'<= {TARGET_QS_US:g} / -')):
            t = s[name]
            trows.append([f'`{name}`', fmt(t['min'], 0), fmt(t['median'], 0), fmt(t['mean'], 0),
                          fmt(t['block_p99'], 0), fmt(t['p99'], 0), fmt(t['p999'], 0),
                          fmt(t['max'], 0), target])
        w(table(['scene', 'min us', 'median us', 'mean us', 'typical block p99 us', 'p99 us',
                 'p99.9 us', 'max us', 'target median / p99 us'], trows) + '\n\n')
        w(f'`sol.cond` (exact cond(Q), an SVD of the 12 x 12 Q), first access on a fresh '
          f'solution, {s["cond_n"]} solutions: median {s["cond"]["median"]:.0f} us, p99 '
          f'{s["cond"]["p99"]:.0f} us. It is computed only on demand (a cached property); the '
          f'per-cycle path computes only the cheap estimates `kinematic_condition` (from the '
          f'block factorisation of Q it already has) and `jacobian_condition` (Frobenius, from '
          f'the 3 x 3 Jacobian and its inverse), whose cost is in the solve time above. '
          f'The node reads `sol.cond` once per diagnostics '
          f'period.\n\n')

    if 'batch' in res:
        b = res['batch']
        w('## 2. Batch solve\n\n')
        w(f'`fsd.solve_batch(model, Q, Qd, Qdd)` on N = {b["n"]:,} samples (the stream of '
          f'section 1 at 1 kHz, tiled), full model, {len(b["times"])} calls: '
          + ', '.join(f'{t:.3f}' for t in b['times'])
          + f' s. Best {b["best"] / 1e3:.0f} k samples/s ({1e6 / b["best"]:.2f} us per '
          f'sample), median {b["median"] / 1e3:.0f} k samples/s (the verdict uses the best '
          f'call: the load of other jobs only adds time). Load average {b["load"]:.2f}.\n\n')
        w(f'Agreement with `fsd.solve` on {b["agree_n"]} samples spread over the stream '
          f'(peak |force| {b["peak"]:.1f} N): max abs difference '
          + ', '.join(f'{k} {v:.1e}' for k, v in b['diffs'].items())
          + f' (SI units); status mismatches: {b["status_mismatch"]}.\n\n')

    if 'csv' in res:
        c = res['csv']
        w('## 3. CSV end to end\n\n')
        w(f'A {c["n"]:,}-row trajectory CSV ({c["bytes"] / 1e6:.1f} MB, the stream at 1 kHz) '
          f'through `python -m flight_sim_dynamics solve big.csv -o out.csv` as a subprocess: '
          + ', '.join(f'{t:.2f}' for t in c['walls'])
          + f' s, median {c["median"]:.2f} s ({c["rows_out"]:,} rows written). Where the '
          f'time goes (one run of each stage in this process): interpreter start + imports '
          f'{c["startup"]:.2f} s (a separate `python -c "import flight_sim_dynamics.cli"`), '
          f'read_csv {c["read"]:.2f} s, solve_batch + columns (`cli.solve_table`) '
          f'{c["solve"]:.2f} s, write_csv {c["write"]:.2f} s. Load average {c["load"]:.2f}.\n\n')

    if 'node' in res:
        n = res['node']
        keeps_up_ms = (1e3 * node_stream.KEEPS_UP_QUEUE_FRACTION * res.get('depth', 100)
                       / res['args']['rate'])
        w('## 4. Node latency\n\n')
        w(f'{len(n["rounds"])} round(s), each of three streams of '
          f'{res["args"]["node_seconds"]:g} s at {res["args"]["rate"]:g} Hz one after the '
          'other: the bare echo, the node fed by the three topics, the node fed by one '
          '`trajectory_msgs/JointTrajectory` per setpoint (`platform_setpoint`, the driver\'s '
          '`--input trajectory`). The summary judges the targets on the round '
          f'{n["chosen"]}: the one whose streams saw the least CPU time stolen by the '
          'hypervisor ("steal %", from /proc/stat over each stream: while a virtual core is '
          'stolen every process on it stalls, whatever it runs). The criterion does not look '
          'at the latencies judged; every round is in the table.\n\n')
        w('Each target is its own process, started fresh: the bare rclpy echo '
          '(`python -m benchmarks.bench_node echo`: PoseStamped in, one reused JointState out '
          'with the '
          f'pose\'s stamp, `{res["args"]["executor"]}` executor, nothing else) and the node '
          f'(`python -m flight_sim_dynamics.ros.node --executor {res["args"]["executor"]} '
          '--ros-args --params-file config/flight_sim_dynamics.yaml`). A driver process '
          '(`python -m benchmarks.bench_node drive`, EventsExecutor) publishes, per sample, '
          'a pose, a '
          'twist and an acceleration with one stamp (the stream of section 1, reliable, '
          f'KEEP_LAST depth {res.get("depth", 100)} = the node\'s `qos.depth`) on a fixed '
          'schedule (or one JointTrajectory), and receives `actuator_states`. Latency = '
          'receipt of the JointState in '
          'the driver\'s callback - the time just before the pose was published (both '
          'CLOCK_MONOTONIC, shared by the processes); with the three topics it includes '
          'publishing the three messages, for the echo too (it subscribes the pose only). '
          'Lost = sent but never '
          'answered (waiting until nothing came for 3 s). "driver late" = publish time - '
          'scheduled time (the driver\'s own stalls; the receipt time is taken when the '
          'driver\'s callback runs, so its stalls add to the latency of both targets alike). '
          'Target CPU = user + system time of the '
          'target process (all its threads: Python and DDS) over the stream / answered '
          f'setpoints. A stream "keeps up" when nothing is lost and its p99 stays below half '
          f'the time a full queue stands for ({node_stream.KEEPS_UP_QUEUE_FRACTION:g} x depth '
          f'/ rate: {keeps_up_ms:g}'
          f' ms at {res["args"]["rate"]:g} Hz). Before each stream 20+ warm-up samples are '
          'answered (not counted).\n\n')
        w(stream_table(n['runs']) + '\n\n')
        for r in n['runs']:
            if r['lost']:
                w(f'- {r["kind"]} at {r["rate"]:g} Hz: {r["lost"]} lost: {r["lost_where"]}.\n')
            if r.get('rejected'):
                w(f'- {r["kind"]} at {r["rate"]:g} Hz, the node\'s rejection counters at the end '
                  f'(including the warm-up): ' + ', '.join(f'{k} {v}' for k, v in
                                                         r['rejected'].items()) + '.\n')
        for r in n['runs']:
            if r.get('other_threads_ms'):
                w(f'- {r["kind"]} at {r["rate"]:g} Hz, CPU per setpoint by thread: Python '
                  f'(main) {fmt(r["main_cpu_ms"])} ms, ' + ', '.join(
                      f'{name} {ms:.2f}' for name, ms in r['other_threads_ms'][:6]
                      if ms >= 0.005) + ' ms.\n')
        for r in n['runs']:
            if r['kind'] == 'node' and r.get('diag'):
                per = [p for p in r['diag'] if p['n'] and p['n'] > 0]
                if per:
                    w(f'- {TARGET_LABELS.get(r.get("key", ""), "node")} at {r["rate"]:g} Hz, '
                      f'round {r.get("round") or "-"}, its /diagnostics: answered rate median '
                      f'{np.median([p["rate"] for p in per]):.0f} Hz, solve time median '
                      f'{np.nanmedian([p["median"] for p in per]):.0f} us, mean '
                      f'{np.median([p["mean"] for p in per]):.0f} us, p99 '
                      f'{np.median([p["p99"] for p in per]):.0f} us (medians over '
                      f'{len(per)} periods), rejected total '
                      f'{max(p["rejected"] for p in r["diag"]):.0f}.\n')
        w('\n')

    if 'executors' in res:
        ex = res['executors']
        w(f'### The executor\n\nThe same streams with the `{ex["other"]}` executor in the echo '
          f'and the node (`--executor {ex["other"]}`), {res["args"]["compare_seconds"]:g} s '
          f'each, for the record of the choice (the rows with `{res["args"]["executor"]}` '
          f'are those above):\n\n')
        w(stream_table([x for pair in ex['pairs'] for x in pair]) + '\n\n')

    if 'soak' in res:
        d = res['soak']
        w('## 5. Soak\n\n')
        w(f'The node at {d["rate"]:g} Hz for {d["seconds"] / 60:g} min ({d["why"]}), the '
          f'driver as in section 4. {d["answered"]} / {d["sent"]} answered, {d["lost"]} lost'
          + (f' ({d["lost_where"]})' if d['lost'] else '') + f'; latency median '
          f'{fmt(d["median"])} ms, p99 {fmt(d["p99"])} ms, max {fmt(d["max"], 1)} ms; node '
          f'CPU {fmt(d["cpu_ms"])} ms per setpoint. Load average {d["load_start"][0]:.2f} -> '
          f'{d["load"][0]:.2f}.\n\n')
        w(f'**Resident memory** (VmRSS of the node, sampled every '
          f'{res["args"]["soak_sample"]:g} s): {d["rss_start"]:.1f} MB when the stream started, '
          f'{d["rss_base"]:.1f} MB at {d["rss_base_t"]:.0f} s (baseline: allocator and '
          f'queues warmed up), {d["rss_end"]:.1f} MB at the end (max {d["rss_max"]:.1f}): '
          f'growth {d["growth"]:+.2f} MB from the baseline ({d["growth0"]:+.2f} MB from t = 0); '
          f'slope over the second half {d["slope_mb_per_min"]:+.3f} MB/min.\n\n')
        mem = d['memory']
        if mem:
            step = max(1, len(mem) // 12)
            picks = mem[::step] + ([mem[-1]] if (len(mem) - 1) % step else [])
            w(table(['t (s)', 'VmRSS (MB)', 'node CPU so far (s)', 'load avg (1 min)'],
                    [[f'{m[0]:.0f}', f'{m[1] / 1024:.2f}', f'{m[2] - mem[0][2]:.1f}',
                      fmt(m[3]) if len(m) > 3 else '-'] for m in picks]) + '\n\n')
        tr = d.get('trend') or {}
        if tr:
            w(f'**Timing figures of /diagnostics** (per 1 s period: `solve time median (us)`, '
              f'`solve time mean (us)`, `solve time p99 (us)`; per minute the median over its '
              f'periods, and the largest p99 of a period): linear trend of the per-period '
              f'median {tr["slope_median"]:+.2f} us/min, of the mean {tr["slope_mean"]:+.2f} '
              f'us/min, of the p99 {tr["slope_p99"]:+.2f} us/min (overall medians '
              f'{tr["overall_median"]:.0f}, {tr["overall_mean"]:.0f} and '
              f'{tr["overall_p99"]:.0f} us). Flatness is judged on the per-minute '
              f'{_timing_key(tr)}: these are wall-clock times, and one preemption inside a solve '
              f'(milliseconds, once in a thousand cycles) moves a period\'s mean and p99 by '
              f'several microseconds but not its median. "steal" = the share of the '
              f'machine\'s CPU time the hypervisor gave to other virtual machines over the '
              f'minute (/proc/stat).\n\n')
            w('"node CPU per setpoint" is the node process\'s CPU time over the minute '
              '(from /proc, sampled with VmRSS) / the setpoints of that minute; unlike the '
              'wall-clock solve times of /diagnostics, it does not count the time the node '
              'waits while other processes run (though it still grows when they compete for '
              'the caches and the cores\' shared resources).\n\n')
            w(table(['minute', 'periods', 'solve median (us)', 'solve mean (us)',
                     'solve p99 (us)', 'worst period p99 (us)', 'node CPU per setpoint (ms)',
                     'load avg (1 min, mean)', 'steal %'],
                    [[str(m['minute']), str(m['periods']), fmt(m.get('median', math.nan), 1),
                      f'{m["mean"]:.1f}', f'{m["p99"]:.0f}', f'{m["p99_max"]:.0f}',
                      fmt(m.get('cpu_ms', math.nan)), fmt(m.get('load', math.nan)),
                      fmt(m.get('steal', math.nan), 1)] for m in tr['minutes']])
              + '\n\n')

    w('## Profiles\n\n')
    if 'profile_solver' in res:
        p = res['profile_solver']
        impl = (f'the compiled kernel (`{Path(p["kernel_path"]).name}`, built from '
                f'`src/kernel.c`)' if p['kernel'] else
                '**the Python code: the compiled kernel was switched off (FSD_KERNEL=0)**'
                if kernel.available() else
                '**the Python code: the compiled kernel was not built**')
        w(f'### The solver: where one `fsd.solve` goes\n\n`fsd.solve` ran {impl}. Each figure '
          f'is the best of 5 runs of {p["n"]} calls on one state of section 1 (us per call; '
          f'the load of other jobs only adds time). "kernel" is the C function alone (packed '
          f'model and output buffer prepared, 9 floats in); "solve_row" adds the model lookup '
          f'and the output buffer; "fsd.solve" adds the argument checks and the `Solution` '
          f'(its array fields are views of the output buffer, made on first access: '
          f'"+ read force" includes one); "Python code" is the same solve through the '
          f'reference Python implementation (`kernel.use_kernel(False)`), for comparison.\n\n')
        trows = []
        for scene in ('full', 'quasi_static'):
            t = p[scene]
            trows.append([f'`{scene}`', fmt(t.get('kernel', math.nan)),
                          fmt(t.get('solve_row', math.nan)), fmt(t['solve']), fmt(t['read']),
                          fmt(t['python'], 0), f'{t["python"] / t["solve"]:.0f}x'])
        w(table(['scene', 'kernel us', 'solve_row us', 'fsd.solve us', '+ read force us',
                 'Python code us', 'speed-up'], trows) + '\n\n')
        pb = p['batch']
        if 'one_thread' in pb:
            w(f'`fsd.solve_batch`, full model, N = {pb["n"]:,} (best of 3): one thread '
              f'{pb["one_thread"] / 1e3:.0f} k samples/s ({1e6 / pb["one_thread"]:.2f} us per '
              f'sample, the kernel looped in C with the GIL released); split over the '
              f'{pb["threads"]} usable cores {pb["threads_rate"] / 1e3:.0f} k samples/s; the '
              f'Python code (numpy columns) {pb["python"] / 1e3:.0f} k samples/s.\n\n')
        else:
            w(f'`fsd.solve_batch` with the Python code: {pb["python"] / 1e3:.0f} k '
              f'samples/s.\n\n')
    if 'profile_node' in res:
        pn = res['profile_node']
        if 'py_spy' in pn:
            ps = pn['py_spy']
            run = ps['run']
            w(f'### The node under load: py-spy\n\n`py-spy record --pid <node> --nonblocking '
              f'--rate 250 --format raw` attached to the node at {run["rate"]:g} Hz '
              f'({run["answered"]} / {run["sent"]} answered during the run, node CPU '
              f'{fmt(run["cpu_ms"])} ms per setpoint); {ps["samples"]} samples of the Python '
              f'threads while they were running (idle excluded; native DDS threads are not '
              f'sampled). Time in native code called from Python (rclpy\'s C++ executor '
              f'taking and deserialising messages, publishing) is charged to the calling '
              f'Python frame. Top by self samples, then by total (anywhere on the stack):\n\n')
            w(f'What the Python thread was busy with (each sample counted once, by the first '
              f'matching frame of its stack). Its CPU during this run was '
              f'{fmt(run.get("main_cpu_ms", math.nan))} ms per answered setpoint, so a share '
              f'of x % is about x/100 of that:\n\n')
            w(table(['activity', '% of samples', '~ms per setpoint'],
                    [[g['group'], f'{g["pct"]:.1f}',
                      fmt(g['pct'] / 100 * run.get('main_cpu_ms', math.nan))]
                     for g in ps['groups']], ['l', 'r', 'r']) + '\n\n')
            if ps.get('other_leaves'):
                w('"other", by innermost frame: ' + ', '.join(
                    f'`{x["func"]}` {x["pct"]:.1f} %' for x in ps['other_leaves']) + '.\n\n')
            w(table(['function (self)', '% of samples'],
                    [[f'`{r["func"]}`', f'{r["pct"]:.1f}'] for r in ps['self']],
                    ['l', 'r']) + '\n\n')
            w(table(['function (total)', '% of samples'],
                    [[f'`{r["func"]}`', f'{r["pct"]:.1f}'] for r in ps['total']],
                    ['l', 'r']) + '\n\n')
        elif 'py_spy_error' in pn:
            w(f'py-spy: not obtained ({pn["py_spy_error"]}).\n\n')
        if 'cprofile' in pn:
            cp = pn['cprofile']
            run = cp['run']
            w(f'### The node under load: cProfile\n\nThe node run through `python -m '
              f'benchmarks.bench_node profiled-node` (cProfile enabled by SIGUSR1 when the '
              f'measured '
              f'stream starts, so imports, start-up and discovery are left out; stats written '
              f'when it stops) at {run["rate"]:g} Hz, a rate it sustains under the profiler '
              f'({cp["answered"]} / {cp["sent"]} answered, {run["lost"]} lost). '
              f'Per answered setpoint: '
              f'{cp["total_calls"]:.0f} Python function calls and {cp["total_us"]:.0f} us '
              f'of profiled time outside the spin loop (the profiler inflates small Python '
              f'functions; C functions such as `publish` are timed as a whole), plus '
              f'{cp["wait_us"]:.0f} us in the spin loop itself (the C++ executor\'s call: '
              f'idle waiting between setpoints, and taking, deserialising and dispatching '
              f'messages in native code, which cProfile cannot tell apart; see py-spy above '
              f'for the busy share). Top {len(cp["top"])} by tottime outside the spin loop, '
              f'per answered setpoint:\n\n')
            w(table(['function', 'calls per setpoint', 'tottime us', 'cumtime us',
                     '% of tottime'],
                    [[f'`{r["func"]}`', f'{r["calls"]:.1f}', f'{r["tottime_us"]:.1f}',
                      f'{r["cumtime_us"]:.1f}', f'{r["pct"]:.1f}'] for r in cp['top']],
                    ['l', 'r', 'r', 'r', 'r']) + '\n\n')
            if cp.get('mine'):
                w('The node\'s callbacks and the calls they make (cumulative, per answered '
                  'setpoint):\n\n')
                w(table(['function', 'calls per setpoint', 'cumtime us'],
                        [[f'`{r["func"]}`', f'{r["calls"]:.2f}', f'{r["cumtime_us"]:.1f}']
                         for r in cp['mine'][:14]], ['l', 'r', 'r']) + '\n\n')
        elif 'cprofile_error' in pn:
            w(f'cProfile of the node: not obtained ({pn["cprofile_error"]}).\n\n')
    if 'profile_solver' not in res and 'profile_node' not in res:
        w('(not run)\n\n')

    return buf.getvalue()
