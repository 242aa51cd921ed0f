"""The ROS sections of the performance benchmark (node latency, executor choice,
soak) and their report, driven by synthetic streams instead of real processes.

``python -m benchmarks.performance`` only runs them in a full run (minutes of
streaming), so these tests replace ``node_stream.run_stream`` by a fake that
returns what a stream measures, and check that every section computes its
verdicts from those figures and that the report renders. No timing of this
machine is measured or asserted.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from benchmarks import node_stream as bench_node
from benchmarks import performance

ROOT = Path(__file__).resolve().parents[2]

#: latency medians / p99 (ms) and steal (%) of each synthetic stream, by round
#: and target; round 2 is the calm one.
PLAN = {
    1: {('echo', 'topics'): (0.40, 3.0, 9.0), ('node', 'topics'): (0.42, 4.0, 9.0),
        ('node', 'trajectory'): (0.41, 3.5, 9.0)},
    2: {('echo', 'topics'): (0.38, 0.8, 0.5), ('node', 'topics'): (0.40, 1.2, 0.4),
        ('node', 'trajectory'): (0.39, 0.9, 0.6)},
}


def fake_stream(kind: str, rate: float, seconds: float, *, round_no: int, median: float,
                p99: float, steal: float, sample_every: float | None = None,
                solve_us: float = 25.0, drift_us_per_min: float = 0.0,
                setpoint_input: str = 'topics', executor: str = 'events',
                **_: object) -> bench_node.StreamResult:
    """A StreamResult as a real stream of ``seconds`` at ``rate`` would give:
    latencies with the given median and (roughly) p99, per-second
    /diagnostics with a solve time drifting by ``drift_us_per_min``, and
    memory samples every ``sample_every`` s."""
    n = int(rate * seconds)
    rng = np.random.default_rng(round_no)
    lat = np.full(n, median)
    tail = rng.choice(n, size=max(1, n // 50), replace=False)     # 2 % tail
    lat[tail] = p99
    lat += rng.uniform(0.0, 0.01, n)
    send = 1000.0 + np.arange(n) / rate
    recv = send + lat / 1e3
    diags = []
    for sec in range(int(seconds) + 1):
        t_us = solve_us + drift_us_per_min * sec / 60.0
        diags.append((1000.0 + sec, {
            'setpoints answered': str(int(min(sec, seconds) * rate)), 'rate (Hz)': f'{rate:.1f}',
            'solve time mean (us)': f'{t_us * 1.2:.1f}', 'solve time median (us)': f'{t_us:.1f}',
            'solve time p99 (us)': f'{t_us * 2:.1f}', 'solve time max (us)': f'{t_us * 10:.1f}',
            'solves this period': str(int(rate)), 'rejected total': '0',
            'rejected stamp_repeated': '0'}))
    memory = []
    if sample_every:
        total = 0
        for i, t in enumerate(np.arange(0.0, seconds + 1e-9, sample_every)):
            total += int(200 * sample_every)
            memory.append((float(t), 80_000 + i, 0.3 * t, 0.5, int(total * steal / 100), total))
    return bench_node.StreamResult(
        kind=kind, executor=executor, setpoint_input=setpoint_input, rate=rate, depth=1000,
        seconds=seconds, sent=n, answered=n, lost=0, latency_ms=lat, send_times=send,
        recv_times=recv, publisher_late_ms=np.zeros(n), target_cpu_s=0.3 * n / 1e3,
        stream_wall_s=seconds, drain_s=0.001, duplicates=0, discovery_s=1.0,
        diagnostics=diags if kind == 'node' else [], memory=memory,
        main_thread_cpu_s=0.2 * n / 1e3, other_threads_cpu=[('dds', 0.05 * n / 1e3)],
        load=(0.5, 0.5, 0.5), load_start=(0.4, 0.4, 0.4), steal_pct=steal)


@pytest.fixture
def fake_run_stream(monkeypatch):
    calls: list[tuple] = []
    rounds = {'n': 0}

    def run_stream(kind, rate, seconds, **kw):
        inp = kw.get('setpoint_input', 'topics')
        calls.append((kind, inp, rate, seconds, kw.get('executor')))
        if kind == 'echo' and inp == 'topics' and rate == 1000.0 and seconds == 60.0:
            rounds['n'] += 1
        plan = PLAN.get(rounds['n'], PLAN[2]).get((kind, inp), (0.4, 1.0, 0.5))
        return fake_stream(kind, rate, seconds, round_no=max(rounds['n'], 1),
                           median=plan[0], p99=plan[1], steal=plan[2], **kw)

    monkeypatch.setattr(bench_node, 'run_stream', run_stream)
    return calls


def args_for(*extra: str):
    return performance.parse_args(['--node-rounds', '2', '--node-seconds', '60',
                                   '--context-rate', '200', '--compare-seconds', '5',
                                   '--soak-minutes', '4', '--soak-sample', '10', *extra])


def test_node_section_judges_the_calmest_round(fake_run_stream, tmp_path):
    args = args_for()
    rows: list = []
    out = performance.section_node(args, rows, {}, tmp_path)
    # 2 rounds of echo, node (topics), node (trajectory), in that order
    assert [(c[0], c[1]) for c in fake_run_stream] == [
        ('echo', 'topics'), ('node', 'topics'), ('node', 'trajectory')] * 2
    assert out['chosen'] == 2                   # the least steal, whatever the latencies
    node = out['done'][('node', 1000.0)]
    assert node['round'] == 2 and node['steal'] == pytest.approx(0.4)
    p99_rows = [r for r in rows if r.figure.endswith('latency p99')]
    assert len(p99_rows) == 2                   # three topics and JointTrajectory
    for row in p99_rows:
        assert 'round 2 of 2' in row.figure and row.verdict.startswith('met')
    every = [r for r in rows if r.figure.startswith('every round')]
    assert every and '1: 3.0' in every[0].measured
    # the node keeps up: no context-rate streams
    assert all(c[2] == 1000.0 for c in fake_run_stream)


def test_node_section_reports_a_miss_with_its_gap(fake_run_stream, tmp_path, monkeypatch):
    monkeypatch.setitem(PLAN, 2, {**PLAN[2], ('node', 'topics'): (0.45, 2.4, 0.4)})
    rows: list = []
    performance.section_node(args_for(), rows, {}, tmp_path)
    row = next(r for r in rows if r.figure.startswith('node (three topics)')
               and r.figure.endswith('latency p99'))
    assert row.verdict.startswith('MISSED: 1.6x over')


def test_soak_flatness_is_judged_on_the_median(fake_run_stream, tmp_path):
    args = args_for()
    rows: list = []
    node_out = performance.section_node(args, rows, {}, tmp_path)
    rows.clear()
    soak = performance.section_soak(args, rows, {}, tmp_path, node_out)
    trend = soak['trend']
    assert performance._timing_key(trend) == 'median'
    assert [m['minute'] for m in trend['minutes']] == [1, 2, 3, 4]
    assert all(m['steal'] == pytest.approx(0.4, abs=0.05) for m in trend['minutes'])
    row = next(r for r in rows if 'diagnostics solve time' in r.figure)
    assert row.verdict.startswith('met: no growth'), row.verdict
    assert 'steal per minute' in row.measured


def test_soak_growth_is_a_miss(fake_run_stream, tmp_path, monkeypatch):
    real = bench_node.run_stream
    monkeypatch.setattr(bench_node, 'run_stream',
                        lambda *a, **kw: real(*a, drift_us_per_min=5.0, **kw))
    args = args_for()
    rows: list = []
    soak = performance.section_soak(args, rows, {}, tmp_path, None)
    assert not performance._flat(soak['trend'])
    row = next(r for r in rows if 'diagnostics solve time' in r.figure)
    assert row.verdict.startswith('MISSED as measured: per-minute medians')


def test_flatness_rules():
    def trend(values, key='median'):
        return {'minutes': [{'minute': i + 1, key: v, 'mean': v} for i, v in enumerate(values)]}
    assert performance._flat(trend([40, 25, 25.5, 24.8, 25.2]))      # warm-up minute ignored
    assert not performance._flat(trend([25, 25, 27, 29, 31]))        # steady growth
    assert not performance._flat(trend([25, 25, 25, 35, 25]))        # one minute 1.4x
    assert performance._flat(trend([30, 30, 28, 26, 25]))            # a fall is no growth
    assert performance._timing_key(trend([1, 2], key='mean')) == 'mean'
    assert math.isnan(performance._minute_r([{'a': 1, 'b': 2}] * 2, 'a', 'b'))


def test_report_renders_every_section(fake_run_stream, tmp_path):
    args = args_for('--node-profiler', 'none')
    rows: list = []
    res: dict = {'args': vars(args), 'notes': [], 'tree': ('clean abc', 'clean abc'),
                 'depth': 1000}
    res['node'] = performance.section_node(args, rows, {}, tmp_path)
    res['executors'] = performance.section_executors(args, rows, {}, tmp_path, res['node'])
    res['soak'] = performance.section_soak(args, rows, {}, tmp_path, res['node'])
    md = performance.markdown(res, rows, ['--node-rounds', '2'], 0.0, 60.0)
    for needed in ('## 4. Node latency', 'round 2', 'steal %',
                   'node (one JointTrajectory per setpoint)', '### The executor',
                   '## 5. Soak', 'solve median (us)', 'Flatness is judged on the per-minute '
                   'median'):
        assert needed in md, needed
    # the executor comparison ran the other executor
    assert any(c[4] == 'single' for c in fake_run_stream)


def test_cprofile_key_names():
    assert performance._short(('~', 0, '<built-in method time>')) == '<built-in method time>'
    here = str(ROOT / 'flight_sim_dynamics' / 'node.py')
    assert performance._short((here, 12, '_process')) == 'flight_sim_dynamics/node.py:12(_process)'
    site = '/x/lib/python3.11/site-packages/rclpy/executors.py'
    assert performance._short((site, 3, 'spin')) == 'rclpy/executors.py:3(spin)'
