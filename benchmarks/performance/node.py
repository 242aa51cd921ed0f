"""Sections 4-5 of the performance benchmark: the node and a bare echo under
a stream (latency, loss, CPU), the executor comparison, the soak. The
streams are :func:`benchmarks.node_stream.run_stream` (looked up at call
time, so a test can replace it).
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any, Sequence

import numpy as np


from .. import node_stream

from .common import (SOAK_BASELINE_S, TARGET_NODE_ECHO_RATIO, TARGET_NODE_MEDIAN_MS,
                     TARGET_NODE_P99_MS, TARGET_RSS_GROWTH_MB, at_most, fmt, load1, log,
                     none_lost, Row)


# ----------------------------------------------------------------------------
# 4. Node and echo
# ----------------------------------------------------------------------------
def stream_dict(r: node_stream.StreamResult) -> dict:
    first, last = r.tenth_medians()
    late = r.publisher_late_ms
    return dict(kind=r.kind, executor=r.executor, input=r.setpoint_input, steal=r.steal_pct,
                rate=r.rate, seconds=r.seconds, sent=r.sent,
                answered=r.answered,
                lost=r.lost, lost_where=r.lost_where(), median=r.median, p90=r.pct(90),
                p99=r.p99, p999=r.pct(99.9), max=r.max, first_tenth=first, last_tenth=last,
                drain_s=r.drain_s, duplicates=r.duplicates, cpu_ms=r.cpu_ms_per_setpoint,
                cpu_fraction=r.cpu_fraction, keeps_up=r.keeps_up,
                keeps_up_p99_ms=r.keeps_up_p99_ms,
                late_p99=float(np.percentile(late, 99)), late_max=float(late.max()),
                discovery_s=r.discovery_s, load=r.load, load_start=r.load_start,
                memory=r.memory,
                main_cpu_ms=1e3 * r.main_thread_cpu_s / max(r.answered, 1),
                other_threads_ms=[(name, 1e3 * c / max(r.answered, 1))
                                  for name, c in r.other_threads_cpu],
                rejected=rejections(r.diagnostics))


def rejections(diags: list) -> dict[str, int]:
    """The node's non-zero rejection counters (totals since start) in its last
    /diagnostics message.
    """
    if not diags:
        return {}
    values = diags[-1][1]
    out = {}
    for key, value in values.items():
        if key.startswith('rejected ') and key != 'rejected total':
            try:
                n = int(value)
            except ValueError:
                continue
            if n:
                out[key[len('rejected '):]] = n
    return out


#: The targets of section 4, in the order of a round: the bare echo, the node fed
#: by the three topics (pose + twist + accel), the node fed by one
#: JointTrajectory per setpoint. Keys of ``done``: (key, rate).
NODE_TARGETS = (('echo', 'echo', 'topics'), ('node', 'node', 'topics'),
                ('node-trajectory', 'node', 'trajectory'))
TARGET_LABELS = {'echo': 'bare rclpy echo', 'node': 'node (three topics)',
                 'node-trajectory': 'node (one JointTrajectory per setpoint)'}


def _round_noise(runs: Sequence[dict]) -> tuple[float, float]:
    """How disturbed a round was: (largest steal %, largest end load) of its runs."""
    steal = [r['steal'] for r in runs if math.isfinite(r.get('steal', math.nan))]
    return (max(steal) if steal else 0.0, max(r['load'][0] for r in runs))


def section_node(args: argparse.Namespace, rows: list[Row], env: dict,
                 workdir: Path) -> dict:
    """Section 4: ``--node-rounds`` rounds of (echo, node with three topics, node
    with one JointTrajectory), each run ``--node-seconds`` at ``--rate``. The
    targets are judged on the calmest round: the one whose runs saw the least
    steal by the hypervisor (a criterion independent of the figures judged);
    every round is printed.
    """
    out: dict[str, Any] = {'runs': [], 'rounds': []}
    rate = args.rate

    def run(key: str, kind: str, setpoint_input: str, rate: float, seconds: float,
            round_no: int) -> dict:
        log(f'4. round {round_no}: {TARGET_LABELS[key]} at {rate:g} Hz for {seconds:g} s')
        r = node_stream.run_stream(kind, rate, seconds, env=env, executor=args.executor,
                                  sample_every=10.0, workdir=workdir,
                                  progress=log if seconds >= 30 else None,
                                  setpoint_input=setpoint_input)
        d = stream_dict(r)
        d.update(key=key, round=round_no)
        if kind == 'node':
            d['diag'] = diag_summary(r.diagnostics)
        out['runs'].append(d)
        log(f'   answered {r.answered}/{r.sent}, median {r.median:.2f} ms, p99 '
            f'{r.p99:.2f} ms, CPU {r.cpu_ms_per_setpoint:.2f} ms/setpoint, steal '
            f'{r.steal_pct:.1f} %')
        return d

    for i in range(max(1, args.node_rounds)):
        out['rounds'].append({key: run(key, kind, inp, rate, args.node_seconds, i + 1)
                              for key, kind, inp in NODE_TARGETS})
    chosen = min(range(len(out['rounds'])),
                 key=lambda i: _round_noise(list(out['rounds'][i].values())))
    out['chosen'] = chosen + 1
    done = {(key, rate): d for key, d in out['rounds'][chosen].items()}
    if args.context_rate and not done[('node', rate)]['keeps_up']:
        for key, kind, inp in NODE_TARGETS[:2]:
            done[(key, args.context_rate)] = run(key, kind, inp, args.context_rate,
                                                 args.context_seconds, 0)
    out['done'] = done
    n_rounds = len(out['rounds'])
    which = (f'round {chosen + 1} of {n_rounds}, the least steal' if n_rounds > 1 else
             'one round')
    for r_ in sorted({k[1] for k in done}, key=lambda x: x != rate):
        e = done[('echo', r_)]
        ctx = f' ({which})' if r_ == rate else ' (context)'
        rows.append(Row('4', f'bare rclpy echo, {r_:g} Hz, {e["seconds"]:g} s{ctx}: latency '
                        f'median / p99 / max', f'{e["median"]:.2f} / {e["p99"]:.2f} / '
                        f'{e["max"]:.1f} ms; lost {e["lost"]} of {e["sent"]}; steal '
                        f'{fmt(e["steal"], 1)} %', 'reference', '-', e['load'][0]))
        for key in ('node', 'node-trajectory'):
            n = done.get((key, r_))
            if n is None:
                continue
            what = f'{TARGET_LABELS[key]}, {r_:g} Hz{ctx}'
            rows.append(Row('4', f'{what}: latency median', f'{n["median"]:.2f} ms',
                            f'<= {TARGET_NODE_MEDIAN_MS:g} ms',
                            at_most(n['median'], TARGET_NODE_MEDIAN_MS, 'ms', '{:.2f}'),
                            n['load'][0]))
            rows.append(Row('4', f'{what}: latency p99', f'{n["p99"]:.2f} ms (max '
                            f'{n["max"]:.0f}; steal {fmt(n["steal"], 1)} %)',
                            f'<= {TARGET_NODE_P99_MS:g} ms',
                            at_most(n['p99'], TARGET_NODE_P99_MS, 'ms', '{:.2f}'),
                            n['load'][0]))
            rows.append(Row('4', f'{what}: setpoints lost', f'{n["lost"]} of {n["sent"]}', '0',
                            none_lost(n['lost'], n['sent']), n['load'][0]))
            rows.append(Row('4', f'{what} / echo: latency ratio (median; p99)',
                            f'{n["median"] / e["median"]:.2f}x; {n["p99"] / e["p99"]:.2f}x',
                            f'<= {TARGET_NODE_ECHO_RATIO:g}x',
                            at_most(n['median'] / e['median'], TARGET_NODE_ECHO_RATIO, 'x',
                                    '{:.2f}'), n['load'][0]))
            rows.append(Row('4', f'{what}: CPU per setpoint vs the echo (whole process)',
                            f'{n["cpu_ms"]:.2f} vs {e["cpu_ms"]:.2f} ms '
                            f'({n["cpu_ms"] / e["cpu_ms"]:.1f}x)',
                            f'< {1e3 / r_:.1f} ms (one core at {r_:g} Hz)',
                            at_most(n['cpu_ms'], 1e3 / r_, 'ms', '{:.2f}'), n['load'][0]))
    if n_rounds > 1:
        rows.append(Row('4', f'every round at {rate:g} Hz: p99 ms echo / node / node '
                        f'(trajectory), steal %',
                        '; '.join(f'{i + 1}: ' + ' / '.join(
                            fmt(rnd[k]['p99']) for k, _, _ in NODE_TARGETS)
                            + f', {fmt(_round_noise(list(rnd.values()))[0], 1)} %'
                            for i, rnd in enumerate(out['rounds'])),
                        'context', '-', load1()))
    return out


def section_executors(args: argparse.Namespace, rows: list[Row], env: dict, workdir: Path,
                      node_out: dict) -> dict:
    """The other executor, for the record of the choice: the echo at --rate and
    the node at --context-rate, compared with the runs of section 4.
    """
    other = 'single' if args.executor == 'events' else 'events'
    done = node_out['done']
    out: dict[str, Any] = {'other': other, 'runs': [], 'pairs': []}
    for kind, rate in (('echo', args.rate), ('node', args.context_rate or args.rate)):
        mine = done.get((kind, rate))
        if mine is None:
            continue
        log(f'4b. {kind} at {rate:g} Hz with the {other} executor for '
            f'{args.compare_seconds:g} s')
        r = stream_dict(node_stream.run_stream(kind, rate, args.compare_seconds, env=env,
                                              executor=other, workdir=workdir))
        out['runs'].append(r)
        out['pairs'].append((mine, r))
        less_cpu = mine['cpu_ms'] < r['cpu_ms']
        better = (less_cpu and mine['median'] <= r['median'] and mine['p99'] <= r['p99']
                  and mine['lost'] <= r['lost'])
        rows.append(Row(
            '4', f'executor choice, {kind} at {rate:g} Hz: {args.executor} vs {other} (median '
            f'/ p99 ms, lost, CPU ms per message)',
            f'{fmt(mine["median"])} / {fmt(mine["p99"])}, {mine["lost"]}, '
            f'{fmt(mine["cpu_ms"])} vs {fmt(r["median"])} / {fmt(r["p99"])}, {r["lost"]}, '
            f'{fmt(r["cpu_ms"])}', 'choose on measurements',
            (f'{args.executor} kept: {r["cpu_ms"] / mine["cpu_ms"]:.1f}x less CPU per message'
             if less_cpu else f'{args.executor} kept, but it used MORE CPU here')
            + ('' if better else
               f'; latency/loss better with {other} in this run (the runs were minutes apart, '
               f'load {mine["load"][0]:.2f} vs {r["load"][0]:.2f})'),
            r['load'][0]))
    return out


def _num(values: dict, key: str) -> float:
    try:
        return float(values.get(key, 'nan'))
    except ValueError:
        return math.nan


def diag_summary(diags: list) -> list[dict]:
    """Per /diagnostics period: time, answered, rate, solve mean / median / p99 /
    max (us).
    """
    return [dict(t=t, answered=_num(v, 'setpoints answered'), rate=_num(v, 'rate (Hz)'),
                 mean=_num(v, 'solve time mean (us)'), median=_num(v, 'solve time median (us)'),
                 p99=_num(v, 'solve time p99 (us)'),
                 max=_num(v, 'solve time max (us)'), n=_num(v, 'solves this period'),
                 rejected=_num(v, 'rejected total'))
            for t, v in diags]


# ----------------------------------------------------------------------------
# 5. Soak
# ----------------------------------------------------------------------------
def section_soak(args: argparse.Namespace, rows: list[Row], env: dict, workdir: Path,
                 node_out: dict | None) -> dict:
    rate = args.soak_rate
    why = 'as asked (--soak-rate)'
    if rate is None:
        done = (node_out or {}).get('done', {})
        main = done.get(('node', args.rate))
        ctx = done.get(('node', args.context_rate))
        if main is None or main['keeps_up']:
            rate, why = args.rate, 'the target rate'
        elif ctx is not None:
            rate = args.context_rate
            why = (f'the node does not keep up at {args.rate:g} Hz (section 4); '
                   f'{args.context_rate:g} Hz is the context rate, where it '
                   + ('keeps up' if ctx['keeps_up'] else 'does not keep up either'))
        else:
            rate, why = args.rate, 'the target rate'
    seconds = args.soak_minutes * 60.0
    log(f'5. soak: node at {rate:g} Hz for {seconds / 60:g} min ({why})')
    r = node_stream.run_stream('node', rate, seconds, env=env, executor=args.executor,
                              sample_every=args.soak_sample, workdir=workdir, progress=log)
    d = stream_dict(r)
    d['why'] = why
    d['diag'] = diag_summary(r.diagnostics)
    mem = np.array([m[:2] for m in r.memory], dtype=float)
    t_mem, rss_mb = mem[:, 0], mem[:, 1] / 1024.0
    base_i = int(np.searchsorted(t_mem, min(SOAK_BASELINE_S, t_mem[-1]) - 1e-9))
    growth = float(rss_mb[-1] - rss_mb[base_i])
    growth0 = float(rss_mb[-1] - rss_mb[0])
    half = t_mem >= t_mem[-1] / 2
    slope = (float(np.polyfit(t_mem[half] / 60.0, rss_mb[half], 1)[0])
             if half.sum() >= 3 else math.nan)
    d.update(rss_start=float(rss_mb[0]), rss_base=float(rss_mb[base_i]),
             rss_base_t=float(t_mem[base_i]), rss_end=float(rss_mb[-1]),
             rss_max=float(rss_mb.max()), growth=growth, growth0=growth0,
             slope_mb_per_min=slope)
    # timing trend of the diagnostics: periods with solves, per minute
    per = [p for p in d['diag'] if p['n'] and p['n'] > 0 and math.isfinite(p['mean'])]
    trend: dict[str, Any] = {}
    if per:
        t0 = r.send_times[0]
        tt = np.array([p['t'] - t0 for p in per])
        mean = np.array([p['mean'] for p in per])
        median = np.array([p['median'] for p in per])
        p99 = np.array([p['p99'] for p in per])
        keep = (tt >= 0) & (tt <= seconds + 5)
        tt, mean, median, p99 = tt[keep], mean[keep], median[keep], p99[keep]
        minutes = []
        # t, rss, cpu, load, machine steal ticks, machine total ticks
        samples = np.array([m[:6] for m in r.memory], dtype=float)
        for mi in range(int(math.ceil(seconds / 60.0))):
            sel = (tt >= 60 * mi) & (tt < 60 * (mi + 1))
            if sel.any():
                # node CPU per setpoint over the minute (process CPU / setpoints sent)
                a = np.searchsorted(samples[:, 0], 60.0 * mi - 1e-6)
                b = np.searchsorted(samples[:, 0], 60.0 * (mi + 1) + 1e-6) - 1
                cpu_ms = load = steal = math.nan
                if b > a:
                    dt = samples[b, 0] - samples[a, 0]
                    cpu_ms = 1e3 * (samples[b, 2] - samples[a, 2]) / (dt * rate)
                    load = float(np.mean(samples[a:b + 1, 3]))
                    steal = node_stream.steal_percent(tuple(samples[a, 4:6]),
                                                     tuple(samples[b, 4:6]))
                minutes.append(dict(minute=mi + 1, periods=int(sel.sum()),
                                    mean=float(np.median(mean[sel])),
                                    median=float(np.median(median[sel])), steal=steal,
                                    p99=float(np.median(p99[sel])),
                                    p99_max=float(p99[sel].max()), cpu_ms=cpu_ms, load=load))
        slope_mean = (float(np.polyfit(tt / 60.0, mean, 1)[0]) if tt.size >= 3 else math.nan)
        slope_median = (float(np.polyfit(tt / 60.0, median, 1)[0])
                        if tt.size >= 3 and np.isfinite(median).all() else math.nan)
        slope_p99 = (float(np.polyfit(tt / 60.0, p99, 1)[0]) if tt.size >= 3 else math.nan)
        trend = dict(minutes=minutes, slope_mean=slope_mean, slope_median=slope_median,
                     slope_p99=slope_p99, overall_mean=float(np.median(mean)),
                     overall_median=float(np.median(median)),
                     overall_p99=float(np.median(p99)),
                     load_r=_minute_r(minutes, 'mean', 'load'),
                     steal_r=_minute_r(minutes, 'mean', 'steal'))
    d['trend'] = trend
    load = r.load[0]
    label = f'soak {seconds / 60:g} min at {rate:g} Hz'
    rows.append(Row('5', f'{label}: RSS growth (from {d["rss_base_t"]:.0f} s to the end)',
                    f'{growth:+.2f} MB ({d["rss_base"]:.1f} -> {d["rss_end"]:.1f} MB; '
                    f'from t = 0: {growth0:+.2f} MB)', f'< {TARGET_RSS_GROWTH_MB:g} MB',
                    'met' if growth < TARGET_RSS_GROWTH_MB else
                    f'MISSED: {growth:.2f} MB ({growth / TARGET_RSS_GROWTH_MB:.1f}x the limit)',
                    load))
    rows.append(Row('5', f'{label}: setpoints lost', f'{r.lost} of {r.sent}', '0',
                    none_lost(r.lost, r.sent), load))
    if trend and len(trend['minutes']) < 2:
        rows.append(Row('5', f'{label}: diagnostics solve time trend', 'soak under 2 min',
                        'flat', 'not judged', load))
    elif trend:
        mins = trend['minutes']
        flat = _flat(trend)
        key = _timing_key(trend)
        settled = [m[key] for m in _settled(trend)]
        c0, c1 = mins[0]['cpu_ms'], mins[-1]['cpu_ms']
        l0, l1 = mins[0]['load'], mins[-1]['load']
        steals = [m['steal'] for m in mins if math.isfinite(m.get('steal', math.nan))]
        context = (f'; node CPU per setpoint {fmt(c0)} -> {fmt(c1)} ms, load avg {fmt(l0)} -> '
                   f'{fmt(l1)}' + (f', steal per minute {min(steals):.1f}-{max(steals):.1f} %'
                                   if steals else ''))
        rows.append(Row('5', f'{label}: diagnostics solve time median / mean / p99, first -> '
                        f'last minute',
                        f'{mins[0]["median"]:.0f} / {mins[0]["mean"]:.0f} / '
                        f'{mins[0]["p99"]:.0f} -> {mins[-1]["median"]:.0f} / '
                        f'{mins[-1]["mean"]:.0f} / {mins[-1]["p99"]:.0f} us (slope '
                        f'{trend["slope_median"]:+.1f} / {trend["slope_mean"]:+.1f} / '
                        f'{trend["slope_p99"]:+.1f} us/min){context}', 'flat',
                        f'met: no growth after the first (warm-up) minute: per-minute '
                        f'{key}s {min(settled):.0f}-{max(settled):.0f} us (first minute '
                        f'{mins[0][key]:.0f} us)' if flat else
                        f'MISSED as measured: per-minute {key}s '
                        f'{min(m[key] for m in mins):.0f}-{max(m[key] for m in mins):.0f} us, '
                        f'trend {100 * _rise(settled) / float(np.median(settled)):+.0f} % over '
                        f'the soak; correlation of the mean with the steal r = '
                        f'{fmt(trend["steal_r"])}, with the load average r = '
                        f'{fmt(trend["load_r"])}; see section 5', load))
    if rate != args.rate:
        rows.append(Row('5', f'soak at {args.rate:g} Hz', 'not run', f'{args.rate:g} Hz',
                        f'MISSED: not sustainable (section 4); soaked at {rate:g} Hz instead',
                        load))
    return d



def _settled(trend: dict) -> list[dict]:
    """The minutes of the soak after the first (warm-up: caches, allocator,
    discovery; like the RSS baseline at 10 s), when there are at least three.
    """
    mins = trend['minutes']
    return mins[1:] if len(mins) >= 3 else mins


def _timing_key(trend: dict) -> str:
    """The per-minute figure the flatness is judged on: the median solve time
    (a preemption of the node inside a solve, a few ms once in a thousand
    cycles, moves the mean and p99 of a period but not its median); the mean
    for diagnostics without a median.
    """
    mins = trend['minutes']
    return 'median' if mins and all(math.isfinite(m.get('median', math.nan))
                                    for m in mins) else 'mean'


def _rise(values: Sequence[float]) -> float:
    """Rise over the whole series of a linear fit (0 for fewer than 2 values)."""
    if len(values) < 2:
        return 0.0
    return float(np.polyfit(np.arange(len(values)), values, 1)[0]) * len(values)


def _minute_r(minutes: Sequence[dict], a: str, b: str) -> float:
    """Correlation of two per-minute figures (nan with < 3 minutes or no spread)."""
    pairs = np.array([(m[a], m[b]) for m in minutes
                      if math.isfinite(m.get(a, math.nan)) and math.isfinite(m.get(b, math.nan))],
                     dtype=float).reshape(-1, 2)
    if len(pairs) < 3 or pairs[:, 0].std() == 0 or pairs[:, 1].std() == 0:
        return math.nan
    return float(np.corrcoef(pairs[:, 0], pairs[:, 1])[0, 1])


def _flat(trend: dict) -> bool:
    """Flat = the timing does not grow: after the warm-up minute, the per-minute
    solve time (:func:`_timing_key`) rises by less than 10 % of its median over
    the soak (linear fit) and no minute's is over 1.25x another's. A fall is no
    growth (it follows the machine's load).
    """
    key = _timing_key(trend)
    values = [m[key] for m in _settled(trend)]
    if len(values) < 2:
        return True
    return (_rise(values) < 0.10 * float(np.median(values))
            and max(values) <= 1.25 * min(values))


